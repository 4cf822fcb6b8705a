"""Where a chart is silent and a load rejection runs: the (N11, opening) points the fitted physical model samples
below the lowest digitized line, toward runaway and between the lines (:func:`silent_region_points`,
:func:`between_line_points`), and, where the model gives no runaway speed beyond a line, the line's straight
continuation and the warning that says so (:func:`continued_line_points`, :func:`runaway_warning`).
:func:`hillchart.extension.extend.extend_samples` turns them into samples.
"""

from __future__ import annotations

import numpy as np

from hillchart.io.samples import ChartSamples

#: Openings of the small-opening samples, fractions of the lowest digitized opening line: only where the nets are
#: read, above :data:`hillchart.nets.silent_model.BLEND_START_FRACTION` (0.5) of it. Below, the extrapolation table
#: answers alone; samples there (0.1, 0.25, 0.45) only bent the nets' fit: out of class the band covered 84 % with
#: them, 90 % without them and with the hidden sizes from 5 (docs/guarantee-benchmark.md, step 11).
SMALL_OPENING_FRACTIONS = (0.7,)
#: N11 values per small opening (0 to the largest sampled N11) and per line between its end and runaway.
SMALL_OPENING_SPEEDS = 12
OVERSPEED_POINTS = 3
#: N11 values of the samples midway between two adjacent lines over their measured speeds (:func:`between_line_points`).
BETWEEN_LINE_SPEEDS = 6


def silent_region_points(chart: ChartSamples, model) -> list[tuple[float, float]]:
    """(N11 r/min, opening) points where the chart is silent and a load rejection runs.

    * small openings: :data:`SMALL_OPENING_FRACTIONS` of the lowest digitized opening, at
      :data:`SMALL_OPENING_SPEEDS` N11 values from 0 to the largest sampled N11 (the zero-opening samples' range),
      kept below the model's valid range (the pumping limit);
    * overspeed: per digitized opening line, :data:`OVERSPEED_POINTS` N11 values evenly inside the gap between the
      line's last point and the model's runaway speed at that opening.
    """
    n11_top = max(chart.flow_n11.max(), chart.runaway_n11.max() if chart.has_runaway else 0.0)
    n11_top = min(n11_top, 0.95 * model.n11_limit)
    a_low = float(np.min(chart.openings))
    points = [(float(n), f * a_low) for f in SMALL_OPENING_FRACTIONS
              for n in np.linspace(0.0, n11_top, SMALL_OPENING_SPEEDS)]
    for a in chart.openings:
        points += _toward_runaway(model, float(a), float(chart.flow_n11[chart.flow_opening == a].max()))
    return points


#: Gaps (fractions of the held-out line ends' gap cap) at which :func:`continued_line_points` continues a line.
CONTINUED_FRACTIONS = (0.5, 1.0)


def continued_line_points(chart: ChartSamples, torque, extrapolation) -> list[tuple[float, float, float, float]]:
    """``(N11, opening, Q11, M11)`` samples continuing each line the fitted model gives no runaway speed beyond
    (``extrapolation.bare``, :func:`lines_without_runaway`) straight through its two last points
    (:func:`hillchart.extension.band.continuation`), at :data:`CONTINUED_FRACTIONS` of the gap the chart's held-out
    line ends tested twice over (``gap_cap`` of :func:`hillchart.extension.hypotheses.overspeed_evidence`). On the
    real FR300T pump-turbine's chart (``benchmarks/bench_model_test_chart.py``) a continuation predicts each line's
    held-out last point within 0.8 % of the M11 range where the model misses by more than half of it; the members'
    torque there stands in the continuations' band (``Extrapolation.overspeed_widths``). Beyond the gap cap the nets
    extrapolate alone, and :func:`runaway_warning` says so."""
    from hillchart.extension.band import continuation

    over = extrapolation.overspeed if extrapolation is not None else None
    if not over or not extrapolation.bare:
        return []
    points, torque = [], np.asarray(torque, float)
    for a in extrapolation.bare:  # every line has MIN_POINTS_PER_LINE points or more (hillchart.io.samples)
        on = chart.flow_opening == a
        n_line, last = chart.flow_n11[on], float(chart.flow_n11[on].max())
        for f in CONTINUED_FRACTIONS:
            n = last * (1.0 + f * over["gap_cap"])
            points.append((n, float(a), continuation(n_line, chart.flow_q11[on], n),
                           continuation(n_line, torque[on], n)))
    return points


def lines_without_runaway(chart: ChartSamples, model) -> list[float]:
    """Openings (chart units) of the lines beyond whose last point the fitted model gives no runaway speed, for a
    chart without runaway curve (:func:`runaway_warning`); none with the curve or without a model."""
    if chart.has_runaway or model is None:
        return []
    short = []
    for a in chart.openings:
        n_run, last = model.runaway_n11(float(a)), float(chart.flow_n11[chart.flow_opening == a].max())
        if not (np.isfinite(n_run) and n_run > last):
            short.append(float(a))
    return short


def openings_text(openings, most: int = 8) -> str:
    """The first ``most`` of ``openings`` as a warning or a report lists them.

    Examples
    --------
    >>> openings_text([4.0, 6.0, 8.5], most=2)
    '4, 6, ...'
    """
    return ", ".join(f"{a:g}" for a in openings[:most]) + (", ..." if len(openings) > most else "")


def runaway_warning(chart: ChartSamples, model, short: list | None = None) -> str | None:
    """The warning for a chart without runaway curve whose fitted model gives no runaway speed beyond the last point
    of some of its lines (None when it gives one beyond every line, or the chart has its runaway curve).

    Between such a line's end and runaway the model gives no sample (:func:`_toward_runaway`); the line's straight
    continuation answers a short way (:func:`continued_line_points`), beyond it the nets alone, where a load
    rejection's maximum speed is decided. The model's valid range can end at the chart's edge: a pump-turbine's lines
    turn toward the S-shaped zone, outside the 1-D Francis model's class; on the real FR300T pump-turbine
    (``benchmarks/bench_model_test_chart.py``) it fits the chart within 1 % and ends at its largest N11, 84 r/min,
    and the nets read the full-opening torque 870 N*m at the measured runaway, 133 r/min. ``short``:
    :func:`lines_without_runaway`, when known.
    """
    short = lines_without_runaway(chart, model) if short is None else short
    if not short:
        return None
    from hillchart.extension.turbine_model import RUNAWAY_SEARCH_N11

    why = (f"its valid range ends at N11 = {model.n11_limit:.4g} r/min, and the chart reaches "
           f"{float(chart.flow_n11.max()):.4g}" if model.n11_limit < RUNAWAY_SEARCH_N11
           else f"its torque does not fall to zero up to N11 = {RUNAWAY_SEARCH_N11:g} r/min")
    return (f"toward runaway the fitted turbine model gives no runaway speed beyond the last point of {len(short)} "
            f"of the {len(chart.openings)} opening lines (a = {openings_text(short)} {chart.info.opening_unit}): "
            f"{why}. "
            "Beyond a short straight continuation of those lines, up to runaway, where a load rejection's maximum "
            "speed comes, only the nets' own extrapolation answers; give the runaway curve (runaway.csv: opening, "
            "n11, q11 of the model test's runaway points), or check the chart with hillsim extend --plot")


def _toward_runaway(model, a: float, n_end: float) -> list[tuple[float, float]]:
    """:data:`OVERSPEED_POINTS` (N11, ``a``) points evenly inside the gap between ``n_end`` and the model's runaway
    speed at opening ``a``; none where the model gives no runaway speed beyond ``n_end``."""
    n_run = model.runaway_n11(a)
    if not (np.isfinite(n_run) and n_run > n_end):
        return []
    return [(float(n), a) for n in np.linspace(n_end, n_run, OVERSPEED_POINTS + 2)[1:-1]]


def between_line_points(chart: ChartSamples, model) -> list[tuple[float, float]]:
    """(N11 r/min, opening) points midway between each two adjacent digitized opening lines, where the chart is
    silent too: :data:`BETWEEN_LINE_SPEEDS` N11 values from the later of the two lines' first points to the later of
    their last points, then :data:`OVERSPEED_POINTS` evenly inside the gap up to the model's runaway speed at the
    midway opening.

    Why: a load rejection's speed rise builds while the closure crosses the gaps between the lines, beyond their last
    points toward runaway. Without samples there the nets are free between the lines: on a sparse chart of a turbine
    outside the model's class (4 lines; docs/guarantee-benchmark.md, step 13) they lay 1.0-1.2 % of the M11 range
    under its torque along a 14 s closure where the fitted model was within 0.5 %, and the speed rise came out 1.3
    points low. The samples carry the model's shape between the lines and the residual the lines measure
    (:func:`hillchart.extension.residual.continued_residual`), so they agree with the measured points beside them.

    Examples
    --------
    >>> from data_synthetic import FRANCIS_DIR
    >>> from hillchart.extension.extend import extend_samples
    >>> from hillchart.io.samples import load_chart
    >>> chart = load_chart(FRANCIS_DIR)
    >>> points = between_line_points(chart, extend_samples(chart).boundary_model)
    >>> len(points) == (np.unique(chart.flow_opening).size - 1) * (BETWEEN_LINE_SPEEDS + OVERSPEED_POINTS)
    True
    """
    lines = np.unique(chart.flow_opening)
    points = []
    for low, high in zip(lines[:-1], lines[1:]):
        a = 0.5 * float(low + high)
        n_low, n_high = chart.flow_n11[chart.flow_opening == low], chart.flow_n11[chart.flow_opening == high]
        first, last = max(n_low.min(), n_high.min()), max(n_low.max(), n_high.max())
        points += [(float(n), a) for n in np.linspace(first, last, BETWEEN_LINE_SPEEDS)]
        points += _toward_runaway(model, a, float(last))
    return points
