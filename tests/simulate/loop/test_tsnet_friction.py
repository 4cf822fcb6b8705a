"""Brunone's friction on the reservoir-pipe-valve case at dt and dt / 2, and TSNet's on the same case (optional:
the TSNet test skips without ``pip install tsnet``); the comparison is ``benchmarks/bench_tsnet_friction.py``."""

from pathlib import Path

import pytest
from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def bench():
    return load_script("bench_tsnet_friction")


def _rows(rows, tool, friction):
    return [r for r in rows if r["tool"] == tool and r["friction"] == friction]


def test_brunones_decay_does_not_move_with_the_step(bench):
    """hillsim alone: the decrement per period 4 L / a is 0.02245 at dt = 0.05 s and 0.02250 at 0.025 s with
    Brunone (0.2 % apart, asserted within 1 %), 1.31 times the steady loss's 0.0171; the first peak is the steady
    model's (the bracket of (B4) vanishes on the closure front) within 0.01 m. The failing case: TSNet's form moves
    by 33 % between the same steps (the test below)."""
    rows = bench.compare(with_tsnet=False)
    coarse, fine = _rows(rows, "hillsim", "brunone")
    steady_coarse, steady_fine = _rows(rows, "hillsim", "steady")
    assert (coarse["dt_s"], fine["dt_s"]) == pytest.approx(bench.STEPS_S, rel=1e-12)
    assert coarse["decrement"] == pytest.approx(0.02245, rel=0.01)
    assert fine["decrement"] == pytest.approx(coarse["decrement"], rel=0.01)
    assert coarse["decrement"] / steady_coarse["decrement"] == pytest.approx(1.31, abs=0.03)
    for unsteady, steady in ((coarse, steady_coarse), (fine, steady_fine)):
        assert unsteady["peaks_m"][0] == pytest.approx(steady["peaks_m"][0], abs=0.01)


def test_tsnets_unsteady_friction_moves_with_the_step(bench):
    """TSNet 0.3.1 on the same grid: its steady decrement is ours within 3 % (0.0175 against 0.0171-0.0172, and
    either step), its unsteady one 0.0358 at dt = 0.05 s and 0.0476 at 0.025 s (its unsteady term is 1/(g dt) times
    Brunone's: 33 % more decay at half the step, asserted above 25 %), and its first peak 1.4 m above its steady one
    (ours: the same peak); hillsim's Brunone rows do not move (the test above)."""
    pytest.importorskip("tsnet")
    rows = bench.compare(with_tsnet=True)
    ts_steady = _rows(rows, "TSNet", "steady")
    ts_coarse, ts_fine = _rows(rows, "TSNet", "unsteady")
    ours_steady = _rows(rows, "hillsim", "steady")
    assert ts_coarse["darcy_friction"] == pytest.approx(bench.TSNET_DARCY_FRICTION, abs=5e-4)
    for theirs, ours in zip(ts_steady, ours_steady):
        assert theirs["decrement"] == pytest.approx(ours["decrement"], rel=0.03)
    assert ts_coarse["decrement"] == pytest.approx(0.0358, abs=0.001)
    assert ts_fine["decrement"] / ts_coarse["decrement"] > 1.25
    assert ts_coarse["peaks_m"][0] - ts_steady[0]["peaks_m"][0] > 1.0
