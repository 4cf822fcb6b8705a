"""Initial steady operation, verified before stepping.

At speed n (rated by default) and stroke y the head H and flow Q satisfy

    penstock:  H = H_st - K Q|Q|                 (K = sum f L / (2 g D A^2))
    turbine:   Q = Q11(n D1 / sqrt(H), a) D1^2 sqrt(H),  a = y * opening_max

solved by Brent's method on H; for a power target the stroke is found by a second Brent search on
P(y) = M11 D1^3 H omega (between the stroke limits, or below the stroke of the largest power when the power peaks
before the upper limit; a target above that largest power is an error naming it). Every residual is then checked
against :data:`RESIDUAL_TOLERANCE` (relative).

Brent's method is :func:`brentq`, a line-by-line port of scipy's ``brentq.c`` (scipy.optimize.brentq): importing
scipy.optimize costs about a quarter of a second of start-up (it pulls in linprog, scipy.fft and scipy.special), an
eighth of the 2 s budget of ``hillsim run``, for two scalar root searches. The port takes the
same steps as scipy's, so it returns the same root to the bit (``tests/simulate/loop/test_sim_steady_brent.py`` checks
it against scipy.optimize.brentq).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hillchart.constants import RPM_TO_RAD_S
from hillchart.errors import InputError, NumericalError

#: Largest accepted relative residual of every steady-state equation.
RESIDUAL_TOLERANCE = 1e-9


def brentq(f, a: float, b: float, *, xtol: float = 2e-12, rtol: float = 4 * 2.220446049250313e-16,
           maxiter: int = 100) -> float:
    """Root of ``f`` in [a, b] (f(a) and f(b) of opposite signs) by Brent's method; scipy.optimize.brentq's
    algorithm (scipy/optimize/Zeros/brentq.c), step for step, so the same root to the bit.

    Converged when half the bracket is below ``(xtol + rtol |x|) / 2``.

    Raises
    ------
    InputError
        ``xtol``, ``rtol`` or ``maxiter`` out of range.
    NumericalError
        f(a) and f(b) have the same sign, f returns NaN, or no convergence in ``maxiter`` iterations.

    Examples
    --------
    >>> round(brentq(lambda x: x * x - 2.0, 0.0, 2.0, xtol=1e-15), 15)
    1.414213562373095
    """
    if not xtol > 0.0:
        raise InputError(f"brentq: xtol must be > 0, got {xtol!r}")
    if not rtol >= 4 * 2.220446049250313e-16:
        raise InputError(f"brentq: rtol must be >= 4 eps (8.88e-16), got {rtol!r}")
    if maxiter < 0:
        raise InputError(f"brentq: maxiter must be >= 0, got {maxiter!r}")

    def call(x):
        value = float(f(x))
        if math.isnan(value):
            raise NumericalError(f"brentq: the function is NaN at {x!r}")
        return value

    xpre, xcur = float(a), float(b)
    xblk = fblk = spre = scur = 0.0
    fpre, fcur = call(xpre), call(xcur)
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if math.copysign(1.0, fpre) == math.copysign(1.0, fcur):
        raise NumericalError(f"brentq: f({xpre!r}) = {fpre!r} and f({xcur!r}) = {fcur!r} have the same sign; "
                             f"no bracketed root")
    for _ in range(maxiter):
        if fpre != 0.0 and fcur != 0.0 and math.copysign(1.0, fpre) != math.copysign(1.0, fcur):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # interpolate (secant)
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # extrapolate (inverse quadratic)
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):  # good short step
                spre, scur = scur, stry
            else:  # bisect
                spre = scur = sbis
        else:  # bisect
            spre = scur = sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = call(xcur)
    raise NumericalError(f"brentq: no convergence in {maxiter} iterations (last x {xcur!r}, f {fcur!r})")


@dataclass(frozen=True)
class SteadyState:
    """A verified operating point (physical units) and its relative residuals."""

    speed_rpm: float
    stroke: float
    opening_chart: float
    head_m: float
    flow_m3_s: float
    unit_speed_rpm: float
    unit_flow_m3_s: float
    torque_nm: float
    power_mw: float
    residuals: dict


def _turbine_point(kernel, params, speed_rpm, opening, head_m, d1_m):
    sqrt_h = math.sqrt(head_m)
    n11 = speed_rpm * d1_m / sqrt_h
    try:
        out = kernel(params, n11, opening)
    except ZeroDivisionError:  # a Python kernel at N11 = 0 (standstill) that has no value there
        return n11, math.nan, math.nan, math.nan
    q11, m11 = float(out[0]), float(out[3])
    return n11, q11, q11 * d1_m * d1_m * sqrt_h, m11 * d1_m ** 3 * head_m


def head_at_opening(kernel, params, *, speed_rpm, opening, static_head_m, friction_s2_m5, d1_m):
    """Steady head (m) at the turbine for chart opening ``opening`` (H_st - K Q|Q| = H with the turbine law).

    Examples
    --------
    >>> from hillchart.characteristics import IdealTurbine, scalar_kernel
    >>> kernel, params, _ = scalar_kernel(IdealTurbine(q11_max_m3_s=0.5, opening_max=1.0, efficiency=0.9))
    >>> h = head_at_opening(kernel, params, speed_rpm=300.0, opening=1.0, static_head_m=100.0,
    ...                     friction_s2_m5=0.01, d1_m=2.0)   # Q = 2 sqrt(H), H = 100 - 0.04 H
    >>> round(h, 9)
    96.153846154
    """
    def gap(head):
        flow = _turbine_point(kernel, params, speed_rpm, opening, head, d1_m)[2]
        return static_head_m - friction_s2_m5 * flow * abs(flow) - head

    g_st = gap(static_head_m)
    if g_st == 0.0:
        return float(static_head_m)
    # One fixed-point step H1 = H_st - K Q(H_st)|Q(H_st)| brackets the root while |Q| grows with H (forward flow:
    # root below H_st; a slightly negative Q11 at a closed vane gives reverse flow and a root above H_st);
    # otherwise widen the step geometrically, never to tiny heads where N11 leaves any chart's range.
    step = g_st
    other = static_head_m + step
    if not (0.1 * static_head_m < other < 10.0 * static_head_m):
        loss = g_st  # gap at the static head = -K Q|Q|
        raise InputError(
            f"steady state: at opening {opening:.6g} and the static head {static_head_m:.6g} m the turbine would pass "
            f"a flow whose friction loss K Q|Q| = {abs(loss):.6g} m (K = {friction_s2_m5:.6g} s^2/m^5) is not small "
            f"against penstock.static_head_m: no plausible steady flow; check the penstock segments' length_m, "
            f"diameter_m and darcy_friction (units m, m, -)")
    g_other = gap(other)
    while g_other * g_st > 0.0 and 0.1 * static_head_m < other < 10.0 * static_head_m:
        step *= 2.0
        other = static_head_m + step
        g_other = gap(other)
    if g_other * g_st > 0.0:
        raise NumericalError(f"steady state: no head between {static_head_m:.6g} and {other:.6g} m balances "
                             f"friction at opening {opening:.6g} (gaps {g_st:.3g} and {g_other:.3g} m)")
    low, high = min(static_head_m, other), max(static_head_m, other)
    return float(brentq(gap, low, high, xtol=1e-13 * static_head_m, rtol=1e-15, maxiter=500))


def largest_power(power_of, stroke_min: float, stroke_max: float, *, samples: int = 33) -> tuple[float, float]:
    """``(stroke, power)`` where ``power_of(stroke)`` is largest in [stroke_min, stroke_max]: the best of
    ``samples`` evenly spaced strokes, refined by golden-section search between its neighbours (to 1e-9 of the
    stroke range).

    Examples
    --------
    >>> y, p = largest_power(lambda y: 1.0 - (y - 0.8) ** 2, 0.0, 1.0)
    >>> round(y, 6), round(p, 9)
    (0.8, 1.0)
    """
    strokes = [stroke_min + (stroke_max - stroke_min) * i / (samples - 1) for i in range(samples)]
    powers = [power_of(y) for y in strokes]
    i = max(range(samples), key=powers.__getitem__)
    low, high = strokes[max(i - 1, 0)], strokes[min(i + 1, samples - 1)]
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = high - ratio * (high - low), low + ratio * (high - low)
    f1, f2 = power_of(x1), power_of(x2)
    while high - low > 1e-9 * (stroke_max - stroke_min):
        if f1 >= f2:
            high, x2, f2 = x2, x1, f1
            x1 = high - ratio * (high - low)
            f1 = power_of(x1)
        else:
            low, x1, f1 = x1, x2, f2
            x2 = low + ratio * (high - low)
            f2 = power_of(x2)
    best = max(((strokes[i], powers[i]), (x1, f1), (x2, f2)), key=lambda item: item[1])
    return float(best[0]), float(best[1])


def unreachable_power_message(power_mw, speed_rpm, stroke_min, stroke_max, p_min_stroke, p_max_stroke, y_peak,
                              p_peak, turbine) -> str:
    """The error for a power target the unit cannot give: the range, the largest reachable power and what to
    change (with a model chart: the IEC 60193 step-up of ``[turbine.step_up]``)."""
    text = (f"scenario.initial_power_mw = {power_mw!r} is outside the power range the unit gives at "
            f"{speed_rpm:.6g} r/min between governor.stroke_min and stroke_max: "
            f"[{p_min_stroke:.6g}, {p_max_stroke:.6g}] MW at the two ends")
    if power_mw < min(p_min_stroke, p_max_stroke):
        return text + "; lower governor.stroke_min or raise scenario.initial_power_mw"
    text += (f"; the largest power it gives is {p_peak:.1f} MW (stroke {y_peak:.4g}); lower "
             f"scenario.initial_power_mw to at most {math.floor(10.0 * p_peak) / 10.0:.1f} MW")
    if getattr(turbine, "step_up", None) is None:
        text += (", or, when the hill chart is a model test (most are), convert it to this prototype with the IEC "
                 "60193 efficiency step-up: add [turbine.step_up] with method = \"iec60193\" to the plant file (or "
                 "--set turbine.step_up=iec60193); its model_diameter_m, model_head_m and model_efficiency_reference "
                 "default to a 0.35 m model at 30 m and the chart's best efficiency")
    else:
        text += " (the IEC 60193 step-up of [turbine.step_up] is already applied)"
    return text


def steady_state(kernel, params, *, turbine, static_head_m, friction_s2_m5, stroke_min, stroke_max,
                 speed_rpm=None, power_mw=None, stroke=None) -> SteadyState:
    """Steady operation at ``speed_rpm`` (when None: the turbine section's initial speed, the rated speed, negative
    in pump mode) for a power target or a given stroke, verified.

    Raises
    ------
    InputError
        The power target is outside what the stroke range can give.
    NumericalError
        A residual is above :data:`RESIDUAL_TOLERANCE` (the message names the equation and its size).

    Examples
    --------
    >>> from hillchart.characteristics import IdealTurbine, scalar_kernel
    >>> from simulate.config import TurbineConfig
    >>> t = TurbineConfig(rated_head_m=100.0, rated_flow_m3_s=10.0, rated_speed_rpm=300.0, rated_power_mw=9.0,
    ...                   runner_diameter_m=2.0, opening_max=1.0, characteristics="ideal")
    >>> ideal = IdealTurbine(q11_max_m3_s=0.25, opening_max=1.0, efficiency=9.0 / 9.81)
    >>> kernel, params, _ = scalar_kernel(ideal)
    >>> s = steady_state(kernel, params, turbine=t, static_head_m=100.0, friction_s2_m5=0.0, stroke_min=0.0,
    ...                  stroke_max=1.0, power_mw=4.5)
    >>> round(s.stroke, 9), round(s.flow_m3_s, 9)
    (0.5, 5.0)
    """
    if (power_mw is None) == (stroke is None):
        raise InputError(f"steady state needs exactly one of power_mw or stroke, got {power_mw!r} and {stroke!r}")
    speed = getattr(turbine, "initial_speed_rpm", turbine.rated_speed_rpm) if speed_rpm is None else float(speed_rpm)
    d1, a_max = turbine.runner_diameter_m, turbine.opening_max
    omega = speed * RPM_TO_RAD_S

    def head_of(y):
        return head_at_opening(kernel, params, speed_rpm=speed, opening=y * a_max, static_head_m=static_head_m,
                               friction_s2_m5=friction_s2_m5, d1_m=d1)

    def power_of(y):
        head = head_of(y)
        return _turbine_point(kernel, params, speed, y * a_max, head, d1)[3] * omega * 1e-6

    if stroke is None:
        p_low, p_high = power_of(stroke_min) - power_mw, power_of(stroke_max) - power_mw
        if p_low == 0.0:
            stroke = stroke_min
        elif p_high == 0.0:
            stroke = stroke_max
        elif p_low * p_high > 0.0:
            # the power may peak inside the stroke range (efficiency falls at large openings): search it there
            y_peak, p_peak = largest_power(power_of, stroke_min, stroke_max)
            if p_high < 0.0 and p_low < 0.0 and p_peak >= power_mw:
                stroke = brentq(lambda y: power_of(y) - power_mw, stroke_min, y_peak, xtol=1e-15, rtol=1e-15,
                                maxiter=500)
            else:
                raise InputError(unreachable_power_message(power_mw, speed, stroke_min, stroke_max, p_low + power_mw,
                                                           p_high + power_mw, y_peak, p_peak, turbine))
        else:
            stroke = brentq(lambda y: power_of(y) - power_mw, stroke_min, stroke_max, xtol=1e-15, rtol=1e-15,
                            maxiter=500)
    stroke = float(stroke)
    if speed == 0.0 and not all(math.isfinite(v) for v in _turbine_point(kernel, params, 0.0, stroke * a_max,
                                                                          static_head_m, d1)[1:]):
        raise InputError(f"steady state at standstill (speed 0, stroke {stroke:g}): the characteristics give no "
                         f"flow or torque at N11 = 0; a start from standstill needs characteristics that hold zero "
                         f"speed and the closed vanes (four-quadrant characteristics, or nets extended to zero "
                         f"speed): set turbine.characteristics to such, or start the unit turning")
    head = head_of(stroke)
    n11, q11, flow, torque = _turbine_point(kernel, params, speed, stroke * a_max, head, d1)
    power = torque * omega * 1e-6
    flow_scale = max(abs(flow), 1e-6 * turbine.rated_flow_m3_s)
    residuals = {
        "penstock head (H_st - K Q|Q| - H)/H": (static_head_m - friction_s2_m5 * flow * abs(flow) - head) / head,
        "turbine flow (Q - Q11 D1^2 sqrt(H))/Q": (flow - q11 * d1 * d1 * math.sqrt(head)) / flow_scale,
    }
    if power_mw is not None:
        residuals["power (P - P_target)/P_r"] = (power - power_mw) / turbine.rated_power_mw
    for name, value in residuals.items():
        if not abs(value) < RESIDUAL_TOLERANCE:
            raise NumericalError(f"initial steady state: residual of {name} is {value:.3g}, above the allowed "
                                 f"{RESIDUAL_TOLERANCE:g} (stroke {stroke:.9g}, head {head:.9g} m)")
    return SteadyState(speed_rpm=speed, stroke=stroke, opening_chart=stroke * a_max, head_m=head, flow_m3_s=flow,
                       unit_speed_rpm=n11, unit_flow_m3_s=q11, torque_nm=torque, power_mw=power,
                       residuals=residuals)


@dataclass(frozen=True)
class ManifoldSteadyState:
    """The verified steady state of a plant with several units: the head at the manifold (m), the common conduit's
    flow (m^3/s, the sum of the units'), each unit's :class:`SteadyState` (in the order of ``[[units]]``) and the
    relative residuals of the junction equations."""

    head_m: float
    flow_m3_s: float
    units: tuple[SteadyState, ...]
    residuals: dict


def manifold_steady_state(units, *, static_head_m: float, friction_s2_m5: float) -> ManifoldSteadyState:
    """Steady operation of several units on one conduit that branches at a manifold, verified.

    ``units``: one dict per unit with the keywords of :func:`steady_state` except ``static_head_m`` (the unit sees the
    manifold head) and ``friction_s2_m5`` given as ``branch_friction_s2_m5`` (its branch's K), and optionally its
    ``name`` (for the messages). ``friction_s2_m5`` is
    the common conduit's (and any upstream tunnel's) K. The manifold head H_m solves

        H_st - K_c (sum_i Q_i(H_m)) |sum_i Q_i(H_m)| - H_m = 0,

    where Q_i(H_m) is unit i's steady flow at its target with the static head H_m and its branch's loss (each unit by
    :func:`steady_state`, Brent's method on its head and stroke), by Brent's method on H_m.

    Raises
    ------
    NumericalError
        No manifold head balances the common loss, or a residual is above :data:`RESIDUAL_TOLERANCE`.

    Examples
    --------
    >>> from hillchart.characteristics import IdealTurbine, scalar_kernel
    >>> from simulate.config import TurbineConfig
    >>> t = TurbineConfig(rated_head_m=100.0, rated_flow_m3_s=10.0, rated_speed_rpm=300.0, rated_power_mw=9.0,
    ...                   runner_diameter_m=2.0, opening_max=1.0, characteristics="ideal")
    >>> kernel, params, _ = scalar_kernel(IdealTurbine(q11_max_m3_s=0.25, opening_max=1.0, efficiency=9.0 / 9.81))
    >>> unit = dict(kernel=kernel, params=params, turbine=t, branch_friction_s2_m5=0.0, stroke_min=0.0,
    ...             stroke_max=1.0, stroke=1.0)
    >>> s = manifold_steady_state([unit, unit], static_head_m=100.0, friction_s2_m5=0.0)
    >>> round(s.head_m, 9), round(s.flow_m3_s, 9)    # frictionless: H_m = H_st, Q = 2 x 10 m^3/s
    (100.0, 20.0)
    """
    def points(head_m):
        out = []
        for i, unit in enumerate(units):
            keywords = {k: v for k, v in unit.items()
                        if k not in ("kernel", "params", "branch_friction_s2_m5", "name")}
            try:
                out.append(steady_state(unit["kernel"], unit["params"], static_head_m=head_m,
                                        friction_s2_m5=unit["branch_friction_s2_m5"], **keywords))
            except (InputError, NumericalError) as exc:
                raise type(exc)(f"unit {unit.get('name', i)!r} at the manifold head {head_m:.6g} m: {exc}") from None
        return out

    def gap(head_m):
        total = sum(p.flow_m3_s for p in points(head_m))
        return static_head_m - friction_s2_m5 * total * abs(total) - head_m

    g_st = gap(static_head_m)
    head = float(static_head_m)
    if g_st != 0.0:
        # as in head_at_opening: the fixed-point step brackets the root; widen geometrically if not
        step = g_st
        other = static_head_m + step
        g_other = gap(other) if 0.1 * static_head_m < other < 10.0 * static_head_m else g_st
        while g_other * g_st > 0.0 and 0.1 * static_head_m < other + step < 10.0 * static_head_m:
            step *= 2.0
            other = static_head_m + step
            g_other = gap(other)
        if g_other * g_st > 0.0:
            raise NumericalError(f"steady state: no manifold head between {static_head_m:.6g} and {other:.6g} m "
                                 f"balances the common conduit's loss (gaps {g_st:.3g} and {g_other:.3g} m): check "
                                 f"the common penstock's segments and the units' initial points")
        head = float(brentq(gap, min(static_head_m, other), max(static_head_m, other), xtol=1e-13 * static_head_m,
                            rtol=1e-15, maxiter=500))
    unit_points = tuple(points(head))
    total = sum(p.flow_m3_s for p in unit_points)
    residuals = {"common conduit (H_st - K_c Q|Q| - H_m)/H_m":
                 (static_head_m - friction_s2_m5 * total * abs(total) - head) / head}
    for name, value in residuals.items():
        if not abs(value) < RESIDUAL_TOLERANCE:
            raise NumericalError(f"initial steady state: residual of {name} is {value:.3g}, above the allowed "
                                 f"{RESIDUAL_TOLERANCE:g} (manifold head {head:.9g} m, flow {total:.9g} m^3/s)")
    return ManifoldSteadyState(head_m=head, flow_m3_s=total, units=unit_points, residuals=residuals)
