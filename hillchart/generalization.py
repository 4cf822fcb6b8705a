"""How well the chart -> nets pipeline generalizes: one synthetic-family chart against its exact turbine.

Used by ``benchmarks/bench_generalization.py`` (the whole grid) and by the acceptance tests (one seed per turbine),
so that both report the same numbers. Errors are percentages of the truth's range inside the measured region (the
convex hull of the digitized opening lines), as in :func:`hillchart.nets.accuracy.truth_errors`.
"""

from __future__ import annotations

import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hillchart.linearize import COEFFICIENT_NAMES, six_coefficients
from hillchart.nets.accuracy import read_truth_csv, truth_errors
from hillchart.nets.training import train_nets
from hillchart.io.samples import measured_region_mask
from hillchart.synthetic.francis import FAMILY, DigitizationOptions, synthetic_chart_texts

#: Operating points of the six-coefficient check, as (N11 / best-efficiency N11, opening / full stroke): the rated
#: point (the medium turbine's is the HLA339's N11 67.8, a 23.46 mm) and two off-design points inside the chart.
COEFFICIENT_POINTS = {"rated": (1.046, 0.733), "part load": (0.93, 0.5), "high speed": (1.2, 0.85)}


@dataclass(frozen=True)
class GeneralizationResult:
    """Errors of one trained chart against the exact turbine.

    Attributes
    ----------
    errors : dict
        :func:`hillchart.nets.accuracy.truth_errors` of the default pipeline.
    baseline : dict or None
        The same for nets fitted to the measured samples alone (no boundary samples), when asked for.
    k_ratio : float or None
        Fitted K of eq. (8) / the turbine's true disc friction.
    coefficient_errors : dict
        Point name -> max |nets - exact| over the six coefficients.
    nets : HillNets
    truth : dict of ndarray
        The exact truth grid (:func:`hillchart.nets.accuracy.read_truth_csv`).
    inside : ndarray of bool
        Measured-region mask of the truth grid.
    """

    errors: dict
    baseline: dict | None
    k_ratio: float | None
    coefficient_errors: dict
    nets: object
    truth: dict | None = None
    inside: np.ndarray | None = None


def best_efficiency_n11(turbine) -> float:
    """N11 (r/min) of the best efficiency of an exact turbine (grid search, 0.25 r/min)."""
    n, a = np.meshgrid(np.arange(30.0, 110.0, 0.25), np.linspace(0.3, 1.0, 57) * turbine.opening_max)
    eta = turbine.efficiency(n, a)
    return float(n.flat[int(np.argmax(eta))])


def coefficient_points(turbine) -> dict[str, tuple[float, float]]:
    """Point name -> (N11 r/min, opening mm) of the six-coefficient check for an exact family turbine."""
    n_best = best_efficiency_n11(turbine)
    return {name: (fn * n_best, fa * turbine.opening_max) for name, (fn, fa) in COEFFICIENT_POINTS.items()}


def evaluate(turbine_name: str, *, seed: int = 0, options: DigitizationOptions | None = None,
             extension=None, train_kwargs: dict | None = None, baseline: bool = False) -> GeneralizationResult:
    """Digitize a family chart, extend and train with the given options, and compare with the exact turbine.

    Parameters
    ----------
    turbine_name : str
        A member of :data:`hillchart.synthetic.francis.FAMILY` or of the out-of-class family
        (:data:`hillchart.synthetic.francis_variants.OUT_OF_CLASS_FAMILY`).
    seed : int
        Digitization seed (also the training seed).
    options : DigitizationOptions, optional
    extension : ExtensionOptions, optional
    train_kwargs : dict, optional
        Passed to :func:`hillchart.nets.training.train_nets`.
    baseline : bool
        Also fit nets to the measured samples alone (the issue's "never worse than 1.2 x" reference).
    """
    from hillchart.extension.extend import ExtensionOptions, extend_samples
    from hillchart.io.samples import load_chart

    from hillchart.errors import InputError
    from hillchart.synthetic.francis_variants import OUT_OF_CLASS_FAMILY

    options = options or DigitizationOptions()
    member = FAMILY.get(turbine_name) or OUT_OF_CLASS_FAMILY.get(turbine_name)
    if member is None:
        raise InputError(f"turbine must be one of {', '.join([*FAMILY, *OUT_OF_CLASS_FAMILY])}, got {turbine_name!r}")
    exact = member.turbine()
    texts = synthetic_chart_texts(seed=seed, turbine=member, options=options)
    with tempfile.TemporaryDirectory() as folder:
        for name, text in texts.items():
            (Path(folder) / name).write_text(text, encoding="utf-8")
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*runaway.csv is absent.*")
            chart = load_chart(folder)
        truth = read_truth_csv(Path(folder) / "truth.csv")
    inside = measured_region_mask(chart.flow_n11, chart.flow_opening, truth["n11"], truth["opening"])
    kwargs = dict(train_kwargs or {})
    kwargs.setdefault("seed", seed)
    extended = extend_samples(chart, extension or ExtensionOptions())
    nets = train_nets(extended, **kwargs)
    base = None
    if baseline:
        measured_only = extend_samples(chart, ExtensionOptions(runaway=False, zero_opening=False, zero_speed=False))
        base = truth_errors(train_nets(measured_only, **kwargs), truth, inside)
    k_ratio = None if extended.k_zero_opening is None else extended.k_zero_opening / exact.params.k_disc_friction
    scale = float(chart.info.opening_max) / exact.opening_max  # chart units per mm
    return GeneralizationResult(errors=truth_errors(nets, truth, inside), baseline=base, k_ratio=k_ratio,
                                coefficient_errors=coefficient_errors(nets, exact, scale), nets=nets, truth=truth,
                                inside=inside)


def coefficient_errors(nets, exact, scale: float = 1.0) -> dict[str, float]:
    """Point name of :data:`COEFFICIENT_POINTS` -> max |nets - exact| over the six coefficients there (``scale``:
    the chart's opening units per mm of the exact turbine's)."""
    out = {}
    for name, (n11, a_mm) in coefficient_points(exact).items():
        want = six_coefficients(exact, n11=n11, opening=a_mm)
        got = six_coefficients(nets, n11=n11, opening=a_mm * scale)
        out[name] = max(abs(getattr(got, c) - getattr(want, c)) for c in COEFFICIENT_NAMES)
    return out


#: Acceptance bounds of the chart -> nets pipeline (percent of the measured-region range; coefficient differences
#: absolute).
ACCEPTANCE = {"q11_rms_pct": 0.5, "q11_max_pct": 2.0, "m11_rms_pct": 1.0, "baseline_factor": 1.2,
              "coefficient_abs": 0.05}


def acceptance_failures(result: GeneralizationResult) -> list[str]:
    """The issue's acceptance criteria that ``result`` misses (empty when it passes them all).

    Measured-region Q11 RMS <= 0.5 %, max <= 2 %, M11 RMS <= 1 % of the range; Q11 and M11 RMS at most 1.2 x those
    of nets fitted to the measured samples alone (when ``result.baseline`` is there); six coefficients within 0.05
    of the exact ones at every :data:`COEFFICIENT_POINTS` point.
    """
    e, out = result.errors, []
    checks = (("Q11 RMS", e["q11"]["rms_measured_pct"], ACCEPTANCE["q11_rms_pct"]),
              ("Q11 max", e["q11"]["max_measured_pct"], ACCEPTANCE["q11_max_pct"]),
              ("M11 RMS", e["m11"]["rms_measured_pct"], ACCEPTANCE["m11_rms_pct"]))
    for label, value, bound in checks:
        if not value <= bound:
            out.append(f"{label} {value:.3f} % > {bound} %")
    if result.baseline is not None:
        for t in ("q11", "m11"):
            ours, base = e[t]["rms_measured_pct"], result.baseline[t]["rms_measured_pct"]
            if not ours <= ACCEPTANCE["baseline_factor"] * base:
                out.append(f"{t.upper()} RMS {ours:.3f} % > {ACCEPTANCE['baseline_factor']} x "
                           f"measured-only {base:.3f} %")
    for name, value in result.coefficient_errors.items():
        if not value <= ACCEPTANCE["coefficient_abs"]:
            out.append(f"six coefficients at {name}: max |error| {value:.3f} > {ACCEPTANCE['coefficient_abs']}")
    return out
