"""The figures of a unit whose characteristics cover all four quadrants (a pump-turbine, a pump): how far it turned
and flowed against its initial direction, when the flow first reversed, and when a runaway reached its first speed
peak.

"Reverse" is against the direction of the initial operating point, so the same figures serve a turbine that runs
away into the S-zone (n0 > 0, Q0 > 0: reverse flow is Q < 0, reverse speed n < 0) and a pump that trips (n0 < 0,
Q0 < 0 in the turbine-positive convention: reverse flow is Q > 0 and reverse rotation n > 0, the turbine direction).

The driver adds them to a run's summary and component figures for every unit whose kind declares that it can
reverse (:attr:`simulate.components.turbine.kinds.CharacteristicKind.four_quadrant`); other kinds give none.
"""

from __future__ import annotations

import numpy as np

#: Figures of :func:`reversal_figures`, with their units (the summary's keys).
REVERSAL_FIGURES = {"max_reverse_speed_rpm": "r/min", "max_reverse_speed_pct": "% of rated speed",
                    "max_reverse_flow_m3_s": "m^3/s", "t_flow_reversal_s": "s", "t_runaway_s": "s"}
#: A speed peak counts as the runaway's when the speed magnitude rose to it by at least this fraction of the rated
#: speed from its lowest value before (the steady state's round-off wiggles are ~1e-12 of it).
PEAK_PROMINENCE = 0.01
#: The guide vanes count as held (the unit runs away instead of being closed) while the stroke stays within this of
#: its initial value (fraction of full stroke; a closing governor moves it by percent within a second).
HELD_STROKE = 1e-6


def _direction(value: float) -> float:
    return -1.0 if value < 0 else 1.0


def reversal_figures(time_s, speed_rpm, flow_m3_s, stroke, rated_speed_rpm: float) -> dict:
    """The four-quadrant figures of one unit's series (arrays of one length; speed r/min and flow m^3/s in the
    turbine-positive convention, stroke as a fraction of full stroke).

    Returns
    -------
    dict
        ``max_reverse_speed_rpm`` the largest speed against the initial rotation (r/min, >= 0; 0 when the unit
        never turned backwards) and ``max_reverse_speed_pct`` the same in % of ``rated_speed_rpm``;
        ``max_reverse_flow_m3_s`` the largest flow against the initial flow (m^3/s, >= 0); ``t_flow_reversal_s``
        the first time the flow crossed zero against its initial direction, interpolated linearly between the two
        samples around the crossing (None when it never did); ``t_runaway_s`` the time of the first peak of the
        speed magnitude that rose at least :data:`PEAK_PROMINENCE` n_r above its lowest value before, when the guide
        vanes were held there (stroke within :data:`HELD_STROKE` of its initial value: the unit runs away; None
        otherwise, e.g. when the governor closes the vanes).

    Examples
    --------
    >>> t = np.arange(6.0)
    >>> f = reversal_figures(t, np.array([100., 120., 130., 125., 120., -5.]), np.array([10., 5., -2., -4., 1., 2.]),
    ...                      np.full(6, 0.7), 100.0)
    >>> f["max_reverse_speed_rpm"], f["max_reverse_speed_pct"], f["max_reverse_flow_m3_s"]
    (5.0, 5.0, 4.0)
    >>> round(f["t_flow_reversal_s"], 6), f["t_runaway_s"]
    (1.714286, 2.0)
    """
    t, n, q, y = (np.asarray(v, float) for v in (time_s, speed_rpm, flow_m3_s, stroke))
    n_dir, q_dir = _direction(n[0]), _direction(q[0])
    reverse_speed = max(0.0, float(np.max(-n_dir * n)))
    reverse_flow = -q_dir * q
    out = {"max_reverse_speed_rpm": reverse_speed, "max_reverse_speed_pct": 100.0 * reverse_speed / rated_speed_rpm,
           "max_reverse_flow_m3_s": max(0.0, float(np.max(reverse_flow))), "t_flow_reversal_s": None,
           "t_runaway_s": None}
    crossed = np.flatnonzero(reverse_flow > 0)
    if crossed.size:
        i = int(crossed[0])
        before, after = -reverse_flow[i - 1], reverse_flow[i]  # >= 0 and > 0: linear interpolation of the zero
        out["t_flow_reversal_s"] = float(t[i - 1] + (t[i] - t[i - 1]) * before / (before + after))
    size = np.abs(n)
    lowest = np.minimum.accumulate(size)
    prominence = PEAK_PROMINENCE * rated_speed_rpm
    for i in range(1, size.size - 1):
        if size[i] > size[i - 1] and size[i] >= size[i + 1] and size[i] - lowest[i] >= prominence:
            if abs(y[i] - y[0]) <= HELD_STROKE:
                out["t_runaway_s"] = float(t[i])
            break
    return out
