"""Beyond Wu et al.: a three-input hill chart Q11(N11, a, phi), M11(N11, a, phi) of a double-regulated turbine and its
on-cam relation."""

from __future__ import annotations

from pathlib import Path

import math

import numba
import numpy as np

from hillchart.errors import InputError, NumericalError
from hillchart.fccm.evidence import (HANDOVER_FRACTION, BulbExtrapolation, band_square_compiled,
                                     hypothesis_value)
from hillchart.fccm.net import FCCMNet, FCCMWeights
from hillchart.fccm.plots import _figure
from hillchart.nets.silent_model import _smoothstep
from hillchart.nets.weights import ensemble_blocks
from hillchart.synthetic.bulb import POINT_PARAMETERS, unit_point
from hillchart.validation import check_finite

# ----------------------------------------------------------------------------------------------------------------
# beyond the paper: a three-input hill chart of a double-regulated turbine and its on-cam relation
# ----------------------------------------------------------------------------------------------------------------
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
#: flag value (``blend[14]``) of residual nets with the weighed hypotheses below the table (then 13 more numbers,
#: :meth:`hillchart.fccm.evidence.BulbExtrapolation.packed`).
_CLOSED = POINT_PARAMETERS.index("guide_vane_closed_deg")
_K_DISC = POINT_PARAMETERS.index("k_disc_friction")
WEIGHED = 2.0


@numba.njit(cache=True)
def weighed_point(net, blend, n11, opening, blade, which):
    """``(y, dy/dN11)`` of the weighed hypotheses (:mod:`hillchart.fccm.evidence`) below the table's smallest
    guide-vane angle ``a_low = blend[13]``, Q11 (``which`` 0, ``net`` the flow net) or M11 (1, the torque net), at the
    member's place in the band: ``y_low`` is the model plus the nets' residual at ``a_low``, the band multiplies
    Q11 and the hydraulic torque ``M11 + K N11^2`` by ``exp(offset h(d))``, each by its own offset (``h`` of
    :func:`hillchart.extension.hypotheses.band_square` at ``d = 1 - t``)."""
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
    y = dy = 0.0
    for h in range(4):
        w = blend[base + h]
        if w > 0.0:
            y += w * hypothesis_value(h, t, y_m, y_ml, y_ml + r, y_0, c)
            dy += w * hypothesis_value(h, t, dy_m, dy_ml, dy_ml + dr, dy_0, c)
    f = math.exp(blend[25 + which] * band_square_compiled(1.0 - t, blend[27])[0])
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
                    extrapolation: BulbExtrapolation | None = None) -> "BulbSilentModel":
        """From a :class:`hillchart.extension.bulb_model.FittedBulbModel` and the table's smallest guide-vane angle
        (with ``extrapolation`` the hand-over starts at :data:`hillchart.fccm.evidence.HANDOVER_FRACTION` of the gap
        from the closed vane, else at :data:`BLEND_START_FRACTION`)."""
        closed = model.opening_closed
        fraction = BLEND_START_FRACTION if extrapolation is None else HANDOVER_FRACTION
        return cls(model.params, (closed + fraction * (opening_min - closed), float(opening_min)),
                   residual=residual, extrapolation=extrapolation)

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


def _net_block(weights: FCCMWeights, output: str) -> dict:
    """A single-output :class:`FCCMWeights` as a ``nets.json`` NET block with three inputs."""
    return {"inputs": list(NET3_INPUTS), "output": output,
            "x_min": [float(v) for v in weights.x_min], "x_max": [float(v) for v in weights.x_max],
            "y_min": float(weights.y_min[0]), "y_max": float(weights.y_max[0]),
            "W1": [[float(v) for v in row] for row in weights.W1], "b1": [float(v) for v in weights.b1],
            "W2": [float(v) for v in weights.W2[0]], "b2": float(weights.b2[0])}


def _weights_from_block(block, key: str, output: str) -> FCCMWeights:
    if not isinstance(block, dict):
        raise InputError(f"{key} must be an object, got {type(block).__name__}")
    required = ("inputs", "output", "x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2", "b2")
    for name in required:
        if name not in block:
            raise InputError(f"{key}.{name} is missing (a NET needs keys {', '.join(required)})")
    if block["inputs"] != list(NET3_INPUTS):
        raise InputError(f"{key}.inputs must be {list(NET3_INPUTS)}, got {block['inputs']!r}")
    if block["output"] != output:
        raise InputError(f"{key}.output must be {output!r}, got {block['output']!r}")
    for name in ("y_min", "y_max", "b2"):
        check_finite(f"{key}.{name}", block[name])
    if not isinstance(block["W2"], list):
        raise InputError(f"{key}.W2 must be a list of numbers, got {block['W2']!r}")
    try:
        return FCCMWeights(inputs=NET3_INPUTS, outputs=(output,), x_min=block["x_min"], x_max=block["x_max"],
                           y_min=[block["y_min"]], y_max=[block["y_max"]], W1=block["W1"], b1=block["b1"],
                           W2=[block["W2"]], b2=[block["b2"]])
    except InputError as exc:
        raise InputError(f"{key}.{exc}") from None


class DoubleRegulatedNets:
    """Q11(N11, a, phi) (m^3/s) and M11(N11, a, phi) (N*m) of a double-regulated turbine: two three-input nets in
    the ``nets.json`` NET format with ``"inputs": ["n11", "opening", "blade_angle"]`` (numpy evaluation, no torch).

    Parameters
    ----------
    flow, torque : FCCMWeights
        Three inputs (n11 r/min, opening, blade angle deg), one output each.
    opening_unit : str
    training : dict, optional
    silent_model : BulbSilentModel, optional
        The fitted bulb model the nets extend (the extension of :func:`table_unit_samples`) and what answers below
        the table's smallest guide-vane angle: the hypotheses weighed by the table's held-out angles
        (:mod:`hillchart.fccm.evidence`), or the model alone in files without them; None: the nets alone everywhere.
    ensemble : list of (flow, torque, silent_model or None), optional
        The ensemble members (:func:`train_table_nets`; the point nets among them), each run by ``hillsim run
        --uncertainty`` as characteristics of its own (:meth:`members`).
    """

    def __init__(self, flow: FCCMWeights, torque: FCCMWeights, opening_unit: str = "deg",
                 training: dict | None = None, silent_model: BulbSilentModel | None = None, ensemble=None):
        for name, w in (("flow", flow), ("torque", torque)):
            if not isinstance(w, FCCMWeights) or len(w.inputs) != 3 or len(w.outputs) != 1:
                raise InputError(f"DoubleRegulatedNets.{name} must be a 3-input, 1-output FCCMWeights")
        if silent_model is not None and not isinstance(silent_model, BulbSilentModel):
            raise InputError("DoubleRegulatedNets.silent_model must be a BulbSilentModel or None")
        self.flow, self.torque = flow, torque
        self.opening_unit = opening_unit
        self.training = dict(training or {})
        self.silent_model = silent_model
        self.ensemble = [tuple(member) for member in (ensemble or [])]

    def members(self) -> list["DoubleRegulatedNets"]:
        """The ensemble members as nets of their own (empty when the file has no ensemble)."""
        return [DoubleRegulatedNets(f, t, opening_unit=self.opening_unit, training=self.training, silent_model=s)
                for f, t, s in self.ensemble]

    def blend_packed(self) -> np.ndarray:
        """The blend vector of :func:`blended_point` (:data:`NO_BLEND` without a silent model)."""
        return NO_BLEND if self.silent_model is None else self.silent_model.packed()

    def _x(self, n11, opening, blade_angle):
        arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (n11, opening, blade_angle)))
        return np.column_stack([a.ravel() for a in arrays]), arrays[0].shape

    def _blended(self, x) -> np.ndarray:
        """(4, N): q11, dq11/dN11, m11, dm11/dN11 of :func:`blended_point` at the rows of ``x``."""
        out = np.empty((4, x.shape[0]))
        _blended_many(packed_net3(self.flow), packed_net3(self.torque), self.blend_packed(),
                      np.ascontiguousarray(x[:, 0]), np.ascontiguousarray(x[:, 1]), np.ascontiguousarray(x[:, 2]),
                      out)
        return out

    def _value(self, which: int, n11, opening, blade_angle):
        x, shape = self._x(n11, opening, blade_angle)
        if self.silent_model is None:
            return (self.flow, self.torque)[which].predict(x)[:, 0].reshape(shape)
        return self._blended(x)[2 * which].reshape(shape)

    def _grad(self, which: int, n11, opening, blade_angle):
        x, shape = self._x(n11, opening, blade_angle)
        g = (self.flow, self.torque)[which].predict_grad(x)[:, 0, :]
        if self.silent_model is not None:
            blended = (x[:, 1] < self.silent_model.blend_openings[1]) | self.silent_model.residual
            if blended.any():  # the blend: N11 analytic, the opening and blade angle by central differences
                xb = x[blended]
                g[blended, 0] = self._blended(xb)[2 * which + 1]
                for j in (1, 2):
                    step = np.zeros(3)
                    step[j] = 1e-5
                    g[blended, j] = (self._blended(xb + step)[2 * which] - self._blended(xb - step)[2 * which]) / 2e-5
        return tuple(g[:, j].reshape(shape) for j in range(3))

    def q11(self, n11, opening, blade_angle):
        """Unit flow Q11, m^3/s (broadcast)."""
        return self._value(0, n11, opening, blade_angle)

    def m11(self, n11, opening, blade_angle):
        """Unit torque M11, N*m (broadcast)."""
        return self._value(1, n11, opening, blade_angle)

    def q11_grad(self, n11, opening, blade_angle):
        """(dQ11/dN11, dQ11/da, dQ11/dphi): analytic; with the silent model (below the table's smallest guide-vane
        angle, or everywhere when the nets give the residual to it) the opening and blade-angle derivatives by
        central differences of step 1e-5 deg."""
        return self._grad(0, n11, opening, blade_angle)

    def m11_grad(self, n11, opening, blade_angle):
        """(dM11/dN11, dM11/da, dM11/dphi), as :meth:`q11_grad`."""
        return self._grad(1, n11, opening, blade_angle)

    def efficiency(self, n11, opening, blade_angle):
        """Hydraulic efficiency M11 omega11 / (rho g Q11) (inverse of eq. (5) of paper 004); NaN where Q11 <= 0."""
        from hillchart.characteristics import efficiency_from_unit_torque

        return efficiency_from_unit_torque(self.q11(n11, opening, blade_angle), n11,
                                           self.m11(n11, opening, blade_angle))

    def on_cam(self, openings, heads_m, *, speed_rpm: float, runner_diameter_m: float, **kwargs) -> dict:
        """:func:`on_cam_relation` of these nets, with ``outside_domain`` (per head: n11 = n D / sqrt(H) or an
        opening outside the box the nets were fitted on) and a :class:`UserWarning` when any is (extrapolation)."""
        import warnings

        cam = on_cam_relation(self.efficiency, openings, heads_m, speed_rpm=speed_rpm,
                              runner_diameter_m=runner_diameter_m, **kwargs)
        n11 = speed_rpm * runner_diameter_m / np.sqrt(cam["head_m"])
        lo, hi = self.flow.x_min, self.flow.x_max
        outside = (n11 < lo[0]) | (n11 > hi[0])
        outside = outside | bool(np.any((cam["opening"] < lo[1]) | (cam["opening"] > hi[1])))
        cam["outside_domain"] = outside
        if outside.any():
            warnings.warn(f"on_cam: heads {cam['head_m'][outside].tolist()} m (or the openings) lie outside the "
                          f"nets' fitted box (n11 {lo[0]:.4g}-{hi[0]:.4g} r/min, opening {lo[1]:.4g}-{hi[1]:.4g}): "
                          "extrapolated", UserWarning, stacklevel=2)
        return cam

    def to_dict(self) -> dict:
        return {"format": "hillsim.nets", "version": 1,
                "units": {"n11": "r/min", "opening": self.opening_unit, "blade_angle": "deg", "q11": "m^3/s",
                          "m11": "N*m"},
                "flow": _net_block(self.flow, "q11"), "torque": _net_block(self.torque, "m11"),
                **({} if self.silent_model is None else {"silent_model": self.silent_model.to_dict()}),
                **({} if not self.ensemble else {"ensemble": [
                    {"flow": _net_block(f, "q11"), "torque": _net_block(t, "m11"),
                     **({} if s is None else {"silent_model": s.to_dict()})} for f, t, s in self.ensemble]}),
                "training": self.training}

    def to_json(self) -> str:
        """``nets.json`` text, in the layout of the two-input nets' file."""
        from hillchart.nets.hill_nets import nets_json_text

        return nets_json_text(self.to_dict())

    def save(self, path) -> Path:
        path = Path(path)
        path.write_text(self.to_json(), encoding="utf-8")
        return path

    @classmethod
    def from_dict(cls, doc) -> "DoubleRegulatedNets":
        """Validate a three-input ``nets.json`` document (format hillsim.nets, version 1, NET blocks with inputs
        n11, opening, blade_angle)."""
        if not isinstance(doc, dict):
            raise InputError(f"nets.json must hold an object, got {type(doc).__name__}")
        for key in ("format", "version", "units", "flow", "torque"):
            if key not in doc:
                raise InputError(f"key {key!r} is missing (required: format, version, units, flow, torque)")
        if doc["format"] != "hillsim.nets":
            raise InputError(f"format must be 'hillsim.nets', got {doc['format']!r}")
        if isinstance(doc["version"], bool) or doc["version"] != 1:
            raise InputError(f"version must be 1, got {doc['version']!r}")
        units = doc["units"]
        fixed = {"n11": "r/min", "blade_angle": "deg", "q11": "m^3/s", "m11": "N*m"}
        if not isinstance(units, dict) or any(units.get(k) != v for k, v in fixed.items()):
            raise InputError(f"units must hold {fixed} and the opening unit, got {units!r}")
        if not isinstance(units.get("opening"), str) or not units.get("opening"):
            raise InputError(f"units.opening must be a non-empty string, got {units.get('opening')!r}")
        training = doc["training"] if "training" in doc else {}
        if not isinstance(training, dict):
            raise InputError(f"training must be an object, got {type(training).__name__}")
        silent = BulbSilentModel.from_dict(doc["silent_model"]) if "silent_model" in doc else None
        ensemble = []
        for i, member in enumerate(ensemble_blocks(doc)):
            ensemble.append((_weights_from_block(member["flow"], f"ensemble[{i}].flow", "q11"),
                             _weights_from_block(member["torque"], f"ensemble[{i}].torque", "m11"),
                             BulbSilentModel.from_dict(member["silent_model"], key=f"ensemble[{i}].silent_model")
                             if "silent_model" in member else None))
        return cls(flow=_weights_from_block(doc["flow"], "flow", "q11"),
                   torque=_weights_from_block(doc["torque"], "torque", "m11"), opening_unit=units["opening"],
                   training=training, silent_model=silent, ensemble=ensemble)


def load_double_regulated_nets(path) -> DoubleRegulatedNets:
    """Read a three-input ``nets.json`` (see :class:`DoubleRegulatedNets`); errors name the file and the key."""
    from hillchart.nets.hill_nets import read_nets_json

    path = Path(path)
    doc = read_nets_json(path)
    try:
        return DoubleRegulatedNets.from_dict(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def bulb_chart_samples(turbine=None, *, n_points: int = 600, seed: int = 0, n11_range=(110.0, 230.0),
                       opening_range=None) -> dict:
    """Scattered samples of the synthetic bulb's unit characteristic (its 'chart'): the 8 corners of the box plus a
    seeded Latin hypercube over n11 (r/min), guide-vane angle (``opening_range``, default the paper's range) and
    blade angle (the paper's range), with exact Q11 (m^3/s) and M11 (N*m)."""
    from scipy.stats import qmc

    from hillchart.synthetic.bulb import BLADE_RANGE_DEG, GUIDE_VANE_RANGE_DEG, SyntheticBulb

    turbine = turbine or SyntheticBulb()
    opening_range = GUIDE_VANE_RANGE_DEG if opening_range is None else opening_range
    lo = np.array([n11_range[0], opening_range[0], BLADE_RANGE_DEG[0]])
    hi = np.array([n11_range[1], opening_range[1], BLADE_RANGE_DEG[1]])
    corners = np.array([[lo[0] if i & 1 == 0 else hi[0], lo[1] if i & 2 == 0 else hi[1],
                         lo[2] if i & 4 == 0 else hi[2]] for i in range(8)])  # the fitted box = the chart's ranges
    x = np.vstack([corners, qmc.scale(qmc.LatinHypercube(d=3, seed=np.random.default_rng(seed)).random(n_points - 8),
                                      lo, hi)])
    n11, gv, blade = x.T
    return {"n11": n11, "opening": gv, "blade_angle": blade, "q11": turbine.q11(n11, gv, blade),
            "m11": turbine.m11(n11, gv, blade)}


def train_double_regulated_nets(samples: dict, *, hidden: int = 15, restarts: int = 3, seed: int = 0,
                                split=(0.70, 0.15, 0.15)) -> DoubleRegulatedNets:
    """Q11 and M11 nets (3-H-1 logsig, Levenberg-Marquardt, as :class:`FCCMNet`) from chart samples with keys
    n11, opening, blade_angle, q11, m11; the flow net uses ``seed``, the torque net ``seed + 1``."""
    X = np.column_stack([np.asarray(samples[k], dtype=float) for k in NET3_INPUTS])
    nets, record = {}, {"hidden": hidden, "restarts": restarts, "split": list(split), "n_samples": int(len(X))}
    for offset, (key, out) in enumerate((("flow", "q11"), ("torque", "m11"))):
        est = FCCMNet(hidden=hidden, restarts=restarts, seed=seed + offset, split=split).fit(
            X, np.asarray(samples[out], dtype=float), input_names=NET3_INPUTS, output_names=(out,))
        nets[key] = est.weights_
        record[key] = est.training_record()
    return DoubleRegulatedNets(flow=nets["flow"], torque=nets["torque"], opening_unit="deg", training=record)


#: How the shipped bulb nets (``data_synthetic/bulb/nets.json``) are made: samples of the synthetic bulb's unit
#: characteristic over the range a load rejection of the example plant visits (n11 up to runaway, guide vanes down
#: to 0.2 deg above closure), plus samples at the closed vane (Q11 = 0: the extension to zero opening, without which
#: the nets leak a little flow at closure that pumps the water hammer), and the net size.
SHIPPED_BULB_NETS = {"n_points": 2000, "n_closed": 300, "seed": 0, "n11_range": (100.0, 300.0),
                     "opening_range": (35.2, 78.0), "hidden": 30, "restarts": 2}


def bulb_closed_vane_samples(turbine=None, *, n_points: int = 300, seed: int = 0, n11_range=(100.0, 300.0)) -> dict:
    """Samples of the synthetic bulb at the closed guide vane (1e-6 deg above the angle at which the vanes touch:
    Q11 ~ 0, M11 the disc friction), over a seeded uniform draw of n11 (r/min) and blade angle (deg)."""
    from hillchart.synthetic.bulb import BLADE_RANGE_DEG, SyntheticBulb

    turbine = turbine or SyntheticBulb()
    rng = np.random.default_rng([seed, 2])
    n11 = rng.uniform(n11_range[0], n11_range[1], n_points)
    blade = rng.uniform(BLADE_RANGE_DEG[0], BLADE_RANGE_DEG[1], n_points)
    gv = np.full(n_points, turbine.params.guide_vane_closed_deg + 1e-6)
    return {"n11": n11, "opening": gv, "blade_angle": blade, "q11": turbine.q11(n11, gv, blade),
            "m11": turbine.m11(n11, gv, blade)}


def write_bulb_nets(out_dir) -> Path:
    """Train and write the shipped three-input nets of the synthetic bulb (:data:`SHIPPED_BULB_NETS`) to
    ``out_dir/nets.json``; the same settings give the same nets (seeded)."""
    cfg = SHIPPED_BULB_NETS
    chart = bulb_chart_samples(n_points=cfg["n_points"], seed=cfg["seed"], n11_range=cfg["n11_range"],
                               opening_range=cfg["opening_range"])
    closed = bulb_closed_vane_samples(n_points=cfg["n_closed"], seed=cfg["seed"], n11_range=cfg["n11_range"])
    samples = {k: np.concatenate([chart[k], closed[k]]) for k in chart}
    nets = train_double_regulated_nets(samples, hidden=cfg["hidden"], restarts=cfg["restarts"], seed=cfg["seed"])
    # below the sampled box (0.2 deg above the closed vane) the physical bulb model answers, fitted to the samples as
    # it is to a user's table (hillchart.extension.bulb_model): at the closed vane, where a rejection spends most of
    # its run, the loop then evaluates the model and not the two 3-30-1 nets
    from hillchart.extension.bulb_model import fit_bulb_model
    from hillchart.synthetic.bulb import SyntheticBulb

    model = fit_bulb_model(chart["n11"], chart["opening"], chart["blade_angle"], chart["q11"], chart["m11"],
                           opening_closed=SyntheticBulb().params.guide_vane_closed_deg, seed=cfg["seed"],
                           source="the shipped bulb samples")
    nets.silent_model = BulbSilentModel.from_fitted(model, cfg["opening_range"][0])
    nets.training["boundary_model"] = model.to_dict()
    nets.training["source"] = ("samples of the synthetic bulb's unit characteristic (hillchart.synthetic.bulb): "
                               f"{cfg['n_points']} scattered, {cfg['n_closed']} at the closed vane, seed {cfg['seed']}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return nets.save(out / "nets.json")


def table_unit_samples(table, *, opening_closed: float | None = None, zero_opening_points: int = 200,
                       seed: int = 0, extension: bool = True) -> tuple[dict, list[str], object]:
    """Unit samples (n11, opening, blade_angle, q11, m11, origin) of a double-regulated test table
    (:class:`hillchart.fccm.table.TestTable` with ``guide_vane_deg``, ``n11_rpm``, ``q11_m3_s``, ``efficiency`` and
    ``blade_angle_deg``), the notes on what was assumed, and the fitted bulb model (None without the extension).

    * M11 from the efficiency, eq. (5) of the BP hill-chart paper (``M11 = rho g Q11 eta / omega11``).
    * A table without ``blade_angle_deg`` is a fixed-blade (propeller) unit: ``blade_angle_deg`` of the table's
      ``table.toml`` is not known, so the angle is taken as 0 deg (a note says so); the nets then do not depend on it.
    * ``extension`` (default): the physical bulb model fitted to the table
      (:func:`hillchart.extension.bulb_model.fit_bulb_model`, with ``opening_closed`` when given, else the closed
      angle fitted) gives the samples where the table is silent
      (:func:`hillchart.extension.bulb_model.extension_samples`): the closed vane (Q11 = 0, M11 = -K N11^2, eqs.
      (6) and (8) of paper 004), runaway, zero speed and the region between them and the table. Raises
      :class:`InputError` when the model cannot represent the table.
    * Without the extension, with ``opening_closed`` (the guide-vane angle at which the vanes touch):
      ``zero_opening_points`` samples with Q11 = 0 and M11 = 0 over the table's N11 and blade-angle range.
    """
    from hillchart.characteristics import unit_torque_from_efficiency

    from hillchart.fccm.on_cam import is_on_cam_table

    if is_on_cam_table(table):
        raise InputError("the table has blade_angle_deg but no guide_vane_deg: an on-cam chart, whose nets are "
                         "two-input over the cam position (hillchart.fccm.on_cam.on_cam_unit_samples; hillsim fccm "
                         "--simulator-nets does this by itself)")
    notes = []
    n11 = np.asarray(table.column("n11_rpm"), float)
    q11 = np.asarray(table.column("q11_m3_s"), float)
    opening = np.asarray(table.column("guide_vane_deg"), float)
    eta = np.asarray(table.column("efficiency"), float)
    if "blade_angle_deg" in table.columns:
        blade = np.asarray(table.column("blade_angle_deg"), float)
    else:
        blade = np.zeros_like(n11)
        notes.append("the table has no blade_angle_deg column: a fixed-blade (propeller) unit, blade angle taken as "
                     "0 deg (use combinator.relation = \"off\", fixed_angle_deg = 0 in the plant)")
    ok = np.isfinite(n11) & np.isfinite(q11) & np.isfinite(eta) & (n11 > 0)
    if not ok.all():
        notes.append(f"{int((~ok).sum())} rows without n11, Q11 or efficiency left out")
    n11, q11, opening, eta, blade = n11[ok], q11[ok], opening[ok], eta[ok], blade[ok]
    m11 = unit_torque_from_efficiency(q11, n11, eta)  # eq. (5) of paper 004
    samples = {"n11": n11, "opening": opening, "blade_angle": blade, "q11": q11, "m11": np.asarray(m11, float),
               "origin": np.full(n11.size, "measured")}
    if opening_closed is not None and not opening_closed < opening.min():
        raise InputError(f"the closed guide-vane angle {opening_closed!r} must be below the table's smallest "
                         f"guide_vane_deg {opening.min()!r}")
    model = None
    if extension:
        samples, note, model = extend_unit_samples(samples, opening_closed=opening_closed, seed=seed,
                                                   source=f"the table {table.info.name!r}")
        notes.append(note)
    elif opening_closed is not None:
        rng = np.random.default_rng([seed, 3])
        k = int(zero_opening_points)
        zero = {"n11": rng.uniform(n11.min(), n11.max(), k), "opening": np.full(k, float(opening_closed)),
                "blade_angle": rng.uniform(blade.min(), blade.max(), k) if np.ptp(blade) > 0 else np.full(k, blade[0]),
                "q11": np.zeros(k), "m11": np.zeros(k), "origin": np.full(k, "zero-opening")}
        samples = {key: np.concatenate([samples[key], zero[key]]) for key in samples}
        notes.append(f"extended to the closed vane ({opening_closed:g} deg): {k} samples with Q11 = 0, M11 = 0")
    return samples, notes, model


def extend_unit_samples(samples: dict, *, opening_closed: float | None = None, seed: int = 0,
                        source: str = "the table") -> tuple[dict, str, object]:
    """Measured unit samples (dict of n11, opening, blade_angle, q11, m11, origin "measured") plus the samples of the
    physical bulb model fitted to them where they are silent (:func:`hillchart.extension.bulb_model.fit_bulb_model`,
    :func:`hillchart.extension.bulb_model.extension_samples`), the note that says so, and the model: the extension of
    :func:`table_unit_samples`. Raises :class:`InputError` when the model cannot represent the samples."""
    from hillchart.extension.bulb_model import extension_samples, fit_bulb_model

    n11, opening, blade = (np.asarray(samples[k], float) for k in NET3_INPUTS)
    model = fit_bulb_model(n11, opening, blade, samples["q11"], samples["m11"], opening_closed=opening_closed,
                           seed=seed, source=source)
    extra = extension_samples(model, n11, opening, blade)
    out = {key: np.concatenate([np.asarray(samples[key]), extra[key]]) for key in extra}
    counts = {o: int(np.sum(extra["origin"] == o)) for o in ("zero-opening", "runaway", "zero-speed", "silent-region")}
    closed_text = (f"fitted closed vane {model.opening_closed:.4g} deg" if model.closed_fitted
                   else f"closed vane {model.opening_closed:g} deg")
    note = (f"extended by the physical bulb model (fits the table to Q11 RMS {model.q11_rms_pct:.2g} %, M11 RMS "
            f"{model.m11_rms_pct:.2g} % of the largest measured value; {closed_text}, K = "
            f"{model.k_zero_opening:.3g} N*m/(r/min)^2): " + ", ".join(f"{n} {o}" for o, n in counts.items())
            + " samples")
    return out, note, model


def train_table_nets(samples: dict, *, hidden: int = 15, restarts: int = 3, seed: int = 0, members: int = 5,
                     split=(0.70, 0.15, 0.15), model=None) -> tuple["DoubleRegulatedNets", dict]:
    """Three-input nets from ``samples`` (:func:`table_unit_samples`) with an ensemble of ``members`` nets (seeds
    ``seed``, ``seed + 2``, ...; the first is the point nets) and the plausibility checks: on a grid over the
    samples' box, the share of points where Q11 falls as the guide vanes open (dQ11/da < 0), where the efficiency
    exceeds 1 (where Q11 is above 5 % of its largest value), and the ensemble's spread (5-95 % of Q11 and M11, as
    % of their ranges). A constant input (a fixed-blade table) is widened by 1 on either side (copies of the samples
    at -1, 0, +1) so the net's scaling is defined; the nets do not depend on it.

    With ``model`` (the fitted bulb model :func:`table_unit_samples` returns), the nets learn the residual to the
    model (what it misses at the measured samples, zero at its own extension samples), and the model is stored with
    them (:class:`BulbSilentModel`, ``residual``): the characteristics are the model's plus the nets' residual. Below
    the table's smallest guide-vane angle the hypotheses weighed by the table's own held-out angles answer
    (:func:`hillchart.fccm.evidence.table_evidence`, recorded in ``training["extrapolation"]``); the point nets read
    their weighed answer, each member stands at its place in their band
    (:func:`hillchart.extension.hypotheses.member_positions`, seeded by ``seed``), as the Francis nets do. The members
    differ otherwise by their seeds (splits and initialisations).

    Returns
    -------
    nets : DoubleRegulatedNets
    report : dict
        ``plausibility`` figures and ``warnings`` (text that says what to check).
    """
    X = {k: np.asarray(samples[k], float) for k in NET3_INPUTS}
    arrays = ("n11", "opening", "blade_angle", "q11", "m11")
    constant = [k for k in NET3_INPUTS if np.ptp(X[k]) == 0]

    def widened(member_samples):
        # a constant input: copies at -1, 0 and +1 so that the scaling is defined, the slope 0, and the net is
        # trained at the constant itself (with copies at +-1 alone a 3-6-1 net interpolated Q11 2.5 x off at 0)
        fitted = {k: np.asarray(member_samples[k], float) for k in arrays}
        if constant:
            size = fitted["n11"].size
            fitted = {k: np.concatenate([fitted[k]] * 3) for k in arrays}
            for k in constant:
                fitted[k] = fitted[k] + np.repeat([-1.0, 0.0, 1.0], size)
        return fitted

    measured = np.asarray(samples.get("origin", np.full(X["n11"].size, "measured"))) == "measured"
    fitted = samples
    if model is not None:  # what the model misses (0 where the model sampled)
        n, a, b = (np.asarray(samples[k], float) for k in NET3_INPUTS)
        fitted = {**samples, "q11": np.asarray(samples["q11"], float) - model.q11(n, a, b),
                  "m11": np.asarray(samples["m11"], float) - model.m11(n, a, b)}
    count = max(1, members)
    ensemble = [train_double_regulated_nets(widened(fitted), hidden=hidden, restarts=restarts, seed=seed + 2 * i,
                                            split=split) for i in range(count)]
    member_silent = [None] * count
    evidence = None
    if model is not None:  # the nets are the residual to the model; below the table the weighed hypotheses answer
        from hillchart.extension.hypotheses import member_positions
        from hillchart.fccm.evidence import table_evidence

        evidence = table_evidence({k: np.asarray(samples[k], float)[measured] for k in arrays}, model, seed=seed)
        point = BulbSilentModel.from_fitted(model, float(X["opening"][measured].min()), residual=True,
                                            extrapolation=BulbExtrapolation.of_evidence(evidence))
        member_silent = [point.at(float(u)) for u in member_positions(count, seed)] if count > 1 else [point]
        for member, silent in zip(ensemble, member_silent):
            member.silent_model = silent
    nets = ensemble[0]
    lo = np.array([X[k].min() for k in NET3_INPUTS])
    hi = np.array([X[k].max() for k in NET3_INPUTS])
    axes = [np.linspace(lo[j], hi[j], 12) for j in range(3)]
    g = np.meshgrid(*axes, indexing="ij")
    n11, a, phi = (v.ravel() for v in g)
    q = nets.q11(n11, a, phi)
    dq_da = nets.q11_grad(n11, a, phi)[1]
    eta = nets.efficiency(n11, a, phi)
    q_all = np.array([m.q11(n11, a, phi) for m in ensemble])
    m_all = np.array([m.m11(n11, a, phi) for m in ensemble])
    spread_q = float(np.median(np.percentile(q_all, 95, axis=0) - np.percentile(q_all, 5, axis=0))
                     / max(np.ptp(samples["q11"]), 1e-12))
    spread_m = float(np.median(np.percentile(m_all, 95, axis=0) - np.percentile(m_all, 5, axis=0))
                     / max(np.ptp(samples["m11"]), 1e-12))
    flowing = q > 0.05 * q.max()  # the efficiency of a near-zero flow is the ratio of two small numbers
    eta = np.where(flowing, eta, np.nan)
    report = {"plausibility": {"share_dq11_da_negative": float(np.mean(dq_da < 0)),
                               "share_efficiency_above_1": float(np.mean(np.nan_to_num(eta) > 1.0)),
                               "max_efficiency": float(np.nanmax(eta)), "q11_min": float(q.min()),
                               "ensemble_members": len(ensemble),
                               "ensemble_spread_q11_pct": 100.0 * spread_q,
                               "ensemble_spread_m11_pct": 100.0 * spread_m},
              "warnings": []}
    p = report["plausibility"]
    if p["share_dq11_da_negative"] > 0.05:
        report["warnings"].append(f"Q11 falls as the guide vanes open on {100 * p['share_dq11_da_negative']:.0f} % of "
                                  "the table's box: the nets fit noise or the table is thin there; check the table, "
                                  "fewer hidden neurons (--hidden)")
    if p["share_efficiency_above_1"] > 0:
        report["warnings"].append(f"the nets' efficiency exceeds 1 on {100 * p['share_efficiency_above_1']:.1f} % of "
                                  f"the table's box (max {p['max_efficiency']:.3f}): implausible; check the table's "
                                  "efficiency column (a fraction) and the extension")
    nets.training["plausibility"] = p
    # the box of the table itself (the nets' box includes the extension): the combinator's cam is searched over it
    nets.training["measured_box"] = {k: [float(X[k][measured].min()), float(X[k][measured].max())]
                                     for k in NET3_INPUTS}
    nets.training["ensemble_seeds"] = [seed + 2 * i for i in range(len(ensemble))]
    if len(ensemble) > 1:  # kept for the bands of the guarantee figures (hillsim run --uncertainty)
        nets.ensemble = [(m.flow, m.torque, m.silent_model) for m in ensemble]
    if evidence is not None:  # the point nets read the weighed hypotheses themselves, their members the band
        nets.silent_model = nets.silent_model.at(0.0)
        nets.training["extrapolation"] = evidence.to_dict()
    return nets, report


def on_cam_relation(efficiency, openings, heads_m, *, speed_rpm: float, runner_diameter_m: float,
                    blade_range=(-18.0, 16.0), step_deg: float = 0.05) -> dict:
    """The on-cam (combinator) relation phi(a, H): the blade angle of best efficiency at each guide-vane opening a
    and head H of a unit at constant speed, ``n11 = n D / sqrt(H)`` (eq. (2) of paper 003).

    Parameters
    ----------
    efficiency : callable (n11, opening, blade_angle) -> eta, broadcast
        E.g. :meth:`DoubleRegulatedNets.efficiency` or :meth:`hillchart.synthetic.bulb.SyntheticBulb.unit_efficiency`.
    openings, heads_m : array_like
    blade_range : (lo, hi), deg
    step_deg : float
        Scan step; the optimum is refined by the vertex of the parabola through the best scan point and its
        neighbours (exact for a locally quadratic efficiency).

    Returns
    -------
    dict
        ``opening`` (na,), ``head_m`` (nh,), ``blade_angle`` (nh, na) in deg, ``efficiency`` (nh, na), ``at_bound``
        (nh, na) bool: the optimum is on the blade range's edge (the cam saturates there), ``held`` (nh, na) bool:
        no blade angle passes water there (Q11 <= 0 at the closed vane), the angle is that of the nearest opening
        that does and the efficiency NaN.
    """
    openings = np.atleast_1d(np.asarray(openings, dtype=float))
    heads = np.atleast_1d(np.asarray(heads_m, dtype=float))
    if np.any(heads <= 0):
        raise InputError(f"heads_m must be > 0, got {heads.tolist()}")
    phi = np.arange(blade_range[0], blade_range[1] + 1e-9, step_deg)
    n11 = speed_rpm * runner_diameter_m / np.sqrt(heads)  # eq. (2), paper 003
    eta = np.asarray(efficiency(n11[:, None, None], openings[None, :, None], phi[None, None, :]), dtype=float)
    finite = np.isfinite(eta)
    flowing = finite.any(axis=2)  # (nh, na): some blade angle passes water at this opening and head
    if not flowing.any(axis=1).all():
        raise NumericalError("on_cam_relation: efficiency is not finite on the scan (Q11 <= 0 at every opening and "
                             "blade angle of a head): the characteristics pass no water there")
    eta = np.where(finite, eta, -np.inf)  # no flow: not a best efficiency
    k = np.argmax(eta, axis=2)
    kk = np.clip(k, 1, phi.size - 2)
    take = lambda off: np.take_along_axis(eta, (kk + off)[..., None], axis=2)[..., 0]  # noqa: E731
    e0, em, ep = take(0), take(-1), take(1)
    at_bound = (k == 0) | (k == phi.size - 1)
    with np.errstate(invalid="ignore"):  # -inf neighbours where a blade angle passes no water
        curvature = em - 2 * e0 + ep
        curvature = np.where(np.isfinite(curvature), curvature, 0.0)
        shift = np.where(curvature < 0, 0.5 * (em - ep) / np.where(curvature < 0, curvature, -1.0), 0.0)
        best = np.where(at_bound, phi[k], phi[kk] + np.clip(shift, -1, 1) * step_deg)
        best_eta = np.where(at_bound | ~(curvature < 0), np.take_along_axis(eta, k[..., None], axis=2)[..., 0],
                            e0 - 0.125 * (em - ep) ** 2 / np.where(curvature < 0, curvature, -1.0))
    held = ~flowing
    for h, i in zip(*np.nonzero(held)):  # no flow at any blade angle (at the closed vane): the nearest flowing cam
        j = np.flatnonzero(flowing[h])
        nearest = j[np.argmin(np.abs(j - i))]
        best[h, i], best_eta[h, i] = best[h, nearest], np.nan
    return {"opening": openings, "head_m": heads, "blade_angle": best, "efficiency": best_eta, "at_bound": at_bound,
            "held": held}


def plot_on_cam(nets_cam: dict, truth_cam: dict | None, path) -> Path:
    """The on-cam relation phi(a) for each head (nets solid, exact dashed) and its efficiency."""
    plt, (fig, ax) = _figure(1, 2, (13, 5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, h in enumerate(nets_cam["head_m"]):
        c = colors[i % len(colors)]
        ax[0, 0].plot(nets_cam["opening"], nets_cam["blade_angle"][i], "-", color=c, label=f"H = {h:g} m (nets)")
        ax[0, 1].plot(nets_cam["opening"], nets_cam["efficiency"][i], "-", color=c, label=f"H = {h:g} m (nets)")
        if truth_cam is not None:
            ax[0, 0].plot(truth_cam["opening"], truth_cam["blade_angle"][i], "--", color=c, label="exact")
            ax[0, 1].plot(truth_cam["opening"], truth_cam["efficiency"][i], "--", color=c, label="exact")
    ax[0, 0].set(xlabel="guide-vane opening a (deg)", ylabel="blade angle phi (deg)",
                 title="on-cam relation phi(a, H): blade angle of best efficiency")
    ax[0, 1].set(xlabel="guide-vane opening a (deg)", ylabel="efficiency on cam", title="efficiency on the cam")
    ax[0, 0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
