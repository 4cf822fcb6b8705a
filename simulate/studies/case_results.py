"""The records of a batch: one :class:`CaseResult` per case, read from its run (:func:`case_from_result`,
:func:`run_case`), and the :class:`BatchResult` of them all with its ``results.csv``.

What is read from each run (:func:`case_from_result`): the maxima/minima of speed and head at the turbine from the
series; N11 and opening extremes from the series, checked against the training range of nets characteristics
(``beyond_nets_range``, :func:`nets_domain`); and, when the run's summary has them (the simulator's envelope and
extrapolation record), ``min_pressure_head_m`` (+ ``min_pressure_head_*`` location keys) and ``extrapolation`` (a
dictionary per kind with a ``fraction``/``time_fraction`` of time outside the trusted domain,
:func:`extrapolation_kinds`). Absent fields stay NaN / empty. A case that fails (a value out of range, a pressure
loop that does not converge, anything raised) becomes a record with ``status`` and ``error``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from hillchart.errors import HillsimError
from hillchart.characteristics import unit_speed
from simulate.config import PlantConfig
from simulate.results.result import unit_series
from simulate.studies.variants import STRUCTURE_CHOICE_KEYS, variant_overrides

#: Series kept per case with ``keep_series=True``.
SERIES_NAMES = ("time_s", "speed_rpm", "head_m", "flow_m3_s", "opening", "torque_nm")


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


def worst_over_units(figures: dict, name: str):
    """The figure ``name`` of ``figures`` (a summary or a case's component figures), or for a plant with several
    units, whose figures are named ``unit.name``, the worst of theirs: the smallest of a ``min_`` figure, the largest
    of a ``max_`` one; None when there is none.

    >>> worst_over_units({"U1.min_draft_tube_pressure_head_m": 3.0, "U2.min_draft_tube_pressure_head_m": 2.5},
    ...                  "min_draft_tube_pressure_head_m")
    2.5
    """
    if figures.get(name) is not None:
        return figures[name]
    values = [float(v) for k, v in figures.items() if k.endswith("." + name) and isinstance(v, (int, float))
              and not isinstance(v, bool) and math.isfinite(v)]
    if not values or not name.startswith(("min_", "max_")):
        return None
    return min(values) if name.startswith("min_") else max(values)


def case_from_result(index: int, values: dict, plant: PlantConfig, result, domain=None,
                     keep_series: bool = False) -> CaseResult:
    """The :class:`CaseResult` of one finished run (``result`` a :class:`simulate.results.result.SimulationResult`)."""
    summary = result.summary()
    # N11 and opening over every unit of the plant (its plant-level figures are the worst over the units)
    units = unit_series(result, plant)
    n11 = np.concatenate([unit_speed(s["speed_rpm"], np.maximum(s["head_m"], 1e-12), d) for _, s, d in units])
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
