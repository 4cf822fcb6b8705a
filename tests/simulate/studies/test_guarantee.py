"""Guarantee figures of a load rejection with trained nets against the exact turbine (synthetic family), and the
physical model's samples where the chart is silent. The whole grid: benchmarks/bench_guarantee.py."""

import warnings
from pathlib import Path

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR
from hillchart.extension.extend import ExtensionOptions, extend_samples
from hillchart.extension.silent_samples import (BETWEEN_LINE_SPEEDS, OVERSPEED_POINTS, between_line_points,
                                                silent_region_points)
from hillchart.io.samples import load_chart
from hillchart.nets.silent_model import BLEND_START_FRACTION
from simulate.studies.guarantee import ACCEPTANCE, evaluate_chart, family_plant_dict
from tests.scripts import load_script


@pytest.fixture(scope="module")
def shipped_chart():
    return load_chart(FRANCIS_DIR)


def test_silent_region_samples_lie_where_the_chart_is_silent(shipped_chart):
    ext = extend_samples(shipped_chart)
    model = ext.boundary_model
    rows = ext.origin == "silent-region"
    a_low = float(shipped_chart.openings.min())
    small = rows & (ext.opening < a_low)
    assert small.sum() == 2 * 1 * 12  # q11 and m11 at 1 opening x 12 speeds
    # only where a run reads the nets: at or above the blend's start, below it the table answers alone
    assert ext.opening[small].max() < a_low and ext.opening[small].min() >= BLEND_START_FRACTION * a_low
    lines = np.unique(shipped_chart.flow_opening)
    between = rows & ~np.isin(ext.opening, lines) & (ext.opening >= a_low)
    over = rows & np.isin(ext.opening, lines)
    for a in np.unique(ext.opening[over]):
        line_end = shipped_chart.flow_n11[shipped_chart.flow_opening == a].max()
        n = ext.n11[over & (ext.opening == a)]
        assert n.min() > line_end and n.max() < model.runaway_n11(float(a))  # strictly inside the gap
    # values: below the lowest line the weighed hypotheses' (the chart's held-out lines weigh them), in overspeed
    # the fitted model's; they weigh like measured samples (not soft boundary samples)
    q_small, q_over = small & (ext.target == "q11"), over & (ext.target == "q11")
    np.testing.assert_allclose(ext.value[q_small],
                               ext.extrapolation.values(ext.n11[q_small], ext.opening[q_small])[0], rtol=1e-12)
    np.testing.assert_allclose(ext.value[q_over], model.q11(ext.n11[q_over], ext.opening[q_over]), rtol=1e-12)
    # the failing case beside it: the model alone differs from the weighed answer below the line (by up to 1 %
    # on this in-class chart, whose evidence gives the model family 0.9 of the weight)
    assert np.max(np.abs(ext.value[q_small] / model.q11(ext.n11[q_small], ext.opening[q_small]) - 1)) > 1e-4
    assert not ext.derived[rows].any()
    assert len(silent_region_points(shipped_chart, model)) == small.sum() // 2 + over.sum() // 2
    # midway between each two adjacent lines: 6 speeds over the lines' measured ones and 3 beyond toward runaway
    np.testing.assert_allclose(np.unique(ext.opening[between]), 0.5 * (lines[:-1] + lines[1:]), rtol=1e-12)
    assert between.sum() == 2 * (lines.size - 1) * (BETWEEN_LINE_SPEEDS + OVERSPEED_POINTS)
    assert len(between_line_points(shipped_chart, model)) == between.sum() // 2
    # their values: the model plus the residual the lines measure, carried there (on this in-class chart the reading
    # noise alone: within 1e-5 of the model; the out-of-class chart of the test below carries more)
    from hillchart.extension.residual import continued_residual

    q_between = between & (ext.target == "q11")
    x = np.column_stack([ext.n11[q_between], ext.opening[q_between]])
    measured = np.column_stack([shipped_chart.flow_n11, shipped_chart.flow_opening])
    residual = shipped_chart.flow_q11 - model.q11(shipped_chart.flow_n11, shipped_chart.flow_opening)
    np.testing.assert_allclose(ext.value[q_between], model.q11(x[:, 0], x[:, 1]) + continued_residual(
        measured, residual, x), rtol=1e-12)


@pytest.mark.slow
def test_samples_between_the_lines_keep_a_sparse_charts_speed_rise(monkeypatch):
    """The out-of-class family's worst chart for the max speed rise (slow-x, sparse: 4 lines of 4 points, noise
    0.3 %, seed 0, with runaway curve), 100 % rejection with a 14 s closure: the speed peak builds while the closure
    crosses the gaps between the lines toward runaway. With the model's samples between the lines the nets' max speed
    rise is within 0.6 point of the exact turbine's (measured -0.49); without them, fitted with the paper's stops
    (goal 1e-5, 6 validation fails: the failing case beside it, the training before the stops were chosen) the nets
    lay 1.0-1.2 % of the M11 range under the torque between the two lowest lines and the rise came out 1.30 points
    low. With the stops chosen the chart reads -0.44 without the samples too. Tolerances: 0.15 point around the
    measured figures, the spread of seeded retraining across CPUs."""
    import hillchart.extension.extend as extend_module
    from hillchart.nets.training import train_nets
    from simulate.loop.engine import run_simulation
    from simulate.studies.guarantee import benchmark_turbine, digitization, family_plant, synthetic_chart_texts

    member = benchmark_turbine("slow-x")
    texts = synthetic_chart_texts(seed=0, turbine=member, options=digitization("sparse", noise_pct=0.3, runaway=True,
                                                                              seed=0))

    def speed_error(tmp, **stops):
        for name, text in texts.items():
            (tmp / name).write_text(text, encoding="utf-8")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            chart = load_chart(tmp)
            nets = train_nets(extend_samples(chart), ensemble=10, seed=0, **stops)
            exact = run_simulation(family_plant("slow-x", closing_time_s=14.0), characteristics=member.turbine())
            got = run_simulation(family_plant("slow-x", closing_time_s=14.0, opening_max=chart.info.opening_max),
                                 characteristics=nets)
        return 100.0 * (got.summary()["max_speed_rise"] - exact.summary()["max_speed_rise"])

    import tempfile
    with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
        with_samples = speed_error(Path(a))
        monkeypatch.setattr(extend_module, "between_line_points", lambda chart, model: [])
        without = speed_error(Path(b), goal=1e-5, max_fail=6)
    assert abs(with_samples) < 0.6  # measured -0.49
    assert without < -1.15  # measured -1.30


def test_silent_regions_can_be_switched_off(shipped_chart):
    for options in (ExtensionOptions(silent_regions=False), ExtensionOptions(boundaries="polynomial")):
        assert "silent-region" not in set(extend_samples(shipped_chart, options).origin.tolist())


def test_the_plant_is_sized_from_each_turbine():
    for name in ("slow", "medium", "fast"):
        turbine = family_plant_dict(name)["turbine"]
        # the HLA339 unit for the medium turbine: D1 4.5 m, 200 r/min, 142.5 m^3/s (ours: rated point at 1.046 x the
        # best N11 and 73.3 % opening of the exact turbine, so a few % off the paper's rounded figures)
        if name == "medium":
            assert turbine["runner_diameter_m"] == pytest.approx(4.5, rel=0.06)
            assert turbine["rated_speed_rpm"] == pytest.approx(200.0, rel=0.06)
            assert turbine["rated_flow_m3_s"] == pytest.approx(142.5, rel=0.06)
        assert 0.85 < 225e6 / (9810 * turbine["rated_flow_m3_s"] * 176.0) < 0.95  # rated efficiency of the chart


CASES = dict(noise_pct=0.3, runaway=True, seed=0, closing_times_s=(8.0, 14.0))
FAMILY_CHARTS = [(t, d) for t in ("slow", "medium", "fast") for d in ("dense", "sparse")]


@pytest.fixture(scope="module")
def family_results():
    """One seed per turbine, dense and sparse: 4 load rejections each with the nets, the ensemble and the exact
    turbine (about 30 s on a quiet 2-core machine)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {key: evaluate_chart(key[0], density=key[1], **CASES) for key in FAMILY_CHARTS}


@pytest.mark.slow
@pytest.mark.parametrize("key", FAMILY_CHARTS, ids=["-".join(k) for k in FAMILY_CHARTS])
def test_guarantee_figures_match_the_exact_turbine(family_results, key):
    result = family_results[key]
    # the bounds: max speed rise within 1.0 point, max head rise within 2.0 points of the exact turbine, for
    # load rejections from 100 % and 60 % load with closures of 8 and 14 s (measured worst over the six charts:
    # 0.80 and 1.41 points with the physical model below the lowest line; without the silent regions the medium
    # dense chart alone misses the head by more than 2 points, see below)
    assert result.worst_error_pt("max_speed_rise") <= ACCEPTANCE["speed_pt"]
    assert result.worst_error_pt("max_head_rise") <= ACCEPTANCE["head_pt"]


@pytest.mark.slow
def test_the_band_covers_the_exact_turbine_and_stays_narrow(family_results):
    from simulate.studies.uncertainty import figure_band

    cases = [c for g in family_results.values() for c in g.cases]
    judged = [(c, f) for c in cases for f in ("max_speed_rise", "max_head_rise")]
    coverage = np.mean([c.covered(f) for c, f in judged])
    width = np.median([c.width_pt("max_head_rise") for c in cases])
    # >= 90 % of the 48 figures inside the 5-95 % band (measured 96 %); median head band measured 5.8 points. The
    # band below the lowest line is no longer calibrated on this family: it comes from each chart's own held-out
    # lines (hillchart.extension.hypotheses), which cannot tell this in-class family from a real runner whose
    # lowest lines bend away (Sayano: 20 of its 22 held-out Q11 points covered), so it is wider here than a band
    # fitted to the family (1.6 points); 8 points bounds it with room for the spread of the six charts' medians
    # (4-8 points)
    assert coverage >= ACCEPTANCE["coverage"] and width <= 8.0
    # the failing case: half the members' spread about their median misses the acceptance (measured 81 %; the
    # plain 5-95 % spread, inflation 1, covers the same 96 % here)
    half = np.mean([(lambda b: b[0] <= c.exact[f] <= b[1])(figure_band(c.members[f], inflation=0.5))
                    for c, f in judged])
    assert half < ACCEPTANCE["coverage"] <= coverage


@pytest.mark.slow
def test_without_the_silent_regions_the_head_rise_misses():
    """The failing case beside the passing one: the nets' sigmoids below the lowest line decide the head rise. The
    medium runner's dense chart without a runaway curve (noise 0.3 %, seed 0): 2.58 points off without the model's
    samples where the chart is silent, 0.45 with them (measured)."""
    options = {**CASES, "runaway": False}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        without = evaluate_chart("medium", density="dense", extension=ExtensionOptions(silent_regions=False),
                                 band=False, **options)
        with_model = evaluate_chart("medium", density="dense", band=False, **options)
    assert without.worst_error_pt("max_head_rise") > ACCEPTANCE["head_pt"]
    assert with_model.worst_error_pt("max_head_rise") < ACCEPTANCE["head_pt"]


@pytest.mark.parametrize("turbine", ["slow", "medium", "fast"])
def test_sparse_family_charts_train_by_default(turbine, tmp_path, capsys):
    from hillchart.extension.plausibility import thin_chart_notes
    from hillchart.synthetic.francis import write_synthetic_chart
    from hillsim.cli import main
    from simulate.studies.guarantee import digitization

    folder = tmp_path / "chart"
    # seed 0: 4 lines of 4 points; on the fast turbine its nets overshoot the best contour (0.922 > 0.91 + 0.01),
    # which refused the chart before thin charts were told apart from inconsistent ones
    write_synthetic_chart(folder, seed=0, turbine=turbine,
                          options=digitization("sparse", noise_pct=0.3, runaway=True, seed=0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        notes = thin_chart_notes(load_chart(folder))
    assert len(notes) == 2 and "4 opening lines" in notes[0] and "16 points" in notes[1]
    out = tmp_path / "nets.json"
    assert main(["train", str(folder), "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert out.is_file() and text.count("warning: thin chart:") == 2 and "digitize 6 or more" in text


def test_a_dense_chart_is_not_thin():
    from hillchart.extension.plausibility import thin_chart_notes

    assert thin_chart_notes(load_chart(FRANCIS_DIR)) == []  # 12 lines, 84 points, 9 contours


def test_each_guarantee_figure_reports_its_extrapolation_share():
    import importlib.resources as ir

    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    plant = load_plant(ir.files("data_synthetic") / "plant_hla339.toml", {"scenario.t_end_s": 20.0})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_simulation(plant)
    record = result.summary()["extrapolation"]
    figures = record["figures"]
    assert figures["max_head_rise"]["time_s"] == pytest.approx(result.summary()["t_max_head_s"])
    # by hand: the share of the steps up to the maximum head that end outside the digitized region (the closure
    # ends below the shipped chart's lowest line, 10 mm, so it is neither 0 nor 1)
    t = result.time_s
    n11 = result.speed_rpm * plant.turbine.runner_diameter_m / np.sqrt(result.head_m)
    from simulate.loop.domain import plant_domain

    outside = plant_domain(plant, _shipped_nets()).masks(n11, result.opening_chart, result.opening)["digitized_region"]
    until = t[1:] <= figures["max_head_rise"]["time_s"]
    want = np.diff(t)[until & outside[1:]].sum() / np.diff(t)[until].sum()
    assert figures["max_head_rise"]["digitized_region"] == pytest.approx(want, abs=1e-12)
    assert 0.0 < want < 1.0


def _shipped_nets():
    from hillchart.nets.hill_nets import load_nets

    return load_nets(FRANCIS_DIR / "nets.json")


def test_out_of_class_turbines_run_through_the_same_pipeline():
    from hillchart.errors import InputError
    from hillchart.synthetic.francis_variants import OUT_OF_CLASS_FAMILY
    from simulate.studies.guarantee import benchmark_turbine, is_out_of_class

    assert benchmark_turbine("medium-x") is OUT_OF_CLASS_FAMILY["medium-x"] and is_out_of_class("fast-x")
    assert not is_out_of_class("medium")
    with pytest.raises(InputError, match="slow, medium, fast, slow-x, medium-x, fast-x"):
        benchmark_turbine("medium-y")
    for name in OUT_OF_CLASS_FAMILY:
        turbine = family_plant_dict(name)["turbine"]
        assert 0.85 < 225e6 / (9810 * turbine["rated_flow_m3_s"] * 176.0) < 0.95  # rated efficiency of the chart
    one_case = dict(noise_pct=0.3, runaway=True, seed=0, closing_times_s=(8.0,), load_fractions=(1.0,), band=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = evaluate_chart("medium-x", density="dense", **one_case)
        inside = evaluate_chart("medium", density="dense", **one_case)
    (case,), (in_case,) = out.cases, inside.cases
    # the exact turbine simulated is the out-of-class one: a rejection like the in-class runner's (8 s closure of
    # the benchmark plant: speed rise 38 %, head rise 59 %) but not its figures (measured 36.5 % and 52.9 %)
    assert 0.3 < case.exact["max_speed_rise"] < 0.45 and 0.4 < case.exact["max_head_rise"] < 0.65
    assert in_case.exact["max_speed_rise"] - case.exact["max_speed_rise"] > 0.01
    assert in_case.exact["max_head_rise"] - case.exact["max_head_rise"] > 0.03
    assert np.isfinite(case.error_pt("max_speed_rise")) and np.isnan(case.band["max_head_rise"][0])


@pytest.mark.slow
def test_the_fitted_throat_foot_brings_the_out_of_class_head_rise_within_two_points(monkeypatch):
    """benchmarks/bench_out_of_class_ablation.py, its dense row (slow-x, noise 0.3 %, 8 s closure from full load): the
    turbine's hyperbolic throat foot, seen above the lowest line by the fitted model's rational foot, leaves the max
    head rise 1.78 points under the exact turbine's; the model without a foot (the failing case, the foot never
    tried) leaves it 4.62 points under; with the foot switched off in the turbine the fit keeps none and the error is
    +0.74. The F-test at level 0 (the foot never kept) no longer fails: the footed form, weighed as the other form
    with its probability given the chart (1 - 1e-6), gives -1.04. The bounds sit in the gaps (2.5 against 1.78,
    1.04 and 4.62; 1.5 against 0.74), so a change of the nets by tenths of a point, more than a CPU family moves
    them, keeps each verdict."""
    import dataclasses

    import hillchart.extension.turbine_model as turbine_model
    from hillchart.synthetic import francis_variants

    bench = load_script("bench_out_of_class_ablation")
    family = francis_variants.OUT_OF_CLASS_FAMILY
    member = family["slow-x"]

    def head_error(label):
        family["slow-x"] = dataclasses.replace(member, physics=bench.variants(member)[label])
        try:
            chart = evaluate_chart("slow-x", density="dense", noise_pct=0.3, runaway=False, seed=0,
                                   closing_times_s=(8.0,), load_fractions=(1.0,), band=False)
        finally:
            family["slow-x"] = member
        return chart.cases[0].error_pt("max_head_rise")

    assert abs(head_error("all three changes")) < 2.5
    assert abs(head_error("without the throat foot")) < 1.5
    monkeypatch.setattr(turbine_model, "FOOT_SIGNIFICANCE", 0.0)
    assert abs(head_error("all three changes")) < 2.5
    monkeypatch.setattr(turbine_model, "FOOT_MIN_LINES", 10 ** 6)
    assert head_error("all three changes") < -2.5
