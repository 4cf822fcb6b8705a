"""Guide-vane closure-law optimization over a plant's load cases, with batched evaluations.

The law is the plant's ``closure-law`` scenario (:func:`simulate.components.control.governor.closure_law`): from the
initial stroke y0 the vanes close at the first-stage rate (a full stroke per ``closing_time_s`` T1) down to
``break_opening`` y_b, then at the second-stage rate (a full stroke per ``break_time_s`` T2). The linear closure is the
family with y_b >= y0 (first stage only).

Problem (``mode="head"``): minimize the worst max head rise over the load cases (and ensemble members) subject to
worst max speed rise <= limit; ``mode="speed"`` is the reverse. Every candidate law is a batch of
(load case x member) runs through :func:`simulate.studies.batch.run_batch`, i.e. the same
:func:`simulate.loop.engine.run_simulation` that ``hillsim run`` uses. The search is
:func:`scipy.optimize.differential_evolution` with ``vectorized=True`` (one batch per generation) and a seed; a
constraint violation adds ``PENALTY x`` the relative excess; a failed run or a closure that does not finish
``CLOSURE_MARGIN_S`` before the end of the run makes a candidate infeasible.

The Pareto front (max speed rise vs max head rise) of the two-stage family is the non-dominated set of every law
the search evaluated; the linear family is a grid of T1. The best linear closure at the limit is found by
:func:`scipy.optimize.brentq` on T1 (speed rise grows and head rise falls monotonically with T1 on the shipped plant;
the grid shows it).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.optimize import brentq, differential_evolution

from hillchart.errors import InputError
from simulate.studies.batch import BatchPool
from simulate.components.turbine.component import characteristics_of
from simulate.config import PlantConfig
from simulate.studies.cases import LoadCase

#: Weight of the relative constraint excess in the penalized objective.
PENALTY = 10.0
#: Objective of an infeasible candidate (failed run, closure not finished in time).
INFEASIBLE = 1e3
#: The closure must end at least this long before the end of the run (the last water-hammer wave is in the run).
CLOSURE_MARGIN_S = 5.0
#: Default search box: T1 (s), y_b (stroke), T2 (s).
DEFAULT_BOUNDS = ((3.0, 30.0), (0.02, 0.95), (3.0, 60.0))
MODES = ("head", "speed")


@dataclass(frozen=True)
class ClosureLaw:
    """Two-stage law: first stage a full stroke per ``closing_time_s`` (T1, s) down to ``break_opening`` (stroke
    fraction; None = linear), then a full stroke per ``break_time_s`` (T2, s)."""

    closing_time_s: float
    break_opening: float | None = None
    break_time_s: float | None = None

    def __post_init__(self):
        for name in ("closing_time_s", "break_time_s"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, (int, float)) and 0.0 < value <= 1000.0):
                raise InputError(f"closure law {name} must be in (0, 1000] s, got {value!r}")
        if (self.break_opening is None) != (self.break_time_s is None):
            raise InputError("closure law: break_opening and break_time_s go together (both or neither)")
        if self.break_opening is not None and not (0.0 < self.break_opening < 1.5):
            raise InputError(f"closure law break_opening must be in (0, 1.5), got {self.break_opening!r}")

    @property
    def first_stage_rate(self) -> float:
        """Stroke per second of the first stage."""
        return 1.0 / self.closing_time_s

    @property
    def second_stage_rate(self) -> float | None:
        return None if self.break_time_s is None else 1.0 / self.break_time_s

    def overrides(self) -> dict:
        out = {"scenario.closing_time_s": float(self.closing_time_s)}
        if self.break_opening is not None:
            out["scenario.break_opening"] = float(self.break_opening)
            out["scenario.break_time_s"] = float(self.break_time_s)
        return out

    def duration_s(self, initial_stroke: float) -> float:
        """Time from the start of the closure to full closure, s."""
        if self.break_opening is None or self.break_opening >= initial_stroke:
            return initial_stroke * self.closing_time_s
        return (initial_stroke - self.break_opening) * self.closing_time_s + self.break_opening * self.break_time_s

    def as_dict(self) -> dict:
        out = asdict(self)
        out["first_stage_rate_per_s"] = self.first_stage_rate
        out["second_stage_rate_per_s"] = self.second_stage_rate
        return out


def closure_plant(plant: PlantConfig) -> PlantConfig:
    """``plant`` with its scenario turned into a ``closure-law`` scenario (same initial point, event, end)."""
    if plant.scenario.kind == "closure-law":
        return plant
    if plant.scenario.kind not in ("load-rejection",):
        raise InputError(f"closure optimization needs a load-rejection or closure-law scenario, got scenario.kind "
                         f"= {plant.scenario.kind!r}")
    return plant.with_overrides({"scenario.kind": "closure-law",
                                 "scenario.closing_time_s": plant.governor.closing_time_s})


@dataclass
class LawEvaluation:
    """Worst case of one law over the load cases and members, and each case's record."""

    law: ClosureLaw
    max_speed_rise: float
    max_head_rise: float
    feasible_runs: bool
    cases: list = field(default_factory=list, repr=False)
    problem: str = ""


class ClosureEvaluator:
    """Evaluates laws in batches over ``load_cases`` x ``members`` (characteristics) of one closure plant, on a
    :class:`simulate.studies.batch.BatchPool` kept for all batches (``workers=1``: in this process). Close it (or use it
    as a context manager) when done."""

    def __init__(self, plant: PlantConfig, load_cases: tuple[LoadCase, ...], members: list | None = None, *,
                 workers: int | None = 1):
        self.plant = closure_plant(plant)
        self.load_cases = tuple(load_cases)
        self.members = members or [characteristics_of(self.plant)]
        self.pool = BatchPool(self.plant, self.members, workers=workers)
        self.evaluations = 0
        self.history: list[LawEvaluation] = []

    def close(self) -> None:
        self.pool.close()

    def __enter__(self) -> "ClosureEvaluator":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def evaluate(self, laws: list[ClosureLaw], record: bool = True) -> list[LawEvaluation]:
        variants = [{**lc.overrides, **law.overrides()} for law in laws for lc in self.load_cases]
        per_law = len(self.load_cases)
        grouped: list[list] = [[] for _ in laws]
        for batch in self.pool.run_members(variants):
            for j, case in enumerate(batch.cases):
                grouped[j // per_law].append(case)
        out = []
        t_end, event = self.plant.scenario.t_end_s, self.plant.scenario.event_time_s
        for law, cases in zip(laws, grouped):
            problem = ""
            bad = [c for c in cases if not c.ok]
            if bad:
                problem = f"{bad[0].status}: {bad[0].error}"
            else:
                late = [c for c in cases if event + law.duration_s(c.initial_opening) > t_end - CLOSURE_MARGIN_S]
                if late:
                    problem = (f"closure ends at {event + law.duration_s(late[0].initial_opening):.4g} s, later than "
                               f"scenario.t_end_s - {CLOSURE_MARGIN_S} s = {t_end - CLOSURE_MARGIN_S:.4g} s")
            speed = max((c.max_speed_rise for c in cases), default=math.nan)
            head = max((c.max_head_rise for c in cases), default=math.nan)
            out.append(LawEvaluation(law=law, max_speed_rise=speed, max_head_rise=head,
                                     feasible_runs=not problem, cases=cases, problem=problem))
        self.evaluations += len(laws)
        if record:
            self.history.extend(out)
        return out


def _objective(ev: LawEvaluation, mode: str, limit: float) -> float:
    if not ev.feasible_runs or not (math.isfinite(ev.max_speed_rise) and math.isfinite(ev.max_head_rise)):
        return INFEASIBLE
    value, constrained = ((ev.max_head_rise, ev.max_speed_rise) if mode == "head"
                          else (ev.max_speed_rise, ev.max_head_rise))
    return value + PENALTY * max(0.0, constrained / limit - 1.0)


def pareto_front(points: np.ndarray) -> np.ndarray:
    """Indices of the non-dominated rows of ``points`` (n, 2), both columns minimized, sorted by column 0.

    Examples
    --------
    >>> pareto_front(np.array([[1.0, 5.0], [2.0, 3.0], [3.0, 4.0], [4.0, 1.0]])).tolist()
    [0, 1, 3]
    """
    order = np.lexsort((points[:, 1], points[:, 0]))
    keep, best = [], math.inf
    for i in order:
        if points[i, 1] < best:
            keep.append(int(i))
            best = points[i, 1]
    return np.array(keep, dtype=int)


@dataclass
class ClosureOptimum:
    """What :func:`optimize_closure` found (all figures worst case over load cases and members)."""

    mode: str
    limit: float
    law: LawEvaluation
    best_linear: LawEvaluation
    linear_family: list
    pareto_two_stage: list
    evaluations: int
    wall_time_s: float
    de_message: str
    bounds: tuple

    @property
    def improvement(self) -> float:
        """Objective of the best linear closure minus that of the two-stage optimum (positive: the optimum wins)."""
        key = "max_head_rise" if self.mode == "head" else "max_speed_rise"
        return getattr(self.best_linear, key) - getattr(self.law, key)


def best_linear(evaluator: ClosureEvaluator, mode: str, limit: float, grid: list[LawEvaluation]) -> LawEvaluation:
    """The linear closure that meets the limit with the best objective: on the grid, the bracket where the
    constrained figure crosses the limit, then brentq on T1 to the limit (1e-6 s)."""
    key = "max_speed_rise" if mode == "head" else "max_head_rise"
    ok = [g for g in grid if g.feasible_runs]
    if not ok:
        raise InputError("no linear closure on the grid runs through; widen the bounds of closing_time_s")
    t = np.array([g.law.closing_time_s for g in ok])
    c = np.array([getattr(g, key) for g in ok]) - limit
    meets = c <= 0
    if not meets.any():
        raise InputError(f"no linear closure with T1 in [{t.min():g}, {t.max():g}] s meets the limit {key} <= "
                         f"{limit:g} (smallest {c.min() + limit:.4g}); relax the limit")
    if meets.all():  # the limit is not active on the grid: best objective on the grid
        return min(ok, key=lambda g: _objective(g, mode, limit))
    cross = np.nonzero(meets[:-1] != meets[1:])[0]
    i = int(cross[0]) if mode == "head" else int(cross[-1])
    cache = {}

    def excess(t1):
        ev = evaluator.evaluate([ClosureLaw(closing_time_s=float(t1))], record=False)[0]
        cache[float(t1)] = ev
        return getattr(ev, key) - limit if ev.feasible_runs else math.inf

    xtol = 1e-6
    root = brentq(excess, t[i], t[i + 1], xtol=xtol)
    # brentq's root lies within xtol of the crossing, on either side: where it is just past the limit, the point
    # 2 xtol toward the bracket's feasible end meets it
    inside = t[i] if meets[i] else t[i + 1]
    candidates = []
    for t1 in (root, root + math.copysign(2.0 * xtol, inside - root)):
        if float(t1) not in cache:  # brentq has run its root already; the step beside it is new
            excess(t1)
        ev = cache[float(t1)]
        if ev.feasible_runs and getattr(ev, key) <= limit:
            candidates.append(ev)
            break
    candidates += [g for g in ok if getattr(g, key) <= limit]
    return min(candidates, key=lambda g: _objective(g, mode, limit))


def optimize_closure(plant: PlantConfig, load_cases: tuple[LoadCase, ...], *, mode: str = "head", limit: float,
                     members: list | None = None, bounds=DEFAULT_BOUNDS, seed: int = 0, maxiter: int = 25,
                     popsize: int = 10, linear_points: int = 28, workers: int | None = None,
                     progress=None) -> ClosureOptimum:
    """Find the two-stage closure law (see the module docstring).

    Parameters
    ----------
    plant : PlantConfig
        A load-rejection or closure-law plant (turned into closure-law).
    load_cases : tuple of LoadCase
    mode : {"head", "speed"}
        ``head``: minimize max head rise s.t. max speed rise <= limit; ``speed``: the reverse.
    limit : float
        The constrained figure's limit, fraction.
    members : list of characteristics, optional
        Apply the figures' worst case over these (an ensemble); default the plant's characteristics.
    bounds : ((T1_lo, T1_hi), (yb_lo, yb_hi), (T2_lo, T2_hi))
    seed, maxiter, popsize
        :func:`scipy.optimize.differential_evolution` settings (popsize x 3 laws per generation).
    linear_points : int
        T1 grid of the linear family over ``bounds[0]``.
    """
    if mode not in MODES:
        raise InputError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    if isinstance(limit, bool) or not isinstance(limit, (int, float)) or not (0.0 < limit <= 5.0):
        raise InputError(f"the limit must be a fraction in (0, 5], got {limit!r}")
    bounds = tuple(tuple(float(v) for v in b) for b in bounds)
    if len(bounds) != 3 or any(len(b) != 2 or not (0 < b[0] < b[1]) for b in bounds):
        raise InputError(f"bounds must be three (low, high) pairs with 0 < low < high, got {bounds!r}")
    for name, value in (("maxiter", maxiter), ("popsize", popsize), ("linear_points", linear_points)):
        if isinstance(value, bool) or not isinstance(value, int) or value < (2 if name == "linear_points" else 1):
            raise InputError(f"{name} must be a positive integer, got {value!r}")
    wall = time.perf_counter()
    with ClosureEvaluator(plant, load_cases, members, workers=workers) as evaluator:
        return _optimize(evaluator, mode, limit, bounds, seed, maxiter, popsize, linear_points, progress, wall)


def _optimize(evaluator, mode, limit, bounds, seed, maxiter, popsize, linear_points, progress, wall):
    linear_grid = evaluator.evaluate([ClosureLaw(closing_time_s=float(t))
                                      for t in np.linspace(bounds[0][0], bounds[0][1], linear_points)],
                                     record=False)
    linear = best_linear(evaluator, mode, limit, linear_grid)
    generation = [0]

    def population_objective(x):  # x: (3, S), vectorized differential evolution
        laws = [ClosureLaw(closing_time_s=float(x[0, j]), break_opening=float(x[1, j]),
                           break_time_s=float(x[2, j])) for j in range(x.shape[1])]
        evs = evaluator.evaluate(laws)
        generation[0] += 1
        if progress is not None:
            progress(generation[0], evaluator.evaluations)
        return np.array([_objective(ev, mode, limit) for ev in evs])

    result = differential_evolution(population_objective, bounds, seed=seed, maxiter=maxiter, popsize=popsize,
                                    vectorized=True, updating="deferred", polish=False, tol=1e-6)
    # the optimum: the best law evaluated that meets the limit (the penalty lets the search cross the limit a little)
    key = "max_speed_rise" if mode == "head" else "max_head_rise"
    meeting = [h for h in evaluator.history if h.feasible_runs and getattr(h, key) <= limit]
    if not meeting:
        raise InputError(f"no two-stage law in the search box meets {key} <= {limit:g}; relax the limit or widen "
                         f"the bounds {bounds!r}")
    optimum = min(meeting, key=lambda h: _objective(h, mode, limit))
    feasible = [h for h in evaluator.history if h.feasible_runs]
    pts = np.array([[h.max_speed_rise, h.max_head_rise] for h in feasible]) if feasible else np.zeros((0, 2))
    front = [feasible[i] for i in pareto_front(pts)] if len(pts) else []
    return ClosureOptimum(mode=mode, limit=float(limit), law=optimum, best_linear=linear,
                          linear_family=linear_grid, pareto_two_stage=front, evaluations=evaluator.evaluations,
                          wall_time_s=time.perf_counter() - wall, de_message=str(result.message), bounds=bounds)


__all__ = ["PENALTY", "INFEASIBLE", "CLOSURE_MARGIN_S", "DEFAULT_BOUNDS", "MODES", "ClosureLaw", "closure_plant",
           "LawEvaluation", "ClosureEvaluator", "ClosureOptimum", "pareto_front", "best_linear", "optimize_closure"]
