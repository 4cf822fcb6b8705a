"""Schedules the components follow: piecewise-linear laws (guide-vane strokes) and piecewise-constant steps (speed
references, loads), evaluated in the compiled loop."""

from __future__ import annotations

import numba
import numpy as np

#: Who drives the guide vanes: the governor, or a prescribed law (the schedules' ``mode``).
GOVERNOR, PRESCRIBED = 0, 1


@numba.njit(cache=True)
def piecewise_linear(times, values, t):
    """Right-continuous piecewise-linear interpolation (a repeated time makes a step).

    Examples
    --------
    >>> tt = np.array([0.0, 1.0, 1.0, 2.0]); vv = np.array([1.0, 1.0, 0.5, 0.0])
    >>> [float(piecewise_linear(tt, vv, t)) for t in (0.5, 1.0, 1.5, 3.0)]
    [1.0, 0.5, 0.25, 0.0]
    """
    n = times.size
    if t < times[0]:
        return values[0]
    if t >= times[n - 1]:
        return values[n - 1]
    i = np.searchsorted(times, t, side="right")  # times[i-1] <= t < times[i]
    t0, t1 = times[i - 1], times[i]
    if t1 <= t0:
        return values[i]
    return values[i - 1] + (values[i] - values[i - 1]) * (t - t0) / (t1 - t0)


@numba.njit(cache=True)
def piecewise_constant(times, values, t, initial):
    """``initial`` before ``times[0]``, then ``values[i]`` from ``times[i]`` on (times sorted).

    Examples
    --------
    >>> float(piecewise_constant(np.array([1.0, 2.0]), np.array([5.0, 7.0]), 1.5, 3.0))
    5.0
    """
    i = np.searchsorted(times, t, side="right")
    if i == 0:
        return initial
    return values[i - 1]
