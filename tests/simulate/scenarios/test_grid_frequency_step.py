"""The scenario kind ``grid-frequency-step``: the infinite bus's frequency steps; the rotor angle against the bus
obeys d delta/dt = omega_b (x - x_bus) and the named signal grid_frequency_hz reads f_n (1 + x_bus). Refused with its
reason where it cannot act (an island, the swing rotor, a unit off the bus)."""

from dataclasses import replace

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339, PLANT_HLA339_GRID
from hillchart.errors import InputError
from simulate.components.electrical.generator import P_OMEGA_B, S_DELTA
from simulate.components.shaft.generator_shaft import (
    build_subtransient,
    subtransient_grid_frequency,
    subtransient_shaft_step,
)
from simulate.config import load_plant
from simulate.loop.engine import initial_state, plant_schedules, run_simulation

#: the grid plant on an infinite bus (x_line 0.3 pu, bus at 1 pu): the island's keys left out
BUS = {"turbine.characteristics": "ideal", "grid.kind": "infinite-bus", "grid.load_model": None,
       "grid.load_power_factor": None, "grid.frequency_p": None, "grid.frequency_q": None, "grid.x_line_pu": 0.3,
       "grid.bus_voltage_pu": 1.0}
#: +0.1 Hz (0.002 pu of 50 Hz) at 1 s, the unit at 180 MW
STEP = {"scenario.kind": "grid-frequency-step", "scenario.initial_power_mw": 180.0,
        "scenario.grid_frequency_steps": [0.002], "scenario.step_times_s": [1.0]}


def bus_plant(**overrides):
    return load_plant(PLANT_HLA339_GRID, {**BUS, **STEP, **overrides})


def test_a_step_that_cannot_act_is_refused_with_its_reason():
    island = {k: v for k, v in STEP.items()}
    with pytest.raises(InputError, match=r"scenario\.kind = 'grid-frequency-step' steps the frequency of an infinite "
                                         r"bus; with grid\.kind = 'island' the grid's frequency is the unit's own"):
        load_plant(PLANT_HLA339_GRID, island)
    with pytest.raises(InputError, match=r"needs generator\.model = \"subtransient\" with grid\.kind = "
                                         r"\"infinite-bus\"; got generator\.model = 'swing' \(the swing rotor has no "
                                         r"grid\)"):
        load_plant(PLANT_HLA339, STEP)
    with pytest.raises(InputError, match=r"scenario\.initial_power_mw = 0\.0: scenario\.kind = 'grid-frequency-step' "
                                         r"needs the unit on the bus"):
        bus_plant(**{"scenario.initial_power_mw": 0.0})
    at_no_load = bus_plant(**{"scenario.initial_power_mw": None, "scenario.initial_opening": 0.0})
    with pytest.raises(InputError, match=r"scenario\.initial_opening = 0\.0 gives no load"):
        run_simulation(at_no_load)
    # beside them, the bus plant with a positive power is accepted
    assert bus_plant().scenario.grid_frequency_steps == (0.002,)


@pytest.mark.parametrize("change,match", [
    ({"scenario.grid_frequency_steps": None}, r"scenario\.kind = 'grid-frequency-step' needs "
                                              r"scenario\.grid_frequency_steps \(the bus frequency's steps"),
    ({"scenario.step_times_s": None}, r"needs scenario\.step_times_s"),
    ({"scenario.step_times_s": [1.0, 2.0]}, r"scenario\.step_times_s must have as many entries as "
                                            r"scenario\.grid_frequency_steps \(1\)"),
    ({"scenario.grid_frequency_steps": [0.06, 0.06], "scenario.step_times_s": [1.0, 2.0]},
     r"scenario\.grid_frequency_steps = \[0\.06, 0\.06\] takes the bus frequency \+0\.12 pu off rated at 2\.0 s; "
     r"allowed within \[-0\.1, 0\.1\]"),
    ({"scenario.grid_frequency_steps": "0.01"}, r"scenario\.grid_frequency_steps must be a list of numbers"),
    ({"scenario.event_time_s": 2.0}, r"scenario\.event_time_s is not used by scenario\.kind = "
                                     r"'grid-frequency-step'; allowed keys: kind, t_end_s, initial_power_mw, "
                                     r"initial_opening, grid_frequency_steps, step_times_s"),
])
def test_bad_keys_are_refused_naming_the_key(change, match):
    with pytest.raises(InputError, match=match):
        bus_plant(**change)


def test_a_key_of_the_step_under_another_kind_is_refused():
    with pytest.raises(InputError, match=r"scenario\.grid_frequency_steps is not used by scenario\.kind = "
                                         r"'opening-steps'"):
        load_plant(PLANT_HLA339_GRID, {**BUS, "scenario.kind": "opening-steps",
                                       "scenario.grid_frequency_steps": [0.01]})


def test_the_angle_against_the_bus_integrates_the_bus_frequency_exactly_and_the_signal_reads_it():
    """The shaft at rated speed (held): d delta/dt = omega_b (0 - x_bus), so delta = delta0 - omega_b x_bus (t - t1)
    with x_bus 0.002 from t1 = 1.005 s, inside a step of 10 ms (the step is split there); grid_frequency_hz is 50 Hz
    up to t1 and 50.1 Hz from it."""
    plant = bus_plant(**{"scenario.step_times_s": [1.005]})
    steady = initial_state(plant)
    schedules = replace(plant_schedules(plant, steady), speed_held=True)
    dt = 0.01
    shaft = build_subtransient(plant, steady, dt, schedules)
    params, state = shaft.params, shaft.state
    delta0 = float(state[1][S_DELTA])
    omega_b = params[1][P_OMEGA_B]
    times, deltas, frequencies = [0.0], [delta0], [subtransient_grid_frequency(params, state)]
    for k in range(200):
        subtransient_shaft_step(params, state, steady.torque_nm, k * dt, dt)
        times.append((k + 1) * dt)
        deltas.append(float(state[1][S_DELTA]))
        frequencies.append(subtransient_grid_frequency(params, state))
    times = np.array(times)
    expected = delta0 - omega_b * 0.002 * np.maximum(times - 1.005, 0.0)
    # the angle's derivative is the constant -omega_b x_bus (RK4 integrates it exactly): rounding of sums of 200
    # steps, 1e-12 rad, against the 3e-3 rad a step taken whole at 1.0 or 1.01 s would be off by
    np.testing.assert_allclose(deltas, expected, rtol=0, atol=1e-12)
    assert abs(deltas[-1] - delta0) == pytest.approx(omega_b * 0.002 * 0.995, rel=1e-12)
    np.testing.assert_array_equal(np.array(frequencies)[times < 1.005], 50.0)
    np.testing.assert_allclose(np.array(frequencies)[times > 1.005], 50.0 * 1.002, rtol=1e-15)
    # beside it, a step at 1.0 s (on the grid of steps) is another angle: off by omega_b x_bus 0.005 = 3.1e-3 rad
    assert abs(deltas[-1] - (delta0 - omega_b * 0.002 * 1.0)) > 3e-3


#: the speed mode with the permanent droop 0.04 (without it the governor would hold the unit at rated speed against
#: the bus) and gains that damp the electromechanical mode within the run (the shipped kp 2, kd 0.5 leave it ringing
#: at 1e-4 after 40 s); the ideal turbine on a rigid penstock at 20 ms
DROOP = {"governor.permanent_droop": 0.04, "governor.kp": 1.0, "governor.ki": 4.0, "governor.kd": 0.0,
         "penstock.model": "rigid", "solver.dt_s": 0.02, "scenario.t_end_s": 60.0}


def test_the_unit_pulls_into_step_at_the_bus_frequency():
    """After the bus steps +0.002 pu the only steady state of d delta/dt = omega_b (x - x_bus) is x = x_bus: the
    unit ends at 50.1 Hz. The bus's frequency rise first pulls the angle back: the electrical power dips."""
    run = run_simulation(bus_plant(**DROOP))
    x = run.speed_rpm / run.rated_speed_rpm - 1.0
    # the last 10 s: |x - x_bus| <= 1.9e-8 measured (the electromechanical mode, 1.15 Hz, and the governor's
    # integral still decaying); 1e-7 is 2e4 below the step
    last = run.time_s >= 50.0
    np.testing.assert_allclose(x[last], 0.002, rtol=0, atol=1e-7)
    np.testing.assert_allclose(run.signals["frequency_hz"][last], 50.1, rtol=0, atol=5e-6)  # 50 Hz x 1e-7
    power = run.signals["electrical_power_pu"]
    after = (run.time_s > 1.0) & (run.time_s < 1.5)
    assert np.min(power[after]) < power[0] - 0.05
    # beside it, the bus at rated frequency (a zero step) leaves the unit at rated speed, its steady state to the
    # last bits
    still = run_simulation(bus_plant(**DROOP, **{"scenario.grid_frequency_steps": [0.0]}))
    assert np.max(np.abs(still.speed_rpm / still.rated_speed_rpm - 1.0)) < 1e-12


def test_a_bus_step_is_an_event_the_chosen_time_step_lands_on():
    """On a rigid penstock the solver chooses the step: a bus step at 1.234 s is one of the events it aligns to (a
    whole number of steps up to it, to 1e-9 of a step), as a load step is; before the bus steps were events, the
    chosen step had no reason to land on 1.234 s."""
    from simulate.loop.timestep import event_times

    plant = bus_plant(**{"penstock.model": "rigid", "scenario.step_times_s": [1.234],
                         "scenario.t_end_s": 3.0})
    run = run_simulation(plant)
    dt = run.meta["dt_s"]
    assert run.meta["aligned_event_times_s"] == [1.234]
    assert abs(1.234 / dt - round(1.234 / dt)) < 1e-9
    # the failing case: without the bus steps the scenario has no event inside the run
    steady = initial_state(plant)
    schedules = plant_schedules(plant, steady)
    assert event_times(replace(schedules, bus_frequency_times_s=np.zeros(0)), 3.0) == []
