"""Double-regulated turbines (Kaplan, bulb): three-input characteristics Q11(N11, a, phi), M11(N11, a, phi) in the
simulator.

The guide vanes are control 0 of the control vector, the runner blades control 1 (both fractions of their servo's
stroke). The plant's chart opening is counted from the closed vane, ``a = y opening_max`` (as for a Francis unit),
and the characteristics are evaluated at ``a + combinator.opening_at_zero_stroke`` (a bulb's guide-vane angle is
counted from another zero: the synthetic bulb's vanes touch at 35 deg); the blade angle is
``phi = angle_min_deg + y_b (angle_max_deg - angle_min_deg)`` (``[blade_servo]``).

:class:`DoubleRegulatedTurbine` is the plant's view of the characteristics:

* for the compiled loop, ``numba_control_kernel()``: ``kernel(params, n11, controls) -> (q11, dq11/dn11, m11,
  dm11/dn11)`` on the chart controls ``[a, y_b]`` (the seam of :func:`simulate.components.turbine.evaluation.
  compile_characteristics`);
* for everything that works on two inputs (the steady state, the trusted domain, ``hillsim linearize``'s six
  coefficients), ``q11(n11, a)`` ... with the blades where the combinator puts them at constant speed: on the cam
  ``phi(a, H)`` with ``H = (n D1 / N11)^2`` (eq. (2) of the tubular-turbine paper solved for H), or at the fixed
  angle when the combinator is off.

The cam is a table over (opening, head) (:class:`Cam`): from the characteristics' best efficiency
(:func:`hillchart.fccm.double_regulated.on_cam_relation`) or the user's table. The combinator reads a head that is
held over a run (the net head of the initial steady state: a head measurement filtered over minutes), so the loop
follows the cam's slice at that head, :meth:`Cam.slice`; the steady state uses the same slice code, so the blades
start exactly on the cam.
"""

from __future__ import annotations

import inspect
import math
from types import SimpleNamespace

import numba
import numpy as np

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3, RPM_TO_RAD_S
from hillchart.errors import InputError
from hillchart.fccm.double_regulated import blended_point, blended_value, net3_point
from hillchart.synthetic.bulb import unit_point
from hillchart.characteristics import unit_speed

#: Opening points of a cam computed from the characteristics, and head points (fractions of the rated head).
CAM_OPENINGS = 61
CAM_HEAD_FRACTIONS = (0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.35, 1.5)
#: Blade-angle step (deg) of the cam's coarse scan before the golden-section search refines each optimum.
CAM_SCAN_STEP_DEG = 0.5


def is_three_input(characteristics) -> bool:
    """True for characteristics whose ``q11`` takes (n11, opening, blade angle)."""
    q11 = getattr(characteristics, "q11", None)
    if q11 is None or isinstance(characteristics, DoubleRegulatedTurbine):
        return False
    try:
        return len(inspect.signature(q11).parameters) == 3
    except (TypeError, ValueError):
        return False


# ---------------------------------------------------------------------------------------------------------------
# compiled kernels on the control vector [a (from the closed vane, chart units), y_b (blade stroke fraction)]
# ---------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _chart_point(scal, controls):
    """``(opening, blade angle)`` of the characteristics (chart units, deg) from the controls ``[a, y_b]``: the
    opening from the closed vane plus the angle at zero stroke, the blade angle from its stroke."""
    return controls[0] + scal[0], scal[1] + controls[1] * scal[2]


@numba.njit(cache=True)
def nets_control_kernel(params, n11, controls):
    """Three-input nets: ``(q11, dq11/dn11, m11, dm11/dn11)``; params = (flow packed, torque packed, blend
    (:meth:`hillchart.fccm.double_regulated.DoubleRegulatedNets.blend_packed`: below the table's smallest guide-vane
    angle the hypotheses weighed by the table's held-out angles, at the member's place in their band, or the fitted
    bulb model alone in files without them, or none), [opening at zero stroke, angle_min_deg, angle span deg])."""
    flow, torque, blend, scal = params
    opening, blade = _chart_point(scal, controls)
    return blended_point(flow, torque, blend, n11, opening, blade)


@numba.njit(cache=True)
def nets_control_flow(params, n11, controls):
    """The flow half of :func:`nets_control_kernel`, ``(q11, dq11/dn11)``, the same arithmetic: what the pressure
    loop reads in each iteration (the torque net is evaluated once, at the converged head)."""
    flow, torque, blend, scal = params
    opening, blade = _chart_point(scal, controls)
    if blend[14] == 0.0 and blend[13] <= opening:  # the nets alone (always, without a silent model)
        return net3_point(flow, n11, opening, blade)
    q, dq, m, dm = blended_point(flow, torque, blend, n11, opening, blade)
    return q, dq


@numba.njit(cache=True)
def nets_control_torque(params, n11, controls):
    """M11 of :func:`nets_control_kernel` (the value, the same arithmetic): the torque at the converged head, the
    flow net not evaluated."""
    flow, torque, blend, scal = params
    opening, blade = _chart_point(scal, controls)
    return blended_value(torque, blend, n11, opening, blade, 1)


@numba.njit(cache=True)
def bulb_control_kernel(params, n11, controls):
    """The exact synthetic bulb: ``(q11, dq11/dn11, m11, dm11/dn11)``; params = (bulb point parameters,
    [opening at zero stroke, angle_min_deg, angle span deg])."""
    point, scal = params
    opening, blade = _chart_point(scal, controls)
    return unit_point(point, n11, opening, blade)


@numba.njit(cache=True)
def bulb_fixed_blade_kernel(params, n11, opening):
    """The exact synthetic bulb at a fixed blade angle as a two-input kernel ``(q11, dq11/dn11, dq11/da, m11,
    dm11/dn11, dm11/da)``; params = (point parameters, [opening at zero stroke, blade angle deg]). The
    a-derivatives are central differences of step 1e-6 (the loop reads only the n11-derivatives)."""
    point, scal = params
    a = opening + scal[0]
    q, dq, m, dm = unit_point(point, n11, a, scal[1])
    step = 1e-6
    qp, _, mp, _ = unit_point(point, n11, a + step, scal[1])
    qm, _, mm, _ = unit_point(point, n11, a - step, scal[1])
    return q, dq, (qp - qm) / (2.0 * step), m, dm, (mp - mm) / (2.0 * step)


@numba.njit(cache=True)
def _nets_efficiency(flow, torque, blend, n11, opening, blade, out):
    """Efficiency M11 omega11 / (rho g Q11) (eq. (5) of the BP hill-chart paper) of packed three-input nets (with
    their blend) at points (flat arrays); NaN where Q11 <= 0 or N11 <= 0, as
    :func:`hillchart.characteristics.efficiency_from_unit_torque`."""
    for i in range(n11.size):
        q = blended_value(flow, blend, n11[i], opening[i], blade[i], 0)
        m = blended_value(torque, blend, n11[i], opening[i], blade[i], 1)
        if q > 0.0 and n11[i] > 0.0:
            out[i] = m * n11[i] * RPM_TO_RAD_S / (RHO_WATER_KG_M3 * G_M_S2 * q)
        else:
            out[i] = np.nan


def _inner_kernel(inner):
    """(control kernel, its first parameters) of a three-input characteristics object: the nets, the exact bulb, or
    any object with ``numba_three_input_kernel() -> (kernel, params)``, a module-level numba function
    ``kernel(params + (scal,), n11, controls) -> (q11, dq11/dn11, m11, dm11/dn11)`` that reads the opening as
    ``controls[0] + scal[0]`` and the blade angle as ``scal[1] + controls[1] scal[2]`` (a user's own turbine)."""
    from hillchart.fccm.double_regulated import DoubleRegulatedNets, packed_net3
    from hillchart.synthetic.bulb import SyntheticBulb

    if hasattr(inner, "numba_three_input_kernel"):
        kernel, first = inner.numba_three_input_kernel()
        return kernel, tuple(first)
    if isinstance(inner, DoubleRegulatedNets):
        return nets_control_kernel, (packed_net3(inner.flow), packed_net3(inner.torque), inner.blend_packed())
    if isinstance(inner, SyntheticBulb):
        return bulb_control_kernel, (inner.point_parameters(),)
    return None, ()


# ---------------------------------------------------------------------------------------------------------------
# the cam
# ---------------------------------------------------------------------------------------------------------------
class Cam:
    """The on-cam relation phi(a, H) as a table: ``openings`` (na,) in plant chart units (from the closed vane),
    ``heads_m`` (nh,), ``angles_deg`` (nh, na). Linear in the head between rows, then linear in the opening
    (:func:`simulate.components.schedules.piecewise_linear`); held constant beyond the table's edges."""

    def __init__(self, openings, heads_m, angles_deg, *, source: str):
        self.openings = np.asarray(openings, dtype=float)
        self.heads_m = np.asarray(heads_m, dtype=float)
        self.angles_deg = np.asarray(angles_deg, dtype=float).reshape(self.heads_m.size, self.openings.size)
        self.source = source

    def slice(self, head_m: float) -> np.ndarray:
        """The angles (na,) at ``head_m`` (linear between the two bracketing rows, clamped)."""
        heads, rows = self.heads_m, self.angles_deg
        if heads.size == 1 or head_m <= heads[0]:
            return rows[0].copy()
        if head_m >= heads[-1]:
            return rows[-1].copy()
        i = int(np.searchsorted(heads, head_m, side="right"))
        t = (head_m - heads[i - 1]) / (heads[i] - heads[i - 1])
        return rows[i - 1] + t * (rows[i] - rows[i - 1])

    def angle(self, opening: float, head_m: float) -> float:
        """phi(a, H), deg: the slice at ``head_m`` read at ``opening`` (the loop's arithmetic)."""
        from simulate.components.schedules import piecewise_linear

        return float(piecewise_linear.py_func(self.openings, self.slice(float(head_m)), float(opening)))


def cam_from_characteristics(inner, *, opening_at_zero_stroke: float, opening_max: float, speed_rpm: float,
                             runner_diameter_m: float, rated_head_m: float, blade_range_deg,
                             opening_range=None) -> Cam:
    """The cam of best efficiency of ``inner`` (:func:`hillchart.fccm.double_regulated.on_cam_relation`, eq. (2) of
    the tubular-turbine paper for N11) over the characteristics' opening range (``opening_range`` in the
    characteristics' units; default: the guide-vane range of the table the nets were trained on (``training.
    measured_box``), else the nets' fitted box, or the whole stroke) and heads
    :data:`CAM_HEAD_FRACTIONS` of the rated head."""
    from hillchart.fccm.double_regulated import on_cam_relation

    training = getattr(inner, "training", None)
    measured_box = training.get("measured_box") if isinstance(training, dict) else None
    if opening_range is None and isinstance(measured_box, dict) and "opening" in measured_box:
        opening_range = tuple(float(v) for v in measured_box["opening"])  # the table's, not the extension's
    if opening_range is None:
        flow = getattr(inner, "flow", None)
        if flow is not None and hasattr(flow, "x_min"):
            opening_range = (float(flow.x_min[1]), float(flow.x_max[1]))
        else:
            from hillchart.synthetic.bulb import GUIDE_VANE_RANGE_DEG, SyntheticBulb

            opening_range = GUIDE_VANE_RANGE_DEG if isinstance(inner, SyntheticBulb) else (
                opening_at_zero_stroke, opening_at_zero_stroke + opening_max)
    lo = max(opening_range[0], opening_at_zero_stroke + 1e-3 * opening_max)
    hi = min(opening_range[1], opening_at_zero_stroke + opening_max)
    if not hi > lo:
        raise InputError(f"combinator: the characteristics' opening range {list(opening_range)} does not overlap the "
                         f"stroke [{opening_at_zero_stroke:g}, {opening_at_zero_stroke + opening_max:g}] "
                         f"(combinator.opening_at_zero_stroke + turbine.opening_max)")
    openings = np.linspace(lo, hi, CAM_OPENINGS)
    heads = rated_head_m * np.asarray(CAM_HEAD_FRACTIONS)
    efficiency = getattr(inner, "efficiency", None) or getattr(inner, "unit_efficiency")
    kernel, first = _inner_kernel(inner)
    if kernel is nets_control_kernel:  # the nets through the loop's compiled point function: 10x numpy's predict
        def efficiency(n11, opening, blade):
            n11, opening, blade = np.broadcast_arrays(*(np.asarray(v, float) for v in (n11, opening, blade)))
            out = np.empty(n11.shape)
            _nets_efficiency(first[0], first[1], first[2], np.ascontiguousarray(n11).ravel(),
                             np.ascontiguousarray(opening).ravel(), np.ascontiguousarray(blade).ravel(), out.ravel())
            return out
    # a coarse scan finds the hump, a golden-section search on the scan step around it the optimum
    cam = on_cam_relation(efficiency, openings, heads, speed_rpm=speed_rpm, runner_diameter_m=runner_diameter_m,
                          blade_range=tuple(blade_range_deg), step_deg=CAM_SCAN_STEP_DEG)
    n11 = np.broadcast_to(unit_speed(speed_rpm, heads, runner_diameter_m)[:, None], cam["blade_angle"].shape)
    a = np.broadcast_to(openings[None, :], n11.shape)
    low = np.clip(cam["blade_angle"] - CAM_SCAN_STEP_DEG, blade_range_deg[0], blade_range_deg[1])
    high = np.clip(cam["blade_angle"] + CAM_SCAN_STEP_DEG, blade_range_deg[0], blade_range_deg[1])
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = high - ratio * (high - low), low + ratio * (high - low)
    f1, f2 = efficiency(n11, a, x1), efficiency(n11, a, x2)
    for _ in range(40):  # 0.618^40 of the bracket: 1e-8 deg
        left = f1 > f2
        high, low = np.where(left, x2, high), np.where(left, low, x1)
        new = np.where(left, high - ratio * (high - low), low + ratio * (high - low))
        f_new = efficiency(n11, a, new)
        x1, x2, f1, f2 = (np.where(left, new, x2), np.where(left, x1, new), np.where(left, f_new, f2),
                          np.where(left, f1, f_new))
    best = np.where(cam["at_bound"] | cam["held"], cam["blade_angle"], 0.5 * (low + high))
    return Cam(openings - opening_at_zero_stroke, heads, best, source="best efficiency of the characteristics")


# ---------------------------------------------------------------------------------------------------------------
# the plant's view
# ---------------------------------------------------------------------------------------------------------------
class DoubleRegulatedTurbine:
    """Three-input characteristics seen from the plant (module docstring).

    Parameters
    ----------
    inner : object with ``q11(n11, opening, blade_angle)``, ``m11(...)`` (e.g.
        :class:`hillchart.fccm.double_regulated.DoubleRegulatedNets`, :class:`hillchart.synthetic.bulb.SyntheticBulb`)
    opening_at_zero_stroke : float
        The characteristics' opening at the closed vane (their units).
    angle_min_deg, angle_max_deg : float
        Blade angles at zero and full blade stroke.
    cam : Cam or None
        None: the blades are fixed at ``fixed_angle_deg``.
    speed_rpm, runner_diameter_m : float
        For the cam's head ``H = (n D1 / N11)^2``.
    """

    def __init__(self, inner, *, opening_at_zero_stroke: float, angle_min_deg: float, angle_max_deg: float,
                 cam: Cam | None, fixed_angle_deg: float | None, speed_rpm: float, runner_diameter_m: float):
        if cam is None and fixed_angle_deg is None:
            raise InputError("combinator: blades without a cam need combinator.fixed_angle_deg")
        self.inner = inner
        self.opening_at_zero_stroke = float(opening_at_zero_stroke)
        self.angle_min_deg, self.angle_max_deg = float(angle_min_deg), float(angle_max_deg)
        self.cam, self.fixed_angle_deg = cam, fixed_angle_deg
        self.speed_rpm, self.runner_diameter_m = float(speed_rpm), float(runner_diameter_m)
        self._kernel = _inner_kernel(inner)
        self.cam_warning = None  # set by the plant's view when the nets' cam and their fitted model's disagree
        #: the plant's opening: the guide-vane angle above its closed position (hill charts and reports label it)
        self.opening_unit = "deg above the closed vane"
        # the nets' fitted box in the plant's units, for the trusted domain (simulate.loop.domain reads
        # flow/torque.x_min, x_max: N11 and the opening); the blade angle's range: blade_range_deg
        # (nets trained down to the closed vane, within 1e-3 deg, count as trained there); the nets were fitted on a
        # box, so the digitized region is that box in (N11, opening), or the test table's box when the nets were
        # extended beyond it (training.measured_box)
        self.blade_range_deg = None
        for name in ("flow", "torque"):
            net = getattr(inner, name, None)
            if net is not None and hasattr(net, "x_min") and len(net.x_min) == 3:
                lo = np.asarray(net.x_min[:2], float) - np.array([0.0, self.opening_at_zero_stroke])
                hi = np.asarray(net.x_max[:2], float) - np.array([0.0, self.opening_at_zero_stroke])
                if abs(lo[1]) < 1e-3:
                    lo[1] = 0.0
                setattr(self, name, SimpleNamespace(x_min=lo, x_max=hi))
                self.blade_range_deg = (float(net.x_min[2]), float(net.x_max[2]))
        if self.blade_range_deg is not None:
            lo, hi = self.flow.x_min, self.flow.x_max
            training = getattr(inner, "training", None)
            box = training.get("measured_box") if isinstance(training, dict) else None
            if isinstance(box, dict) and {"n11", "opening"} <= set(box):  # the test table's own box, not the extension
                lo = np.array([box["n11"][0], box["opening"][0] - self.opening_at_zero_stroke])
                hi = np.array([box["n11"][1], box["opening"][1] - self.opening_at_zero_stroke])
            self.digitized_region = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])

    @property
    def angle_span_deg(self) -> float:
        return self.angle_max_deg - self.angle_min_deg

    def blade_stroke(self, angle_deg: float) -> float:
        """Blade stroke fraction of ``angle_deg``."""
        return (float(angle_deg) - self.angle_min_deg) / self.angle_span_deg

    def blade_angle(self, n11, opening):
        """Where the combinator puts the blades at unit speed ``n11`` and plant opening ``opening`` (deg)."""
        n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
        if self.cam is None:
            return np.full(n11.shape, float(self.fixed_angle_deg))
        heads = (self.speed_rpm * self.runner_diameter_m / n11) ** 2  # eq. (2), tubular-turbine paper
        out = np.array([self.cam.angle(a, h) for a, h in zip(opening.ravel(), heads.ravel())])
        return out.reshape(n11.shape)

    def three_input(self, n11, opening, blade_angle):
        """(q11, m11) of the characteristics at plant opening ``opening`` and blade angle (deg): through the loop's
        compiled kernel where there is one (the same arithmetic as the time loop, so the steady state is the loop's
        equilibrium), else the characteristics' own methods."""
        kernel, first = self._kernel
        if kernel is None:
            a = np.asarray(opening, float) + self.opening_at_zero_stroke
            return self.inner.q11(n11, a, blade_angle), self.inner.m11(n11, a, blade_angle)
        params = first + (np.array([self.opening_at_zero_stroke, self.angle_min_deg, self.angle_span_deg]),)
        n11, opening, blade_angle = np.broadcast_arrays(*(np.asarray(v, float) for v in (n11, opening, blade_angle)))
        q, m = np.empty(n11.shape), np.empty(n11.shape)
        controls = np.zeros(2)
        for i, (n, a, phi) in enumerate(zip(n11.ravel(), opening.ravel(), blade_angle.ravel())):
            controls[0], controls[1] = a, self.blade_stroke(phi)
            out = kernel(params, float(n), controls)
            q.flat[i], m.flat[i] = out[0], out[2]
        return q, m

    def steady_kernel(self):
        """``(kernel, params)`` for the steady state (:func:`simulate.loop.steady.steady_state` reads values only):
        ``kernel(params, n11, opening) -> (q11, nan, nan, m11, nan, nan)`` with the blades where the combinator puts
        them, one call of the loop's compiled kernel a point (the derivatives along the combinator are
        :meth:`q11_grad` / :meth:`m11_grad`)."""
        kernel, first = self._kernel
        if kernel is None:
            def values(params, n11, opening):
                phi = self.blade_angle(n11, opening)
                q, m = self.three_input(n11, opening, phi)
                return float(q), math.nan, math.nan, float(m), math.nan, math.nan

            return values, ()
        kparams = first + (np.array([self.opening_at_zero_stroke, self.angle_min_deg, self.angle_span_deg]),)
        controls = np.zeros(2)
        cam, fixed = self.cam, self.fixed_angle_deg
        nd = self.speed_rpm * self.runner_diameter_m

        def values(params, n11, opening):
            phi = float(fixed) if cam is None else cam.angle(opening, (nd / n11) ** 2)  # eq. (2), H from N11
            controls[0], controls[1] = opening, self.blade_stroke(phi)
            q, _, m, _ = kernel(kparams, float(n11), controls)
            return q, math.nan, math.nan, m, math.nan, math.nan

        return values, ()

    # two-input methods: the blades where the combinator puts them ------------------------------------------
    def q11(self, n11, opening):
        return self.three_input(n11, opening, self.blade_angle(n11, opening))[0]

    def m11(self, n11, opening):
        return self.three_input(n11, opening, self.blade_angle(n11, opening))[1]

    def _grad(self, which: int, n11, opening):
        n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
        h_n = 1e-5 * np.maximum(np.abs(n11), 1.0)
        h_a = 1e-6 * np.maximum(np.abs(opening), 1.0)

        def f(n, a):
            return self.three_input(n, a, self.blade_angle(n, a))[which]

        return ((f(n11 + h_n, opening) - f(n11 - h_n, opening)) / (2 * h_n),
                (f(n11, opening + h_a) - f(n11, opening - h_a)) / (2 * h_a))

    def q11_grad(self, n11, opening):
        """(dQ11/dN11, dQ11/da) along the combinator, central differences (the cam is piecewise linear)."""
        return self._grad(0, n11, opening)

    def m11_grad(self, n11, opening):
        """(dM11/dN11, dM11/da) along the combinator, central differences."""
        return self._grad(1, n11, opening)

    def efficiency(self, n11, opening):
        from hillchart.characteristics import efficiency_from_unit_torque

        return efficiency_from_unit_torque(self.q11(n11, opening), n11, self.m11(n11, opening))

    def numba_control_flow_kernel(self):
        """The flow half of :meth:`numba_control_kernel`, ``kernel(params, n11, controls) -> (q11, dq11/dn11)`` on
        the same params, or None when the characteristics have none (the loop then reads the full kernel)."""
        return nets_control_flow if self._kernel[0] is nets_control_kernel else None

    def numba_control_torque_kernel(self):
        """M11 of :meth:`numba_control_kernel` alone, ``kernel(params, n11, controls) -> m11`` on the same params,
        or None when the characteristics have none (the loop then reads the full kernel)."""
        return nets_control_torque if self._kernel[0] is nets_control_kernel else None

    def numba_control_kernel(self):
        """``(kernel, params)`` for the compiled loop on the chart controls ``[a, y_b]``."""
        kernel, first = self._kernel
        if kernel is None:
            raise InputError(f"three-input characteristics of type {type(self.inner).__name__} have no compiled "
                             f"kernel: use three-input nets (nets.json with inputs n11, opening, blade_angle) or "
                             f"\"synthetic-bulb\"")
        scal = np.array([self.opening_at_zero_stroke, self.angle_min_deg, self.angle_span_deg])
        return kernel, first + (scal,)


class FixedBladeBulb:
    """The exact synthetic bulb with its blades fixed at ``blade_angle_deg``, as two-input characteristics (plant
    opening counted from ``opening_at_zero_stroke``) with a compiled two-input kernel: today's path for a
    single-regulated unit, the reference of the double-regulated loop with the blades held."""

    def __init__(self, bulb, *, blade_angle_deg: float, opening_at_zero_stroke: float):
        self.bulb, self.blade_angle_deg = bulb, float(blade_angle_deg)
        self.opening_at_zero_stroke = float(opening_at_zero_stroke)

    def q11(self, n11, opening):
        return self.bulb.q11(n11, np.asarray(opening, float) + self.opening_at_zero_stroke, self.blade_angle_deg)

    def m11(self, n11, opening):
        return self.bulb.m11(n11, np.asarray(opening, float) + self.opening_at_zero_stroke, self.blade_angle_deg)

    def _grads(self, n11, opening):
        n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
        out = [bulb_fixed_blade_kernel.py_func(self.numba_kernel()[1], float(n), float(a))
               for n, a in zip(n11.ravel(), opening.ravel())]
        return np.array(out).reshape(n11.shape + (6,))

    def q11_grad(self, n11, opening):
        g = self._grads(n11, opening)
        return g[..., 1], g[..., 2]

    def m11_grad(self, n11, opening):
        g = self._grads(n11, opening)
        return g[..., 4], g[..., 5]

    def numba_kernel(self):
        return bulb_fixed_blade_kernel, (self.bulb.point_parameters(),
                                         np.array([self.opening_at_zero_stroke, self.blade_angle_deg]))


def plant_characteristics(plant, characteristics):
    """``characteristics`` as the plant uses them: three-input ones wrapped in :class:`DoubleRegulatedTurbine`
    (from ``[combinator]`` and ``[blade_servo]``); anything else unchanged.

    Raises
    ------
    InputError
        Three-input characteristics without ``[combinator]``, or ``[blade_servo]`` with two-input ones.
    """
    if isinstance(characteristics, DoubleRegulatedTurbine):
        return characteristics
    combinator = getattr(plant, "combinator", None)
    servo = getattr(plant, "blade_servo", None)
    if not is_three_input(characteristics):
        if combinator is not None or servo is not None:
            raise InputError(f"[combinator] and [blade_servo] need three-input characteristics (nets.json with inputs "
                             f"n11, opening, blade_angle, or \"synthetic-bulb\"); turbine.characteristics = "
                             f"{plant.turbine.characteristics!r} has two inputs")
        return characteristics
    if combinator is None:
        raise InputError(f"turbine.characteristics = {plant.turbine.characteristics!r} has a blade angle (three "
                         f"inputs): the plant needs a [combinator] section (relation = \"cam\", \"table\" or "
                         f"\"off\") and, unless the blades are fixed, a [blade_servo] section")
    return _wrap(plant, characteristics)


_CAMS: dict = {}


def _wrap(plant, inner) -> DoubleRegulatedTurbine:
    comb, servo, turbine = plant.combinator, plant.blade_servo, plant.turbine
    if comb.relation != "off" and servo is None:
        raise InputError(f"combinator.relation = {comb.relation!r} moves the blades: the plant needs a [blade_servo] "
                         f"section (servo_time_s, closing_time_s, opening_time_s, angle_min_deg, angle_max_deg)")
    if servo is not None:
        lo, hi = servo.angle_min_deg, servo.angle_max_deg
    else:  # blades fixed: the stroke fraction is read against a nominal range around the fixed angle
        lo, hi = comb.fixed_angle_deg - 1.0, comb.fixed_angle_deg + 1.0
    cam, cam_warning = None, None
    fitted = getattr(inner, "silent_model", None)  # nets from a test table carry the physical model fitted to it
    if comb.relation == "model" and fitted is None:
        raise InputError(f"combinator.relation = \"model\" takes the cam from the physical model fitted to the test "
                         f"table, which nets from hillsim fccm --simulator-nets carry (silent_model in nets.json); "
                         f"turbine.characteristics = {plant.turbine.characteristics!r} has none: use \"cam\" or "
                         f"\"table\"")
    if comb.relation in ("cam", "model"):
        # the cam depends on the characteristics' numbers, not on the object: the same nets read again (each run
        # of a study loads its nets.json) find their cam here; characteristics without a compiled kernel by object
        kernel, first = _inner_kernel(inner)
        content = (kernel, tuple(np.asarray(v).tobytes() for v in first)) if kernel is not None else (id(inner),)
        key = content + (comb.relation, comb.opening_at_zero_stroke, turbine.opening_max, turbine.rated_speed_rpm,
                         turbine.runner_diameter_m, turbine.rated_head_m, lo, hi)
        entry = _CAMS.get(key)  # read once: ensemble members run on threads, each may replace the entry
        if entry is None or (kernel is None and entry[0] is not inner):
            entry = (inner if kernel is None else None, *_cams(inner, fitted, comb, turbine, (lo, hi)))
            _CAMS.clear()  # one plant at a time; keeps the cache from holding characteristics alive
            _CAMS[key] = entry
        cam, cam_warning = entry[1:]
    elif comb.relation == "table":
        cam = Cam(np.asarray(comb.table_openings, float) - comb.opening_at_zero_stroke, comb.table_heads_m,
                  comb.table_angles_deg, source="the combinator table of the plant file")
    view = DoubleRegulatedTurbine(inner, opening_at_zero_stroke=comb.opening_at_zero_stroke, angle_min_deg=lo,
                                  angle_max_deg=hi, cam=cam, fixed_angle_deg=comb.fixed_angle_deg,
                                  speed_rpm=turbine.rated_speed_rpm, runner_diameter_m=turbine.runner_diameter_m)
    view.cam_warning = cam_warning
    return view


#: Largest difference (deg) between the cam of the nets and that of the physical model fitted to their test table
#: before a run warns, compared above the lowest :data:`CAM_COMPARE_FROM` of the cam's opening range (near the closed
#: vane the efficiency, and which blade angle is best, means little): the efficiency is flat in the blade angle near
#: its optimum, so the nets' misfit of a few tenths of a percent can move their cam by degrees (nets of the
#: characteristics themselves from 150-point synthetic tables: 2.8-7.9 deg, where the model's cam is within 0.2 deg of
#: the truth, and a rejection's speed rise 3-54 points off on the nets' cam), and the initial opening and the
#: overspeed with it. The shipped bulb nets (2000 exact samples) differ by up to 0.94 deg.
CAM_DISAGREEMENT_DEG = 1.5
CAM_COMPARE_FROM = 0.1


def _cams(inner, fitted, comb, turbine, blade_range) -> tuple:
    """``(cam, warning)`` of ``combinator.relation`` "cam" (the characteristics') or "model" (the fitted model's);
    with a fitted model, the other cam is computed too and a warning says where the two differ by more than
    :data:`CAM_DISAGREEMENT_DEG`. Both are searched over the same openings (the test table's guide-vane range)."""
    kwargs = dict(opening_at_zero_stroke=comb.opening_at_zero_stroke, opening_max=turbine.opening_max,
                  speed_rpm=turbine.rated_speed_rpm, runner_diameter_m=turbine.runner_diameter_m,
                  rated_head_m=turbine.rated_head_m, blade_range_deg=blade_range)
    if fitted is None:
        return cam_from_characteristics(inner, **kwargs), None
    box = inner.training.get("measured_box", {}) if isinstance(getattr(inner, "training", None), dict) else {}
    opening_range = tuple(box["opening"]) if "opening" in box else None
    nets_cam = cam_from_characteristics(inner, opening_range=opening_range, **kwargs)
    model_cam = cam_from_characteristics(fitted, opening_range=opening_range, **kwargs)
    model_cam.source = "best efficiency of the physical model fitted to the test table"
    span = nets_cam.openings[-1] - nets_cam.openings[0]
    compared = nets_cam.openings >= nets_cam.openings[0] + CAM_COMPARE_FROM * span
    difference = np.where(compared[None, :], np.abs(nets_cam.angles_deg - model_cam.angles_deg), 0.0)
    warning = None
    if difference.max() > CAM_DISAGREEMENT_DEG:
        h, i = np.unravel_index(int(np.argmax(difference)), difference.shape)
        warning = (f"the cam of the nets and that of the physical model fitted to their test table differ by up to "
                   f"{difference.max():.1f} deg (at the guide-vane angle "
                   f"{nets_cam.openings[i] + comb.opening_at_zero_stroke:.4g} deg and {nets_cam.heads_m[h]:.4g} m): "
                   "the efficiency is flat in the blade angle near its optimum and the table does not fix it; "
                   + ("the run uses the nets' (combinator.relation = \"cam\"): set relation = \"model\" for the "
                      "fitted model's, or give the unit's measured cam (relation = \"table\")"
                      if comb.relation == "cam" else
                      "the run uses the model's (combinator.relation = \"model\"); a measured cam (relation = "
                      "\"table\") is better than either"))
    return (nets_cam if comb.relation == "cam" else model_cam), warning


__all__ = ["Cam", "DoubleRegulatedTurbine", "FixedBladeBulb", "cam_from_characteristics", "is_three_input",
           "plant_characteristics"]
