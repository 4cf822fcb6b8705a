"""The physical model where the chart is silent: the nets hand over to it below the lowest digitized opening line.

A load rejection's maximum head is decided in the last seconds of the closure, at openings below the lowest line a
user digitized. There the nets can only interpolate between the measured lines and the samples the extension adds
(the fitted physical model's, :func:`hillchart.extension.extend.silent_region_points`), and a 2-H-1 net of logsig
units follows those samples to 2-3 % of Q11 at best, with whatever slope and curvature its sigmoids give between them.
The fitted model itself (:mod:`hillchart.extension.turbine_model`: the 1-D Euler model of
:mod:`hillchart.synthetic.francis`, fitted to the whole chart) has the guide-vane opening/area relation built in:
Q11 -> 0 as the opening -> 0 with the slope the runner's inlet geometry implies, and M11 -> -K N11^2 (eq. 8 of the BP
hill-chart paper). So below the lowest line the characteristics are the model's, blended into the nets:

    y = w y_nets + (1 - w) y_model,      w = 1 - (1 - s(a)) (1 - s_N(N11)),

with ``s(a)`` a C1 smoothstep from 0 at ``blend_openings[0]`` to 1 at ``blend_openings[1]`` (the lowest digitized
opening) and ``s_N`` one from 0 at ``n11_blend[0]`` to 1 at ``n11_blend[1]`` (below the model's valid range: beyond
it the model has no positive flow, the pumping region). Derivatives follow by the product rule, so the pressure loop
sees a C1 characteristic. Above the lowest line the nets alone answer: the model never overrides measured data.

Chosen by the guarantee benchmark (``benchmarks/bench_guarantee.py``, docs page "Guarantee figures"): the worst
max-head-rise error over the family fell from 3.4 to the figure given there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from hillchart.errors import InputError
from hillchart.nets.weights import _PYTHON_POINTS, _net_value_grad
from hillchart.synthetic.francis import _synthetic_kernel_at, _synthetic_values_at, francis_angles

#: Parameter names of the model, in the order of :func:`hillchart.synthetic.francis._francis_terms`.
PARAMETER_NAMES = ("d2", "b1", "guide_vane_pitch", "beta1_deg", "beta2_deg", "k_guide_vane", "k_incidence",
                   "k_runner", "k_draft_tube", "k_swirl", "k_disc_friction", "opening_max")
#: Fraction of the lowest digitized opening below which the model alone answers (above the lowest opening: the nets).
BLEND_START_FRACTION = 0.5
#: The N11 hand-back to the nets, as fractions of the model's valid range (its pumping limit).
N11_BLEND_FRACTIONS = (0.85, 0.95)
#: Model identifier in nets.json.
KIND = "francis-1d"


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
    """``(w, dw/dN11, dw/da)``: the nets' weight w = 1 - (1 - s(a)) (1 - s_N(N11)) (module docstring)."""
    s_a, ds_a = _smoothstep(opening, blend[12], blend[13])
    s_n, ds_n = _smoothstep(n11, blend[14], blend[15])
    return 1.0 - (1.0 - s_a) * (1.0 - s_n), (1.0 - s_a) * ds_n, (1.0 - s_n) * ds_a


@numba.njit(cache=True)
def _silent_nets_kernel(params, n11, opening):
    """Simulator kernel ``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)``: the nets (``params[0]``,
    ``params[1]``) blended into the physical model (``params[2]``: 12 model parameters, then a0, a1, n0, n1, the
    model's torque factor and its three blade-angle terms) below
    the lowest digitized opening (module docstring)."""
    blend = params[2]
    angles = (blend[17], blend[18], blend[19])
    w, w_n, w_a = _blend_weight(blend, n11, opening)
    if w <= 0.0:  # the model alone (the blend's derivatives are 0 there too): the nets need not be evaluated
        mq, mq_n, mq_a, mm, mm_n, mm_a = _synthetic_kernel_at(blend[:12], angles, n11, max(opening, 0.0))
        if math.isfinite(mq) and math.isfinite(mm):
            factor = blend[16]
            return mq, mq_n, mq_a, factor * mm, factor * mm_n, factor * mm_a
    q, q_n, q_a = _net_value_grad(params[0], n11, opening)
    m, m_n, m_a = _net_value_grad(params[1], n11, opening)
    if w >= 1.0:
        return q, q_n, q_a, m, m_n, m_a
    mq, mq_n, mq_a, mm, mm_n, mm_a = _synthetic_kernel_at(blend[:12], angles, n11, max(opening, 0.0))
    if not (math.isfinite(mq) and math.isfinite(mm)):  # outside the model's range: the nets alone
        return q, q_n, q_a, m, m_n, m_a
    factor = blend[16]  # the model's torque factor (the prototype step-up; 1 for the model test)
    mm, mm_n, mm_a = factor * mm, factor * mm_n, factor * mm_a
    v = 1.0 - w
    return (w * q + v * mq, w * q_n + v * mq_n + w_n * (q - mq), w * q_a + v * mq_a + w_a * (q - mq),
            w * m + v * mm, w * m_n + v * mm_n + w_n * (m - mm), w * m_a + v * mm_a + w_a * (m - mm))


@numba.njit(cache=True)
def _silent_nets_value(params, n11, opening, which):
    """The value alone of Q11 (``which`` 0) or M11 (1) of :func:`_silent_nets_kernel`, by the same formulas
    without the derivatives (the physical model's complex steps cost about four times its value): what the
    pressure loop's iterations and the torque at the converged head need."""
    blend = params[2]
    w = _blend_weight(blend, n11, opening)[0]
    if w < 1.0:
        mq, mm = _synthetic_values_at(blend[:12], (blend[17], blend[18], blend[19]), n11, max(opening, 0.0))
        if w <= 0.0 and math.isfinite(mq) and math.isfinite(mm):  # the model alone
            return mq if which == 0 else blend[16] * mm
    # static indices: a tuple indexed by a variable hands out a new array reference, which the loop compiled
    # without reference counting refuses (simulate.loop.assembly)
    y = _net_value_grad(params[0], n11, opening)[0] if which == 0 else _net_value_grad(params[1], n11, opening)[0]
    if w >= 1.0:
        return y
    if not (math.isfinite(mq) and math.isfinite(mm)):  # outside the model's range: the nets alone
        return y
    v = 1.0 - w
    if which == 0:
        return w * y + v * mq
    return w * y + v * (blend[16] * mm)


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


@dataclass(frozen=True, eq=False)
class SilentRegionModel:
    """The fitted physical model and where it answers instead of the nets (module docstring).

    Attributes
    ----------
    parameters : tuple of 12 float
        :data:`PARAMETER_NAMES` (lengths relative to D1, angles in degrees, openings in the chart's unit).
    blend_openings : (float, float)
        Openings (chart units): the model alone at or below the first, the nets alone at or above the second (the
        lowest digitized opening).
    n11_blend : (float, float)
        N11 (r/min): the nets take over again between these, below the model's pumping limit.
    torque_factor : float
        The model's M11 is multiplied by it (1: the chart as measured; the prototype step-up scales the torque of
        nets and model alike, :func:`simulate.components.turbine.step_up.scale_torque`).
    """

    parameters: tuple
    blend_openings: tuple
    n11_blend: tuple
    torque_factor: float = 1.0

    def __post_init__(self):
        values = np.asarray(self.parameters, dtype=float)
        if values.shape != (len(PARAMETER_NAMES),) or not np.all(np.isfinite(values)) or np.any(values <= 0):
            raise InputError(f"silent_model.parameters must be {len(PARAMETER_NAMES)} finite positive numbers "
                             f"({', '.join(PARAMETER_NAMES)}), got {list(self.parameters)!r}")
        for key, (lo, hi) in (("blend_openings", self.blend_openings), ("n11_blend", self.n11_blend)):
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
                raise InputError(f"silent_model.{key} must be two finite numbers 0 <= low < high, got "
                                 f"{[lo, hi]!r}")
        if not (math.isfinite(self.torque_factor) and self.torque_factor > 0):
            raise InputError(f"silent_model.torque_factor must be finite and > 0, got {self.torque_factor!r}")

    def scaled(self, factor: float) -> "SilentRegionModel":
        """The same model with its torque multiplied by ``factor`` (on top of the present factor)."""
        return SilentRegionModel(self.parameters, self.blend_openings, self.n11_blend, self.torque_factor * factor)

    @classmethod
    def from_fitted(cls, fitted, lowest_opening: float, n11_top: float, turbine=None) -> "SilentRegionModel":
        """From a :class:`hillchart.extension.turbine_model.FittedTurbineModel` (or ``turbine``, one of its
        :meth:`~hillchart.extension.turbine_model.FittedTurbineModel.draw`) and the chart's lowest digitized
        opening; ``n11_top`` bounds the N11 blend when the model has no pumping limit (inf)."""
        from hillchart.extension.turbine_model import _n11_limit

        model = fitted.turbine if turbine is None else turbine
        values = model._terms_params()  # the model equations' parameter vector, PARAMETER_NAMES order
        limit = _n11_limit(model.params)
        limit = limit if math.isfinite(limit) else max(float(n11_top), 1.0) / 0.95
        lo, hi = N11_BLEND_FRACTIONS
        return cls(parameters=tuple(float(v) for v in values),
                   blend_openings=(BLEND_START_FRACTION * float(lowest_opening), float(lowest_opening)),
                   n11_blend=(lo * limit, hi * limit))

    def packed(self) -> np.ndarray:
        """The 20 numbers the kernel reads: parameters, blend openings, N11 blend, torque factor and the model's
        blade-angle terms (:func:`hillchart.synthetic.francis.francis_angles`)."""
        return np.array([*self.parameters, *self.blend_openings, *self.n11_blend, self.torque_factor,
                         *francis_angles(self.parameters)], dtype=float)

    def evaluate(self, flow, torque, n11, opening):
        """``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` of the blended characteristics, broadcast arrays;
        ``flow``, ``torque``: :class:`hillchart.nets.weights.NetWeights`."""
        n11_b, a_b = np.broadcast_arrays(np.asarray(n11, dtype=float), np.asarray(opening, dtype=float))
        flat_n = np.ascontiguousarray(n11_b, dtype=float).ravel()
        flat_a = np.ascontiguousarray(a_b, dtype=float).ravel()
        out = np.empty((6, flat_n.size))
        if flat_n.size <= _PYTHON_POINTS:
            # few points (e.g. linearizing at one operating point): where the nets alone answer, their kernel's
            # Python source (loading the compiled kernels costs about half a second); below the lowest line the
            # compiled blend
            params = (flow.packed(), torque.packed(), self.packed())
            packed = params[2]
            for k in range(flat_n.size):
                n, a = float(flat_n[k]), float(flat_a[k])
                s_a = _smoothstep.py_func(a, packed[12], packed[13])[0]
                s_n = _smoothstep.py_func(n, packed[14], packed[15])[0]
                if (1.0 - s_a) * (1.0 - s_n) <= 0.0:
                    out[:3, k] = _net_value_grad.py_func(params[0], n, a)
                    out[3:, k] = _net_value_grad.py_func(params[1], n, a)
                else:
                    out[:, k] = _silent_nets_kernel(params, n, a)
        else:
            _silent_eval_many(flow.packed(), torque.packed(), self.packed(), flat_n, flat_a, out)
        return tuple(row.reshape(n11_b.shape) for row in out)

    def to_dict(self) -> dict:
        doc = {"kind": KIND, "parameters": dict(zip(PARAMETER_NAMES, self.parameters)),
               "blend_openings": list(self.blend_openings), "n11_blend": list(self.n11_blend)}
        if self.torque_factor != 1.0:
            doc["torque_factor"] = self.torque_factor
        return doc

    @classmethod
    def from_dict(cls, doc, key: str = "silent_model") -> "SilentRegionModel":
        """Validate a parsed ``silent_model`` block of nets.json."""
        required = {"kind", "parameters", "blend_openings", "n11_blend"}
        if not isinstance(doc, dict) or not required <= set(doc) <= required | {"torque_factor"}:
            raise InputError(f"nets.json: {key} must be an object with the keys kind, parameters, blend_openings, "
                             f"n11_blend (and optionally torque_factor), got "
                             f"{sorted(doc) if isinstance(doc, dict) else doc!r}")
        if doc["kind"] != KIND:
            raise InputError(f"nets.json: {key}.kind must be {KIND!r}, got {doc['kind']!r}")
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
        if len(openings) != 2 or len(speeds) != 2:
            raise InputError(f"nets.json: {key}.blend_openings and {key}.n11_blend must be [low, high] pairs")
        return cls(parameters=values, blend_openings=openings, n11_blend=speeds, torque_factor=factor)
