"""Small logsig nets of the Suter curves WH(x, y), WM(x, y) of a pump-turbine (and WH(x), WB(x) of a pump), with an
ensemble for a band, their ``nets.json``, and the head and torque they give at an operating point.

The nets are the BP nets of the hill-chart papers (one logsig hidden layer, a linear output, inputs and output mapped
to [-1, 1], Levenberg-Marquardt from Nguyen-Widrow starts with a validation stop: :class:`hillchart.fccm.net.FCCMNet`
on :mod:`hillchart.nets.lm`), one net per curve. The curves are periodic in x, so the nets take ``cos x`` and
``sin x`` instead of x: every function of them is 2 pi-periodic and smooth across x = 0 = 2 pi, where a complete
characteristic crosses (the pump and pump-brake zones meet there), while a net of x itself would have to learn the
same value at both ends of its input range and could not be asked to match the slopes; the price is one more input.
The opening y (relative, 0..1) is the third input; a pump's curves (one speed line, no guide vanes) have none.

Ensemble: ``members`` nets per curve trained with the seeds ``seed``, ``seed + 2``, ... (each its own random split
and initialisations); the first is the point net, the percentiles of all make the band (:meth:`SuterNets.band`).

``nets.json``::

    {"format": "hillsim.suter_nets", "version": 1, "convention": "turbine", "constants": {k1, k2, c_h, c_y},
     "inputs": ["cos_x", "sin_x", "opening"] | ["cos_x", "sin_x"], "wh": NET, "wm": NET,
     "members": [{"wh": NET, "wm": NET}, ...], "training": {...}}      NET: a fccm_nets.json object (FCCMWeights)

Regenerate the shipped nets of the synthetic pump-turbine with
``python -m hillchart.four_quadrant.nets data_synthetic/pump_turbine``.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from hillchart.errors import InputError, NumericalError
from hillchart.fccm.net import FCCMNet, FCCMWeights
from hillchart.four_quadrant.suter import (CONVENTIONS, SuterConstants, _to_turbine, inverse_suter_transform,
                                           suter_angle)

FORMAT = "hillsim.suter_nets"
VERSION = 1
INPUTS_WITH_OPENING = ("cos_x", "sin_x", "opening")
INPUTS_X_ONLY = ("cos_x", "sin_x")
#: The transform of the shipped pump-turbine nets: C_h and C_y at the middle of the published ranges (C_h 0.4-0.6,
#: C_y 0.1-0.3), k2 at the low end of its range (0.5-1.2) because larger k2 fold the 4 mm line back on itself in x
#: (k2 = 1.2 does, measured). k1 = 0, not above max(-m/h) as published: the torque shift makes WM mostly k1 WH, and
#: the inverse subtracts k1 h again, so WH's errors reach the torque magnified; measured on the turbine-zone points of
#: the table from 8 mm up, torque RMS error 0.0035 of the rated torque with k1 = 0 against 0.044 with k1 = 6.5.
PUMP_TURBINE_CONSTANTS = SuterConstants(k1=0.0, k2=0.5, c_h=0.5, c_y=0.2)
#: How the shipped nets are trained (:func:`write_pump_turbine_nets`).
SHIPPED = {"hidden": 20, "restarts": 2, "seed": 0, "members": 4, "max_fail": 30, "split": (0.70, 0.15, 0.15)}
#: Coverage the calibrated band aims at (the 5-95 % band of the members, :meth:`SuterNets.band`).
BAND_COVERAGE = 0.90
#: Fewest opening lines a calibration of the band splits in two halves (:func:`band_factor`).
MIN_LINES_CALIBRATED = 4


def net_inputs(x, opening=None) -> np.ndarray:
    """The nets' input columns ``cos x, sin x[, y]`` (n, 2 or 3) from x (radians) and the relative opening."""
    x = np.asarray(x, dtype=float).ravel()
    columns = [np.cos(x), np.sin(x)]
    if opening is not None:
        columns.append(np.broadcast_to(np.asarray(opening, dtype=float), np.shape(x)).ravel())
    return np.column_stack(columns)


class SuterNets:
    """The nets of WH and WM (:class:`FCCMWeights`), the transform they were made with, and the ensemble.

    Parameters
    ----------
    wh, wm : FCCMWeights
        Inputs :data:`INPUTS_WITH_OPENING` or :data:`INPUTS_X_ONLY`, one output each.
    constants : SuterConstants
    convention : "turbine" | "wylie-streeter"
    members : list of (FCCMWeights, FCCMWeights), optional
        The ensemble (the point nets first when it has them).
    training : dict, optional
    """

    def __init__(self, wh: FCCMWeights, wm: FCCMWeights, *, constants: SuterConstants,
                 convention: str = "turbine", members=(), training: dict | None = None):
        inputs = None
        for name, net in (("wh", wh), ("wm", wm), *((f"members[{i}]", m) for i, pair in enumerate(members)
                                                    for m in pair)):
            if not isinstance(net, FCCMWeights) or len(net.outputs) != 1 \
                    or net.inputs not in (INPUTS_WITH_OPENING, INPUTS_X_ONLY):
                raise InputError(f"SuterNets.{name} must be a one-output FCCMWeights with inputs "
                                 f"{list(INPUTS_WITH_OPENING)} or {list(INPUTS_X_ONLY)}")
            if inputs is not None and net.inputs != inputs:
                raise InputError(f"SuterNets.{name} has inputs {list(net.inputs)}, the others {list(inputs)}")
            inputs = net.inputs
        if not isinstance(constants, SuterConstants):
            raise InputError(f"SuterNets.constants must be a SuterConstants, got {type(constants).__name__}")
        if convention not in CONVENTIONS:
            raise InputError(f"SuterNets.convention must be one of {CONVENTIONS}, got {convention!r}")
        self.wh, self.wm, self.constants, self.convention = wh, wm, constants, convention
        self.members = [tuple(pair) for pair in members]
        self.training = dict(training or {})

    @property
    def has_opening(self) -> bool:
        return self.wh.inputs == INPUTS_WITH_OPENING

    def _x(self, x, opening):
        if self.has_opening and opening is None:
            raise InputError("these nets take the opening: give opening (relative, 0..1)")
        if not self.has_opening and opening is not None:
            raise InputError("these nets are curves of x alone (a pump): they take no opening")
        return net_inputs(x, opening)

    def curves(self, x, opening=None) -> tuple[np.ndarray, np.ndarray]:
        """WH and WM of the point nets at x (radians) and, for a pump-turbine, the relative opening."""
        X = self._x(x, opening)
        return self.wh.predict(X)[:, 0], self.wm.predict(X)[:, 0]

    def band(self, x, opening=None, percentiles=(5.0, 95.0)) -> dict:
        """The ensemble's percentiles of WH and WM: ``{"wh": (low, high), "wm": (low, high)}``."""
        if len(self.members) < 2:
            raise InputError("these nets have no ensemble (members < 2): no band")
        X = self._x(x, opening)
        out = {}
        for k, key in enumerate(("wh", "wm")):
            values = np.array([pair[k].predict(X)[:, 0] for pair in self.members])
            out[key] = tuple(np.percentile(values, percentiles, axis=0))
        return out

    def head_torque(self, speed, flow, opening=None, *, tol: float = 1e-12, max_iter: int = 200):
        """Head and torque ``(h, m)`` (relative) at an operating point's speed, flow (and opening), in the nets'
        convention. With k2 > 0 the angle x depends on h: h solves ``h = F(h)``, F the head of the curves at
        x(h) (:func:`inverse_suter_transform`): bracketed on a geometric grid of ``max_iter // 2 + 1`` heads from
        1e-4 to 1e4 times q^2 + v^2 (the largest root, where F(h) - h changes sign), then bisected to ``tol`` relative.

        Raises
        ------
        NumericalError
            No root on the grid (the curves give no positive head at that point: outside their domain); the
            message gives the point.
        """
        v, q = np.broadcast_arrays(np.asarray(speed, dtype=float), np.asarray(flow, dtype=float))
        y = None if opening is None else np.broadcast_to(np.asarray(opening, dtype=float), v.shape)
        y_calc = np.ones_like(v) if y is None else y

        def head_of(h):
            x = suter_angle(v, q, h, constants=self.constants, convention=self.convention)
            wh, wm = (c.reshape(v.shape) for c in self.curves(x, y))
            return inverse_suter_transform(wh, wm, v, q, y_calc, constants=self.constants,
                                           convention=self.convention)

        if self.constants.k2 == 0:
            return head_of(np.ones_like(v))
        # bracket: F(h) - h on a geometric grid of h around q^2 + v^2 (the head where WH ~ 1); the largest h where
        # it changes sign
        vt, qt = _to_turbine(v, q, self.convention)
        scale = vt**2 + qt**2
        grid = np.logspace(-4, 4, max_iter // 2 + 1)
        sign = np.array([head_of(g * scale)[0] - g * scale > 0 for g in grid])  # (grid, *shape)
        turns = sign[:-1] != sign[1:]
        if not np.all(turns.any(axis=0)):
            i = int(np.flatnonzero(~turns.any(axis=0).ravel())[0])
            raise NumericalError(f"head_torque: the curves give no head at speed {float(v.flat[i])!r}, flow "
                                 f"{float(q.flat[i])!r} (no h in [1e-4, 1e4] (q^2 + v^2) with h = F(h): outside "
                                 "their domain)")
        k = turns.shape[0] - 1 - np.argmax(turns[::-1], axis=0)
        lo, hi = grid[k] * scale, grid[k + 1] * scale
        lo_above = np.take_along_axis(sign, k[None], axis=0)[0]  # F(lo) > lo
        while np.any(hi - lo > tol * hi):
            mid = 0.5 * (lo + hi)
            same = (head_of(mid)[0] > mid) == lo_above
            lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
        return head_of(0.5 * (lo + hi))

    # nets.json ---------------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {"format": FORMAT, "version": VERSION, "convention": self.convention,
                "constants": self.constants.to_dict(), "inputs": list(self.wh.inputs), "wh": self.wh.to_dict(),
                "wm": self.wm.to_dict(), "members": [{"wh": a.to_dict(), "wm": b.to_dict()} for a, b in self.members],
                "training": self.training}

    def to_json(self) -> str:
        """``nets.json`` text, floats in shortest round-trip form (loading is bit-exact)."""
        return json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n"

    def save(self, path) -> Path:
        path = Path(path)
        path.write_text(self.to_json(), encoding="utf-8")
        return path


def load_suter_nets(path) -> SuterNets:
    """Read and validate a Suter-curve ``nets.json`` (:class:`SuterNets`); errors name the file and the key."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None
    try:
        if not isinstance(doc, dict):
            raise InputError(f"must hold an object, got {type(doc).__name__}")
        for key in ("format", "version", "convention", "constants", "wh", "wm"):
            if key not in doc:
                raise InputError(f"key {key!r} is missing")
        if doc["format"] != FORMAT or doc["version"] != VERSION:
            raise InputError(f"format must be {FORMAT!r} version {VERSION}, got {doc['format']!r} version "
                             f"{doc['version']!r}")
        if not isinstance(doc["constants"], dict) or set(doc["constants"]) != {"k1", "k2", "c_h", "c_y"}:
            raise InputError(f"constants must be an object with k1, k2, c_h, c_y, got {doc['constants']!r}")
        members = doc.get("members", [])
        if not isinstance(members, list) or not all(isinstance(m, dict) and {"wh", "wm"} <= set(m) for m in members):
            raise InputError("members must be a list of objects with wh and wm")
        return SuterNets(FCCMWeights.from_dict(doc["wh"]), FCCMWeights.from_dict(doc["wm"]),
                         constants=SuterConstants(**doc["constants"]), convention=doc["convention"],
                         members=[(FCCMWeights.from_dict(m["wh"]), FCCMWeights.from_dict(m["wm"])) for m in members],
                         training=doc.get("training", {}))
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def train_suter_nets(samples: dict, *, constants: SuterConstants, convention: str = "turbine", hidden: int = 20,
                     restarts: int = 2, seed: int = 0, members: int = 4, max_fail: int = 30,
                     split=(0.70, 0.15, 0.15), calibrate: bool | None = None) -> SuterNets:
    """Nets of WH and WM from curve samples ``{"x", "wh", "wm"[, "opening"]}`` (x in radians, opening relative;
    without "opening": curves of x alone), an ensemble of ``members`` (the first the point nets).

    ``calibrate``: the members are moved away from the point nets by :func:`band_factor` (each member ``m`` of a
    curve becomes ``p + f (m - p)``, :func:`blended_net`, with that curve's factor ``f``), so that their band covers
    the curves between the table's lines as the table's own held-out lines say; the factors and what they were
    calibrated on are in ``training["band"]``. Without it the members differ by their training splits and starts
    only: on a real pump-turbine's table their band covered half the curve values between lines
    (``benchmarks/bench_pump_turbine_table.py``). Three trainings instead of one. None (the default): calibrated
    where it can be (an ensemble, curves of the opening, :data:`MIN_LINES_CALIBRATED` opening lines or more), and
    ``training["band"]`` says why not elsewhere.

    ``max_fail`` 30 instead of trainlm's 6: the samples of a synthetic or a smoothed table carry no noise, and at 6 a
    3-20-1 net of the synthetic pump-turbine stopped after 22 epochs at 1.4 % RMS of WM's range against 0.13 % at 30.
    """
    for key in ("x", "wh", "wm"):
        if key not in samples:
            raise InputError(f"train_suter_nets: samples need keys x, wh, wm[, opening]; {key!r} is missing")
    if isinstance(members, bool) or not isinstance(members, int) or not 1 <= members <= 50:
        raise InputError(f"train_suter_nets: members must be an integer in [1, 50], got {members!r}")
    opening = samples.get("opening")
    X = net_inputs(samples["x"], opening)
    names = INPUTS_WITH_OPENING if opening is not None else INPUTS_X_ONLY
    pairs, records = [], []
    for i in range(members):
        pair, record = [], {}
        for offset, key in enumerate(("wh", "wm")):
            est = FCCMNet(hidden=hidden, restarts=restarts, seed=seed + 2 * i + offset, split=split,
                          max_fail=max_fail, goal=1e-9).fit(X, np.asarray(samples[key], dtype=float),
                                                            input_names=names, output_names=(key,))
            pair.append(est.weights_)
            record[key] = {"test_mse_normalized": est.test_mse_, "epochs": est.epochs_,
                           "stop_reason": est.stop_reason_}
        pairs.append(tuple(pair))
        records.append(record)
    training = {"hidden": hidden, "restarts": restarts, "seed": seed, "members": members, "max_fail": max_fail,
                "split": list(split), "n_samples": int(X.shape[0]), "member_records": records,
                "inputs": "cos x, sin x" + (", opening" if opening is not None else "") + ": periodic in x"}
    lines = 0 if opening is None else np.unique(np.asarray(opening, float)).size
    why_not = ("no ensemble (members < 2)" if members < 2 else "curves of x alone (no opening lines)"
               if opening is None else f"{lines} opening lines (calibrating needs {MIN_LINES_CALIBRATED})"
               if lines < MIN_LINES_CALIBRATED else None)
    if calibrate and why_not is not None:
        raise InputError(f"train_suter_nets: calibrate needs an ensemble of curves of {MIN_LINES_CALIBRATED} opening "
                         f"lines or more; these have {why_not}")
    if calibrate is None and why_not is not None:
        training["band"] = {"calibrated": False, "why": why_not}
    elif calibrate is not False:
        band = band_factor(samples, constants=constants, hidden=hidden, restarts=restarts, seed=seed,
                           members=members, max_fail=max_fail, split=split)
        point = pairs[0]
        pairs = [point] + [tuple(blended_net(p, m, band[key]) for p, m, key in zip(point, pair, ("wh", "wm")))
                           for pair in pairs[1:]]
        training["band"] = {"calibrated": True, **band,
                            "calibrated_on": "every other opening line held out, both halves"}
    return SuterNets(pairs[0][0], pairs[0][1], constants=constants, convention=convention,
                     members=pairs if members > 1 else (), training=training)


def blended_net(a: FCCMWeights, b: FCCMWeights, share: float) -> FCCMWeights:
    """The net of ``(1 - share) a(x) + share b(x)`` (same inputs and outputs; any input and output scaling), exactly:
    the hidden units of both side by side, the first layer of ``b`` rewritten for ``a``'s input scaling, the output
    layer weighed and rewritten for ``a``'s output scaling. ``share`` > 1 moves ``b`` away from ``a``.

    Examples
    --------
    >>> a = FCCMWeights(inputs=["u"], outputs=["y"], x_min=[0], x_max=[1], y_min=[0], y_max=[1], W1=[[1.0]], b1=[0.0],
    ...                 W2=[[1.0]], b2=[0.0])
    >>> b = FCCMWeights(inputs=["u"], outputs=["y"], x_min=[-1], x_max=[3], y_min=[2], y_max=[5], W1=[[2.0]],
    ...                 b1=[0.5], W2=[[-1.0]], b2=[0.3])
    >>> x = np.array([[0.2], [0.9]])
    >>> np.allclose(blended_net(a, b, 2.5).predict(x), -1.5 * a.predict(x) + 2.5 * b.predict(x), rtol=1e-12)
    True
    """
    if a.inputs != b.inputs or a.outputs != b.outputs:
        raise InputError(f"blended_net: the nets differ in inputs or outputs ({list(a.inputs)} -> {list(a.outputs)}, "
                         f"{list(b.inputs)} -> {list(b.outputs)})")
    scale_a, scale_b = 2.0 / (a.x_max - a.x_min), 2.0 / (b.x_max - b.x_min)
    offset_a, offset_b = -scale_a * a.x_min - 1.0, -scale_b * b.x_min - 1.0
    ratio = scale_b / scale_a  # xn_b = ratio (xn_a - offset_a) + offset_b
    w1_b = b.W1 * ratio
    b1_b = b.b1 + b.W1 @ (offset_b - ratio * offset_a)
    span = a.y_max - a.y_min
    weights = ((1.0 - share) * (a.y_max - a.y_min) / span, share * (b.y_max - b.y_min) / span)
    w2 = np.hstack([weights[0][:, None] * a.W2, weights[1][:, None] * b.W2])
    b2 = (weights[0] * (a.b2 + 1.0) + weights[1] * (b.b2 + 1.0)
          + 2.0 * ((1.0 - share) * a.y_min + share * b.y_min - a.y_min) / span - 1.0)
    return FCCMWeights(inputs=a.inputs, outputs=a.outputs, x_min=a.x_min, x_max=a.x_max, y_min=a.y_min,
                       y_max=a.y_max, W1=np.vstack([a.W1, w1_b]), b1=np.concatenate([a.b1, b1_b]), W2=w2, b2=b2)


def band_factor(samples: dict, *, constants: SuterConstants, coverage: float = BAND_COVERAGE, **train) -> dict:
    """How far the ensemble's members must stand from the point nets for their band to cover each curve between
    measured lines: the table's opening lines split in two (every other line, in the order of the openings), nets
    trained on each half as :func:`train_suter_nets` trains them, and at the other half's points the miss of the
    point nets divided by the members' half-spread (half the 5-95 % band, :meth:`SuterNets.band`); each curve's
    factor is the split-conformal ``ceil((n + 1) coverage)``-th smallest of its ratios over both halves, at least 1.
    Returns ``{"wh": factor, "wm": factor, "points", "coverage_before": {"wh", "wm"}}`` (the share of the held-out
    values the members' own band covered). Needs a table of :data:`MIN_LINES_CALIBRATED` opening lines or more.
    The halves are trained uncalibrated."""
    openings = np.unique(np.asarray(samples["opening"], float))
    if openings.size < MIN_LINES_CALIBRATED:
        raise InputError(f"band_factor: the table has {openings.size} opening lines; calibrating the band between "
                         f"lines needs {MIN_LINES_CALIBRATED} or more (two halves of two lines)")
    ratios, covered = {"wh": [], "wm": []}, {"wh": 0, "wm": 0}
    for half in (openings[0::2], openings[1::2]):
        train_on = np.isin(samples["opening"], half)
        nets = train_suter_nets({k: np.asarray(v)[train_on] for k, v in samples.items()}, constants=constants,
                                calibrate=False, **train)
        x, y = np.asarray(samples["x"])[~train_on], np.asarray(samples["opening"])[~train_on]
        points, band = nets.curves(x, y), nets.band(x, y)
        for k, key in enumerate(("wh", "wm")):
            truth = np.asarray(samples[key], float)[~train_on]
            low, high = band[key]
            covered[key] += int(np.sum((low <= truth) & (truth <= high)))
            half_spread = np.maximum(0.5 * (high - low), 1e-12 * float(np.ptp(samples[key])))
            ratios[key].append(np.abs(points[k] - truth) / half_spread)
    out = {"points": 0, "coverage_before": {}}
    for key, parts in ratios.items():
        ordered = np.sort(np.concatenate(parts))
        rank = min(math.ceil((ordered.size + 1) * coverage), ordered.size)
        out[key] = max(1.0, float(ordered[rank - 1]))
        out["points"] = int(ordered.size)
        out["coverage_before"][key] = covered[key] / ordered.size
    return out


def curve_errors(nets: SuterNets, exact: dict) -> dict:
    """RMS and largest error of the point nets against exact curve samples ``{"x", "wh", "wm"[, "opening"]}``,
    each as a percentage of the exact curve's range: ``{"wh": {"rms_pct", "max_pct", "range"}, "wm": {...}}``."""
    wh, wm = nets.curves(exact["x"], exact.get("opening"))
    out = {}
    for key, value in (("wh", wh), ("wm", wm)):
        truth = np.asarray(exact[key], dtype=float)
        err = value - truth
        span = float(np.ptp(truth))
        out[key] = {"rms_pct": 100.0 * float(np.sqrt(np.mean(err**2))) / span,
                    "max_pct": 100.0 * float(np.max(np.abs(err))) / span, "range": span}
    return out


def pump_turbine_test_samples(rated: dict, turbine=None, *, openings_mm=tuple(np.arange(5.0, 28.0, 2.0)),
                              directions: int = 97, phase: float = 0.31,
                              constants: SuterConstants = PUMP_TURBINE_CONSTANTS) -> dict:
    """Exact improved curves of the synthetic pump-turbine on a grid the shipped table does not hold: the openings
    between its lines (5, 7, ..., 27 mm), ``directions`` directions of (N11, Q11) offset by ``phase`` of a step,
    inside the table's window. ``rated``: the table's rated point (``{"n11_rpm", "q11_m3_s", "m11_nm"}``, as the
    shipped nets record it in ``training["rated"]``)."""
    from hillchart.synthetic.pump_turbine import (TABLE_N11_LIMIT_RPM, TABLE_Q11_LIMIT_M3_S,
                                                  SyntheticPumpTurbine)
    from hillchart.four_quadrant.suter import suter_transform

    turbine = turbine or SyntheticPumpTurbine()
    theta = -math.pi + (np.arange(directions) + phase) * 2.0 * math.pi / directions
    parts = []
    for a in openings_mm:
        n11, q11, m11 = turbine.unit_curve(a, theta)
        keep = np.isfinite(n11) & (np.abs(n11) <= TABLE_N11_LIMIT_RPM) & (np.abs(q11) <= TABLE_Q11_LIMIT_M3_S)
        y = np.full(int(keep.sum()), a / turbine.opening_max)
        x, wh, wm = suter_transform(n11[keep] / rated["n11_rpm"], q11[keep] / rated["q11_m3_s"], 1.0,
                                    m11[keep] / rated["m11_nm"], y, constants=constants)
        parts.append((x, y, wh, wm))
    return {key: np.concatenate([p[i] for p in parts]) for i, key in enumerate(("x", "opening", "wh", "wm"))}


def table_nets(table, *, calibrate: bool | None = None, **options) -> SuterNets:
    """The nets of a complete-characteristics table of unit quantities
    (:class:`hillchart.four_quadrant.table.CompleteCharacteristics`) with :data:`PUMP_TURBINE_CONSTANTS`, trained as
    :data:`SHIPPED` says unless ``options`` (``hidden``, ``members``, ``seed``, ...) say otherwise; the table's rated
    point and full stroke recorded for the simulator (``training.rated``, ``training.opening_max``). What
    ``hillsim four-quadrant`` and :func:`write_pump_turbine_nets` write."""
    if table.is_curves:
        raise InputError(f"{table.source}: a table of Suter curves has no rated point for the simulator; give the "
                         "unit quantities (columns opening,n11,q11,m11 and the rated point in table.toml)")
    nets = train_suter_nets(table.suter(PUMP_TURBINE_CONSTANTS), constants=PUMP_TURBINE_CONSTANTS,
                            calibrate=calibrate, **{**SHIPPED, **options})
    nets.training["source"] = f"the complete-characteristics table {table.name!r} ({table.opening.size} points)"
    nets.training["rated"] = dict(table.rated)
    nets.training["opening_max"] = table.opening_max
    return nets


def write_pump_turbine_nets(folder) -> Path:
    """Train the nets of the complete-characteristics table in ``folder`` (table.toml, table.csv) as shipped
    (:func:`table_nets`), and write ``folder/nets.json``; seeded: the same table gives the same file on one
    machine."""
    from hillchart.four_quadrant.table import load_complete_characteristics

    return table_nets(load_complete_characteristics(folder)).save(Path(folder) / "nets.json")


if __name__ == "__main__":  # python -m hillchart.four_quadrant.nets FOLDER
    if len(sys.argv) != 2:
        raise SystemExit("usage: python -m hillchart.four_quadrant.nets FOLDER (with table.toml and table.csv)")
    print(write_pump_turbine_nets(sys.argv[1]))
