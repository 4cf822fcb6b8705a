"""Below the lowest line: the hypotheses, their held-out evidence and the band (hillchart.extension.hypotheses)."""

import shutil
import warnings
from dataclasses import replace

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR
from hillchart.extension import hypotheses as H
from hillchart.extension.extend import extend_samples
from hillchart.io.samples import load_chart
from hillchart.synthetic.francis import SyntheticFrancis
from tests.scripts import load_script


@pytest.fixture(scope="module")
def shipped():
    return extend_samples(load_chart(FRANCIS_DIR))


def test_every_anchored_hypothesis_passes_through_the_lowest_line_and_the_closed_vanes(shipped):
    """At the lowest line (t = 1) the anchored hypotheses give the line's own values; at shut vanes Q11 = 0 and
    M11 = -K N11^2 (eq. 8). 1e-12: the formulas reduce to the anchor exactly there."""
    hyp = shipped.extrapolation.hypotheses
    n11 = np.linspace(40.0, 100.0, 7)
    q_low, m_low = hyp.lowest.values(hyp.model, n11)
    for name in ("anchored-model", "anchored-other-form-model", "line", "offset-line", "quadratic"):
        q, m = hyp.predict(name, n11, hyp.lowest.opening)
        np.testing.assert_allclose(q, q_low, rtol=1e-12)
        np.testing.assert_allclose(m, m_low, rtol=1e-12)
        q0, m0 = hyp.predict(name, n11, 0.0)
        assert np.all(q0 == 0.0)
        np.testing.assert_allclose(m0, -hyp.k_zero_opening * n11 ** 2, rtol=1e-12)
    # the model itself is not anchored: it misses the lowest line by its own misfit there
    assert np.max(np.abs(hyp.predict("model", n11, hyp.lowest.opening)[0] / q_low - 1.0)) > 1e-4
    # the other form has a disc friction of its own (K differs by 2.6 % here), corrected to the chart's K at shut
    # vanes, so eq. (8) holds there with the K every hypothesis shares
    assert abs(hyp.other.k_zero_opening / hyp.k_zero_opening - 1.0) > 0.01
    np.testing.assert_allclose(hyp.predict("other-form-model", n11, 0.0)[1], -hyp.k_zero_opening * n11 ** 2,
                               rtol=1e-12)


def test_the_lowest_line_passes_through_its_own_points_beyond_the_models_range(shipped):
    """Where the lowest line was digitized it gives its own values, also beyond 0.95 of the model's pumping limit
    (where the model is held): a model held from the line's second-last point on still reads the last point exactly
    (1e-12: the residual there is the point minus the held model, added back). Read at the held N11 instead, the
    line misses its last point by the change of Q11 between the two points (measured 1.2 %)."""
    chart = load_chart(FRANCIS_DIR)
    torque = shipped.value[(shipped.target == "m11") & (shipped.origin == "measured")]
    a_low = float(np.min(chart.flow_opening))
    on = chart.flow_opening == a_low
    n_line, q_line = chart.flow_n11[on], chart.flow_q11[on]
    order = np.argsort(n_line)
    n_line, q_line = n_line[order], q_line[order]
    held_at = n_line[-2]  # 0.95 of the limit: the model is held from there
    model = replace(shipped.boundary_model, n11_limit=held_at / 0.95)
    hyp = H.fit_hypotheses(chart, torque, model, model.k_zero_opening)
    q, _ = hyp.lowest.values(model, n_line)
    np.testing.assert_allclose(q, q_line, rtol=1e-12)
    # the failing reading: the whole line read at the held N11 misses the last point
    q_held, _ = hyp.lowest.values(model, np.full(1, held_at))
    assert abs(q_held[0] / q_line[-1] - 1.0) > 0.005
    # beyond the line's end and the model's range, the value is held
    far = hyp.lowest.values(model, np.array([n_line[-1] + 5.0, n_line[-1] + 50.0]))[0]
    assert far[0] == far[1]


def test_the_weights_sum_to_one_and_favour_what_predicted_the_held_out_lines(shipped):
    """On the in-class chart the held-out lines are predicted within 0.5 % by the model family (both forms) and 15 %
    too high by the lines through the origin (the exact turbine's Q11 is concave in the opening): the evidence weighs
    them so."""
    ev = shipped.extrapolation.evidence
    for target in ("q11", "m11"):
        assert sum(ev.weights[target].values()) == pytest.approx(1.0, abs=1e-12)
    assert ev.points == 21 and [f.lines for f in ev.folds] == [1, 2]
    assert ev.errors["q11"]["model"] < 0.01 < 0.05 < ev.errors["q11"]["line"]
    assert ev.errors["q11"]["other-form-model"] < 0.01
    assert sum(ev.weights["q11"][h] for h in ("model", "anchored-model", *H.OTHER_FORM)) > 0.8  # measured 0.90
    # the weighed answer is within 4 % of the exact turbine at 2-8 mm below the lowest line, and below it at 2 mm
    # (measured -3.8 %: this turbine has no throat foot, but its chart's F-test, p = 0.014, leaves the foot 0.64
    # likely and the held-out lines cannot tell the forms apart, so the weighed median follows the footed form, whose
    # two hypotheses weigh 0.62; the weighed mean read -2.3 %; less flow there is the safe side of a head rise)
    exact = SyntheticFrancis()
    n11, a = np.meshgrid(np.linspace(40.0, 100.0, 13), [2.0, 4.0, 6.0, 8.0])
    q, _ = shipped.extrapolation.values(n11, a)
    error = q / exact.q11(n11, a) - 1.0
    assert np.max(np.abs(error)) < 0.04 and np.all(error[0] < 0.0)


def test_a_chart_with_too_few_lines_says_so_and_has_a_wide_band(tmp_path):
    """Three opening lines leave no line to hold out with three above it: no evidence, the hypotheses weighed
    equally, the band at its stated width, and the summary says what to digitize."""
    folder = tmp_path / "chart"
    shutil.copytree(FRANCIS_DIR, folder)
    (folder / "nets.json").unlink()
    lines = (folder / "flow.csv").read_text(encoding="utf-8").splitlines()
    keep = {10.0, 20.0, 30.0}
    (folder / "flow.csv").write_text("\n".join([lines[0]] + [row for row in lines[1:]
                                                             if float(row.split(",")[0]) in keep]) + "\n",
                                     encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ext = extend_samples(load_chart(folder))
    ev = ext.extrapolation.evidence
    wide = (H.NO_EVIDENCE_SCALE, H.NO_EVIDENCE_SCALE)
    assert ev.points == 0 and ev.band == {"q11": wide, "m11": wide}
    # three lines: the throat foot is not tried, so the model has no other form to weigh
    assert ev.names == tuple(h for h in H.HYPOTHESES if h not in H.OTHER_FORM)
    assert {ev.weights["q11"][h] for h in ev.names} == {1.0 / len(ev.names)}
    assert all(ev.weights["q11"][h] == 0.0 for h in H.OTHER_FORM)
    assert "no held-out evidence" in ev.summary() and "digitize more opening lines" in ev.summary()
    # kappa h(0.5) = 0.585 of log Q11 at half the lowest opening, h growing as d^2 to 0.05 and on linearly: 1.2 at
    # the closed vanes (the message once printed kappa itself, "+-120 %"; growing as d^2 all the way, +-30 %)
    assert ev.distance_cap == H.NO_EVIDENCE_CAP
    assert "(-44 % to +79 % of Q11 at half the lowest opening)" in ev.summary()


def test_the_priors_multiply_the_held_out_likelihoods():
    """Two hypotheses that predicted the held-out points equally well share their weight as their priors do (3:1
    here, the model's two forms by their probability given the chart); a hypothesis with a 100x larger held-out MSE
    over 3 lines weighs 100^(-3/2) of them; a hypothesis a weighing fold did not answer weighs 0."""
    distance = np.full(4, 0.5)
    truth = np.array([1.0, 1.1, 1.2, 1.3])

    def fold(lines, answers):
        return H.HeldOut(lines=lines, n11=np.arange(4.0), opening=np.full(4, 5.0), q11=truth, m11=truth,
                         distance=distance, predictions=answers, lines_left=5)

    near, far = truth * np.exp(0.01 * np.array([1, -1, 1, -1])), truth * np.exp(0.1 * np.array([1, -1, 1, -1]))
    answers = {"model": (near, near), "other-form-model": (near, near), "line": (far, far)}
    folds = [fold(1, dict(answers)), fold(2, {k: v for k, v in answers.items()})]
    ev = H.weigh(folds, 1.0, names=("model", "other-form-model", "line", "quadratic"),
                 priors={"model": 0.75, "other-form-model": 0.25})
    w = ev.weights["q11"]
    assert w["model"] == pytest.approx(3.0 * w["other-form-model"], rel=1e-9)
    assert w["line"] / w["model"] == pytest.approx(100.0 ** -1.5 / 0.75, rel=1e-6)
    assert w["quadratic"] == 0.0 and "quadratic" not in ev.names  # not answered by the folds
    # without priors the two forms weigh the same: the failing case of a prior left out
    plain = H.weigh(folds, 1.0, names=("model", "other-form-model", "line"))
    assert plain.weights["q11"]["model"] == pytest.approx(plain.weights["q11"]["other-form-model"], rel=1e-12)


def test_band_scale_is_split_conformal_on_the_far_half():
    """The ceil((n + 1) 0.9)-th smallest score |r| / d^2 among the points at least half the furthest distance;
    a thin record is widened by (n + 1) / n instead of being read as its largest score."""
    residuals = np.array([0.001, 0.002, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09])
    distance = np.array([0.05, 0.05] + [0.5] * 8)  # the two near points (noise over a tiny d^2) are left out
    # 8 far points: the rank ceil(9 x 0.9) = 9 is beyond them, so the largest, widened by 9 / 8
    assert H.band_scale(residuals, distance) == pytest.approx(0.09 / 0.25 * 9 / 8)
    many = np.linspace(0.01, 0.2, 20)
    assert H.band_scale(many, np.full(20, 0.5)) == pytest.approx(np.sort(many)[18] / 0.25)  # rank ceil(21 x 0.9)


def test_band_sides_are_one_sided_conformal_bounds_on_the_signed_scores():
    """Each side is the ceil((n + 1) 0.95)-th smallest signed score on the far half (prediction minus truth: points
    the prediction overshot set the low side); with too few points for that rank, the largest score widened by
    (lines + 1) / lines; the narrow side is at least a quarter of the wide one."""
    residuals = np.concatenate([np.linspace(0.01, 0.2, 20), np.linspace(-0.019, -0.001, 19)])
    distance = np.full(residuals.size, 0.5)
    low, high = H.band_sides(residuals, distance, lines=6)
    scores = residuals / 0.25
    rank = int(np.ceil(40 * 0.95))  # 38 of 39 scores
    assert low == pytest.approx(np.sort(scores)[rank - 1])
    assert high == pytest.approx(max(np.sort(-scores)[rank - 1], 0.25 * low))  # the floor holds here
    assert high == pytest.approx(0.25 * low) and low > 0.5  # the failing side: a symmetric |r| band would be 0.76
    # a thin record: 3 points of one line, widened by (1 + 1) / 1 on each side
    assert H.band_sides([0.02, 0.04, -0.01], [0.5] * 3, lines=1) == pytest.approx((0.32, 0.08))
    assert H.band_sides([0.02, 0.04, -0.01], [0.5] * 3, lines=3) == pytest.approx((0.16 * 4 / 3, 0.04 * 4 / 3))


def test_folds_that_disagree_on_the_sign_give_a_symmetric_band():
    """With the hold-out of each residual given: two folds whose mean misses take both signs (one overshot, one
    undershot), or a single fold, have not shown on which side the error falls, and both sides are the wider one;
    two folds that agree keep the narrow side at its floor. The Kaplan chart of the bulb page, its lowest line held
    out: its inner folds missed by +3.4 % and -2.4 % (mean), the held-out line lay 3-5 % below the answer, and the
    band with a narrow low side covered 5 of its 10 points (docs/bulb-extrapolation.md)."""
    residuals = np.array([0.04, 0.03, 0.05, -0.02, -0.01, -0.03])
    distance = np.array([0.2, 0.2, 0.2, 0.4, 0.4, 0.4])
    # the failing side: without the folds, the narrow (high) side is half the wide one
    asymmetric = H.band_sides(residuals, distance, lines=3, min_side_fraction=0.5)
    wide = max(asymmetric)
    assert asymmetric == pytest.approx((wide, 0.5 * wide)) and wide > 1.0
    disagree = H.band_sides(residuals, distance, lines=3, min_side_fraction=0.5, folds=[1, 1, 1, 2, 2, 2])
    assert disagree == pytest.approx((wide, wide))
    one = H.band_sides(residuals[3:], distance[3:], lines=1, min_side_fraction=0.5, folds=[2, 2, 2])
    assert one[0] == pytest.approx(one[1]) and one[1] > 0
    same_sign = np.abs(residuals)
    agree = H.band_sides(same_sign, distance, lines=3, min_side_fraction=0.5, folds=[1, 1, 1, 2, 2, 2])
    assert agree == pytest.approx(H.band_sides(same_sign, distance, lines=3, min_side_fraction=0.5))
    assert agree[1] == pytest.approx(0.5 * agree[0])


@pytest.mark.external
def test_the_real_chart_predicts_its_held_out_lines_no_worse_than_a_straight_line(tmp_path, monkeypatch):
    """Sayano with its lowest line, then its two and its three lowest, held out and trained with the defaults on the
    rest: what a run reads is within the straight line's mean error (measured 1.3, 4.2 and 4.6 % against 4.0, 7.2
    and 6.1 %), its worst error within 8 % for one and two lines (measured -3.4 and +6.7 %; the straight line's +7.9
    and +13.2 % show the bound can fail; the nets move by up to 0.4 % between CPU families), and for every k the band
    covers at least 80 % of the held-out Q11 and M11 (measured Q11 3/3, 6/7, 11/12, M11 3/3, 6/7, 12/12). The failing
    sides: without a floor under the band's narrow side below the lowest line a point of the 10 mm line lies 2.3 % of
    its Q11 above the band with one line held out (2 of 3 covered; 0.4 % with the floor at a quarter); with
    three lines held out the F-test does not keep the throat foot (p = 0.0104), and the model it chose misses by
    11.4 % (mean), where the weighed forms miss by 4.4 %; the physical model without its throat foot misses the two
    lowest lines by 14 % (mean)."""

    from tests.external_charts import SAYANO_CONTOURS, SAYANO_LINES, require_external

    require_external(SAYANO_LINES, SAYANO_CONTOURS)
    bench = load_script("bench_extrapolation")
    chart = bench.sayano_chart(tmp_path)
    results = [bench.hold_out_lines(chart, k) for k in (1, 2, 3)]
    for result in results:
        run, line = result["rows"]["run"], result["rows"]["line"]
        assert run["q11_mean_abs_pct"] < line["q11_mean_abs_pct"]
    for result in results[:2]:
        assert abs(result["rows"]["run"]["q11_worst_pct"]) <= 8.0
    assert results[1]["rows"]["line"]["q11_worst_pct"] > 8.0
    assert results[2]["rows"]["model"]["q11_mean_abs_pct"] > 10.0  # the chosen form alone (measured 11.4 %)
    for result in results:
        assert result["m11_covered"] >= 0.8 * result["points"]
    for result in results[1:]:  # one point may leave the band (one of 7 and one of 12 does, 0.2 and 0.3 % outside)
        assert result["q11_covered"] >= 0.8 * result["points"]
    # k = 1: all three points must be inside, the nearest edge's lies 2.0 % of its Q11 inside it: its margin is
    # asserted, with the nets' 0.4 % spread between CPU families as the tolerance
    assert results[0]["q11_margin_pct"] > -0.4
    import hillchart.extension.hypotheses as hypotheses

    monkeypatch.setattr(hypotheses, "MIN_SIDE_FRACTION_BELOW", 0.0)
    assert bench.hold_out_lines(chart, 1)["q11_margin_pct"] < -1.0  # measured -2.3 %
    # the model with the foot and without it (the test at level 0 never keeps it), at the two lowest lines
    import hillchart.extension.turbine_model as turbine_model

    rest, held = bench.reduced_chart(chart, 2)
    n11, opening, q11 = chart.flow_n11[held], chart.flow_opening[held], chart.flow_q11[held]
    footed = turbine_model.fit_turbine_model(rest, bench.chart_torque(rest))
    monkeypatch.setattr(turbine_model, "FOOT_SIGNIFICANCE", 0.0)
    plain = turbine_model.fit_turbine_model(rest, bench.chart_torque(rest))
    assert plain.throat_foot_mm == 0.0 < footed.throat_foot_mm
    assert np.mean(np.abs(plain.q11(n11, opening) / q11 - 1.0)) > 0.10
    assert np.mean(np.abs(footed.q11(n11, opening) / q11 - 1.0)) < 0.04  # measured 2.1 %


def test_toward_runaway_the_chart_states_how_well_it_predicts_its_held_out_line_ends(shipped):
    """Each line's highest-N11 point held out: the refitted model predicts them within 0.4 % (Q11) on the in-class
    chart, better than a straight continuation of each line (0.8 %), and the held-out runaway curve within 0.6 %;
    the evidence is in the summary hillsim train prints."""
    o = shipped.extrapolation.overspeed
    assert o["held_out_points"] == 12  # one per line
    assert o["model_q11_rms"] < 0.006 and o["model_q11_rms"] < o["line_q11_rms"]
    assert o["runaway_n11_rms"] < 0.01
    assert "toward runaway the model predicts each line's held-out last point within" in \
        shipped.extrapolation.summary()


def test_toward_runaway_the_evidence_pairs_each_line_with_its_own_held_out_end(shipped):
    """The held-out line ends are compared with the continuations and gaps of their own lines, whatever the order
    of the chart's points: the shipped chart with its flow points in reverse order gives the same evidence. The
    continuations see the same points (1e-12); the refitted model sees them in another order, so its least squares
    takes other rounding and stops elsewhere within its tolerance (6e-7 apart measured; 1e-5 allowed). Before, the
    ends were taken in the points' order and the continuations in the openings': reversed, the straight continuation
    "missed" by tens of % of Q11 (0.8 % in order) and the band per gap paired each line's miss with another's gap."""
    from hillchart.characteristics import unit_torque_from_efficiency
    from hillchart.extension.turbine_model import fit_turbine_model

    chart = load_chart(FRANCIS_DIR)
    torque = unit_torque_from_efficiency(chart.flow_q11, chart.flow_n11, shipped.efficiency_surface(
        chart.flow_n11, chart.flow_q11))
    back = slice(None, None, -1)
    reverse = replace(chart, flow_opening=chart.flow_opening[back], flow_n11=chart.flow_n11[back],
                      flow_q11=chart.flow_q11[back], rows={**chart.rows, "flow": chart.rows["flow"][back]})
    ordered = H.overspeed_evidence(chart, torque, fit_turbine_model)
    reversed_ = H.overspeed_evidence(reverse, torque[back], fit_turbine_model)
    assert ordered["line_q11_rms"] < 0.01
    for key, rel in (("line_q11_rms", 1e-12), ("line_m11_rms", 1e-12), ("model_q11_rms", 1e-5),
                     ("model_m11_rms", 1e-5), ("runaway_n11_rms", 1e-5)):
        assert reversed_[key] == pytest.approx(ordered[key], rel=rel), key
    for key, rel in (("line_m11_band_per_gap", 1e-12), ("m11_band_per_gap", 1e-5)):
        for side in ("low", "high"):
            assert reversed_[key][side] == pytest.approx(ordered[key][side], rel=rel), (key, side)


def test_toward_runaway_a_refit_that_cannot_reach_the_line_ends_says_so(shipped):
    """The shipped chart's refit reaches past every held-out line end (its pumping limit N11 = 200, none beyond, and
    the summary does not speak of it); a refit whose pumping limit falls short of them (as Sayano's without its three
    lowest lines does, N11 = 95.6 against line ends at 100) counts each as a miss of its whole value, and the summary
    says how many and where the limit is, so that "within 100.0 %" is not read as a fit."""
    import dataclasses

    from hillchart.characteristics import unit_torque_from_efficiency
    from hillchart.extension.hypotheses import overspeed_evidence
    from hillchart.extension.turbine_model import fit_turbine_model

    o = shipped.extrapolation.overspeed
    assert o["beyond_model_range"] == 0 and o["model_n11_limit"] > 150.0
    assert "pumping limit" not in shipped.extrapolation.summary()
    chart = load_chart(FRANCIS_DIR)
    torque = unit_torque_from_efficiency(chart.flow_q11, chart.flow_n11, shipped.efficiency_surface(
        chart.flow_n11, chart.flow_q11))  # as the extension computes it, eq. (5)
    ends = max(n for _, n in shipped.extrapolation.line_ends)

    def short_reach(*args, **kwargs):
        model = fit_turbine_model(*args, **kwargs)
        return dataclasses.replace(model, n11_limit=0.9 * ends)

    short = overspeed_evidence(chart, torque, short_reach)
    assert 0 < short["beyond_model_range"] <= short["held_out_points"]
    assert short["model_q11_rms"] > o["model_q11_rms"]
    summary = dataclasses.replace(shipped.extrapolation, overspeed=short).summary()
    assert f"lie beyond the refitted model's pumping limit, N11 = {0.9 * ends:.4g}" in summary


def test_toward_runaway_the_band_grows_with_the_gap_beyond_each_line(shipped):
    """The overspeed band: the refitted model's signed M11 misses at the held-out line ends, per relative N11 gap,
    give each side's width; it is zero up to a line's last point, grows linearly with the gap, stops at twice the
    largest gap tested, and is zero off the digitized lines (1e-12: the formula itself). The shipped chart's model
    overshot more than it undershot there (low side 0.075, high 0.034 of the M11 range per unit gap)."""
    x = shipped.extrapolation
    band = x.overspeed["m11_band_per_gap"]
    scale, cap = x.overspeed["m11_scale"], x.overspeed["gap_cap"]
    assert 0.0 < band["high"] < band["low"] < 0.2 and 0.0 < cap < 0.5
    a, n_end = x.line_ends[4]
    gaps = np.array([-0.1, 0.0, 0.05, 0.1, cap, 2 * cap])
    low, high = x.overspeed_widths(n_end * (1.0 + gaps), np.full(gaps.size, a))
    want = np.minimum(np.maximum(gaps, 0.0), cap)
    np.testing.assert_allclose(low, band["low"] * scale * want, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(high, band["high"] * scale * want, rtol=1e-12, atol=1e-12)
    between = x.overspeed_widths(1.2 * n_end, a + 0.5 * (x.line_ends[5][0] - a))
    assert between[0] == 0.0 and between[1] == 0.0  # between lines the nets interpolate measured data


def test_the_members_move_only_derived_overspeed_torque_samples(shipped):
    """Each ensemble member's torque samples toward runaway stand at its place in the band (the same places as below
    the lowest line); measured samples, a digitized runaway point and the flow never move (exactly 0)."""
    from hillchart.nets.training import _overspeed_moves

    x = shipped.extrapolation
    a, n_end = x.line_ends[2]
    X = np.array([[0.95 * n_end, a], [1.1 * n_end, a], [1.1 * n_end, a], [1.1 * n_end, a]])
    groups = np.array(["measured", "silent-region", "runaway", "runaway"])
    derived = np.array([False, False, False, True])
    moves = _overspeed_moves(shipped, "torque", X, groups, derived, 10, 0)
    positions = H.member_positions(10, 0)
    low, high = x.overspeed_widths(X[:, 0], X[:, 1])
    for u, move in zip(positions, moves):
        width = low if u < 0 else high
        np.testing.assert_allclose(move, [0.0, u * width[1], 0.0, u * width[3]], rtol=1e-12, atol=0.0)
    assert max(abs(m[1]) for m in moves) > 1.0  # N*m: the band is not empty here
    assert _overspeed_moves(shipped, "flow", X, groups, derived, 10, 0) is None


def test_the_weighed_median_follows_the_hypotheses_that_agree_where_the_mean_falls_between(tmp_path):
    """The out-of-class family's worst chart for the max head rise (medium-x, sparse: 4 lines, noise 0.3 %, seed 0):
    one held-out line leaves the weights spread, and the quadratic (weight 0.24) lies 16-18 % above the exact Q11 at
    half the lowest opening where the model and its anchored form (0.34, 0.32) lie within 2.5 %. The weighed median
    answers within 3 % there; the weighed mean (the failing case: the answer before) lies 5-8 % above."""
    from simulate.studies.guarantee import benchmark_turbine, digitization, synthetic_chart_texts

    member = benchmark_turbine("medium-x")
    texts = synthetic_chart_texts(seed=0, turbine=member, options=digitization("sparse", noise_pct=0.3, runaway=True,
                                                                              seed=0))
    for name, text in texts.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ext = extend_samples(load_chart(tmp_path))
    ev, hyp = ext.extrapolation.evidence, ext.extrapolation.hypotheses
    n11 = np.array([60.0, 70.0, 80.0])
    a = np.full(3, 0.5 * hyp.lowest.opening)
    exact = member.turbine().q11(n11, a)
    median = ext.extrapolation.values(n11, a)[0] / exact - 1.0
    mean = sum(ev.weights["q11"][h] * hyp.predict(h, n11, a)[0] for h in hyp.names) / exact - 1.0
    assert np.all(np.abs(median) < 0.03) and np.all(mean > 0.05)
    # the median is one of the hypotheses at every point, and moves with the weights: all weight on the quadratic
    # gives the quadratic
    assert np.allclose(H.weighed_median([hyp.predict(h, n11, a)[0] for h in hyp.names],
                                        [float(h == "quadratic") for h in hyp.names]),
                       hyp.predict("quadratic", n11, a)[0], rtol=0, atol=0)


def test_the_weighed_median_is_the_sort_rule_ties_in_the_hypotheses_order():
    """:func:`hillchart.extension.band.median_pick` (the one implementation, in Python and in the compiled bulb kernel)
    against the rule written with numpy's stable sort, on 2000 random draws of 2-8 hypotheses whose values are drawn
    from 4 levels (so most draws hold ties) and whose weights include zeros: the same hypothesis at every point, exactly
    (both are exact comparisons and sums in one order). The failing case beside it: the rule with ties taken in the
    reverse order of the hypotheses picks another hypothesis in many draws."""
    from hillchart.extension.band import weighed_median

    rng = np.random.default_rng(3)
    differ_unstable = 0
    for _ in range(2000):
        h = int(rng.integers(2, 9))
        values = rng.integers(0, 4, size=(h, 5)).astype(float)
        weights = rng.choice([0.0, 0.1, 0.25, 0.4], size=h)
        if weights.sum() == 0.0:
            weights[0] = 1.0
        order = np.argsort(values, axis=0, kind="stable")
        first = np.argmax(np.cumsum(weights[order], axis=0) >= 0.5 * weights.sum(), axis=0)
        expected = np.take_along_axis(order, first[None], axis=0)[0]
        assert weighed_median(values, weights, index=True).tolist() == expected.tolist()
        flipped = h - 1 - np.argsort(values[::-1], axis=0, kind="stable")
        first = np.argmax(np.cumsum(weights[flipped], axis=0) >= 0.5 * weights.sum(), axis=0)
        differ_unstable += int(np.any(np.take_along_axis(flipped, first[None], axis=0)[0] != expected))
    assert differ_unstable > 1000  # measured 1353 of 2000: ties decide often here, so the order of ties is tested
