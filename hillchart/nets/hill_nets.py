"""BP nets for the unit characteristics Q11(N11, a) and M11(N11, a): fit, text export, fast evaluation.

BP hill-chart paper (004), sections 2.2-2.6, eqs. (10)-(12): one 2-H-1 net per characteristic (H = 5 in the paper),
log-sigmoid hidden layer, linear output, inputs and output mapped to [-1, 1] by their min/max (MATLAB
``mapminmax``)::

    xn = 2 (x - x_min) / (x_max - x_min) - 1                  # mapminmax of the inputs (N11 r/min, a chart unit)
    yn = sum_i W2_i f(W1_i1 xn_n11 + W1_i2 xn_a + b1_i) + b2  # eq. (11), f(z) = 1 / (1 + exp(-z)) eq. (10)
    y  = (yn + 1) (y_max - y_min) / 2 + y_min                 # reverse mapminmax of the output

Q11 is in m^3/s and M11 in N*m whatever the chart's units; N11 in r/min; the opening in the chart's unit.

Pieces
------
:class:`HillNet`
    scikit-learn style estimator for one net, trained by Levenberg-Marquardt (:mod:`hillchart.nets.lm`, a compiled
    loop) with a seeded, origin-stratified 80/20 split and a multi-start "loop control" (section 2.3).
:class:`NetWeights`
    The exported weights of one net (the ``NET`` block of ``nets.json``), validated on construction.
:class:`HillNets`
    The flow and torque nets together; implements the :class:`hillchart.characteristics.Characteristics`
    protocol and ``numba_kernel()`` for the simulator, ``to_json()``/``save()``; :func:`load_nets` reads it back.
:func:`train_nets`
    Both nets from the extended-samples table of :mod:`hillchart.extension.extend`: derived boundary samples weighted
    as soft constraints, boundary weight / hidden size / weight decay chosen by cross-validation on the measured
    samples, optionally an ensemble whose mean is distilled into the point nets.

There is exactly one implementation of eq. (11) and its analytic gradient at evaluation time, the numba function
``_net_value_grad``; the vectorized methods loop over it in compiled code. Torch is used only for training.

``nets.json``
-------------
::

    {"format": "hillsim.nets", "version": 1,
     "units": {"n11": "r/min", "opening": "<chart unit>", "q11": "m^3/s", "m11": "N*m"},
     "flow": NET (output "q11"), "torque": NET (output "m11"), "training": {...},
     "ensemble": [{"flow": NET, "torque": NET}, ...],    # optional: the members of the uncertainty band
     "digitized_region": [[n11, opening], ...]}         # optional: the hull of the digitized chart points
    NET = {"inputs": ["n11", "opening"], "output": "q11" | "m11",
           "x_min": [n11_min, opening_min], "x_max": [n11_max, opening_max], "y_min": float, "y_max": float,
           "W1": [[w_n11, w_opening], ... H rows], "b1": [... H], "W2": [... H], "b2": float}

Floats are written with Python's shortest round-trip ``repr``, so ``load_nets(save(nets))`` is bit-exact.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np

from hillchart.nets import lm
from hillchart.errors import InputError
from hillchart.validation import check_finite, check_vector

FORMAT = "hillsim.nets"
VERSION = 1
#: Units fixed by the format (the opening unit is the chart's).
FIXED_UNITS = {"n11": "r/min", "q11": "m^3/s", "m11": "N*m"}
#: Origin families of the extended samples (see :mod:`hillchart.extension.extend`).
ORIGINS = ("measured", "runaway", "zero-opening", "zero-speed", "silent-region")


# ----------------------------------------------------------------------------------------------------------------
# evaluation: the single implementation of eq. (11) and its gradient
# ----------------------------------------------------------------------------------------------------------------
# Packed layout of one net (float64 vector):
#   [H, n11_min, a_min, n11_max, a_max, y_min, y_max, b2, W1 (H x 2 row-major), b1 (H), W2 (H)]
_HEADER = 8


@numba.njit(cache=True)
def _net_value_grad(p, n11, opening):
    """Value y and (dy/dN11, dy/da) of one packed net at a scalar point (physical units)."""
    hidden = int(p[0])
    n11_min, a_min, n11_max, a_max = p[1], p[2], p[3], p[4]
    y_min, y_max, b2 = p[5], p[6], p[7]
    s_n = 2.0 / (n11_max - n11_min)  # d xn / d x of mapminmax
    s_a = 2.0 / (a_max - a_min)
    xn_n = s_n * (n11 - n11_min) - 1.0
    xn_a = s_a * (opening - a_min) - 1.0
    yn = b2
    g_n = 0.0
    g_a = 0.0
    for i in range(hidden):
        w_n = p[_HEADER + 2 * i]
        w_a = p[_HEADER + 2 * i + 1]
        b1 = p[_HEADER + 2 * hidden + i]
        w2 = p[_HEADER + 3 * hidden + i]
        z = w_n * xn_n + w_a * xn_a + b1
        # eq. (10), paper 004: logsig, evaluated without overflow for either sign of z
        if z >= 0.0:
            f = 1.0 / (1.0 + math.exp(-z))
        else:
            ez = math.exp(z)
            f = ez / (1.0 + ez)
        yn += w2 * f  # eq. (11), paper 004
        d = w2 * f * (1.0 - f)
        g_n += d * w_n
        g_a += d * w_a
    half_range = 0.5 * (y_max - y_min)
    y = (yn + 1.0) * half_range + y_min  # reverse mapminmax
    return y, half_range * g_n * s_n, half_range * g_a * s_a


@numba.njit(cache=True)
def _net_eval_many(p, n11, opening, y, dy_dn11, dy_da):
    for k in range(n11.shape[0]):
        y[k], dy_dn11[k], dy_da[k] = _net_value_grad(p, n11[k], opening[k])


@numba.njit(cache=True)
def _nets_kernel(params, n11, opening):
    """Simulator kernel: ``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` at a scalar point."""
    q, dq_dn, dq_da = _net_value_grad(params[0], n11, opening)
    m, dm_dn, dm_da = _net_value_grad(params[1], n11, opening)
    return q, dq_dn, dq_da, m, dm_dn, dm_da


#: Up to this many points ``evaluate`` runs the kernel's Python source (``py_func``): a process evaluating a few
#: points (``hillsim linearize``) need not load the compiled kernel from numba's cache, about half a second of
#: start-up (numba's first cache load initialises its compiler), against about 10 us a point in Python.
_PYTHON_POINTS = 64


def _evaluate(packed: np.ndarray, n11, opening):
    n11 = np.asarray(n11, dtype=float)
    opening = np.asarray(opening, dtype=float)
    n11_b, opening_b = np.broadcast_arrays(n11, opening)
    shape = n11_b.shape
    flat_n = np.ascontiguousarray(n11_b, dtype=float).ravel()
    flat_a = np.ascontiguousarray(opening_b, dtype=float).ravel()
    y, d_n, d_a = np.empty_like(flat_n), np.empty_like(flat_n), np.empty_like(flat_n)
    if flat_n.size <= _PYTHON_POINTS:  # the same kernel's Python source: loading the compiled one costs more
        point = _net_value_grad.py_func
        for k in range(flat_n.size):
            y[k], d_n[k], d_a[k] = point(packed, float(flat_n[k]), float(flat_a[k]))
    else:
        _net_eval_many(packed, flat_n, flat_a, y, d_n, d_a)
    return y.reshape(shape), d_n.reshape(shape), d_a.reshape(shape)


# ----------------------------------------------------------------------------------------------------------------
# weights of one net
# ----------------------------------------------------------------------------------------------------------------
#: Largest magnitude accepted for any number of a NET block: trained nets stay orders of magnitude below it, and
#: beyond it the evaluation overflows (e.g. y_max - y_min of 2e300 times a weight gives inf, then NaN).
MAX_ABS_NET_VALUE = 1e9


@dataclass(frozen=True, eq=False)
class NetWeights:
    """Weights of one 2-H-1 logsig/purelin net and its input/output scaling (one ``NET`` block of ``nets.json``).

    Parameters
    ----------
    x_min, x_max : array_like (2,)
        mapminmax ranges of the inputs (N11 in r/min, opening in chart units); ``x_max > x_min``.
    y_min, y_max : float
        mapminmax range of the output (Q11 in m^3/s or M11 in N*m); ``y_max > y_min``.
    W1 : array_like (H, 2)
        Hidden weights, columns (N11, opening), on normalized inputs.
    b1, W2 : array_like (H,)
        Hidden biases and output weights.
    b2 : float
        Output bias.

    Raises
    ------
    InputError
        Wrong shapes, NaN/inf or empty ranges; the message names the field.

    Examples
    --------
    >>> w = NetWeights(x_min=[0.0, 0.0], x_max=[100.0, 30.0], y_min=0.0, y_max=1.0,
    ...                W1=[[1.0, 0.0]], b1=[0.0], W2=[2.0], b2=-1.0)
    >>> float(w.evaluate(50.0, 10.0)[0])  # xn_n11 = 0 -> f = 0.5 -> yn = 0 -> y = 0.5
    0.5
    """

    x_min: np.ndarray
    x_max: np.ndarray
    y_min: float
    y_max: float
    W1: np.ndarray
    b1: np.ndarray
    W2: np.ndarray
    b2: float
    _packed: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self._set_validated(key="")

    def _set_validated(self, key: str):
        put = object.__setattr__
        x_min = check_vector(f"{key}x_min", self.x_min, 2, max_abs=MAX_ABS_NET_VALUE)
        x_max = check_vector(f"{key}x_max", self.x_max, 2, max_abs=MAX_ABS_NET_VALUE)
        for j, name in enumerate(("n11", "opening")):
            if not x_max[j] > x_min[j]:
                raise InputError(f"{key}x_max[{j}] ({name}) must be > {key}x_min[{j}] = {x_min[j]!r}, "
                                 f"got {x_max[j]!r}")
        y_min = check_finite(f"{key}y_min", self.y_min, max_abs=MAX_ABS_NET_VALUE)
        y_max = check_finite(f"{key}y_max", self.y_max, max_abs=MAX_ABS_NET_VALUE)
        if not y_max > y_min:
            raise InputError(f"{key}y_max must be > {key}y_min = {y_min!r}, got {y_max!r}")
        w1_raw = self.W1.tolist() if isinstance(self.W1, np.ndarray) else self.W1
        if not isinstance(w1_raw, (list, tuple)) or len(w1_raw) == 0:
            raise InputError(f"{key}W1 must be a non-empty list of H rows [w_n11, w_opening], got {w1_raw!r}")
        w1 = np.array([check_vector(f"{key}W1[{i}]", row, 2, max_abs=MAX_ABS_NET_VALUE)
                       for i, row in enumerate(w1_raw)])
        hidden = w1.shape[0]
        b1 = check_vector(f"{key}b1", self.b1, hidden, max_abs=MAX_ABS_NET_VALUE)
        w2 = check_vector(f"{key}W2", self.W2, hidden, max_abs=MAX_ABS_NET_VALUE)
        b2 = check_finite(f"{key}b2", self.b2, max_abs=MAX_ABS_NET_VALUE)
        for name, value in (("x_min", x_min), ("x_max", x_max), ("W1", w1), ("b1", b1), ("W2", w2)):
            value.setflags(write=False)
            put(self, name, value)
        put(self, "y_min", y_min)
        put(self, "y_max", y_max)
        put(self, "b2", b2)
        packed = np.concatenate([[hidden], x_min, x_max, [y_min, y_max, b2], w1.ravel(), b1, w2]).astype(float)
        packed.setflags(write=False)
        put(self, "_packed", packed)

    @property
    def hidden(self) -> int:
        """Number of hidden neurons H."""
        return int(self.W1.shape[0])

    @classmethod
    def from_dict(cls, block, *, key: str, output: str) -> "NetWeights":
        """Validate a ``NET`` block of ``nets.json`` (``key`` names it in messages, ``output`` is expected)."""
        if not isinstance(block, dict):
            raise InputError(f"{key} must be an object, got {type(block).__name__}")
        required = ("inputs", "output", "x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2", "b2")
        for name in required:
            if name not in block:
                raise InputError(f"{key}.{name} is missing (a NET needs keys {', '.join(required)})")
        if block["inputs"] != ["n11", "opening"]:
            raise InputError(f'{key}.inputs must be ["n11", "opening"], got {block["inputs"]!r}')
        if block["output"] != output:
            raise InputError(f"{key}.output must be {output!r}, got {block['output']!r}")
        obj = cls.__new__(cls)
        for name in ("x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2", "b2"):
            object.__setattr__(obj, name, block[name])
        obj._set_validated(key=f"{key}.")
        return obj

    def to_dict(self, output: str) -> dict:
        """The ``NET`` block (plain Python floats, so ``json`` writes them exactly)."""
        return {"inputs": ["n11", "opening"], "output": output,
                "x_min": [float(v) for v in self.x_min], "x_max": [float(v) for v in self.x_max],
                "y_min": float(self.y_min), "y_max": float(self.y_max),
                "W1": [[float(v) for v in row] for row in self.W1],
                "b1": [float(v) for v in self.b1], "W2": [float(v) for v in self.W2], "b2": float(self.b2)}

    def packed(self) -> np.ndarray:
        """Read-only float64 vector consumed by the numba kernels (layout in the module source)."""
        return self._packed

    def evaluate(self, n11, opening):
        """Output and analytic gradient, vectorized.

        Parameters
        ----------
        n11 : array_like, r/min
        opening : array_like, chart units (broadcast with ``n11``)

        Returns
        -------
        y, dy_dn11, dy_da : ndarray, broadcast shape
        """
        return _evaluate(self._packed, n11, opening)

    def __eq__(self, other):
        if not isinstance(other, NetWeights):
            return NotImplemented
        return bool(np.array_equal(self._packed, other._packed))

    __hash__ = None


# ----------------------------------------------------------------------------------------------------------------
# one net: scikit-learn style estimator
# ----------------------------------------------------------------------------------------------------------------
def stratified_split(groups, validation_fraction: float, rng: np.random.Generator):
    """Random train/validation split in which every group appears in both parts.

    Each group of ``n_g`` samples gives ``round(validation_fraction n_g)`` samples to validation, clipped to
    ``[1, n_g - 1]``.

    Parameters
    ----------
    groups : array_like (n,)
        Group label per sample (here: the origin family).
    validation_fraction : float in (0, 1)
    rng : numpy.random.Generator

    Returns
    -------
    train_index, val_index : ndarray of int, sorted

    Raises
    ------
    InputError
        A group with fewer than 2 samples cannot be in both parts.

    Examples
    --------
    >>> tr, va = stratified_split(["a"] * 10 + ["b"] * 5, 0.2, np.random.default_rng(0))
    >>> len(tr), len(va)
    (12, 3)
    """
    groups = np.asarray(groups)
    train, val = [], []
    for label in sorted(set(groups.tolist())):
        members = np.flatnonzero(groups == label)
        if members.size < 2:
            raise InputError(f"groups: origin {label!r} has {members.size} sample(s); each origin needs >= 2 so "
                             f"that it is present in both the training and the validation set")
        n_val = int(np.clip(round(validation_fraction * members.size), 1, members.size - 1))
        perm = rng.permutation(members)
        val.append(perm[:n_val])
        train.append(perm[n_val:])
    return np.sort(np.concatenate(train)), np.sort(np.concatenate(val))


def _split(groups, validation_fraction, validation_groups, rng):
    """Train/validation split: stratified over all groups, or validating on ``validation_groups`` only (every
    other sample trains)."""
    groups = np.asarray(groups)
    if validation_groups is None:
        return stratified_split(groups, validation_fraction, rng)
    chosen = np.isin(groups.astype(str), [str(g) for g in validation_groups])
    if chosen.sum() < 2:
        raise InputError(f"groups: the validation groups {list(validation_groups)} have {int(chosen.sum())} "
                         f"sample(s); need >= 2")
    members = np.flatnonzero(chosen)
    tr, va = stratified_split(groups[members], validation_fraction, rng)
    train = np.sort(np.concatenate([members[tr], np.flatnonzero(~chosen)]))
    return train, np.sort(members[va])


def _lm_runs(xn, yn, train_index, val_index, weight, hidden, regularization, rng, restarts, n_threads, lm_params):
    """``restarts`` Levenberg-Marquardt runs from Nguyen-Widrow initialisations ("loop control", section 2.3 of
    paper 004); returns the list of :class:`hillchart.nets.lm.LMResult`."""
    sample_weight = None if np.all(weight[train_index] == 1.0) else weight[train_index]
    thetas0 = [lm.nguyen_widrow_init(hidden, rng) for _ in range(restarts)]
    return lm.levenberg_marquardt_many(xn[train_index], yn[train_index], xn[val_index], yn[val_index], thetas0,
                                       n_threads=n_threads, hidden=hidden, sample_weight=sample_weight,
                                       regularization=regularization, **lm_params)


class HillNet:
    """One 2-H-1 logsig BP net y(N11, a), trained by Levenberg-Marquardt as MATLAB ``trainlm``.

    BP hill-chart paper (004), sections 2.2-2.3: inputs and output mapped to [-1, 1] (``mapminmax``), a seeded
    random 80/20 train/validation split stratified by origin, ``restarts`` Nguyen-Widrow initialisations ("loop
    control"), and the run with the lowest validation MSE kept.

    Parameters
    ----------
    hidden : int, default 5
        Hidden log-sigmoid neurons.
    restarts : int, default 10
        Independent initialisations; the best validation MSE wins.
    seed : int, default 0
        Seeds the split and every initialisation (``numpy.random.default_rng``).
    goal : float, default 1e-5
        Training MSE goal on normalized outputs.
    max_epochs : int, default 1000
    max_fail : int, default 6
        Consecutive validation increases that stop a run.
    mu, mu_dec, mu_inc, mu_max : float
        Levenberg-Marquardt damping: initial value, factor on success, factor on failure, upper limit.
    validation_fraction : float, default 0.2
    n_threads : int, default 1
        Threads running the restarts side by side during ``fit`` (the compiled LM loop releases the GIL; the
        result does not depend on it: the restarts are independent and drawn before they run).

    Attributes
    ----------
    weights_ : NetWeights
    train_mse_, val_mse_ : float
        Normalized-output MSEs of the kept run.
    epochs_, best_epoch_ : int
    stop_reason_ : str
    best_restart_ : int
    restart_val_mse_ : list of float
    train_index_, val_index_ : ndarray of int
    fit_time_s_ : float
        Wall-clock training time.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> X = np.column_stack([rng.uniform(0, 100, 200), rng.uniform(0, 30, 200)])
    >>> y = 0.02 * X[:, 1] * (1 - X[:, 0] / 250)
    >>> net = HillNet(restarts=1, seed=0).fit(X, y)
    >>> bool(np.max(np.abs(net.predict(X) - y)) < 0.01 * np.ptp(y))
    True
    """

    def __init__(self, *, hidden: int = 5, restarts: int = 10, seed: int = 0, goal: float = 1e-5,
                 max_epochs: int = 1000, max_fail: int = 6, mu: float = 1e-3, mu_dec: float = 0.1,
                 mu_inc: float = 10.0, mu_max: float = 1e10, validation_fraction: float = 0.2,
                 n_threads: int = 1, boundary_weight: float = 1.0, regularization: float = 0.0,
                 validation_groups: tuple | None = None):
        self.hidden = hidden
        self.restarts = restarts
        self.seed = seed
        self.goal = goal
        self.max_epochs = max_epochs
        self.max_fail = max_fail
        self.mu = mu
        self.mu_dec = mu_dec
        self.mu_inc = mu_inc
        self.mu_max = mu_max
        self.validation_fraction = validation_fraction
        self.n_threads = n_threads
        self.boundary_weight = boundary_weight
        self.regularization = regularization
        self.validation_groups = validation_groups

    def get_params(self, deep: bool = True) -> dict:
        """Hyperparameters (scikit-learn contract)."""
        return {name: getattr(self, name) for name in
                ("hidden", "restarts", "seed", "goal", "max_epochs", "max_fail", "mu", "mu_dec", "mu_inc",
                 "mu_max", "validation_fraction", "n_threads", "boundary_weight", "regularization",
                 "validation_groups")}

    def set_params(self, **params) -> "HillNet":
        valid = self.get_params()
        for name, value in params.items():
            if name not in valid:
                raise InputError(f"HillNet has no parameter {name!r}; valid: {', '.join(valid)}")
            setattr(self, name, value)
        return self

    def __repr__(self):
        return "HillNet(" + ", ".join(f"{k}={v!r}" for k, v in self.get_params().items()) + ")"

    def _validate_params(self):
        def check_int(name, low):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise InputError(f"HillNet.{name} must be an integer >= {low}, got {value!r}")
        check_int("hidden", 1)
        check_int("restarts", 1)
        check_int("max_epochs", 0)
        check_int("max_fail", 1)
        check_int("n_threads", 1)
        check_int("seed", 0)
        for name in ("goal", "mu", "mu_max"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise InputError(f"HillNet.{name} must be a finite number >= 0, got {value!r}")
        if not 0 < self.mu_dec < 1:
            raise InputError(f"HillNet.mu_dec must be in (0, 1), got {self.mu_dec!r}")
        if not self.mu_inc > 1:
            raise InputError(f"HillNet.mu_inc must be > 1, got {self.mu_inc!r}")
        if not 0 < self.validation_fraction < 1:
            raise InputError(f"HillNet.validation_fraction must be in (0, 1), got {self.validation_fraction!r}")
        for name, low, high in (("boundary_weight", 0.0, 1.0), ("regularization", 0.0, 1.0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not (
                    low <= value <= high) or (name == "boundary_weight" and value == 0):
                bound = "(0, 1]" if name == "boundary_weight" else "[0, 1]"
                raise InputError(f"HillNet.{name} must be a number in {bound}, got {value!r}")
        if self.validation_groups is not None and (
                not isinstance(self.validation_groups, (tuple, list)) or not self.validation_groups):
            raise InputError(f"HillNet.validation_groups must be None or a non-empty tuple of group labels, got "
                             f"{self.validation_groups!r}")

    def fit(self, X, y, groups=None, derived=None) -> "HillNet":
        """Train on samples ``X = [[N11, a], ...]`` (n, 2) and targets ``y`` (n,).

        Parameters
        ----------
        X : array_like (n, 2)
            Columns N11 (r/min) and opening (chart units).
        y : array_like (n,)
            Targets in physical units (Q11 m^3/s or M11 N*m).
        groups : array_like (n,), optional
            Origin label per sample; the split puts every label in both parts (or, with ``validation_groups``,
            validates on those labels only and trains on every other sample). ``None``: one group.
        derived : array_like of bool (n,), optional
            True for boundary samples derived by the extension (not read from the chart): their residuals carry
            ``boundary_weight``. ``None``: no derived samples.

        Returns
        -------
        self

        Raises
        ------
        InputError
            Bad shapes, NaN/inf, constant inputs or outputs, too few samples, bad hyperparameters.
        NumericalError
            Training diverged to NaN.
        """
        self._validate_params()
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        if X.ndim != 2 or X.shape[1] != 2:
            raise InputError(f"X must have shape (n, 2) with columns (n11, opening), got {X.shape}")
        if y.shape != (X.shape[0],):
            raise InputError(f"y must have shape ({X.shape[0]},) matching X, got {y.shape}")
        if X.shape[0] < 10:
            raise InputError(f"X must have >= 10 samples to train and validate, got {X.shape[0]}")
        if not np.all(np.isfinite(X)):
            raise InputError("X contains NaN or inf")
        if not np.all(np.isfinite(y)):
            raise InputError("y contains NaN or inf")
        groups = np.zeros(X.shape[0], dtype=int) if groups is None else np.asarray(groups)
        if groups.shape != (X.shape[0],):
            raise InputError(f"groups must have shape ({X.shape[0]},) matching X, got {groups.shape}")
        x_min, x_max = X.min(axis=0), X.max(axis=0)
        for j, name in enumerate(("n11", "opening")):
            if not x_max[j] > x_min[j]:
                raise InputError(f"X column {j} ({name}) is constant ({x_min[j]!r}); the net needs a range")
        y_min, y_max = float(y.min()), float(y.max())
        if not y_max > y_min:
            raise InputError(f"y is constant ({y_min!r}); the net needs a range")

        xn = 2.0 * (X - x_min) / (x_max - x_min) - 1.0  # mapminmax, section 2.6 of paper 004
        yn = 2.0 * (y - y_min) / (y_max - y_min) - 1.0
        rng = np.random.default_rng(self.seed)
        train_index, val_index = _split(groups, self.validation_fraction, self.validation_groups, rng)
        derived = np.zeros(X.shape[0], bool) if derived is None else np.asarray(derived, bool)
        if derived.shape != (X.shape[0],):
            raise InputError(f"derived must have shape ({X.shape[0]},) matching X, got {derived.shape}")
        weight = np.where(derived, float(self.boundary_weight), 1.0)
        start = time.perf_counter()
        results = _lm_runs(xn, yn, train_index, val_index, weight, self.hidden, float(self.regularization), rng,
                           self.restarts, self.n_threads, self._lm_params())
        self.fit_time_s_ = time.perf_counter() - start
        best = int(np.argmin([r.val_mse for r in results]))
        res = results[best]
        w1, b1, w2, b2 = lm.unpack(res.theta, self.hidden)
        self.weights_ = NetWeights(x_min=x_min, x_max=x_max, y_min=y_min, y_max=y_max, W1=w1, b1=b1, W2=w2,
                                   b2=float(b2))
        self.train_mse_ = res.train_mse
        self.val_mse_ = res.val_mse
        self.epochs_ = res.epochs
        self.best_epoch_ = res.best_epoch
        self.stop_reason_ = res.stop_reason
        self.best_restart_ = best
        self.restart_val_mse_ = [r.val_mse for r in results]
        self.train_index_ = train_index
        self.val_index_ = val_index
        return self

    def _lm_params(self) -> dict:
        return {"goal": self.goal, "max_epochs": self.max_epochs, "max_fail": self.max_fail, "mu": self.mu,
                "mu_dec": self.mu_dec, "mu_inc": self.mu_inc, "mu_max": self.mu_max}

    def _check_fitted(self):
        if not hasattr(self, "weights_"):
            raise InputError("this HillNet is not fitted yet; call fit(X, y) before predict")

    def _split_X(self, X):
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != 2:
            raise InputError(f"X must have shape (n, 2) with columns (n11, opening), got {X.shape}")
        return X[:, 0], X[:, 1]

    def predict(self, X) -> np.ndarray:
        """Net output (n,) in the units of ``y`` at ``X`` (n, 2)."""
        self._check_fitted()
        return self.weights_.evaluate(*self._split_X(X))[0]

    def predict_grad(self, X) -> np.ndarray:
        """Analytic gradient (n, 2): columns dy/dN11 and dy/da."""
        self._check_fitted()
        _, d_n, d_a = self.weights_.evaluate(*self._split_X(X))
        return np.column_stack([d_n, d_a])


def _check_percentiles(percentiles) -> tuple[float, float]:
    try:
        low, high = (float(p) for p in percentiles)
    except (TypeError, ValueError):
        raise InputError(f"percentiles must be a pair (low, high) of numbers, got {percentiles!r}") from None
    if not (0 <= low < high <= 100):
        raise InputError(f"percentiles must satisfy 0 <= low < high <= 100, got {percentiles!r}")
    return low, high


# ----------------------------------------------------------------------------------------------------------------
# the pair: Characteristics for the simulator, nets.json
# ----------------------------------------------------------------------------------------------------------------
class HillNets:
    """Flow net Q11(N11, a) (m^3/s) and torque net M11(N11, a) (N*m): eq. (12) of paper 004.

    Implements :class:`hillchart.characteristics.Characteristics` (vectorized numpy in and out, compiled
    evaluation, no torch) and ``numba_kernel()`` for the simulator's compiled loop.

    Parameters
    ----------
    flow, torque : NetWeights
    opening_unit : str
        The chart's opening unit ("mm", "deg", "%").
    training : dict, optional
        Training record written to ``nets.json`` (JSON-serializable).

    Examples
    --------
    >>> w = NetWeights(x_min=[0.0, 0.0], x_max=[100.0, 30.0], y_min=0.0, y_max=1.0,
    ...                W1=[[0.0, 1.0]], b1=[0.0], W2=[2.0], b2=-1.0)
    >>> nets = HillNets(flow=w, torque=w, opening_unit="mm")
    >>> float(nets.q11(40.0, 15.0))
    0.5
    >>> nets2 = HillNets.from_json(nets.to_json())
    >>> nets2.flow == nets.flow
    True
    """

    def __init__(self, flow: NetWeights, torque: NetWeights, opening_unit: str, training: dict | None = None,
                 ensemble=None, digitized_region=None):
        if not isinstance(flow, NetWeights) or not isinstance(torque, NetWeights):
            raise InputError("HillNets.flow and HillNets.torque must be NetWeights")
        if not isinstance(opening_unit, str) or not opening_unit:
            raise InputError(f"HillNets.opening_unit must be a non-empty string, got {opening_unit!r}")
        self.flow = flow
        self.torque = torque
        self.opening_unit = opening_unit
        self.training = dict(training or {})
        pairs = list(ensemble or [])
        for i, pair in enumerate(pairs):
            if not (isinstance(pair, (tuple, list)) and len(pair) == 2
                    and all(isinstance(w, NetWeights) for w in pair)):
                raise InputError(f"HillNets.ensemble[{i}] must be a (flow, torque) pair of NetWeights")
        self.ensemble = [tuple(p) for p in pairs]
        #: Vertices (k, 2) of the convex hull of the digitized (N11 r/min, opening) points the nets were trained
        #: on, or None (files written before it was recorded): what a run needs to say when it leaves the chart,
        #: wherever the nets.json is kept.
        self.digitized_region = None if digitized_region is None else _region(digitized_region, "digitized_region")

    # ensemble: uncertainty band ------------------------------------------------------------------------------------
    def members(self) -> list["HillNets"]:
        """The ensemble members as HillNets (empty when the file has no ensemble)."""
        return [HillNets(flow=f, torque=t, opening_unit=self.opening_unit, digitized_region=self.digitized_region)
                for f, t in self.ensemble]

    def band(self, quantity: str, n11, opening, *, percentiles=(5.0, 95.0)) -> dict:
        """Mean and percentile band of ``quantity`` over the ensemble members.

        Parameters
        ----------
        quantity : {"q11", "m11", "efficiency"}
        n11, opening : array_like (broadcast), r/min and chart units
        percentiles : (low, high), percent

        Returns
        -------
        dict
            ``mean``, ``low``, ``high`` (arrays of the broadcast shape; Q11 m^3/s, M11 N*m, efficiency fraction)
            and ``point`` (the point-estimate nets).

        Raises
        ------
        InputError
            Unknown quantity, bad percentiles, or no ensemble in these nets.
        """
        if quantity not in ("q11", "m11", "efficiency"):
            raise InputError(f"quantity must be 'q11', 'm11' or 'efficiency', got {quantity!r}")
        low_p, high_p = _check_percentiles(percentiles)
        if not self.ensemble:
            raise InputError("these nets have no ensemble (train with --ensemble N)")
        values = np.array([getattr(m, quantity)(n11, opening) for m in self.members()])
        # np.nanpercentile along an axis loops over the points in Python (2.3 s for the 81 x 81 trust map);
        # np.percentile gives the same numbers when nothing is NaN (efficiency can be NaN where Q11 <= 0)
        percentile = np.percentile if np.all(np.isfinite(values)) else np.nanpercentile
        return {"mean": np.nanmean(values, axis=0), "low": percentile(values, low_p, axis=0),
                "high": percentile(values, high_p, axis=0), "point": getattr(self, quantity)(n11, opening)}

    # Characteristics protocol -----------------------------------------------------------------------------------
    def q11(self, n11, opening) -> np.ndarray:
        """Unit flow Q11, m^3/s, at N11 (r/min) and opening (chart units), broadcast."""
        return self.flow.evaluate(n11, opening)[0]

    def m11(self, n11, opening) -> np.ndarray:
        """Unit torque M11, N*m."""
        return self.torque.evaluate(n11, opening)[0]

    def q11_grad(self, n11, opening) -> tuple[np.ndarray, np.ndarray]:
        """(dQ11/dN11 in m^3/s per r/min, dQ11/da in m^3/s per opening unit)."""
        return self.flow.evaluate(n11, opening)[1:]

    def m11_grad(self, n11, opening) -> tuple[np.ndarray, np.ndarray]:
        """(dM11/dN11 in N*m per r/min, dM11/da in N*m per opening unit)."""
        return self.torque.evaluate(n11, opening)[1:]

    def efficiency(self, n11, opening) -> np.ndarray:
        """Hydraulic efficiency eta = M11 omega11 / (rho g Q11) (inverse of eq. (5), paper 004); NaN where
        Q11 <= 0 or N11 <= 0."""
        from hillchart.characteristics import efficiency_from_unit_torque

        n11 = np.asarray(n11, dtype=float)
        return efficiency_from_unit_torque(self.q11(n11, opening), n11, self.m11(n11, opening))

    def numba_kernel(self):
        """``(kernel, params)``: ``kernel(params, n11, a) -> (q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)``,
        numba-jitted, on scalars (see :mod:`hillchart.characteristics`)."""
        return _nets_kernel, (self.flow.packed(), self.torque.packed())

    # nets.json --------------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        doc = {"format": FORMAT, "version": VERSION,
               "units": {"n11": FIXED_UNITS["n11"], "opening": self.opening_unit, "q11": FIXED_UNITS["q11"],
                         "m11": FIXED_UNITS["m11"]},
               "flow": self.flow.to_dict("q11"), "torque": self.torque.to_dict("m11"),
               "training": self.training}
        if self.ensemble:
            doc["ensemble"] = [{"flow": f.to_dict("q11"), "torque": t.to_dict("m11")} for f, t in self.ensemble]
        if self.digitized_region is not None:
            doc["digitized_region"] = self.digitized_region.tolist()
        return doc

    def to_json(self) -> str:
        """``nets.json`` text (floats in shortest round-trip form, so loading is bit-exact)."""
        doc = self.to_dict()
        lines = []
        for key, value in doc.items():
            if key in ("flow", "torque"):  # one line per NET key, weight lists kept on one line
                inner = ",\n".join(f"  {json.dumps(k)}: {json.dumps(v, allow_nan=False)}" for k, v in value.items())
                lines.append(f" {json.dumps(key)}: {{\n{inner}\n }}")
            elif key == "digitized_region":  # one line per vertex
                vertices = ",\n".join(f"  {json.dumps(v, allow_nan=False)}" for v in value)
                lines.append(f" {json.dumps(key)}: [\n{vertices}\n ]")
            elif key == "ensemble":  # one line per member NET
                members = ",\n".join(
                    "  {" + ", ".join(f"{json.dumps(k)}: {json.dumps(v, allow_nan=False)}" for k, v in m.items()) + "}"
                    for m in value)
                lines.append(f" {json.dumps(key)}: [\n{members}\n ]")
            else:
                text = json.dumps(value, indent=1, allow_nan=False).replace("\n", "\n ")
                lines.append(f" {json.dumps(key)}: {text}")
        return "{\n" + ",\n".join(lines) + "\n}\n"

    def save(self, path) -> Path:
        """Write ``nets.json`` to ``path``; returns the path."""
        path = Path(path)
        path.write_text(self.to_json(), encoding="utf-8")
        return path

    @classmethod
    def from_dict(cls, doc) -> "HillNets":
        """Validate a parsed ``nets.json`` document (see module docstring)."""
        if not isinstance(doc, dict):
            raise InputError(f"nets.json must hold an object, got {type(doc).__name__}")
        for key in ("format", "version", "units", "flow", "torque"):
            if key not in doc:
                raise InputError(f"nets.json: key {key!r} is missing (required: format, version, units, flow, "
                                 f"torque)")
        if doc["format"] != FORMAT:
            raise InputError(f"nets.json: format must be {FORMAT!r}, got {doc['format']!r}")
        if doc["version"] != VERSION or isinstance(doc["version"], bool):
            raise InputError(f"nets.json: version must be {VERSION}, got {doc['version']!r}")
        units = doc["units"]
        if not isinstance(units, dict):
            raise InputError(f"nets.json: units must be an object, got {units!r}")
        for name, unit in FIXED_UNITS.items():
            if units.get(name) != unit:  # format check, not a default: a missing key reads as None here
                raise InputError(f"nets.json: units.{name} must be {unit!r}, got {units.get(name)!r}")
        if "opening" not in units or not isinstance(units["opening"], str) or not units["opening"]:
            raise InputError(f"nets.json: units.opening must be the chart's opening unit (a string), got "
                             f"{units.get('opening')!r}")
        flow = NetWeights.from_dict(doc["flow"], key="flow", output="q11")
        torque = NetWeights.from_dict(doc["torque"], key="torque", output="m11")
        training = doc["training"] if "training" in doc else {}
        if not isinstance(training, dict):
            raise InputError(f"nets.json: training must be an object, got {type(training).__name__}")
        ensemble = []
        if "ensemble" in doc:  # optional; a file without it is the version-1 file of before
            members = doc["ensemble"]
            if not isinstance(members, list):
                raise InputError(f"nets.json: ensemble must be a list of {{\"flow\": NET, \"torque\": NET}}, got "
                                 f"{type(members).__name__}")
            for i, member in enumerate(members):
                if not isinstance(member, dict) or set(member) != {"flow", "torque"}:
                    raise InputError(f"nets.json: ensemble[{i}] must be an object with exactly the keys flow and "
                                     f"torque, got {member if not isinstance(member, dict) else sorted(member)!r}")
                ensemble.append((NetWeights.from_dict(member["flow"], key=f"ensemble[{i}].flow", output="q11"),
                                 NetWeights.from_dict(member["torque"], key=f"ensemble[{i}].torque", output="m11")))
        region = _region(doc["digitized_region"], "nets.json: digitized_region") if "digitized_region" in doc else None
        return cls(flow=flow, torque=torque, opening_unit=units["opening"], training=training, ensemble=ensemble,
                   digitized_region=region)

    @classmethod
    def from_json(cls, text: str) -> "HillNets":
        """Parse ``nets.json`` text; rejects invalid JSON and malformed blocks (NaN/Infinity literals and numbers
        that overflow to inf are rejected by the block validation, which names the key)."""
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"nets.json: not valid JSON ({exc})") from None
        except RecursionError:
            raise InputError("nets.json: nested too deeply to be a nets file (a NET block is 2 levels deep)") from None
        except ValueError as exc:  # e.g. an integer beyond Python's 4300-digit conversion limit
            raise InputError(f"nets.json: not a valid nets file ({exc})") from None
        return cls.from_dict(doc)


def _region(value, key: str) -> np.ndarray:
    """A digitized region: at least 3 finite (N11, opening) vertices."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{key} must be a list of [n11, opening] pairs, got {str(value)[:80]}") from None
    if array.ndim != 2 or array.shape[1] != 2 or len(array) < 3:
        raise InputError(f"{key} must be a list of at least 3 [n11, opening] pairs, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise InputError(f"{key} must hold finite numbers")
    return array


def load_nets(path) -> HillNets:
    """Read and validate ``nets.json``.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    HillNets

    Raises
    ------
    InputError
        Wrong format or version, missing keys, wrong shapes, NaN/inf, ``x_max <= x_min``: the message names the key.
    FileNotFoundError
        No such file.

    Examples
    --------
    >>> from importlib.resources import files
    >>> nets = load_nets(files("data_synthetic.francis") / "nets.json")  # the shipped synthetic-Francis nets
    >>> nets.opening_unit, nets.flow.hidden, len(nets.ensemble)  # hidden size chosen by cross-validation
    ('mm', 8, 10)
    >>> abs(float(nets.efficiency(65.0, 18.0)) - 0.935) < 0.005  # best efficiency of the synthetic turbine: 0.935
    True
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path}: is a folder, not a nets.json file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start}); nets.json is JSON "
                         "text") from None
    try:
        return HillNets.from_json(text)
    except InputError as exc:
        message = str(exc).removeprefix("nets.json: ")
        raise InputError(f"{path}: {message}") from None


# ----------------------------------------------------------------------------------------------------------------
# both nets from the extended samples
# ----------------------------------------------------------------------------------------------------------------
def _column(table, name):
    try:
        return np.asarray(table[name])
    except (KeyError, IndexError, TypeError, ValueError):
        pass
    if hasattr(table, name):
        return np.asarray(getattr(table, name))
    raise InputError(f"extended samples: column {name!r} is missing (need target, origin, n11, opening, value)")


#: Candidates of the model selection, each scored by the validation MSE on measured samples.
BOUNDARY_WEIGHTS = (0.03, 0.1, 0.3, 1.0)
HIDDEN_SIZES = (3, 4, 5, 6, 8, 10)
REGULARIZATIONS = (0.0, 1e-5, 1e-4)
#: A candidate is "as good" as the best when its validation MSE is within this factor; among those the selection
#: takes the largest boundary weight, the smallest net, the strongest regularization (Occam, as the 1-SE rule).
SELECTION_TOLERANCE = 1.1
#: Restarts per candidate during the selection, and per ensemble member.
SELECTION_RESTARTS = 3
SELECTION_FOLDS = 5
ENSEMBLE_RESTARTS = 2
DISTILL_RESTARTS = 3
#: Derived (not digitized) origins; the runaway samples are derived when the extension made them from the model.
DERIVED_ORIGINS = ("zero-opening", "zero-speed")


def _derived_mask(extended, origin: np.ndarray) -> np.ndarray:
    derived = getattr(extended, "derived", None)
    if derived is not None:
        derived = np.asarray(derived, bool)
    else:
        try:
            derived = np.asarray(extended["derived"], bool)
        except (KeyError, IndexError, TypeError, ValueError):
            derived = None
    if derived is None:
        derived = np.isin(origin, DERIVED_ORIGINS)
    return derived


def _select(xn, yn, train_index, val_index, derived, validated, *, hidden, boundary_weight, regularization, seed,
            n_threads, lm_params, progress, label):
    """Choose boundary weight, hidden size and regularization by validation MSE on the measured samples."""
    table = []
    # K-fold cross-validation over the validated (measured) samples; every other sample always trains. A single
    # 20 % split holds about 17 measured samples: too few to rank candidates whose errors differ by < 10 %.
    checked = np.flatnonzero(validated)
    always = np.setdiff1d(np.arange(xn.shape[0]), checked)
    folds = np.array_split(np.random.default_rng([seed, 31]).permutation(checked), SELECTION_FOLDS)

    def score(weight, h, lam, index):
        rng = np.random.default_rng([seed, 7919, index])
        errors = []
        for fold in folds:
            train = np.sort(np.concatenate([always, np.setdiff1d(checked, fold)]))
            results = _lm_runs(xn, yn, train, np.sort(fold), np.where(derived, weight, 1.0), h, lam, rng,
                               1, n_threads, lm_params)
            errors.append(results[0].val_mse * fold.size)
        value = float(np.sum(errors) / checked.size)
        table.append({"boundary_weight": weight, "hidden": h, "regularization": lam, "cv_mse": value})
        return value

    def pick(candidates, prefer_last: bool, evaluate):
        scores = [evaluate(c, i) for i, c in enumerate(candidates)]
        good = [c for c, v in zip(candidates, scores) if v <= SELECTION_TOLERANCE * min(scores) + 1e-15]
        return good[-1] if prefer_last else good[0]

    weight = boundary_weight
    h = hidden if hidden is not None else 5
    lam = regularization if regularization is not None else 0.0
    if weight is None:
        weight = pick(BOUNDARY_WEIGHTS, True, lambda w, i: score(w, h, lam, i)) if derived.any() else 1.0
        if progress:
            progress(f"{label}: boundary weight {weight}")
    if hidden is None:
        h = pick(HIDDEN_SIZES, False, lambda c, i: score(weight, c, lam, 100 + i))
        if progress:
            progress(f"{label}: hidden size {h}")
    if regularization is None:
        lam = pick(REGULARIZATIONS, True, lambda c, i: score(weight, h, c, 200 + i))
        if progress:
            progress(f"{label}: regularization {lam}")
    return weight, h, lam, table


def train_nets(extended, *, opening_unit: str | None = None, hidden: int | None = None, restarts: int = 10,
               seed: int = 0, boundary_weight: float | None = None, regularization: float | None = None,
               ensemble: int = 0, record_time: bool = False, progress=None, **net_params) -> HillNets:
    """Train the flow and torque nets on the extended samples (Li et al. 2017, eq. (12) and section 2.6 steps (5)-(6)).

    The measured (digitized) samples carry the fit; derived boundary samples are soft constraints whose weight, the
    hidden size (3-10) and a weight-decay regularization are chosen by the validation error on measured samples
    (see the docs page on the nets). Give ``hidden``, ``boundary_weight`` or ``regularization`` to fix them instead.

    Parameters
    ----------
    extended : table
        Extended samples with columns ``target`` ('q11' | 'm11'), ``origin`` ('measured' | 'runaway' |
        'zero-opening' | 'zero-speed'), ``n11`` (r/min), ``opening`` (chart units), ``value`` (m^3/s or N*m);
        anything indexable by column name or with those attributes; an optional boolean ``derived`` marks the
        samples the extension made up (default: the zero-opening and zero-speed origins).
    opening_unit : str, optional
        The chart's opening unit; default ``extended.opening_unit``.
    hidden : int in [1, 50] or None
        Hidden neurons of both nets; None selects among :data:`HIDDEN_SIZES`. The paper's net: 5.
    restarts : int
        Multi-start count of the final fit of each net.
    seed : int
        The flow net uses ``seed``, the torque net ``seed + 1``.
    boundary_weight : float in (0, 1] or None
        Weight of the derived samples' residuals; None selects among :data:`BOUNDARY_WEIGHTS`.
    regularization : float in [0, 1] or None
        Weight decay lambda; None selects among :data:`REGULARIZATIONS`.
    ensemble : int >= 0
        Extra members trained on bootstrap resamples of the training samples with other seeds (the uncertainty
        band); 0: none.
    record_time : bool
        Put training times (``time_s``) into the training record; off by default so that ``nets.json`` is
        byte-reproducible.
    progress : callable(str), optional
        Called with a short message after each stage (long trainings report progress).
    **net_params
        Further :class:`HillNet` hyperparameters.

    Returns
    -------
    HillNets
        With ``training`` holding per-net sample counts, split, errors (normalized MSE and physical max/RMS),
        epochs, stop reasons and the selection; the fitted estimators are kept in ``nets.estimators``.
    """
    if opening_unit is None:
        opening_unit = getattr(extended, "opening_unit", None)
        if opening_unit is None:
            raise InputError("train_nets: opening_unit is required when the table does not carry it")
    for name, value, low, high in (("hidden", hidden, 1, 50), ("ensemble", ensemble, 0, 200),
                                   ("restarts", restarts, 1, 1000), ("seed", seed, 0, 2**63 - 1)):
        if value is None and name == "hidden":
            continue
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
            raise InputError(f"train_nets: {name} must be an integer in [{low}, {high}], got {value!r}")
    if boundary_weight is not None and not (isinstance(boundary_weight, (int, float)) and 0 < boundary_weight <= 1):
        raise InputError(f"train_nets: boundary_weight must be in (0, 1], got {boundary_weight!r}")
    if regularization is not None and not (isinstance(regularization, (int, float))
                                           and 0 <= regularization <= 1):
        raise InputError(f"train_nets: regularization must be in [0, 1], got {regularization!r}")
    target = _column(extended, "target").astype(str)
    origin = _column(extended, "origin").astype(str)
    n11 = _column(extended, "n11").astype(float)
    opening = _column(extended, "opening").astype(float)
    value = _column(extended, "value").astype(float)
    bad_targets = sorted(set(target.tolist()) - {"q11", "m11"})
    if bad_targets:
        raise InputError(f"extended samples: target must be 'q11' or 'm11', got {bad_targets}")
    bad_origins = sorted(set(origin.tolist()) - set(ORIGINS))
    if bad_origins:
        raise InputError(f"extended samples: origin must be one of {', '.join(ORIGINS)}, got {bad_origins}")
    derived_all = _derived_mask(extended, origin)
    record = {"seed": seed, "hidden": hidden if hidden is not None else "selected", "restarts": restarts,
              "validation": "measured samples", "ensemble": int(ensemble)}
    weights, estimators, members = {}, {}, {"flow": [], "torque": []}
    for offset, (key, tgt) in enumerate((("flow", "q11"), ("torque", "m11"))):
        sel = target == tgt
        if not np.any(sel):
            raise InputError(f"extended samples: no rows with target {tgt!r}")
        X = np.column_stack([n11[sel], opening[sel]])
        y = value[sel]
        groups = origin[sel]
        derived = derived_all[sel]
        net_seed = seed + offset
        validation_groups = ("measured",) if np.sum(groups == "measured") >= 10 else None
        probe = HillNet(hidden=hidden or 5, restarts=restarts, seed=net_seed, validation_groups=validation_groups,
                        **net_params)
        probe._validate_params()
        x_min, x_max = X.min(axis=0), X.max(axis=0)
        y_min, y_max = float(y.min()), float(y.max())
        if not (np.all(x_max > x_min) and y_max > y_min) or X.shape[0] < 10 or not np.all(np.isfinite(X)) or \
                not np.all(np.isfinite(y)):
            probe.fit(X, y, groups, derived)  # raises the estimator's own, precise error
        xn = 2.0 * (X - x_min) / (x_max - x_min) - 1.0  # mapminmax, section 2.6 of paper 004
        yn = 2.0 * (y - y_min) / (y_max - y_min) - 1.0
        train_index, val_index = _split(groups, probe.validation_fraction, validation_groups,
                                        np.random.default_rng(net_seed))
        start = time.perf_counter()
        validated = np.isin(groups, validation_groups) if validation_groups else np.ones(groups.size, bool)
        weight, h, lam, table = _select(xn, yn, train_index, val_index, derived, validated, hidden=hidden,
                                        boundary_weight=boundary_weight, regularization=regularization,
                                        seed=net_seed, n_threads=probe.n_threads, lm_params=probe._lm_params(),
                                        progress=progress, label=key)
        for i in range(ensemble):
            # member i: its own random 80/20 split of the validated samples (early stopping on its held-out part),
            # every derived sample in training, its own initialisations
            rng = np.random.default_rng([net_seed, 104729, i])
            tr_i, va_i = _split(groups, probe.validation_fraction, validation_groups, rng)
            results = _lm_runs(xn, yn, tr_i, va_i, np.where(derived, weight, 1.0), h, lam, rng,
                               ENSEMBLE_RESTARTS, probe.n_threads, probe._lm_params())
            res = min(results, key=lambda r: r.val_mse)
            w1, b1, w2, b2 = lm.unpack(res.theta, h)
            members[key].append(NetWeights(x_min=x_min, x_max=x_max, y_min=y_min, y_max=y_max, W1=w1, b1=b1,
                                           W2=w2, b2=float(b2)))
        if ensemble:
            # point estimate: one 2-h-1 net fitted to the ensemble mean (the average of nets trained on different
            # splits has a fraction of a single net's variance; "distilling" it keeps the paper's small net).
            # Targets: the mean at the samples and on a 21 x 21 grid over the input box.
            grid = np.stack(np.meshgrid(np.linspace(x_min[0], x_max[0], 21), np.linspace(x_min[1], x_max[1], 21)),
                            axis=-1).reshape(-1, 2)
            X_d = np.vstack([X, grid])
            y_d = np.mean([m.evaluate(X_d[:, 0], X_d[:, 1])[0] for m in members[key]], axis=0)
            est = HillNet(hidden=h, restarts=DISTILL_RESTARTS, seed=net_seed, goal=1e-8, **net_params).fit(X_d, y_d)
            if progress:
                progress(f"{key}: {ensemble} ensemble members, point net 2-{h}-1 fitted to their mean")
        else:
            est = HillNet(hidden=h, restarts=restarts, seed=net_seed, boundary_weight=weight, regularization=lam,
                          validation_groups=validation_groups, **net_params).fit(X, y, groups, derived)
            if progress:
                progress(f"{key}: final fit 2-{h}-1, validation MSE {est.val_mse_:.3g}")
        est.fit_time_s_ = time.perf_counter() - start  # selection + ensemble + final fit
        estimators[key] = est
        weights[key] = est.weights_
        rec = _training_record(est, X, y, groups, record_time, point_of_ensemble=bool(ensemble))
        err = est.predict(X) - y
        measured = groups == "measured"
        if measured.any():
            rec["measured_rms_error"] = float(np.sqrt(np.mean(err[measured] ** 2)))
            rec["measured_max_abs_error"] = float(np.max(np.abs(err[measured])))
        best_cv = min(c["cv_mse"] for c in table) if table else None
        rec["selection"] = {"boundary_weight": weight, "hidden": h, "regularization": lam,
                            "cv_mse_best": best_cv,
                            "rule": f"{SELECTION_FOLDS}-fold CV MSE on measured samples within {SELECTION_TOLERANCE} "
                                    "x the best: largest boundary weight, smallest net, strongest regularization",
                            "candidates": table}
        record[key] = rec
    ensemble_pairs = list(zip(members["flow"], members["torque"])) if ensemble else None
    nets = HillNets(flow=weights["flow"], torque=weights["torque"], opening_unit=opening_unit, training=record,
                    ensemble=ensemble_pairs)
    nets.estimators = estimators
    return nets


def _training_record(est: HillNet, X, y, groups, record_time: bool, point_of_ensemble: bool = False) -> dict:
    pred = est.predict(X)
    err = pred - y
    tr, va = est.train_index_, est.val_index_
    if point_of_ensemble:  # the point net was fitted to the ensemble mean: report its errors at the samples
        tr, va = np.arange(X.shape[0]), np.zeros(0, int)
    counts = {}
    for g in sorted(set(groups.tolist())):
        counts[g] = {"train": int(np.sum(groups[tr] == g)), "validation": int(np.sum(groups[va] == g))}
    rec = {"seed": est.seed, "n_train": int(tr.size), "n_validation": int(va.size), "samples_by_origin": counts,
           "train_mse_normalized": est.train_mse_, "validation_mse_normalized": est.val_mse_,
           "train_rms_error": float(np.sqrt(np.mean(err[tr] ** 2))),
           "train_max_abs_error": float(np.max(np.abs(err[tr]))),
           "validation_rms_error": float(np.sqrt(np.mean(err[va] ** 2))) if va.size else None,
           "validation_max_abs_error": float(np.max(np.abs(err[va]))) if va.size else None,
           "epochs": est.epochs_, "best_epoch": est.best_epoch_, "stop_reason": est.stop_reason_,
           "best_restart": est.best_restart_, "restart_validation_mse": est.restart_val_mse_}
    if record_time:
        rec["time_s"] = round(est.fit_time_s_, 3)
    return rec


# ----------------------------------------------------------------------------------------------------------------
# accuracy against an exact reference (the synthetic turbine's truth.csv)
# ----------------------------------------------------------------------------------------------------------------
def read_truth_csv(path) -> dict[str, np.ndarray]:
    """Read ``truth.csv`` (columns ``n11,opening,q11,m11,efficiency``; r/min, chart units, m^3/s, N*m, fraction).

    Raises
    ------
    InputError
        Missing column or non-finite value (naming the file and column).
    """
    path = Path(path)
    data = np.genfromtxt(path, delimiter=",", names=True, dtype=float)
    names = data.dtype.names or ()
    out = {}
    for column in ("n11", "opening", "q11", "m11"):
        if column not in names:
            raise InputError(f"{path}: column {column!r} is missing (have {', '.join(names)})")
        values = np.atleast_1d(np.asarray(data[column], dtype=float))
        if not np.all(np.isfinite(values)):
            raise InputError(f"{path}: column {column!r} has non-numeric or non-finite values")
        out[column] = values
    return out


def truth_errors(characteristics, truth: dict, inside: np.ndarray) -> dict:
    """Errors of ``characteristics`` against exact values, inside and outside the measured region.

    Parameters
    ----------
    characteristics : object with ``q11(n11, a)`` and ``m11(n11, a)``
    truth : dict of ndarray
        ``n11``, ``opening``, ``q11``, ``m11`` (see :func:`read_truth_csv`).
    inside : ndarray of bool
        Measured-region mask of the truth points (see :func:`hillchart.io.samples.measured_region_mask`).

    Returns
    -------
    dict
        For ``q11`` and ``m11``: ``range_measured`` (truth max - min inside, the scale of the issue's
        percentages), ``rms_measured``, ``max_measured``, ``rms_extended``, ``max_extended`` (physical units) and
        the same as percentages of ``range_measured`` (``*_pct``).
    """
    out = {}
    for name in ("q11", "m11"):
        pred = getattr(characteristics, name)(truth["n11"], truth["opening"])
        err = np.asarray(pred, dtype=float) - truth[name]
        scale = float(np.ptp(truth[name][inside]))
        rec = {"range_measured": scale,
               "rms_measured": float(np.sqrt(np.mean(err[inside] ** 2))),
               "max_measured": float(np.max(np.abs(err[inside]))),
               "rms_extended": float(np.sqrt(np.mean(err[~inside] ** 2))),
               "max_extended": float(np.max(np.abs(err[~inside])))}
        for key in ("rms_measured", "max_measured", "rms_extended", "max_extended"):
            rec[key + "_pct"] = 100.0 * rec[key] / scale
        out[name] = rec
    return out
