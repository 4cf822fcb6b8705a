"""Guarantee figures of a load rejection, trained nets against the exact turbine behind the chart.

A user signs the max speed rise and max head rise of a load rejection, not a fit of the chart. This module measures
those answers on the synthetic Francis family (:data:`hillchart.synthetic.francis.FAMILY`): a chart is digitized from an
exact turbine, trained with ``hillsim train``'s defaults, and the same load rejections are simulated once with the
trained nets (and once per ensemble member, the ``run --uncertainty`` band) and once with the exact turbine.
Used by ``benchmarks/bench_guarantee.py`` (the whole grid) and by the acceptance tests (one seed per turbine), so
both report the same numbers.

The plant is sized from each turbine so that the rated power is reachable: a 225 MW unit at 176 m rated head on a
600 m MOC penstock (two segments, flow velocity about 4.7 m/s at rated flow, as the HLA339 example plant), the rated
point at 1.046 x the best-efficiency N11 and 73.3 % opening (the HLA339's rated point relative to its best point).
"""

from __future__ import annotations

import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
from hillchart.errors import HillsimError
from hillchart.generalization import best_efficiency_n11
from hillchart.synthetic.francis import FAMILY, DigitizationOptions, synthetic_chart_texts

#: Rated head (m), power (MW) and static head (m) of the benchmark plant (the HLA339 example unit).
RATED_HEAD_M = 176.0
RATED_POWER_MW = 225.0
STATIC_HEAD_M = 180.0
#: Rated point relative to the best-efficiency point: N11 ratio and opening fraction (HLA339: N11 67.8, a 23.46 mm).
RATED_N11_RATIO = 1.046
RATED_OPENING_FRACTION = 0.733
#: Penstock flow velocity at rated flow, m/s (HLA339 example: 142.5 m^3/s in 6.2 m).
PENSTOCK_VELOCITY_M_S = 4.72
#: Guarantee figures compared (keys of SimulationResult.summary(), fractions of the initial values).
FIGURES = ("max_speed_rise", "max_head_rise", "min_head_drop")
#: Figures whose ensemble band is judged (coverage and width).
BAND_JUDGED = ("max_speed_rise", "max_head_rise")
#: Default load cases: (closing time of a full stroke s, initial load fraction of rated power).
CLOSING_TIMES_S = (8.0, 10.0, 14.0)
LOAD_FRACTIONS = (1.0, 0.6)

#: Digitizations of the benchmark: dense as a careful engineer (8 lines of 6 unevenly spaced points, l/s, percent);
#: sparse cycles through 4-6 lines of 3-5 points with the seed.
def digitization(density: str, *, noise_pct: float, runaway: bool, seed: int) -> DigitizationOptions:
    """The digitization options of the benchmark grid ("dense" or "sparse")."""
    if density == "dense":
        lines, points = 8, 6
    elif density == "sparse":
        lines, points = 4 + seed % 3, 3 + (seed + 1) % 3
    else:
        raise ValueError(f"density must be 'dense' or 'sparse', got {density!r}")
    return DigitizationOptions(points_per_line=points, spacing="uneven", noise_pct=noise_pct, q11_unit="l/s",
                               efficiency_unit="percent", opening_lines=lines, runaway=runaway)


def family_plant_dict(turbine_name: str, *, closing_time_s: float = 10.0, load_fraction: float = 1.0,
                      t_end_s: float = 30.0) -> dict:
    """Plant dictionary (as parsed from TOML) of the benchmark unit for one family turbine, openings in mm.

    Rated point: N11_r = :data:`RATED_N11_RATIO` x best N11, a_r = :data:`RATED_OPENING_FRACTION` x full stroke;
    D1 from P_r = rho g Q11_r D1^2 H_r^1.5 eta_r, n_r = N11_r sqrt(H_r) / D1, Q_r = P_r / (rho g H_r eta_r).
    """
    exact = FAMILY[turbine_name].turbine()
    n11_r = RATED_N11_RATIO * best_efficiency_n11(exact)
    a_r = RATED_OPENING_FRACTION * exact.opening_max
    q11_r = float(exact.q11(n11_r, a_r))
    eta_r = float(exact.efficiency(n11_r, a_r))
    flow = RATED_POWER_MW * 1e6 / (RHO_WATER_KG_M3 * G_M_S2 * RATED_HEAD_M * eta_r)
    d1 = float(np.sqrt(flow / (q11_r * np.sqrt(RATED_HEAD_M))))
    speed = n11_r * np.sqrt(RATED_HEAD_M) / d1
    pipe = float(np.sqrt(4.0 * flow / (np.pi * PENSTOCK_VELOCITY_M_S)))
    return {
        "turbine": {"rated_head_m": RATED_HEAD_M, "rated_flow_m3_s": round(flow, 4), "rated_speed_rpm": round(speed, 4),
                    "rated_power_mw": RATED_POWER_MW, "runner_diameter_m": round(d1, 5),
                    "opening_max": float(exact.opening_max), "characteristics": "ideal"},
        "penstock": {"model": "moc", "static_head_m": STATIC_HEAD_M, "reaches": 8,
                     "segments": [{"length_m": 400.0, "diameter_m": round(pipe, 4), "wave_speed_m_s": 1120.0,
                                   "darcy_friction": 0.012},
                                  {"length_m": 200.0, "diameter_m": round(0.9 * pipe, 4), "wave_speed_m_s": 1180.0,
                                   "darcy_friction": 0.012}]},
        "generator": {"inertia_time_s": 9.0, "self_regulation": 1.0},
        "governor": {"kp": 2.0, "ki": 0.4, "kd": 0.5, "derivative_filter_s": 0.2, "permanent_droop": 0.0,
                     "servo_time_s": 0.2, "closing_time_s": float(closing_time_s), "opening_time_s": 20.0,
                     "stroke_min": 0.0, "stroke_max": 1.0},
        "scenario": {"kind": "load-rejection", "t_end_s": float(t_end_s),
                     "initial_power_mw": RATED_POWER_MW * float(load_fraction), "event_time_s": 1.0},
        "solver": {"pressure_loop": "improved", "tolerance": 1e-10, "max_iterations": 50, "relaxation": 1.0},
    }


def family_plant(turbine_name: str, *, opening_max: float | None = None, **kwargs):
    """:class:`simulate.config.PlantConfig` of :func:`family_plant_dict`; ``opening_max`` in the chart's opening
    unit when the characteristics take another unit than mm (the same stroke: a = y * opening_max)."""
    from simulate.config import plant_from_dict

    raw = family_plant_dict(turbine_name, **kwargs)
    if opening_max is not None:
        raw["turbine"]["opening_max"] = float(opening_max)
    return plant_from_dict(raw)


@dataclass(frozen=True)
class CaseResult:
    """One load rejection: exact, nets (point) and the ensemble band of each figure, fractions."""

    closing_time_s: float
    load_fraction: float
    exact: dict
    nets: dict
    members: dict  # figure -> list of the ensemble members' values (empty without the band)

    @property
    def band(self) -> dict:
        """Figure -> (low, high): the ``run --uncertainty`` 5-95 % band
        (:func:`simulate.studies.uncertainty.figure_band`); NaN without members."""
        from simulate.studies.uncertainty import figure_band

        return {k: tuple(float(v) for v in figure_band(vals)) if len(vals) else (np.nan, np.nan)
                for k, vals in self.members.items()}

    def error_pt(self, figure: str) -> float:
        """Nets minus exact, points (percent of the initial value)."""
        return 100.0 * (self.nets[figure] - self.exact[figure])

    def covered(self, figure: str) -> bool:
        low, high = self.band[figure]
        return bool(low <= self.exact[figure] <= high)

    def width_pt(self, figure: str) -> float:
        low, high = self.band[figure]
        return 100.0 * (high - low)


@dataclass(frozen=True)
class ChartGuarantee:
    """All load cases of one digitized, trained chart."""

    turbine: str
    density: str
    noise_pct: float
    runaway: bool
    seed: int
    cases: list = field(default_factory=list)
    refused: str | None = None  # what ``hillsim train`` would say instead of writing the nets
    train_s: float = 0.0

    def worst_error_pt(self, figure: str) -> float:
        return max(abs(c.error_pt(figure)) for c in self.cases)

    def to_dict(self) -> dict:
        """JSON-ready record (the benchmark's ``--json``)."""
        return {"turbine": self.turbine, "density": self.density, "noise_pct": self.noise_pct,
                "runaway": self.runaway, "seed": self.seed, "refused": self.refused, "train_s": self.train_s,
                "cases": [{"closing_time_s": c.closing_time_s, "load_fraction": c.load_fraction, "exact": c.exact,
                           "nets": c.nets, "members": c.members} for c in self.cases]}

    @classmethod
    def from_dict(cls, doc: dict) -> "ChartGuarantee":
        cases = [CaseResult(c["closing_time_s"], c["load_fraction"], c["exact"], c["nets"], c["members"])
                 for c in doc["cases"]]
        return cls(doc["turbine"], doc["density"], doc["noise_pct"], doc["runaway"], doc["seed"], cases,
                   doc["refused"], doc["train_s"])


def _figures(result) -> dict:
    s = result.summary()
    return {k: float(s[k]) for k in FIGURES}


def evaluate_chart(turbine_name: str, *, density: str = "dense", noise_pct: float = 0.15, runaway: bool = True,
                   seed: int = 0, closing_times_s=CLOSING_TIMES_S, load_fractions=LOAD_FRACTIONS,
                   train_kwargs: dict | None = None, extension=None, band: bool = True) -> ChartGuarantee:
    """Digitize, train with the defaults of ``hillsim train`` and simulate every load case with the nets, each
    ensemble member (when ``band``; otherwise the band is NaN) and the exact turbine."""
    import time

    from hillchart.extension.extend import ExtensionOptions, extend_samples
    from hillchart.nets.training import train_nets
    from hillchart.extension.plausibility import efficiency_plausibility, thin_chart_notes
    from hillchart.io.samples import load_chart
    from simulate.loop.engine import run_simulation
    from simulate.studies.uncertainty import run_members

    options = digitization(density, noise_pct=noise_pct, runaway=runaway, seed=seed)
    exact = FAMILY[turbine_name].turbine()
    texts = synthetic_chart_texts(seed=seed, turbine=turbine_name, options=options)
    kwargs = {"ensemble": 10, "seed": seed}  # hillsim train's defaults
    kwargs.update(train_kwargs or {})
    with tempfile.TemporaryDirectory() as folder:
        for name, text in texts.items():
            (Path(folder) / name).write_text(text, encoding="utf-8")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            chart = load_chart(folder)
            start = time.perf_counter()
            extended = extend_samples(chart, extension or ExtensionOptions())
            nets = train_nets(extended, **kwargs)
            train_s = time.perf_counter() - start
    # as hillsim train: the efficiency check refuses a chart that is not thin, warns on a thin one
    refused = None if thin_chart_notes(chart) else (efficiency_plausibility(nets, chart) or None)
    chart_opening_max = float(chart.info.opening_max)
    cases = []
    for closing in closing_times_s:
        for load in load_fractions:
            exact_plant = family_plant(turbine_name, closing_time_s=closing, load_fraction=load)
            nets_plant = family_plant(turbine_name, closing_time_s=closing, load_fraction=load,
                                      opening_max=chart_opening_max)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                for label, plant, chars in (("exact turbine", exact_plant, exact), ("nets", nets_plant, nets)):
                    try:
                        figures = _figures(run_simulation(plant, characteristics=chars))
                    except HillsimError as exc:  # re-raised with the case it belongs to
                        raise type(exc)(f"{label}, closing {closing} s, load {load:.0%}: {exc}") from exc
                    if label == "nets":
                        got = figures
                    else:
                        want = figures
                members = run_members(nets_plant, nets) if band else {k: {"values": []} for k in BAND_JUDGED}
            cases.append(CaseResult(closing, load, want, got, {k: list(members[k]["values"]) for k in BAND_JUDGED}))
    return ChartGuarantee(turbine_name, density, noise_pct, runaway, seed, cases, refused, train_s)


#: Acceptance bounds (points): max speed rise and max head rise errors, band coverage, median head-rise band width.
ACCEPTANCE = {"speed_pt": 1.0, "head_pt": 2.0, "coverage": 0.90, "head_band_median_pt": 5.0}


def summarize(charts: list) -> dict:
    """Aggregate figures over charts: worst errors, coverage fraction, median band widths (points)."""
    cases = [c for g in charts for c in g.cases]
    if not cases:
        return {}
    out = {"charts": len(charts), "cases": len(cases), "refused": sum(g.refused is not None for g in charts)}
    for f in FIGURES:
        errors = np.array([c.error_pt(f) for c in cases])
        out[f"{f}_worst_pt"] = float(np.max(np.abs(errors)))
        out[f"{f}_mean_abs_pt"] = float(np.mean(np.abs(errors)))
    covered = [c.covered(f) for c in cases for f in BAND_JUDGED]
    out["coverage"] = float(np.mean(covered))
    for f in BAND_JUDGED:
        out[f"{f}_band_median_pt"] = float(np.median([c.width_pt(f) for c in cases]))
        out[f"{f}_coverage"] = float(np.mean([c.covered(f) for c in cases]))
    out["within_bounds"] = float(np.mean([abs(c.error_pt("max_speed_rise")) <= ACCEPTANCE["speed_pt"]
                                          and abs(c.error_pt("max_head_rise")) <= ACCEPTANCE["head_pt"]
                                          for c in cases]))
    return out
