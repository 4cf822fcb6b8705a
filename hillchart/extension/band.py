"""The band around an answer the data do not reach: how wide each side is from held-out residuals (split-conformal,
:func:`band_scale`, :func:`band_sides`), how it grows with the distance from the data (:func:`band_square`,
:func:`band_envelope`), where each ensemble member stands in it (:func:`member_positions`), the answer it is centred
on (:func:`weighed_median` of the weighed hypotheses); and the straight continuation of a line toward runaway whose
misses are the evidence there (:func:`continuation`).

Below a Francis chart's lowest digitized line (:mod:`hillchart.extension.hypotheses`) and below a double-regulated
table's smallest guide-vane angle (:mod:`hillchart.fccm.evidence`) alike, the residuals of the weighed hypotheses at
the held-out points, divided by the squared distance below the lowest kept line (``d = 1 - t``), give the band's
widths: a band that widens with the distance from the data and is as wide as the chart's own evidence says.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba.extending import register_jitable

#: The band grows as the distance below the lowest line to this power (:func:`band_square`).
GROWTH = 2.0
#: The band is calibrated on the held-out points at least this fraction of the furthest distance tested.
FAR_FRACTION = 0.5
#: Coverage the band aims at (two-sided: the 5-95 % band; each side is a one-sided 95 % bound).
BAND_COVERAGE = 0.90
#: The narrower side of the band is at least this fraction of the wider one: a record of a few held-out lines that
#: all fell on one side does not show that the other side is impossible, only that it is less likely.
MIN_SIDE_FRACTION = 0.25
#: The same floor below the lowest line (:func:`hillchart.extension.hypotheses.weigh`), where the evidence is the
#: inner folds' two or three held-out lines, one or two line spacings below the kept lines: a record that short
#: does not fix the sign of the error further down (on the real chart of ``benchmarks/bench_extrapolation.py`` the
#: inner folds all fell below the blend, the chart's own lowest line above it), so neither side is narrower than half
#: the other. Toward runaway every line is a unit of evidence (6 to 12 of them) and :data:`MIN_SIDE_FRACTION` holds.
MIN_SIDE_FRACTION_BELOW = 0.5
#: When the chart gives no held-out evidence (too few lines for a fold) nothing shows how the error grows below the
#: lowest line, nor that it is small near it: the band grows as ``d^2`` only up to this distance (the ``cap`` of
#: :func:`band_square`) and on linearly beyond. Growing as ``d^2`` all the way it was 3.5 % of the M11 range 17 % of
#: the way to the closed cam of the real Kaplan chart of ``benchmarks/bench_kaplan_extrapolation.py`` with three
#: lines held out (two left, no fold), where the torque missed by up to 17 % (11 of 39 points covered); the real
#: charts that give folds miss by 0.5-3 times the distance near their lowest line.
NO_EVIDENCE_CAP = 0.05
#: ``kappa`` of the band without held-out evidence: 1.2 at the closed vanes (``d = 1``; ``h(1) = c (2 - c)`` with
#: ``c`` = :data:`NO_EVIDENCE_CAP`), so about 1.2 d below the lowest line: +-58 % of log Q11 at half the lowest
#: opening (-44 % to +79 %), 18 % at 0.17 (the spread of the hypotheses' errors on real charts, 10-20 % at a quarter
#: to a half of the lowest opening below it, is inside it).
NO_EVIDENCE_SCALE = 1.2 / (NO_EVIDENCE_CAP * (2.0 - NO_EVIDENCE_CAP))


def continuation(n11, values, at_n11) -> float:
    """A line's straight continuation in N11 through its two points of highest N11 (``n11``, ``values`` of one
    line, two points or more), at ``at_n11``; flat where those two share their N11. Toward runaway its misses at
    each line's held-out last point are a chart's evidence (:func:`hillchart.extension.hypotheses.overspeed_evidence`,
    :func:`hillchart.fccm.evidence.overspeed_evidence`, :func:`hillchart.fccm.on_cam.overspeed_evidence`).

    Examples
    --------
    >>> round(continuation([100.0, 120.0, 140.0], [0.5, 0.6, 0.8], 150.0), 12)
    0.9
    """
    n11, values = np.asarray(n11, float), np.asarray(values, float)
    two = np.argsort(n11)[-2:]
    x, y = n11[two], values[two]
    slope = (y[1] - y[0]) / (x[1] - x[0]) if x[1] != x[0] else 0.0
    return float(y[1] + slope * (at_n11 - x[1]))


#: How the band grows beyond the furthest distance the hold-outs tested (``cap`` of :func:`band_square`): ``"grows"``,
#: on at the slope it has there (the square's curvature is not extrapolated, its slope is); ``"levels"``, to a plateau
#: at twice that distance, as files written before read. A band that levels off claims that the error stops growing
#: where nothing was tested: on the real Kaplan chart of ``benchmarks/bench_kaplan_extrapolation.py`` with two lines
#: held out the chart tested 13 % of the way to the closed cam, the held-out line 30 % down lay 14 % of Q11 below the
#: answer, and the levelled band reached 13 % there (18 of 25 points covered, 24 growing on); on the out-of-class
#: bulb of ``benchmarks/bench_bulb_extrapolation.py`` with two angles held out 13 of 18, growing on 15.
BEYOND_CAP = ("grows", "levels")


def runout(beyond_cap: str, cap: float) -> float:
    """``runout`` of :func:`band_square` for ``beyond_cap`` (:data:`BEYOND_CAP`): infinite (growing on), or ``cap``."""
    return math.inf if beyond_cap == "grows" else float(cap)


@register_jitable
def band_square(distance, cap, runout):
    """``(h, dh/dd)``: how the band grows with the distance ``d = 1 - a / a_low`` below the lowest line: ``d^p``
    (``p`` = :data:`GROWTH`) up to ``cap``, continued C1 beyond, its slope falling linearly to 0 over ``runout``
    (a plateau at ``cap + runout``; ``runout`` infinite: the slope at ``cap`` held, :data:`BEYOND_CAP`); 0 above the
    lowest line. Scalars; the simulator's kernels compile this function (:mod:`hillchart.nets.silent_model`).

    Examples
    --------
    >>> band_square(0.2, 0.5, math.inf)[0] == 0.2 ** GROWTH, band_square(1.0, 0.5, 0.5)[1]
    (True, 0.0)
    >>> band_square(1.0, 0.5, math.inf)  # on at the slope 2 cap from cap^2
    (0.75, 1.0)
    """
    if distance <= 0.0:
        return 0.0, 0.0
    if distance <= cap:
        return distance ** GROWTH, GROWTH * distance ** (GROWTH - 1.0)
    slope = GROWTH * cap ** (GROWTH - 1.0)
    e = min(distance, cap + runout) - cap
    return cap ** GROWTH + slope * (e - e * e / (2.0 * runout)), slope * (1.0 - e / runout)


@register_jitable

def no_evidence_sides(distance_cap: float) -> str:
    """The no-evidence band's two sides at half the distance to the closed vanes, as the summaries print them
    (``distance_cap``: the band's, :data:`NO_EVIDENCE_CAP` in files written with it).

    Examples
    --------
    >>> no_evidence_sides(NO_EVIDENCE_CAP)
    '-44 % to +79 % of Q11'
    """
    half = NO_EVIDENCE_SCALE * band_square(0.5, distance_cap, math.inf)[0]
    return f"{100 * math.expm1(-half):+.0f} % to {100 * math.expm1(half):+.0f} % of Q11"

def band_envelope(distance, cap, crossover, runout):
    """``(h, dh/dd)``: :func:`band_square` with a straight start, ``crossover d`` up to ``d = crossover`` (above ``d^2``
    there, and equal to it at the crossover), then :func:`band_square`. With ``kappa`` the quadratic scale and
    ``crossover = kappa_1 / kappa`` (``kappa_1`` the scale of the same held-out residuals over ``d``,
    :func:`band_scale` with ``growth = 1``), the half-width ``kappa h`` is the larger of the two bands: an error in
    the slope below the lowest kept line grows as ``d``, one in the curvature as ``d^2``, and held-out lines at a
    few distances do not say which, so near the data, where ``d^2`` would shrink a band calibrated further down to
    nothing, the band follows the slope's error. ``crossover = 0``: :func:`band_square`. Scalars; compiled by the
    simulator's kernels (both functions are jitable where they are called from compiled code). Continuous; its slope
    steps from ``crossover`` to ``2 crossover`` at the crossover.

    Examples
    --------
    >>> band_envelope(0.05, 0.5, 0.1, math.inf)[0] == 0.1 * 0.05
    True
    >>> band_envelope(0.2, 0.5, 0.1, math.inf)[0] == band_square(0.2, 0.5, math.inf)[0]
    True
    """
    if 0.0 < distance < crossover:
        return crossover * distance, crossover
    return band_square(distance, cap, runout)


def log_ratio(predicted, actual, floor):
    """``log(predicted / actual)`` of two positive quantities, each floored at ``floor`` (a sign change counts as
    a large error, not as an undefined one)."""
    return np.log(np.maximum(predicted, floor) / np.maximum(actual, floor))


def band_scale(residuals, distance, coverage: float = BAND_COVERAGE, growth: float = GROWTH) -> float:
    """Half-width per squared distance that covers ``coverage`` of the held-out residuals: split-conformal on the
    scores ``|r| / d^2`` (the ``ceil((n + 1) coverage)``-th smallest; with too few points for that, the largest
    times ``(n + 1) / n``, so a thin record gives a wider band, never a narrower one).

    The square: every anchored hypothesis passes through the lowest line, so its error there is zero; an error in
    the slope grows as ``d``, one in the curvature as ``d^2``. The inner hold-outs reach only one or two line
    spacings below the lowest kept line, where the curvature error is still small; scaling their scores by ``d^2``
    rather than ``d`` widens the band faster with the distance, which is what the real chart shows (its lowest lines
    bend away from every hypothesis fitted above them). ``growth``: the power of ``d`` the scores are divided by (1
    for the straight start of :func:`band_envelope`).

    Examples
    --------
    >>> round(band_scale([0.01, -0.02, 0.03], [0.5, 0.5, 0.5]), 4)
    0.16
    """
    residuals = np.abs(np.asarray(residuals, float))
    distance = np.maximum(np.asarray(distance, float), 1e-9)
    # calibrated where the hold-outs reach furthest (the far half of their distances): near the lowest line the
    # residuals are reading noise, which divided by a small d^p would pass for a steep growth
    far = distance >= FAR_FRACTION * distance.max()
    score = residuals[far] / distance[far] ** growth
    n = score.size
    if n == 0:
        return NO_EVIDENCE_SCALE
    rank = math.ceil((n + 1) * coverage)
    ordered = np.sort(score)
    if rank <= n:
        return float(ordered[rank - 1])
    return float(ordered[-1] * (n + 1) / n)


def band_sides(residuals, distance, lines: int, coverage: float = BAND_COVERAGE, *, growth: float = GROWTH,
               far_fraction: float = FAR_FRACTION, shape=None,
               min_side_fraction: float = MIN_SIDE_FRACTION, folds=None) -> tuple[float, float]:
    """``(low, high)``: the band's half-widths per squared distance below and above the prediction, each a one-sided
    split-conformal bound at ``(1 + coverage) / 2`` on the signed scores ``r / d^2`` of the far half of the distances
    tested (:func:`band_scale` says why ``d^2`` and the far half). ``r`` is prediction minus truth (a log-ratio for
    Q11), so the held-out points the prediction overshot set the low side.

    The units of evidence are the held-out *lines* (the points of one line share one cause of error): with too few
    of them for the quantile (``ceil((n + 1) q) > n``), a side is its largest score times ``(lines + 1) / lines``,
    so a chart with one held-out line gets twice the width its one line showed. Neither side is narrower than
    ``min_side_fraction`` of the other (:data:`MIN_SIDE_FRACTION`; below the lowest line
    :data:`MIN_SIDE_FRACTION_BELOW`). ``folds`` (one label per residual: the hold-out it comes from): where the
    far half holds one fold only, or folds whose mean scores take both signs, the evidence has not shown on which
    side the error falls, and both sides are the wider one (an on-cam chart's band,
    :func:`hillchart.fccm.on_cam.on_cam_evidence`). ``growth`` and ``far_fraction``: the power of the distance and
    the part of the distances calibrated on (toward runaway,
    :func:`hillchart.extension.hypotheses.overspeed_evidence`: 1 and 0); ``shape``, a further factor of the band's
    growth at each point (M11 below the lowest line: ``1 - d``, the band closing at the closed vanes).

    Examples
    --------
    >>> [round(v, 4) for v in band_sides([0.02, 0.04, -0.01], [0.5, 0.5, 0.5], lines=1)]
    [0.32, 0.08]
    """
    residuals = np.asarray(residuals, float)
    distance = np.maximum(np.asarray(distance, float), 1e-9)
    far = distance >= far_fraction * distance.max()
    growth_at = distance ** growth if shape is None else distance ** growth * np.asarray(shape, float)
    score = residuals[far] / growth_at[far]
    n = score.size
    if n == 0 or lines <= 0:
        return NO_EVIDENCE_SCALE, NO_EVIDENCE_SCALE
    level = 0.5 * (1.0 + coverage)
    rank = math.ceil((n + 1) * level)
    sides = []
    for signed in (score, -score):
        ordered = np.sort(signed)
        width = float(ordered[rank - 1]) if rank <= n else float(ordered[-1]) * (lines + 1) / lines
        sides.append(max(width, 0.0))
    widest = max(sides)
    if folds is not None:
        labels = np.asarray(folds)[far]
        means = np.array([np.mean(score[labels == f]) for f in np.unique(labels)])
        if means.size < 2 or (np.any(means > 0.0) and np.any(means < 0.0)):
            min_side_fraction = 1.0
    return tuple(max(v, min_side_fraction * widest) for v in sides)


def member_positions(members: int, seed: int) -> np.ndarray:
    """Where each of ``members`` ensemble members stands in the band (standard units, +-1 the 5-95 % edges):
    evenly spaced normal quantiles ``Phi^-1((i + 1/2) / members)``, scaled so that their own 95th percentile is 1
    (the band a report reads from the members is then the band of the evidence), shuffled with ``seed`` so that a
    member's place does not follow its index (the nets of member i are trained on their own split)."""
    from scipy.stats import norm

    if members <= 0:
        return np.zeros(0)
    positions = norm.ppf((np.arange(members) + 0.5) / members)
    if members > 1:  # the members' own 5-95 % percentiles (as the report reads a band) fall on +-1
        positions = positions / np.percentile(positions, 95.0)
    return np.random.default_rng([seed, 7]).permutation(positions)


@register_jitable
def median_pick(values, weights, half):
    """Index of the hypothesis the weighed median takes among ``values`` (1-D, one per hypothesis) with ``weights``
    (>= 0) and ``half`` (half their sum): the first, in the order of the values (ties in the hypotheses' order), at
    which the weights reach ``half``. The one implementation of the rule, in Python and in the compiled kernels
    (:func:`weighed_median`, :func:`hillchart.fccm.bulb_silent_model.weighed_point`).

    Examples
    --------
    >>> int(median_pick(np.array([3.0, 1.0, 2.0]), np.array([0.2, 0.3, 0.5]), 0.5))
    2
    """
    n = values.size
    order = np.arange(n)
    for i in range(1, n):  # insertion sort of a handful of hypotheses, stable
        k = order[i]
        j = i - 1
        while j >= 0 and values[order[j]] > values[k]:
            order[j + 1] = order[j]
            j -= 1
        order[j + 1] = k
    reached = 0.0
    for i in range(n):
        reached += weights[order[i]]
        if reached >= half:
            return order[i]
    return order[n - 1]


@numba.njit(cache=True)
def _median_picks(flat, weights, half):
    picks = np.empty(flat.shape[1], np.int64)
    column = np.empty(flat.shape[0])
    for p in range(flat.shape[1]):
        for h in range(flat.shape[0]):
            column[h] = flat[h, p]
        picks[p] = median_pick(column, weights, half)
    return picks


def weighed_median(values, weights, *, index: bool = False):
    """The weighed median of the hypotheses' ``values`` (a sequence of arrays of one shape, or numbers) with
    ``weights`` (one per hypothesis, >= 0, not all 0): at each point the value of the hypothesis at which the weights,
    taken in the order of the values, first reach half their sum. With ``index``, that hypothesis' position in
    ``values`` instead (ints of the values' shape): the median is one hypothesis at every point, and a guarantee
    report names the one that decided a figure.

    The weighed hypotheses answer by it rather than by their weighed mean: with the evidence of one or two held-out
    lines the weights stay spread (pseudo-BMA), and a minority of hypotheses that diverge below the data pulled the
    mean to where none of them stands. On the out-of-class synthetic family's worst chart (sparse, 4 lines) the model
    and its anchored form (weights 0.34 and 0.32) were within 2.5 % of the exact Q11 at half the lowest opening, the
    quadratic (0.24) 18 % above: the mean was 6.7 % above, and the max head rise of a load rejection 3.7 points under
    the exact turbine's; the median follows the model (docs/guarantee-benchmark.md, step 12). Continuous where the
    hypotheses cross (they are equal there). A Francis chart's hypotheses answer by it
    (:meth:`hillchart.extension.hypotheses.Evidence.blend`), and a double-regulated table's four, in the compiled
    kernel (:func:`hillchart.fccm.bulb_silent_model.weighed_point`); both take :func:`median_pick`.

    Examples
    --------
    >>> float(weighed_median([1.0, 2.0, 10.0], [0.35, 0.35, 0.3]))
    2.0
    >>> weighed_median([[1.0, 5.0], [2.0, 0.0]], [0.6, 0.4]).tolist()
    [1.0, 5.0]
    >>> weighed_median([[1.0, 5.0], [2.0, 0.0], [3.0, 1.0]], [0.3, 0.3, 0.4], index=True).tolist()
    [1, 2]
    """
    stacked = np.array(np.broadcast_arrays(*[np.asarray(v, float) for v in values]))
    w = np.asarray(weights, float)
    flat = np.ascontiguousarray(stacked.reshape(len(w), -1))
    pick = _median_picks(flat, w, 0.5 * float(w.sum()))
    if index:
        return pick.reshape(stacked.shape[1:])
    return flat[pick, np.arange(flat.shape[1])].reshape(stacked.shape[1:])
