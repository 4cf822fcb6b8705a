"""What every scenario kind shares: the scenario section's tagged union (:class:`ScenarioConfig`, one subclass per
kind), the schedules the time loop follows, and their common start."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import ClassVar

import numpy as np

from hillchart.errors import InputError
from hillchart.validation import check_choice, check_float_list
from simulate.components.parameters import parameter, validate_parameters
from simulate.components.schedules import GOVERNOR, PRESCRIBED  # noqa: F401  (the control modes, re-exported)


SCENARIO_KINDS = ("load-rejection", "closure-law", "frequency-steps", "load-step", "opening-steps", "short-circuit",
                  "field-step", "grid-frequency-step", "start-up")

#: Keys each scenario kind accepts beyond ``kind`` and ``t_end_s`` (required ones first in the docs).
SCENARIO_KEYS = {
    "load-rejection": ("initial_power_mw", "initial_opening", "event_time_s"),
    "closure-law": ("initial_power_mw", "initial_opening", "event_time_s", "closing_time_s", "break_opening",
                    "break_time_s"),
    "frequency-steps": ("speed_steps", "step_times_s"),
    "load-step": ("initial_power_mw", "initial_opening", "event_time_s", "load_step"),
    "opening-steps": ("initial_power_mw", "initial_opening", "opening_steps", "step_times_s"),
    "short-circuit": ("event_time_s",),
    "field-step": ("event_time_s", "field_step_pu"),
    "grid-frequency-step": ("initial_power_mw", "initial_opening", "grid_frequency_steps", "step_times_s"),
    "start-up": ("event_time_s",),
}

#: What a list key of the scenario takes.
_NUMBERS = "a list of numbers (non-empty)"

#: The scenario registry: TOML ``scenario.kind`` -> its config dataclass; each kind's class registers itself when it is
#: defined (:mod:`simulate.scenarios` imports every kind).
SCENARIO_CLASSES: dict[str, type] = {}

@dataclass(frozen=True)
class ScenarioConfig:
    """What happens: ``kind`` (one of :data:`SCENARIO_KINDS`), end time and the kind's own keys.

    A tagged union: ``ScenarioConfig(kind=..., ...)`` returns the dataclass of that kind, one per file in
    :mod:`simulate.scenarios` (``LoadRejection``, ``ClosureLaw``, ``FrequencySteps``, ``LoadStep``,
    ``OpeningSteps``), each with its own keys (``KEYS``), checks (``validate``), initial point and schedules. A key
    that the kind does not use must stay at its default (an error names it and the kind's keys).

    Defaults: ``event_time_s`` 1.0; ``load_step`` 0.1 (fraction of the initial load); ``speed_steps``
    (0.04, -0.08, 0.04) at ``step_times_s`` (10, 40, 70) for frequency-steps (paper 004 Fig. 11a);
    ``opening_steps`` (0.02,) at ``step_times_s`` (1,) for opening-steps. Exactly one of ``initial_power_mw`` /
    ``initial_opening`` (stroke fraction) for the kinds that start on load; frequency-steps starts at no load.
    ``closing_time_s`` (closure-law): time of a full stroke at the first-stage rate; below ``break_opening`` the
    vanes move at the slower rate of a full stroke per ``break_time_s``. ``field_step_pu`` (field-step, default 0.1):
    the field-voltage step, pu. ``grid_frequency_steps`` (grid-frequency-step, required with ``step_times_s``):
    the steps of the infinite bus's frequency, per unit of ``grid.frequency_hz``, cumulative. ``units`` (any kind;
    a plant with ``[[units]]`` only): the names of the units the event applies to (default: all); the others stay on
    the grid under their governors at constant load.
    """

    kind: str = parameter(unit="", choices=SCENARIO_KINDS, description="what happens")
    t_end_s: float = parameter(unit="s", low=0.0, low_open=True, high=1e5, description="end of the run")
    initial_power_mw: float | None = parameter(None, unit="MW", low=0.0, high=3000.0,
                                               description="initial power (at most 1.5 x turbine.rated_power_mw)")
    initial_opening: float | None = parameter(None, unit="stroke fraction", low=0.0, high=1.5,
                                              description="initial stroke (within the governor's stroke limits)")
    event_time_s: float = parameter(1.0, unit="s", low=0.0, high="t_end_s", high_open=True,
                                    description="time of the event")
    closing_time_s: float | None = parameter(None, unit="s", low=0.0, high=1000.0,
                                             description="closure-law: time of a full stroke at the first rate")
    break_opening: float | None = parameter(None, unit="stroke fraction", low=0.0, low_open=True, high=1.0,
                                            description="closure-law: stroke below which the second rate holds")
    break_time_s: float | None = parameter(None, unit="s", low=0.0, low_open=True, high=1000.0,
                                           description="closure-law: time of a full stroke at the second rate")
    load_step: float = parameter(0.1, unit="fraction of the initial load", low=-1.0, high=1.0,
                                 description="load-step: the step of the load")
    speed_steps: tuple[float, ...] | None = parameter(None, what=_NUMBERS, unit="pu speed", kind="array",
                                                      description="frequency-steps: the speed-reference steps")
    opening_steps: tuple[float, ...] | None = parameter(None, what=_NUMBERS, unit="stroke fraction", kind="array",
                                                        description="opening-steps: the stroke steps")
    step_times_s: tuple[float, ...] | None = parameter(None, what=_NUMBERS, unit="s", kind="array",
                                                       description="the times of the steps, non-decreasing")
    field_step_pu: float = parameter(0.1, unit="pu", low=-1.0, high=1.0,
                                     description="field-step: the field-voltage step")
    grid_frequency_steps: tuple[float, ...] | None = parameter(
        None, what=_NUMBERS, unit="pu of grid.frequency_hz", kind="array",
        description="grid-frequency-step: the steps of the infinite bus's frequency (cumulative)")
    units: tuple[str, ...] | None = parameter(None, unit="", kind="array",
                                              what="a non-empty list of unit names (the [[units]] names)",
                                              description="the units the event applies to (default: all)")

    #: keys of this kind beyond ``kind`` and ``t_end_s`` (set by each kind's class)
    KEYS: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "KIND" in cls.__dict__:
            SCENARIO_CLASSES[cls.KIND] = cls

    def __new__(cls, *args, **kwargs):
        if cls is ScenarioConfig:
            kind = kwargs.get("kind", args[0] if args else None)
            check_choice("scenario.kind", kind, SCENARIO_KINDS)
            cls = SCENARIO_CLASSES[kind]
        return super().__new__(cls)

    def __post_init__(self):
        event = self.event_time_s
        if (isinstance(event, (int, float)) and not isinstance(event, bool) and math.isfinite(event)
                and type(self.t_end_s) in (int, float) and 0.0 < self.t_end_s <= event):  # which bound, and why
            raise InputError(f"scenario.event_time_s = {float(event)!r} s is not before scenario.t_end_s = "
                             f"{float(self.t_end_s)!r} s: the run would end before its event; set scenario.t_end_s "
                             f"beyond the event (e.g. {event + max(10.0, event):g}) or an earlier event_time_s")
        validate_parameters("scenario", self)
        if SCENARIO_KEYS.get(self.kind) != self.KEYS:
            raise InputError(f"scenario.kind = {self.kind!r} does not match the scenario class {type(self).__name__}")
        allowed = set(self.KEYS)
        for f in fields(self):
            if f.name in ("kind", "t_end_s", "units") or f.name in allowed:
                continue
            if getattr(self, f.name) != f.default:
                raise InputError(f"scenario.{f.name} is not used by scenario.kind = {self.kind!r}; "
                                 f"allowed keys: kind, t_end_s, {', '.join(self.KEYS)}")
        if self.units is not None:
            if not all(isinstance(u, str) and u for u in self.units):
                raise InputError(f"scenario.units must be a non-empty list of unit names (the [[units]] names), "
                                 f"got {self.units!r}")
            if len(set(self.units)) != len(self.units):
                raise InputError(f"scenario.units names a unit twice: {list(self.units)!r}")
        if "initial_power_mw" in allowed:
            if (self.initial_power_mw is None) == (self.initial_opening is None):
                raise InputError(f"scenario kind {self.kind!r} needs exactly one of scenario.initial_power_mw or "
                                 f"scenario.initial_opening; got {self.initial_power_mw!r} and "
                                 f"{self.initial_opening!r}")
        self.validate()

    def validate(self) -> None:
        """The kind's own checks (overridden per kind)."""

    def check_plant(self, plant) -> None:
        """Checks of the kind against the rest of the plant (e.g. a kind that needs the sub-transient generator);
        overridden per kind."""

    def initial_target(self) -> dict:
        """Keyword for :func:`simulate.loop.steady.steady_state`: ``{"power_mw": ...}`` or ``{"stroke": ...}``."""
        if self.initial_power_mw is not None:
            return {"power_mw": float(self.initial_power_mw)}
        return {"stroke": float(self.initial_opening)}

    #: What happens at ``event_time_s``, in words (per kind).
    EVENT: ClassVar[str] = "event"

    def events(self) -> list[tuple[float, str]]:
        """``(time_s, label)`` of what happens, for the figures to mark (per kind): the event at ``event_time_s``
        by default, a step at each of ``step_times_s`` for the kinds that step."""
        return [(float(self.event_time_s), self.EVENT)]

    def schedules(self, plant, initial_stroke: float, initial_load_pu: float):
        """The :class:`simulate.scenarios.Schedules` the loop follows (per kind)."""
        raise NotImplementedError(f"scenario kind {self.kind!r} defines no schedules")


@dataclass(frozen=True)
class Schedules:
    """Time tables for the loop. Loads are per unit of the rated torque P_r / omega_r.

    ``law_times_s``/``law_strokes``: piecewise-linear prescribed stroke (mode PRESCRIBED).
    ``ref_times_s``/``ref_values``: piecewise-constant speed reference x_ref (0 before the first time).
    ``load_times_s``/``load_values``/``self_regulation_values``: piecewise-constant load torque and e_g
    (``initial_load``/``initial_self_regulation`` before the first time).
    Electrical events (the sub-transient shaft reads them; the swing rotor has none): ``speed_held`` (the shaft
    stays at rated speed), ``fault_time_s`` (three-phase terminal fault from then on), ``field_held`` (no voltage
    control: the field voltage stays at its steady value) plus ``field_step_pu`` from ``field_step_time_s``;
    ``bus_frequency_times_s``/``bus_frequency_values``: the infinite bus's frequency deviation x_bus (per unit of
    the rated frequency), piecewise constant (0 before the first time; none: the bus at rated frequency).
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
    bus_frequency_times_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    bus_frequency_values: np.ndarray = field(default_factory=lambda: np.zeros(0))


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
    e_g = float(plant.generator.self_regulation)
    none = np.array([np.inf])
    base = Schedules(GOVERNOR, np.array([0.0]), np.array([initial_stroke], dtype=float), none, np.array([0.0]), none,
                     np.array([initial_load_pu], dtype=float), np.array([e_g]), float(initial_load_pu), e_g)
    changes = {k: (np.asarray(v, float) if isinstance(v, (np.ndarray, list, tuple)) else v) for k, v in changes.items()}
    return replace(base, **changes)


def check_steps(scenario, steps_key: str) -> None:
    """Shared checks of the step-list kinds (frequency-steps, opening-steps)."""
    steps = getattr(scenario, steps_key)
    if steps is not None:
        check_float_list(f"scenario.{steps_key}", steps, low=-1.0, high=1.0)
    if scenario.step_times_s is not None:
        times = check_float_list("scenario.step_times_s", scenario.step_times_s, low=0.0, high=scenario.t_end_s)
        if any(b < a for a, b in zip(times, times[1:])):
            raise InputError(f"scenario.step_times_s must be non-decreasing, got {list(times)!r}")
    n_steps = len(scenario.steps_or_default)
    if len(scenario.step_times_or_default) != n_steps:
        raise InputError(f"scenario.step_times_s must have as many entries as scenario.{steps_key} "
                         f"({n_steps}), got {list(scenario.step_times_or_default)!r}")
