"""Accuracy bounds: the nets against the exact synthetic Francis turbine (truth.csv), and the shipped nets.json.

"Measured region" = convex hull, in (N11, a), of the digitized opening-line points; percentages are of the truth's
Q11 (or M11) range inside that region (the stricter reading: the whole-domain range is about twice as large).
"""

from pathlib import Path

import numpy as np
import pytest

from hillchart.extension.extend import extend_samples
from hillchart.nets.accuracy import read_truth_csv, truth_errors
from hillchart.nets.hill_nets import load_nets
from hillchart.nets.training import train_nets
from hillchart.io.samples import measured_region_mask
from hillchart.io.samples import load_chart
from hillchart.synthetic.francis import SyntheticFrancis

CHART = Path(__file__).resolve().parents[3] / "data_synthetic" / "francis"


@pytest.fixture(scope="module")
def chart():
    return load_chart(CHART)


@pytest.fixture(scope="module")
def extended(chart):
    return extend_samples(chart)


@pytest.fixture(scope="module")
def truth_and_mask(chart):
    truth = read_truth_csv(CHART / "truth.csv")
    inside = measured_region_mask(chart.flow_n11, chart.flow_opening, truth["n11"], truth["opening"])
    return truth, inside


def assert_issue_bounds(nets, truth, inside):
    errs = truth_errors(nets, truth, inside)
    # the accuracy bounds the product promises: Q11 RMS <= 0.5 %, max <= 2 %, M11 RMS <= 1 % of the range
    assert errs["q11"]["rms_measured_pct"] <= 0.5, errs["q11"]
    assert errs["q11"]["max_measured_pct"] <= 2.0, errs["q11"]
    assert errs["m11"]["rms_measured_pct"] <= 1.0, errs["m11"]
    return errs


def test_measured_region_covers_the_digitized_lines(truth_and_mask):
    truth, inside = truth_and_mask
    # the chart spans openings 10-32 mm and N11 about 44-88 r/min: a few hundred of the 1947 truth points
    assert 200 < inside.sum() < 600
    assert truth["opening"][inside].min() >= 10.0 and truth["n11"][inside].max() <= 90.0


def test_shipped_nets_meet_the_accuracy_bounds(truth_and_mask):
    truth, inside = truth_and_mask
    errs = assert_issue_bounds(load_nets(CHART / "nets.json"), truth, inside)
    # measured 2026-11 (see docs/nets.md, "Accuracy on the synthetic chart"): Q11 0.23 % RMS, 0.40 % max;
    # M11 0.19 % RMS. A regression that doubles them would still pass the promised bounds, so also pin them loosely
    # (x2) to catch a degraded retrain.
    assert errs["q11"]["rms_measured_pct"] < 0.46 and errs["m11"]["rms_measured_pct"] < 0.40


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_accuracy_bounds_hold_for_other_seeds(extended, truth_and_mask, seed):
    truth, inside = truth_and_mask
    assert_issue_bounds(train_nets(extended, seed=seed), truth, inside)


def _largest_difference_over_range(a, b) -> float:
    """Largest |a - b| of Q11 and M11, point nets and every ensemble member, over the whole extended domain
    (N11 0-140 r/min, openings 0-34 mm), as a fraction of each quantity's range there."""
    n11, opening = np.meshgrid(np.linspace(0.0, 140.0, 71), np.linspace(0.0, 34.0, 35))
    worst = 0.0
    for ma, mb in zip([a, *a.members()], [b, *b.members()], strict=True):
        for name in ("q11", "m11"):
            ya, yb = getattr(ma, name)(n11, opening), getattr(mb, name)(n11, opening)
            worst = max(worst, float(np.max(np.abs(ya - yb)) / np.ptp(ya)))
    return worst


@pytest.mark.slow
def test_shipped_nets_regenerate_on_any_cpu(tmp_path, capsys):
    """``hillsim train data_synthetic/francis --out nets.json`` reproduces the shipped file to a stated tolerance.

    Training is deterministic, but not bit-identical across CPUs: the compiled Levenberg-Marquardt loop and LAPACK's
    Cholesky sum in an order that depends on the CPU's vector unit (AVX2, AVX-512, NEON), and the optimisation
    amplifies those last-bit differences. Measured on two CPU families against an earlier file written on an AMD
    EPYC: 3e-5 of the range on another AMD EPYC, 3.7e-3 on an Intel CPU (AVX-512); the file shipped now is written
    on an Intel Xeon, so the AMD family sees the larger figure. The bound, 1e-2 of each quantity's range over the
    whole extended domain, is 2.7x that figure and 5x below what a change of seed moves (5e-2; the failing case
    below), so a changed selection, seed or extension still fails it.
    """
    from hillsim.cli import main

    out = tmp_path / "nets.json"
    assert main(["train", str(CHART), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "flow" in text and "torque" in text and "CV MSE" in text
    shipped, regenerated = load_nets(CHART / "nets.json"), load_nets(out)
    assert regenerated.flow.hidden == shipped.flow.hidden and regenerated.torque.hidden == shipped.torque.hidden
    assert len(regenerated.members()) == len(shipped.members())
    assert _largest_difference_over_range(shipped, regenerated) < 1e-2
    # the failing case: another seed is another set of nets, outside the bound (measured 5e-2)
    other = tmp_path / "other.json"
    assert main(["train", str(CHART), "--out", str(other), "--seed", "1", "--quiet"]) == 0
    assert _largest_difference_over_range(shipped, load_nets(other)) > 2e-2

    # on one machine, training is bit-identical: the same command writes the same bytes
    again = tmp_path / "again.json"
    assert main(["train", str(CHART), "--out", str(again), "--quiet"]) == 0
    assert again.read_bytes() == out.read_bytes()


def test_runaway_curve_of_the_nets_matches_the_turbine():
    """Where M11 = 0 on each measured opening: the nets' runaway N11 against the exact model's."""
    from scipy.optimize import brentq

    nets = load_nets(CHART / "nets.json")
    turbine = SyntheticFrancis()
    for a in (12.0, 20.0, 28.0):
        exact = turbine.runaway_n11(a)
        ours = brentq(lambda n: float(nets.m11(n, a)), 60.0, 140.0)
        # runaway samples are digitized (noise ~ 1 r/min) and the net smooths them: 2 % of N11 is the
        # size of a line width on a printed chart
        assert abs(ours - exact) < 0.02 * exact, (a, ours, exact)


def test_best_efficiency_point_matches_the_turbine():
    from hillchart.nets.chartplot import efficiency_from_characteristics

    nets = load_nets(CHART / "nets.json")
    turbine = SyntheticFrancis()
    n11, a = np.meshgrid(np.linspace(50, 80, 61), np.linspace(12, 28, 33))
    eta_nets = efficiency_from_characteristics(nets, n11, a)
    eta_true = turbine.efficiency(n11, a)
    # efficiency = M11 omega / (rho g Q11) combines both nets' errors (~0.2 % each): 0.5 efficiency points
    assert abs(np.nanmax(eta_nets) - np.max(eta_true)) < 0.005
    assert np.max(np.abs(eta_nets - eta_true)) < 0.01
