"""Below the lowest digitized opening: the tabulated extrapolation blended into the nets, C1, in nets.json, and the
ensemble members placed across its band."""

import json

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR
from hillchart.errors import InputError
from hillchart.extension.band import runout
from hillchart.extension.hypotheses import band_square
from hillchart.nets.hill_nets import HillNets, load_nets
from hillchart.nets.silent_model import SilentRegionModel
from hillchart.synthetic.francis import FrancisParameters, SyntheticFrancis

#: The physical model an earlier version fitted to the shipped chart and wrote into nets.json (kind francis-1d).
LEGACY_PARAMETERS = {"d2": 0.8489489601401382, "b1": 0.20324396877393391, "guide_vane_pitch": 71.00949732403572,
                     "beta1_deg": 44.384877242441185, "beta2_deg": 16.04033036270099,
                     "k_guide_vane": 0.04791297321581836, "k_incidence": 0.8988339968203615,
                     "k_runner": 0.05170949794750406, "k_draft_tube": 0.30224788686216914,
                     "k_swirl": 0.9969303215138795, "k_disc_friction": 0.001648731179379382, "opening_max": 32.0}


@pytest.fixture(scope="module")
def nets():
    return load_nets(FRANCIS_DIR / "nets.json")


def test_the_shipped_nets_hand_over_below_the_lowest_line(nets):
    silent = nets.silent_model
    a0, a1 = silent.blend_openings
    assert a1 == pytest.approx(10.0) and a0 == pytest.approx(0.5 * a1)  # the chart's lowest line is 10 mm
    n11 = np.linspace(20.0, 0.85 * silent.n11_top, 10)
    # below a0: the table's values exactly; above the lowest line: the nets alone, exactly
    for a in (0.0, 0.3, 2.0, a0):
        q, m = silent.table(n11, a)
        np.testing.assert_array_equal(nets.q11(n11, a), q)
        np.testing.assert_array_equal(nets.m11(n11, a), m)
    for a in (a1, 12.0, 30.0):
        np.testing.assert_array_equal(nets.q11(n11, a), nets.flow.evaluate(n11, a)[0])
        np.testing.assert_array_equal(nets.m11(n11, a), nets.torque.evaluate(n11, a)[0])
    # physics at the shut vanes: no flow (every hypothesis passes through Q11 = 0 at a = 0: the table's nodes hold
    # it exactly), and the disc friction's torque -K N11^2 (eq. 8): the cubic convolution reproduces a quadratic
    # exactly inside the grid, to 1e-9 of the torque range with its linearly continued edges
    assert np.all(nets.q11(n11, 0.0) == 0.0)
    k = nets.training["extension"]["k_zero_opening_used"]
    np.testing.assert_allclose(nets.m11(n11, 0.0), -k * n11 ** 2, atol=1e-9 * np.ptp(silent.m11))
    # the failing case beside it: the flow net alone leaks (and pumps) at the shut vanes
    assert np.max(np.abs(nets.flow.evaluate(n11, 0.0)[0])) > 1e-4


def test_the_table_follows_the_exact_turbine_on_the_in_class_chart(nets):
    """The shipped chart is drawn from the 1-D model itself, so its held-out lines weigh the model hypotheses (both
    forms: without the throat foot and with it, 0.64 likely given this chart); the table is then within 4 % of the
    exact Q11 below the lowest line, and below it at 2 mm (measured -3.8 %: the footed form's foot of 0.11 mm, fitted
    to the reading noise, takes flow away at small openings, the safe side of a head rise; the weighed median follows
    that form, whose two hypotheses weigh 0.62; the weighed mean read -2.3 %)."""
    exact = SyntheticFrancis()
    n11, a = np.meshgrid(np.linspace(40.0, 100.0, 13), [2.0, 4.0, 6.0, 8.0])
    q, _ = nets.silent_model.table(n11, a)
    error = q / exact.q11(n11, a) - 1.0
    assert np.max(np.abs(error)) < 0.04 and np.all(error[0] < 0.0)
    weights = nets.training["extrapolation"]["weights"]["q11"]
    family = ("model", "anchored-model", "other-form-model", "anchored-other-form-model")
    assert sum(weights[h] for h in family) > 0.8 and weights["line"] < 0.01


def test_the_blend_is_continuously_differentiable(nets):
    """The pressure loop needs C1 characteristics: the analytic gradient equals a central difference across the
    blend (1e-5 relative of the gradient scale: central differences of step 1e-4 mm have error ~h^2 f''' ~ 1e-8),
    for the point nets and for a member placed at the band's edge."""
    a0, a1 = nets.silent_model.blend_openings
    n11 = np.full(8, 75.0)
    a = np.array([0.5 * a0, a0, 0.5 * (a0 + a1), a1 - 1e-3, a1, a1 + 1e-3, 1.2 * a1, 0.37])
    h = 1e-4
    edge = max(nets.members(), key=lambda m: m.silent_model.position)
    for chars in (nets, edge):
        for value, grad in ((chars.q11, chars.q11_grad), (chars.m11, chars.m11_grad)):
            d_a = grad(n11, a)[1]
            numeric = (value(n11, a + h) - value(n11, a - h)) / (2 * h)
            np.testing.assert_allclose(d_a, numeric, atol=1e-5 * np.max(np.abs(d_a)))
            d_n = grad(n11, a)[0]
            numeric_n = (value(n11 + h, a) - value(n11 - h, a)) / (2 * h)
            np.testing.assert_allclose(d_n, numeric_n, atol=1e-5 * np.max(np.abs(d_n)))


def test_the_compiled_kernel_is_the_python_evaluation(nets):
    kernel, params = nets.numba_kernel()
    a0, a1 = nets.silent_model.blend_openings
    for n11, a in ((60.0, 0.5 * a0), (80.0, 0.5 * (a0 + a1)), (70.0, 2 * a1)):
        got = kernel(params, n11, a)
        want = (*[float(v) for v in (nets.q11(n11, a), *nets.q11_grad(n11, a))],
                *[float(v) for v in (nets.m11(n11, a), *nets.m11_grad(n11, a))])
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)


def test_members_spread_across_the_band_of_the_held_out_evidence(nets):
    """Each member stands at its own place in the band: below half the lowest opening (the table alone) a member's
    Q11 is the table's times exp(u kappa_side h(d)) and its M11 the table's plus u kappa_m_side h(d) a / a_low, so the
    members' own 5 and 95 % percentiles are the band's two sides the chart's held-out lines gave (1e-12: the same
    formula); above the lowest line the band is the nets' alone."""
    members = nets.members()
    silent = nets.silent_model
    positions = np.array([m.silent_model.position for m in members])
    assert len(set(positions)) == len(members) and np.percentile(positions, 95) == pytest.approx(1.0, abs=1e-12)
    assert np.percentile(positions, 5) == pytest.approx(-1.0, abs=1e-12)
    a1 = silent.blend_openings[1]
    a, n11 = 0.3 * a1, 75.0
    spread = np.log([float(m.q11(n11, a)) / float(nets.q11(n11, a)) for m in members])
    shift = np.array([float(m.m11(n11, a)) - float(nets.m11(n11, a)) for m in members])
    h = band_square(1.0 - a / a1, silent.distance_cap, runout(silent.beyond_cap, silent.distance_cap))[0]
    sides = np.where(positions < 0, 0, 1)
    np.testing.assert_allclose(spread, positions * np.array(silent.band_q11)[sides] * h, rtol=1e-12, atol=1e-15)
    t = a / a1  # the torque's band closes at the closed vanes
    np.testing.assert_allclose(shift, positions * np.array(silent.band_m11)[sides] * h * t, rtol=1e-10, atol=1e-10)
    at_shut = [float(m.m11(n11, 0.0)) - float(nets.m11(n11, 0.0)) for m in members]
    assert max(map(abs, at_shut)) < 1e-9 * abs(float(nets.m11(n11, 0.0)))
    np.testing.assert_allclose(np.percentile(spread, [5, 95]), np.array([-1, 1]) * np.array(silent.band_q11) * h,
                               rtol=1e-12)
    assert silent.band_q11[0] != silent.band_q11[1]  # the two sides differ: a symmetric band would fail above
    spread_data = np.ptp([float(m.q11(n11, 2 * a1)) for m in members]) / float(nets.q11(n11, 2 * a1))
    assert spread_data < np.ptp(spread) / 3  # the failing side: with data, the members agree


def test_nets_json_round_trip_and_errors(nets):
    text = nets.to_json()
    again = HillNets.from_json(text)
    np.testing.assert_array_equal(again.silent_model.packed(), nets.silent_model.packed())
    assert [m.packed().tobytes() for m in again.member_silent_models] == \
        [m.packed().tobytes() for m in nets.member_silent_models]
    doc = json.loads(text)
    assert doc["ensemble"][0]["silent_model"] == {"position": nets.member_silent_models[0].position}
    bad = json.loads(text)
    bad["silent_model"]["kind"] = "kaplan"
    with pytest.raises(InputError, match="silent_model.kind must be 'hypotheses-table' .* got 'kaplan'"):
        HillNets.from_dict(bad)
    bad = json.loads(text)
    bad["silent_model"]["blend_openings"] = [7.5, 3.0]
    with pytest.raises(InputError, match="blend_openings must be two finite numbers 0 <= low < high"):
        HillNets.from_dict(bad)
    bad = json.loads(text)
    bad["silent_model"]["q11"][3][2] = -0.01
    with pytest.raises(InputError, match=r"silent_model.q11 must be >= 0 everywhere .* got -0.01"):
        HillNets.from_dict(bad)
    bad = json.loads(text)
    bad["ensemble"][2]["silent_model"]["position"] = "far"
    with pytest.raises(InputError, match=r"ensemble\[2\].silent_model.position must be a number"):
        HillNets.from_dict(bad)
    bad = json.loads(text)
    del bad["silent_model"]  # members with places in a band but no top-level table
    with pytest.raises(InputError, match="top-level silent_model"):
        HillNets.from_dict(bad)
    # a file without the blocks (written before them) still loads: the nets alone everywhere
    del doc["silent_model"]
    for member in doc["ensemble"]:
        del member["silent_model"]
    plain = HillNets.from_dict(doc)
    assert plain.silent_model is None and float(plain.q11(75.0, 0.0)) == float(nets.flow.evaluate(75.0, 0.0)[0])


def test_a_file_of_an_earlier_version_reads_its_physical_model_as_a_table(nets):
    """nets.json of earlier versions held the fitted 1-D model itself (kind francis-1d): it is tabulated on reading,
    within 1e-3 of its Q11 range and M11 range (measured 5.8e-4 of M11, where the torque rises steeply with the
    first half millimetre of opening; cubic convolution on a 41 x 11 grid of a smooth function: error
    ~h^3 f'''), and its members' blocks are whole blocks of the same kind."""
    doc = json.loads(nets.to_json())
    legacy = {"kind": "francis-1d", "parameters": LEGACY_PARAMETERS, "blend_openings": [5.0, 10.0],
              "n11_blend": [171.44620458991497, 191.61634630637556]}
    doc["silent_model"] = legacy
    for member in doc["ensemble"]:
        member["silent_model"] = legacy
    old = HillNets.from_dict(doc)
    p = dict(LEGACY_PARAMETERS)
    model = SyntheticFrancis(FrancisParameters(guide_vane_pitch_mm=p.pop("guide_vane_pitch"),
                                               opening_max=p.pop("opening_max"), **p))
    n11, a = np.meshgrid(np.linspace(0.0, 160.0, 33), np.linspace(0.0, 5.0, 11))
    q, m = old.silent_model.table(n11, a)
    np.testing.assert_allclose(q, model.q11(n11, a), atol=1e-3 * np.ptp(model.q11(n11, a)))
    np.testing.assert_allclose(m, model.m11(n11, a), atol=1e-3 * np.ptp(model.m11(n11, a)))
    assert old.silent_model.band_q11 == (0.0, 0.0) and len(old.member_silent_models) == len(old.ensemble)
    bad = json.loads(json.dumps(doc))
    bad["silent_model"]["parameters"]["d2"] = -1.0
    with pytest.raises(InputError, match="silent_model.parameters must be 12 finite positive numbers"):
        HillNets.from_dict(bad)


def test_a_file_with_the_one_number_band_reads_it_as_both_sides(nets):
    """nets.json of the release before the two-sided band held one Q11 width and no M11 band: it reads as that
    width on both sides and no torque band (a member's Q11 moves, its M11 does not), exactly."""
    doc = json.loads(nets.to_json())
    doc["silent_model"]["band"] = {"q11": 0.3, "distance_cap": doc["silent_model"]["band"]["distance_cap"]}
    old = HillNets.from_dict(doc)
    assert old.silent_model.band_q11 == (0.3, 0.3) and old.silent_model.band_m11 == (0.0, 0.0)
    a, n11 = 0.3 * old.silent_model.blend_openings[1], 75.0
    member = old.members()[0]
    assert float(member.m11(n11, a)) == float(old.m11(n11, a))
    assert float(member.q11(n11, a)) != float(old.q11(n11, a))
    doc["silent_model"]["band"] = {"q11": [0.3], "distance_cap": 0.5}
    with pytest.raises(InputError, match=r"silent_model.band_q11 must be a pair \[low, high\]"):
        HillNets.from_dict(doc)


def test_the_band_grows_on_beyond_the_distances_tested_and_older_files_level_off(nets):
    """Beyond the furthest distance the chart's hold-outs tested (``distance_cap``, c) the band of a file written now
    grows on at the slope of its square there, ``c^2 + 2 c (d - c)``; the shipped nets were written before, without
    ``beyond_cap``, and read as they were written: levelling off at ``2 c^2`` from ``d = 2 c`` (by hand, 1e-12: the
    same formula). The key round-trips; a value outside the two is refused, naming it."""
    from dataclasses import replace

    levels = nets.silent_model
    c, a1 = levels.distance_cap, levels.blend_openings[1]
    assert levels.beyond_cap == "levels" and c < 0.45  # 0.286: 2 c lies inside the gap below the lowest line
    grows = replace(levels, beyond_cap="grows")
    for d in (0.5 * c, 2.0 * c, 0.9):
        want_grows = d * d if d <= c else c * c + 2.0 * c * (d - c)
        want_levels = d * d if d <= c else 2.0 * c * c
        assert grows.band_sides((1.0 - d) * a1)["h"] == pytest.approx(want_grows, rel=1e-12)
        assert levels.band_sides((1.0 - d) * a1)["h"] == pytest.approx(want_levels, rel=1e-12)
    # the compiled kernel reads the same: a member at +1, 0.9 of the way down, moves Q11 by exp(kappa_high h)
    n11, a = 75.0, 0.1 * a1
    for table, h in ((grows, c * c + 2.0 * c * (0.9 - c)), (levels, 2.0 * c * c)):
        member = HillNets(flow=nets.flow, torque=nets.torque, opening_unit=nets.opening_unit,
                          silent_model=table.at(1.0))
        point = HillNets(flow=nets.flow, torque=nets.torque, opening_unit=nets.opening_unit, silent_model=table)
        ratio = float(member.q11(n11, a)) / float(point.q11(n11, a))
        assert ratio == pytest.approx(np.exp(table.band_q11[1] * h), rel=1e-12)
    doc = grows.to_dict()
    assert doc["band"]["beyond_cap"] == "grows" and SilentRegionModel.from_dict(doc).beyond_cap == "grows"
    del doc["band"]["beyond_cap"]
    assert SilentRegionModel.from_dict(doc).beyond_cap == "levels"
    doc["band"]["beyond_cap"] = "sideways"
    with pytest.raises(InputError, match="beyond_cap must be one of grows, levels, got 'sideways'"):
        SilentRegionModel.from_dict(doc)


def test_a_table_with_bad_numbers_is_refused():
    good = np.ones((5, 5))
    with pytest.raises(InputError, match=r"silent_model.q11 and silent_model.m11 must be tables of the same shape"):
        SilentRegionModel(q11=good, m11=np.ones((5, 4)), n11_top=100.0, blend_openings=(1.0, 2.0))
    with pytest.raises(InputError, match=r"silent_model.n11_top must be finite and > 0, got -100.0"):
        SilentRegionModel(q11=good, m11=good, n11_top=-100.0, blend_openings=(1.0, 2.0))
    with pytest.raises(InputError, match=r"silent_model.band_q11 must be a pair \[low, high\] of finite numbers in "
                                         r"\[0, 10\], got \(-1.0, 0.2\)"):
        SilentRegionModel(q11=good, m11=good, n11_top=100.0, blend_openings=(1.0, 2.0), band_q11=(-1.0, 0.2))
    with pytest.raises(InputError, match=r"silent_model.band_m11 must be a pair .* got 3.0"):
        SilentRegionModel(q11=good, m11=good, n11_top=100.0, blend_openings=(1.0, 2.0), band_m11=3.0)
    # the bound is on the band at the shut vanes, a log-ratio of 10: kappa h(1) with h growing as d^2 to the cap and
    # on linearly (h(1) = 0.05 x 1.95 = 0.0975 with the no-evidence cap 0.05). The no-evidence band (kappa 12.3)
    # was refused when kappa itself was bounded by 10; 103 is refused
    SilentRegionModel(q11=good, m11=good, n11_top=100.0, blend_openings=(1.0, 2.0), band_q11=(12.3, 12.3),
                      distance_cap=0.05)
    with pytest.raises(InputError, match=r"silent_model.band_q11 must be a pair .* in \[0, 102.564\], got"):
        SilentRegionModel(q11=good, m11=good, n11_top=100.0, blend_openings=(1.0, 2.0), band_q11=(103.0, 1.0),
                          distance_cap=0.05)
    SilentRegionModel(q11=good, m11=good, n11_top=100.0, blend_openings=(1.0, 2.0))


def test_the_step_up_scales_the_table_torque_too(nets):
    """The prototype step-up multiplies the unit torque everywhere: above the lowest line (the torque net's output
    scaling) and below it (the table's torque factor, also on a member's band shift); the flow is unchanged
    (1e-12: one multiplication)."""
    from simulate.components.turbine.step_up import scale_torque

    stepped = scale_torque(nets, 1.03)
    n11, a = np.meshgrid(np.linspace(10.0, 110.0, 11), [0.0, 1.0, 4.0, 7.0, 10.0, 20.0])
    np.testing.assert_allclose(stepped.m11(n11, a), 1.03 * nets.m11(n11, a), rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(stepped.q11(n11, a), nets.q11(n11, a))
    member, base = stepped.members()[3], nets.members()[3]
    np.testing.assert_allclose(member.m11(n11, a), 1.03 * base.m11(n11, a), rtol=1e-12, atol=1e-12)
    kernel, params = stepped.numba_kernel()
    assert kernel(params, 70.0, 1.0)[3] == pytest.approx(1.03 * float(nets.m11(70.0, 1.0)), rel=1e-12)


def test_the_value_kernels_are_the_kernels_values(nets):
    """The loop's value-only kernels (pressure-loop iterations, torque at the converged head) are the full kernel's
    values by the same formulas: equal to 1e-15 relative (the same operations in the same order; only a compiler's
    choice could move the last bit) over the table, blend, nets and beyond-the-table regions, with and without the
    table, and for a member at the band's edge."""
    n11 = np.linspace(0.0, 260.0, 27)  # 260 r/min: beyond the table's N11 range, where its last values are held
    a = np.linspace(0.0, 32.0, 33)
    nn, aa = (v.ravel() for v in np.meshgrid(n11, a))
    plain = HillNets(flow=nets.flow, torque=nets.torque, opening_unit=nets.opening_unit, training=nets.training)
    edge = max(nets.members(), key=lambda m: m.silent_model.position)
    for chars in (nets, plain, edge):
        kernel, params = chars.numba_kernel()
        flow, torque = chars.numba_value_kernels()
        full = np.array([kernel(params, n, x) for n, x in zip(nn, aa)])
        values = np.array([[flow(params, n, x), torque(params, n, x)] for n, x in zip(nn, aa)])
        np.testing.assert_allclose(values, full[:, [0, 3]], rtol=1e-15, atol=1e-300)
    # the failing case beside it: the nets' values alone differ from the blended kernel below the lowest line
    kernel, params = nets.numba_kernel()
    assert abs(plain.numba_value_kernels()[0](params, 60.0, 2.0) - kernel(params, 60.0, 2.0)[0]) > 1e-4


def test_a_corrupted_ensemble_member_is_refused_naming_it(nets):
    """A member whose weights were damaged (one hidden weight times 10) departs from the point net far beyond what
    members of one ensemble depart by (0.5 % in the median at most on the shipped chart): refused, naming it."""
    doc = json.loads(nets.to_json())
    HillNets.from_dict(json.loads(json.dumps(doc)))  # as written: loads
    # its flow net's strongest hidden unit: 357 % of the range on the shipped nets (the same damage to a torque net
    # departs by 28-34 % or not at all, as the unit's share of the output varies between members)
    w2 = doc["ensemble"][4]["flow"]["W2"]
    w2[int(np.argmax(np.abs(w2)))] *= 10.0
    with pytest.raises(InputError,
                       match=r"ensemble\[4\].flow departs from the point net by \d+% .* median .* allowed 25%"):
        HillNets.from_dict(doc)


def test_no_flow_passes_shut_vanes_at_any_speed(nets):
    """Below half the lowest opening the table answers at every N11 (its last values held beyond its range, 1.5 x
    the chart's largest N11): at shut vanes Q11 is 0 up to 400 r/min, so a shutdown never runs flow backwards through
    them. The failing case beside it: the flow net alone pumps backwards there (-0.011 m^3/s at high N11; -0.125
    with the nets of an earlier extension), which the simulator followed when the physical
    model's pumping limit handed the characteristics back to the nets."""
    n11 = np.linspace(0.0, 400.0, 81)
    assert np.all(nets.q11(n11, 0.0) == 0.0) and np.all(nets.q11(n11, 1.0) > 0.0)
    assert nets.silent_model.n11_top < 400.0
    assert np.min(nets.flow.evaluate(n11, 0.0)[0]) < -0.005
