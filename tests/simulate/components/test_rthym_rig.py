"""The rig in RTHYM-MOC beside hillsim (``benchmarks/bench_rthym_rig.py``; the RTHYM-MOC rows skip without ``pip
install rthym-moc``)."""

import math

import pytest

from tests.scripts import load_script


@pytest.fixture(scope="module")
def bench():
    return load_script("bench_rthym_rig")


def test_without_rthym_the_table_has_hillsims_rows(bench, monkeypatch):
    """The measured row first, then hillsim's defaults (the convolution friction, the DGCM) at dt and dt / 2; the
    first collapse's top at dt / 2 is the figure of ``test_column_separation.py`` (2060 kPa, within 0.5 %)."""
    monkeypatch.setattr(bench, "rthym_available", lambda: False)
    rows = bench.rows()
    assert [r["run"] for r in rows] == ["measured"] + ["hillsim, DGCM, convolution friction"] * 2
    assert rows[2]["peaks"]["first collapse"][0] == pytest.approx(2060.0, rel=5e-3)


def test_rthym_on_its_own_set_up_of_the_rig(bench):
    """RTHYM-MOC 0.4.1 with its verification helper's set-up (its defaults: unsteady friction on): the water
    hammer's plateau at 2930-2960 kPa, 39-41 % above the measured 2102 kPa (its friction term lifts it; hillsim's
    steady and convolution runs 1.8 and 3.5 %), at every step of 2e-4, 1e-4 and 5e-5 s; asserted above 30 %. The
    same helper's own output was reproduced to 1e-4 kPa when this was written (the initial 1140.77 kPa). Another
    version of RTHYM-MOC is only run (three rows of finite figures): its numbers are its own."""
    rthym = pytest.importorskip("rthym_moc")
    rows = [r for r in bench.rows() if r["run"].startswith("RTHYM-MOC")]
    assert len(rows) == 3
    measured = bench.rig().window_peaks(*bench.rig().measured_trace())["water hammer"][0]
    for row in rows:
        assert all(math.isfinite(v[0]) for v in row["peaks"].values())
        if rthym.__version__ == "0.4.1":
            assert row["peaks"]["water hammer"][0] / measured - 1.0 > 0.30
