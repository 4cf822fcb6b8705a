"""Water-column separation in the method of characteristics (:mod:`simulate.components.hydraulic.cavitation`): the
vapour pressure, the discrete vapour cavity model against the wave solution of a frictionless pipe, no change where
the pressure stays above the vapour pressure, the failing cases with the model off, its keys and its report."""

import math

import numpy as np
import pytest

from hillchart.constants import G_M_S2
from hillchart.errors import InputError
from simulate.components.hydraulic.cavitation import vapour_pressure_head_m, vapour_pressure_pa
from simulate.config import (GeneratorConfig, GovernorConfig, PenstockConfig, PenstockSegment, PlantConfig,
                             ScenarioConfig, SolverConfig, TurbineConfig)
from simulate.loop.engine import run_simulation
from tests.simulate.components.test_friction import valve_plant
from tests.scripts import load_script

LENGTH_M, WAVE_SPEED_M_S, DIAMETER_M, V0_M_S = 1000.0, 1000.0, 0.5, 0.5
AXIS_M = 12.0  # the horizontal pipe's axis above the datum (the valve's outlet): the vapour head stays positive
EVENT_S = 0.1


def horizontal_plant(static_head_m: float, column_separation: str = "dvcm", t_end_s: float = 6.0,
                     profile: bool = True) -> PlantConfig:
    """A frictionless horizontal pipe (1000 m, a = 1000 m/s, 20 reaches, axis 12 m above the datum, or without a
    profile) from a reservoir to a valve (the ideal turbine at full stroke passing V0 = 0.5 m/s) shut at once at
    0.1 s."""
    flow = V0_M_S * math.pi * DIAMETER_M ** 2 / 4.0
    turbine = TurbineConfig(rated_head_m=static_head_m, rated_flow_m3_s=flow, rated_speed_rpm=1500.0,
                            rated_power_mw=0.9 * G_M_S2 * flow * static_head_m * 1e-3, runner_diameter_m=0.3,
                            opening_max=1.0, characteristics="ideal")
    seg = PenstockSegment(length_m=LENGTH_M, diameter_m=DIAMETER_M, wave_speed_m_s=WAVE_SPEED_M_S, darcy_friction=0.0,
                          **(dict(elevation_start_m=AXIS_M, elevation_end_m=AXIS_M) if profile else {}))
    penstock = PenstockConfig(model="moc", static_head_m=static_head_m, reaches=20, segments=(seg,),
                              column_separation=column_separation, friction_model="steady")  # f = 0: no friction
    governor = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0, servo_time_s=0.2,
                              closing_time_s=10.0, opening_time_s=20.0)
    scenario = ScenarioConfig(kind="closure-law", t_end_s=t_end_s, initial_opening=1.0, event_time_s=EVENT_S,
                              closing_time_s=0.0)
    return PlantConfig(turbine=turbine, penstock=penstock, generator=GeneratorConfig(inertia_time_s=8.0),
                       governor=governor, scenario=scenario, solver=SolverConfig())


def test_vapour_pressure_is_the_iapws_saturation_line():
    """IF97 eq. (30) at its check point (table 35: T = 300 K, p = 3.53658941 kPa, given to 9 digits); at 100 degC
    the normal boiling point 101.325 kPa within the formulation's 0.1 % there; a wrong temperature scale (K given as
    degC) is refused."""
    assert vapour_pressure_pa(26.85) == pytest.approx(3536.58941, rel=1e-8)
    assert vapour_pressure_pa(100.0) == pytest.approx(101325.0, rel=1e-3)
    assert vapour_pressure_pa(100.0) != pytest.approx(101325.0, rel=1e-4)  # 101418 Pa: IF97's own value
    assert vapour_pressure_head_m(20.0) == pytest.approx(2339.2 / (1000.0 * G_M_S2), rel=1e-4)
    with pytest.raises(InputError, match=r"water temperature must be a number in \[0.0, 100.0\] degC, got 293.15"):
        vapour_pressure_pa(293.15)


@pytest.fixture(scope="module")
def cavity_run():
    # H0 - H_v = 35 m lies between a V0 / (2 g) = 25.5 m and a V0 / g = 51.0 m: one cavity at the valve, which opens
    # when the reflected down-surge arrives (2 L / a) and closes before the next one
    return run_simulation(horizontal_plant(37.0))


def test_a_valve_cavity_follows_the_wave_solution(cavity_run):
    """Frictionless pipe, instantaneous closure (Wylie and Streeter's column separation at a closed valve): at 2 L/a
    the down-surge H0 - a V0 / g would fall below the vapour head H_v, so the valve holds H_v and the column leaves
    it at V1 = V0 - g (H0 - H_v) / a; the reservoir's reflection returns at 4 L/a with V2 = -V0 + 2 g (H0 - H_v) / a
    and the column closes the cavity at V3 = V2 + g (H0 - H_v) / a. Largest volume A V1 2 L / a; collapse after
    A V1 (2 L / a) / (A V3) more; collapse head H0 + a V2 / g. The MOC at Courant number 1 is exact for these
    piecewise-constant waves; the cavity's volume is integrated by steps of dt (psi = 1), so its largest volume is
    exact to rounding (measured 3e-15 relative) and the collapse time within one step."""
    r, dt = cavity_run, cavity_run.meta["dt_s"]
    s = r.summary()
    area = math.pi * DIAMETER_M ** 2 / 4.0
    v0 = r.flow_m3_s[0] / area
    h0, hv = 37.0, AXIS_M - s["atmospheric_pressure_head_m"] + s["vapour_pressure_head_m"]
    g, a, travel = G_M_S2, WAVE_SPEED_M_S, LENGTH_M / WAVE_SPEED_M_S
    v1 = v0 - g * (h0 - hv) / a
    v2 = -v0 + 2.0 * g * (h0 - hv) / a
    v3 = v2 + g * (h0 - hv) / a
    assert s["max_cavity_volume_m3"] == pytest.approx(area * v1 * 2.0 * travel, rel=1e-12)
    assert s["max_cavity_x_m"] == LENGTH_M and s["cavity_nodes"] == 1
    assert s["t_first_cavity_s"] - EVENT_S == pytest.approx(2.0 * travel, abs=1e-9)
    cavity = r.signals["outlet_cavity_volume_m3"]
    closed = np.flatnonzero(cavity > 0.0)[-1] + 1
    t_collapse = 4.0 * travel + 2.0 * travel * v1 / v3
    assert abs(r.time_s[closed] - EVENT_S - t_collapse) <= dt
    collapse_head = h0 + a * v2 / g
    assert r.head_m[closed + 1] == pytest.approx(collapse_head, rel=1e-9)
    # by hand: 3 H0 - 2 H_v - a V0 / g = 111 - 3.817 - 50.968, below the Joukowsky peak H0 + a V0 / g = 87.97 m
    assert collapse_head == pytest.approx(56.215, abs=0.001)
    # the valve held the vapour head while the cavity was open, and the head never went below it anywhere
    assert np.all(r.head_m[np.flatnonzero(cavity > 0.0)] == pytest.approx(hv, abs=1e-12))
    assert r.envelope_min_m.min() >= hv - 1e-9


def test_off_refuses_the_same_closure_with_todays_message(cavity_run):
    """The failing case beside the passing one: without column separation the valve's head falls below the datum
    at 2 L/a and the turbine boundary stops the run as it always did."""
    off = run_simulation(horizontal_plant(37.0, "off"), raise_on_failure=False)
    assert not off.success
    assert "no solution with a positive net head" in off.message and 'column_separation = "dgcm"' in off.message
    assert off.time_s[-1] - EVENT_S == pytest.approx(2.0 * LENGTH_M / WAVE_SPEED_M_S, abs=0.06)
    assert cavity_run.success and cavity_run.time_s[-1] == pytest.approx(6.0)


def test_no_cavity_no_change_to_the_last_bit():
    """The Allievi closure of the friction tests (52 m of water hammer on 100 m of head) stays above the vapour
    pressure: with the DVCM the run is the same to the last bit as with column separation off, and its cavity columns
    are zeros; the cavitating closure above differs from the same closure off (it fails there)."""
    on = run_simulation(valve_plant(t_end_s=5.0, column_separation="dvcm"))
    off = run_simulation(valve_plant(t_end_s=5.0, column_separation="off"))
    for name in ("head_m", "flow_m3_s", "speed_rpm", "torque_nm"):
        assert np.array_equal(getattr(on, name), getattr(off, name)), name
    assert np.array_equal(on.envelope_min_m, off.envelope_min_m)
    assert np.all(on.signals["cavity_volume_m3"] == 0.0) and "cavity_volume_m3" not in off.signals
    assert on.summary()["max_cavity_volume_m3"] == 0.0 and on.summary()["cavity_nodes"] == 0
    assert not any("vapour cavity" in w for w in on.summary()["warnings"])


def test_a_boiling_steady_state_is_refused_naming_the_profile():
    """The horizontal pipe's axis 12 m above the datum puts its vapour head at 12 - 10.33 + 0.24 = 1.91 m: a
    reservoir 1.5 m above the datum would have the water boil in steady flow, which neither cavity model starts from
    (the DVCM opened cavities at every node at the first step); the error names the profile keys and their values.
    The passing case beside: 2.5 m runs."""
    for model in ("dvcm", "dgcm"):
        with pytest.raises(InputError, match=rf"penstock.column_separation = '{model}': the steady head at node 1 "
                                             r"\(x = 50 m\), 1.5 m, is not above its vapour head 1.908 m \(the pipe "
                                             r"axis there from penstock.segments.elevation_start_m = 12 and "
                                             r"penstock.segments.elevation_end_m = 12 of segment 1\)"):
            run_simulation(horizontal_plant(1.5, model, t_end_s=0.5))
        assert run_simulation(horizontal_plant(2.5, model, t_end_s=0.5)).success


def test_the_report_names_place_and_time(cavity_run):
    s = cavity_run.summary()
    warning = next(w for w in s["warnings"] if "vapour cavity" in w)
    assert "x = 1000 m from the pipe's inlet (node 20 of 20) at t = 2.1 s" in warning
    # the wave at the vapour pressure passing node 1 leaves a cavity of rounding there (2.8e-18 m^3, 3e-19 of the
    # pipe's volume per node), not reported
    assert sum("vapour cavity" in w for w in s["warnings"]) == 1
    assert f"largest volume {s['max_cavity_volume_m3']:.3g} m^3 at t = {s['t_max_cavity_s']:.4g} s" in warning
    # the lowest absolute pressure along the profile is the vapour pressure, reached first upstream of the valve
    assert s["min_absolute_pressure_head_m"] == pytest.approx(s["vapour_pressure_head_m"], abs=1e-9)
    assert s["min_absolute_pressure_kpa"] == pytest.approx(2.339, abs=1e-3)
    assert 0.0 < s["t_min_absolute_pressure_s"] < cavity_run.time_s[-1]
    assert s["column_separation"] is True  # the envelope's flag follows the cavities, without its own warning
    assert not any("which the model does not represent" in w for w in s["warnings"])


def test_a_turbine_held_at_a_negative_vapour_head_stops_with_the_cavity_named():
    """Without a profile the axis is at the datum, so the vapour head at the valve is -10.1 m: a shut valve's net
    head is then not positive, which the turbine boundary does not cover; the message says the cavity held it (the
    same closure with the axis 12 m up runs, above)."""
    r = run_simulation(horizontal_plant(37.0, profile=False), raise_on_failure=False)
    assert not r.success
    assert "a vapour cavity holds the downstream end of the pipe (the turbine inlet) at the vapour head, -10.1 m" in \
        r.message
    assert "the pipe axis is taken at the tailwater level" in r.message
    # the gas cavity model's words: its gas adds a partial pressure to the vapour's
    gas = run_simulation(horizontal_plant(37.0, "dgcm", profile=False), raise_on_failure=False)
    assert not gas.success
    assert "a gas cavity holds the downstream end of the pipe (the turbine inlet) at about the vapour head, -10.1 m" \
        in gas.message and "discrete gas cavity model" in gas.message


@pytest.mark.parametrize("keys,match", [
    (dict(column_separation="off", water_temperature_c=40.0),
     r"penstock.water_temperature_c = 40.0 is a key of penstock.column_separation = 'dvcm' or 'dgcm'; with "
     r"column_separation = 'off' it would be ignored"),
    (dict(column_separation="off", cavity_weighting=0.5), r"penstock.cavity_weighting = 0.5 is a key of"),
    (dict(cavity_weighting=0.3), r"penstock.cavity_weighting must be in \[0.5, 1.0\], got 0.3"),
    (dict(water_temperature_c=120.0), r"penstock.water_temperature_c must be in \[0.0, 100.0\], got 120.0"),
    (dict(column_separation="gas"), r"penstock.column_separation must be one of dvcm, dgcm, off; got 'gas'"),
    (dict(model="rigid", water_temperature_c=30.0),
     r"penstock.water_temperature_c = 30.0 is read only by penstock.model = moc; with model = 'rigid'"),
    (dict(model="rigid", column_separation="off"), r"penstock.column_separation = 'off' is read only by"),
])
def test_the_keys_are_refused_where_they_would_be_ignored(keys, match):
    seg = PenstockSegment(length_m=400.0, diameter_m=2.0, wave_speed_m_s=1000.0, darcy_friction=0.01)
    with pytest.raises(InputError, match=match):
        PenstockConfig(**{"model": "moc", "static_head_m": 100.0, "reaches": 4, "segments": (seg,), **keys})
    PenstockConfig(model="moc", static_head_m=100.0, reaches=4, segments=(seg,), water_temperature_c=40.0,
                   atmospheric_pressure_head_m=9.0, cavity_weighting=0.5)
    PenstockConfig(model="rigid", static_head_m=100.0, reaches=4, segments=(seg,))  # the default is not "set"


def _rig():
    return load_script("bench_column_separation")


def test_bergant_simpson_rig_with_the_defaults_meets_the_measured_peaks_and_converges():
    """The sloping copper pipe of Bergant and Simpson (37.23 m, 22.1 mm, a = 1319 m/s, rising 2.03 m to a valve shut
    in 9 ms < 2 L/a, tank 22 m above the pipe's upstream end; ``benchmarks/bench_column_separation.py``) with the
    default settings (the convolution friction, the discrete gas cavity model) at dt and dt/2 (256 and 512 reaches).
    The collapse peaks measured at the valve (He et al. 2025 after Bergant and Simpson 1999: 1015 kPa at 0.3 m/s,
    2057 kPa at 1.4 m/s, absolute): 1063 / 1062 kPa (+4.7 %) and 2061 / 2060 kPa (+0.2 / +0.1 %), bound 5 %; the
    first collapse at 1.4 m/s rises through 1000 kPa at 371.2 ms against the digitized trace's 387.8 ms (-4.3 %,
    bound 5 %). dt and dt/2 agree on the collapse peaks to 0.06 % and 0.07 % (bound 1 %), on the first peak to 0.01 %
    (bound 0.1 %) and on the time the valve's first cavity closed (interpolated within the step) to 0.05 % (bound
    1 %). The first peak lies above Joukowsky's rho a V0 over the initial pressure: the line packing of the friction
    adds to it. On a coarser grid (128 reaches) the 1.4 m/s collapse peak is 2074 kPa, 0.6 % off the 256 reaches'
    (bound 2 %; the benchmark's grid scan): the valve's cavity decided from the boundary flow foreseen, not from the
    last step's, leaves no spike of one step there (2195 kPa, +6.5 %, when it was decided from the last step's).
    The failing case: with column separation off the valve's head falls below its datum and the run stops."""
    rig = _rig()
    measured_rise = rig.window_peaks(*rig.measured_trace())["first collapse"][1]
    for v in (0.3, 1.4):
        coarse, fine = (rig.run_simulation(rig.rig_plant(v, reaches=n, t_end_s=rig.TRACE_END_S))
                        for n in (256, 512))
        assert coarse.meta["column_separation_model"] == "dgcm"
        assert coarse.meta["convolution_weighting"] == "vardy-brown"  # the convolution friction
        p, q = rig.peaks(coarse), rig.peaks(fine)
        f = rig.blasius_friction(v)
        friction_head = f * rig.LENGTH_M / rig.DIAMETER_M * v ** 2 / (2 * G_M_S2)
        initial = (rig.TANK_HEAD_M - rig.RISE_M - friction_head + 10.33) * G_M_S2  # kPa, absolute
        assert q.first_kpa > initial + rig.WAVE_SPEED_M_S * v  # rho a V0 in kPa with rho = 1000 kg/m^3
        assert abs(p.first_kpa / q.first_kpa - 1.0) < 1e-3
        assert abs(p.cavity_closed_t_s / q.cavity_closed_t_s - 1.0) < 1e-2, v
        for run in (p, q):
            assert abs(run.collapse_kpa / rig.MEASURED[v] - 1.0) < 0.05, v
        assert abs(p.collapse_kpa / q.collapse_kpa - 1.0) < 1e-2, v
        assert q.collapse_kpa == pytest.approx({0.3: 1062.4, 1.4: 2059.8}[v], rel=5e-3)  # as measured here
        if v < 1.0:
            assert q.collapse_kpa > 1.5 * q.first_kpa  # active column separation: the collapse pulse is the largest
        else:
            for run in (coarse, fine):
                rise = rig.window_peaks(run.time_s - rig.EVENT_TIME_S, rig.valve_pressure_kpa(run))[
                    "first collapse"][1]
                assert abs(rise / measured_rise - 1.0) < 0.05
            # the cavities' total volume converges (3.52e-5 m^3 on 64 to 1024 reaches; bound 1 %), the largest
            # cavity of one node does not (9.4 and 8.0 cm^3 at the valve: a zone of cavities shared among more nodes)
            total = [run.signals["cavity_volume_m3"].max() for run in (coarse, fine)]
            assert total[0] == pytest.approx(3.52e-5, rel=5e-3) and abs(total[1] / total[0] - 1.0) < 1e-2
            assert coarse.summary()["max_cavity_volume_m3"] / fine.summary()["max_cavity_volume_m3"] - 1.0 > 0.1
    coarser = rig.peaks(rig.run_simulation(rig.rig_plant(1.4, reaches=128))).collapse_kpa
    assert abs(coarser / p.collapse_kpa - 1.0) < 0.02
    # the failing case: with column separation off the valve's head falls below its datum and the run stops
    off = rig.run_simulation(rig.rig_plant(1.4, column_separation="off"), raise_on_failure=False)
    assert not off.success and "no solution with a positive net head" in off.message
    assert 'column_separation = "dgcm" or "dvcm" (not by "off"' in off.message


def test_bergant_simpson_rig_first_peak_with_steady_friction():
    """With the quasi-steady loss and the DVCM (32 and 64 reaches), the first peak at the valve is Joukowsky's
    rho a V0 above the initial pressure plus at most the friction head the shut pipe packs back (rho g h_f: 39 kPa at
    1.4 m/s, 2.6 kPa at 0.3 m/s); dt and dt/2 agree on it to 0.02 % (bound 0.1 %)."""
    rig = _rig()
    for v in (0.3, 1.4):
        coarse, fine = (rig.run_simulation(rig.rig_plant(v, reaches=n, friction_model="steady",
                                                         column_separation="dvcm")) for n in (32, 64))
        p, q = rig.peaks(coarse), rig.peaks(fine)
        f = rig.blasius_friction(v)
        friction_head = f * rig.LENGTH_M / rig.DIAMETER_M * v ** 2 / (2 * G_M_S2)
        initial = (rig.TANK_HEAD_M - rig.RISE_M - friction_head + 10.33) * G_M_S2  # kPa, absolute
        joukowsky = initial + rig.WAVE_SPEED_M_S * v
        assert joukowsky <= q.first_kpa <= joukowsky + friction_head * G_M_S2, v
        assert abs(p.first_kpa / q.first_kpa - 1.0) < 1e-3


def test_bergant_simpson_rig_against_the_peaks_measured():
    """The collapse peaks measured at the valve (He et al. 2025 after Bergant and Simpson 1999: 1015 kPa at 0.3 m/s,
    2057 kPa at 1.4 m/s, absolute), dt/2, steady friction: at 1.4 m/s the DVCM comes within 1.2 % (bound 5 %); at
    0.3 m/s it is 6.4 % above, outside 5 % (asserted as the gap it is), and Brunone's unsteady friction brings it to
    4.5 % (bound 5 %)."""
    rig = _rig()
    steady = {v: rig.peaks(rig.run_simulation(rig.rig_plant(v, reaches=64, friction_model="steady",
                                                            column_separation="dvcm"))).collapse_kpa
              for v in (0.3, 1.4)}
    assert abs(steady[1.4] / rig.MEASURED[1.4] - 1.0) < 0.05
    assert abs(steady[0.3] / rig.MEASURED[0.3] - 1.0) > 0.05  # the gap of the steady friction: 1080 kPa
    assert steady[0.3] == pytest.approx(1080.0, rel=5e-3)  # as the benchmark prints it (to the kPa: 0.05 %)
    brunone = rig.peaks(rig.run_simulation(rig.rig_plant(0.3, reaches=64, friction_model="brunone",
                                                         column_separation="dvcm")))
    assert abs(brunone.collapse_kpa / rig.MEASURED[0.3] - 1.0) < 0.05


def test_bergant_simpson_rig_with_the_convolution_friction():
    """Vardy and Brown's convolution friction on the rig (dt, dt/2: 32 and 64 reaches): at 1.4 m/s the DVCM's
    collapse peak is 1998 / 2015 kPa, 2.9 % / 2.0 % below the 2057 kPa measured (bound 5 %), and dt and dt/2 agree
    within 0.85 % (bound 1 %; Brunone's 2685 / 2399 kPa differ by 11 %, the steady loss's 2052 / 2081 by 1.4 %); at
    0.3 m/s 1069 kPa at both steps, 5.3 % above the 1015 kPa measured: still outside 5 % with the DVCM (asserted
    as the gap it is), inside with the DGCM (1061 / 1063 kPa, +4.6 / +4.8 %). Each figure pinned within 0.5 % of
    the value measured here."""
    rig = _rig()
    peaks = {(v, model, n): rig.peaks(rig.run_simulation(rig.rig_plant(
        v, reaches=n, friction_model="convolution", column_separation=model))).collapse_kpa
        for v, model, n in ((1.4, "dvcm", 32), (1.4, "dvcm", 64), (0.3, "dvcm", 64), (0.3, "dgcm", 64))}
    severe = peaks[1.4, "dvcm", 32], peaks[1.4, "dvcm", 64]
    assert severe == pytest.approx((1998.0, 2015.0), rel=5e-3)
    assert all(abs(p / rig.MEASURED[1.4] - 1.0) < 0.05 for p in severe)
    assert abs(severe[1] / severe[0] - 1.0) < 0.01
    assert peaks[0.3, "dvcm", 64] == pytest.approx(1069.0, rel=5e-3)
    assert peaks[0.3, "dvcm", 64] / rig.MEASURED[0.3] - 1.0 > 0.05
    assert peaks[0.3, "dgcm", 64] == pytest.approx(1063.0, rel=5e-3)
    assert abs(peaks[0.3, "dgcm", 64] / rig.MEASURED[0.3] - 1.0) < 0.05


def test_bergant_simpson_rig_against_the_measured_trace():
    """The measured valve pressure at 1.4 m/s (digitized from He et al. 2025, Fig. 4; ``benchmarks/data``), each
    pulse's largest pressure and the time it rises through 1000 kPa. The trace: 428 points, 6 of a horizontal line
    the digitizer followed left out (a failing case: with them the first collapse's top would read 2062 kPa, after
    the curve fell); the pulses 2102 kPa / 3.0 ms, 2035 kPa / 387.8 ms, 1871 kPa / 729.6 ms (to the digit printed).
    Computed on 64 reaches (pinned within 0.5 %, as measured here): the first collapse's top and rise with the
    steady loss 2081 kPa (+2.2 %) and 371.5 ms (-4.2 %), with the convolution 2015 kPa (-1.0 %) and 365.3 ms
    (-5.8 %); the second collapse 2161 kPa (+15.5 %) and 1638 kPa (-12.4 %): the steady loss keeps too much of the
    pulse, the convolution's DVCM damps too much of it; the convolution's DGCM 1827 kPa (-2.3 %) at 688.6 ms
    (-5.6 %)."""
    rig = _rig()
    t, p = rig.measured_trace()
    assert t.size == 422 and np.all(np.diff(t) >= 0.0)
    measured = rig.window_peaks(t, p)
    for name, (peak, rise) in {"water hammer": (2102.4, 0.0030), "first collapse": (2035.4, 0.3878),
                               "second collapse": (1870.9, 0.7296)}.items():
        assert measured[name][0] == pytest.approx(peak, abs=0.1)  # the file's digits
        assert measured[name][1] == pytest.approx(rise, abs=1e-4)
    raw = np.array([line.split(",") for line in rig.TRACE_PATH.read_text(encoding="utf-8").splitlines()
                    if line[:1].isdigit()], dtype=float)
    assert raw.shape[0] == 428
    window = (raw[:, 0] >= 0.25) & (raw[:, 0] < 0.5)
    assert raw[window, 1].max() == pytest.approx(2062.0, abs=0.1)  # what the artefact would make of the peak
    computed = {(f, m): rig.window_peaks(r.time_s - rig.EVENT_TIME_S, rig.valve_pressure_kpa(r))
                for f, m in (("steady", "dvcm"), ("convolution", "dvcm"), ("convolution", "dgcm"))
                for r in [rig.run_simulation(rig.rig_plant(1.4, friction_model=f, column_separation=m, reaches=64,
                                                          t_end_s=rig.TRACE_END_S))]}
    assert computed["steady", "dvcm"]["first collapse"][0] == pytest.approx(2081.0, rel=5e-3)
    assert computed["steady", "dvcm"]["first collapse"][1] == pytest.approx(0.3715, rel=5e-3)
    assert computed["convolution", "dvcm"]["first collapse"][0] == pytest.approx(2015.0, rel=5e-3)
    assert computed["convolution", "dvcm"]["first collapse"][1] == pytest.approx(0.3653, rel=5e-3)
    assert computed["steady", "dvcm"]["second collapse"][0] == pytest.approx(2161.0, rel=5e-3)
    assert computed["convolution", "dvcm"]["second collapse"][0] == pytest.approx(1638.0, rel=5e-3)
    assert computed["convolution", "dgcm"]["second collapse"] == pytest.approx((1827.0, 0.6886), rel=5e-3)
    for run in computed.values():  # every run's first collapse within 5 % of the measured top
        assert abs(run["first collapse"][0] / measured["first collapse"][0] - 1.0) < 0.05
