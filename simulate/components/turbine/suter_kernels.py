"""Compiled kernels of four-quadrant characteristics on the Suter transform: the curves WH(x, y), WM(x, y) and the
operating point they give for a speed and the conduit's relation H = C_L + k Q.

Relative quantities (:mod:`hillchart.four_quadrant.suter`, turbine convention): v = n/n_r, q = Q/Q_r, h = H/H_r,
m = M/M_r, y the relative opening. The curves come in two forms, one kernel (:func:`suter_curves`) reading a flag:

* a table (form :data:`TABLE`): WH and WM on a regular periodic grid of x (``nx`` points, step 2 pi / nx, from 0)
  and a regular grid of openings (``ny`` lines from ``y0`` by ``dy``; one line: curves of x alone, a pump),
  interpolated linearly in x (periodic) and in y;
* logsig nets (form :data:`NETS`): :class:`hillchart.fccm.net.FCCMWeights` of inputs cos x, sin x[, y] (the
  :class:`hillchart.four_quadrant.nets.SuterNets`), evaluated as ``FCCMWeights.predict`` does.

The point (:func:`suter_point`) is walked on w = q + k2 sqrt(h), the shifted flow whose direction with v is the
Suter angle, ``x = pi + atan2(w, v)``: for a fixed speed, x is a monotone function of w on the branch of the speed's
sign (v > 0: x in (pi/2, 3 pi/2); v < 0: x in (3 pi/2, 5 pi/2), i.e. through 2 pi = 0), and each w gives one head
and one flow, so F(w) = h(w) - (c + b q(w)) is single-valued, where Q11(N11) of the same machine is not (the S-zone).
With the plain transform w = q and h = WH(x) (w^2 + v^2). With the improved one, s = sqrt(h) solves the quadratic
the definitions give at a fixed x (WH (q^2 + v^2 + C_h h) = (y + C_y)^2 h with q = w - k2 s)::

    (A - WH k2^2) s^2 + 2 WH k2 w s - WH (w^2 + v^2) = 0,     A = (y + C_y)^2 - C_h WH

whose product of roots is negative when A - WH k2^2 > 0: one positive root. When A - WH k2^2 <= 0 (small openings
near zero speed, where WH nears (y + C_y)^2 / (C_h + k2^2)) both roots have the sign of k2 w: the smaller positive
one is the point (the larger tends to infinity as A - WH k2^2 rises to 0). The point is invalid where WH <= 0 or
A <= 0 (no finite positive head has this WH) or no root is positive. The torque is
m = WM (q^2 + v^2 + C_h h) / (y + C_y)^2 - k1 h (plain: WM (q^2 + v^2)),
:func:`hillchart.four_quadrant.suter.inverse_suter_transform` in compiled form. Through
zero speed nothing changes: at v = 0 the angle is pi/2 or 3 pi/2 by the sign of w, and h tends to 0 with w.

Below the curves' smallest opening y_f (the closed vanes, :func:`closed_vane_point`): the curves end at the smallest
opening they were made from, and the guide vanes close below it. There the machine is the one at y_f with its flow
scaled by r = y / y_f (a throat area proportional to the opening, as the hill chart's extension to zero opening
takes Q11 proportional to the opening), and its torque blended from the y_f machine's at that point to the
torque it has at zero flow at the same speed (the runner turning in the water of the closed casing)::

    q = r q_f(w),   h = h_f(w),   m = r m_f(w) + (1 - r) m_0(v),   r = y / y_f

so the head relation h = c + b q is the y_f machine's with b r in place of b (one solve, as above), and at y = 0 the
flow is zero and the head the conduit's. m_0(v) is the y_f machine's torque where q_f = 0 at speed v
(:func:`zero_flow_torque`). The blend is an assumption of this simulator, the simplest that is continuous at y_f
and has zero flow at the closed vanes; the curves themselves say nothing below y_f.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Curve forms (the first entry of the curves' scalars).
TABLE, NETS = 0, 1
TWO_PI = 2.0 * math.pi

#: The halvings of a bracketing step that landed where the curves give no point, on each side of the walk
#: (:func:`solve_shifted_flow`): 2^-60 of the step, far below any tolerance on w.
MAX_SHRINKS = 60
#: Step statuses (0: converged).
NOT_BRACKETED, NOT_CONVERGED, INVALID_POINT, OPENING_OUTSIDE = 1, 2, 3, 4
STATUS_TEXT = {NOT_BRACKETED: "found no sign change of h(w) - (C_L + k Q(w)) / H_r (no root bracketed)",
               NOT_CONVERGED: "did not converge", INVALID_POINT: "met a point where the curves give no finite "
               "positive head", OPENING_OUTSIDE: "was given an opening outside the curves' openings"}


@numba.njit(cache=True, inline="always")
def _logsig(z):
    if z >= 0.0:
        return 1.0 / (1.0 + math.exp(-z))
    ez = math.exp(z)
    return ez / (1.0 + ez)


@numba.njit(cache=True)
def _net(w1, vec, c, s, y):
    """One FCCMWeights net (one output) at inputs (cos x, sin x[, y]); ``vec``: b1 (H), W2 (H), b2, x_min, x_max
    (n_in each), y_min, y_max."""
    hidden, n_in = w1.shape
    inputs = (c, s, y)
    lo = 2 * hidden + 1
    out = vec[2 * hidden]
    for i in range(hidden):
        z = vec[i]
        for j in range(n_in):
            z += w1[i, j] * (2.0 * (inputs[j] - vec[lo + j]) / (vec[lo + n_in + j] - vec[lo + j]) - 1.0)
        out += vec[hidden + i] * _logsig(z)
    y_min, y_max = vec[lo + 2 * n_in], vec[lo + 2 * n_in + 1]
    return (out + 1.0) * (y_max - y_min) / 2.0 + y_min


@numba.njit(cache=True)
def suter_curves(cs, wh_t, wm_t, w1h, w1m, vh, vm, x, y):
    """``(WH, WM, ok)`` at the angle x (radians, any real) and relative opening y; ``ok`` False where y lies
    outside a table's openings (no extrapolation). ``cs``: form, nx, ny, y0, dy, k1, k2, c_h, c_y."""
    if cs[0] == NETS:
        c, s = math.cos(x), math.sin(x)
        return _net(w1h, vh, c, s, y), _net(w1m, vm, c, s, y), True
    nx, ny = int(cs[1]), int(cs[2])
    u = (x % TWO_PI) * nx / TWO_PI
    i = int(math.floor(u))
    fx = u - i
    i = i % nx
    i1 = (i + 1) % nx
    if ny == 1:
        return ((1.0 - fx) * wh_t[0, i] + fx * wh_t[0, i1], (1.0 - fx) * wm_t[0, i] + fx * wm_t[0, i1], True)
    t = (y - cs[3]) / cs[4]
    if not (-1e-12 <= t <= ny - 1 + 1e-12):
        return 0.0, 0.0, False
    j = min(max(int(math.floor(t)), 0), ny - 2)
    fy = t - j
    wh = ((1.0 - fy) * ((1.0 - fx) * wh_t[j, i] + fx * wh_t[j, i1])
          + fy * ((1.0 - fx) * wh_t[j + 1, i] + fx * wh_t[j + 1, i1]))
    wm = ((1.0 - fy) * ((1.0 - fx) * wm_t[j, i] + fx * wm_t[j, i1])
          + fy * ((1.0 - fx) * wm_t[j + 1, i] + fx * wm_t[j + 1, i1]))
    return wh, wm, True


@numba.njit(cache=True)
def suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, w, v, y):
    """``(q, h, m, status)`` at the shifted flow w and speed v (relative) and opening y (module docstring); status 0,
    :data:`INVALID_POINT` or :data:`OPENING_OUTSIDE`."""
    wh, wm, ok = suter_curves(cs, wh_t, wm_t, w1h, w1m, vh, vm, math.pi + math.atan2(w, v), y)
    if not ok:
        return 0.0, 0.0, 0.0, OPENING_OUTSIDE
    k1, k2, c_h, c_y = cs[5], cs[6], cs[7], cs[8]
    r2 = w * w + v * v
    if k1 == 0.0 and k2 == 0.0 and c_h == 0.0 and c_y == 0.0:  # plain
        return w, wh * r2, wm * r2, 0
    factor = (y + c_y) ** 2
    a2 = factor - c_h * wh - wh * k2 * k2
    if not (wh > 0.0 and factor - c_h * wh > 0.0):
        return 0.0, 0.0, 0.0, INVALID_POINT
    if r2 == 0.0:
        s = 0.0
    else:
        disc = (wh * k2 * w) ** 2 + a2 * wh * r2
        if disc < 0.0 or (a2 <= 0.0 and wh * k2 * w <= 0.0):  # a2 <= 0: both roots of one sign, that of k2 w
            return 0.0, 0.0, 0.0, INVALID_POINT
        root = math.sqrt(disc)
        # the positive root (a2 > 0), or the smaller positive one (a2 <= 0: the larger one tends to infinity as a2
        # rises to 0, a point of reversed flow, h < 0 physically), without cancellation on either side of w = 0
        s = wh * r2 / (wh * k2 * w + root) if wh * k2 * w >= 0.0 else (root - wh * k2 * w) / a2
    h = s * s
    q = w - k2 * s
    m = wm * (q * q + v * v + c_h * h) / factor - k1 * h
    return q, h, m, 0


@numba.njit(cache=True)
def zero_flow_torque(cs, wh_t, wm_t, w1h, w1m, vh, vm, v, y):
    """``(m_0, status)``: the torque at zero flow (q = 0) at speed v and opening y; 0 at v = 0 (standstill). The
    plain transform has q = w (m_0 at w = 0); the improved one q = w - k2 sqrt(h(w)), whose sign at the walk's
    start gives the side where it crosses 0: found by doubling a step from 1e-3 (1 + |v|), then bisected to
    1e-13 (1 + |v|).

    The walk starts at w = 0, or where the curves give no point there at the first w > 0 that gives one, the step
    doubled from 1e-3 (1 + |v|): with WH at x = pi above (y + C_y)^2 / (C_h + k2^2) both roots of the quadratic in
    sqrt(h) have the sign of k2 w and none is positive at w = 0, and q <= w (k2 >= 0) puts the zero flow at w > 0.
    Where q is already above 0 there, the walk starts at the last of 63 points between that w and the one before
    it where q is below 0 (the points begin below the zero flow; a bisection to where they begin lands on a sliver
    of nearly no head, where q nears w > 0). A real pump-turbine's nets at their smallest opening are so
    (``benchmarks/bench_pump_turbine_table.py``: WH(pi) at 4 mm of 38 above 0.124): without the search the closed
    vanes had no torque, and a run at an opening below the smallest none at all."""
    if v == 0.0:
        return 0.0, 0
    step = 1e-3 * (1.0 + abs(v))
    lo = 0.0
    q, h, m, st = suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, lo, v, y)
    if st != 0 and cs[6] > 0.0:  # no point at w = 0: the first w > 0 with one, the step doubled
        bad, lo = 0.0, step
        for _ in range(80):
            q, h, m, st = suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, lo, v, y)
            if st == 0:
                break
            bad, lo = lo, 2.0 * lo
        if st == 0 and q > 0.0:  # past the zero flow: the last of 63 points between bad and lo below it
            for i in range(63, 0, -1):
                w = bad + (lo - bad) * i / 64.0
                q2, h2, m2, st2 = suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, w, v, y)
                if st2 == 0 and q2 < 0.0:
                    lo, q, h, m = w, q2, h2, m2
                    break
    if st != 0 or q == 0.0:
        return m, st
    side = 1.0 if q < 0.0 else -1.0  # toward q = 0
    q_lo = q
    hi = lo + side * step
    for _ in range(80):
        q, h, m, st = suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, hi, v, y)
        if st != 0:
            return 0.0, st
        if q * q_lo <= 0.0:
            break
        step *= 2.0
        lo, hi = hi, hi + side * step
    if q * q_lo > 0.0:
        return 0.0, NOT_BRACKETED
    while abs(hi - lo) > 1e-13 * (1.0 + abs(v)):
        mid = 0.5 * (lo + hi)
        q, h, m, st = suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, mid, v, y)
        if st != 0:
            return 0.0, st
        if q * q_lo <= 0.0:
            hi = mid
        else:
            lo = mid
    q, h, m, st = suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, hi, v, y)
    return m, st


@numba.njit(cache=True)
def closed_vane_ratio(y, y_floor):
    """r = y / y_floor below the smallest opening ``y_floor`` (0 at the closed vanes and below), 1 at or above it
    and for curves of x alone (``y_floor`` = 0: no vanes to close)."""
    if y_floor <= 0.0 or y >= y_floor:
        return 1.0
    return max(y, 0.0) / y_floor


@numba.njit(cache=True)
def closed_vane_blend(r, q, m, m0):
    """``(q, m)`` of the closed-vane model (module docstring) from the smallest opening's flow q and torque m and the
    zero-flow torque m0: the flow scaled by r, the torque blended, ``(r q, r m + (1 - r) m0)``."""
    return r * q, r * m + (1.0 - r) * m0


@numba.njit(cache=True)
def closed_vane_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, w, v, y_floor, r):
    """``(q, h, m, status)`` below the smallest opening ``y_floor`` (module docstring: the y_floor machine's point at
    w, its flow scaled by r = y / y_floor, :func:`closed_vane_ratio`, the torque blended to the zero-flow torque)."""
    q, h, m, st = suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, w, v, y_floor)
    if st != 0:
        return q, h, m, st
    m0, st = zero_flow_torque(cs, wh_t, wm_t, w1h, w1m, vh, vm, v, y_floor)
    q, m = closed_vane_blend(r, q, m, m0)
    return q, h, m, st


@numba.njit(cache=True)
def _gap(cs, wh_t, wm_t, w1h, w1m, vh, vm, w, v, y, c, b):
    q, h, m, status = suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, w, v, y)
    return h - (c + b * q), status


@numba.njit(cache=True)
def solve_shifted_flow(cs, wh_t, wm_t, w1h, w1m, vh, vm, v, y, c, b, w0, tol, max_iter):
    """``(w, status, iterations)``: the root of F(w) = h(w) - (c + b q(w)) next to ``w0`` (relative head relation
    h = c + b q, b <= 0). Bracketed from w0 outward: first toward where |F| falls (the side of the previous
    solution's branch), the step growing 1.6-fold, at most 80 steps each way (the guard: a run that leaves the
    curves' branch stops with :data:`NOT_BRACKETED`); then the Illinois method to |dw| < tol (1 + |w|). A step that
    lands where the curves give no point (:data:`INVALID_POINT`: no finite positive head, e.g. past the reverse
    flow a pump brakes) is halved back toward the last valid point, up to :data:`MAX_SHRINKS` times on each side,
    and the walk goes on from there without growing: a root between the two is found, not stepped over; a side with
    no valid point left ends, and with no root on either side the status is the invalid point's."""
    f0, st = _gap(cs, wh_t, wm_t, w1h, w1m, vh, vm, w0, v, y, c, b)
    if st != 0:
        return w0, st, 0
    if f0 == 0.0:
        return w0, 0, 0
    delta = 1e-3 * (1.0 + abs(w0) + abs(v))
    fp, sp = _gap(cs, wh_t, wm_t, w1h, w1m, vh, vm, w0 + delta, v, y, c, b)
    fm, sm = _gap(cs, wh_t, wm_t, w1h, w1m, vh, vm, w0 - delta, v, y, c, b)
    if sp != 0 and sm != 0:
        return w0, sp, 2
    if sp != 0 or sm != 0:
        first = -1.0 if sp != 0 else 1.0  # the side with a point
    else:
        first = 1.0 if (fp - fm) * f0 < 0.0 else -1.0  # toward a smaller |F|
    iterations = 2
    invalid = 0
    lo, flo, hi, fhi = w0, f0, w0, f0
    found = False
    for direction in (first, -first):
        step = delta
        a, fa = w0, f0
        shrinks = 0
        for _ in range(80):
            bnext = a + direction * step
            fb, st = _gap(cs, wh_t, wm_t, w1h, w1m, vh, vm, bnext, v, y, c, b)
            iterations += 1
            grow = 1.6
            while st != 0 and shrinks < MAX_SHRINKS:  # the curves end between a and bnext: a shorter step
                invalid = st
                shrinks += 1
                step *= 0.5
                bnext = a + direction * step
                fb, st = _gap(cs, wh_t, wm_t, w1h, w1m, vh, vm, bnext, v, y, c, b)
                iterations += 1
                grow = 1.0
            if st != 0:
                invalid = st
                break
            if fb == 0.0:
                return bnext, 0, iterations
            if fb * fa < 0.0:
                lo, flo, hi, fhi = a, fa, bnext, fb
                found = True
                break
            a, fa = bnext, fb
            step *= grow
        if found:
            break
    if not found:
        return w0, invalid if invalid != 0 else NOT_BRACKETED, iterations
    w, status, more = _illinois(cs, wh_t, wm_t, w1h, w1m, vh, vm, v, y, c, b, lo, flo, hi, fhi, tol, max_iter)
    return w, status, iterations + more


@numba.njit(cache=True)
def _illinois(cs, wh_t, wm_t, w1h, w1m, vh, vm, v, y, c, b, lo, flo, hi, fhi, tol, max_iter):
    """``(w, status, iterations)``: the Illinois method (regula falsi halving the value of an end kept twice) on
    the bracket [lo, hi] of F (values flo, fhi of opposite signs) to |hi - lo| < tol (1 + |w|)."""
    side = 0
    w = lo
    for iteration in range(max_iter):
        w = (lo * fhi - hi * flo) / (fhi - flo)
        fw, st = _gap(cs, wh_t, wm_t, w1h, w1m, vh, vm, w, v, y, c, b)
        if st != 0:
            return w, st, iteration + 1
        if fw == 0.0:
            return w, 0, iteration + 1
        if fw * fhi < 0.0:
            lo, flo = hi, fhi
            hi, fhi = w, fw
            side = 0
        else:
            hi, fhi = w, fw
            if side == 1:
                flo *= 0.5
            side = 1
        if abs(hi - lo) < tol * (1.0 + abs(w)):
            return w, 0, iteration + 1
    return w, NOT_CONVERGED, max_iter


@numba.njit(cache=True)
def unit_head_flow(cs, wh_t, wm_t, w1h, w1m, vh, vm, v, y, scan):
    """``(q, m, ok)`` at unit head (h = 1) and speed v: the root of h(w) = 1 with the largest flow in the speed's
    direction (the normal operating branch: turbine flow for v > 0, pump flow for v < 0), found by a scan of
    ``scan`` angles over the speed's branch from that end, then :func:`solve_shifted_flow`. Not at v = 0."""
    if v == 0.0:
        return np.nan, np.nan, False
    previous = before = 0.0
    have = False
    for i in range(scan):
        # x from the end of the branch where q sign(v) is largest: w = v tan(x - pi) runs from +-inf inward
        phi = (0.5 - (i + 0.5) / scan) * math.pi * 0.999
        w = v * math.tan(phi)  # from w sign(v) large (q sign(v) largest) to the other end of the branch
        f, st = _gap(cs, wh_t, wm_t, w1h, w1m, vh, vm, w, v, y, 1.0, 0.0)
        if st != 0:
            have = False
            continue
        if have and f * previous <= 0.0:
            root = w
            if f != 0.0:
                root, status, _ = _illinois(cs, wh_t, wm_t, w1h, w1m, vh, vm, v, y, 1.0, 0.0, before, previous, w,
                                            f, 1e-15, 300)
                if status != 0:
                    return np.nan, np.nan, False
            q, h, m, st = suter_point(cs, wh_t, wm_t, w1h, w1m, vh, vm, root, v, y)
            return q, m, st == 0
        previous, before, have = f, w, True
    return np.nan, np.nan, False
