"""Plausibility checks of a digitized chart before training, and of the trained nets.

What a digitizer typically gets wrong, each reported as an :class:`~hillchart.errors.InputError` that names the file,
the row (line number in the file) and what looks wrong:

* every flow point at one N11 (no speed range to train on);
* Q11 that looks like l/s in a chart declared m^3/s (or the reverse), efficiency that looks like percent in a chart
  declared fraction (the loader's range check) or like a fraction in a chart declared percent;
* opening lines that cross (a larger opening must pass more flow at the same N11);
* an interior point far off its opening line (an outlier or a zigzag: a misclick), judged against a quadratic
  through the line's other points, beyond 4 % of the chart's Q11 range or 4 robust standard deviations of the
  chart's own scatter about those quadratics where that is wider (a chart read from a poor copy: a warning);
* efficiency contours outside the flow lines' N11-Q11 hull (contours digitized on another chart or in other units).

:func:`efficiency_plausibility` checks the trained nets: efficiency above the best digitized contour inside the
digitized region means the flow and torque nets disagree.
"""

from __future__ import annotations

import warnings

import numpy as np

from hillchart.errors import InputError

#: Q11 of Francis model runners, m^3/s: a chart declared in m^3/s with Q11 above this is in l/s.
Q11_MAX_PLAUSIBLE_M3_S = 5.0
#: A point further than this fraction of the chart's Q11 range from the quadratic through its line's other points
#: is an outlier (digitization noise is about 0.5 % of the range; a misclick several %). The range is that of the
#: lines' and the contours' Q11, the printed axis a misclick is a share of: a chart of a few lines near full load
#: with its contours keeps the whole chart's scale (:func:`q11_range`).
OUTLIER_FRACTION = 0.04
#: A point is a misclick only beyond this many robust standard deviations of the chart's own scatter about the
#: leave-one-out quadratics, where that is wider than :data:`OUTLIER_FRACTION`: a chart read from a poor copy (1 %
#: of the axes' full scale, about 2-3 % of the Q11 range about the quadratics) has honest points 7-9 % off, and its
#: nets still read the exact turbine within 0.41 % (Q11) and 0.52 % (M11) of the range (measured on the slow and the
#: fast synthetic turbine, 12 points a line). The largest of such a chart's misses is 2.4-3.2 of them. A chart
#: that scatters by less than 1 % of the range keeps the bound of 4 %.
OUTLIER_SCATTER = 4.0
#: Fewer leave-one-out misses than this give no estimate of the chart's scatter (the bound stays at
#: :data:`OUTLIER_FRACTION`).
OUTLIER_MIN_MISSES = 15
#: Opening lines "cross" when the larger opening has less flow by more than this fraction of the Q11 range.
CROSSING_FRACTION = 0.02
#: Contour points may lie this far (fraction of each axis span) outside the hull of the flow points.
HULL_MARGIN_FRACTION = 0.10
#: More than this share of the contour points outside the lines' region (and of the line points outside the
#: contours') means contours from another chart or in other units; contours beyond the lines of a chart whose lines
#: lie among its contours are a warning.
OUTSIDE_SHARE = 0.25
#: A chart whose largest opening line lies below this share of ``opening_max`` (the full stroke) is warned about: its
#: openings look like fractions written for percent, or another unit (the shipped and the real charts' largest lines
#: are 100 %; a chart of its lower lines alone is rare, and a run near full load would read the nets far above them).
LOW_TOP_LINE_SHARE = 0.25
#: Nets' efficiency may exceed the best digitized contour by this much inside the digitized region.
EFFICIENCY_MARGIN = 0.01
#: A chart with fewer opening lines, flow points or contour levels than these is thin: it trains, with warnings.
THIN_OPENING_LINES = 6
THIN_FLOW_POINTS = 30
THIN_CONTOUR_LEVELS = 5


def _row(chart, name: str, index: int) -> str:
    rows = getattr(chart, "rows", None) or {}
    numbers = rows.get(name)
    return f"row {int(numbers[index])}" if numbers is not None and len(numbers) > index else f"point {index + 1}"


def q11_range(chart) -> float:
    """m^3/s: the range of the Q11 of ``chart``'s opening lines and efficiency contours, the scale of a misclick
    (:data:`OUTLIER_FRACTION`, :data:`CROSSING_FRACTION`). The runaway curve is left out: it runs on to openings
    below the lowest line, where a chart's axis need not reach.

    Examples
    --------
    >>> from data_synthetic import FRANCIS_DIR
    >>> from hillchart.io.samples import load_chart
    >>> round(q11_range(load_chart(FRANCIS_DIR)), 4)
    0.299
    """
    return float(np.ptp(np.concatenate([chart.flow_q11, chart.eff_q11])))


def outlier_bound(misses) -> tuple[float, float]:
    """The bound on a point's leave-one-out miss (a fraction of the chart's Q11 range) and the chart's scatter
    (the robust standard deviation of ``misses``, fractions of the range; 0 when there are too few to estimate it):
    :data:`OUTLIER_FRACTION`, or :data:`OUTLIER_SCATTER` times the scatter where that is wider.

    Examples
    --------
    >>> outlier_bound([0.005] * 20)[0] == OUTLIER_FRACTION  # a careful chart: scatter 0.74 % of the range
    True
    >>> [round(v, 4) for v in outlier_bound([0.02] * 20)]  # a poor copy's: 3 % of the range
    [0.1186, 0.0297]
    """
    misses = np.abs(np.asarray(misses, float))
    if misses.size < OUTLIER_MIN_MISSES:
        return OUTLIER_FRACTION, 0.0
    scatter = 1.4826 * float(np.median(misses))  # the normal's standard deviation from the median absolute value
    return max(OUTLIER_FRACTION, OUTLIER_SCATTER * scatter), scatter


def check_units(chart) -> None:
    """Units that look wrong: l/s in m^3/s, fraction in percent (the reverse cases are range errors of the loader)."""
    info, folder = chart.info, chart.folder
    q_raw = chart.flow_q11 / (1e-3 if info.q11_unit == "l/s" else 1.0)
    if info.q11_unit == "m3/s" and np.max(chart.flow_q11) > Q11_MAX_PLAUSIBLE_M3_S:
        raise InputError(f"{folder / 'flow.csv'}: Q11 up to {np.max(q_raw):.4g} looks like l/s, but chart.toml "
                         f"declares q11_unit = 'm3/s' (model-runner Q11 is below {Q11_MAX_PLAUSIBLE_M3_S} m^3/s); "
                         "set q11_unit = \"l/s\"")
    if info.q11_unit == "l/s" and np.max(q_raw) < Q11_MAX_PLAUSIBLE_M3_S:
        raise InputError(f"{folder / 'flow.csv'}: Q11 up to {np.max(q_raw):.4g} looks like m^3/s, but chart.toml "
                         "declares q11_unit = 'l/s'; set q11_unit = \"m3/s\"")
    if info.efficiency_unit == "percent" and np.max(chart.eff_efficiency) * 100.0 <= 1.0:
        raise InputError(f"{folder / 'efficiency.csv'}: efficiency values up to "
                         f"{np.max(chart.eff_efficiency) * 100:.4g} look like fractions, but chart.toml declares "
                         "efficiency_unit = 'percent'; set efficiency_unit = \"fraction\"")
    top = float(np.max(chart.flow_opening))
    if top < LOW_TOP_LINE_SHARE * info.opening_max:
        unit, share = info.opening_unit, 100 * top / info.opening_max
        warnings.warn(
            f"{folder / 'flow.csv'}: the largest opening line is a = {top:g} {unit}, {share:.2g} "
            f"% of chart.toml's opening_max = {info.opening_max:g} {unit} (the opening at full stroke): a run near "
            "full load reads the nets far above every digitized line. If the openings are fractions of the full "
            f"opening or in another unit, write them in {unit}; if opening_max is in another unit than the lines, "
            "correct it", UserWarning, stacklevel=3)


def check_lines(chart) -> None:
    """Speed range, outliers/zigzags on each opening line, crossing lines."""
    path = chart.folder / "flow.csv"
    if np.ptp(chart.flow_n11) <= 0:
        raise InputError(f"{path}: every point sits at N11 = {float(chart.flow_n11[0])!r} r/min; the nets need the "
                         "opening lines over a range of N11 (digitize several points along each line)")
    if np.ptp(chart.flow_q11) <= 0:
        raise InputError(f"{path}: every point has Q11 = {float(chart.flow_q11[0])!r}; the lines need a range of flow")
    q_range = q11_range(chart)
    lines, misses = {}, []  # misses: (|miss| m^3/s, opening, N11, Q11, index of the point)
    for a in chart.openings:
        idx = np.flatnonzero(chart.flow_opening == a)
        idx = idx[np.argsort(chart.flow_n11[idx], kind="stable")]
        n, q = chart.flow_n11[idx], chart.flow_q11[idx]
        if np.unique(n).size < 2:
            raise InputError(f"{path}: the opening line a = {a:g} has all its points at N11 = {float(n[0])!r} "
                             f"({_row(chart, 'flow', int(idx[0]))}); a line needs a range of N11")
        if n.size >= 5:
            # leave-one-out quadratic: a misclicked point stands out against the others. End points are not judged:
            # extrapolating 4 unevenly spaced points misses by 10 % of the range on clean family charts (measured),
            # so no bound there separates misclicks from honest points.
            for j in range(1, n.size - 1):
                keep = np.arange(n.size) != j
                if np.unique(n[keep]).size >= 3:
                    miss = abs(float(np.polyval(np.polyfit(n[keep], q[keep], 2), n[j])) - q[j])
                    misses.append((miss, float(a), float(n[j]), float(q[j]), int(idx[j])))
        lines[float(a)] = (n, q, idx)
    allowed, scatter = outlier_bound(np.array([m[0] for m in misses]) / q_range)
    widen = allowed / OUTLIER_FRACTION  # the chart's own scatter widens both bounds alike
    scattered = []  # what a careful chart's bounds refuse and this chart's scatter explains
    miss, a, n_j, q_j, i = max(misses) if misses else (0.0, 0.0, 0.0, 0.0, 0)
    where = (f"{_row(chart, 'flow', i)} (opening {a:g}, N11 {n_j:g}, Q11 {q_j:.4g} m^3/s) is {miss:.3g} m^3/s "
             f"({100 * miss / q_range:.1f} % of the Q11 range) off the smooth curve through the line's other points")
    if miss > allowed * q_range:
        raise InputError(f"{path}: {where} (allowed {100 * allowed:.3g} %): an outlier or a zigzag; check the "
                         "digitized point")
    if miss > OUTLIER_FRACTION * q_range:
        scattered.append(where)
    openings, crossings = sorted(lines), []
    for low, high in zip(openings[:-1], openings[1:]):
        n_lo, q_lo, _ = lines[low]
        n_hi, q_hi, idx_hi = lines[high]
        inside = (n_hi >= n_lo[0]) & (n_hi <= n_lo[-1])
        if not inside.any():
            continue
        gap = q_hi[inside] - np.interp(n_hi[inside], n_lo, q_lo)
        worst = int(np.argmin(gap))
        cross = (f"the opening lines a = {low:g} and a = {high:g} cross: at N11 {n_hi[inside][worst]:g} "
                 f"({_row(chart, 'flow', int(idx_hi[inside][worst]))}) the larger opening has {-gap[worst]:.3g} "
                 f"m^3/s less flow ({-100 * gap[worst] / q_range:.1f} % of the Q11 range)")
        if gap[worst] < -CROSSING_FRACTION * widen * q_range:
            raise InputError(f"{path}: {cross} (allowed {100 * CROSSING_FRACTION * widen:.3g} %); check the "
                             "openings of these lines")
        if gap[worst] < -CROSSING_FRACTION * q_range:
            crossings.append((float(gap[worst]), cross))
    if crossings:  # the deepest, and how many pairs cross
        others = f" (and {len(crossings) - 1} more pairs of lines less deeply)" if len(crossings) > 1 else ""
        scattered.append(min(crossings)[1] + others)
    if scattered:
        warnings.warn(
            f"{path}: the chart's points scatter by {100 * scatter:.2g} % of the Q11 range about smooth curves "
            f"through their neighbours (robust standard deviation; a careful chart's by "
            f"{100 * OUTLIER_FRACTION / OUTLIER_SCATTER:.2g} % or less), so a misclick is looked for beyond "
            f"{100 * allowed:.3g} % off a line and {100 * CROSSING_FRACTION * widen:.3g} % across the next "
            f"({100 * OUTLIER_FRACTION:g} and {100 * CROSSING_FRACTION:g} % on a careful chart), and this is taken "
            f"for scatter: {'; '.join(scattered)}. The nets smooth the scatter; digitize the chart from a larger or "
            "sharper copy for a closer fit", UserWarning, stacklevel=3)


def _outside(points: np.ndarray, region: np.ndarray) -> np.ndarray:
    """True for each N11-Q11 point of ``points`` outside the hull of ``region``'s, grown by
    :data:`HULL_MARGIN_FRACTION` of each axis span (its bounding box where the hull is degenerate)."""
    from scipy.spatial import Delaunay, QhullError

    span = np.ptp(region, axis=0)
    lo = region.min(axis=0) - HULL_MARGIN_FRACTION * span
    hi = region.max(axis=0) + HULL_MARGIN_FRACTION * span
    outside = np.any((points < lo) | (points > hi), axis=1)
    try:  # inside the bounding box but outside the hull, grown by the margin about its centre
        centre = region.mean(axis=0)
        hull = Delaunay(centre + (region - centre) * (1.0 + 2.0 * HULL_MARGIN_FRACTION))
        outside |= hull.find_simplex(points) < 0
    except QhullError:
        pass  # a degenerate hull (points on one line): the bounding box alone
    return outside


def check_contours(chart) -> None:
    """Efficiency points far outside the N11-Q11 hull of the flow points: an error when the lines do not lie among
    the contours either (contours from another chart or in other units), a warning when they do (a chart whose
    lines were digitized over part of it: the contours beyond them shape the efficiency surface, and the nets there
    are extrapolated)."""
    flow = np.column_stack([chart.flow_n11, chart.flow_q11])
    eff = np.column_stack([chart.eff_n11, chart.eff_q11])
    outside = _outside(eff, flow)
    if outside.mean() <= OUTSIDE_SHARE:
        return
    j = int(np.flatnonzero(outside)[0])
    where = (f"{int(outside.sum())} of {outside.size} contour points lie outside the N11-Q11 region of the opening "
             f"lines (first: {_row(chart, 'eff', j)}, N11 {eff[j, 0]:g}, Q11 {eff[j, 1]:.4g} m^3/s; lines cover "
             f"N11 {flow[:, 0].min():g}-{flow[:, 0].max():g}, Q11 {flow[:, 1].min():.4g}-{flow[:, 1].max():.4g} "
             "m^3/s)")
    lines_outside = _outside(flow, eff)
    if lines_outside.mean() > OUTSIDE_SHARE:
        raise InputError(f"{chart.folder / 'efficiency.csv'}: {where}, and {int(lines_outside.sum())} of "
                         f"{lines_outside.size} line points outside the contours': contours from another chart or in "
                         "other units?")
    warnings.warn(f"{chart.folder / 'efficiency.csv'}: {where}; the lines lie among the contours, so they cover "
                  "part of the chart, and the nets beyond them are extrapolated (below the lowest line by the "
                  "extension's weighed hypotheses, with their band). Digitize the opening lines where the contours "
                  "are for nets that read the chart there", UserWarning, stacklevel=3)


def check_chart(chart) -> None:
    """All chart checks (units, lines, contours); raises the first InputError found.

    Examples
    --------
    >>> from data_synthetic import FRANCIS_DIR
    >>> from hillchart.io.samples import load_chart
    >>> check_chart(load_chart(FRANCIS_DIR)) is None
    True
    """
    check_units(chart)
    check_lines(chart)
    check_contours(chart)


def thin_chart_notes(chart) -> list[str]:
    """What a sparse chart lacks, one note each with what to digitize (empty for a chart that is not thin).

    A thin chart is consistent but leaves the nets more to interpolate: fewer than :data:`THIN_OPENING_LINES`
    opening lines, :data:`THIN_FLOW_POINTS` flow points or :data:`THIN_CONTOUR_LEVELS` efficiency contours.

    Examples
    --------
    >>> from data_synthetic import FRANCIS_DIR
    >>> from hillchart.io.samples import load_chart
    >>> thin_chart_notes(load_chart(FRANCIS_DIR))
    []
    """
    notes = []
    lines, points = int(np.asarray(chart.openings).size), int(np.asarray(chart.flow_n11).size)
    levels = int(np.unique(chart.eff_efficiency).size)
    if lines < THIN_OPENING_LINES:
        notes.append(f"{lines} opening lines (digitize {THIN_OPENING_LINES} or more, the smallest opening drawn "
                     "included: between lines the nets interpolate)")
    if points < THIN_FLOW_POINTS:
        notes.append(f"{points} points on the opening lines (digitize {THIN_FLOW_POINTS} or more, each line to its "
                     "ends)")
    if levels < THIN_CONTOUR_LEVELS:
        notes.append(f"{levels} efficiency contours (digitize {THIN_CONTOUR_LEVELS} or more, the best one included: "
                     "the torque comes from them)")
    return notes


def efficiency_plausibility(nets, chart, *, margin: float = EFFICIENCY_MARGIN) -> str | None:
    """A message when the nets' efficiency contradicts the chart inside its digitized region, else None.

    Two things are judged (the flow and torque nets then disagree: usually a poor boundary extension, or a unit
    error in the chart):

    * an efficiency above 1 anywhere inside the digitized region (impossible);
    * at the contour points, where the contours say what the efficiency is: the nets' efficiency there (at the
      opening where their Q11 is the point's) above the contour's level by more than ``margin`` in the median, a
      systematic excess; single points at a contour's sparse, noisy edge do not decide.

    The best contour is no bound: the best point lies inside the innermost contour, a contour spacing or so above
    it (a clean chart with 8 lines and contours up to 0.920 has its nets' best point at 0.932).
    """
    from hillchart.characteristics import efficiency_from_characteristics
    from hillchart.io.samples import measured_region_mask

    n11, opening = np.meshgrid(np.linspace(chart.flow_n11.min(), chart.flow_n11.max(), 60),
                               np.linspace(chart.flow_opening.min(), chart.flow_opening.max(), 60))
    inside = measured_region_mask(chart.flow_n11, chart.flow_opening, n11, opening)
    n, a = n11[inside], opening[inside]
    eta = np.asarray(efficiency_from_characteristics(nets, n, a), float)
    if not np.isfinite(eta).any():
        return None
    best = int(np.nanargmax(eta))
    if eta[best] > 1.0:
        return (f"the nets' efficiency reaches {eta[best]:.3f} inside the digitized region (at N11 {n[best]:.4g} "
                f"r/min, opening {a[best]:.4g} {chart.info.opening_unit}): above 1, the flow and torque nets disagree "
                "there; check the extended samples (hillsim extend --plot) and the chart's units")
    excess = _contour_excess(nets, chart)
    if excess.size == 0 or float(np.median(excess)) <= margin:
        return None
    return (f"the nets' efficiency lies {float(np.median(excess)):.3f} above the chart's contours in the median of "
            f"the {excess.size} contour points inside the digitized region (allowed + {margin}): the flow and torque "
            "nets disagree there; check the extended samples (hillsim extend --plot) and the chart's units")


def _contour_excess(nets, chart) -> np.ndarray:
    """The nets' efficiency minus the contour's level at each contour point inside the digitized region, at the
    opening where the nets' Q11 equals the point's (Q11 rises with the opening at a given N11)."""
    from hillchart.characteristics import efficiency_from_characteristics
    from hillchart.io.samples import measured_region_mask

    grid = np.linspace(chart.flow_opening.min(), chart.flow_opening.max(), 81)
    q_grid = np.asarray(nets.q11(chart.eff_n11[:, None], grid[None, :]), float)
    points, openings = [], []
    for k in range(chart.eff_n11.size):
        q = q_grid[k]
        if np.all(np.diff(q) > 0) and q[0] <= chart.eff_q11[k] <= q[-1]:
            points.append(k)
            openings.append(float(np.interp(chart.eff_q11[k], q, grid)))
    if not points:
        return np.array([])
    inside = measured_region_mask(chart.flow_n11, chart.flow_opening, chart.eff_n11[points], np.array(openings))
    out = []
    for k, a in zip(np.array(points)[inside], np.array(openings)[inside]):
        eta = float(efficiency_from_characteristics(nets, chart.eff_n11[k], a))
        out.append(eta - float(chart.eff_efficiency[k]))
    return np.array(out)
