"""Batched runs: N variants of one plant structure in one call, in parallel, one record per case.

A *variant* is a dictionary ``{"section.key": number}`` applied to a base plant with
:meth:`simulate.config.PlantConfig.with_overrides`; every case then runs through the same
:func:`simulate.loop.engine.run_simulation` that ``hillsim run`` uses, so a batch result is bit-identical to the single
run of the same plant. Numeric keys vary within one structure; keys that choose a model (penstock model, scenario
kind, pressure loop, characteristics: :data:`STRUCTURE_CHOICE_KEYS`) group the cases, one batch of numbers per group
with its own characteristics and compiled loop (:class:`BatchPool` and the closure optimization, whose cases share
one structure, refuse them). ``penstock.reaches`` may vary (a grid-convergence study): each case builds its own grid.

Parallelism (chosen by measurement, ``benchmarks/bench_batch.py``): the compiled loop releases the GIL, but about
half of a shipped-plant case is Python around it (the plant variant, the figures), which threads run one at a time;
``mechanism="processes"`` (the default for more than :data:`SERIAL_BELOW` cases) forks worker processes *after* the
parent has run the first case, so the workers inherit the compiled loop instead of compiling it again (about 3 s
each), and hands them chunks of cases. ``mechanism="threads"`` shares the memory instead (about 10 % slower on 2
cores); ``mechanism="serial"`` runs in the calling thread. :class:`BatchPool` keeps the workers across batches and
runs a batch for every member of an ensemble at once (:meth:`BatchPool.run_members`).

A case that fails (a value out of range, a pressure loop that does not converge, anything raised) becomes a record
with ``status`` and ``error``; the batch goes on.

What is read from each run (:func:`case_from_result`): the maxima/minima of speed and head at the turbine from the
series; N11 and opening extremes from the series, checked against the training range of nets characteristics
(``beyond_nets_range``); and, when the run's summary has them (the simulator's envelope and extrapolation record),
``min_pressure_head_m`` (+ ``min_pressure_head_*`` location keys) and ``extrapolation`` (a dictionary per kind with a
``fraction``/``time_fraction`` of time outside the trusted domain). Absent fields stay NaN / empty.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import multiprocessing
import signal
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, fields
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from hillchart.errors import HillsimError, InputError
from simulate.results.result import unit_series
from simulate.loop.parallel import available_cores as default_workers, checked_workers
from simulate.config import (GeneratorConfig, GovernorConfig, PenstockConfig, PlantConfig, SCENARIO_KEYS,
                             ScenarioConfig, SolverConfig, TurbineConfig, load_characteristics)

#: Below this many cases ``mechanism="auto"`` runs serially: forking a pool of workers from a process that holds
#: the compiled loop costs about 0.2 s, more than 100 shipped-plant cases take (bench_batch.py: processes lose at
#: N = 100, win by 2x at N = 1000 on 2 cores).
SERIAL_BELOW = 200
#: Keys that are numbers but change the structure the cases share (none today: ``penstock.reaches`` sizes the MOC
#: grid's arrays, and every case builds its own, so a grid-convergence sweep over it is a batch like any other).
STRUCTURE_KEYS: dict[str, str] = {}
#: Keys whose value is a name that selects a model. :func:`run_batch` (so ``hillsim sweep``) groups the cases by
#: them and runs one batch of numbers per group (each with its own compiled loop, characteristics and pool);
#: studies that share one structure among their cases (:class:`BatchPool`, closure optimization) refuse them.
STRUCTURE_CHOICE_KEYS = ("penstock.model", "scenario.kind", "solver.pressure_loop", "turbine.characteristics")
#: The two scenario keys of which exactly one is set; varying one removes the other.
_EXCLUSIVE = {"scenario.initial_power_mw": "scenario.initial_opening",
              "scenario.initial_opening": "scenario.initial_power_mw"}
_SECTION_CLASSES = {"turbine": TurbineConfig, "penstock": PenstockConfig, "generator": GeneratorConfig,
                    "governor": GovernorConfig, "scenario": ScenarioConfig, "solver": SolverConfig}
#: Sections a plant file may have (a surge tank, a draft tube, a double-regulated unit's blades, the generator's
#: voltage control and grid): their numeric keys vary like any other where the plant has the section.
OPTIONAL_SECTIONS = ("surge_tank", "draft_tube", "blade_servo", "combinator", "excitation", "grid")
#: Series kept per case with ``keep_series=True``.
SERIES_NAMES = ("time_s", "speed_rpm", "head_m", "flow_m3_s", "opening", "torque_nm")
MECHANISMS = ("auto", "serial", "processes", "threads")


@functools.cache
def _section_keys(section: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(numeric keys as ``section.key``, every key name) of a plant section; an optional section's class is
    imported here, when a key of it is first varied (some cost a quarter of a second of start-up)."""
    from simulate.config import _section_class

    cls = _SECTION_CLASSES.get(section) or _section_class(section)
    numeric = tuple(f"{section}.{f.name}" for f in fields(cls)
                    if str(f.type).replace(" ", "") in ("float", "int", "float|None", "int|None"))
    return numeric, tuple(f.name for f in fields(cls))


def numeric_keys() -> dict[str, tuple[str, ...]]:
    """Numeric keys of every plant section (what :func:`check_key` accepts before the scenario-kind check and, for
    an optional section, the check that the plant has it).

    Examples
    --------
    >>> "governor.closing_time_s" in numeric_keys()["governor"], "surge_tank.area_m2" in numeric_keys()["surge_tank"]
    (True, True)
    """
    return {section: _section_keys(section)[0] for section in (*_SECTION_CLASSES, *OPTIONAL_SECTIONS)}


def check_key(plant: PlantConfig, key: Any, *, choices: bool = False) -> str:
    """Validate a varied key against ``plant``: a numeric ``section.key`` that keeps the structure, or with
    ``choices`` also a key of :data:`STRUCTURE_CHOICE_KEYS` (a model's name; the batch groups the cases by it).

    Raises
    ------
    InputError
        Not ``section.key``; unknown section or key; a non-numeric key; a structure key; a scenario key the plant's
        scenario kind does not use. The message names the key and the allowed ones.

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> from data_synthetic import PLANT_HLA339
    >>> check_key(load_plant(PLANT_HLA339), "governor.kp")
    'governor.kp'
    """
    if not isinstance(key, str) or key.count(".") != 1 or not all(key.split(".")):
        raise InputError(f"varied key must be section.key (e.g. governor.closing_time_s), got {key!r}")
    section, name = key.split(".")
    sections = (*_SECTION_CLASSES, *OPTIONAL_SECTIONS)
    if section not in sections:
        raise InputError(f"unknown section in varied key {key!r}; valid sections: {', '.join(sections)}")
    numeric, names = _section_keys(section)
    if key in STRUCTURE_CHOICE_KEYS and choices:
        return key
    if key in STRUCTURE_KEYS or key in STRUCTURE_CHOICE_KEYS:
        why = STRUCTURE_KEYS.get(key, "it selects a model every case shares")
        raise InputError(f"varied key {key!r} changes the plant structure ({why}); this study's cases share one "
                         f"structure: run one study per {key} (a sweep groups its cases by it)")
    if name not in names:
        named = [k for k in STRUCTURE_CHOICE_KEYS if k.startswith(f"{section}.")] if choices else []
        raise InputError(f"unknown key {key!r}; numeric keys of [{section}]: {', '.join(numeric)}"
                         + (f"; keys of [{section}] that take a name: {', '.join(named)}" if named else ""))
    if section in OPTIONAL_SECTIONS and getattr(plant, section, None) is None:
        raise InputError(f"varied key {key!r}: the plant has no [{section}]; add the section to the plant file to "
                         f"vary its keys")
    if key not in numeric:
        names_note = (f"; of the keys that take a name only {', '.join(STRUCTURE_CHOICE_KEYS)} can be varied (a "
                      f"sweep groups its cases by them)") if choices else ""
        raise InputError(f"varied key {key!r} is not numeric (it takes a name or a table, not a number){names_note}; "
                         f"numeric keys of [{section}]: {', '.join(numeric)}")
    if section == "scenario" and name != "t_end_s" and name not in SCENARIO_KEYS[plant.scenario.kind]:
        raise InputError(f"varied key {key!r} is not used by scenario.kind = {plant.scenario.kind!r}; scenario "
                         f"keys of that kind: t_end_s, {', '.join(SCENARIO_KEYS[plant.scenario.kind])}")
    return key


@functools.cache
def integer_keys(section: str) -> tuple[str, ...]:
    """The keys of a plant section that take an integer (``penstock.reaches``, ``solver.max_iterations``, ...)."""
    from simulate.config import _section_class

    cls = _SECTION_CLASSES.get(section) or _section_class(section)
    return tuple(f"{section}.{f.name}" for f in fields(cls) if str(f.type).replace(" ", "") in ("int", "int|None"))


def check_value(key: str, value: Any) -> float:
    """A varied value must be a finite real number (bool refused); ints stay ints, and a key that takes an integer
    (:func:`integer_keys`, e.g. ``penstock.reaches``) gets one: a whole float (``8.0`` from a ``--vary`` list or
    range, or a ``cases.csv`` cell) becomes ``8``, a fraction is refused.

    Examples
    --------
    >>> check_value("penstock.reaches", 8.0), check_value("governor.kp", 2)
    (8, 2)
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"value of varied key {key!r} must be a number, got {value!r}")
    if not math.isfinite(float(value)):
        raise InputError(f"value of varied key {key!r} must be finite, got {value!r}")
    section = key.split(".")[0] if isinstance(key, str) and key.count(".") == 1 else None
    if section in (*_SECTION_CLASSES, *OPTIONAL_SECTIONS) and key in integer_keys(section):
        if float(value) != int(value):
            raise InputError(f"value of varied key {key!r} must be an integer (the key counts), got {value!r}")
        return int(value)
    return int(value) if isinstance(value, (int, np.integer)) else float(value)


def variant_overrides(variant: dict[str, float]) -> dict[str, Any]:
    """The override dictionary of a variant (adds the removal of the exclusive partner of an initial-point key)."""
    out: dict[str, Any] = dict(variant)
    for key in variant:
        partner = _EXCLUSIVE.get(key)
        if partner is not None and partner not in variant:
            out[partner] = None
    return out


@dataclass(frozen=True)
class CaseResult:
    """One case of a batch: its varied values, status and the figures of the run.

    ``status`` is ``"ok"``, ``"failed"`` (the run stopped: pressure-loop failure; figures over the series up to the
    failure) or ``"error"`` (no run: bad value, steady state impossible, ...). Heads are at the turbine inlet, m;
    ``max_speed_rise``, ``max_head_rise``, ``min_head_drop`` are fractions of the initial value; ``max_unit_speed_rpm``
    / ``min_unit_speed_rpm`` N11 = n D1 / sqrt(H), r/min; ``max_opening_chart`` chart units; ``beyond_nets_range``
    None when the characteristics have no training range. ``series`` only with ``keep_series``. For a plant with
    several units the figures are the worst over the units (as the run's summary gives them) and the N11 and opening
    ranges span every unit.
    """

    index: int
    values: dict
    status: str
    error: str = ""
    max_speed_rise: float = math.nan
    max_speed_rpm: float = math.nan
    t_max_speed_s: float = math.nan
    max_head_m: float = math.nan
    max_head_rise: float = math.nan
    t_max_head_s: float = math.nan
    min_head_m: float = math.nan
    min_head_drop: float = math.nan
    initial_opening: float = math.nan
    initial_power_mw: float = math.nan
    max_unit_speed_rpm: float = math.nan
    min_unit_speed_rpm: float = math.nan
    max_opening_chart: float = math.nan
    beyond_nets_range: bool | None = None
    min_pressure_head_m: float = math.nan
    min_pressure_head_at: str = ""
    extrapolation: dict | None = None
    steps: int = 0
    series: dict | None = field(default=None, compare=False, repr=False)
    #: the figures the plant's components give (a surge tank's highest and lowest level, a draft tube's lowest
    #: outlet pressure, a grid's frequency range, ...): :attr:`SimulationResult.component_figures`, the numbers
    components: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def extrapolated(self) -> bool | None:
        """True when the run left a trusted domain: the simulator's ``extrapolation`` record (any kind with a
        positive time fraction) or, without it, the nets' training range. None when neither is known."""
        kinds = extrapolation_kinds(self.extrapolation)
        if kinds is not None:
            return bool(kinds) or bool(self.beyond_nets_range)
        return self.beyond_nets_range


#: Figures of a case, in results.csv order (after index, the varied keys and status).
FIGURES = ("max_speed_rise", "max_speed_rpm", "t_max_speed_s", "max_head_m", "max_head_rise", "t_max_head_s",
           "min_head_m", "min_head_drop", "min_pressure_head_m", "min_pressure_head_at", "initial_opening",
           "initial_power_mw", "max_unit_speed_rpm", "min_unit_speed_rpm", "max_opening_chart", "beyond_nets_range",
           "extrapolated", "extrapolation", "steps", "error")


#: Keys of the simulator's extrapolation record that describe it rather than name a kind of extrapolation.
RECORD_METADATA = ("checked", "intervals_s", "training_n11_range", "training_opening_range",
                   "digitized_region_source", "digitized_region_unknown")


def extrapolation_kinds(record) -> dict[str, float] | None:
    """``{kind: time fraction}`` of the kinds with a positive fraction in the simulator's ``extrapolation`` record;
    None when there is no record.

    Accepted shapes: ``{kind: {"fraction": f, ...}}`` / ``{kind: {"time_fraction": f}}`` / ``{kind: f}``.

    Examples
    --------
    >>> extrapolation_kinds({"nets_range": {"fraction": 0.1, "n11_max": 95.0}, "full_stroke": {"fraction": 0.0}})
    {'nets_range': 0.1}
    >>> extrapolation_kinds(None) is None
    True
    >>> extrapolation_kinds({"checked": ["full_stroke"], "full_stroke": {"fraction_of_time": 0.0},
    ...                      "intervals_s": [], "training_n11_range": [40.0, 110.0]})  # metadata is not a kind
    {}
    """
    if record is None:
        return None
    if not isinstance(record, dict):
        return {"extrapolation": 1.0} if record else {}
    out = {}
    if "checked" in record:  # the simulator's record (simulate.loop.domain): the kinds it checked, beside metadata
        kinds = [k for k in record["checked"] if isinstance(k, str)] if isinstance(record["checked"], list) else []
        items = [(k, record[k]) for k in kinds if k in record]
    else:
        items = [(k, v) for k, v in record.items() if k not in RECORD_METADATA]
    for kind, value in items:
        if isinstance(value, dict):
            frac = next((value[k] for k in ("fraction", "time_fraction", "fraction_of_time") if k in value), None)
            if frac is None:
                frac = 1.0 if any(bool(v) for k, v in value.items() if k in ("extrapolated", "any", "reached")) \
                    else 0.0
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            frac = value
        else:
            frac = 1.0 if value else 0.0
        if isinstance(frac, (int, float)) and frac > 0:
            out[str(kind)] = float(frac)
    return out


def nets_domain(characteristics, plant: PlantConfig | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """The (N11, opening) training box ``(x_min, x_max)`` of nets characteristics (intersection of the flow and
    torque nets' mapminmax ranges), or None for characteristics without one (ideal turbine, user models).
    ``plant``: the box of the characteristics as that plant sees them, in the units of its runs' openings (a
    double-regulated unit's: the guide-vane angle above the closed vane, the blade angle on the cam)."""
    if plant is not None:
        from simulate.loop.engine import plant_characteristics

        characteristics = plant_characteristics(plant, characteristics)
    flow, torque = getattr(characteristics, "flow", None), getattr(characteristics, "torque", None)
    if flow is None or torque is None or not hasattr(flow, "x_min") or not hasattr(torque, "x_min"):
        return None
    return (np.maximum(np.asarray(flow.x_min, float), np.asarray(torque.x_min, float)),
            np.minimum(np.asarray(flow.x_max, float), np.asarray(torque.x_max, float)))


def case_from_result(index: int, values: dict, plant: PlantConfig, result, domain=None,
                     keep_series: bool = False) -> CaseResult:
    """The :class:`CaseResult` of one finished run (``result`` a :class:`simulate.results.result.SimulationResult`)."""
    summary = result.summary()
    # N11 and opening over every unit of the plant (its plant-level figures are the worst over the units)
    units = unit_series(result, plant)
    n11 = np.concatenate([s["speed_rpm"] * d / np.sqrt(np.maximum(s["head_m"], 1e-12)) for _, s, d in units])
    opening_chart = np.concatenate([s["opening_chart"] for _, s, _ in units])
    beyond = None
    if domain is not None:
        low, high = domain
        beyond = bool(n11.min() < low[0] or n11.max() > high[0] or opening_chart.min() < low[1]
                      or opening_chart.max() > high[1])
    min_ph = summary.get("min_pressure_head_m", math.nan)
    at = [f"{k}={summary[k]}" for k in sorted(summary) if k.startswith("min_pressure_head_")
          and k != "min_pressure_head_m"]
    extrap = summary.get("extrapolation")
    series = {name: np.asarray(getattr(result, name)).copy() for name in SERIES_NAMES} if keep_series else None
    components = {name: math.nan if value is None else float(value)
                  for name, value in result.component_figures.items()
                  if value is None or isinstance(value, (int, float)) and not isinstance(value, bool)}
    return CaseResult(
        index=index, values=dict(values), status="ok" if result.success else "failed",
        error="" if result.success else result.message,
        max_speed_rise=summary["max_speed_rise"], max_speed_rpm=summary["max_speed_rpm"],
        t_max_speed_s=summary["t_max_speed_s"], max_head_m=summary["max_head_m"],
        max_head_rise=summary["max_head_rise"], t_max_head_s=summary["t_max_head_s"],
        min_head_m=summary["min_head_m"], min_head_drop=summary["min_head_drop"],
        initial_opening=summary["initial_opening"], initial_power_mw=summary["initial_power_mw"],
        max_unit_speed_rpm=float(n11.max()), min_unit_speed_rpm=float(n11.min()),
        max_opening_chart=float(opening_chart.max()), beyond_nets_range=beyond,
        min_pressure_head_m=float(min_ph) if isinstance(min_ph, (int, float)) else math.nan,
        min_pressure_head_at=";".join(at), extrapolation=extrap if isinstance(extrap, dict) else None,
        steps=int(summary["steps"]), series=series, components=components)


def run_case(plant: PlantConfig, characteristics, index: int, variant: dict, *, domain=None,
             keep_series: bool = False, run: Callable | None = None, case_plant=None) -> CaseResult:
    """Run one variant of ``plant``; every failure becomes a record (``status`` ``"error"`` or ``"failed"``).
    ``case_plant``: the variant's plant when the caller built it already (the same variant for several
    characteristics)."""
    from simulate.loop.engine import run_simulation

    run = run_simulation if run is None else run
    try:
        if case_plant is None:
            case_plant = plant.with_overrides(variant_overrides(variant)) if variant else plant
        result = run(case_plant, characteristics=characteristics, raise_on_failure=False)
        return case_from_result(index, variant, case_plant, result, domain, keep_series)
    except (HillsimError, ValueError, ArithmeticError, FloatingPointError) as exc:
        return CaseResult(index=index, values=dict(variant), status="error", error=f"{type(exc).__name__}: {exc}")


@dataclass
class BatchResult:
    """All cases of a batch, in the order given, with the run's settings."""

    keys: tuple[str, ...]
    cases: list[CaseResult]
    mechanism: str
    workers: int
    chunk_size: int
    wall_time_s: float

    @property
    def case_steps(self) -> int:
        return int(sum(c.steps for c in self.cases))

    @property
    def n_ok(self) -> int:
        return sum(c.ok for c in self.cases)

    @property
    def component_figures(self) -> tuple[str, ...]:
        """The names of the components' figures over the cases (:attr:`CaseResult.components`), in order."""
        return tuple(dict.fromkeys(name for c in self.cases for name in c.components))

    def column(self, name: str) -> np.ndarray:
        """A figure (or a varied key, or a component's figure) over the cases, float array (NaN where missing); a
        varied model's name (:data:`STRUCTURE_CHOICE_KEYS`) as a string array."""
        if name in STRUCTURE_CHOICE_KEYS and name in self.keys:
            return np.array([str(c.values.get(name, "")) for c in self.cases])
        if name in self.keys:
            return np.array([float(c.values.get(name, math.nan)) for c in self.cases])
        if name not in FIGURES and name in self.component_figures:
            return np.array([c.components.get(name, math.nan) for c in self.cases], dtype=float)
        return np.array([float(getattr(c, name)) if getattr(c, name) is not None else math.nan
                         for c in self.cases])

    def rows(self) -> list[dict]:
        """One dictionary per case: ``index``, the varied keys, ``status``, :data:`FIGURES`, then the components'
        figures (:attr:`component_figures`; NaN where a case has none, e.g. an error)."""
        components = self.component_figures
        out = []
        for c in self.cases:
            row = {"index": c.index}
            row.update({k: c.values.get(k, "") for k in self.keys})
            row["status"] = c.status
            for name in FIGURES:
                value = getattr(c, name)
                if name == "extrapolation":
                    kinds = extrapolation_kinds(value)
                    value = "" if kinds is None else ";".join(f"{k}:{v:.6g}" for k, v in sorted(kinds.items()))
                row[name] = value
            row.update({name: c.components.get(name, math.nan) for name in components})
            out.append(row)
        return out

    def to_csv(self, path) -> None:
        """Write results.csv (floats in repr, so the file round-trips exactly; NaN/None as empty cells)."""
        import csv
        from pathlib import Path

        rows = self.rows()
        header = ["index", *self.keys, "status", *FIGURES, *self.component_figures]
        with open(Path(path), "w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            writer.writerow(header)
            for row in rows:
                writer.writerow([_cell(row[h]) for h in header])


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return str(value)


# ---------------------------------------------------------------------------------------------------------------
# workers
# ---------------------------------------------------------------------------------------------------------------
_WORKER: dict = {}


_FORK_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP", "SIGXCPU") if hasattr(signal, n))


class _SignalsBlockedWhileForking:
    """Blocks SIGINT/SIGTERM/SIGHUP/SIGXCPU while a pool forks its workers: a worker is born with the parent's
    Python handlers and keeps them until its initializer resets them (:func:`_worker_signals`, which unblocks); a
    signal in between would end it with the parent's exception and a traceback. The parent receives what arrived
    once the workers exist."""

    def __enter__(self):
        self.blocked = hasattr(signal, "pthread_sigmask")
        if self.blocked:
            self.previous = signal.pthread_sigmask(signal.SIG_BLOCK, _FORK_SIGNALS)
        return self

    def __exit__(self, *exc):
        if self.blocked:
            signal.pthread_sigmask(signal.SIG_SETMASK, self.previous)


def _worker_signals() -> None:
    """A forked worker must not keep the parent's signal handlers (the CLI's raise exceptions that end in a
    traceback on stderr when the pool terminates its workers with SIGTERM): SIGTERM, SIGHUP and SIGXCPU end a
    worker quietly, SIGINT is left to the parent (it stops the pool)."""
    import signal

    for name in ("SIGTERM", "SIGHUP", "SIGXCPU"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):  # blocked by the parent while it forked (_SignalsBlockedWhileForking)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _FORK_SIGNALS)


def _init_worker(plant, characteristics, domain, keep_series):
    _worker_signals()
    _WORKER.update(plant=plant, characteristics=characteristics, domain=domain, keep_series=keep_series)


def _run_chunk_in_worker(chunk):
    w = _WORKER
    return [run_case(w["plant"], w["characteristics"], i, v, domain=w["domain"], keep_series=w["keep_series"])
            for i, v in chunk]


def run_chunk(plant: PlantConfig, characteristics, chunk: Sequence[tuple[int, dict]], keep_series: bool = False):
    """Run a chunk ``[(index, variant), ...]`` serially (the unit of work of every parallel mechanism, Dask too)."""
    domain = nets_domain(characteristics, plant)
    return [run_case(plant, characteristics, i, v, domain=domain, keep_series=keep_series) for i, v in chunk]


def check_choice_value(key: str, value: Any) -> str:
    """The value of a :data:`STRUCTURE_CHOICE_KEYS` key: a non-empty name (what the plant file would hold)."""
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"value of varied key {key!r} selects a model: a name (e.g. penstock.model = \"rigid\"), "
                         f"got {value!r}")
    return value.strip()


def validate_variants(plant: PlantConfig, variants: Iterable[dict], *,
                      choices: bool = False) -> tuple[tuple[str, ...], list[dict]]:
    """Check every variant's keys (:func:`check_key`) and values (:func:`check_value`, or
    :func:`check_choice_value` for a model's name with ``choices``); returns (keys, variants)."""
    out, keys = [], []
    for i, variant in enumerate(variants):
        if not isinstance(variant, dict):
            raise InputError(f"variant {i} must be a dictionary {{section.key: number}}, got {variant!r}")
        clean = {}
        for key, value in variant.items():
            check_key(plant, key, choices=choices)
            clean[key] = check_choice_value(key, value) if key in STRUCTURE_CHOICE_KEYS else check_value(key, value)
            if key not in keys:
                keys.append(key)
        out.append(clean)
    both = [k for k in _EXCLUSIVE if k in keys]
    if len(both) == 2:
        raise InputError("scenario.initial_power_mw and scenario.initial_opening cannot both be varied: a case "
                         "starts from exactly one of them")
    return tuple(keys), out


def run_batch(plant: PlantConfig, variants: Iterable[dict], *, characteristics=None, mechanism: str = "auto",
              workers: int | None = None, chunk_size: int | None = None, keep_series: bool = False,
              progress: Callable[[int, int], None] | None = None) -> BatchResult:
    """Run every variant of ``plant`` and return one :class:`CaseResult` per variant, in order.

    Parameters
    ----------
    plant : PlantConfig
        The base plant (structure shared by every case).
    variants : iterable of dict
        ``{"section.key": number}`` per case (an empty dict runs the base plant).
    characteristics : optional
        Turbine characteristics; default ``plant.turbine.characteristics`` loaded once.
    mechanism : {"auto", "serial", "processes", "threads"}
        ``auto``: serial below :data:`SERIAL_BELOW` cases or with one worker, processes otherwise.
    workers : int, optional
        Parallel workers (default: the cores this process may use).
    chunk_size : int, optional
        Cases per task (default: about four chunks per worker, at most 64 cases).
    keep_series : bool
        Keep the time series of each case in ``CaseResult.series``.
    progress : callable(done, total), optional
        Called after each chunk.

    Raises
    ------
    InputError
        A bad key or value (before anything runs). Failing cases do not raise: they are records.

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> from data_synthetic import PLANT_HLA339
    >>> plant = load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 3.0,
    ...                                   "penstock.model": "rigid"})
    >>> batch = run_batch(plant, [{"governor.closing_time_s": 8.0}, {"governor.closing_time_s": -1.0}])
    >>> [c.status for c in batch.cases]
    ['ok', 'error']
    """
    if mechanism not in MECHANISMS:
        raise InputError(f"mechanism must be one of {', '.join(MECHANISMS)}, got {mechanism!r}")
    keys, variants = validate_variants(plant, variants, choices=True)
    if any(key in STRUCTURE_CHOICE_KEYS for key in keys):
        return _run_grouped(plant, keys, variants, characteristics=characteristics, mechanism=mechanism,
                            workers=workers, chunk_size=chunk_size, keep_series=keep_series, progress=progress)
    n = len(variants)
    workers = checked_workers(workers)
    if chunk_size is None:
        chunk_size = max(1, min(64, math.ceil(n / (4 * workers)))) if n else 1
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        raise InputError(f"chunk_size must be a positive integer, got {chunk_size!r}")
    chars = load_characteristics(plant.turbine, plant.base_dir) if characteristics is None else characteristics
    domain = nets_domain(chars, plant)
    if mechanism == "auto":
        mechanism = "serial" if n < SERIAL_BELOW or workers == 1 else "processes"
    wall = time.perf_counter()
    indexed = list(enumerate(variants))
    cases: list[CaseResult] = []

    def report(done):
        if progress is not None:
            progress(done, n)

    if mechanism == "serial" or n == 0:
        for start in range(0, n, chunk_size):
            cases.extend(run_chunk(plant, chars, indexed[start:start + chunk_size], keep_series))
            report(len(cases))
    else:
        # the first case in this process: compiles the loop before the workers fork (they inherit it)
        cases.extend(run_chunk(plant, chars, indexed[:1], keep_series))
        report(1)
        rest = indexed[1:]
        chunks = [rest[s:s + chunk_size] for s in range(0, len(rest), chunk_size)]
        if not chunks:
            pass
        elif mechanism == "threads":
            with ThreadPoolExecutor(max_workers=workers) as pool:
                for part in pool.map(lambda c: run_chunk(plant, chars, c, keep_series), chunks):
                    cases.extend(part)
                    report(len(cases))
        else:
            ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods()
                                              else "spawn")
            with _SignalsBlockedWhileForking():
                pool = ctx.Pool(processes=min(workers, max(1, len(chunks))), initializer=_init_worker,
                                initargs=(plant, chars, domain, keep_series))
            with pool:
                for part in pool.imap_unordered(_run_chunk_in_worker, chunks):
                    cases.extend(part)
                    report(len(cases))
    cases.sort(key=lambda c: c.index)
    return BatchResult(keys=keys, cases=cases, mechanism=mechanism, workers=workers, chunk_size=chunk_size,
                       wall_time_s=time.perf_counter() - wall)


def structure_variant(plant: PlantConfig, names: dict[str, str]) -> tuple[PlantConfig, Any]:
    """``plant`` with the model names ``names`` (:data:`STRUCTURE_CHOICE_KEYS` -> name), and its characteristics
    when ``turbine.characteristics`` is among them (None otherwise: the base plant's serve).

    Raises
    ------
    InputError
        A name the plant file would refuse, or characteristics that cannot be read; the message names the varied
        key and value.
    """
    try:
        varied = plant.with_overrides(names) if names else plant
        chars = (load_characteristics(varied.turbine, varied.base_dir) if "turbine.characteristics" in names
                 else None)
    except InputError as exc:
        raise InputError(f"varied {', '.join(f'{k} = {v!r}' for k, v in names.items())}: {exc}") from None
    return varied, chars


def _run_grouped(plant: PlantConfig, keys: tuple, variants: list[dict], *, characteristics, mechanism, workers,
                 chunk_size, keep_series, progress) -> BatchResult:
    """:func:`run_batch` of variants that vary :data:`STRUCTURE_CHOICE_KEYS`: the cases grouped by their model
    names, each group's plant (and characteristics, when ``turbine.characteristics`` varies) built and checked
    before anything runs, one batch of numbers per group, the records back in the variants' order."""
    choice_keys = [k for k in keys if k in STRUCTURE_CHOICE_KEYS]
    groups: dict[tuple, list[int]] = {}
    for i, variant in enumerate(variants):
        groups.setdefault(tuple(variant.get(k) for k in choice_keys), []).append(i)
    plan = []
    shared = characteristics
    for choice, indices in groups.items():
        group_plant, chars = structure_variant(plant, {k: v for k, v in zip(choice_keys, choice) if v is not None})
        if chars is None:
            if shared is None:
                shared = load_characteristics(plant.turbine, plant.base_dir)
            chars = shared
        numeric = [{k: v for k, v in variants[i].items() if k not in STRUCTURE_CHOICE_KEYS} for i in indices]
        plan.append((group_plant, chars, indices, numeric))
    wall = time.perf_counter()
    cases: list[CaseResult] = []
    done = 0
    result = None
    for group_plant, chars, indices, numeric in plan:
        def report(count, _total, offset=done):
            if progress is not None:
                progress(offset + count, len(variants))

        result = run_batch(group_plant, numeric, characteristics=chars, mechanism=mechanism, workers=workers,
                           chunk_size=chunk_size, keep_series=keep_series, progress=report)
        for case in result.cases:  # the record of the whole variant, at its place among all the variants
            index = indices[case.index]
            cases.append(dataclasses.replace(case, index=index, values=dict(variants[index])))
        done += len(indices)
    cases.sort(key=lambda c: c.index)
    return BatchResult(keys=keys, cases=cases, mechanism=result.mechanism, workers=result.workers,
                       chunk_size=result.chunk_size, wall_time_s=time.perf_counter() - wall)


def _init_pool_worker(plant, members, domains):
    _worker_signals()
    _WORKER.update(plant=plant, members=members, domains=domains)


def run_chunk_members(plant: PlantConfig, members: Sequence, domains: Sequence, chunk: Sequence[tuple[int, dict]],
                      keep_series: bool = False) -> list[list[CaseResult]]:
    """A chunk of variants for every characteristics of ``members``: each variant's plant is built once. One list
    of :class:`CaseResult` per member."""
    out: list[list[CaseResult]] = [[] for _ in members]
    for index, variant in chunk:
        try:
            case_plant = plant.with_overrides(variant_overrides(variant)) if variant else plant
        except (HillsimError, ValueError, ArithmeticError) as exc:
            for cases in out:
                cases.append(CaseResult(index=index, values=dict(variant), status="error",
                                        error=f"{type(exc).__name__}: {exc}"))
            continue
        for cases, chars, domain in zip(out, members, domains):
            cases.append(run_case(plant, chars, index, variant, domain=domain, keep_series=keep_series,
                                  case_plant=case_plant))
    return out


def _run_pool_members(task):
    members, keep_series, chunk = task
    w = _WORKER
    return run_chunk_members(w["plant"], [w["members"][m] for m in members], [w["domains"][m] for m in members],
                             chunk, keep_series)


def _run_pool_chunk(task):
    member, keep_series, chunk = task
    w = _WORKER
    return [run_case(w["plant"], w["members"][member], i, v, domain=w["domains"][member], keep_series=keep_series)
            for i, v in chunk]


class BatchPool:
    """Worker processes kept across many batches of one plant (the generations of an optimizer, say).

    The pool is forked once, after this process has run the plant once (so the workers inherit the compiled loop);
    each :meth:`run` then costs only the transfer of its chunks, which makes batches of a few dozen cases worth
    running in parallel (a fresh pool per batch pays off only from :data:`SERIAL_BELOW` cases on). ``members`` are
    the characteristics a batch can use (e.g. the members of an ensemble), chosen per :meth:`run` by index. With one
    worker everything runs in this process. Use as a context manager, or call :meth:`close`.
    """

    def __init__(self, plant: PlantConfig, members: Sequence | None = None, *, workers: int | None = None):
        self.plant = plant
        self.members = list(members) if members else [load_characteristics(plant.turbine, plant.base_dir)]
        self.domains = [nets_domain(m, plant) for m in self.members]
        self.workers = checked_workers(workers)
        self._pool = None
        if self.workers > 1:
            run_case(plant, self.members[0], 0, {})  # compile here, before the fork
            ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods()
                                              else "spawn")
            with _SignalsBlockedWhileForking():
                self._pool = ctx.Pool(processes=self.workers, initializer=_init_pool_worker,
                                      initargs=(plant, self.members, self.domains))

    def _check_member(self, member) -> None:
        if isinstance(member, bool) or not isinstance(member, int) or not 0 <= member < len(self.members):
            raise InputError(f"member must be an index in [0, {len(self.members) - 1}], got {member!r}")

    def run(self, variants: Iterable[dict], *, member: int = 0, chunk_size: int | None = None,
            keep_series: bool = False) -> BatchResult:
        """Like :func:`run_batch` with ``characteristics = members[member]``, on the pool's workers."""
        self._check_member(member)
        keys, variants = validate_variants(self.plant, variants)
        n = len(variants)
        if chunk_size is None:
            chunk_size = max(1, math.ceil(n / (2 * self.workers))) if n else 1
        wall = time.perf_counter()
        indexed = list(enumerate(variants))
        chunks = [indexed[s:s + chunk_size] for s in range(0, n, chunk_size)]
        if self._pool is None:
            parts = [run_chunk(self.plant, self.members[member], chunk, keep_series) for chunk in chunks]
        else:
            parts = self._pool.map(_run_pool_chunk, [(member, keep_series, chunk) for chunk in chunks])
        cases = sorted((c for part in parts for c in part), key=lambda c: c.index)
        return BatchResult(keys=keys, cases=cases, mechanism="pool" if self._pool is not None else "serial",
                           workers=self.workers, chunk_size=chunk_size, wall_time_s=time.perf_counter() - wall)

    def run_members(self, variants: Iterable[dict], members: Sequence[int] | None = None, *,
                    keep_series: bool = False) -> list[BatchResult]:
        """:meth:`run` of the same variants for each of ``members`` (default all), as one batch: a chunk of variants
        runs for every member (each variant's plant built once) and the workers take the chunks of all members
        together (one wait for the slowest chunk, not one per member). One :class:`BatchResult` per member, in the
        order given."""
        members = list(range(len(self.members))) if members is None else list(members)
        for member in members:
            self._check_member(member)
        keys, variants = validate_variants(self.plant, variants)
        n = len(variants)
        chunk_size = max(1, math.ceil(n / (4 * self.workers))) if n else 1
        wall = time.perf_counter()
        indexed = list(enumerate(variants))
        tasks = [(members, keep_series, indexed[s:s + chunk_size]) for s in range(0, n, chunk_size)]
        if self._pool is None:
            parts = [run_chunk_members(self.plant, [self.members[m] for m in members],
                                       [self.domains[m] for m in members], chunk, keep_series)
                     for _, _, chunk in tasks]
        else:
            parts = self._pool.map(_run_pool_members, tasks)
        wall = time.perf_counter() - wall
        return [BatchResult(keys=keys, cases=sorted((c for part in parts for c in part[j]), key=lambda c: c.index),
                            mechanism="pool" if self._pool is not None else "serial", workers=self.workers,
                            chunk_size=chunk_size, wall_time_s=wall) for j in range(len(members))]

    def close(self) -> None:
        if self._pool is not None:
            self._pool.close()
            self._pool.join()
            self._pool = None

    def __enter__(self) -> "BatchPool":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


__all__ = ["SERIAL_BELOW", "STRUCTURE_KEYS", "STRUCTURE_CHOICE_KEYS", "MECHANISMS", "FIGURES", "CaseResult",
           "BatchResult", "BatchPool", "numeric_keys", "check_key", "check_value", "check_choice_value",
           "variant_overrides", "extrapolation_kinds", "nets_domain", "case_from_result", "run_case", "run_chunk",
           "run_chunk_members", "run_batch", "structure_variant", "validate_variants", "default_workers"]
