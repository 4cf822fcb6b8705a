"""Below the lowest digitized opening line: the weighed extrapolation hypotheses, blended into the nets.

A load rejection's maximum head is decided in the last seconds of the closure, at openings below the lowest line a
user digitized. There the nets can only interpolate between the measured lines and the samples the extension adds,
and a 2-H-1 net of logsig units follows those samples to 2-3 % of Q11 at best, with whatever slope and curvature its
sigmoids give between them. So below the lowest line the characteristics are the extension's answer there: the
hypotheses of :mod:`hillchart.extension.hypotheses` (the fitted physical model, the model anchored to the lowest
line, straight and bent lines to the closed vanes) weighed by how well each predicted the chart's own held-out lines.
That answer is tabulated over (N11, opening) when the nets are trained and stored in nets.json, so any hypothesis
(and any ensemble member's perturbation of it, the band) is evaluated the same way in a run:

    y = w y_nets + (1 - w) y_table,      w = s(a),

with ``s(a)`` a C1 smoothstep from 0 at ``blend_openings[0]`` to 1 at ``blend_openings[1]`` (the lowest digitized
opening). The table is interpolated by Catmull-Rom cubic convolution on its uniform grid (C1, exact for linear
functions; the grid's opening edges are continued linearly), derivatives analytically, so the pressure loop sees a C1
characteristic. Beyond the table's N11 range (1.5 times the chart's largest N11) its values at the last N11 are
held: below the lowest line the table answers at every speed, so the flow through shut vanes is zero at any N11
(the nets alone, which a 2-H-1 net of sigmoids makes of zero opening, pumped flow backwards beyond runaway). Above
the lowest line the nets alone answer: the extrapolation never overrides measured data.

Files written before the hypotheses were weighed hold the fitted physical model itself (kind ``francis-1d``): they
are read by tabulating that model on the same grid (to about 1e-4 of Q11; the exact model is no longer evaluated in
a run).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numba
import numpy as np

from hillchart.errors import InputError
from hillchart.extension.band import BEYOND_CAP, runout
from hillchart.extension.hypotheses import band_square
from hillchart.nets.weights import _PYTHON_POINTS, _net_value_grad

#: Model identifier in nets.json of the tabulated extrapolation, and of the physical model of older files.
KIND = "hypotheses-table"
LEGACY_KIND = "francis-1d"
#: Parameter names of the legacy physical model, in the order of :func:`hillchart.synthetic.francis._francis_terms`.
PARAMETER_NAMES = ("d2", "b1", "guide_vane_pitch", "beta1_deg", "beta2_deg", "k_guide_vane", "k_incidence",
                   "k_runner", "k_draft_tube", "k_swirl", "k_disc_friction", "opening_max")
#: Fraction of the lowest digitized opening below which the table alone answers (above the lowest opening: the nets).
BLEND_START_FRACTION = 0.5
#: Grid of the table: N11 from 0 to its top, openings from 0 to the lowest digitized one.
N11_NODES = 41
OPENING_NODES = 11
#: Packed layout (:meth:`SilentRegionModel.packed`): blend openings, the member's M11 band offset (N*m), an unused
#: slot, torque factor, node counts, the grid's top N11 and opening, the member's Q11 band offset, the band's
#: distance cap and run-out (:func:`hillchart.extension.band.band_square`), then the Q11 and M11 tables (row-major,
#: N11 first).
_HEADER = 12


@numba.njit(cache=True)
def _smoothstep(x, x0, x1):
    """(s, ds/dx): 0 below x0, 1 above x1, 3t^2 - 2t^3 between (C1)."""
    if x <= x0:
        return 0.0, 0.0
    if x >= x1:
        return 1.0, 0.0
    width = x1 - x0
    t = (x - x0) / width
    return t * t * (3.0 - 2.0 * t), 6.0 * t * (1.0 - t) / width


@numba.njit(cache=True)
def _blend_weight(blend, n11, opening):
    """``(w, dw/dN11, dw/da)``: the nets' weight w = s(a) (module docstring)."""
    s_a, ds_a = _smoothstep(opening, blend[0], blend[1])
    return s_a, 0.0, ds_a


@numba.njit(cache=True)
def _catmull_rom(u, k):
    """Weight of the k-th of the four nodes around a cell (k = 0: the node before it) at the cell coordinate
    ``u`` in [0, 1], and its derivative in u (cubic convolution with a = -1/2, Keys 1981)."""
    u2 = u * u
    u3 = u2 * u
    if k == 0:
        return 0.5 * (-u3 + 2.0 * u2 - u), 0.5 * (-3.0 * u2 + 4.0 * u - 1.0)
    if k == 1:
        return 0.5 * (3.0 * u3 - 5.0 * u2 + 2.0), 0.5 * (9.0 * u2 - 10.0 * u)
    if k == 2:
        return 0.5 * (-3.0 * u3 + 4.0 * u2 + u), 0.5 * (-9.0 * u2 + 8.0 * u + 1.0)
    return 0.5 * (u3 - u2), 0.5 * (3.0 * u2 - 2.0 * u)


@numba.njit(cache=True)
def _node_in_opening(blend, base, i, j):
    """Table value at N11 node ``i`` (inside the grid) and opening node ``j``, continued linearly beyond the grid."""
    na = int(blend[6])
    if j < 0:
        return 2.0 * blend[base + i * na] - blend[base + i * na + 1]
    if j >= na:
        return 2.0 * blend[base + i * na + na - 1] - blend[base + i * na + na - 2]
    return blend[base + i * na + j]


@numba.njit(cache=True)
def _node(blend, base, i, j):
    """Table value at nodes (``i``, ``j``), the grid continued linearly in both directions."""
    nn = int(blend[5])
    if i < 0:
        return 2.0 * _node_in_opening(blend, base, 0, j) - _node_in_opening(blend, base, 1, j)
    if i >= nn:
        return 2.0 * _node_in_opening(blend, base, nn - 1, j) - _node_in_opening(blend, base, nn - 2, j)
    return _node_in_opening(blend, base, i, j)


@numba.njit(cache=True)
def _table_value_grad(blend, base, n11, opening):
    """``(y, dy/dN11, dy/da)`` of the table starting at ``blend[base]``: Catmull-Rom interpolation on the grid,
    N11 and opening clamped to the grid (derivative 0 beyond it)."""
    nn, na = int(blend[5]), int(blend[6])
    h_n = blend[7] / (nn - 1)
    h_a = blend[8] / (na - 1)
    x = min(max(n11, 0.0), blend[7]) / h_n
    y = min(max(opening, 0.0), blend[8]) / h_a
    i = min(int(x), nn - 2)
    j = min(int(y), na - 2)
    u = x - i
    s = y - j
    value = 0.0
    d_u = 0.0
    d_s = 0.0
    for p in range(4):
        w_u, dw_u = _catmull_rom(u, p)
        for q in range(4):
            w_s, dw_s = _catmull_rom(s, q)
            f = _node(blend, base, i - 1 + p, j - 1 + q)
            value += w_u * w_s * f
            d_u += dw_u * w_s * f
            d_s += w_u * dw_s * f
    inside_n = 1.0 if 0.0 < n11 < blend[7] else 0.0
    inside_a = 1.0 if 0.0 < opening < blend[8] else 0.0
    return value, inside_n * d_u / h_n, inside_a * d_s / h_a


@numba.njit(cache=True)
def _table_kernel(blend, n11, opening):
    """``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` of the tables (the torque times its factor)."""
    size = int(blend[5]) * int(blend[6])
    q, q_n, q_a = _table_value_grad(blend, _HEADER, n11, opening)
    m, m_n, m_a = _table_value_grad(blend, _HEADER + size, n11, opening)
    f = blend[4]
    return q, q_n, q_a, f * m, f * m_n, f * m_a


_band_square = numba.njit(cache=True)(band_square)


@numba.njit(cache=True)
def _silent_nets_kernel(params, n11, opening):
    """:func:`_blended_kernel` moved along the band (an ensemble member's place in it, :func:`_band_moves`)."""
    q, q_n, q_a, m, m_n, m_a = _blended_kernel(params, n11, opening)
    blend = params[2]
    if (blend[9] == 0.0 and blend[2] == 0.0) or opening >= blend[1]:
        return q, q_n, q_a, m, m_n, m_a
    f, f_a, dm, dm_a = _band_moves(blend, opening)
    return q * f, q_n * f, q_a * f + q * f_a, m + dm, m_n, m_a + dm_a


@numba.njit(cache=True)
def _band_moves(blend, opening):
    """``(f, df/da, dM, ddM/da)``: an ensemble member's move below the lowest line, Q11 multiplied by
    ``f = exp(u_q h)`` and M11 shifted by ``dM = u_m h t`` (N*m, times the torque factor), ``u_q`` and ``u_m`` its
    place in the band times the band's width on that side, ``h`` of :func:`_band_square` at the distance
    ``d = 1 - t``, ``t = a / a_low``: each target moves by its own held-out evidence, and the torque's band closes
    at the closed vanes, where the disc friction's -K N11^2 (eq. 8) holds."""
    a_low = blend[1]
    t = opening / a_low
    h, dh = _band_square(1.0 - t, blend[10], blend[11])
    dh_a = dh * (-1.0 / a_low)
    f = math.exp(blend[9] * h)
    shift = blend[2] * blend[4]
    return f, f * blend[9] * dh_a, shift * h * t, shift * (dh_a * t + h / a_low)


@numba.njit(cache=True)
def _blended_kernel(params, n11, opening):
    """``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)``: the nets (``params[0]``,
    ``params[1]``) blended into the tabulated extrapolation (``params[2]``, :meth:`SilentRegionModel.packed`) below
    the lowest digitized opening (module docstring)."""
    blend = params[2]
    w, w_n, w_a = _blend_weight(blend, n11, opening)
    if w <= 0.0:  # the table alone (the blend's derivatives are 0 there too): the nets need not be evaluated
        return _table_kernel(blend, n11, opening)
    q, q_n, q_a = _net_value_grad(params[0], n11, opening)
    m, m_n, m_a = _net_value_grad(params[1], n11, opening)
    if w >= 1.0:
        return q, q_n, q_a, m, m_n, m_a
    tq, tq_n, tq_a, tm, tm_n, tm_a = _table_kernel(blend, n11, opening)
    v = 1.0 - w
    return (w * q + v * tq, w * q_n + v * tq_n + w_n * (q - tq), w * q_a + v * tq_a + w_a * (q - tq),
            w * m + v * tm, w * m_n + v * tm_n + w_n * (m - tm), w * m_a + v * tm_a + w_a * (m - tm))


@numba.njit(cache=True)
def _silent_nets_value(params, n11, opening, which):
    """The value alone of Q11 (``which`` 0) or M11 (1) of :func:`_silent_nets_kernel`, by the same formulas: what
    the pressure loop's iterations and the torque at the converged head need."""
    blend = params[2]
    w = _blend_weight(blend, n11, opening)[0]
    if w <= 0.0:  # the table alone: the nets need not be evaluated
        y = _table_kernel(blend, n11, opening)[3 * which]
    else:
        # static indices: a tuple indexed by a variable hands out a new array reference, which the loop compiled
        # without reference counting refuses (simulate.loop.assembly)
        y = _net_value_grad(params[0], n11, opening)[0] if which == 0 else \
            _net_value_grad(params[1], n11, opening)[0]
        if w < 1.0:
            y = w * y + (1.0 - w) * _table_kernel(blend, n11, opening)[3 * which]
    if (blend[9] == 0.0 and blend[2] == 0.0) or opening >= blend[1]:
        return y
    f, _, dm, _ = _band_moves(blend, opening)
    if which == 0:
        return y * f
    return y + dm


@numba.njit(cache=True)
def _silent_nets_flow(params, n11, opening):
    """Q11 of :func:`_silent_nets_kernel` (value only)."""
    return _silent_nets_value(params, n11, opening, 0)


@numba.njit(cache=True)
def _silent_nets_torque(params, n11, opening):
    """M11 of :func:`_silent_nets_kernel` (value only)."""
    return _silent_nets_value(params, n11, opening, 1)


@numba.njit(cache=True)
def _silent_eval_many(flow, torque, blend, n11, opening, out):
    params = (flow, torque, blend)
    for k in range(n11.size):
        r = _silent_nets_kernel(params, n11[k], opening[k])
        for j in range(6):
            out[j, k] = r[j]


def _finite_pair(lo, hi) -> bool:
    return math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi


def _band_pair(value):
    """``(low, high)`` floats of a band's two half-widths (a pair of finite numbers), or None."""
    try:
        low, high = (float(v) for v in value)
    except (TypeError, ValueError):
        return None
    if any(isinstance(v, bool) for v in value) or not (math.isfinite(low) and math.isfinite(high)):
        return None
    return low, high


def table_grid(lowest_opening: float, n11_top: float, n11_nodes: int = N11_NODES, opening_nodes: int = OPENING_NODES):
    """``(N11, opening)`` at the table's nodes (arrays ``(n11_nodes, opening_nodes)``, N11 first): N11 = 0 ..
    ``n11_top`` r/min x opening = 0 .. ``lowest_opening`` (chart units), both uniform."""
    return np.meshgrid(np.linspace(0.0, float(n11_top), n11_nodes), np.linspace(0.0, float(lowest_opening),
                                                                                   opening_nodes), indexing="ij")


def median_of(extrapolation) -> dict:
    """Which hypothesis the weighed median takes at each node of the table
    (:meth:`hillchart.extension.hypotheses.Evidence.blend` with ``deciding``): ``{"q11": [[i, ...], ...], "m11":
    ..., "lowest_opening", "n11_top"}``, ``i`` the hypothesis' index in the record's ``hypotheses``, N11 first as
    the table. nets.json keeps it beside the evidence, and a guarantee report names the hypothesis that decided a
    figure from it (:mod:`simulate.studies.figure_origin`)."""
    from hillchart.extension.hypotheses import HYPOTHESES

    nn, aa = table_grid(extrapolation.lowest_opening, extrapolation.n11_top)
    names = extrapolation.evidence.blend(extrapolation.hypotheses, nn, aa, deciding=True)
    index = {h: i for i, h in enumerate(HYPOTHESES)}
    return {"lowest_opening": float(extrapolation.lowest_opening), "n11_top": float(extrapolation.n11_top),
            **{t: [[index[h] for h in row] for row in np.asarray(v).tolist()] for t, v in zip(("q11", "m11"), names)}}


@dataclass(frozen=True, eq=False)
class SilentRegionModel:
    """The tabulated extrapolation below the lowest digitized line and where it answers instead of the nets.

    Attributes
    ----------
    q11, m11 : ndarray (N11_NODES, OPENING_NODES)
        Q11 (m^3/s) and M11 (N*m) on the grid N11 = 0 .. ``n11_top`` (r/min) x opening = 0 .. ``blend_openings[1]``
        (chart units), both uniform.
    n11_top : float
        r/min, the table's last N11.
    blend_openings : (float, float)
        Openings (chart units): the table alone at or below the first, the nets alone at or above the second (the
        lowest digitized opening).
    torque_factor : float
        The table's M11 is multiplied by it (1: the chart as measured; the prototype step-up scales the torque of
        nets and table alike, :func:`simulate.components.turbine.step_up.scale_torque`).
    band_q11 : (float, float)
        The band below the lowest line (:mod:`hillchart.extension.hypotheses`), below and above the answer: its
        half-widths are ``band_q11 h`` in log Q11, ``h`` the squared distance ``(1 - a / a_low)^2`` up to
        ``distance_cap``, then as ``beyond_cap`` says (:func:`_band_square`).
    band_m11 : (float, float)
        The same for M11, in N*m of the chart's M11 (times ``torque_factor`` in a run): half-widths
        ``band_m11 h a / a_low``, closing at the closed vanes.
    distance_cap : float
    beyond_cap : str
        :data:`hillchart.extension.band.BEYOND_CAP`: ``"grows"``, or ``"levels"`` in files written before.
    position : float
        An ensemble member's place in the band (+-1: the 5-95 % edges); 0 for the point answer. The member's
        characteristics below the lowest line are ``Q11 exp(u_q h)`` and ``M11 + u_m h a / a_low`` with
        ``u = position`` times the band's width on its side (low for a negative position).
    """

    q11: np.ndarray
    m11: np.ndarray
    n11_top: float
    blend_openings: tuple
    torque_factor: float = 1.0
    band_q11: tuple = (0.0, 0.0)
    band_m11: tuple = (0.0, 0.0)
    distance_cap: float = 1.0
    position: float = 0.0
    beyond_cap: str = "grows"

    def __post_init__(self):
        q, m = np.asarray(self.q11, float), np.asarray(self.m11, float)
        if q.ndim != 2 or q.shape != m.shape or q.shape[0] < 4 or q.shape[1] < 4:
            raise InputError(f"silent_model.q11 and silent_model.m11 must be tables of the same shape, at least 4 x 4 "
                             f"(N11 x opening), got {q.shape} and {m.shape}")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(m))):
            raise InputError("silent_model.q11 and silent_model.m11 must hold finite numbers only")
        if np.any(q < 0):
            raise InputError(f"silent_model.q11 must be >= 0 everywhere (no flow backwards through the vanes), got "
                             f"{float(q.min())!r}")
        if not (math.isfinite(self.n11_top) and self.n11_top > 0):
            raise InputError(f"silent_model.n11_top must be finite and > 0, got {self.n11_top!r}")
        if not _finite_pair(*self.blend_openings):
            raise InputError(f"silent_model.blend_openings must be two finite numbers 0 <= low < high, got "
                             f"{list(self.blend_openings)!r}")
        if not (math.isfinite(self.torque_factor) and self.torque_factor > 0):
            raise InputError(f"silent_model.torque_factor must be finite and > 0, got {self.torque_factor!r}")
        if not (math.isfinite(self.distance_cap) and 0 < self.distance_cap <= 1.0):
            raise InputError(f"silent_model.distance_cap must be a finite number in (0, 1.0], got "
                             f"{self.distance_cap!r}")
        if self.beyond_cap not in BEYOND_CAP:
            raise InputError(f"silent_model.band.beyond_cap must be one of {', '.join(BEYOND_CAP)}, got "
                             f"{self.beyond_cap!r}")
        # Q11's band at most a log-ratio of 10 at the shut vanes (h there from the cap and the run-out: a band
        # that grows as d^2 only near the lowest line, as the no-evidence band does, has a larger kappa)
        closed = band_square(1.0, self.distance_cap, runout(self.beyond_cap, self.distance_cap))[0]
        for key in ("band_q11", "band_m11"):
            value = getattr(self, key)
            sides = _band_pair(value)
            limit = 10.0 / closed if key == "band_q11" else math.inf
            if sides is None or not all(0 <= v <= limit for v in sides):
                raise InputError(f"silent_model.{key} must be a pair [low, high] of finite numbers in "
                                 f"[0, {limit:g}], got {value!r}")
            object.__setattr__(self, key, sides)
        if not (math.isfinite(self.position) and abs(self.position) <= 5.0):
            raise InputError(f"silent_model.position must be a finite number in [-5, 5], got {self.position!r}")
        object.__setattr__(self, "q11", q)
        object.__setattr__(self, "m11", m)

    # ------------------------------------------------------------------------------------------------------------
    @classmethod
    def tabulate(cls, values, lowest_opening: float, n11_top: float, *, torque_factor: float = 1.0,
                 n11_nodes: int = N11_NODES, opening_nodes: int = OPENING_NODES, **band) -> "SilentRegionModel":
        """The table of ``values(n11, opening) -> (Q11, M11)`` (arrays of the grid's shape) below the lowest
        digitized opening ``lowest_opening``, N11 from 0 to ``n11_top`` (r/min)."""
        nn, aa = table_grid(lowest_opening, n11_top, n11_nodes, opening_nodes)
        q, m = values(nn, aa)
        q, m = np.broadcast_to(np.asarray(q, float), nn.shape), np.broadcast_to(np.asarray(m, float), nn.shape)
        return cls(q11=np.maximum(q, 0.0), m11=np.array(m), n11_top=float(n11_top),
                   blend_openings=(BLEND_START_FRACTION * float(lowest_opening), float(lowest_opening)),
                   torque_factor=torque_factor, **band)

    def scaled(self, factor: float) -> "SilentRegionModel":
        """The same table with its torque multiplied by ``factor`` (on top of the present factor)."""
        return replace(self, torque_factor=self.torque_factor * factor)

    def at(self, position: float) -> "SilentRegionModel":
        """The same table at ``position`` in the band (an ensemble member's)."""
        return replace(self, position=float(position))

    def packed(self) -> np.ndarray:
        """The numbers the kernel reads (:data:`_HEADER` header values, then the Q11 and M11 tables)."""
        nn, na = self.q11.shape
        side = 0 if self.position < 0 else 1
        header = [*self.blend_openings, self.position * self.band_m11[side], 0.0, self.torque_factor, nn, na,
                  self.n11_top, self.blend_openings[1], self.position * self.band_q11[side], self.distance_cap,
                  runout(self.beyond_cap, self.distance_cap)]
        return np.concatenate([np.array(header, dtype=float), self.q11.ravel(), self.m11.ravel()])

    def nets_weight(self, opening: float) -> float:
        """The nets' weight ``w = s(a)`` in the blend at ``opening`` (chart units): 0 where the table alone answers
        (at or below ``blend_openings[0]``), 1 at and above the lowest digitized opening (module docstring)."""
        return float(_smoothstep.py_func(float(opening), *self.blend_openings)[0])

    def band_sides(self, opening: float) -> dict:
        """The band's two sides at ``opening`` (chart units), as the kernel moves a member at position -1 and +1
        (:func:`_band_moves`): ``q11`` the relative changes of Q11 ``(exp(-k_low h) - 1, exp(k_high h) - 1)``,
        ``m11_nm`` the shifts of M11 ``(-b_low h t, +b_high h t)`` (N*m, times the torque factor), with ``h`` of
        :func:`hillchart.extension.hypotheses.band_square` at the distance ``d = 1 - t``, ``t = a / a_low``; all
        zero at and above the lowest digitized opening.

        Examples
        --------
        >>> table = SilentRegionModel(np.ones((4, 4)), np.zeros((4, 4)), 100.0, (5.0, 10.0),
        ...                           band_q11=(0.4, 0.2), band_m11=(30.0, 10.0), distance_cap=1.0)
        >>> sides = table.band_sides(5.0)  # d = 0.5, h = d^2 = 0.25, t = 0.5
        >>> [round(v, 6) for v in sides["q11"]], [round(v, 6) for v in sides["m11_nm"]]
        ([-0.095163, 0.051271], [-3.75, 1.25])
        """
        a_low = self.blend_openings[1]
        t = float(opening) / a_low
        distance = 1.0 - t
        cap = self.distance_cap
        h = _band_square.py_func(distance, cap, runout(self.beyond_cap, cap))[0] if float(opening) < a_low else 0.0
        factor = self.torque_factor
        return {"distance": distance, "h": h,
                "q11": (math.exp(-self.band_q11[0] * h) - 1.0, math.exp(self.band_q11[1] * h) - 1.0),
                "m11_nm": (-self.band_m11[0] * h * t * factor, self.band_m11[1] * h * t * factor)}

    def table(self, n11, opening):
        """``(Q11, M11)`` of the table alone (the torque times its factor), broadcast arrays."""
        n11_b, a_b = np.broadcast_arrays(np.asarray(n11, dtype=float), np.asarray(opening, dtype=float))
        packed = self.packed()
        kernel = _table_kernel.py_func if n11_b.size <= _PYTHON_POINTS else _table_kernel
        out = np.array([kernel(packed, float(n), float(a)) for n, a in zip(n11_b.ravel(), a_b.ravel())])
        out = out.reshape(-1, 6)
        return out[:, 0].reshape(n11_b.shape), out[:, 3].reshape(n11_b.shape)

    def evaluate(self, flow, torque, n11, opening):
        """``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` of the blended characteristics, broadcast arrays;
        ``flow``, ``torque``: :class:`hillchart.nets.weights.NetWeights`."""
        n11_b, a_b = np.broadcast_arrays(np.asarray(n11, dtype=float), np.asarray(opening, dtype=float))
        flat_n = np.ascontiguousarray(n11_b, dtype=float).ravel()
        flat_a = np.ascontiguousarray(a_b, dtype=float).ravel()
        out = np.empty((6, flat_n.size))
        params = (flow.packed(), torque.packed(), self.packed())
        if flat_n.size <= _PYTHON_POINTS:
            # few points (e.g. linearizing at one operating point): the kernels' Python source (loading the compiled
            # kernels costs about half a second)
            for k in range(flat_n.size):
                out[:, k] = _python_kernel(params, float(flat_n[k]), float(flat_a[k]))
        else:
            _silent_eval_many(params[0], params[1], params[2], flat_n, flat_a, out)
        return tuple(row.reshape(n11_b.shape) for row in out)

    # ------------------------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        doc = {"kind": KIND, "n11_top": self.n11_top, "blend_openings": list(self.blend_openings),
               "band": {"q11": list(self.band_q11), "m11": list(self.band_m11), "distance_cap": self.distance_cap,
                        "beyond_cap": self.beyond_cap},
               "q11": self.q11.tolist(), "m11": self.m11.tolist()}
        if self.torque_factor != 1.0:
            doc["torque_factor"] = self.torque_factor
        return doc

    def member_dict(self) -> dict:
        """An ensemble member's block in nets.json: its place in the band of the top-level table."""
        return {"position": self.position}

    def member_from_dict(self, doc, key: str) -> "SilentRegionModel":
        """An ensemble member's block: ``{"position": p}`` on this (the top-level) table, or a whole block."""
        if isinstance(doc, dict) and set(doc) == {"position"}:
            position = doc["position"]
            if isinstance(position, bool) or not isinstance(position, (int, float)):
                raise InputError(f"nets.json: {key}.position must be a number in [-5, 5], got {position!r}")
            try:
                return self.at(float(position))
            except InputError as exc:
                raise InputError(f"nets.json: {str(exc).replace('silent_model', key)}") from None
        return SilentRegionModel.from_dict(doc, key=key)

    @classmethod
    def from_dict(cls, doc, key: str = "silent_model") -> "SilentRegionModel":
        """Validate a parsed ``silent_model`` block of nets.json (kind :data:`KIND`, or :data:`LEGACY_KIND`,
        tabulated on reading)."""
        if not isinstance(doc, dict) or "kind" not in doc:
            raise InputError(f"nets.json: {key} must be an object with a kind ({KIND!r}), got "
                             f"{sorted(doc) if isinstance(doc, dict) else doc!r}")
        if doc["kind"] == LEGACY_KIND:
            return _from_legacy(doc, key)
        if doc["kind"] != KIND:
            raise InputError(f"nets.json: {key}.kind must be {KIND!r} (or {LEGACY_KIND!r}, files of earlier "
                             f"versions), got {doc['kind']!r}")
        required = {"kind", "n11_top", "blend_openings", "band", "q11", "m11"}
        if not required <= set(doc) <= required | {"torque_factor"}:
            raise InputError(f"nets.json: {key} must have the keys {', '.join(sorted(required))} (and optionally "
                             f"torque_factor), got {sorted(doc)}")
        try:
            q = np.array(doc["q11"], dtype=float)
            m = np.array(doc["m11"], dtype=float)
            top = float(doc["n11_top"])
            openings = tuple(float(v) for v in doc["blend_openings"])
            factor = float(doc.get("torque_factor", 1.0))
            band = doc["band"]
            if not isinstance(band, dict) or set(band) - {"beyond_cap"} not in ({"q11", "m11", "distance_cap"},
                                                                                 {"q11", "distance_cap"}):
                raise ValueError
            # files of the release before the two-sided band: one Q11 width, both sides (no M11 band of its own)
            widths = {"band_q11": band["q11"] if isinstance(band["q11"], list) else [band["q11"]] * 2,
                      "band_m11": band.get("m11", [0.0, 0.0]), "distance_cap": float(band["distance_cap"]),
                      # files written before the band grew on beyond the distances tested: it levelled off
                      "beyond_cap": band.get("beyond_cap", "levels")}
        except (TypeError, ValueError):
            raise InputError(f"nets.json: {key} must hold numbers (n11_top, blend_openings, band with "
                             f"q11, m11 ([low, high] pairs), distance_cap and optionally beyond_cap, and the q11 and "
                             f"m11 tables)") from None
        if len(openings) != 2:
            raise InputError(f"nets.json: {key}.blend_openings must be a [low, high] pair")
        try:
            return cls(q11=q, m11=m, n11_top=top, blend_openings=openings, torque_factor=factor,
                       **widths)
        except InputError as exc:
            raise InputError(f"nets.json: {str(exc).replace('silent_model', key)}") from None


def _python_kernel(params, n11, opening):
    """:func:`_silent_nets_kernel` in Python, where the nets alone answer; the compiled kernel elsewhere."""
    blend = params[2]
    s_a = _smoothstep.py_func(opening, blend[0], blend[1])[0]
    banded = opening < blend[1] and (blend[9] != 0.0 or blend[2] != 0.0)
    if s_a >= 1.0 and not banded:
        return (*_net_value_grad.py_func(params[0], n11, opening), *_net_value_grad.py_func(params[1], n11, opening))
    return _silent_nets_kernel(params, n11, opening)


def _from_legacy(doc, key: str) -> SilentRegionModel:
    """A ``francis-1d`` block (the fitted physical model itself) tabulated on the grid of :data:`KIND`."""
    from hillchart.synthetic.francis import FrancisParameters, SyntheticFrancis

    required = {"kind", "parameters", "blend_openings", "n11_blend"}
    if not required <= set(doc) <= required | {"torque_factor"}:
        raise InputError(f"nets.json: {key} must be an object with the keys kind, parameters, blend_openings, "
                         f"n11_blend (and optionally torque_factor), got {sorted(doc)}")
    params = doc["parameters"]
    if not isinstance(params, dict) or set(params) != set(PARAMETER_NAMES):
        raise InputError(f"nets.json: {key}.parameters must have exactly the keys {', '.join(PARAMETER_NAMES)}")
    try:
        values = tuple(float(params[name]) for name in PARAMETER_NAMES)
        openings = tuple(float(v) for v in doc["blend_openings"])
        speeds = tuple(float(v) for v in doc["n11_blend"])
        factor = float(doc.get("torque_factor", 1.0))
    except (TypeError, ValueError):
        raise InputError(f"nets.json: {key} must hold numbers (parameters, blend_openings, n11_blend)") from None
    if not all(math.isfinite(v) and v > 0 for v in values):
        raise InputError(f"nets.json: {key}.parameters must be {len(PARAMETER_NAMES)} finite positive numbers "
                         f"({', '.join(PARAMETER_NAMES)}), got {list(values)!r}")
    if len(openings) != 2 or len(speeds) != 2 or not _finite_pair(*openings) or not _finite_pair(*speeds):
        raise InputError(f"nets.json: {key}.blend_openings and {key}.n11_blend must be [low, high] pairs of finite "
                         f"numbers 0 <= low < high")
    p = dict(zip(PARAMETER_NAMES, values))
    pitch, opening_max = p.pop("guide_vane_pitch"), p.pop("opening_max")
    turbine = SyntheticFrancis(FrancisParameters(guide_vane_pitch_mm=pitch, opening_max=opening_max, **p))
    top = speeds[1]

    def model(n11, opening):
        return turbine.q11(np.minimum(n11, 0.999 * top), opening), turbine.m11(np.minimum(n11, 0.999 * top), opening)

    table = SilentRegionModel.tabulate(model, openings[1], top, torque_factor=factor)
    return SilentRegionModel(table.q11, table.m11, table.n11_top, openings, factor)
