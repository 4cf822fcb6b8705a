"""Beyond Wu et al.: a three-input hill chart Q11(N11, a, phi), M11(N11, a, phi) of a double-regulated turbine and its
on-cam relation."""

from __future__ import annotations

import json
from pathlib import Path

import math

import numba
import numpy as np

from hillchart.errors import InputError, NumericalError
from hillchart.fccm.net import FCCMNet, FCCMWeights
from hillchart.fccm.plots import _figure
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
    """

    def __init__(self, flow: FCCMWeights, torque: FCCMWeights, opening_unit: str = "deg",
                 training: dict | None = None):
        for name, w in (("flow", flow), ("torque", torque)):
            if not isinstance(w, FCCMWeights) or len(w.inputs) != 3 or len(w.outputs) != 1:
                raise InputError(f"DoubleRegulatedNets.{name} must be a 3-input, 1-output FCCMWeights")
        self.flow, self.torque = flow, torque
        self.opening_unit = opening_unit
        self.training = dict(training or {})

    def _x(self, n11, opening, blade_angle):
        arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (n11, opening, blade_angle)))
        return np.column_stack([a.ravel() for a in arrays]), arrays[0].shape

    def q11(self, n11, opening, blade_angle):
        """Unit flow Q11, m^3/s (broadcast)."""
        x, shape = self._x(n11, opening, blade_angle)
        return self.flow.predict(x)[:, 0].reshape(shape)

    def m11(self, n11, opening, blade_angle):
        """Unit torque M11, N*m (broadcast)."""
        x, shape = self._x(n11, opening, blade_angle)
        return self.torque.predict(x)[:, 0].reshape(shape)

    def q11_grad(self, n11, opening, blade_angle):
        """(dQ11/dN11, dQ11/da, dQ11/dphi), analytic."""
        x, shape = self._x(n11, opening, blade_angle)
        g = self.flow.predict_grad(x)[:, 0, :]
        return tuple(g[:, j].reshape(shape) for j in range(3))

    def m11_grad(self, n11, opening, blade_angle):
        """(dM11/dN11, dM11/da, dM11/dphi), analytic."""
        x, shape = self._x(n11, opening, blade_angle)
        g = self.torque.predict_grad(x)[:, 0, :]
        return tuple(g[:, j].reshape(shape) for j in range(3))

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
                "training": self.training}

    def to_json(self) -> str:
        doc = self.to_dict()
        lines = []
        for key, value in doc.items():
            if key in ("flow", "torque"):
                inner = ",\n".join(f"  {json.dumps(k)}: {json.dumps(v, allow_nan=False)}" for k, v in value.items())
                lines.append(f" {json.dumps(key)}: {{\n{inner}\n }}")
            else:
                text = json.dumps(value, indent=1, allow_nan=False).replace("\n", "\n ")
                lines.append(f" {json.dumps(key)}: {text}")
        return "{\n" + ",\n".join(lines) + "\n}\n"

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
        return cls(flow=_weights_from_block(doc["flow"], "flow", "q11"),
                   torque=_weights_from_block(doc["torque"], "torque", "m11"), opening_unit=units["opening"],
                   training=training)


def load_double_regulated_nets(path) -> DoubleRegulatedNets:
    """Read a three-input ``nets.json`` (see :class:`DoubleRegulatedNets`); errors name the file and the key."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None
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
    samples = bulb_chart_samples(n_points=cfg["n_points"], seed=cfg["seed"], n11_range=cfg["n11_range"],
                                 opening_range=cfg["opening_range"])
    closed = bulb_closed_vane_samples(n_points=cfg["n_closed"], seed=cfg["seed"], n11_range=cfg["n11_range"])
    samples = {k: np.concatenate([samples[k], closed[k]]) for k in samples}
    nets = train_double_regulated_nets(samples, hidden=cfg["hidden"], restarts=cfg["restarts"], seed=cfg["seed"])
    nets.training["source"] = ("samples of the synthetic bulb's unit characteristic (hillchart.synthetic.bulb): "
                               f"{cfg['n_points']} scattered, {cfg['n_closed']} at the closed vane, seed {cfg['seed']}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return nets.save(out / "nets.json")


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
        (nh, na) bool: the optimum is on the blade range's edge (the cam saturates there).
    """
    openings = np.atleast_1d(np.asarray(openings, dtype=float))
    heads = np.atleast_1d(np.asarray(heads_m, dtype=float))
    if np.any(heads <= 0):
        raise InputError(f"heads_m must be > 0, got {heads.tolist()}")
    phi = np.arange(blade_range[0], blade_range[1] + 1e-9, step_deg)
    n11 = speed_rpm * runner_diameter_m / np.sqrt(heads)  # eq. (2), paper 003
    eta = np.asarray(efficiency(n11[:, None, None], openings[None, :, None], phi[None, None, :]), dtype=float)
    if not np.all(np.isfinite(eta)):
        raise NumericalError("on_cam_relation: efficiency is not finite on the scan (Q11 <= 0 somewhere)")
    k = np.argmax(eta, axis=2)
    kk = np.clip(k, 1, phi.size - 2)
    take = lambda off: np.take_along_axis(eta, (kk + off)[..., None], axis=2)[..., 0]  # noqa: E731
    e0, em, ep = take(0), take(-1), take(1)
    curvature = em - 2 * e0 + ep
    shift = np.where(curvature < 0, 0.5 * (em - ep) / np.where(curvature < 0, curvature, -1.0), 0.0)
    at_bound = (k == 0) | (k == phi.size - 1)
    best = np.where(at_bound, phi[k], phi[kk] + np.clip(shift, -1, 1) * step_deg)
    best_eta = np.where(at_bound, np.take_along_axis(eta, k[..., None], axis=2)[..., 0],
                        e0 - 0.125 * (em - ep) ** 2 / np.where(curvature < 0, curvature, -1.0))
    return {"opening": openings, "head_m": heads, "blade_angle": best, "efficiency": best_eta, "at_bound": at_bound}


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
