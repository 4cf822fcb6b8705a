"""The governor's modes (``governor.mode``, registry :data:`simulate.components.registry.GOVERNORS`) against their
closed-form steady states, each beside the mode that settles elsewhere, and the keys of one mode refused under
another:

* power: on the grid plant's island, a load step moves the frequency by df; the electrical power settles at
  P_ref - df / b_p (the stroke-droop PID of the speed mode settles elsewhere); on its infinite bus, the bus frequency
  steps by dx_bus and the power settles at P_ref - dx_bus / b_p exactly (the speed mode at y0 - dx_bus / b_p);
* opening: the stroke goes to the opening reference through the servo and stays there through a load step;
* dashpot: the speed settles on the permanent droop's line x = x_ref - b_p (y - y0).
"""

import tomllib

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.components.control.governor import GovernorConfig
from simulate.components.registry import GOVERNORS
from simulate.config import apply_overrides, plant_from_dict, read_plant_toml
from simulate.loop.engine import run_simulation

GRID = PLANT_HLA339.parent / "plant_hla339_grid.toml"
PID = ("kp", "ki", "kd", "derivative_filter_s", "permanent_droop")
#: the [governor] keys every mode shares (the shipped plant's servo and limits)
COMMON = dict(servo_time_s=0.2, closing_time_s=12.0, opening_time_s=20.0)


def _plant(path, overrides, drop=()):
    """The plant file with ``overrides`` and without the [governor] keys ``drop`` (a mode refuses the keys it does
    not read)."""
    raw = tomllib.loads(read_plant_toml(path)[1].decode())
    apply_overrides(raw, overrides)
    for key in drop:
        raw["governor"].pop(key)
    return plant_from_dict(raw, base_dir=path.parent)


def test_a_key_of_one_mode_is_refused_under_another_and_a_mode_asks_for_its_keys():
    pid = dict(kp=2.0, ki=0.4, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.04)
    dashpot = dict(permanent_droop=0.04, transient_droop=0.3, dashpot_time_s=5.0, pilot_servo_time_s=0.05,
                   gate_servo_time_s=0.2)
    assert GovernorConfig(**COMMON, **pid, mode="power", power_reference_mw=150.0).power_reference_mw == 150.0
    assert GovernorConfig(**COMMON, **dashpot, mode="dashpot").dashpot_time_s == 5.0
    assert GovernorConfig(**COMMON, mode="opening", opening_reference=0.5).opening_reference == 0.5
    with pytest.raises(InputError, match=r"governor\.power_reference_mw is a key of governor\.mode = 'power'; with "
                                         r"mode = 'speed' it would be ignored"):
        GovernorConfig(**COMMON, **pid, power_reference_mw=150.0)
    with pytest.raises(InputError, match=r"governor\.kp is a key of governor\.mode = 'speed' or 'power'; with mode "
                                         r"= 'opening' it would be ignored"):
        GovernorConfig(**COMMON, mode="opening", kp=2.0)
    with pytest.raises(InputError, match=r"governor\.transient_droop is a key of governor\.mode = 'dashpot'"):
        GovernorConfig(**COMMON, **pid, transient_droop=0.3)
    with pytest.raises(InputError, match=r"governor\.mode = \"dashpot\" needs governor\.dashpot_time_s and "
                                         r"governor\.gate_servo_time_s$"):
        GovernorConfig(**COMMON, mode="dashpot", permanent_droop=0.04, transient_droop=0.3, pilot_servo_time_s=0.05)
    with pytest.raises(InputError, match=r"governor\.opening_reference must be in \[governor\.stroke_min, "
                                         r"governor\.stroke_max\] = \[0\.0, 0\.9\], got 0\.95"):
        GovernorConfig(**COMMON, mode="opening", opening_reference=0.95, stroke_max=0.9)
    with pytest.raises(InputError, match=r"governor\.mode must be one of speed, power, opening, dashpot, level; got "
                                         r"'pid'"):
        GovernorConfig(**COMMON, **pid, mode="pid")
    # every optional key of the section belongs to a mode or a servo (none is accepted and read by nobody)
    owned = {k for name in GOVERNORS.names() for k in GOVERNORS.attribute(name, "GOVERNOR_KEYS", ())}
    assert owned == set(GovernorConfig.mode_keys())


def test_opening_mode_refuses_a_scenario_that_steps_the_speed_reference():
    plant = _plant(PLANT_HLA339, {"scenario.kind": "frequency-steps", "scenario.t_end_s": 20.0,
                                  "governor.mode": "opening", "turbine.characteristics": "ideal"}, drop=PID)
    with pytest.raises(InputError, match=r"governor\.mode = 'opening' holds the opening and has no speed reference: "
                                         r"the speed steps of scenario\.kind = 'frequency-steps' would be ignored"):
        run_simulation(plant)


def test_a_control_that_reads_a_signal_the_shaft_does_not_give_is_refused():
    """The swing rotor has no grid: a control reading grid_frequency_hz is refused before the run (never fed NaN);
    the sub-transient machine gives it."""
    from dataclasses import replace

    from simulate.components.registry import CompiledPart, PartHooks
    from simulate.components.signals import check_provided, provided
    from simulate.components.shaft.rotor import rotor_shaft_step, rotor_speed, rotor_electrical_power

    control = CompiledPart("control", "user", {}, (), (), hooks=PartHooks(reads=("speed_rpm", "grid_frequency_hz")))
    swing = CompiledPart("shaft", "rotor", {"speed": rotor_speed, "step": rotor_shaft_step,
                                            "power": rotor_electrical_power}, (), ())
    with pytest.raises(InputError, match=r"the control 'user' reads grid_frequency_hz, which the shaft 'rotor' does "
                                         r"not give \(it gives speed_rpm, electrical_power_mw, turbine_power_mw, "
                                         r"net_head_m, vane_stroke\)"):
        check_provided(control, swing)
    with_grid = replace(swing, functions={**swing.functions, "grid_frequency": rotor_speed})
    check_provided(control, with_grid)
    assert "grid_frequency_hz" in provided(with_grid)


def _settle(result, seconds=4.0):
    """The largest change of the speed and the stroke over the run's last ``seconds``: how far the final transient
    still moves them."""
    tail = result.time_s >= result.time_s[-1] - seconds
    return max(np.ptp(result.speed_rpm[tail] / result.rated_speed_rpm), np.ptp(result.opening[tail]))


@pytest.mark.slow
def test_power_mode_settles_the_electrical_power_on_its_droop_line_after_a_frequency_step():
    """Grid plant, island: the load steps +10 % at 1 s and the frequency falls by df; with the droop b_p = 0.04 on
    the electrical power the unit settles at P = P_ref - df / b_p (per unit of the rated power; P_ref the initial
    180 MW), and df itself at its closed form -b_p P0 dL / (1 + b_p P0 (1 + dL)) (the impedance load at V = 1 (the
    excitation's integral) takes P0 (1 + dL)(1 + x), frequency_p = 1)."""
    b_p, p0, step = 0.04, 180.0 / 225.0, 0.1
    # the quasi-steady loss: the convolution's slowest memory (B* of a 6 m penstock, about 240 s) would still move
    # the power by 1e-8 at the end, and the closed form is the governor's
    keys = {"scenario.event_time_s": 1.0, "scenario.t_end_s": 120.0, "governor.permanent_droop": b_p,
            "penstock.friction_model": "steady"}
    power = run_simulation(_plant(GRID, {**keys, "governor.mode": "power"}))
    df = power.signals["frequency_hz"][-1] / 50.0 - 1.0
    p_e = power.signals["electrical_power_pu"][-1] * 250.0 / 225.0  # machine base (250 MVA) -> turbine base
    # the last 4 s move speed and stroke by < 1e-11 (measured 2e-12): the transient has died away, and what is left
    # of the droop line's residual is the network's and the pressure loop's tolerances (1e-10 of the head): 1e-8
    assert _settle(power) < 1e-11
    assert p_e == pytest.approx(p0 - df / b_p, abs=1e-8)
    assert df == pytest.approx(-b_p * p0 * step / (1.0 + b_p * p0 * (1.0 + step)), abs=1e-9)
    # the initial power, solved to the steady state's tolerance (measured 1e-13 MW off)
    assert power.summary()["power_reference_mw"] == pytest.approx(180.0, abs=1e-9)
    # beside it, the speed mode's droop on the stroke settles elsewhere: 0.0128 pu off that line
    speed = run_simulation(_plant(GRID, keys))
    assert _settle(speed) < 1e-11
    df = speed.signals["frequency_hz"][-1] / 50.0 - 1.0
    p_e = speed.signals["electrical_power_pu"][-1] * 250.0 / 225.0
    assert abs(p_e - (p0 - df / b_p)) > 0.01


#: the grid plant on an infinite bus (x_line 0.3 pu) at 180 MW, the bus frequency stepping +0.002 pu (+0.1 Hz) at
#: 1 s; b_p = 0.04 and PI gains that damp the electromechanical mode (1.15 Hz) under the power feedback (with the
#: shipped kp 2, kd 0.5 the power mode undamps it: 0.35 pu of power peak to peak 60 s after the step)
BUS_STEP = {"grid.kind": "infinite-bus", "grid.x_line_pu": 0.3, "grid.bus_voltage_pu": 1.0, "grid.load_model": None,
            "grid.load_power_factor": None, "grid.frequency_p": None, "grid.frequency_q": None,
            "scenario.kind": "grid-frequency-step", "scenario.initial_power_mw": 180.0,
            "penstock.friction_model": "steady",  # the closed forms are the governor's (see the island case)
            "scenario.grid_frequency_steps": [0.002], "scenario.step_times_s": [1.0], "scenario.t_end_s": 160.0,
            "governor.permanent_droop": 0.04, "governor.kp": 0.5, "governor.ki": 2.0, "governor.kd": 0.0}


@pytest.mark.slow
def test_power_mode_settles_the_electrical_power_at_its_droop_after_a_bus_frequency_step():
    """Infinite bus: the unit pulls into step at the bus's frequency, x = dx_bus (the angle's equation), and with
    the integral at rest e = -x - b_p (P - P_ref) = 0 gives P = P_ref - dx_bus / b_p exactly: 0.8 - 0.05 = 0.75 of
    the rated power (P_ref the initial 180 MW)."""
    b_p, dx_bus, p_ref = 0.04, 0.002, 180.0 / 225.0
    power = run_simulation(_plant(GRID, {**BUS_STEP, "governor.mode": "power"}))
    p_e = power.signals["electrical_power_pu"] * 250.0 / 225.0  # machine base (250 MVA) -> turbine base
    x = power.speed_rpm / power.rated_speed_rpm - 1.0
    last = power.time_s >= power.time_s[-1] - 10.0
    # the last 10 s move P by 6e-11 (measured); the slowest mode left decays at 0.14 /s (measured: x16 in 20 s), so
    # what remains of it at the end is below 6e-11 / (1 - e^-1.4) = 8e-11; 1e-9 leaves room for the pressure loop's
    # tolerance (1e-10 of the head) and the network's
    assert np.ptp(p_e[last]) < 1e-9
    assert p_e[-1] == pytest.approx(p_ref - dx_bus / b_p, abs=1e-9)
    assert x[-1] == pytest.approx(dx_bus, abs=1e-12)  # in step with the bus (measured 6e-15 off)
    # beside it, the speed mode's droop on the stroke settles the stroke at y0 - dx_bus / b_p (its integral's time
    # 1 / (ki b_p) = 12.5 s leaves 2e-7 of drift in the last 10 s: 1e-6) and the power 0.0196 off the power mode's
    # line (the bound half that: the gap is the turbine's power-stroke slope, which the characteristics set)
    speed = run_simulation(_plant(GRID, BUS_STEP))
    assert speed.opening[-1] == pytest.approx(speed.opening[0] - dx_bus / b_p, abs=1e-6)
    p_speed = speed.signals["electrical_power_pu"][-1] * 250.0 / 225.0
    assert abs(p_speed - (p_ref - dx_bus / b_p)) > 0.01


@pytest.mark.slow
def test_opening_mode_holds_the_opening_at_its_reference():
    """Load step on the shipped unit (swing rotor): the opening mode takes the stroke from y0 to the reference
    y0 - 0.1 through the servo (rate limited, then its lag) and holds it whatever the speed does."""
    keys = {"scenario.kind": "load-step", "scenario.initial_power_mw": 180.0, "scenario.event_time_s": 10.0,
            "scenario.t_end_s": 30.0, "turbine.characteristics": "ideal", "penstock.model": "rigid",
            "solver.dt_s": 0.02}
    speed = run_simulation(_plant(PLANT_HLA339, keys))
    y0 = speed.opening[0]
    held = run_simulation(_plant(PLANT_HLA339, {**keys, "governor.mode": "opening",
                                                "governor.opening_reference": y0 - 0.1}, drop=PID))
    # 0.1 of stroke at 1/12 a second closes in 1.2 s, then the lag e^(-t/0.2) leaves 1e-16 within 8 s: from 9 s
    # on the stroke is the reference to rounding (1e-12), through the load step at 10 s
    after = held.time_s >= 9.0
    np.testing.assert_allclose(held.opening[after], y0 - 0.1, rtol=0, atol=1e-12)
    assert held.summary()["opening_reference"] == pytest.approx(y0 - 0.1)
    assert abs(held.speed_rpm[-1] - held.speed_rpm[after][0]) > 1.0  # the speed is left to the load step
    # beside it, the speed mode moves the stroke after the load step
    assert np.max(np.abs(speed.opening[after] - speed.opening[after][0])) > 0.01


@pytest.mark.slow
def test_dashpot_mode_settles_on_the_permanent_droop_line():
    """Load step -10 % on the shipped unit: the dashpot's transient droop decays, the speed settles at
    x = -b_p (y - y0) (x_ref = 0) with b_p = 0.04; the pilot servo and the integrator are at rest."""
    b_p = 0.04
    keys = {"scenario.kind": "load-step", "scenario.initial_power_mw": 180.0, "scenario.event_time_s": 1.0,
            "scenario.load_step": -0.1, "scenario.t_end_s": 150.0, "turbine.characteristics": "ideal",
            "penstock.model": "rigid", "solver.dt_s": 0.02, "governor.mode": "dashpot",
            "governor.permanent_droop": b_p, "governor.transient_droop": 0.4, "governor.dashpot_time_s": 6.0,
            "governor.pilot_servo_time_s": 0.05, "governor.gate_servo_time_s": 0.2}
    run = run_simulation(_plant(PLANT_HLA339, keys, drop=PID[:4]))
    x = run.speed_rpm / run.rated_speed_rpm - 1.0
    y0 = run.opening[0]
    # the last 4 s move speed and stroke by < 1e-10 (the slowest mode, the dashpot's T_r, has decayed e^-24): the
    # droop line holds to 1e-9 (pu speed; the moved stroke is 0.07)
    assert _settle(run) < 1e-10
    assert x[-1] == pytest.approx(-b_p * (run.opening[-1] - y0), abs=1e-9)
    assert run.opening[-1] < y0 - 0.03  # it moved along the line: a load step down closed the vanes
    # beside it, without the permanent droop the speed returns to rated: x = 0, off the line by 0.003
    free = run_simulation(_plant(PLANT_HLA339, {**keys, "governor.permanent_droop": 0.0}, drop=PID[:4]))
    assert abs(free.speed_rpm[-1] / free.rated_speed_rpm - 1.0) < 1e-9
    assert abs(-b_p * (free.opening[-1] - y0)) > 1e-3
