"""Scenario kinds -> the schedules the time loop follows (one file per kind; the registry is
:data:`SCENARIO_CLASSES`).

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
``short-circuit``    sub-transient generator at open circuit, rated speed and voltage; three-phase terminal fault at
                     ``event_time_s``; speed and field voltage held (the standard short-circuit test).
``field-step``       sub-transient generator at open circuit and rated speed; the field voltage steps by
                     ``field_step_pu`` at ``event_time_s`` (speed held, no voltage control).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hillchart.errors import InputError

GOVERNOR, PRESCRIBED = 0, 1


@dataclass(frozen=True)
class Schedules:
    """Time tables for the loop. Loads are per unit of the rated torque P_r / omega_r.

    ``law_times_s``/``law_strokes``: piecewise-linear prescribed stroke (mode PRESCRIBED).
    ``ref_times_s``/``ref_values``: piecewise-constant speed reference x_ref (0 before the first time).
    ``load_times_s``/``load_values``/``self_regulation_values``: piecewise-constant load torque and e_g
    (``initial_load``/``initial_self_regulation`` before the first time).
    Electrical events (the sub-transient shaft reads them; the swing rotor has none): ``speed_held`` (the shaft
    stays at rated speed), ``fault_time_s`` (three-phase terminal fault from then on), ``field_held`` (no voltage
    control: the field voltage stays at its steady value) plus ``field_step_pu`` from ``field_step_time_s``.
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
    speed_held: bool = False
    fault_time_s: float = float("inf")
    field_held: bool = False
    field_step_time_s: float = float("inf")
    field_step_pu: float = 0.0


def initial_target(scenario) -> dict:
    """Keyword for :func:`simulate.loop.steady.steady_state`: ``{"power_mw": ...}`` or ``{"stroke": ...}``.

    Examples
    --------
    >>> from simulate.config import ScenarioConfig
    >>> initial_target(ScenarioConfig(kind="frequency-steps", t_end_s=100.0))
    {'power_mw': 0.0}
    """
    return scenario.initial_target()


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
    return plant.scenario.schedules(plant, initial_stroke, initial_load_pu)


def steady_schedules(plant, initial_stroke: float, initial_load_pu: float, **changes) -> Schedules:
    """Schedules of an undisturbed plant (governor in control, constant load with self-regulation e_g), with
    ``changes`` applied: the common start of every kind's schedules."""
    from dataclasses import replace

    e_g = float(plant.generator.self_regulation)
    none = np.array([np.inf])
    base = Schedules(GOVERNOR, np.array([0.0]), np.array([initial_stroke], dtype=float), none, np.array([0.0]), none,
                     np.array([initial_load_pu], dtype=float), np.array([e_g]), float(initial_load_pu), e_g)
    changes = {k: (np.asarray(v, float) if isinstance(v, (np.ndarray, list, tuple)) else v) for k, v in changes.items()}
    return replace(base, **changes)


def check_steps(scenario, steps_key: str) -> None:
    """Shared checks of the step-list kinds (frequency-steps, opening-steps)."""
    from simulate.config import _check_float_list

    steps = getattr(scenario, steps_key)
    if steps is not None:
        _check_float_list("scenario", steps_key, steps, low=-1.0, high=1.0)
    if scenario.step_times_s is not None:
        times = _check_float_list("scenario", "step_times_s", scenario.step_times_s, low=0.0, high=scenario.t_end_s)
        if any(b < a for a, b in zip(times, times[1:])):
            raise InputError(f"scenario.step_times_s must be non-decreasing, got {list(times)!r}")
    n_steps = len(scenario.steps_or_default)
    if len(scenario.step_times_or_default) != n_steps:
        raise InputError(f"scenario.step_times_s must have as many entries as scenario.{steps_key} "
                         f"({n_steps}), got {list(scenario.step_times_or_default)!r}")


from simulate.scenarios.load_rejection import LoadRejection  # noqa: E402  (the kinds subclass ScenarioConfig)
from simulate.scenarios.closure_law import ClosureLaw  # noqa: E402
from simulate.scenarios.frequency_steps import FrequencySteps  # noqa: E402
from simulate.scenarios.load_step import LoadStep  # noqa: E402
from simulate.scenarios.opening_steps import OpeningSteps  # noqa: E402
from simulate.scenarios.short_circuit import ShortCircuit  # noqa: E402
from simulate.scenarios.field_step import FieldStep  # noqa: E402

#: The scenario registry: TOML ``scenario.kind`` -> its config dataclass (which builds its schedules).
SCENARIO_CLASSES = {cls.KIND: cls for cls in (LoadRejection, ClosureLaw, FrequencySteps, LoadStep, OpeningSteps,
                                              ShortCircuit, FieldStep)}
