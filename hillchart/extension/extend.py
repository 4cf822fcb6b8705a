"""Torque from efficiency and extension of the samples to runaway, zero opening and zero speed.

BP hill-chart paper (004), section 2.1 steps (d)-(f) and section 2.6 boundaries (1)-(4):

* (d) an efficiency surface eta(N11, Q11) fitted to the iso-efficiency points (eq. 4), evaluated on the flow-line
  points, gives their torque M11 = rho g Q11 eta 60 / (2 pi N11) (eq. 5, see
  :func:`~hillchart.characteristics.unit_torque_from_efficiency`);
* (e), 2.6 (1) runaway points join the flow samples and give M11 = 0 torque samples;
* (e), (f), 2.6 (2)-(3) at zero opening Q11 = 0 for every N11 (eq. 6), and M11 = -K N11^2 (eqs. 8-9) with K fitted
  by least squares to the per-N11 polynomial extrapolation of the torque samples to a = 0;
* 2.6 (4) at zero speed, per-opening polynomial extrapolation of Q11 and M11 to N11 = 0.

Beyond the paper, with the physical-model boundaries (:mod:`hillchart.extension.turbine_model`), the model also fills
the regions where the chart is silent but a load rejection decides its guarantee figures: the small openings between
a = 0 and the lowest digitized line (the end of the closure, where the maximum head comes) and the overspeed band
between each line's last point and its runaway speed (origin ``silent-region``,
:func:`hillchart.extension.silent_samples.silent_region_points`), and midway between each two adjacent lines, where
a closure crosses the gaps, as the model plus the residual the lines measure
(:func:`hillchart.extension.silent_samples.between_line_points`). On the synthetic family the first two cut the
worst max-head-rise error of a load rejection from 4.6 to 3.4 points and the worst max-speed-rise error from 3.3 to
1.3 points (``benchmarks/bench_guarantee.py``, docs/guarantee-benchmark.md).

Every extended point carries its origin (``measured``, ``runaway``, ``zero-opening``, ``zero-speed``,
``silent-region``); each boundary can be switched off.

Efficiency surface: a total-degree polynomial in standardized (N11, Q11), least squares, degree chosen by 5-fold
cross-validation among 2..6 (seeded folds; the lowest degree within 5 % of the best error). The paper names
polynomial surfaces for eq. (4); a low-degree polynomial is smooth, averages the digitization noise of the contour
points and extrapolates gently to the ends of the opening lines that lie just outside the lowest contour. On the
synthetic chart it picks degree 3, with torque errors below 0.5 % of the M11 range (``benchmarks/bench_extension.py``);
a thin-plate RBF was tried and was about 40 % worse.
"""

from __future__ import annotations

import csv
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import KFold, cross_val_score
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler

from hillchart.characteristics import unit_torque_from_efficiency
from hillchart.errors import InputError, NumericalError
from hillchart.extension.silent_samples import (between_line_points, continued_line_points, lines_without_runaway,
                                               runaway_warning, silent_region_points)
from hillchart.io.samples import ChartSamples

ORIGINS = ("measured", "runaway", "zero-opening", "zero-speed", "silent-region")
#: Plot colour of each origin family (shared by every figure that shows the samples).
ORIGIN_COLOURS = {"measured": "tab:blue", "runaway": "tab:red", "zero-opening": "tab:green", "zero-speed": "tab:orange",
                  "silent-region": "tab:purple"}
TARGETS = ("q11", "m11")
CSV_COLUMNS = ("target", "origin", "n11", "opening", "value")
BOUNDARY_METHODS = ("model", "polynomial")


@dataclass(frozen=True)
class ExtensionOptions:
    """How the samples are extended.

    Attributes
    ----------
    runaway, zero_opening, zero_speed : bool
        Switch each boundary family on or off.
    extrapolation_degree : int
        Degree of the per-N11 (zero opening) and per-opening (zero speed) polynomial extrapolations (paper:
        MATLAB ``polyfit``); 2 by default.
    zero_opening_points : int
        Number of N11 values from 0 to the largest sampled N11 at zero opening (eqs. 6 and 9).
    zero_opening_k : float or None
        K of eq. (8), N*m/(r/min)^2, when the user sets it from experience (the paper adjusts it by hand);
        None fits it from the data.
    efficiency_degree : int or None
        Degree of the efficiency surface; None chooses it by cross-validation among 2..6.
    boundaries : {"model", "polynomial"}
        Where the zero-opening, zero-speed (and, for a chart without runaway curve, runaway) samples come from:
        ``"model"`` (default) a low-order physical turbine model fitted to the chart
        (:mod:`hillchart.extension.turbine_model`), ``"polynomial"`` the paper's per-line polynomial extrapolations.
    check_chart : bool
        Run :func:`hillchart.extension.plausibility.check_chart` first (default). Off only for contrived test charts
        that exercise a later step.
    silent_regions : bool
        With ``boundaries="model"``: samples of the fitted physical model where the chart is silent and a load
        rejection runs (origin ``silent-region``): the small openings between a = 0 and the lowest digitized line
        (where the closure ends and the maximum head comes), the overspeed band between each line's last point
        and its runaway speed (where the maximum speed comes), and midway between adjacent lines
        (:func:`between_line_points`). Weight 1 in training, like the zero-opening samples.
    """

    runaway: bool = True
    zero_opening: bool = True
    zero_speed: bool = True
    extrapolation_degree: int = 2
    zero_opening_points: int = 15
    zero_opening_k: float | None = None
    efficiency_degree: int | None = None
    boundaries: str = "model"
    check_chart: bool = True
    silent_regions: bool = True

    def __post_init__(self):
        if self.boundaries not in BOUNDARY_METHODS:
            raise InputError(f"boundaries must be one of {BOUNDARY_METHODS}, got {self.boundaries!r}")
        if not isinstance(self.extrapolation_degree, int) or not 1 <= self.extrapolation_degree <= 4:
            raise InputError(f"extrapolation_degree must be an integer in [1, 4], got {self.extrapolation_degree!r}")
        if not isinstance(self.zero_opening_points, int) or self.zero_opening_points < 2:
            raise InputError(f"zero_opening_points must be an integer >= 2, got {self.zero_opening_points!r}")
        if self.zero_opening_k is not None and not (np.isfinite(self.zero_opening_k) and self.zero_opening_k > 0):
            raise InputError(f"zero_opening_k must be a finite number > 0, got {self.zero_opening_k!r}")
        if self.efficiency_degree is not None and (
            not isinstance(self.efficiency_degree, int) or not 1 <= self.efficiency_degree <= 8
        ):
            raise InputError(f"efficiency_degree must be an integer in [1, 8] or None, got {self.efficiency_degree!r}")


@dataclass(frozen=True)
class EfficiencySurface:
    """eta(N11, Q11) fitted to the iso-efficiency points (eq. 4 of the BP hill-chart paper)."""

    model: Pipeline
    degree: int
    cv_rmse: float

    def __call__(self, n11, q11) -> np.ndarray:
        n11, q11 = np.broadcast_arrays(np.asarray(n11, float), np.asarray(q11, float))
        return self.model.predict(np.column_stack([n11.ravel(), q11.ravel()])).reshape(n11.shape)


def fit_efficiency_surface(n11, q11, efficiency, *, degree: int | None = None, seed: int = 0) -> EfficiencySurface:
    """Least-squares polynomial surface eta(N11, Q11); ``degree=None`` picks 2..6 by 5-fold cross-validation.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> n, q = rng.uniform(50, 90, 200), rng.uniform(0.3, 0.6, 200)
    >>> surface = fit_efficiency_surface(n, q, 0.9 - 1e-4 * (n - 70) ** 2 - (q - 0.45) ** 2)
    >>> surface.degree, round(float(surface(70.0, 0.45)), 6)
    (2, 0.9)
    """
    x = np.column_stack([np.asarray(n11, float), np.asarray(q11, float)])
    y = np.asarray(efficiency, float)
    if len(y) < 10:
        raise InputError(f"efficiency.csv: need at least 10 points to fit the efficiency surface, got {len(y)}")
    if np.unique(y).size < 2:
        raise InputError(f"efficiency.csv: all {len(y)} points are at efficiency {float(y[0])!r}; the surface needs "
                         "contours at two or more levels")
    if np.unique(x, axis=0).shape[0] < 6:
        raise InputError("efficiency.csv: fewer than 6 distinct (n11, q11) points; a quadratic surface needs 6")

    def make(d):
        return make_pipeline(StandardScaler(), PolynomialFeatures(d), LinearRegression())

    folds = KFold(n_splits=5, shuffle=True, random_state=seed)
    if degree is None:
        scores = {}
        for d in range(2, 7):
            if (d + 1) * (d + 2) // 2 >= 0.8 * len(y):  # more coefficients than a training fold can determine
                break
            scores[d] = -cross_val_score(make(d), x, y, cv=folds, scoring="neg_root_mean_squared_error").mean()
        scores = {d: v for d, v in scores.items() if np.isfinite(v)}
        if not scores:
            raise InputError(f"efficiency.csv: {len(y)} points leave no degree of the efficiency surface that "
                             "cross-validation can score; digitize more contour points")
        best = min(scores.values())
        # parsimony: the lowest degree within 5 % of the best cross-validated error (exact data ties at ~1e-16)
        degree = min(d for d, rmse in scores.items() if rmse <= 1.05 * best + 1e-12)
        cv_rmse = scores[degree]
    else:
        cv_rmse = -cross_val_score(make(degree), x, y, cv=folds, scoring="neg_root_mean_squared_error").mean()
    return EfficiencySurface(model=make(degree).fit(x, y), degree=degree, cv_rmse=float(cv_rmse))


@dataclass(frozen=True)
class ExtendedSamples:
    """The extended flow and torque samples, one row per sample (the long table of ``hillsim extend``).

    Attributes
    ----------
    target : ndarray of str (S,)       ``"q11"`` (value in m^3/s) or ``"m11"`` (value in N*m)
    origin : ndarray of str (S,)       one of :data:`ORIGINS`
    n11 : ndarray (S,)                 r/min
    opening : ndarray (S,)             chart opening unit
    value : ndarray (S,)
    opening_unit : str
    opening_max : float
    k_zero_opening : float or None     K of eq. (8) used, N*m/(r/min)^2
    k_zero_opening_fitted : float or None  K from the data before any user override
    efficiency_surface : EfficiencySurface or None
    derived : ndarray of bool (S,) or None
        True for samples the extension derived by extrapolation or from the model (zero speed, runaway from the
        model); they are soft constraints in training. The zero-opening family keeps weight 1: Q11 = 0 is exact
        (eq. 6) and M11 = -K N11^2 sets the simulator's no-load opening and braking. None: the zero-opening and
        zero-speed origins.
    boundary_model : FittedTurbineModel or None
        The physical model the boundaries came from (``boundaries="model"``).
    extrapolation : Extrapolation or None
        Below the lowest digitized line: the hypotheses and the chart's held-out evidence that weighs them
        (:mod:`hillchart.extension.hypotheses`), with the silent regions.
    warnings : tuple of str
        What the extension could not do and how to fix it (:func:`runaway_warning`; also a ``UserWarning``).
    lines_without_runaway : tuple of float
        :func:`lines_without_runaway` (``nets.json`` records both, and a guarantee report decided there says so).
    """

    target: np.ndarray
    origin: np.ndarray
    n11: np.ndarray
    opening: np.ndarray
    value: np.ndarray
    opening_unit: str
    opening_max: float
    k_zero_opening: float | None = None
    k_zero_opening_fitted: float | None = None
    efficiency_surface: EfficiencySurface | None = field(default=None, repr=False)
    derived: np.ndarray | None = field(default=None, repr=False)
    boundary_model: object | None = field(default=None, repr=False)
    extrapolation: object | None = field(default=None, repr=False)
    warnings: tuple = ()
    lines_without_runaway: tuple = ()

    def select(self, target: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(X, y, origin)`` of one target: X (S, 2) columns N11 and opening."""
        if target not in TARGETS:
            raise InputError(f"target must be one of {TARGETS}, got {target!r}")
        m = self.target == target
        return np.column_stack([self.n11[m], self.opening[m]]), self.value[m], self.origin[m]

    def counts(self) -> dict[str, dict[str, int]]:
        """Number of samples per target and origin."""
        return {
            t: {o: int(np.sum((self.target == t) & (self.origin == o))) for o in ORIGINS} for t in TARGETS
        }

    def plot(self, path=None):
        """Flow and torque samples over (N11, a), coloured by origin (like the paper's Figs. 2-3).

        Returns the matplotlib Figure; writes a PNG only when ``path`` is given.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig = plt.figure(figsize=(12, 5.2))
        for i, (target, label) in enumerate((("q11", "Q11 (m$^3$/s)"), ("m11", "M11 (N m)"))):
            ax = fig.add_subplot(1, 2, i + 1, projection="3d")
            x, y, origin = self.select(target)
            for o in ORIGINS:
                m = origin == o
                if m.any():
                    ax.scatter(x[m, 0], x[m, 1], y[m], s=10, color=ORIGIN_COLOURS[o], label=f"{o} ({int(m.sum())})")
            ax.set_xlabel("N11 (r/min)")
            ax.set_ylabel(f"opening ({self.opening_unit})")
            ax.set_zlabel(label)
            ax.set_title(f"extended {target.upper()} samples")
            ax.view_init(elev=22, azim=-125)
            ax.legend(loc="upper left", fontsize=8)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=110)
        return fig

    def to_csv(self, path) -> Path:
        """Write the long format ``target,origin,n11,opening,value`` (values repr-exact)."""
        path = Path(path)
        rows = [
            (t, o, repr(float(n)), repr(float(a)), repr(float(v)))
            for t, o, n, a, v in zip(self.target, self.origin, self.n11, self.opening, self.value)
        ]
        with path.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle, lineterminator="\n")
            writer.writerow(CSV_COLUMNS)
            writer.writerows(rows)
        return path


def zero_opening_torque(chart: ChartSamples, torque: np.ndarray, degree: int):
    """Per-N11 extrapolation of the flow-line torque to a = 0 (section 2.6 (3)) and the K of eq. (8).

    At N11 values where every equal-opening line has data, each line's M11 is interpolated in N11, a polynomial
    of ``degree`` in the opening is fitted (``numpy.polyfit``) and evaluated at a = 0. K is the least-squares fit
    of M11(a=0) = -K N11^2 through those values: ``K = -sum(M0 N11^2) / sum(N11^4)``.

    Returns
    -------
    n11 : ndarray, r/min;   m11_at_zero : ndarray, N*m;   k : float, N*m/(r/min)^2
    """
    lines = list(chart.per_line(torque))
    if len(lines) < degree + 1:
        raise InputError(
            f"flow.csv: zero-opening extrapolation of degree {degree} needs at least {degree + 1} opening lines, "
            f"got {len(lines)}"
        )
    lo = max(line[1][0] for line in lines)
    hi = min(line[1][-1] for line in lines)
    if not hi > lo:
        # the lines share no N11 interval: use the N11 range covered by the most lines instead
        lo, hi = np.percentile(chart.flow_n11, [25, 75])
    n11_used, m0 = [], []
    for n in np.linspace(lo, hi, 9):
        usable = [(a, np.interp(n, ns, ms)) for a, ns, ms in lines if ns[0] <= n <= ns[-1]]
        if len(usable) < degree + 1:
            continue
        a, m = np.array(usable).T
        n11_used.append(n)
        m0.append(np.polyval(np.polyfit(a, m, degree), 0.0))
    if not m0:
        raise InputError("flow.csv: no N11 value is covered by enough opening lines to extrapolate to a = 0")
    n11, m0 = np.asarray(n11_used), np.asarray(m0)
    k = float(-np.sum(m0 * n11**2) / np.sum(n11**4))  # least squares of eq. (8)
    return n11, m0, k


def _zero_speed(n11_sets, value_sets, degree: int) -> float:
    """polyfit/polyval of one opening's samples to N11 = 0 (section 2.6 (4))."""
    n = np.concatenate(n11_sets)
    v = np.concatenate(value_sets)
    if np.unique(n).size < degree + 1:
        return float("nan")
    return float(np.polyval(np.polyfit(n, v, degree), 0.0))


def extend_samples(chart: ChartSamples, options: ExtensionOptions | None = None) -> ExtendedSamples:
    """Torque samples from efficiency plus the four boundary families of the BP hill-chart paper.

    Parameters
    ----------
    chart : ChartSamples
        From :func:`hillchart.io.samples.load_chart`.
    options : ExtensionOptions, optional

    Returns
    -------
    ExtendedSamples

    Raises
    ------
    NumericalError
        When the zero-opening extrapolation gives K <= 0 (positive torque with closed guide vanes) and the user gave
        no ``zero_opening_k``, or a zero-speed extrapolation gives a negative flow.

    Examples
    --------
    >>> from data_synthetic import FRANCIS_DIR
    >>> from hillchart.io.samples import load_chart
    >>> ext = extend_samples(load_chart(FRANCIS_DIR))
    >>> sorted(o for o, n in ext.counts()["m11"].items() if n > 0)
    ['measured', 'runaway', 'silent-region', 'zero-opening', 'zero-speed']
    >>> ext.k_zero_opening > 0
    True
    """
    from hillchart.extension.plausibility import check_chart

    options = options or ExtensionOptions()
    if options.check_chart:
        check_chart(chart)  # what a digitizer gets wrong, by file and row, before any fit
    rows: list[tuple[str, str, float, float, float]] = []

    # (d) torque on the flow lines from the efficiency surface, eqs. (4)-(5)
    surface = fit_efficiency_surface(
        chart.eff_n11, chart.eff_q11, chart.eff_efficiency, degree=options.efficiency_degree
    )
    eta = surface(chart.flow_n11, chart.flow_q11)
    if np.any(chart.flow_n11 <= 0):
        raise InputError("flow.csv: torque from efficiency (eq. 5) needs n11 > 0 on the opening lines")
    torque = unit_torque_from_efficiency(chart.flow_q11, chart.flow_n11, eta)
    for a, n, q, m in zip(chart.flow_opening, chart.flow_n11, chart.flow_q11, torque):
        rows.append(("q11", "measured", n, a, q))
        rows.append(("m11", "measured", n, a, m))

    derived_rows = [False] * len(rows)
    model = None
    notes = []  # what the extension cannot do, and how to fix it
    needs_model = (options.zero_speed or (options.zero_opening and options.zero_opening_k is None)
                   or (options.runaway and not chart.has_runaway))
    if options.boundaries == "model" and needs_model:
        from hillchart.extension.turbine_model import fit_turbine_model

        model = fit_turbine_model(chart, torque)

    def add(target, origin, n, a, v, derived):
        rows.append((target, origin, n, a, v))
        derived_rows.append(derived)

    bare = lines_without_runaway(chart, model)  # searched once: the warning, the record, the continued lines
    if options.runaway and (note := runaway_warning(chart, model, bare)) is not None:
        notes.append(note)
        warnings.warn(note, UserWarning, stacklevel=2)
    # (e)-(f), 2.6 (1): runaway points are flow samples and zero-torque samples
    if options.runaway and chart.has_runaway:
        for a, n, q in zip(chart.runaway_opening, chart.runaway_n11, chart.runaway_q11):
            add("q11", "runaway", n, a, q, False)
            add("m11", "runaway", n, a, 0.0, False)
    elif options.runaway and model is not None:  # no runaway curve digitized: the model's, at the line openings
        for a in chart.openings:
            n = model.runaway_n11(float(a))
            if np.isfinite(n):
                add("q11", "runaway", n, a, float(model.q11(n, a)), True)
                add("m11", "runaway", n, a, 0.0, True)

    # 2.6 (4): zero speed, per opening
    if options.zero_speed:
        for a in chart.openings:
            if model is not None:  # the physical model at N11 = 0
                q0, m0 = float(model.q11(0.0, a)), float(model.m11(0.0, a))
            else:  # the paper's polynomial extrapolation of each line (with its runaway point when there is one)
                on_line = chart.flow_opening == a
                run = (chart.runaway_opening == a) if (options.runaway and chart.has_runaway) else np.zeros(0, bool)
                n_sets = [chart.flow_n11[on_line], chart.runaway_n11[run]]
                q0 = _zero_speed(n_sets, [chart.flow_q11[on_line], chart.runaway_q11[run]],
                                 options.extrapolation_degree)
                m0 = _zero_speed(n_sets, [torque[on_line], np.zeros(int(run.sum()))], options.extrapolation_degree)
            if not np.isfinite(q0) or q0 < 0:
                raise NumericalError(
                    f"zero-speed extrapolation of the opening line a = {a} gives Q11(N11=0) = {q0:.4g} m^3/s "
                    f"(must be >= 0); lower extrapolation_degree or switch the zero-speed boundary off"
                )
            add("q11", "zero-speed", 0.0, a, q0, True)
            add("m11", "zero-speed", 0.0, a, m0, True)

    extrapolation = None
    if options.silent_regions and model is not None:
        from hillchart.extension.hypotheses import Extrapolation

        # below the lowest line: the hypotheses weighed by the chart's own held-out lines; in overspeed: the model
        extrapolation = Extrapolation.of_chart(chart, torque, model, bare)
        a_low = float(np.min(chart.openings))
        for n, a in silent_region_points(chart, model):
            # weight 1 like the zero-opening samples: the net's selection scores measured samples only, so a soft
            # weight there is chosen low and the net's sigmoids decide the guarantee figures instead of the physics
            if a < a_low:
                q, m = (float(v) for v in extrapolation.values(n, a))
            else:
                q, m = float(model.q11(n, a)), float(model.m11(n, a))
            add("q11", "silent-region", n, a, q, False)
            add("m11", "silent-region", n, a, m, False)
        for n, a, q, m in continued_line_points(chart, torque, extrapolation):
            add("q11", "silent-region", n, a, max(q, 0.0), False)
            add("m11", "silent-region", n, a, m, False)
        between = between_line_points(chart, model)
        if between:  # the model's shape between the lines, with the residual the lines measure carried there
            from hillchart.extension.residual import continued_residual

            x = np.array(between)
            measured = np.column_stack([chart.flow_n11, chart.flow_opening])
            model_q, model_m = model.q11(x[:, 0], x[:, 1]), model.m11(x[:, 0], x[:, 1])
            q = model_q + continued_residual(measured, chart.flow_q11 - model.q11(chart.flow_n11, chart.flow_opening),
                                             x)
            m = model_m + continued_residual(measured, torque - model.m11(chart.flow_n11, chart.flow_opening), x)
            for (n, a), q_i, m_i in zip(between, q, m):
                add("q11", "silent-region", n, a, float(q_i), False)
                add("m11", "silent-region", n, a, float(m_i), False)

    # (e)-(f), 2.6 (2)-(3): zero opening, Q11 = 0 (eq. 6) and M11 = -K N11^2 (eqs. 8-9)
    k_used = k_fitted = None
    if options.zero_opening:
        if model is not None:
            k_fitted = model.k_zero_opening  # the model's disc friction: M11(N11, 0) = -K N11^2 exactly
        elif options.boundaries == "model":
            k_fitted = None  # the user's K, no model needed
        else:
            _, _, k_fitted = zero_opening_torque(chart, torque, options.extrapolation_degree)
        k_used = options.zero_opening_k if options.zero_opening_k is not None else k_fitted
        if k_used <= 0:
            raise NumericalError(
                f"zero-opening extrapolation gives K = {k_fitted:.4g} N*m/(r/min)^2 in M11 = -K N11^2 (eq. 8), "
                "i.e. positive torque with closed guide vanes; set zero_opening_k (> 0) from experience, as the "
                "paper does, or switch the zero-opening boundary off"
            )
        n11_max = max(chart.flow_n11.max(), chart.runaway_n11.max() if chart.has_runaway else 0.0)
        measured = [abs(r[4]) for r in rows if r[0] == "m11" and r[1] == "measured"]
        if options.zero_opening_k is not None and measured and n11_max > 0:
            # disc friction with closed vanes is a fraction of the working torque; 10 x the largest measured
            # |M11| at the highest N11 is far beyond any turbine (typo or wrong unit)
            k_max = 10.0 * max(measured) / n11_max**2
            if k_used > k_max:
                raise InputError(
                    f"zero_opening_k = {k_used:.4g} N*m/(r/min)^2 gives M11 = {-k_used * n11_max**2:.4g} N*m at "
                    f"N11 = {n11_max:.4g} r/min, more than 10 x the largest measured |M11| ({max(measured):.4g} "
                    f"N*m); a plausible K is below {k_max:.3g}"
                    + (f" (the chart's own extrapolation gives {k_fitted:.3g})" if k_fitted else ""))
        for n in np.linspace(0.0, n11_max, options.zero_opening_points):
            add("q11", "zero-opening", n, 0.0, 0.0, False)  # exact, not derived: closed vanes pass no flow (eq. 6)
            # weight 1 like the measured samples: the zero-opening torque decides the no-load opening and the
            # braking after closure in the simulator, and it lies far (a = 0) from the digitized lines
            add("m11", "zero-opening", n, 0.0, 0.0 - k_used * n * n, False)  # 0.0 - ...: no -0.0

    target, origin, n11, opening, value = zip(*rows)
    return ExtendedSamples(
        target=np.array(target),
        origin=np.array(origin),
        n11=np.array(n11, float),
        opening=np.array(opening, float),
        value=np.array(value, float),
        opening_unit=chart.info.opening_unit,
        opening_max=float(chart.info.opening_max),
        k_zero_opening=k_used,
        k_zero_opening_fitted=k_fitted,
        efficiency_surface=surface,
        derived=np.array(derived_rows, bool),
        boundary_model=model,
        extrapolation=extrapolation,
        warnings=tuple(notes),
        lines_without_runaway=tuple(bare) if options.runaway else (),
    )


def read_extended_csv(path, *, opening_unit: str, opening_max: float) -> ExtendedSamples:
    """Read a table written by :meth:`ExtendedSamples.to_csv` (e.g. after a user edited it by hand)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: missing file")
    from hillchart.io.tabular import csv_rows, decimal_commas, detect_delimiter, parse_number, read_text

    text = read_text(path, "extended-samples CSV")
    # saved again by a spreadsheet: semicolon- or tab-separated, perhaps with decimal commas (hillchart.io.tabular)
    delimiter = detect_delimiter(text.split("\n", 1)[0])
    rows = csv_rows(text, path, delimiter=delimiter)
    if not rows or tuple(c.strip() for c in rows[0]) != CSV_COLUMNS:
        raise InputError(f"{path}: the header must be {','.join(CSV_COLUMNS)}, got {rows[0] if rows else 'nothing'}")
    decimal_comma, note = decimal_commas(path, delimiter, (c for row in rows[1:] for c in row[2:]))
    if note:
        warnings.warn(note, UserWarning, stacklevel=2)
    cols = {c: [] for c in CSV_COLUMNS}
    for line_no, row in enumerate(rows[1:], start=2):
        if len(row) != len(CSV_COLUMNS):
            raise InputError(f"{path}: row {line_no} has {len(row)} fields, expected {len(CSV_COLUMNS)}")
        t, o = row[0].strip(), row[1].strip()
        if t not in TARGETS:
            raise InputError(f"{path}: row {line_no}, column 'target': {t!r}; allowed {TARGETS}")
        if o not in ORIGINS:
            raise InputError(f"{path}: row {line_no}, column 'origin': {o!r}; allowed {ORIGINS}")
        cols["target"].append(t)
        cols["origin"].append(o)
        for name, cell in zip(CSV_COLUMNS[2:], row[2:]):
            cols[name].append(parse_number(path, line_no, name, cell, decimal_comma=decimal_comma))
    return ExtendedSamples(
        target=np.array(cols["target"]),
        origin=np.array(cols["origin"]),
        n11=np.array(cols["n11"], float),
        opening=np.array(cols["opening"], float),
        value=np.array(cols["value"], float),
        opening_unit=opening_unit,
        opening_max=float(opening_max),
    )
