"""Scenario kinds -> the schedules the time loop follows.

``load-rejection``   governor in control; the breaker opens at ``event_time_s``: generator torque and load
                     self-regulation drop to zero (paper 004 Fig. 11b).
``closure-law``      load rejection at ``event_time_s`` with no governor: the vanes follow a prescribed linear or
                     two-stage closure (the regulating-guarantee calculation).
``frequency-steps``  no load (breaker open), speed reference steps ``speed_steps`` (cumulative, per unit) at
                     ``step_times_s`` (paper 004 Fig. 11a: +4 %, -8 %, +4 % at 10, 40, 70 s).
``load-step``        grid-connected with load self-regulation e_g; the load torque steps by ``load_step`` times the
                     initial load at ``event_time_s`` (paper 001 eq. (14)).
``opening-steps``    open loop: the vanes step by ``opening_steps`` (stroke fraction, cumulative) at ``step_times_s``;
                     the load torque stays at its initial value with self-regulation e_g (paper 000 section 5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hillchart.errors import InputError
from simulate.governor import closure_law

GOVERNOR, PRESCRIBED = 0, 1


@dataclass(frozen=True)
class Schedules:
    """Time tables for the loop. Loads are per unit of the rated torque P_r / omega_r.

    ``law_times_s``/``law_strokes``: piecewise-linear prescribed stroke (mode PRESCRIBED).
    ``ref_times_s``/``ref_values``: piecewise-constant speed reference x_ref (0 before the first time).
    ``load_times_s``/``load_values``/``self_regulation_values``: piecewise-constant load torque and e_g
    (``initial_load``/``initial_self_regulation`` before the first time).
    """

    mode: int
    law_times_s: np.ndarray
    law_strokes: np.ndarray
    ref_times_s: np.ndarray
    ref_values: np.ndarray
    load_times_s: np.ndarray
    load_values: np.ndarray
    self_regulation_values: np.ndarray
    initial_load: float
    initial_self_regulation: float


def initial_target(scenario) -> dict:
    """Keyword for :func:`simulate.steady.steady_state`: ``{"power_mw": ...}`` or ``{"stroke": ...}``.

    Examples
    --------
    >>> from simulate.config import ScenarioConfig
    >>> initial_target(ScenarioConfig(kind="frequency-steps", t_end_s=100.0))
    {'power_mw': 0.0}
    """
    if scenario.kind == "frequency-steps":
        return {"power_mw": 0.0}
    if scenario.initial_power_mw is not None:
        return {"power_mw": float(scenario.initial_power_mw)}
    return {"stroke": float(scenario.initial_opening)}


def build_schedules(plant, initial_stroke: float, initial_load_pu: float) -> Schedules:
    """The schedules of ``plant.scenario`` starting from a steady state with the given stroke and load.

    Examples
    --------
    >>> from simulate.config import ScenarioConfig, GovernorConfig
    >>> from types import SimpleNamespace
    >>> gov = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0,
    ...                      servo_time_s=0.2, closing_time_s=10.0, opening_time_s=20.0)
    >>> plant = SimpleNamespace(scenario=ScenarioConfig(kind="load-rejection", t_end_s=30.0, initial_opening=0.8,
    ...                         event_time_s=2.0), governor=gov, generator=SimpleNamespace(self_regulation=1.0))
    >>> s = build_schedules(plant, 0.8, 0.75)
    >>> s.mode, s.load_times_s.tolist(), s.load_values.tolist(), s.initial_self_regulation
    (0, [2.0], [0.0], 1.0)
    """
    sc, gov = plant.scenario, plant.governor
    e_g = float(plant.generator.self_regulation)
    none = np.array([np.inf])
    zero = np.array([0.0])
    law_t, law_y = np.array([0.0]), np.array([initial_stroke])
    ref_t, ref_v = none, zero
    load_t, load_v, reg_v = none, np.array([initial_load_pu]), np.array([e_g])
    load0, reg0 = initial_load_pu, e_g
    mode = GOVERNOR
    if sc.kind in ("load-rejection", "closure-law"):
        load_t, load_v, reg_v = np.array([sc.event_time_s]), zero, zero
        if sc.kind == "closure-law":
            mode = PRESCRIBED
            law_t, law_y = closure_law(initial_stroke, sc.event_time_s, sc.closing_time_s, sc.break_opening,
                                       sc.break_time_s)
    elif sc.kind == "frequency-steps":
        load0, reg0 = 0.0, 0.0
        load_v, reg_v = zero, zero
        ref_t = np.array(sc.step_times_or_default)
        ref_v = np.cumsum(sc.steps_or_default)
    elif sc.kind == "load-step":
        load_t = np.array([sc.event_time_s])
        load_v = np.array([initial_load_pu * (1.0 + sc.load_step)])
    elif sc.kind == "opening-steps":
        mode = PRESCRIBED
        levels = initial_stroke + np.cumsum(sc.steps_or_default)
        bad = (levels < gov.stroke_min) | (levels > gov.stroke_max)
        if np.any(bad):
            raise InputError(f"scenario.opening_steps take the stroke to {levels[bad][0]:.6g}, outside "
                             f"[governor.stroke_min, governor.stroke_max] = [{gov.stroke_min}, {gov.stroke_max}] "
                             f"(initial stroke {initial_stroke:.6g})")
        times = np.array(sc.step_times_or_default)
        law_t = np.concatenate(([0.0], np.repeat(times, 2)))
        law_y = np.concatenate(([initial_stroke], np.ravel(np.column_stack((
            np.concatenate(([initial_stroke], levels[:-1])), levels)))))
    return Schedules(mode, np.asarray(law_t, float), np.asarray(law_y, float), np.asarray(ref_t, float),
                     np.asarray(ref_v, float), np.asarray(load_t, float), np.asarray(load_v, float),
                     np.asarray(reg_v, float), float(load0), float(reg0))
