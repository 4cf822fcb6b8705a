"""Q11(N11, a, phi) and M11(N11, a, phi) of a double-regulated turbine as two three-input nets: their ``nets.json``
file (:class:`DoubleRegulatedNets`, :func:`load_double_regulated_nets`) and the on-cam (combinator) relation of best
efficiency they give (:func:`on_cam_relation`, :func:`plot_on_cam`). The nets are trained in
:mod:`hillchart.fccm.double_regulated`; below the table they are blended with the fitted bulb model of
:mod:`hillchart.fccm.bulb_silent_model`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hillchart.errors import InputError, NumericalError
from hillchart.fccm.bulb_silent_model import NET3_INPUTS, NO_BLEND, BulbSilentModel, _blended_many, packed_net3
from hillchart.fccm.net import FCCMWeights
from hillchart.fccm.plots import _figure
from hillchart.nets.weights import ensemble_blocks
from hillchart.validation import check_finite
from hillchart.characteristics import unit_speed


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
        The fitted bulb model the nets extend (the extension of
        :func:`hillchart.fccm.double_regulated.table_unit_samples`) and what answers below the table's smallest
        guide-vane angle: the hypotheses weighed by the table's held-out angles (:mod:`hillchart.fccm.evidence`), or
        the model alone in files without them; None: the nets alone everywhere.
    ensemble : list of (flow, torque, silent_model or None), optional
        The ensemble members (:func:`hillchart.fccm.double_regulated.train_table_nets`; the point nets among them),
        each run by ``hillsim run --uncertainty`` as characteristics of its own (:meth:`members`).
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
        n11 = unit_speed(speed_rpm, cam["head_m"], runner_diameter_m)
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
    n11 = unit_speed(speed_rpm, heads, runner_diameter_m)  # eq. (2), paper 003
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
