"""The upstream level as a named signal and the governor mode that reads it (``governor.mode = "level"``, the
headwater level controller of a run-of-river plant, :mod:`simulate.components.control.level_governor`).

The plant: the shipped surge-tank plant on the ideal turbine and the rigid column at part load (180 of 225 MW), its
tunnel rougher (Darcy f = 0.06: the tunnel's friction time L / (g A_t) / (2 K_t Q0), the slowest pole of the level
loop, 62 s instead of 300 s) and a stiff load (self-regulation 20: the speed, which the mode does not control, stays
within a few per mille). The level set point is stepped 0.1 m above the initial level at t = 0."""

import tomllib

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.components.registry import CompiledPart, PartHooks
from simulate.components.signals import SIGNALS, UPSTREAM_LEVEL_M, check_provided, initial_signals, provided
from simulate.config import apply_overrides, plant_from_dict, read_plant_toml
from simulate.loop.engine import run_simulation
from simulate.loop.prepare import initial_state

SURGE_TANK = PLANT_HLA339.parent / "plant_hla339_surge_tank.toml"
PID = ("kp", "ki", "kd", "derivative_filter_s", "permanent_droop")
BASE = {"turbine.characteristics": "ideal", "penstock.model": "rigid", "governor.mode": "level",
        "governor.level_kp": 1.0, "governor.level_ki": 0.2, "generator.self_regulation": 20.0,
        "surge_tank.tunnel_darcy_friction": 0.06, "scenario.kind": "load-step", "scenario.initial_power_mw": 180.0,
        "scenario.load_step": 0.0, "scenario.event_time_s": 1.0, "scenario.t_end_s": 600.0}
STEP_M = 0.1


def _plant(overrides, path=SURGE_TANK):
    """The plant file without the PID's keys (the level mode reads its own), with ``overrides``."""
    raw = tomllib.loads(read_plant_toml(path)[1].decode())
    for key in PID:
        raw["governor"].pop(key)
    apply_overrides(raw, overrides)
    return plant_from_dict(raw, base_dir=path.parent)


def _initial_level(plant) -> float:
    """The tank level at the steady state: the static level less the tunnel's loss K_t Q0^2 (the throttle passes no
    steady flow)."""
    flow = initial_state(plant).flow_m3_s
    return plant.penstock.static_head_m - plant.surge_tank.steady_loss_coefficient_s2_m5 * flow ** 2


@pytest.fixture(scope="module")
def level_step():
    """``(z_ref, result of k_i > 0, result of k_i = 0)`` for the set point 0.1 m above the initial level."""
    base = _plant(BASE)
    target = _initial_level(base) + STEP_M
    runs = [run_simulation(_plant({**BASE, "governor.level_setpoint_m": target, "governor.level_ki": ki}))
            for ki in (0.2, 0.0)]
    return target, *runs


def test_a_set_point_step_settles_the_level_on_the_set_point(level_step):
    """Integral action: at rest the error is zero. The residual decays with the tunnel's friction time (62 s,
    measured: 7e-5 m at 200 s, 1.4e-5 m at 300 s); after 600 s (about 10 of them) it is 1e-7 m, so 1e-5 m (1e-4 of
    the step) bounds it with margin, and the level has moved the whole 0.1 m."""
    target, result, _ = level_step
    assert result.success
    level, time_s = result.signals["surge_level_m"], result.time_s
    assert abs(level[0] - (target - STEP_M)) < 1e-9  # starts on the initial level
    tail = time_s >= time_s[-1] - 50.0
    assert np.max(np.abs(level[tail] - target)) < 1e-5
    # the vanes closed to pass less water (the level rises when less flow leaves the tank), the speed held by the load
    opening = result.columns()["opening"]
    assert opening[-1] < opening[0] - 0.005
    assert np.max(np.abs(result.columns()["speed_rpm"] / result.columns()["speed_rpm"][0] - 1.0)) < 0.01


def test_without_integral_action_a_steady_error_remains(level_step):
    """The failing case: k_i = 0 leaves the proportional law's error, at rest y - y0 = k_p (z - z_ref) exactly (the
    servo at rest holds the command): 0.0173 m, 17 % of the step, three orders above the tolerance the integral
    meets."""
    target, _, proportional = level_step
    level, opening = proportional.signals["surge_level_m"], proportional.columns()["opening"]
    error = level[-1] - target
    assert error < -0.01
    tail = proportional.time_s >= proportional.time_s[-1] - 50.0
    assert np.max(level[tail]) - np.min(level[tail]) < 1e-6  # at rest over the last 50 s
    # y - y0 = k_p e (opening is the stroke fraction; the servo's lag leaves 1e-9 at rest)
    assert abs((opening[-1] - opening[0]) - BASE["governor.level_kp"] * error) < 1e-7


def test_the_level_signal_is_the_upstream_parts_level():
    """The signals vector at t = 0 holds the surge tank's level (the steady z0) and, without a tank, the reservoir's
    (the static head); a part without a level function is NaN there and refused for a control that reads it."""
    from simulate.components.hydraulic.reservoir import build_reservoir
    from simulate.components.hydraulic.surge_tank import build_surge_tank
    from simulate.components.shaft.rotor import rotor_shaft_step, rotor_speed

    plant = _plant(BASE)
    steady = initial_state(plant)
    tank, reservoir = build_surge_tank(plant, steady, 0.02), build_reservoir(plant, steady, 0.02)
    shaft = CompiledPart("shaft", "rotor", {"speed": rotor_speed, "step": rotor_shaft_step}, (np.zeros(6),),
                         (np.array([200.0]),))
    control = CompiledPart("control", "governor", {}, (), (np.array([0.7]),),
                           hooks=PartHooks(reads=("upstream_level_m",)))
    assert SIGNALS[UPSTREAM_LEVEL_M] == "upstream_level_m"
    assert initial_signals(control, shaft, 170.0, 1e6, tank)[UPSTREAM_LEVEL_M] == pytest.approx(_initial_level(plant),
                                                                                                abs=1e-12)
    assert initial_signals(control, shaft, 170.0, 1e6, reservoir)[UPSTREAM_LEVEL_M] == plant.penstock.static_head_m
    check_provided(control, shaft, upstream=tank)
    check_provided(control, shaft, upstream=reservoir)
    silent = CompiledPart("upstream", "user_lake", {"head": tank.functions["head"]}, tank.params, tank.state)
    assert "upstream_level_m" not in provided(shaft, silent)
    assert np.isnan(initial_signals(control, shaft, 170.0, 1e6, silent)[UPSTREAM_LEVEL_M])
    with pytest.raises(InputError, match=r"unit 'U1': the control 'governor' reads upstream_level_m, which the "
                                         r"upstream part 'user_lake' does not give \(an upstream part gives it with a "
                                         r"function level\(p, s\)\)"):
        check_provided(control, shaft, "unit 'U1': ", upstream=silent)


def test_the_level_keys_are_the_modes_own():
    """``level_kp``, ``level_ki`` (required) and ``level_setpoint_m`` (optional) belong to mode level: refused under
    another mode, required by their own, validated by their declarations; the PID's keys are refused under it."""
    with pytest.raises(InputError, match=r"governor\.level_kp is a key of governor\.mode = 'level'"):
        _plant({**{k: v for k, v in BASE.items() if k != "governor.mode"}, "governor.mode": "opening"})
    with pytest.raises(InputError, match=r"governor.mode = \"level\" needs governor\.level_ki"):
        _plant({k: v for k, v in BASE.items() if k != "governor.level_ki"})
    with pytest.raises(InputError, match=r"governor\.level_setpoint_m"):
        _plant({**BASE, "governor.level_setpoint_m": -3.0})
    with pytest.raises(InputError, match=r"governor\.kp is a key of governor\.mode = "):
        _plant({**BASE, "governor.kp": 2.0})


def test_a_speed_reference_step_is_refused_under_the_level_mode():
    keys = {k: v for k, v in BASE.items() if not k.startswith("scenario.")}
    plant = _plant({**keys, "scenario.kind": "frequency-steps", "scenario.t_end_s": 10.0,
                    "scenario.speed_steps": [0.01], "scenario.step_times_s": [5.0]})
    with pytest.raises(InputError, match=r"governor\.mode = 'level' controls the upstream level and has no speed "
                                         r"reference"):
        run_simulation(plant)


def test_the_default_set_point_holds_the_initial_level():
    """Without ``level_setpoint_m`` the set point is the level at t = 0: the plant at rest stays there (the vanes
    still to the bit: the error is exactly zero at every step, so the PI's command is y0)."""
    result = run_simulation(_plant({**BASE, "scenario.t_end_s": 20.0}))
    assert np.all(result.columns()["opening"] == result.columns()["opening"][0])
    assert result.summary()["level_setpoint_m"] == "the initial level"


@pytest.mark.slow
def test_the_compiled_loop_fills_the_level_as_the_python_loop_does():
    """The MOC penstock (the compiled loop with the level's line and the surge tank's level function inlined) against
    the same text run as Python: the same arithmetic, equal to the bit (tolerance 0); the vanes moved (0.006 of a
    stroke in 20 s), so an unread or stale level would show."""
    over = {**BASE, "penstock.model": "moc", "scenario.t_end_s": 20.0}
    target = _initial_level(_plant(over)) + STEP_M
    plant = _plant({**over, "governor.level_setpoint_m": target})
    compiled, python = run_simulation(plant, jit=True), run_simulation(plant, jit=False)
    assert compiled.summary()["compiled"] and not python.summary()["compiled"]
    np.testing.assert_array_equal(compiled.signals["surge_level_m"], python.signals["surge_level_m"])
    np.testing.assert_array_equal(compiled.columns()["opening"], python.columns()["opening"])
    assert compiled.columns()["opening"][0] - compiled.columns()["opening"][-1] > 0.005
