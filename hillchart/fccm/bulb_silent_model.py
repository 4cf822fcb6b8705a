"""The fitted bulb model where a double-regulated turbine's three-input nets are silent, and the compiled evaluation
of the nets blended with it (what the simulator's time loop and
:class:`hillchart.fccm.three_input_nets.DoubleRegulatedNets` read).

Below the table's smallest guide-vane angle the fitted physical bulb model (:mod:`hillchart.extension.bulb_model`)
answers instead of the nets, or, with residual nets, the hypotheses weighed by the table's held-out angles
(:mod:`hillchart.fccm.evidence`). :class:`BulbSilentModel` holds the model and where it hands over, and packs them
into the vector that :func:`blended_point` and :func:`blended_value` read; :func:`net3_point` evaluates one packed
three-input net (:func:`packed_net3`) on scalars.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from hillchart.errors import InputError
from hillchart.extension.band import median_pick
from hillchart.fccm.evidence import (HANDOVER_FRACTION, HANDOVER_STEPS, BulbExtrapolation, band_envelope_compiled,
                                     hypothesis_value)
from hillchart.fccm.net import FCCMWeights
from hillchart.nets.silent_model import _smoothstep
from hillchart.synthetic.bulb import POINT_PARAMETERS, unit_point
from hillchart.validation import check_finite

#: Inputs of the three-input NET blocks (nets.json NET format): unit speed, guide-vane opening, blade angle.
NET3_INPUTS = ("n11", "opening", "blade_angle")


def packed_net3(weights: FCCMWeights) -> np.ndarray:
    """A three-input, one-output :class:`FCCMWeights` as one float vector for :func:`net3_point`:
    ``[H, x_min (3), x_max (3), y_min, y_max, b2, W1 (H x 3, row-major), b1 (H), W2 (H)]``."""
    if len(weights.inputs) != 3 or len(weights.outputs) != 1:
        raise InputError(f"packed_net3 needs a 3-input, 1-output net, got inputs {list(weights.inputs)} and outputs "
                         f"{list(weights.outputs)}")
    return np.concatenate(([float(weights.hidden)], weights.x_min, weights.x_max,
                           [weights.y_min[0], weights.y_max[0], weights.b2[0]], weights.W1.ravel(), weights.b1,
                           weights.W2[0]))


@numba.njit(cache=True)
def net3_point(p, x0, x1, x2):
    """Value y and dy/dx0 of a packed three-input net (:func:`packed_net3`) at one point, physical units: the
    evaluation of :meth:`FCCMWeights.predict` (mapminmax, logsig hidden layer (eq. (10) of paper 004), linear
    output, reverse mapminmax) on scalars for the compiled time loop, with the derivative of
    :meth:`FCCMWeights.predict_grad` in the first input (unit speed)."""
    hidden = int(p[0])
    s0 = 2.0 / (p[4] - p[1])
    xn0 = s0 * (x0 - p[1]) - 1.0
    xn1 = 2.0 * (x1 - p[2]) / (p[5] - p[2]) - 1.0
    xn2 = 2.0 * (x2 - p[3]) / (p[6] - p[3]) - 1.0
    y_min, y_max, yn = p[7], p[8], p[9]
    w1, b1, w2 = 10, 10 + 3 * hidden, 10 + 4 * hidden
    g = 0.0
    for i in range(hidden):
        z = p[w1 + 3 * i] * xn0 + p[w1 + 3 * i + 1] * xn1 + p[w1 + 3 * i + 2] * xn2 + p[b1 + i]
        if z >= 0.0:  # logsig without overflow for either sign of z
            f = 1.0 / (1.0 + math.exp(-z))
        else:
            ez = math.exp(z)
            f = ez / (1.0 + ez)
        yn += p[w2 + i] * f
        g += p[w2 + i] * f * (1.0 - f) * p[w1 + 3 * i]
    half = 0.5 * (y_max - y_min)
    return (yn + 1.0) * half + y_min, g * half * s0


#: Where the fitted bulb model answers instead of the nets (:class:`BulbSilentModel`): the model alone at or below
#: the closed vane plus this fraction of the gap up to the table's smallest guide-vane angle, the nets alone at it.
BLEND_START_FRACTION = 0.5
#: Model identifier of the ``silent_model`` block of a three-input nets.json.
SILENT_KIND = "bulb-1d"
#: The packed blend of nets without a model: the nets alone everywhere (the smoothstep is 1 for any opening).
NO_BLEND = np.concatenate([np.zeros(12), [-np.inf, -np.inf, 0.0]])


#: Indices in the packed blend (:meth:`BulbSilentModel.packed`) of the closed vane and the disc friction K, and the
#: flag value (``blend[14]``) of residual nets with the weighed hypotheses below the table (then 20 more numbers,
#: :meth:`hillchart.fccm.evidence.BulbExtrapolation.packed`).
_CLOSED = POINT_PARAMETERS.index("guide_vane_closed_deg")
_K_DISC = POINT_PARAMETERS.index("k_disc_friction")
WEIGHED = 2.0


@numba.njit(cache=True)
def weighed_point(net, blend, n11, opening, blade, which):
    """``(y, dy/dN11)`` of the weighed hypotheses (:mod:`hillchart.fccm.evidence`) below the table's smallest guide-vane
    angle ``a_low = blend[13]``, Q11 (``which`` 0, ``net`` the flow net) or M11 (1, the torque net), at the member's
    place in the band: their weighed median (:func:`hillchart.extension.band.median_pick`, as a Francis chart's
    hypotheses answer) with the derivative of the hypothesis it takes (``blend[33]`` 1; 0 in files written before the
    median, which read the weighed mean). ``y_low`` is the model plus the nets' residual at ``a_low``; the band
    multiplies Q11 by ``exp(offset h(d) + low)`` and adds ``(offset h(d) + low) t m11_scale`` to M11 (``blend[32]``,
    N*m; with 0, a file written before, it multiplies the hydraulic torque ``M11 + K N11^2`` by ``exp(offset h(d) +
    low)``), each target by its own offsets (``h`` of :func:`hillchart.extension.band.band_envelope` at ``d = 1 - t``;
    ``low`` the member's share of the nets' own miss at the smallest angles,
    :func:`hillchart.fccm.evidence.low_band`)."""
    params = blend[:12]
    a_low, closed = blend[13], params[_CLOSED]
    t = min(max((opening - closed) / (a_low - closed), 0.0), 1.0)
    q_m, dq_m, m_m, dm_m = unit_point(params, n11, opening, blade)
    q_l, dq_l, m_l, dm_l = unit_point(params, n11, a_low, blade)
    r, dr = net3_point(net, n11, a_low, blade)
    if which == 0:
        y_m, dy_m, y_ml, dy_ml, y_0, dy_0 = q_m, dq_m, q_l, dq_l, 0.0, 0.0
    else:
        y_m, dy_m, y_ml, dy_ml = m_m, dm_m, m_l, dm_l
        y_0, dy_0 = -params[_K_DISC] * n11 * n11, -2.0 * params[_K_DISC] * n11  # eq. (8), BP hill-chart paper
    base = 15 + 4 * which
    c = blend[23 + which]
    values = np.empty(4)
    for h in range(4):
        values[h] = hypothesis_value(h, t, y_m, y_ml, y_ml + r, y_0, c)
    weights = blend[base:base + 4]
    if blend[33] > 0.0:  # the weighed median
        pick = median_pick(values, weights, 0.5 * (weights[0] + weights[1] + weights[2] + weights[3]))
        y, dy = values[pick], hypothesis_value(pick, t, dy_m, dy_ml, dy_ml + dr, dy_0, c)
    else:  # a file written before the median: the weighed mean
        y = dy = 0.0
        for h in range(4):
            y += weights[h] * values[h]
            dy += weights[h] * hypothesis_value(h, t, dy_m, dy_ml, dy_ml + dr, dy_0, c)
    h = band_envelope_compiled(1.0 - t, blend[27], blend[28 + which], blend[34])[0]
    shift = blend[25 + which] * h + blend[30 + which]
    if which == 1 and blend[32] > 0.0:  # a share of the M11 range, closing as t toward the closed vanes
        return y + shift * t * blend[32], dy
    f = math.exp(shift)
    return y_0 + (y - y_0) * f, dy_0 + (dy - dy_0) * f


@numba.njit(cache=True)
def blended_point(flow, torque, blend, n11, opening, blade):
    """``(q11, dq11/dn11, m11, dm11/dn11)`` of packed three-input nets with the fitted bulb model
    (:class:`BulbSilentModel`; ``blend`` = its :meth:`~BulbSilentModel.packed`, or :data:`NO_BLEND`), w a C1
    smoothstep in the opening, 0 below the table's smallest guide-vane angle (w does not depend on N11, so the
    N11-derivatives follow the same formula):

    * nets of the characteristics (``blend[14]`` 0): ``y = w y_nets + (1 - w) y_model``;
    * nets of the residual to the model (``blend[14]`` 1): ``y = y_model + w y_nets``;
    * residual nets with the weighed hypotheses (``blend[14]`` 2, :data:`WEIGHED`):
      ``y = w (y_model + y_nets) + (1 - w) y_weighed`` (:func:`weighed_point`).

    Where w is 0 the nets are not evaluated (with the hypotheses: only at the smallest angle)."""
    w = _smoothstep(opening, blend[12], blend[13])[0]
    if blend[14] == WEIGHED and w < 1.0:
        eq, edq = weighed_point(flow, blend, n11, opening, blade, 0)
        em, edm = weighed_point(torque, blend, n11, opening, blade, 1)
        if w <= 0.0:
            return eq, edq, em, edm
        mq, mdq, mm, mdm = unit_point(blend[:12], n11, opening, blade)
        q, dq = net3_point(flow, n11, opening, blade)
        m, dm = net3_point(torque, n11, opening, blade)
        v = 1.0 - w
        return (w * (mq + q) + v * eq, w * (mdq + dq) + v * edq, w * (mm + m) + v * em, w * (mdm + dm) + v * edm)
    if w <= 0.0:
        return unit_point(blend[:12], n11, opening, blade)
    q, dq = net3_point(flow, n11, opening, blade)
    m, dm = net3_point(torque, n11, opening, blade)
    if blend[14] == 0.0:
        if w >= 1.0:
            return q, dq, m, dm
        mq, mdq, mm, mdm = unit_point(blend[:12], n11, opening, blade)
        v = 1.0 - w
        return w * q + v * mq, w * dq + v * mdq, w * m + v * mm, w * dm + v * mdm
    mq, mdq, mm, mdm = unit_point(blend[:12], n11, opening, blade)
    return mq + w * q, mdq + w * dq, mm + w * m, mdm + w * dm


@numba.njit(cache=True)
def blended_value(net, blend, n11, opening, blade, which):
    """The value alone of Q11 (``which`` 0, ``net`` the flow net) or M11 (1, the torque net) of
    :func:`blended_point`, by the same formulas: what the pressure loop's iterations and the torque at the converged
    head read."""
    w = _smoothstep(opening, blend[12], blend[13])[0]
    if blend[14] == WEIGHED and w < 1.0:
        e = weighed_point(net, blend, n11, opening, blade, which)[0]
        if w <= 0.0:
            return e
        mq, _, mm, _ = unit_point(blend[:12], n11, opening, blade)
        return w * ((mq if which == 0 else mm) + net3_point(net, n11, opening, blade)[0]) + (1.0 - w) * e
    model = 0.0
    if w < 1.0 or blend[14] != 0.0:
        mq, _, mm, _ = unit_point(blend[:12], n11, opening, blade)
        model = mq if which == 0 else mm
        if w <= 0.0:
            return model
    y = net3_point(net, n11, opening, blade)[0]
    if blend[14] != 0.0:
        return model + w * y
    if w >= 1.0:
        return y
    return w * y + (1.0 - w) * model


@numba.njit(cache=True)
def _blended_many(flow, torque, blend, n11, opening, blade, out):
    for k in range(n11.size):
        r = blended_point(flow, torque, blend, n11[k], opening[k], blade[k])
        for j in range(4):
            out[j, k] = r[j]


class BulbSilentModel:
    """The fitted bulb model (:mod:`hillchart.extension.bulb_model`) and where it answers instead of the three-input
    nets: below the table's smallest guide-vane angle, blended in between :data:`BLEND_START_FRACTION` of the gap
    from the closed vane and that angle, as the Francis nets hand over to their fitted model
    (:mod:`hillchart.nets.silent_model`). The end of a closure then has the model's physics (Q11 -> 0 at the closed
    vane with the slope of its inlet geometry, M11 -> -K N11^2) instead of the nets' few-tenths-of-a-percent misfit
    of a zero flow, which at a closed vane would be a reverse flow.

    Parameters
    ----------
    parameters : sequence of 12 float
        :data:`hillchart.synthetic.bulb.POINT_PARAMETERS` (unit quantities, angles in degrees).
    blend_openings : (float, float)
        Guide-vane angles (deg): the model alone at or below the first, the nets (or the model plus the nets'
        residual) at or above the second.
    residual : bool
        The nets give the residual to the model (``y = y_model + w y_nets``, :func:`blended_point`), as nets
        trained on a table with the extension do: they learn what the model misses, and the model's physics carries
        every region the table leaves out; False: the nets give the characteristics themselves.
    extrapolation : BulbExtrapolation, optional
        With residual nets: below the table's smallest angle (``blend_openings[1]``) the hypotheses weighed by the
        table's held-out angles answer (:mod:`hillchart.fccm.evidence`), at this member's place in their band,
        instead of the model alone; None (files written before): the model alone.
    """

    def __init__(self, parameters, blend_openings, residual: bool = False,
                 extrapolation: BulbExtrapolation | None = None):
        from hillchart.synthetic.bulb import POINT_PARAMETERS

        values = np.asarray(parameters, dtype=float)
        if values.shape != (len(POINT_PARAMETERS),) or not np.all(np.isfinite(values)):
            raise InputError(f"silent_model.parameters must be {len(POINT_PARAMETERS)} finite numbers "
                             f"({', '.join(POINT_PARAMETERS)}), got {list(np.ravel(parameters))!r}")
        lo, hi = (float(v) for v in blend_openings)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise InputError(f"silent_model.blend_openings must be two finite angles low < high, got {[lo, hi]!r}")
        if not isinstance(residual, bool):
            raise InputError(f"silent_model.residual must be true or false, got {residual!r}")
        if extrapolation is not None and not (isinstance(extrapolation, BulbExtrapolation) and residual):
            raise InputError("silent_model.extrapolation needs residual nets (residual = true) and a "
                             "BulbExtrapolation")
        if extrapolation is not None and not lo > values[_CLOSED]:
            raise InputError(f"silent_model.blend_openings must lie above the closed vane "
                             f"{values[_CLOSED]:g} deg with the extrapolation, got {[lo, hi]!r}")
        self.parameters, self.blend_openings, self.residual = values, (lo, hi), residual
        self.extrapolation = extrapolation

    @classmethod
    def from_fitted(cls, model, opening_min: float, residual: bool = False,
                    extrapolation: BulbExtrapolation | None = None, step: float | None = None) -> "BulbSilentModel":
        """From a :class:`hillchart.extension.bulb_model.FittedBulbModel` and the table's smallest guide-vane angle
        (with ``extrapolation`` the hand-over starts at :data:`hillchart.fccm.evidence.HANDOVER_FRACTION` of the gap
        from the closed vane, or :data:`hillchart.fccm.evidence.HANDOVER_STEPS` times ``step`` (the table's angle
        step, deg, :func:`hillchart.fccm.evidence.angle_step`) below the smallest angle where that is nearer; else at
        :data:`BLEND_START_FRACTION`)."""
        closed = model.opening_closed
        fraction = BLEND_START_FRACTION if extrapolation is None else HANDOVER_FRACTION
        start = closed + fraction * (opening_min - closed)
        if extrapolation is not None and step is not None:
            start = max(start, float(opening_min) - HANDOVER_STEPS * float(step))
        return cls(model.params, (start, float(opening_min)), residual=residual, extrapolation=extrapolation)

    def at(self, position: float) -> "BulbSilentModel":
        """The same model and hypotheses at ``position`` in the band (an ensemble member's)."""
        from dataclasses import replace

        if self.extrapolation is None:
            return self
        return BulbSilentModel(self.parameters, self.blend_openings, residual=self.residual,
                               extrapolation=replace(self.extrapolation, position=float(position)))

    def _values(self, n11, opening, blade_angle):
        from hillchart.extension.bulb_model import model_values

        return model_values(self.parameters, n11, opening, blade_angle)

    def q11(self, n11, opening, blade_angle):
        """The model's unit flow, m^3/s (broadcast): the model alone, everywhere."""
        return self._values(n11, opening, blade_angle)[0]

    def m11(self, n11, opening, blade_angle):
        """The model's unit torque, N*m (broadcast)."""
        return self._values(n11, opening, blade_angle)[1]

    def efficiency(self, n11, opening, blade_angle):
        """The model's hydraulic efficiency (eq. (5) of paper 004 inverted); NaN where Q11 <= 0."""
        from hillchart.characteristics import efficiency_from_unit_torque

        q, m = self._values(n11, opening, blade_angle)
        return efficiency_from_unit_torque(q, n11, m)

    def packed(self) -> np.ndarray:
        """The numbers :func:`blended_point` reads: the model's parameters, the blend openings, the flag (0.0 the
        nets of the characteristics, 1.0 the residual, :data:`WEIGHED` the residual with the weighed hypotheses, whose
        13 numbers follow)."""
        if self.extrapolation is not None:
            return np.concatenate([self.parameters, self.blend_openings, [WEIGHED], self.extrapolation.packed()])
        return np.concatenate([self.parameters, self.blend_openings, [1.0 if self.residual else 0.0]])

    def to_dict(self) -> dict:
        from hillchart.synthetic.bulb import POINT_PARAMETERS

        doc = {"kind": SILENT_KIND, "parameters": {k: float(v) for k, v in zip(POINT_PARAMETERS, self.parameters)},
               "blend_openings": list(self.blend_openings)}
        if self.residual:
            doc["residual"] = True
        if self.extrapolation is not None:
            doc["extrapolation"] = self.extrapolation.to_dict()
        return doc

    @classmethod
    def from_dict(cls, doc, key: str = "silent_model") -> "BulbSilentModel":
        """Validate a parsed ``silent_model`` block of a three-input nets.json."""
        from hillchart.synthetic.bulb import POINT_PARAMETERS

        required = {"kind", "parameters", "blend_openings"}
        if not isinstance(doc, dict) or not required <= set(doc) <= required | {"residual", "extrapolation"}:
            raise InputError(f"{key} must be an object with the keys kind, parameters, blend_openings (and optionally "
                             f"residual, extrapolation), got {sorted(doc) if isinstance(doc, dict) else doc!r}")
        residual = doc.get("residual", False)
        if not isinstance(residual, bool):
            raise InputError(f"{key}.residual must be true or false, got {residual!r}")
        if doc["kind"] != SILENT_KIND:
            raise InputError(f"{key}.kind must be {SILENT_KIND!r}, got {doc['kind']!r}")
        params = doc["parameters"]
        if not isinstance(params, dict) or set(params) != set(POINT_PARAMETERS):
            raise InputError(f"{key}.parameters must have exactly the keys {', '.join(POINT_PARAMETERS)}")
        blend = doc["blend_openings"]
        if not isinstance(blend, list) or len(blend) != 2:
            raise InputError(f"{key}.blend_openings must be a [low, high] pair of angles (deg), got {blend!r}")
        try:
            values = [float(check_finite(f"{key}.parameters.{k}", params[k])) for k in POINT_PARAMETERS]
            pair = [float(check_finite(f"{key}.blend_openings", v)) for v in blend]
        except (TypeError, ValueError):
            raise InputError(f"{key} must hold numbers (parameters, blend_openings)") from None
        extrapolation = (BulbExtrapolation.from_dict(doc["extrapolation"], key=f"{key}.extrapolation")
                         if "extrapolation" in doc else None)
        return cls(values, pair, residual=residual, extrapolation=extrapolation)
