"""Four-quadrant characteristics on the Suter transform: pump-turbines and pumps in the simulator.

A kind of characteristics (:class:`simulate.components.turbine.kinds.CharacteristicKind`) that brings its own turbine
boundary. Three entries of :data:`simulate.components.registry.CHARACTERISTICS` read it:

* ``"suter-nets"``: a nets.json of Suter curves (format ``hillsim.suter_nets``, :class:`hillchart.four_quadrant.nets.
  SuterNets`), recognised by its content; the nets must record their rated unit point and full-stroke opening
  (``training.rated``, ``training.opening_max``, as the shipped nets of the synthetic pump-turbine do);
* ``"suter-curves"``: a JSON of tabulated curves (format ``hillsim.suter_curves``, :func:`write_suter_curves`), e.g.
  the Wylie-Streeter pump curves (:func:`wylie_streeter_pump_curves`);
* ``"synthetic-pump-turbine"``: the exact synthetic pump-turbine (:class:`hillchart.synthetic.pump_turbine.
  SyntheticPumpTurbine`), evaluated as a fine table of its plain Suter curves (:func:`exact_pump_turbine_curves`:
  0.5 deg in x, 0.25 mm in opening, interpolated bilinearly; the table is the model's own head and torque at each
  node, the model's equations are not copied).

Convention (hillsim's, turbine-positive, :mod:`hillchart.four_quadrant.suter`): speed n > 0 in turbine rotation,
flow Q > 0 in turbine flow, head H across the machine from the high- to the low-pressure side, torque M > 0 when the
water drives the runner in turbine rotation. Pump mode is n < 0, Q < 0, H > 0, M > 0 (the water brakes the negative
rotation, the motor holds it: the load torque is positive and the power M n negative). ``turbine.operating_mode =
"pump"`` starts the run in pump mode: the steady state at t = 0 is at n = -n_r.

Rated values: the characteristics carry their rated unit point (N11_r, Q11_r, M11_r: one turbine-mode point of the
table, or the pump's rated point for a pump) and the plant's runner diameter D1 and rated head H_r make the
relative quantities' bases n_r = N11_r sqrt(H_r) / D1, Q_r = Q11_r D1^2 sqrt(H_r), M_r = M11_r D1^3 H_r; the
plant's rated speed, flow and torque (P_r / omega_r) must agree with them to :data:`RATED_AGREEMENT`.

The steady state at t = 0 (:mod:`simulate.loop.steady`) reads the characteristics as Q11(N11, a), M11(N11, a)
(:meth:`SuterCharacteristics.numba_kernel`): at unit head the root of h = 1 with the largest flow in the speed's
direction (the normal operating branch; :func:`simulate.components.turbine.suter_kernels.unit_head_flow`). Every
step the boundary (:func:`build_suter_boundary`) solves H = C_L + k Q on the curves, walking the Suter angle
(:func:`simulate.components.turbine.suter_kernels.solve_shifted_flow`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numba
import numpy as np

from hillchart.characteristics import KernelCharacteristics
from hillchart.errors import InputError
from hillchart.four_quadrant.suter import PLAIN, SuterConstants
from simulate.components.registry import CompiledPart, PartHooks
from simulate.components.turbine.kinds import CharacteristicKind
from simulate.components.turbine.suter_kernels import (INVALID_POINT, NETS, NOT_BRACKETED, OPENING_OUTSIDE,
                                                       STATUS_TEXT, TABLE, TWO_PI, closed_vane_blend,
                                                       closed_vane_point, closed_vane_ratio, solve_shifted_flow,
                                                       suter_point, unit_head_flow, zero_flow_torque)

#: Largest relative difference between the plant's rated speed, flow and torque and those of the characteristics'
#: rated unit point at the plant's D1 and H_r.
RATED_AGREEMENT = 0.01
CURVES_FORMAT = "hillsim.suter_curves"
#: Angles of the steady state's scan over the speed's branch (:func:`unit_head_flow`).
STEADY_SCAN = 720
#: The boundary's tolerance on w (relative to 1 + |w|) and its Illinois iterations.
BOUNDARY_TOL, BOUNDARY_MAX_ITER = 1e-13, 200
_EMPTY2, _EMPTY1 = np.zeros((1, 1)), np.zeros(1)


def _net_arrays(net):
    """``(W1, vec)`` of an FCCMWeights net with one output, as :func:`simulate.components.turbine.suter_kernels._net`
    reads them."""
    vec = np.concatenate([net.b1, net.W2[0], net.b2, net.x_min, net.x_max, net.y_min, net.y_max]).astype(float)
    return np.ascontiguousarray(net.W1, dtype=float), vec


class SuterCharacteristics(KernelCharacteristics):
    """Four-quadrant characteristics: Suter curves (a table or nets), their transform, their rated unit point.

    Parameters
    ----------
    curves : tuple
        The curves' arrays as :func:`~simulate.components.turbine.suter_kernels.suter_curves` reads them
        (:meth:`from_table`, :meth:`from_nets`).
    rated : dict
        ``{"n11_rpm", "q11_m3_s", "m11_nm"}``: the rated unit point (the curves' v = q = h = m = 1).
    opening_max : float
        The characteristics' full-stroke opening (chart units): y = a / opening_max.
    name : str
    """

    def __init__(self, curves, *, rated: dict, opening_max: float, name: str):
        for key in ("n11_rpm", "q11_m3_s", "m11_nm"):
            value = rated.get(key) if isinstance(rated, dict) else None
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise InputError(f"{name}: rated.{key} must be a number > 0 (the rated unit point), got {value!r}")
        if not (isinstance(opening_max, (int, float)) and math.isfinite(opening_max) and opening_max > 0):
            raise InputError(f"{name}: opening_max must be a number > 0, got {opening_max!r}")
        self.curves = tuple(curves)
        self.rated = {k: float(rated[k]) for k in ("n11_rpm", "q11_m3_s", "m11_nm")}
        self.opening_max = float(opening_max)
        self.name = name
        self.params = (np.array([self.rated["n11_rpm"], self.rated["q11_m3_s"], self.rated["m11_nm"],
                                 self.opening_max, self.smallest_opening]),) + self.curves
        #: the :class:`hillchart.four_quadrant.nets.SuterNets` the curves are of (None for a table)
        self.nets = None

    @classmethod
    def from_table(cls, wh, wm, *, openings=None, constants: SuterConstants = PLAIN, **keywords):
        """Curves on a regular periodic x grid (columns: x_i = 2 pi i / nx) and regular relative openings
        ``openings`` (rows; None: one row, curves of x alone)."""
        wh, wm = np.atleast_2d(np.asarray(wh, float)), np.atleast_2d(np.asarray(wm, float))
        if wh.shape != wm.shape or wh.shape[1] < 8 or not (np.all(np.isfinite(wh)) and np.all(np.isfinite(wm))):
            raise InputError(f"Suter curve table: wh and wm must be finite arrays of one shape with >= 8 angles, got "
                             f"{wh.shape} and {wm.shape}")
        y0 = dy = 0.0
        if openings is None:
            if wh.shape[0] != 1:
                raise InputError(f"Suter curve table: {wh.shape[0]} rows need their openings")
        else:
            y = np.asarray(openings, float)
            if y.shape != (wh.shape[0],) or y.size < 2 or not np.allclose(np.diff(y), y[1] - y[0], rtol=1e-9) \
                    or y[1] <= y[0]:
                raise InputError("Suter curve table: openings must ascend evenly, one per row (at least two)")
            y0, dy = float(y[0]), float(y[1] - y[0])
        cs = np.array([TABLE, wh.shape[1], wh.shape[0], y0, dy, constants.k1, constants.k2, constants.c_h,
                       constants.c_y, 0.0])
        return cls((cs, np.ascontiguousarray(wh), np.ascontiguousarray(wm), _EMPTY2, _EMPTY2, _EMPTY1, _EMPTY1),
                   **keywords)

    @classmethod
    def from_nets(cls, nets, **keywords):
        """From :class:`hillchart.four_quadrant.nets.SuterNets` in the turbine convention."""
        if nets.convention != "turbine":
            raise InputError(f"{keywords.get('name', 'Suter nets')}: convention must be 'turbine' for the simulator, "
                             f"got {nets.convention!r}")
        c = nets.constants
        (w1h, vh), (w1m, vm) = _net_arrays(nets.wh), _net_arrays(nets.wm)
        cs = np.array([NETS, 0.0, 0.0, 0.0, 0.0, c.k1, c.k2, c.c_h, c.c_y, float(w1h.shape[1])])
        out = cls((cs, _EMPTY2, _EMPTY2, w1h, w1m, vh, vm), **keywords)
        out.nets = nets
        return out

    @property
    def smallest_opening(self) -> float:
        """The smallest relative opening the curves were made from (a table's first row; the nets' smallest
        training opening), below which the guide vanes close on the closed-vane model (:func:`simulate.components.
        turbine.suter_kernels.closed_vane_point`); 0 for curves of x alone (a pump without vanes)."""
        cs, w1h, w1m, vh, vm = self.curves[0], self.curves[3], self.curves[4], self.curves[5], self.curves[6]
        if cs[0] == TABLE:
            return float(cs[3]) if int(cs[2]) > 1 else 0.0
        floors = []
        for w1, vec in ((w1h, vh), (w1m, vm)):
            hidden, n_in = w1.shape
            if n_in == 3:
                floors.append(float(vec[2 * hidden + 1 + 2]))  # x_min of the opening input (_net's layout)
        return max(floors, default=0.0)

    def members(self) -> list["SuterCharacteristics"]:
        """The ensemble members of the nets (:attr:`hillchart.four_quadrant.nets.SuterNets.members`), each as
        characteristics with the same transform, rated unit point and opening (empty for a table or nets without
        an ensemble): what ``run --uncertainty`` runs once each."""
        from hillchart.four_quadrant.nets import SuterNets

        if self.nets is None:
            return []
        out = []
        for i, (wh, wm) in enumerate(self.nets.members):
            member = SuterNets(wh, wm, constants=self.nets.constants, convention=self.nets.convention,
                               training=self.nets.training)
            out.append(SuterCharacteristics.from_nets(member, rated=self.rated, opening_max=self.opening_max,
                                                      name=f"{self.name} member {i}"))
        return out

    # the curves and the point, for Python callers (tests, the steady state's checks) --------------------------
    def curve_values(self, x, opening) -> tuple[np.ndarray, np.ndarray]:
        """WH and WM at angles x (radians, turbine axis) and relative openings (arrays broadcast)."""
        from simulate.components.turbine.suter_kernels import suter_curves

        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(opening, float))
        out = np.array([suter_curves(*self.curves, a, b)[:2] for a, b in zip(x.ravel(), y.ravel())])
        return out[:, 0].reshape(x.shape), out[:, 1].reshape(x.shape)

    def numba_kernel(self):
        """``(kernel, params)``: Q11, M11 at (N11, a) on the normal operating branch at unit head
        (:func:`suter_unit_kernel`), with central-difference derivatives; the Python methods are
        :class:`hillchart.characteristics.KernelCharacteristics`'."""
        return suter_unit_kernel, self.params


@numba.njit(cache=True)
def _unit_point(params, n11, opening):
    """Q11, M11 at unit head; below the smallest opening on the closed-vane model (:func:`simulate.components.
    turbine.suter_kernels.closed_vane_point`): the flow at the smallest opening scaled, the torque blended."""
    scal = params[0]
    v, y, y_floor = n11 / scal[0], opening / scal[3], scal[4]
    r = closed_vane_ratio(y, y_floor)
    m0 = 0.0
    if r < 1.0:
        y = y_floor
        m0, st = zero_flow_torque(params[1], params[2], params[3], params[4], params[5], params[6], params[7], v, y)
        if st != 0:
            return np.nan, np.nan
        if r == 0.0:
            return 0.0, m0 * scal[2]
    q, m, ok = unit_head_flow(params[1], params[2], params[3], params[4], params[5], params[6], params[7], v, y,
                              STEADY_SCAN)
    if not ok:
        return np.nan, np.nan
    q, m = closed_vane_blend(r, q, m, m0)
    return q * scal[1], m * scal[2]


@numba.njit(cache=True)
def suter_unit_kernel(params, n11, opening):
    """``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` at unit head on the normal operating branch (module
    docstring); derivatives by central differences of 1e-6 N11_r and 1e-6 of the full-stroke opening; NaN where the
    branch has no point at unit head (v = 0, or the curves give none)."""
    scal = params[0]
    q, m = _unit_point(params, n11, opening)
    dn, da = 1e-6 * scal[0], 1e-6 * scal[3]
    qp, mp = _unit_point(params, n11 + dn, opening)
    qm, mm = _unit_point(params, n11 - dn, opening)
    qa, ma = _unit_point(params, n11, opening + da)
    qb, mb = _unit_point(params, n11, opening - da)
    return (q, (qp - qm) / (2 * dn), (qa - qb) / (2 * da), m, (mp - mm) / (2 * dn), (ma - mb) / (2 * da))


# ---------------------------------------------------------------------------------------------------------------
# The turbine boundary (a unit's part of kind "turbine"; simulate.components.turbine.component.BOUNDARY_ROLES)
# ---------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def suter_step(p, s, c_l_m, k, speed_rpm, controls, diag):
    """Head, flow and torque against H = C_L + k Q (k <= 0, m per m^3/s) at the speed and the guide-vane stroke
    ``controls[0]``: the shifted flow w next to the last step's (state ``s[0][3]``) by
    :func:`~simulate.components.turbine.suter_kernels.solve_shifted_flow`; below the curves' smallest opening on
    the closed-vane model (:func:`~simulate.components.turbine.suter_kernels.closed_vane_point`: the smallest
    opening's curves with the head relation's slope scaled by r = y / y_f). ``p[0]``: H_r, Q_r, n_r, M_r, the
    relative opening per unit of stroke, y_f. On failure ``diag[1:7]`` holds v, y, C_L, k, the last w, q."""
    b = p[0]
    h_r, q_r, n_r, m_r, y_floor = b[0], b[1], b[2], b[3], b[5]
    v = speed_rpm / n_r
    y = controls[0] * b[4]
    r = closed_vane_ratio(y, y_floor)
    state = s[0]
    w, status, iterations = solve_shifted_flow(p[1], p[2], p[3], p[4], p[5], p[6], p[7], v, y_floor if r < 1.0 else y,
                                               c_l_m / h_r, r * k * q_r / h_r, state[3], BOUNDARY_TOL,
                                               BOUNDARY_MAX_ITER)
    if r < 1.0:
        q, h, m, st = closed_vane_point(p[1], p[2], p[3], p[4], p[5], p[6], p[7], w, v, y_floor, r)
    else:
        q, h, m, st = suter_point(p[1], p[2], p[3], p[4], p[5], p[6], p[7], w, v, y)
    if status == 0 and st != 0:
        status = st
    if status != 0:
        diag[1], diag[2], diag[3], diag[4], diag[5], diag[6] = v, y, c_l_m, k, w, q
        return status, iterations
    state[0] = c_l_m + k * q * q_r  # the conduit's head at this flow: h H_r to the tolerance on w
    state[1] = q * q_r
    state[2] = m * m_r
    state[3] = w
    return 0, iterations


@numba.njit(cache=True)
def suter_signals(p, s):
    return s[0][0], s[0][1], s[0][2]


#: What to change when the boundary's step fails with a status (:func:`suter_step_failure`).
STEP_ADVICE = {
    OPENING_OUTSIDE: "the curves end at their largest opening: keep the guide-vane stroke at or below it "
                     "(turbine.opening_max against the opening of the curves' full stroke, governor.stroke_max)",
    INVALID_POINT: "the curves give no finite positive head there (nets far from the points they were trained on "
                   "can): give curves that cover the point, e.g. a table with more points near it, or keep the "
                   "run away from it",
    NOT_BRACKETED: "the operating point left the curves' branch it was on: a smaller step (more penstock reaches) "
                   "follows a fast change; check the curves are continuous in the Suter angle there",
}


def suter_step_failure(status: int, diag, conduit: str) -> tuple[str, str]:
    """The boundary's own words for a failed step (:attr:`simulate.components.registry.PartHooks.step_failure`),
    with what to change (:data:`STEP_ADVICE`)."""
    advice = STEP_ADVICE.get(status)
    return (f"the four-quadrant boundary {STATUS_TEXT.get(status, f'failed (status {status})')}",
            f"speed v = {diag[1]:.6g} of n_r, opening y = {diag[2]:.6g}, {conduit} relation H = {diag[3]:.6g} + "
            f"({diag[4]:.6g}) Q, last shifted flow w = {diag[5]:.6g} (q = {diag[6]:.6g} of Q_r)"
            + (f"; {advice}" if advice else ""))


def rated_bases(characteristics: SuterCharacteristics, turbine) -> tuple[float, float, float, float]:
    """``(H_r, Q_r, n_r, M_r)``: the bases of the relative quantities from the rated unit point and the plant's D1
    and H_r (module docstring), checked against the plant's rated speed, flow and torque."""
    d1, h_r = turbine.runner_diameter_m, turbine.rated_head_m
    r = characteristics.rated
    n_r = r["n11_rpm"] * math.sqrt(h_r) / d1
    q_r = r["q11_m3_s"] * d1 * d1 * math.sqrt(h_r)
    m_r = r["m11_nm"] * d1 ** 3 * h_r
    for key, ours, theirs in (("rated_speed_rpm", n_r, turbine.rated_speed_rpm),
                              ("rated_flow_m3_s", q_r, turbine.rated_flow_m3_s),
                              ("rated_power_mw (the torque P_r / omega_r)", m_r, turbine.rated_torque_nm)):
        if abs(theirs / ours - 1.0) > RATED_AGREEMENT:
            raise InputError(f"turbine.{key}: the characteristics {characteristics.name!r} have their rated unit "
                             f"point N11 {r['n11_rpm']:.6g} r/min, Q11 {r['q11_m3_s']:.6g} m^3/s, M11 "
                             f"{r['m11_nm']:.6g} N*m, which at D1 = {d1:g} m and H_r = {h_r:g} m is {ours:.6g}; the "
                             f"plant gives {theirs:.6g}, more than {100 * RATED_AGREEMENT:g} % off: make the rated "
                             f"values agree")
    return h_r, q_r, n_r, m_r


#: The ``[solver]`` keys of the Q11/N11 pressure loop, which the four-quadrant boundary does not read.
PRESSURE_LOOP_KEYS = ("pressure_loop", "tolerance", "max_iterations", "relaxation", "fallback")


def refuse_pressure_loop_keys(solver) -> None:
    """:class:`InputError` naming a ``[solver]`` key of the pressure loop set to other than its default: the
    four-quadrant boundary solves its own equation to its own tolerance (:data:`BOUNDARY_TOL` on the shifted flow,
    at most :data:`BOUNDARY_MAX_ITER` Illinois iterations), so the key would be accepted and ignored."""
    from dataclasses import fields

    for f in fields(solver):
        if f.name in PRESSURE_LOOP_KEYS and getattr(solver, f.name) != f.default:
            raise InputError(f"solver.{f.name} = {getattr(solver, f.name)!r} sets the Q11/N11 pressure loop; the "
                             f"four-quadrant boundary solves on its Suter curves to its own tolerance "
                             f"({BOUNDARY_TOL:g} on the shifted flow, at most {BOUNDARY_MAX_ITER} iterations) and "
                             f"would ignore it: remove the key")


def initial_shifted_flow(chars: SuterCharacteristics, steady, scal) -> float:
    """The shifted flow w of the steady state (relative; ``scal`` as :func:`build_suter_boundary` makes it): at or
    above the smallest opening q + k2 sqrt(h); below it the smallest opening's w of the flow q / r; with the vanes
    closed (r = 0, no flow) the smallest opening's w that gives the head at the speed, on the side of turbine flow
    (the way the water would go if the vanes opened), solved as the boundary solves."""
    k2 = float(chars.curves[0][6])
    q0, h0 = steady.flow_m3_s / scal[1], steady.head_m / scal[0]
    y, y_floor = steady.stroke * scal[4], scal[5]
    r = closed_vane_ratio(y, y_floor)
    if r > 0.0:
        return q0 / r + k2 * math.sqrt(max(h0, 0.0))
    guess = (1.0 + k2) * math.sqrt(max(h0, 0.0))
    w, status, _ = solve_shifted_flow(*chars.curves, steady.speed_rpm / scal[2], y_floor, h0, 0.0, guess,
                                      BOUNDARY_TOL, BOUNDARY_MAX_ITER)
    if status != 0:
        raise InputError(f"{chars.name}: with the guide vanes closed the curves at their smallest opening "
                         f"{y_floor:.6g} give no point at the steady head {steady.head_m:.6g} m and speed "
                         f"{steady.speed_rpm:.6g} r/min ({STATUS_TEXT.get(status, status)}): give curves that "
                         f"cover that point, or start with the vanes open")
    return float(w)


def build_suter_boundary(inputs) -> CompiledPart:
    """The four-quadrant boundary of one unit (``inputs``: :class:`simulate.components.turbine.component.
    BoundaryInputs`), started from its steady state."""
    chars = inputs.characteristics
    if not isinstance(chars, SuterCharacteristics):
        raise TypeError(f"the four-quadrant boundary needs SuterCharacteristics, got {type(chars).__name__}")
    refuse_pressure_loop_keys(inputs.solver)
    turbine, steady = inputs.turbine, inputs.steady
    h_r, q_r, n_r, m_r = rated_bases(chars, turbine)
    scal = np.array([h_r, q_r, n_r, m_r, turbine.opening_max / chars.opening_max, chars.smallest_opening])
    w0 = initial_shifted_flow(chars, steady, scal)
    return CompiledPart(kind="turbine", name="four-quadrant", functions={"step": suter_step, "signals": suter_signals},
                        params=(scal,) + chars.curves,
                        state=(np.array([steady.head_m, steady.flow_m3_s, steady.torque_nm, w0]),),
                        hooks=PartHooks(step_failure=suter_step_failure,
                                        summary={"pressure_loop": "none (four-quadrant boundary)"}))


# ---------------------------------------------------------------------------------------------------------------
# Where the curves come from: tables, nets, the exact synthetic pump-turbine
# ---------------------------------------------------------------------------------------------------------------
def write_suter_curves(path, *, x_rad, wh, wm, rated: dict, opening_max: float = 1.0, openings=None,
                       name: str = "Suter curves") -> Path:
    """Write tabulated plain Suter curves, turbine convention, as JSON (format :data:`CURVES_FORMAT`): ``x_rad``
    the regular periodic grid 2 pi i / nx, ``wh``, ``wm`` of shape (nx,) or (len(openings), nx)."""
    doc = {"format": CURVES_FORMAT, "version": 1, "name": name, "convention": "turbine",
           "x_rad": list(map(float, x_rad)),
           "openings": None if openings is None else list(map(float, openings)),
           "wh": np.asarray(wh, float).tolist(), "wm": np.asarray(wm, float).tolist(), "rated": dict(rated),
           "opening_max": float(opening_max)}
    path = Path(path)
    path.write_text(json.dumps(doc, allow_nan=False) + "\n", encoding="utf-8")
    return path


def read_suter_curves(document, path) -> SuterCharacteristics:
    """:class:`SuterCharacteristics` of a :data:`CURVES_FORMAT` document read from ``path`` (for messages)."""
    keys = ("format", "version", "name", "convention", "x_rad", "openings", "wh", "wm", "rated", "opening_max")
    missing = [k for k in keys if k not in document]
    if missing:
        raise InputError(f"{path}: keys {missing} are missing; a Suter curves file holds {list(keys)}")
    if document["convention"] != "turbine" or document["version"] != 1:
        raise InputError(f"{path}: convention must be 'turbine' and version 1, got {document['convention']!r} and "
                         f"{document['version']!r}")
    x = np.asarray(document["x_rad"], float)
    if x.ndim != 1 or x.size < 8 or not np.allclose(x, TWO_PI * np.arange(x.size) / x.size, atol=1e-9):
        raise InputError(f"{path}: x_rad must be the periodic grid 2 pi i / nx (nx >= 8), got {x.size} values "
                         f"from {x[:1]} ")
    try:
        return SuterCharacteristics.from_table(document["wh"], document["wm"], openings=document["openings"],
                                               rated=document["rated"], opening_max=document["opening_max"],
                                               name=str(document["name"]))
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def wylie_streeter_pump_curves(path, pump: str = "radial") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(x, WH, WM)`` of one pump of a Wylie-Streeter table (:func:`hillchart.four_quadrant.table.
    load_wylie_streeter_curves`) on the turbine convention's axis, x = (x_ws + pi) mod 2 pi (WH and WB = WM are the
    same in both conventions), on the table's own regular grid without its end point 2 pi (= 0)."""
    from hillchart.four_quadrant.table import load_wylie_streeter_curves

    pumps = load_wylie_streeter_curves(path)
    if pump not in pumps:
        raise InputError(f"{path}: no pump {pump!r}; it holds {list(pumps)}")
    c = pumps[pump]
    nx = c.x.size - 1
    if not np.allclose(c.x, TWO_PI * np.arange(nx + 1) / nx, atol=1e-6) or nx % 2:
        raise InputError(f"{path}: x_rad must be an even number of equal steps over [0, 2 pi] to shift by pi")
    shift = nx // 2  # x_turbine = x_ws + pi: index i of the turbine axis is index i - nx/2 of the table's
    return TWO_PI * np.arange(nx) / nx, np.roll(c.wh[:-1], shift), np.roll(c.wb[:-1], shift)


#: The table of the exact synthetic pump-turbine's plain curves: angles, and openings (mm) from 1 mm to full stroke.
EXACT_ANGLES = 720
EXACT_OPENINGS_MM = np.arange(1.0, 28.0 + 1e-9, 0.25)


def exact_pump_turbine_curves(turbine=None, *, angles: int = EXACT_ANGLES, openings_mm=EXACT_OPENINGS_MM):
    """``(WH, WM)`` of the exact synthetic pump-turbine's plain Suter curves on ``angles`` x values 2 pi i / angles
    and the openings (rows), relative to the rated unit point of the shipped table: at x the direction (v, q) =
    (-cos x, -sin x) (x = pi + atan2(q, v)), and the model's head and torque are homogeneous of degree 2 in (n, Q),
    so WH = H(-N11_r cos x, -Q11_r sin x, a) / 1 m and WM = M(...) / M11_r (q^2 + v^2 = 1)."""
    from hillchart.synthetic.pump_turbine import SyntheticPumpTurbine

    turbine = turbine or SyntheticPumpTurbine()
    rated = pump_turbine_rated()
    x = TWO_PI * np.arange(angles) / angles
    a = np.asarray(openings_mm, float)[:, None]
    head, torque = turbine.head_torque(-rated["n11_rpm"] * np.cos(x)[None, :], -rated["q11_m3_s"] * np.sin(x)[None, :],
                                       a)
    return head, torque / rated["m11_nm"]


def pump_turbine_rated() -> dict:
    """The rated unit point of the shipped synthetic pump-turbine table (data_synthetic/pump_turbine/table.toml)."""
    import importlib.resources as ir
    import tomllib

    doc = tomllib.loads((ir.files("data_synthetic") / "pump_turbine" / "table.toml").read_text(encoding="utf-8"))
    return {"n11_rpm": doc["rated_n11_rpm"], "q11_m3_s": doc["rated_q11"], "m11_nm": doc["rated_m11_nm"]}


def characteristics_of_nets(nets, name: str) -> SuterCharacteristics:
    """:class:`SuterCharacteristics` of :class:`hillchart.four_quadrant.nets.SuterNets` that record their rated unit
    point and full-stroke opening (``training.rated``, ``training.opening_max``); ``name`` for messages."""
    training = nets.training
    if "rated" not in training or "opening_max" not in training:
        raise InputError(f"{name}: the simulator needs the nets' rated unit point and full-stroke opening "
                         f"(training.rated and training.opening_max), which these nets do not record")
    return SuterCharacteristics.from_nets(nets, rated=training["rated"], opening_max=training["opening_max"],
                                          name=name)


class SuterNetsKind(CharacteristicKind):
    """Nets of the Suter curves (format hillsim.suter_nets) that record their rated unit point."""

    description = "Suter-curve nets (format hillsim.suter_nets, with training.rated and training.opening_max)"
    boundary = "simulate.components.turbine.four_quadrant:build_suter_boundary"
    four_quadrant = True

    def owns(self, document) -> bool:
        from hillchart.four_quadrant.nets import FORMAT

        return isinstance(document, dict) and document.get("format") == FORMAT

    def read(self, document, path):
        from hillchart.four_quadrant.nets import load_suter_nets

        return characteristics_of_nets(load_suter_nets(path), str(path))

    def adopt(self, characteristics):
        """A caller's :class:`hillchart.four_quadrant.nets.SuterNets` (converted, :func:`characteristics_of_nets`)
        or :class:`SuterCharacteristics` of nets (as they are)."""
        from hillchart.four_quadrant.nets import SuterNets

        if isinstance(characteristics, SuterNets):
            return characteristics_of_nets(characteristics, "the caller's Suter nets")
        if isinstance(characteristics, SuterCharacteristics) and characteristics.nets is not None:
            return characteristics
        return None


class SuterCurvesKind(CharacteristicKind):
    """Tabulated Suter curves (format hillsim.suter_curves, :func:`write_suter_curves`)."""

    description = "tabulated Suter curves (format hillsim.suter_curves)"
    boundary = "simulate.components.turbine.four_quadrant:build_suter_boundary"
    four_quadrant = True

    def owns(self, document) -> bool:
        return isinstance(document, dict) and document.get("format") == CURVES_FORMAT

    def read(self, document, path):
        return read_suter_curves(document, path)

    def adopt(self, characteristics):
        """A caller's :class:`SuterCharacteristics` of a table (as it is)."""
        if isinstance(characteristics, SuterCharacteristics) and characteristics.nets is None:
            return characteristics
        return None


class SyntheticPumpTurbineKind(CharacteristicKind):
    """The exact synthetic pump-turbine as a fine table of its plain curves (:func:`exact_pump_turbine_curves`)."""

    by_word = True
    description = "the exact synthetic pump-turbine"
    label = "synthetic pump-turbine (exact, tabulated)"
    opening_unit = "mm"
    boundary = "simulate.components.turbine.four_quadrant:build_suter_boundary"
    four_quadrant = True

    def load(self, turbine, *, key="turbine.characteristics"):
        wh, wm = exact_pump_turbine_curves()
        return SuterCharacteristics.from_table(wh, wm, openings=EXACT_OPENINGS_MM / 28.0, rated=pump_turbine_rated(),
                                               opening_max=28.0, name="synthetic pump-turbine (exact)")


SUTER_NETS = SuterNetsKind()
SUTER_CURVES = SuterCurvesKind()
SYNTHETIC_PUMP_TURBINE = SyntheticPumpTurbineKind()
