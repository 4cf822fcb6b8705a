"""What a double-regulated test table says below its smallest guide-vane angle: hypotheses judged by its own angles.

A load rejection of a bulb or Kaplan unit ends with the guide vanes closing below the smallest angle the model test
measured; nothing is measured there. As for the Francis chart (:mod:`hillchart.extension.hypotheses`), the fitted
physical model (:mod:`hillchart.extension.bulb_model`) is one hypothesis among several, and the table decides among
them: it holds out its own lowest guide-vane angles, refits every hypothesis on the rest, and scores each at the
held-out points.

A *sweep* is a set of measured points that share the blade angle and N11 (a head of a fixed-blade rig, a blade
angle and unit speed of a Kaplan test) over several guide-vane angles (:func:`sweeps`). Held out: the ``k`` lowest
angles of every sweep that keeps :data:`MIN_ANGLES_LEFT` angles (``k`` in :data:`HOLD_OUT`). The hypotheses are
functions of the opening ratio ``t = (a - a_c) / (a_low - a_c)`` (``a_c`` the model's closed vane, ``a_low`` the
lowest kept angle of the sweep; ``t`` in [0, 1]) at the same N11 and blade angle (:func:`hypothesis_value`, the one
implementation the simulator's kernel runs as well):

``model``
    the fitted bulb model, ``y = y_m(a)``;
``anchored-model``
    the model corrected to pass through the lowest kept angle, ``y = y_m(a) + (y_low - y_m(a_low)) t``;
``line``
    a straight line in opening from the lowest kept angle to the closed vanes: ``Q11 = Q_low t``,
    ``M11 = M_0 + (M_low - M_0) t`` with ``M_0 = -K N11^2`` (eq. (8) of the BP hill-chart paper, K the model's disc
    friction);
``quadratic``
    the paper's polynomial extrapolation in opening (section 2.6 (3), degree 2) in the same anchored form,
    ``Q11 = Q_low (t + c t (t - 1))``, ``M11 = M_0 + (M_low - M_0) (t + c t (t - 1))``, the curvature ``c`` fitted by
    least squares to the lowest :data:`CURVATURE_ANGLES` kept angles of every sweep.

``y_low(N11, phi)`` is the value at the lowest kept angle: the model there plus the sweep's own residual against it
at that angle. In the simulator it is the nets' value at the table's smallest angle, which fit it.

The weights are pseudo-BMA on the held-out errors (:func:`pseudo_bma`, as :func:`hillchart.extension.hypotheses.weigh`
does for the Francis chart: one piece of evidence per held-out angle, the errors divided by the squared distance ``d = 1
- t``), never the fit. The hypotheses answer by their weighed median (:func:`hillchart.extension.band.weighed_median`,
as a Francis chart's: with few held-out angles the weights stay spread, and the mean stood where no hypothesis does);
the band is split-conformal on the median's held-out residuals of each fold
(:func:`hillchart.extension.hypotheses.band_scale`, the widest fold's, :func:`fold_band`), growing as ``d^2``
(:func:`hillchart.extension.band.band_square`, on at its slope beyond the distances tested) after a straight start
near the smallest angle, where ``d^2`` would shrink a band calibrated further down to nothing
(:func:`hillchart.extension.band.band_envelope`). A table without sweeps of :data:`MIN_ANGLES_LEFT` + 1 angles gives
no evidence: the fitted model answers alone (weighed equally, the line and the quadratic, 15-35 % off on every table
measured, took a synthetic bulb's rejection 1.6 points of speed off), the band is the wide no-evidence band (linear
in the distance, :data:`hillchart.extension.band.NO_EVIDENCE_SCALE`), and the summary says so. Toward overspeed the
table's evidence is stated too (:func:`overspeed_evidence`): the highest-N11 point of every setting held out."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np

from hillchart.errors import InputError
from hillchart.extension.band import (BEYOND_CAP, band_envelope, continuation, no_evidence_sides, runout,
                                      weighed_median)
from hillchart.extension.hypotheses import GROWTH, NO_EVIDENCE_CAP, NO_EVIDENCE_SCALE, band_scale, log_ratio

#: The hypotheses, in the order of every weight vector (and of :func:`hypothesis_value`'s ``which``).
HYPOTHESES = ("model", "anchored-model", "line", "quadratic")
#: How the weighed hypotheses answer (:class:`BulbExtrapolation`): weighed median, or weighed mean (older files).
COMBINATIONS = ("median", "mean")
#: Held-out folds of ``hillsim fccm --simulator-nets``: the lowest angle of every sweep, then the two lowest.
HOLD_OUT = (1, 2)
#: Angles a sweep keeps after a hold-out (a sweep with fewer takes no part in that fold).
MIN_ANGLES_LEFT = 3
#: Lowest kept angles of each sweep whose bending gives the quadratic hypothesis its curvature.
CURVATURE_ANGLES = 4
#: Points belong to one sweep when their N11 differ by less than this fraction of the median N11 (the rig's head
#: noise moves a derived N11 by a few tenths of a percent) and their blade angles by less than BLADE_GAP_DEG.
N11_GAP_FRACTION = 0.01
BLADE_GAP_DEG = 0.1
#: Below the table's smallest angle, the weighed hypotheses alone answer from this fraction of the gap between the
#: closed vane and that angle, or from :data:`HANDOVER_STEPS` of the table's angle step below it where that is
#: nearer (:func:`angle_step`); above it they hand over to the nets (a C1 smoothstep, reaching the nets at the angle).
#: The step bounds the hand-over where the closed vane lies far below the table: on the 137 kW rig's table without
#: its two lowest angles (closed vane 60 deg below) a fifth of the gap let the nets answer almost alone 12 deg below
#: the table, and the run missed the angles held out by 3 times the hypotheses' mean error (1.3 against 0.4 %).
HANDOVER_FRACTION = 0.8
HANDOVER_STEPS = 0.5


def angle_step(n11, opening, blade) -> float | None:
    """The table's guide-vane step at its smallest angles: the median over its sweeps (:func:`sweeps`) of the gap
    between their two smallest angles, deg; None without sweeps.

    Examples
    --------
    >>> angle_step([100.0, 100.0, 100.0, 120.0, 120.0], [35.0, 37.5, 45.0, 40.0, 42.0], [0.0] * 5)
    2.25
    """
    opening = np.asarray(opening, float).ravel()
    gaps = [float(np.diff(np.unique(opening[s])[:2])[0]) for s in sweeps(n11, opening, blade)]
    return float(np.median(gaps)) if gaps else None


@numba.njit(cache=True)
def hypothesis_value(which, t, y_model, y_model_low, y_low, y_closed, curvature):
    """Hypothesis ``which`` (index in :data:`HYPOTHESES`) at the opening ratio ``t``: ``y_model`` and ``y_model_low``
    the model at the angle and at the lowest kept angle, ``y_low`` the characteristic there, ``y_closed`` its value at
    the closed vanes (0 for Q11, ``-K N11^2`` for M11, eq. (8) of the BP hill-chart paper), ``curvature`` the
    quadratic's ``c``. Linear in the four values, so the same call on their N11-derivatives gives the derivative.

    Examples
    --------
    >>> [round(hypothesis_value(k, 0.5, 1.0, 2.0, 3.0, 0.0, 0.4), 3) for k in range(4)]
    [1.0, 1.5, 1.5, 1.2]
    """
    if which == 0:
        return y_model
    if which == 1:
        return y_model + (y_low - y_model_low) * t
    if which == 2:
        return y_closed + (y_low - y_closed) * t
    return y_closed + (y_low - y_closed) * (t + curvature * t * (t - 1.0))


@numba.njit(cache=True)
def _hypothesis_values(which, t, y_model, y_model_low, y_low, y_closed, curvature):
    out = np.empty(t.size)
    for i in range(t.size):
        out[i] = hypothesis_value(which, t[i], y_model[i], y_model_low[i], y_low[i], y_closed[i], curvature)
    return out


def opening_ratio(opening, closed: float, low):
    """``t = (a - a_c) / (a_low - a_c)`` clipped to [0, 1]: 0 at the closed vanes, 1 at the lowest kept angle."""
    return np.clip((np.asarray(opening, float) - closed) / (np.asarray(low, float) - closed), 0.0, 1.0)


def _clusters(values, gap: float) -> np.ndarray:
    """Labels of ``values`` grouped in ascending order, a group spanning at most ``gap`` from its smallest value (not
    chained: the blade angles of a scattered campaign lie closer than ``gap`` to their neighbours over the whole
    range)."""
    order = np.argsort(values, kind="stable")
    labels = np.empty(values.size, int)
    label, start = -1, -np.inf
    for i in order:
        if values[i] - start > gap:
            label, start = label + 1, values[i]
        labels[i] = label
    return labels


def sweeps(n11, opening, blade) -> list[np.ndarray]:
    """The table's guide-vane sweeps: indices of the points sharing the blade angle and N11 (within
    :data:`BLADE_GAP_DEG` and :data:`N11_GAP_FRACTION`), ordered by angle, for groups of 2 or more angles.

    Examples
    --------
    >>> [s.tolist() for s in sweeps([100.0, 100.2, 120.0, 100.1], [40.0, 35.0, 40.0, 50.0], [0.0, 0.0, 0.0, 0.0])]
    [[1, 0, 3]]
    """
    n11, opening, blade = (np.asarray(v, float).ravel() for v in (n11, opening, blade))
    key = (_clusters(blade, BLADE_GAP_DEG) * (n11.size + 1)
           + _clusters(n11, N11_GAP_FRACTION * float(np.median(n11))))
    out = []
    for k in np.unique(key):
        index = np.flatnonzero(key == k)
        if np.unique(opening[index]).size >= 2:
            out.append(index[np.argsort(opening[index], kind="stable")])
    return out


def _fit(n, a, b, q, m, opening_closed, seed):
    from hillchart.extension.bulb_model import fit_bulb_model

    return fit_bulb_model(n, a, b, q, m, opening_closed=opening_closed, seed=seed, source="the table's kept points")


@dataclass(frozen=True)
class SweepAnchors:
    """Per point: the lowest kept angle of its sweep and the characteristic there (model plus residual)."""

    model: object
    low: np.ndarray
    q_residual: np.ndarray
    m_residual: np.ndarray

    def values(self, which: str, n11, opening, blade, curvature=(0.0, 0.0)):
        """``(Q11, M11)`` of hypothesis ``which`` at the points (arrays aligned with the anchors)."""
        model, low = self.model, self.low
        t = opening_ratio(opening, model.opening_closed, low)
        q_ml, m_ml = model.q11(n11, low, blade), model.m11(n11, low, blade)
        q_m, m_m = model.q11(n11, opening, blade), model.m11(n11, opening, blade)
        m_0 = -model.k_zero_opening * np.asarray(n11, float) ** 2
        k = HYPOTHESES.index(which)
        q = _hypothesis_values(k, t, q_m, q_ml, q_ml + self.q_residual, np.zeros(t.size), curvature[0])
        m = _hypothesis_values(k, t, m_m, m_ml, m_ml + self.m_residual, m_0, curvature[1])
        return q, m


def _anchors(model, n, a, b, q, m, lines, kept):
    """Per line: the kept indices, the lowest kept angle and the residuals of the model there (mean of the points
    at that angle)."""
    out = []
    for line in lines:
        keep = line[kept[line]]
        if keep.size == 0:
            continue
        low = float(a[keep].min())
        at = keep[a[keep] == low]
        out.append((line, keep, low, float(np.mean(q[at] - model.q11(n[at], low, b[at]))),
                    float(np.mean(m[at] - model.m11(n[at], low, b[at])))))
    return out


def fit_curvature(model, n, a, b, q, m, anchors) -> tuple[float, float]:
    """``c`` of the quadratic hypothesis for Q11 and M11: least squares over the lowest :data:`CURVATURE_ANGLES`
    kept angles of every sweep (``t >= 1`` there), clipped to [-1, 1], as
    :func:`hillchart.extension.hypotheses.fit_hypotheses` does for the lines of a Francis chart."""
    num_q = den_q = num_m = den_m = 0.0
    for _, keep, low, r_q, r_m in anchors:
        angles = np.unique(a[keep])[:CURVATURE_ANGLES]
        idx = keep[np.isin(a[keep], angles)]
        t = (a[idx] - model.opening_closed) / (low - model.opening_closed)
        base_q = model.q11(n[idx], low, b[idx]) + r_q
        base_m = model.m11(n[idx], low, b[idx]) + r_m
        m_0 = -model.k_zero_opening * n[idx] ** 2
        bend_q, bend_m = base_q * t * (t - 1.0), (base_m - m_0) * t * (t - 1.0)
        num_q += float(np.sum((q[idx] - base_q * t) * bend_q))
        den_q += float(np.sum(bend_q ** 2))
        num_m += float(np.sum((m[idx] - m_0 - (base_m - m_0) * t) * bend_m))
        den_m += float(np.sum(bend_m ** 2))
    c_q = num_q / den_q if den_q > 0 else 0.0
    c_m = num_m / den_m if den_m > 0 else 0.0
    return float(np.clip(c_q, -1.0, 1.0)), float(np.clip(c_m, -1.0, 1.0))


@dataclass(frozen=True)
class AngleHoldOut:
    """The points of one hold-out (the ``angles`` lowest angles of every sweep) and every hypothesis' answer there.

    Attributes
    ----------
    angles : int
    sweeps : int
        Sweeps that took part.
    n11, opening, blade_angle, q11, m11 : ndarray (P,)
        The held-out points (r/min, deg, deg) and the table's Q11 (m^3/s) and M11 (N*m) there.
    distance : ndarray (P,)
        ``1 - t`` of each point below the lowest kept angle of its sweep.
    predictions : dict
        hypothesis -> ``(Q11, M11)`` arrays.
    """

    angles: int
    sweeps: int
    n11: np.ndarray
    opening: np.ndarray
    blade_angle: np.ndarray
    q11: np.ndarray
    m11: np.ndarray
    distance: np.ndarray
    predictions: dict


SAMPLE_KEYS = ("n11", "opening", "blade_angle", "q11", "m11")


def _arrays(samples):
    """The measured samples' arrays; an error names what is missing or of unequal length."""
    missing = [k for k in SAMPLE_KEYS if not isinstance(samples, dict) or k not in samples]
    if missing:
        raise InputError(f"samples must be a dict with the arrays {', '.join(SAMPLE_KEYS)}; missing {missing}")
    arrays = tuple(np.asarray(samples[k], float).ravel() for k in SAMPLE_KEYS)
    sizes = {k: a.size for k, a in zip(SAMPLE_KEYS, arrays)}
    if len(set(sizes.values())) != 1:
        raise InputError(f"samples' arrays must have one length, got {sizes}")
    return arrays


def held_out_mask(n11, opening, blade, angles: int) -> tuple[np.ndarray, list]:
    """``(held, sweeps)``: the points among the ``angles`` lowest angles of every sweep that keeps
    :data:`MIN_ANGLES_LEFT` angles (bool per point), and those sweeps (index arrays).

    Examples
    --------
    >>> held, lines = held_out_mask(np.full(5, 100.0), [35.0, 40.0, 45.0, 50.0, 55.0], np.zeros(5), 2)
    >>> held.tolist(), len(lines)
    ([True, True, False, False, False], 1)
    """
    n11, opening, blade = (np.asarray(v, float).ravel() for v in (n11, opening, blade))
    lines = [s for s in sweeps(n11, opening, blade) if np.unique(opening[s]).size - angles >= MIN_ANGLES_LEFT]
    held = np.zeros(n11.size, bool)
    for line in lines:
        held[line[np.isin(opening[line], np.unique(opening[line])[:angles])]] = True
    return held, lines


def hold_out_angles(samples: dict, angles: int, *, opening_closed: float | None = None,
                    seed: int = 0) -> AngleHoldOut | None:
    """Hold out the ``angles`` lowest guide-vane angles of every sweep that keeps :data:`MIN_ANGLES_LEFT`, refit the
    bulb model on every other measured point, and predict the held-out points by each hypothesis. None when no
    sweep is long enough or the model cannot represent the rest."""
    if isinstance(angles, bool) or not isinstance(angles, (int, np.integer)) or angles < 1:
        raise InputError(f"angles must be an integer >= 1, got {angles!r}")
    n, a, b, q, m = _arrays(samples)
    held, lines = held_out_mask(n, a, b, angles)
    if not lines:
        return None
    try:
        model = _fit(n[~held], a[~held], b[~held], q[~held], m[~held], opening_closed, seed)
    except InputError:
        return None
    anchors = _anchors(model, n, a, b, q, m, lines, ~held)
    curvature = fit_curvature(model, n, a, b, q, m, anchors)
    idx, low, r_q, r_m = [], [], [], []
    for line, _, a_low, rq, rm in anchors:
        out = line[held[line]]
        idx.append(out)
        low.append(np.full(out.size, a_low))
        r_q.append(np.full(out.size, rq))
        r_m.append(np.full(out.size, rm))
    idx, low = np.concatenate(idx), np.concatenate(low)
    anchor = SweepAnchors(model=model, low=low, q_residual=np.concatenate(r_q), m_residual=np.concatenate(r_m))
    predictions = {h: anchor.values(h, n[idx], a[idx], b[idx], curvature) for h in HYPOTHESES}
    return AngleHoldOut(angles=int(angles), sweeps=len(lines), n11=n[idx], opening=a[idx], blade_angle=b[idx],
                        q11=q[idx], m11=m[idx], distance=1.0 - opening_ratio(a[idx], model.opening_closed, low),
                        predictions=predictions)


def pseudo_bma(errors: dict, distance, pieces: int) -> dict:
    """Pseudo-BMA weights (Yao et al. 2018) of ``errors`` (hypothesis -> held-out errors): ``exp(-n/2 log MSE)``
    with ``n`` = ``pieces`` (the held-out angles: the points of one angle share one cause of error) and the errors
    divided by ``d^2`` (the error model of :func:`hillchart.extension.hypotheses.band_scale`), as
    :func:`hillchart.extension.hypotheses.weigh` weighs the Francis hypotheses.

    Examples
    --------
    >>> w = pseudo_bma({"a": np.array([0.01]), "b": np.array([0.02])}, np.array([0.5]), 2)
    >>> round(w["a"], 3), round(w["b"], 3)
    (0.8, 0.2)
    """
    distance = np.maximum(np.asarray(distance, float), 1e-9)
    mse = {h: float(np.mean((np.asarray(e, float) / distance ** GROWTH) ** 2)) for h, e in errors.items()}
    best = max(min(mse.values()), 1e-300)
    log_w = {h: -0.5 * pieces * math.log(max(v, 1e-300) / best) for h, v in mse.items()}
    total = sum(math.exp(v) for v in log_w.values())
    return {h: math.exp(v) / total for h, v in log_w.items()}


def _stats(e) -> dict:
    e = np.asarray(e, float)
    return {"rms": float(np.sqrt(np.mean(e ** 2))), "mean_abs": float(np.mean(np.abs(e))),
            "worst": float(np.max(np.abs(e)))}


def fold_errors(fold: AngleHoldOut, m11_scale: float) -> dict:
    """``{"q11": {hypothesis: errors}, "m11": {...}}`` at the held-out points of ``fold``: Q11 as log-ratios (about
    relative; a sign change counts as a large error), M11 as fractions of ``m11_scale`` (the table's M11 range)."""
    floor = 1e-3 * float(np.max(np.abs(fold.q11)))
    return {"q11": {h: log_ratio(p[0], fold.q11, floor) for h, p in fold.predictions.items()},
            "m11": {h: (p[1] - fold.m11) / m11_scale for h, p in fold.predictions.items()}}


@dataclass(frozen=True)
class TableEvidence:
    """What the table's own held-out angles say below its smallest guide-vane angle.

    Attributes
    ----------
    folds : list of AngleHoldOut
    weights : dict
        ``{"q11": {hypothesis: weight}, "m11": {...}}``, each summing to 1.
    errors : dict
        ``{"q11": {hypothesis or "blend": {"rms", "mean_abs", "worst"}}, "m11": {...}}`` at the held-out points of
        every fold together (Q11 log-ratios, M11 fractions of ``m11_scale``).
    band : dict
        ``{"q11": kappa, "m11": kappa}``: the band's half-width (:func:`band_scale`) ``kappa h(d)`` as a log-ratio
        of Q11 and ``kappa h(d) (1 - d)`` as a share of the M11 range ``m11_scale``, ``h`` of
        :func:`hillchart.extension.band.band_envelope`.
    points : int
        Held-out points behind the weights (0: none; the band is ``NO_EVIDENCE_SCALE``).
    m11_scale : float
        The table's measured M11 range, N*m.
    distance_cap : float
        The band grows as ``d^2`` up to the largest distance the hold-outs tested, then on at its slope there.
    curvature : (float, float)
        ``c`` of the quadratic hypothesis for Q11 and M11, fitted to the whole table.
    crossover : dict
        ``{"q11": x, "m11": x}``: where the band's straight start meets its square
        (:func:`hillchart.extension.band.band_envelope`, :func:`fold_band`); 0 without evidence.
    overspeed : dict or None
        :func:`overspeed_evidence`.
    notes : list of str
    """

    folds: list
    weights: dict
    errors: dict
    band: dict
    points: int
    m11_scale: float
    distance_cap: float
    curvature: tuple = (0.0, 0.0)
    crossover: dict = field(default_factory=lambda: {"q11": 0.0, "m11": 0.0})
    overspeed: dict | None = None
    notes: list = field(default_factory=list)

    def weight_vectors(self) -> tuple[list, list]:
        """The Q11 and M11 weights in the order of :data:`HYPOTHESES`."""
        return [self.weights["q11"][h] for h in HYPOTHESES], [self.weights["m11"][h] for h in HYPOTHESES]

    def summary(self) -> str:
        """What ``hillsim fccm --simulator-nets`` prints."""
        if not self.points:
            text = (f"below the lowest guide-vane angle: no held-out evidence (no sweep over {MIN_ANGLES_LEFT + 1} "
                    "or more guide-vane angles at one N11 and blade angle): the fitted model answers alone, the band "
                    f"is wide ({no_evidence_sides(self.distance_cap)} at half the gap to the closed vane); measure "
                    "guide-vane sweeps down to small angles")
        else:
            q, m = self.errors["q11"]["blend"], self.errors["m11"]["blend"]
            ranked = sorted(HYPOTHESES, key=lambda h: -(self.weights["q11"][h] + self.weights["m11"][h]))
            weights = ", ".join(f"{h} {self.weights['q11'][h]:.2f}/{self.weights['m11'][h]:.2f}" for h in ranked)
            text = (f"below the lowest guide-vane angle this table predicts its own held-out angles within "
                    f"{100 * q['rms']:.1f} % (Q11) and {100 * m['rms']:.1f} % (M11, of its range) RMS, worst "
                    f"{100 * q['worst']:.1f} % and {100 * m['worst']:.1f} % ({self.points} points); hypothesis "
                    f"weights Q11/M11: {weights}")
        o = self.overspeed
        if o:
            text += (f"; toward overspeed the model predicts each setting's held-out highest-N11 point within "
                     f"{100 * o['model_q11_rms']:.1f} % (Q11) and {100 * o['model_m11_rms']:.1f} % of the M11 range "
                     f"(a straight continuation: {100 * o['line_q11_rms']:.1f} % and {100 * o['line_m11_rms']:.1f} %)")
        return text

    def to_dict(self) -> dict:
        return {"hypotheses": list(HYPOTHESES), "held_out_points": self.points,
                "held_out_angles": [f.angles for f in self.folds], "weights": self.weights, "errors": self.errors,
                "band_per_distance_squared": self.band, "band_crossover": self.crossover, "m11_scale": self.m11_scale,
                "distance_cap": self.distance_cap, "curvature": list(self.curvature), "overspeed": self.overspeed,
                "notes": list(self.notes), "summary": self.summary()}


def weigh_folds(folds, m11_scale: float) -> tuple[dict, dict, dict, float, int, dict]:
    """Weights, error statistics, band, distance cap, points and the band's crossover of the hypotheses from
    held-out folds (None entries skipped); ``points`` 0 when there are none."""
    folds = [f for f in folds if f is not None]
    points = int(sum(f.n11.size for f in folds))
    if not points:
        alone = {h: float(h == "model") for h in HYPOTHESES}  # the prior: the physical model (module docstring)
        return ({"q11": dict(alone), "m11": dict(alone)}, {"q11": {}, "m11": {}},
                {"q11": NO_EVIDENCE_SCALE, "m11": NO_EVIDENCE_SCALE}, NO_EVIDENCE_CAP, 0, {"q11": 0.0, "m11": 0.0})
    per_fold = [fold_errors(f, m11_scale) for f in folds]
    distance = np.maximum(np.concatenate([f.distance for f in folds]), 1e-9)
    pieces = sum(f.angles for f in folds)
    weights, stats, band, crossover, cap = {}, {}, {}, {}, min(1.0, float(distance.max()))
    # the band of a member moves Q11 by a factor (so it vanishes at the closed vanes) and M11 by a share of the
    # table's M11 range closing as 1 - d toward them (the Francis chart's band): calibrated on the weighed median's
    # Q11 log-ratios and its M11 misses over (1 - d) at each fold's points
    for index, target in enumerate(("q11", "m11")):
        errors = {h: np.concatenate([e[target][h] for e in per_fold]) for h in HYPOTHESES}
        weights[target] = pseudo_bma(errors, distance, pieces)
        w = [weights[target][h] for h in HYPOTHESES]
        stats[target] = {h: _stats(e) for h, e in errors.items()}
        stats[target]["blend"] = _stats(weighed_median([errors[h] for h in HYPOTHESES], w))
        residuals = []
        for f in folds:
            blended = weighed_median([f.predictions[h][index] for h in HYPOTHESES], w)
            if index == 0:
                residuals.append(log_ratio(blended, f.q11, 1e-3 * float(np.max(np.abs(f.q11)))))
            else:
                residuals.append((blended - f.m11) / m11_scale / np.maximum(1.0 - f.distance, 1e-9))
        band[target], crossover[target] = fold_band(folds, residuals, cap)
    return weights, stats, band, cap, points, crossover


def fold_band(folds, residuals, cap: float = 1.0) -> tuple[float, float]:
    """``(kappa, crossover)`` of the band: ``kappa`` is :func:`hillchart.extension.hypotheses.band_scale` of each
    fold's blended residuals at its own distances, the largest, and ``crossover`` (at most ``cap``) the same scale
    over ``d`` (``growth = 1``) divided by ``kappa``: the band's straight start
    (:func:`hillchart.extension.band.band_envelope`). Pooled, the calibration on the far half of all distances left
    out the nearer fold: on the 137 kW rig's table without its lowest angle (the fold one angle down at d = 0.18, the
    two-angle fold's far half at 0.27-0.40) the band came out 3.5 times narrower than that fold's own and covered none
    of the 8 points held out. Each fold is a test at its own distance; the band covers what each one saw."""
    kappa = max(band_scale(r, f.distance) for f, r in zip(folds, residuals))
    slope = max(band_scale(r, f.distance, growth=1.0) for f, r in zip(folds, residuals))
    return kappa, (min(slope / kappa, cap) if kappa > 0.0 else 0.0)


def low_band(nets_q11, nets_m11, q11, m11, m11_scale: float, coverage: float = 0.90) -> tuple[float, float]:
    """``(low_q11, low_m11)``: the nets' miss at the measured points of the table's smallest angles (arrays: the nets'
    Q11 and M11 there and the measured ones), as log-ratios of Q11 and as shares of the table's M11 range
    ``m11_scale`` (N*m): split-conformal (:func:`hillchart.extension.hypotheses.band_scale` at one distance), the
    ``ceil((n + 1) (1 + coverage) / 2)``-th smallest absolute miss (the largest times ``(n + 1) / n`` with too
    few points), as each side of the band is a one-sided bound.

    Examples
    --------
    >>> [round(v, 4) for v in low_band([1.02, 0.99], [9.0, 10.0], [1.0, 1.0], [10.0, 10.0], 20.0)]
    [0.0297, 0.075]
    """
    floor = 1e-3 * float(np.max(np.abs(q11)))
    r_q = np.abs(log_ratio(np.asarray(nets_q11, float), np.asarray(q11, float), floor))
    r_m = np.abs(np.asarray(nets_m11, float) - np.asarray(m11, float)) / m11_scale
    level = 0.5 * (1.0 + coverage)  # one-sided, as each side of the band
    return tuple(band_scale(r, np.ones(r.size), coverage=level) for r in (r_q, r_m))


def table_evidence(samples: dict, model, *, hold_out=HOLD_OUT, seed: int = 0) -> TableEvidence:
    """The evidence of a table's measured unit samples (dict of n11, opening, blade_angle, q11, m11; r/min, deg, deg,
    m^3/s, N*m) for ``model`` (the bulb model fitted to all of them): the folds of ``hold_out``, weighed, the band,
    the whole table's curvature and the overspeed evidence.

    The refits keep the closed vane of ``model`` (the user's ``opening_closed`` or the one fitted to the whole
    table): refitted on fewer angles the closed vane is not determined (on the 137 kW rig's table, with its two lowest
    angles held out, the refit put it 0.3 deg below the lowest kept angle), and the simulator runs the whole table's.
    The folds then test the hypotheses given that closed vane."""
    n, a, b, q, m = _arrays(samples)
    m11_scale = float(np.ptp(m)) or 1.0
    closed = model.opening_closed
    folds = [hold_out_angles(samples, k, opening_closed=closed, seed=seed) for k in hold_out]
    weights, stats, band, cap, points, crossover = weigh_folds(folds, m11_scale)
    lines = sweeps(n, a, b)
    anchors = _anchors(model, n, a, b, q, m, lines, np.ones(n.size, bool))
    curvature = fit_curvature(model, n, a, b, q, m, anchors) if anchors else (0.0, 0.0)
    notes = [] if points else ["no held-out evidence: no guide-vane sweep keeps "
                               f"{MIN_ANGLES_LEFT} angles after a hold-out"]
    return TableEvidence(folds=[f for f in folds if f is not None], weights=weights, errors=stats, band=band,
                         points=points, m11_scale=m11_scale, distance_cap=cap, curvature=curvature, crossover=crossover,
                         overspeed=overspeed_evidence(samples, opening_closed=closed, seed=seed), notes=notes)


def overspeed_ends(n11, opening, blade) -> tuple[list, list]:
    """``(ends, settings)``: the index of the highest-N11 point of every setting (blade and guide-vane angle)
    measured at 3 or more N11, and each such setting's indices.

    Examples
    --------
    >>> overspeed_ends([90.0, 100.0, 110.0, 95.0], [40.0, 40.0, 40.0, 50.0], [0.0] * 4)[0]
    [2]
    """
    n11, opening, blade = (np.asarray(v, float).ravel() for v in (n11, opening, blade))
    key = _clusters(blade, BLADE_GAP_DEG) * (n11.size + 1) + _clusters(opening, 1e-6)
    ends, settings = [], []
    for k in np.unique(key):
        index = np.flatnonzero(key == k)
        if np.unique(np.round(n11[index], 6)).size >= 3:
            ends.append(int(index[np.argmax(n11[index])]))
            settings.append(index)
    return ends, settings


def overspeed_evidence(samples: dict, *, opening_closed: float | None = None, seed: int = 0) -> dict | None:
    """How well the table predicts itself toward overspeed, where a rejection's maximum speed comes: the highest-N11
    point of every setting (blade and guide-vane angle) measured at 3 or more N11 held out and predicted by the model
    refitted without them and by a straight continuation through the setting's two highest kept N11. Q11 errors
    relative, M11 fractions of the table's M11 range (RMS and worst). None when no setting has 3 N11 or the refit
    fails."""
    n, a, b, q, m = _arrays(samples)
    ends, settings = overspeed_ends(n, a, b)
    if not ends:
        return None
    held = np.zeros(n.size, bool)
    held[ends] = True
    try:
        model = _fit(n[~held], a[~held], b[~held], q[~held], m[~held], opening_closed, seed)
    except InputError:
        return None
    scale = float(np.ptp(m)) or 1.0
    q_line, m_line = [], []
    for end, index in zip(ends, settings):
        on = index[index != end]
        q_line.append(continuation(n[on], q[on], n[end]))
        m_line.append(continuation(n[on], m[on], n[end]))
    nh, ah, bh, qh, mh = n[ends], a[ends], b[ends], q[ends], m[ends]
    e = {"model_q11": model.q11(nh, ah, bh) / qh - 1.0, "model_m11": (model.m11(nh, ah, bh) - mh) / scale,
         "line_q11": np.array(q_line) / qh - 1.0, "line_m11": (np.array(m_line) - mh) / scale}
    out = {"held_out_points": len(ends), "n11_range": [float(nh.min()), float(nh.max())]}
    for name, err in e.items():
        out[f"{name}_rms"] = float(np.sqrt(np.mean(err ** 2)))
        out[f"{name}_worst"] = float(np.max(np.abs(err)))
    return out


#: The band's growth ``h(d)`` compiled for the simulator's kernel (one implementation:
#: :func:`hillchart.extension.band.band_envelope`).
band_envelope_compiled = numba.njit(cache=True)(band_envelope)


@dataclass(frozen=True)
class BulbExtrapolation:
    """The weighed hypotheses below the table's smallest guide-vane angle, as nets.json stores them with the fitted
    bulb model (:class:`hillchart.fccm.double_regulated.BulbSilentModel`), and an ensemble member's place in the band.

    Attributes
    ----------
    weights_q11, weights_m11 : tuple of 4 float
        Weights of :data:`HYPOTHESES` (each summing to 1).
    curvature_q11, curvature_m11 : float
        ``c`` of the quadratic hypothesis.
    band_q11, band_m11 : float
        ``kappa``: the band's half-width is ``kappa h(d)`` as a log-ratio of Q11, and ``kappa h(d) (1 - d)`` as a
        share of the table's M11 range (``m11_scale``): a member multiplies Q11 by ``exp(position kappa h)`` and
        adds ``position kappa h (1 - d) m11_scale`` to M11, so at the closed vanes (``d = 1``), where Q11 = 0 and
        M11 = -K N11^2 are known (eqs. (6) and (8) of the BP hill-chart paper), the band vanishes. In files written
        without ``m11_scale`` (0), a log-ratio of the hydraulic torque ``M11 + K N11^2`` (docs/bulb-extrapolation.md).
    distance_cap : float
        Where the band's square ends (:func:`hillchart.extension.band.band_square`); beyond it the band grows on at
        its slope there, or levels off in files written before (``beyond_cap``, :data:`BEYOND_CAP`).
    crossover_q11, crossover_m11 : float
        Where the band's straight start meets its square (:func:`hillchart.extension.band.band_envelope`); 0 (files
        written without them) for the square alone.
    low_q11, low_m11 : float
        The nets' own miss at the table's smallest angles, where every hypothesis takes its ``y_low`` (the half-width
        of :func:`low_band`, in the band's measures), added to ``kappa h``; 0 in files written without them.
    m11_scale : float
        N*m: the table's measured M11 range, the unit of the M11 band; 0 in files written before (the band a
        log-ratio of the hydraulic torque).
    combination : str
        ``"median"`` (:func:`hillchart.extension.band.weighed_median`, the band calibrated on its residuals), or
        ``"mean"``: the weighed mean, in files written before the median (the band calibrated on the mean's).
    position : float
        The member's place in the band (0: the point nets; +-1 the 5-95 % edges).
    """

    weights_q11: tuple
    weights_m11: tuple
    curvature_q11: float
    curvature_m11: float
    band_q11: float
    band_m11: float
    distance_cap: float
    position: float = 0.0
    crossover_q11: float = 0.0
    crossover_m11: float = 0.0
    low_q11: float = 0.0
    low_m11: float = 0.0
    m11_scale: float = 0.0
    combination: str = "median"
    beyond_cap: str = "grows"

    def __post_init__(self):
        for name, allowed in (("combination", COMBINATIONS), ("beyond_cap", BEYOND_CAP)):
            if getattr(self, name) not in allowed:
                raise InputError(f"silent_model.extrapolation.{name} must be one of {', '.join(allowed)}, got "
                                 f"{getattr(self, name)!r}")
        for name in ("weights_q11", "weights_m11"):
            w = np.asarray(getattr(self, name), float)
            if w.shape != (len(HYPOTHESES),) or not np.all(np.isfinite(w)) or np.any(w < 0) \
                    or abs(float(w.sum()) - 1.0) > 1e-6:
                raise InputError(f"silent_model.extrapolation.{name} must be {len(HYPOTHESES)} weights >= 0 of "
                                 f"{', '.join(HYPOTHESES)} summing to 1, got {list(np.ravel(w))!r}")
            object.__setattr__(self, name, tuple(float(v) for v in w))
        limits = {"curvature_q11": (-1.0, 1.0), "curvature_m11": (-1.0, 1.0), "band_q11": (0.0, 1e3),
                  "band_m11": (0.0, 1e3), "distance_cap": (1e-9, 1.0), "position": (-5.0, 5.0),
                  "crossover_q11": (0.0, 1.0), "crossover_m11": (0.0, 1.0), "low_q11": (0.0, 1.0),
                  "low_m11": (0.0, 1.0), "m11_scale": (0.0, 1e12)}
        for name, (lo, hi) in limits.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (lo <= value <= hi):
                raise InputError(f"silent_model.extrapolation.{name} must be a number in [{lo:g}, {hi:g}], "
                                 f"got {value!r}")

    @classmethod
    def of_evidence(cls, evidence: TableEvidence, position: float = 0.0, low=(0.0, 0.0)) -> "BulbExtrapolation":
        """From the table's evidence; ``low``: ``(low_q11, low_m11)`` (:func:`low_band`)."""
        q, m = evidence.weight_vectors()
        return cls(weights_q11=tuple(q), weights_m11=tuple(m), curvature_q11=evidence.curvature[0],
                   curvature_m11=evidence.curvature[1], band_q11=float(evidence.band["q11"]),
                   band_m11=float(evidence.band["m11"]), distance_cap=evidence.distance_cap, position=float(position),
                   crossover_q11=float(evidence.crossover["q11"]), crossover_m11=float(evidence.crossover["m11"]),
                   low_q11=float(low[0]), low_m11=float(low[1]), m11_scale=float(evidence.m11_scale))

    def packed(self) -> np.ndarray:
        """20 numbers: the Q11 and M11 weights, the curvatures, the member's band offsets ``position band_q11`` and
        ``position band_m11``, the distance cap, the Q11 and M11 crossovers, the member's offsets ``position
        low_q11`` and ``position low_m11``, ``m11_scale``, 1 for the weighed median (0: the mean), the run-out."""
        return np.array([*self.weights_q11, *self.weights_m11, self.curvature_q11, self.curvature_m11,
                         self.position * self.band_q11, self.position * self.band_m11, self.distance_cap,
                         self.crossover_q11, self.crossover_m11, self.position * self.low_q11,
                         self.position * self.low_m11, self.m11_scale, float(self.combination == "median"),
                         runout(self.beyond_cap, self.distance_cap)])

    def to_dict(self) -> dict:
        return {"hypotheses": list(HYPOTHESES), "weights_q11": list(self.weights_q11),
                "weights_m11": list(self.weights_m11), "curvature_q11": self.curvature_q11,
                "curvature_m11": self.curvature_m11, "band_q11": self.band_q11, "band_m11": self.band_m11,
                "distance_cap": self.distance_cap, "position": self.position,
                "crossover_q11": self.crossover_q11, "crossover_m11": self.crossover_m11, "low_q11": self.low_q11,
                "low_m11": self.low_m11, "m11_scale": self.m11_scale, "combination": self.combination,
                "beyond_cap": self.beyond_cap}

    @classmethod
    def from_dict(cls, doc, key: str = "silent_model.extrapolation") -> "BulbExtrapolation":
        names = {"hypotheses", "weights_q11", "weights_m11", "curvature_q11", "curvature_m11", "band_q11",
                 "band_m11", "distance_cap", "position"}
        # absent from files written before the band's straight start, its term at the smallest angles, the M11
        # band in shares of the table's range, the weighed median (those read as the mean) and the band growing on
        optional = {"crossover_q11", "crossover_m11", "low_q11", "low_m11", "m11_scale", "combination", "beyond_cap"}
        if not isinstance(doc, dict) or not names <= set(doc) <= names | optional:
            raise InputError(f"{key} must be an object with the keys {', '.join(sorted(names))} (and optionally "
                             f"{', '.join(sorted(optional))}), got {sorted(doc) if isinstance(doc, dict) else doc!r}")
        if doc["hypotheses"] != list(HYPOTHESES):
            raise InputError(f"{key}.hypotheses must be {list(HYPOTHESES)}, got {doc['hypotheses']!r}")
        try:
            return cls(**{"combination": "mean", "beyond_cap": "levels",
                          **{k: (tuple(v) if isinstance(v, list) else v) for k, v in doc.items() if k != "hypotheses"}})
        except InputError as exc:
            raise InputError(str(exc).replace("silent_model.extrapolation", key)) from None
