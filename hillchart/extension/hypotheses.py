"""What the chart says below its lowest digitized opening line: competing hypotheses, judged by the chart's own lines.

A load rejection's maximum head is decided at the end of the closure, below the lowest opening line a user
digitized. Nothing measured is there; any answer is an extrapolation, and the fitted physical model
(:mod:`hillchart.extension.turbine_model`) is one hypothesis among several. On a real chart (Sayano-Shushenskaya, its
lowest lines held out) the model alone overpredicted Q11 by 10-21 %, worse than a straight line. So the extension
asks the chart: it holds out its own lowest line (then its two lowest), refits every hypothesis on the lines above,
and scores each at the held-out points. The hypotheses, all of them functions of the opening ratio ``t = a / a_low``
(``a_low`` the lowest digitized opening; ``t`` in [0, 1]) at the same N11:

``model``
    the fitted 1-D Euler model itself, ``y = y_m(a)``;
``anchored-model``
    the model's shape corrected to pass through the lowest line: ``y = y_m(a) + (y_low - y_m(a_low)) t`` (the
    model's error at the lowest line, fading linearly to none at a = 0, where Q11 = 0 and M11 = -K N11^2 hold);
``other-form-model``, ``anchored-other-form-model``
    the same two of the model's other form (:attr:`FittedTurbineModel.other_form`: with the throat foot when the
    chart's F-test did not keep it, without it when it did), fitted to the same lines: the test decides the form from
    the lines above, where the forms differ little; below the lowest line they part, and the held-out lines weigh
    them as they weigh every other hypothesis. Available where the foot was tried (four opening lines or more);
``line``
    a straight line in opening from the lowest line to the closed vanes: ``Q11 = Q_low t``,
    ``M11 = M_0 + (M_low - M_0) t`` with ``M_0 = -K N11^2`` (eq. 8 of the BP hill-chart paper);
``offset-line``
    a straight line through the lowest lines that reaches zero flow at ``t0`` before the vanes shut (``t0`` fitted
    to the lowest :data:`CURVATURE_LINES` lines), with a parabolic foot to the closed vanes (:func:`offset_line`);
``speed-scaled-line``
    the line, read at the N11 scaled by the model's runaway-speed ratio ``n_run(a_low) / n_run(a)``: a smaller
    opening runs closer to its own runaway at the same N11;
``quadratic``
    the paper's polynomial extrapolation in opening (section 2.6 (3), degree 2), in the same anchored form:
    ``Q11 = Q_low (t + c t (t - 1))``, ``M11 = M_0 + (M_low - M_0) (t + c t (t - 1))``, the curvature ``c`` fitted
    by least squares to the lowest :data:`CURVATURE_LINES` lines (a parabola through the closed vanes and the
    lowest line, bent as the chart's lines bend).

``y_low(N11)`` is the lowest line's value at N11: the model there plus the line's own residuals against it,
interpolated in N11 (held constant beyond the line's ends). In the simulator it is the nets' value at ``a_low``,
which fits that line.

The hypotheses are weighed by their held-out likelihood (pseudo-BMA, Yao et al. 2018: ``exp(-n/2 log MSE)`` with
``n`` the number of held-out lines, since the points of one line share one cause of error), never by their fit to
the lines they were fitted on (:func:`weigh`; a least-squares stacking over the simplex was tried: better on one
hold-out of the real chart, much worse on the out-of-class synthetic family). They answer by their weighed median
(:func:`weighed_median`), not their weighed mean: with one or two held-out lines the weights stay spread, and the
mean then stood between hypotheses that diverge below the data. The residuals of that median at the held-out points,
divided by the squared distance below the lowest kept line (``d = 1 - t``), give the band's widths, one per side
(:func:`band_sides`, split-conformal on the far half of the distances tested, growing no further
than the furthest of them, :func:`band_square`): a band that widens with the distance from the data, is as wide as
this chart's own evidence says, and reaches furthest on the side where the held-out lines fell. Toward runaway the
chart's evidence gives a band as well (:func:`overspeed_evidence`). The band itself (its sides, its growth, the
members' places in it) is :mod:`hillchart.extension.band`, whose names are importable from here as well.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from hillchart.errors import InputError
from hillchart.extension.band import (BAND_COVERAGE, FAR_FRACTION, GROWTH, MIN_SIDE_FRACTION, MIN_SIDE_FRACTION_BELOW,
                                      NO_EVIDENCE_CAP, NO_EVIDENCE_SCALE, band_scale, band_sides, band_square,
                                      continuation, log_ratio, member_positions, no_evidence_sides,
                                      weighed_median)

#: The hypotheses, in the order of every weight vector.
HYPOTHESES = ("model", "anchored-model", "other-form-model", "anchored-other-form-model", "line", "offset-line",
              "speed-scaled-line", "quadratic")
#: The hypotheses of the model's other form: available only where it was fitted (:attr:`Hypotheses.names`).
OTHER_FORM = ("other-form-model", "anchored-other-form-model")
#: The hypotheses of a chart whose model has no other form.
WITHOUT_OTHER_FORM = tuple(h for h in HYPOTHESES if h not in OTHER_FORM)
#: Lines (the lowest, and those just above it) whose bending gives the quadratic hypothesis its curvature.
CURVATURE_LINES = 4
#: Held-out folds: the lowest line, then the two lowest. A fold needs MIN_LINES_LEFT lines left to refit on to
#: count for the band, MIN_LINES_WEIGHED to count for the weights too (a model refitted on two lines predicts
#: worse than the chart's answer will, which is all the band needs to know, but it would mislead the weights: on
#: 4-line charts of the in-class synthetic family, weighing with it doubled the worst max head rise error).
HOLD_OUT = (1, 2)
MIN_LINES_LEFT = 2
MIN_LINES_WEIGHED = 3
#: The band's distance is capped at this multiple of the largest distance the hold-outs tested.
DISTANCE_CAP_FACTOR = 1.0
#: Toward runaway the band grows linearly with the N11 gap beyond a line's last point up to this multiple of the
#: largest gap the held-out last points tested, and no further (:func:`overspeed_evidence`).
OVERSPEED_GAP_CAP = 2.0


@dataclass(frozen=True)
class LowestLine:
    """The lowest digitized line as a function of N11: the model there plus the line's residuals against it.

    Attributes
    ----------
    opening : float
        ``a_low``, chart units.
    n11 : ndarray (P,)
        N11 of the line's points, ascending (r/min).
    q11_residual, m11_residual : ndarray (P,)
        The line's Q11 (m^3/s) and M11 (N*m) minus the model's at those points (the model read at most at
        :func:`model_n11`, as :meth:`values` reads it, so the line passes through its own points).
    """

    opening: float
    n11: np.ndarray
    q11_residual: np.ndarray
    m11_residual: np.ndarray

    def values(self, model, n11):
        """``(Q11, M11)`` of the lowest line at ``n11`` (array, r/min)."""
        n11 = np.asarray(n11, float)
        n_m = model_n11(model, n11)
        # the residuals at the line's own N11: where it was digitized the line gives its own values, also beyond
        # the model's range (read at the clamped N11, the lowest line of Sayano without its 22 and 26 mm lines was
        # 7.9 % high at its digitized point at N11 = 100, where the refitted model's range ends at 96.4)
        q = model.q11(n_m, self.opening) + np.interp(n11, self.n11, self.q11_residual)
        m = model.m11(n_m, self.opening) + np.interp(n11, self.n11, self.m11_residual)
        return q, m


def model_n11(model, n11):
    """``n11`` (r/min) held at 0.95 of the model's pumping limit: its valid range ends there (beyond it, no positive
    flow), and the value there is held beyond."""
    n11 = np.asarray(n11, float)
    return np.minimum(n11, 0.95 * model.n11_limit) if math.isfinite(model.n11_limit) else n11


@dataclass(frozen=True)
class Hypotheses:
    """The hypotheses fitted to one chart (or to the lines left after a hold-out).

    Attributes
    ----------
    model : FittedTurbineModel or None
        The physical model (None when it cannot represent the chart: the model hypotheses are then unavailable).
    lowest : LowestLine
    curvature_q11, curvature_m11 : float
        ``c`` of the quadratic hypothesis for Q11 and M11.
    k_zero_opening : float
        K of eq. (8), N*m/(r/min)^2.
    other : FittedTurbineModel or None
        The model's other form (:data:`OTHER_FORM`), fitted to the same lines; None when it was not.
    """

    model: object
    lowest: LowestLine
    curvature_q11: float
    curvature_m11: float
    k_zero_opening: float
    offset_q11: float = 0.0
    offset_m11: float = 0.0
    other: object = None

    @property
    def names(self) -> tuple:
        """The hypotheses these fits answer: :data:`HYPOTHESES`, less :data:`OTHER_FORM` without the other form."""
        return HYPOTHESES if self.other is not None else WITHOUT_OTHER_FORM

    def speed_ratio(self, opening):
        """``n_run(a_low) / n_run(a)``: how much closer to its runaway speed a smaller opening runs at the same N11
        (the model's runaway curve; 1 where it has none)."""
        a_low = self.lowest.opening
        grid = a_low * np.linspace(0.05, 1.0, 12)
        runaway = np.array([self.model.runaway_n11(float(a)) for a in grid])
        finite = np.isfinite(runaway) & (runaway > 0)
        if finite.sum() < 3:
            return np.ones_like(np.asarray(opening, float))
        top = runaway[-1]
        if not finite[-1]:  # the model's runaway at a_low lies beyond its valid range: the trend of the last three
            index = np.flatnonzero(finite)[-3:]
            top = float(np.polyval(np.polyfit(grid[index], runaway[index], 1), a_low))
        ratio = np.maximum(top / runaway[finite], 1.0)
        # below the smallest opening with a runaway speed: held at its ratio (np.interp holds the end value)
        return np.interp(np.asarray(opening, float), grid[finite], ratio)

    def predict(self, name: str, n11, opening):
        """``(Q11, M11)`` of hypothesis ``name`` at (``n11``, ``opening``) below the lowest line (arrays)."""
        n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
        a_low = self.lowest.opening
        t = np.clip(opening / a_low, 0.0, 1.0)
        q_low, m_low = self.lowest.values(self.model, n11)
        m_0 = -self.k_zero_opening * n11 ** 2
        n_m = model_n11(self.model, n11)
        if name == "model":
            return self.model.q11(n_m, opening), self.model.m11(n_m, opening)
        if name in ("anchored-model", "anchored-other-form-model", "other-form-model"):
            model = self.model if name == "anchored-model" else self.other
            if model is None:
                raise InputError(f"hypothesis {name!r} needs the model's other form, which was not fitted "
                                 f"(fewer than four opening lines, or it cannot represent the chart)")
            n_o = model_n11(model, n11)
            q_m, m_m = model.q11(n_o, opening), model.m11(n_o, opening)
            if model is self.other:  # the other form's disc friction is not the chart's K: at shut vanes eq. (8)
                m_m = m_m + (m_0 - model.m11(n_o, 0.0)) * (1.0 - t)  # holds with the K every hypothesis shares
            if name == "other-form-model":
                return q_m, m_m
            q_ml = model.q11(n_o, a_low)
            m_ml = model.m11(n_o, a_low)  # the shut-vane correction vanishes at the lowest line
            return q_m + (q_low - q_ml) * t, m_m + (m_low - m_ml) * t
        if name == "line":
            return q_low * t, m_0 + (m_low - m_0) * t
        if name == "offset-line":
            return q_low * offset_line(t, self.offset_q11), m_0 + (m_low - m_0) * offset_line(t, self.offset_m11)
        if name == "speed-scaled-line":
            rho = self.speed_ratio(opening)
            q_s, m_s = self.lowest.values(self.model, n11 * rho)
            m_0s = -self.k_zero_opening * (n11 * rho) ** 2
            return q_s * t, m_0 + (m_s - m_0s) * t
        if name == "quadratic":
            bend = t * (t - 1.0)
            return q_low * (t + self.curvature_q11 * bend), m_0 + (m_low - m_0) * (t + self.curvature_m11 * bend)
        raise InputError(f"hypothesis must be one of {HYPOTHESES}, got {name!r}")


#: Largest opening ratio at which the offset line may reach zero flow (the rest is its parabolic foot).
MAX_OFFSET = 0.4


def offset_line(t, t0: float):
    """``S(t)`` of the offset-line hypothesis: the straight line ``(t - t0) / (1 - t0)`` through the lowest line
    (``S(1) = 1``) that would reach zero at ``t0``, joined C1 at ``2 t0`` to the parabola ``A t^2`` that reaches
    zero at the closed vanes (``A = 1 / (4 t0 (1 - t0))``); ``t0 <= 0`` is the plain line ``S = t``.

    Examples
    --------
    >>> [round(float(v), 6) for v in offset_line(np.array([0.0, 0.1, 0.2, 1.0]), 0.1)]
    [0.0, 0.027778, 0.111111, 1.0]
    """
    t = np.asarray(t, float)
    if t0 <= 0.0:
        return t
    line = (t - t0) / (1.0 - t0)
    foot = t * t / (4.0 * t0 * (1.0 - t0))
    return np.where(t >= 2.0 * t0, line, foot)


def _offset(ratios, ts) -> float:
    """Least-squares ``t0`` of ``ratio = (t - t0) / (1 - t0)`` over the points (``ratio - t = t0 (ratio - 1)``),
    clipped to [0, :data:`MAX_OFFSET`]."""
    r, t = np.concatenate(ratios), np.concatenate(ts)
    den = float(np.sum((r - 1.0) ** 2))
    if den <= 0:
        return 0.0
    return float(np.clip(np.sum((r - t) * (r - 1.0)) / den, 0.0, MAX_OFFSET))


def fit_hypotheses(chart, torque, model, k_zero_opening: float, other=None) -> Hypotheses:
    """The hypotheses of a chart: its lowest line against ``model`` and the curvature of its lowest lines.

    Parameters
    ----------
    chart : ChartSamples
    torque : ndarray (F,)
        M11 (N*m) at the flow points (from the efficiency surface, eq. 5).
    model : FittedTurbineModel
    k_zero_opening : float
        K of eq. (8), N*m/(r/min)^2.
    other : FittedTurbineModel or None
        The model's other form (:data:`OTHER_FORM`).
    """
    torque = np.asarray(torque, float)
    lines = [(float(a), n, (q, m)) for (a, n, q), (_, _, m) in zip(chart.per_line(chart.flow_q11),
                                                                   chart.per_line(torque))]
    a_low, n_low, (q_low, m_low) = lines[0]
    n_m = model_n11(model, n_low)
    lowest = LowestLine(opening=a_low, n11=n_low, q11_residual=q_low - model.q11(n_m, a_low),
                        m11_residual=m_low - model.m11(n_m, a_low))
    # curvature of the quadratic hypothesis: least squares over the lowest lines (t >= 1 there)
    num_q = den_q = num_m = den_m = 0.0
    ratios_q, ratios_m, ts = [], [], []
    for a, n, (q, m) in lines[:CURVATURE_LINES]:
        t = a / a_low
        base_q, base_m = lowest.values(model, n)
        m_0 = -k_zero_opening * n ** 2
        ratios_q.append(q / base_q)
        ratios_m.append((m - m_0) / (base_m - m_0))
        ts.append(np.full(n.size, t))
        bend_q = base_q * t * (t - 1.0)
        bend_m = (base_m - m_0) * t * (t - 1.0)
        num_q += float(np.sum((q - base_q * t) * bend_q))
        den_q += float(np.sum(bend_q ** 2))
        num_m += float(np.sum((m - m_0 - (base_m - m_0) * t) * bend_m))
        den_m += float(np.sum(bend_m ** 2))
    c_q = num_q / den_q if den_q > 0 else 0.0
    c_m = num_m / den_m if den_m > 0 else 0.0
    return Hypotheses(model=model, lowest=lowest, curvature_q11=float(np.clip(c_q, -1.0, 1.0)),
                      curvature_m11=float(np.clip(c_m, -1.0, 1.0)), k_zero_opening=float(k_zero_opening),
                      offset_q11=_offset(ratios_q, ts), offset_m11=_offset(ratios_m, ts), other=other)


@dataclass(frozen=True)
class HeldOut:
    """The points of one hold-out and every hypothesis' answer there.

    Attributes
    ----------
    lines : int
        How many of the lowest lines were held out.
    n11, opening, q11, m11 : ndarray (P,)
        The held-out points (r/min, chart units) and the chart's Q11 (m^3/s) and M11 (N*m) there.
    distance : ndarray (P,)
        ``1 - a / a_low`` of each point, ``a_low`` the lowest line kept.
    predictions : dict
        hypothesis -> ``(Q11, M11)`` arrays (the hypotheses the refit answers: :attr:`Hypotheses.names`).
    lines_left : int
        Opening lines the hypotheses were refitted on.
    """

    lines: int
    n11: np.ndarray
    opening: np.ndarray
    q11: np.ndarray
    m11: np.ndarray
    distance: np.ndarray
    predictions: dict
    lines_left: int = 0


def sub_chart(chart, keep):
    """``chart`` with only the flow points where ``keep`` (bool, per flow point); contours and runaway kept."""
    return replace(chart, flow_opening=chart.flow_opening[keep], flow_n11=chart.flow_n11[keep],
                   flow_q11=chart.flow_q11[keep])


def hold_out(chart, torque, lines: int, fit_model, fit_other=None) -> HeldOut | None:
    """Hold out the ``lines`` lowest opening lines, refit on the rest, predict the held-out points.

    ``fit_model(chart, torque) -> FittedTurbineModel`` refits the physical model, ``fit_other`` its other form
    (None: not refitted, :data:`OTHER_FORM` not predicted; nor when it cannot represent the rest). None when fewer
    than :data:`MIN_LINES_LEFT` lines would be left or the model cannot represent the rest (``InputError``)."""
    openings = np.unique(chart.flow_opening)
    if openings.size - lines < MIN_LINES_LEFT:
        return None
    held = np.isin(chart.flow_opening, openings[:lines])
    rest = sub_chart(chart, ~held)
    torque = np.asarray(torque, float)
    try:
        model = fit_model(rest, torque[~held])
    except InputError:
        return None
    other = None
    if fit_other is not None:
        try:
            other = fit_other(rest, torque[~held])
        except InputError:
            other = None
    hyp = fit_hypotheses(rest, torque[~held], model, model.k_zero_opening, other=other)
    n, a = chart.flow_n11[held], chart.flow_opening[held]
    predictions = {name: hyp.predict(name, n, a) for name in hyp.names}
    return HeldOut(lines=lines, n11=n, opening=a, q11=chart.flow_q11[held], m11=torque[held],
                   distance=1.0 - a / openings[lines], predictions=predictions,
                   lines_left=int(openings.size - lines))


@dataclass(frozen=True)
class Evidence:
    """What the chart's own held-out lines say about the region below its lowest line.

    Errors of Q11 are log-ratios (about relative errors; Q11 vanishes with the opening and stays positive); errors
    of M11 are fractions of the chart's measured M11 range (``m11_scale``): M11 passes through zero near runaway,
    where a relative error means nothing.

    Attributes
    ----------
    folds : list of HeldOut
        The folds behind the weights (and the band).
    weights : dict
        ``{"q11": {hypothesis: weight}, "m11": {...}}``, each summing to 1.
    errors : dict
        ``{"q11": {hypothesis: RMS error}, "m11": {...}}`` at the held-out points, with ``"blend"`` (the weighed
        hypotheses) and ``"blend_worst"``.
    band : dict
        ``{"q11": (low, high), "m11": (low, high)}``: the band's half-widths below and above the prediction,
        ``kappa h`` in log Q11 and ``kappa h (1 - d)`` in M11 (a fraction of ``m11_scale``; at the closed vanes
        the disc friction's ``-K N11^2`` of eq. 8 holds and the band closes), ``h`` of :func:`band_square` at the
        distance ``d = 1 - a / a_low`` below the lowest line (:func:`band_sides`).
    m11_scale : float
        N*m.
    distance_cap : float
        The band grows as ``d^2`` up to :data:`DISTANCE_CAP_FACTOR` times the largest distance the hold-outs
        tested, and on at the slope it has there beyond (the error model's curvature is not extrapolated further;
        :func:`band_square`, :data:`hillchart.extension.band.BEYOND_CAP`).
    points : int
        Held-out points behind the weights and the band (0: no evidence; the band is :data:`NO_EVIDENCE_SCALE`).
    notes : list of str
    band_folds : list of HeldOut
        Folds refitted on fewer than :data:`MIN_LINES_WEIGHED` lines: behind the band only.
    names : tuple
        The hypotheses weighed (answered by every fold); the others weigh 0.
    """

    folds: list
    weights: dict
    errors: dict
    band: dict
    points: int
    m11_scale: float = 1.0
    distance_cap: float = 1.0
    notes: list = field(default_factory=list)
    band_folds: list = field(default_factory=list)
    names: tuple = HYPOTHESES

    def blend(self, hypotheses: Hypotheses, n11, opening, *, deciding: bool = False):
        """``(Q11, M11)`` of the weighed hypotheses at (``n11``, ``opening``): their weighed median
        (:func:`weighed_median`); with ``deciding``, the name of the hypothesis it takes at each point instead."""
        answers = {h: hypotheses.predict(h, n11, opening) for h in HYPOTHESES
                   if self.weights["q11"][h] > 0 or self.weights["m11"][h] > 0}
        out = tuple(weighed_median([v[j] for v in answers.values()], [self.weights[t][h] for h in answers],
                                   index=deciding) for j, t in enumerate(("q11", "m11")))
        return tuple(np.array(list(answers))[i] for i in out) if deciding else out

    def summary(self) -> str:
        """What ``hillsim train`` prints: how well this chart predicts its own held-out lines, and the weights."""
        if not self.points:
            return ("below the lowest line: no held-out evidence (fewer than "
                    f"{MIN_LINES_WEIGHED + 1} opening lines): hypotheses weighed equally, the band is wide "
                    f"({no_evidence_sides(self.distance_cap)} at half the lowest opening); digitize more opening lines")
        q, m = self.errors["q11"]["blend"], self.errors["m11"]["blend"]
        ranked = sorted(self.names, key=lambda h: -(self.weights["q11"][h] + self.weights["m11"][h]))
        weights = ", ".join(f"{h} {self.weights['q11'][h]:.2f}/{self.weights['m11'][h]:.2f}" for h in ranked)
        h = band_square(0.5, self.distance_cap, math.inf)[0]
        low, high = (100.0 * (math.exp(sign * k * h) - 1.0) for sign, k in zip((-1.0, 1.0), self.band["q11"]))
        return (f"below the lowest line this chart predicts its own held-out lines within {100 * q:.1f} % (Q11) and "
                f"{100 * m:.1f} % of the M11 range (RMS, {self.points} points); hypothesis weights Q11/M11: "
                f"{weights}; the band at half the lowest opening spans {low:+.0f} % to {high:+.0f} % of Q11")

    def to_dict(self) -> dict:
        return {"hypotheses": list(HYPOTHESES), "held_out_points": self.points,
                "held_out_lines": [f.lines for f in self.folds],
                "band_only_held_out_lines": [f.lines for f in self.band_folds], "weights": self.weights,
                "rms_error": self.errors,
                "band_per_distance_squared": {k: {"low": v[0], "high": v[1]} for k, v in self.band.items()},
                "m11_scale": self.m11_scale,
                "distance_cap": self.distance_cap, "notes": list(self.notes)}


def _errors(folds, m11_scale, names):
    """Per target and hypothesis of ``names``: the held-out errors pooled over the folds (:class:`Evidence`)."""
    out = {"q11": {}, "m11": {}}
    for name in names:
        q, m = [], []
        for f in folds:
            pq, pm = f.predictions[name]
            q.append(log_ratio(pq, f.q11, 1e-3 * float(np.max(np.abs(f.q11)))))
            m.append((pm - f.m11) / m11_scale)
        out["q11"][name], out["m11"][name] = np.concatenate(q), np.concatenate(m)
    return out


def weigh(folds, m11_scale: float, names=HYPOTHESES, priors=None) -> Evidence:
    """Pseudo-BMA weights of the hypotheses ``names`` from the held-out folds, the blend's errors and the band.

    A hypothesis that a weighing fold does not answer (the model's other form where its refit failed) weighs 0.
    ``priors`` (hypothesis -> prior weight, 1 when not given) multiply the held-out likelihoods: the model's two
    forms share the prior of one hypothesis by their probability given the whole chart
    (:attr:`hillchart.extension.turbine_model.FittedTurbineModel.form_probability`), so a form the chart's lines
    reject is not revived by a few held-out points.
    Each hypothesis' weight is ``exp(-n/2 log MSE)``, its held-out Gaussian log-likelihood (Yao et al. 2018), with
    ``n`` the number of held-out *lines* (the points of one line share one cause of error, so they are one piece of
    evidence) and the errors divided by ``d^2`` (the error model of :func:`band_scale`). The weights come from the
    folds refitted on at least :data:`MIN_LINES_WEIGHED` lines, the band from every fold."""
    folds = [f for f in folds if f is not None]
    weighed = [f for f in folds if f.lines_left >= MIN_LINES_WEIGHED]
    points = int(sum(f.n11.size for f in weighed))
    names = tuple(h for h in names if all(h in f.predictions for f in weighed))
    priors = {h: float((priors or {}).get(h, 1.0)) for h in names}
    if not points:
        equal = {h: priors[h] / sum(priors.values()) if h in names else 0.0 for h in HYPOTHESES}
        wide = (NO_EVIDENCE_SCALE, NO_EVIDENCE_SCALE)
        return Evidence(folds=[], weights={"q11": dict(equal), "m11": dict(equal)}, errors={"q11": {}, "m11": {}},
                        band={"q11": wide, "m11": wide}, points=0, names=names, m11_scale=m11_scale,
                        distance_cap=NO_EVIDENCE_CAP, notes=["no held-out evidence: too few opening lines"])
    errors = _errors(weighed, m11_scale, names)
    distance_w = np.maximum(np.concatenate([f.distance for f in weighed]), 1e-9)
    lines_w = sum(f.lines for f in weighed)
    # the band: the blend's errors at every fold; M11's band closes at the closed vanes (eq. 8), as 1 - d (a
    # band-only fold that does not answer a hypothesis takes the blend of those it answers, reweighed)
    band_names = tuple(h for h in names if all(h in f.predictions for f in folds))
    band_errors = _errors(folds, m11_scale, band_names)
    distance = np.maximum(np.concatenate([f.distance for f in folds]), 1e-9)
    closing = {"q11": None, "m11": np.maximum(1.0 - distance, 1e-9)}
    lines = sum(f.lines for f in folds)
    weights, rms, band = {}, {}, {}
    for target in ("q11", "m11"):
        mse = {h: float(np.mean((e / distance_w ** GROWTH) ** 2)) for h, e in errors[target].items()}
        best = max(min(mse.values()), 1e-300)
        log_w = {h: math.log(max(priors[h], 1e-300)) - 0.5 * lines_w * math.log(max(v, 1e-300) / best)
                 for h, v in mse.items()}
        top = max(log_w.values())
        log_w = {h: v - top for h, v in log_w.items()}
        total = sum(math.exp(v) for v in log_w.values())
        weights[target] = {h: math.exp(log_w[h]) / total if h in names else 0.0 for h in HYPOTHESES}
        blended = weighed_median([errors[target][h] for h in names], [weights[target][h] for h in names])
        rms[target] = {h: float(np.sqrt(np.mean(e ** 2))) for h, e in errors[target].items()}
        rms[target]["blend"] = float(np.sqrt(np.mean(blended ** 2)))
        rms[target]["blend_worst"] = float(np.max(np.abs(blended)))
        share = sum(weights[target][h] for h in band_names)
        # every weighed hypothesis missing from a band-only fold: those left, equally
        scored = weighed_median([band_errors[target][h] for h in band_names],
                                [weights[target][h] if share > 0 else 1.0 for h in band_names])
        # without the folds' signs (band_sides' ``folds``): a symmetric band where the folds disagree widened the
        # in-class family's median head band from 4.8 to 5.1 points and covered nothing more (97 %), the
        # out-of-class family's and the real chart's not at all (docs/guarantee-benchmark.md, step 11)
        band[target] = band_sides(scored, distance, lines, shape=closing[target],
                                  min_side_fraction=MIN_SIDE_FRACTION_BELOW)
    return Evidence(folds=weighed, weights=weights, errors=rms, band=band, points=points, m11_scale=m11_scale,
                    distance_cap=min(1.0, DISTANCE_CAP_FACTOR * float(distance.max())),
                    band_folds=[f for f in folds if f not in weighed], names=names)


def chart_evidence(chart, torque, fit_model, *, hold_out_lines=HOLD_OUT, fit_other=None, priors=None) -> Evidence:
    """Hold out the chart's lowest line, then its two lowest (:data:`HOLD_OUT`), and weigh the hypotheses
    (:data:`OTHER_FORM` among them when ``fit_other`` refits the model's other form; ``priors``: :func:`weigh`)."""
    torque = np.asarray(torque, float)
    names = HYPOTHESES if fit_other is not None else WITHOUT_OTHER_FORM
    return weigh([hold_out(chart, torque, k, fit_model, fit_other) for k in hold_out_lines],
                 float(np.ptp(torque)) or 1.0, names, priors)


@dataclass(frozen=True)
class Extrapolation:
    """A chart's answer below its lowest line: its hypotheses, the evidence that weighs them, and the band.

    Attributes
    ----------
    hypotheses : Hypotheses
        Fitted to the whole chart.
    evidence : Evidence
        From the chart's held-out lowest lines.
    n11_top : float
        r/min: the N11 range the answer is tabulated over (0 .. n11_top).
    """

    hypotheses: Hypotheses
    evidence: Evidence
    n11_top: float
    overspeed: dict | None = None
    line_ends: tuple = ()
    bare: tuple = ()

    @classmethod
    def of_chart(cls, chart, torque, model, bare=()) -> "Extrapolation":
        """Weigh the hypotheses of ``chart`` (``torque``: M11 at its flow points, N*m; ``model``: the physical
        model fitted to the whole chart; ``bare``: the lines of
        :func:`hillchart.extension.silent_samples.lines_without_runaway`, whose straight continuations answer toward
        runaway, within the band of the continuations' held-out misses)."""
        from functools import partial

        from hillchart.extension.turbine_model import fit_turbine_model

        # the refits take the whole chart's form (with or without the throat foot): the evidence judges the model
        # the answer uses, also where a fold's lines are too few to find the foot on their own
        refit = partial(fit_turbine_model, throat_foot_mm=model.throat_foot_mm)
        other = model.other_form
        refit_other = None if other is None else partial(fit_turbine_model, throat_foot_mm=other.throat_foot_mm)
        priors = None if other is None else {
            **dict.fromkeys(("model", "anchored-model"), model.form_probability),
            **dict.fromkeys(OTHER_FORM, other.form_probability)}
        evidence = chart_evidence(chart, torque, refit, fit_other=refit_other, priors=priors)
        hypotheses = fit_hypotheses(chart, torque, model, model.k_zero_opening, other=other)
        # 1.5 x the chart's largest N11, where a load rejection's overspeed at small openings runs (the model's
        # answers held at its pumping limit beyond it, :meth:`Hypotheses.predict`)
        top = 1.5 * max(float(chart.flow_n11.max()), float(chart.runaway_n11.max()) if chart.has_runaway else 0.0)
        ends = tuple((float(a), float(chart.flow_n11[chart.flow_opening == a].max()))
                     for a in np.unique(chart.flow_opening))
        return cls(hypotheses=hypotheses, evidence=evidence, n11_top=top,
                   overspeed=overspeed_evidence(chart, torque, refit), line_ends=ends, bare=tuple(bare))

    @property
    def lowest_opening(self) -> float:
        return self.hypotheses.lowest.opening

    def values(self, n11, opening):
        """``(Q11, M11)`` of the weighed hypotheses at (``n11``, ``opening``) below the lowest line."""
        return self.evidence.blend(self.hypotheses, n11, opening)

    def overspeed_widths(self, n11, opening):
        """``(low, high)``: the M11 band's half-widths (N*m) toward runaway at (``n11``, ``opening``) (arrays): the
        per-gap widths of :func:`overspeed_evidence` (the model's misses; on the ``bare`` lines the continuations')
        times the relative N11 gap beyond the last point of the digitized line at that opening (up to the cap of
        :data:`OVERSPEED_GAP_CAP`); 0 on or before it, between lines, below the lowest line, without evidence."""
        n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
        low, high = np.zeros(n11.shape), np.zeros(n11.shape)
        band = (self.overspeed or {}).get("m11_band_per_gap")
        if not band:
            return low, high
        scale, cap = self.overspeed["m11_scale"], self.overspeed["gap_cap"]
        for a, n_end in self.line_ends:
            on = np.isclose(opening, a, rtol=0.0, atol=1e-9 * max(abs(a), 1.0)) & (n11 > n_end)
            gap = np.minimum((n11[on] - n_end) / n_end, cap)
            side = self.overspeed.get("line_m11_band_per_gap", band) if a in self.bare else band
            low[on], high[on] = side["low"] * scale * gap, side["high"] * scale * gap
        return low, high

    def summary(self) -> str:
        text = self.evidence.summary()
        o = self.overspeed
        if o:
            text += (f"; toward runaway the model predicts each line's held-out last point within "
                     f"{100 * o['model_q11_rms']:.1f} % (Q11) and {100 * o['model_m11_rms']:.1f} % of the M11 range "
                     f"(a straight continuation of each line: {100 * o['line_q11_rms']:.1f} % and "
                     f"{100 * o['line_m11_rms']:.1f} %)")
            if o.get("beyond_model_range"):
                text += (f" ({o['beyond_model_range']} of the {o['held_out_points']} held-out points lie beyond the "
                         f"refitted model's pumping limit, N11 = {o['model_n11_limit']:.4g}, and count as misses of "
                         f"their whole value)")
            if o.get("runaway_n11_rms") is not None:
                text += f", its held-out runaway speeds within {100 * o['runaway_n11_rms']:.1f} %"
            band = o.get("m11_band_per_gap")
            if band:
                text += (f"; the torque band 10 % beyond a line's last point spans {-10 * band['low']:+.1f} % to "
                         f"{10 * band['high']:+.1f} % of the M11 range")
        return text

    def to_dict(self) -> dict:
        return {**self.evidence.to_dict(), "lowest_opening": self.lowest_opening, "overspeed": self.overspeed,
                "summary": self.summary()}


def overspeed_evidence(chart, torque, fit_model) -> dict | None:
    """How well the chart predicts itself toward runaway, where a load rejection's maximum speed comes: each line's
    highest-N11 point held out (lines of 3 or more points) and predicted by the model refitted without them and by a
    straight continuation of the line through its last two kept points; the runaway points, where given, held out
    and their N11 predicted by the refitted model's runaway curve. RMS errors: Q11 and runaway N11 relative, M11 a
    fraction of the measured M11 range. None when no line has 3 points or the refit fails.

    The overspeed samples of the extension are the whole chart's model; its signed M11 misses here, per relative
    N11 gap ``(N11 - N11_last) / N11_last`` beyond the line's last kept point, give the band toward runaway
    (``m11_band_per_gap``, fractions of the M11 range per unit gap, below and above: :func:`band_sides` with linear
    growth), in which the ensemble members' torque stands (:meth:`Extrapolation.overspeed_widths`)."""
    torque = np.asarray(torque, float)
    lines = [np.flatnonzero(chart.flow_opening == a) for a in np.unique(chart.flow_opening)]
    # one held-out point per line of 3 or more, in the order of ``q_line``, ``m_line`` and ``gaps`` below
    ends = np.array([index[np.argmax(chart.flow_n11[index])] for index in lines if index.size >= 3], int)
    if not ends.size:
        return None
    held = np.zeros(chart.flow_n11.size, bool)
    held[ends] = True
    try:
        model = fit_model(sub_chart(chart, ~held), torque[~held])
    except InputError:
        return None
    scale = float(np.ptp(torque)) or 1.0
    n, a, q, m = chart.flow_n11[ends], chart.flow_opening[ends], chart.flow_q11[ends], torque[ends]
    # a point beyond the refitted model's pumping limit has no model answer: it counts as the model's miss of the
    # whole value (the line still answers there)
    inside = n < 0.95 * model.n11_limit if math.isfinite(model.n11_limit) else np.ones(n.size, bool)
    q_model, m_model = np.zeros_like(q), np.zeros_like(m)
    if inside.any():
        q_model[inside], m_model[inside] = model.q11(n[inside], a[inside]), model.m11(n[inside], a[inside])
    q_line, m_line, gaps = [], [], []
    for k in ends:
        on = np.flatnonzero((chart.flow_opening == chart.flow_opening[k]) & ~held)
        n_on, last = chart.flow_n11[on], float(chart.flow_n11[on].max())  # the line's last kept point
        q_line.append(continuation(n_on, chart.flow_q11[on], chart.flow_n11[k]))
        m_line.append(continuation(n_on, torque[on], chart.flow_n11[k]))
        gaps.append((chart.flow_n11[k] - last) / last)
    # the band toward runaway: the model's signed M11 misses per relative N11 gap beyond the line's last kept point
    # (one point per line: the lines are the units of evidence), growing linearly with the gap; calibrated on the
    # far half of the gaps (a miss over a tiny gap is reading noise, not a steep growth), and growing no further
    # than OVERSPEED_GAP_CAP times the largest gap tested
    gaps = np.array(gaps)
    m_low, m_high = band_sides((m_model - m) / scale, gaps, lines=len(ends), growth=1.0)
    l_low, l_high = band_sides((np.array(m_line) - m) / scale, gaps, lines=len(ends), growth=1.0)
    result = {"held_out_points": int(held.sum()), "beyond_model_range": int((~inside).sum()),
              "model_n11_limit": float(model.n11_limit) if math.isfinite(model.n11_limit) else None,
              "m11_band_per_gap": {"low": m_low, "high": m_high}, "m11_scale": scale,
              "line_m11_band_per_gap": {"low": l_low, "high": l_high},
              "gap_cap": OVERSPEED_GAP_CAP * float(gaps.max()),
              "model_q11_rms": float(np.sqrt(np.mean(((q_model - q) / q) ** 2))),
              "model_m11_rms": float(np.sqrt(np.mean(((m_model - m) / scale) ** 2))),
              "line_q11_rms": float(np.sqrt(np.mean(((np.array(q_line) - q) / q) ** 2))),
              "line_m11_rms": float(np.sqrt(np.mean(((np.array(m_line) - m) / scale) ** 2))),
              "runaway_n11_rms": None}
    if chart.has_runaway and chart.runaway_n11.size >= 2:
        without = replace(chart, runaway_opening=chart.runaway_opening[:0], runaway_n11=chart.runaway_n11[:0],
                          runaway_q11=chart.runaway_q11[:0])
        try:
            refit = fit_model(without, torque)
        except InputError:
            return result
        predicted = np.array([refit.runaway_n11(float(o)) for o in chart.runaway_opening])
        ok = np.isfinite(predicted)
        if ok.any():
            result["runaway_n11_rms"] = float(np.sqrt(np.mean(((predicted[ok] - chart.runaway_n11[ok])
                                                                / chart.runaway_n11[ok]) ** 2)))
    return result


__all__ = ["HYPOTHESES", "OTHER_FORM", "WITHOUT_OTHER_FORM", "CURVATURE_LINES", "HOLD_OUT", "MIN_LINES_LEFT",
           "MIN_LINES_WEIGHED", "DISTANCE_CAP_FACTOR", "OVERSPEED_GAP_CAP", "MAX_OFFSET", "LowestLine", "Hypotheses",
           "offset_line", "fit_hypotheses", "HeldOut",
           "sub_chart", "hold_out", "Evidence", "weigh", "chart_evidence", "Extrapolation", "overspeed_evidence",
           "GROWTH", "FAR_FRACTION", "BAND_COVERAGE", "MIN_SIDE_FRACTION", "MIN_SIDE_FRACTION_BELOW",
           "NO_EVIDENCE_SCALE", "NO_EVIDENCE_CAP", "band_square", "log_ratio", "band_scale", "band_sides",
           "member_positions", "continuation"]
