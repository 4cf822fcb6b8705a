"""The time step from the plant's own time scales.

Every component states the time scales it needs resolved (a function ``time_scales(plant, schedules)`` in the module
of its builder, found through the registries of :mod:`simulate.components.registry`): the rotor's inertia time Ta, the
governor's servo, derivative filter and integral time, the generator's sub-transient constants and the excitation
filter, the surge tank's mass-oscillation period, and the penstock model's own condition (Tw for the rigid, lumped and
z-domain models; none for the method of characteristics, which is exact on its grid).

A scale is *coupled* when the component exchanges it with the hydraulics once per step (the rotor through the turbine
torque, the penstock and the surge tank themselves): only a smaller step resolves it. The others (controls, the
generator's fluxes and its excitation) advance in sub-steps of the step when the step is fixed by the MOC grid.

:func:`plan_step` chooses:

* MOC: the step is the grid's, (shortest travel time) / ``penstock.reaches``; every non-coupled component runs in
  ``substeps`` sub-steps of at most :data:`RESOLVE_FRACTION` x its fastest scale.
* rigid, lumped, z-domain without ``solver.dt_s``: the largest step at most the MOC grid's and
  :data:`RESOLVE_FRACTION` x every scale, shortened so that every scenario event falls on a step (an event at t
  happens at t); not shortened by more than :data:`ALIGN_MIN_RATIO`, else not aligned.
* a user-fixed ``solver.dt_s``: that step; a scale it does not resolve is a warning naming the component, its time
  constant and the key that fixes it.
* ``solver.substeps`` (optional) fixes the sub-steps of the non-coupled components, for any model; a scale the
  sub-step does not resolve is a warning.

A coupled scale the step does not resolve is a warning above :data:`RESOLVE_FRACTION` x its value and an
:class:`InputError` above :data:`REFUSE_FRACTION` x it (the explicit rotor step is unstable or meaningless there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

from hillchart.errors import InputError
from simulate.components.registry import PENSTOCKS
from simulate.components.timescale import RESOLVE_FRACTION, TimeScale  # noqa: F401  (RESOLVE_FRACTION: re-exported)

#: A coupled time scale T with dt > this x T is refused.
REFUSE_FRACTION = 0.5
#: Event alignment may shorten the step to this fraction of the resolving step at most (else no alignment).
ALIGN_MIN_RATIO = 0.25
#: Event times are read as fractions with denominators up to this (1 us resolution) to find a common step.
ALIGN_DENOMINATOR = 10 ** 6


@dataclass(frozen=True)
class StepPlan:
    """The chosen step ``dt_s`` (s), the sub-steps of the non-coupled components per step, what limited the step
    (``limited_by``), the scales considered, the events put on the grid and the warnings for the result."""

    dt_s: float
    substeps: int
    chosen: bool
    limited_by: str
    scales: tuple[TimeScale, ...] = ()
    aligned_events_s: tuple[float, ...] = ()
    moved_events_s: tuple[tuple[float, float], ...] = ()
    warnings: tuple[str, ...] = field(default=())

    @property
    def substep_s(self) -> float:
        return self.dt_s / self.substeps


def time_scales(plant, schedules) -> list[TimeScale]:
    """Every component's time scales (see the module docstring), in the order penstock, upstream, control, shaft,
    downstream."""
    from simulate.components.registry import (CONTROLS, DOWNSTREAM, PENSTOCKS, SHAFTS, UPSTREAM, control_name,
                                              downstream_section, shaft_section, upstream_section)

    out = []
    for registry, name in ((PENSTOCKS, plant.penstock.model), (UPSTREAM, upstream_section(plant)[0]),
                           (CONTROLS, control_name(plant, schedules)),
                           (SHAFTS, shaft_section(plant)[0]), (DOWNSTREAM, downstream_section(plant)[0])):
        out += registry.time_scales(name, plant, schedules)
    return out


def event_times(schedules, t_end_s: float) -> list[float]:
    """The scenario's event times inside (0, t_end): load changes, speed-reference steps, fault, field step, the
    infinite bus's frequency steps."""
    times = [*schedules.load_times_s, *schedules.ref_times_s, schedules.fault_time_s, schedules.field_step_time_s,
             *schedules.bus_frequency_times_s]
    return sorted({float(t) for t in times if math.isfinite(t) and 0.0 < t < t_end_s})


def aligned_step(dt_max_s: float, events_s) -> float:
    """The largest step <= ``dt_max_s`` of which every event time is a whole multiple; ``dt_max_s`` when there is
    none within :data:`ALIGN_MIN_RATIO` of it.

    Examples
    --------
    >>> round(aligned_step(0.043, [0.5]), 12)      # 0.5 s / 12 steps
    0.041666666667
    >>> aligned_step(0.02, [10.0, 40.0, 70.0])
    0.02
    >>> aligned_step(0.02, [1.0000001])           # no common step near 0.02 s: unchanged
    0.02
    """
    if not events_s:
        return dt_max_s
    common = None
    for t in events_s:
        frac = Fraction(t).limit_denominator(ALIGN_DENOMINATOR)
        if abs(float(frac) - t) > 1e-12 * max(1.0, t):
            return dt_max_s
        common = frac if common is None else Fraction(math.gcd(common.numerator * frac.denominator,
                                                               frac.numerator * common.denominator),
                                                      common.denominator * frac.denominator)
    n = math.ceil(common / Fraction(dt_max_s) - Fraction(1, 10 ** 9))
    dt = float(common / max(n, 1))
    return dt if ALIGN_MIN_RATIO * dt_max_s <= dt <= dt_max_s * (1.0 + 1e-12) else dt_max_s


def plan_step(plant, schedules, *, grid_step_s: float | None = None) -> StepPlan:
    """The step, the sub-steps and the warnings for ``plant`` with its scenario's ``schedules`` (module docstring).

    ``grid_step_s``: the MOC grid's step when it is set by more pipes than ``plant.penstock`` (a unit of a plant with
    several units, whose step is the shortest over the common conduit and every branch).

    Raises
    ------
    InputError
        The MOC grid or a user-fixed step is more than :data:`REFUSE_FRACTION` x a coupled time scale.
    """
    scales = time_scales(plant, schedules)
    moc = PENSTOCKS.traits(plant.penstock.model).grid_fixes_time_step
    user = plant.solver.dt_s is not None
    # the MOC grid's step, or the user's (checked against the Courant condition for MOC)
    base = plant.time_step_s if grid_step_s is None else float(grid_step_s)
    fix = "penstock.reaches (more reaches, a shorter step)" if moc else "solver.dt_s"
    events = event_times(schedules, plant.scenario.t_end_s)
    aligned: tuple[float, ...] = ()
    if moc or user:
        dt, chosen = base, False
        limited_by = "the MOC grid ((shortest travel time) / penstock.reaches)" if moc else "solver.dt_s"
    else:
        limits = [(base, "(shortest travel time) / penstock.reaches")]
        limits += [(s.resolving_step_s, f"{s.resolve_fraction:g} x {s.label}") for s in scales]
        dt_max, limited_by = min(limits, key=lambda item: item[0])
        dt, chosen = aligned_step(dt_max, events), True
        if dt != dt_max:
            aligned = tuple(events)
    warnings = []
    moved = []
    # the user's step: an event between steps acts from the next one (the rotor, the loads, the faults). With MOC the
    # step is the grid's whatever solver.dt_s says (it is accepted only within COURANT_TOLERANCE of it), so an event
    # acts where it would without the key: nothing to report, and no other step to advise
    if user and not moc:
        for t in events:
            acts = math.ceil(t / dt - 1e-9) * dt
            if abs(acts - t) > 1e-9 * max(1.0, t):
                moved.append((t, acts))
        if moved:
            better = aligned_step(dt, events)
            how = (f"set solver.dt_s = {better:.6g} s (every event time a whole number of steps)" if better != dt
                   else f"move the event(s) to whole multiples of {dt:.6g} s")
            warnings.append(f"scenario event(s) at {', '.join(f'{t:.6g} s' for t, _ in moved)} fall between steps of "
                            f"solver.dt_s = {dt:.6g} s and act from {', '.join(f'{a:.6g} s' for _, a in moved)} (the "
                            f"next step); to have them act when requested, {how}, or leave solver.dt_s out (the "
                            f"solver then aligns the step)")
    for s in scales:
        sub_stepped = moc and not s.coupled
        if sub_stepped or (plant.solver.substeps is not None and not s.coupled):
            continue
        if s.coupled and dt > REFUSE_FRACTION * s.value_s:
            raise InputError(
                f"time step dt = {dt:.6g} s is not small against {s.label} = {s.value_s:.6g} s (allowed dt <= "
                f"{REFUSE_FRACTION} x {s.value_s:.6g} = {REFUSE_FRACTION * s.value_s:.6g} s): set {fix}, or check "
                f"the wave speeds and lengths (m/s and m)")
        if dt > s.resolving_step_s * (1.0 + 1e-9):
            warnings.append(f"time step dt = {dt:.6g} s is more than {s.resolve_fraction:g} x {s.label} = "
                            f"{s.value_s:.6g} s; results may be inaccurate: set {fix} so that dt <= "
                            f"{s.resolving_step_s:.6g} s")
    free = [s.resolving_step_s for s in scales if not s.coupled]
    substeps = 1
    if moc and free:
        substeps = max(1, math.ceil(dt / min(free) - 1e-9))
    if plant.solver.substeps is not None:  # the user's count: what it leaves unresolved is a warning
        substeps = plant.solver.substeps
        for s in scales:
            if not s.coupled and dt / substeps > s.resolving_step_s * (1.0 + 1e-9):
                warnings.append(f"sub-step dt / solver.substeps = {dt / substeps:.6g} s is more than "
                                f"{s.resolve_fraction:g} x {s.label} = {s.value_s:.6g} s; results may be inaccurate: "
                                f"raise solver.substeps to {math.ceil(dt / s.resolving_step_s - 1e-9)} or omit it")
    return StepPlan(dt_s=dt, substeps=substeps, chosen=chosen, limited_by=limited_by, scales=tuple(scales),
                    aligned_events_s=aligned, moved_events_s=tuple(moved), warnings=tuple(warnings))
