"""The multi-output BP net of the full characteristic curve map: exported weights (``fccm_nets.json``), the estimator
:class:`FCCMNet` (Levenberg-Marquardt, hidden size from eq. (3), the seeded 30/35/35 split)."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hillchart.errors import InputError, NumericalError
from hillchart.validation import check_vector

# ----------------------------------------------------------------------------------------------------------------
# the exported net: fccm_nets.json (numpy evaluation, no torch)
# ----------------------------------------------------------------------------------------------------------------
FORMAT = "hillsim.fccm"
VERSION = 1
NETS_FILE = "fccm_nets.json"
METRICS_FILE = "metrics.json"


def _float_matrix(value, key: str, rows: int | None, cols: int) -> np.ndarray:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) == 0:
        raise InputError(f"{key} must be a non-empty list of rows, got {value!r}")
    if rows is not None and len(value) != rows:
        raise InputError(f"{key} must have {rows} rows, got {len(value)}")
    return np.array([check_vector(f"{key}[{i}]", row, cols) for i, row in enumerate(value)])


def _names(value, key: str) -> tuple:
    if isinstance(value, tuple):
        value = list(value)
    if (not isinstance(value, list) or not value
            or not all(isinstance(v, str) and v.strip() for v in value)):
        raise InputError(f"{key} must be a non-empty list of column names, got {value!r}")
    if len(set(value)) != len(value):
        raise InputError(f"{key} must be distinct, got {value!r}")
    return tuple(value)


def _logsig(z):
    """eq. (10) of paper 004, the log-sigmoid, without overflow for either sign of z."""
    out = np.empty_like(z)
    pos = z >= 0
    out[pos] = 1.0 / (1.0 + np.exp(-z[pos]))
    ez = np.exp(z[~pos])
    out[~pos] = ez / (1.0 + ez)
    return out


@dataclass(frozen=True, eq=False)
class FCCMWeights:
    """An n_in-H-n_out logsig/purelin net with its input/output scaling (``fccm_nets.json``)::

        xn = 2 (x - x_min) / (x_max - x_min) - 1;  h = 1 / (1 + exp(-(W1 xn + b1)));  yn = W2 h + b2
        y = (yn + 1) (y_max - y_min) / 2 + y_min          (per output)

    Parameters
    ----------
    inputs, outputs : sequence of str
        Column names (units in the names).
    x_min, x_max : array_like (n_in,)
    y_min, y_max : array_like (n_out,)
    W1 : array_like (H, n_in)
    b1 : array_like (H,)
    W2 : array_like (n_out, H)
    b2 : array_like (n_out,)
    training : dict, optional
        Training record (JSON-serializable).

    Raises
    ------
    InputError
        Wrong shapes, NaN/inf, ``x_max <= x_min``, ``y_max <= y_min``, bad names: the message names the key.

    Examples
    --------
    >>> w = FCCMWeights(inputs=["a", "b"], outputs=["y"], x_min=[0, 0], x_max=[2, 2], y_min=[0], y_max=[1],
    ...                 W1=[[1.0, 0.0]], b1=[0.0], W2=[[2.0]], b2=[-1.0])
    >>> w.predict([[1.0, 5.0]]).tolist()   # xn = 0 -> h = 0.5 -> yn = 0 -> y = 0.5
    [[0.5]]
    """

    inputs: tuple
    outputs: tuple
    x_min: np.ndarray
    x_max: np.ndarray
    y_min: np.ndarray
    y_max: np.ndarray
    W1: np.ndarray
    b1: np.ndarray
    W2: np.ndarray
    b2: np.ndarray
    training: dict = field(default_factory=dict)

    def __post_init__(self):
        self._validate(prefix="")

    def _validate(self, prefix: str):
        put = object.__setattr__
        inputs = _names(self.inputs, f"{prefix}inputs")
        outputs = _names(self.outputs, f"{prefix}outputs")
        n_in, n_out = len(inputs), len(outputs)
        x_min = check_vector(f"{prefix}x_min", self.x_min, n_in)
        x_max = check_vector(f"{prefix}x_max", self.x_max, n_in)
        for j, name in enumerate(inputs):
            if not x_max[j] > x_min[j]:
                raise InputError(f"{prefix}x_max[{j}] ({name}) must be > {prefix}x_min[{j}] = {x_min[j]!r}, "
                                 f"got {x_max[j]!r}")
        y_min = check_vector(f"{prefix}y_min", self.y_min, n_out)
        y_max = check_vector(f"{prefix}y_max", self.y_max, n_out)
        for j, name in enumerate(outputs):
            if not y_max[j] > y_min[j]:
                raise InputError(f"{prefix}y_max[{j}] ({name}) must be > {prefix}y_min[{j}] = {y_min[j]!r}, "
                                 f"got {y_max[j]!r}")
        w1 = _float_matrix(self.W1, f"{prefix}W1", None, n_in)
        hidden = w1.shape[0]
        b1 = check_vector(f"{prefix}b1", self.b1, hidden)
        w2 = _float_matrix(self.W2, f"{prefix}W2", n_out, hidden)
        b2 = check_vector(f"{prefix}b2", self.b2, n_out)
        training = self.training if self.training is not None else {}
        if not isinstance(training, dict):
            raise InputError(f"{prefix}training must be an object, got {type(training).__name__}")
        for name, value in (("x_min", x_min), ("x_max", x_max), ("y_min", y_min), ("y_max", y_max), ("W1", w1),
                            ("b1", b1), ("W2", w2), ("b2", b2)):
            value.setflags(write=False)
            put(self, name, value)
        put(self, "inputs", inputs)
        put(self, "outputs", outputs)
        put(self, "training", dict(training))

    @property
    def hidden(self) -> int:
        return int(self.W1.shape[0])

    def predict(self, X) -> np.ndarray:
        """Outputs (n, n_out) in physical units at inputs ``X`` (n, n_in), the columns in ``inputs`` order."""
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != len(self.inputs):
            raise InputError(f"X must have shape (n, {len(self.inputs)}) with columns {list(self.inputs)}, got "
                             f"{X.shape}")
        xn = 2.0 * (X - self.x_min) / (self.x_max - self.x_min) - 1.0  # mapminmax
        h = _logsig(xn @ self.W1.T + self.b1)  # eq. (10) of paper 004, one hidden layer
        yn = h @ self.W2.T + self.b2  # linear outputs
        return (yn + 1.0) * (self.y_max - self.y_min) / 2.0 + self.y_min  # reverse mapminmax

    def predict_grad(self, X) -> np.ndarray:
        """Analytic Jacobian dy/dx (n, n_out, n_in) in physical units at inputs ``X`` (n, n_in).

        ``dy_k/dx_j = (y_max_k - y_min_k)/2 sum_i W2_ki h_i (1 - h_i) W1_ij 2/(x_max_j - x_min_j)``.
        """
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != len(self.inputs):
            raise InputError(f"X must have shape (n, {len(self.inputs)}) with columns {list(self.inputs)}, got "
                             f"{X.shape}")
        xn = 2.0 * (X - self.x_min) / (self.x_max - self.x_min) - 1.0
        h = _logsig(xn @ self.W1.T + self.b1)
        dh = h * (1.0 - h)  # (n, H)
        jac = np.einsum("ki,ni,ij->nkj", self.W2, dh, self.W1)
        return jac * ((self.y_max - self.y_min) / 2.0)[None, :, None] * (2.0 / (self.x_max - self.x_min))[None, None, :]

    def predict_columns(self, **inputs) -> dict:
        """Outputs by name from inputs by name (arrays broadcast together), e.g.
        ``predict_columns(blade_angle_deg=a, guide_vane_deg=b)["efficiency"]``."""
        missing = [n for n in self.inputs if n not in inputs]
        unknown = [n for n in inputs if n not in self.inputs]
        if missing or unknown:
            raise InputError(f"predict_columns needs exactly the inputs {list(self.inputs)}; missing {missing}, "
                             f"unknown {unknown}")
        arrays = np.broadcast_arrays(*(np.asarray(inputs[n], dtype=float) for n in self.inputs))
        shape = arrays[0].shape
        y = self.predict(np.column_stack([a.ravel() for a in arrays]))
        return {name: y[:, j].reshape(shape) for j, name in enumerate(self.outputs)}

    def outside_domain(self, X) -> np.ndarray:
        """True for rows of ``X`` outside the box the net was fitted on (extrapolation)."""
        X = np.asarray(X, dtype=float)
        return np.any((X < self.x_min) | (X > self.x_max), axis=1)

    # fccm_nets.json -------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {"format": FORMAT, "version": VERSION, "inputs": list(self.inputs), "outputs": list(self.outputs),
                "x_min": [float(v) for v in self.x_min], "x_max": [float(v) for v in self.x_max],
                "y_min": [float(v) for v in self.y_min], "y_max": [float(v) for v in self.y_max],
                "W1": [[float(v) for v in row] for row in self.W1], "b1": [float(v) for v in self.b1],
                "W2": [[float(v) for v in row] for row in self.W2], "b2": [float(v) for v in self.b2],
                "training": self.training}

    def to_json(self) -> str:
        """``fccm_nets.json`` text: one line per key, floats in shortest round-trip form (loading is bit-exact)."""
        doc = self.to_dict()
        lines = []
        for key, value in doc.items():
            if key == "training":
                text = json.dumps(value, indent=1, allow_nan=False).replace("\n", "\n ")
            else:
                text = json.dumps(value, allow_nan=False)
            lines.append(f" {json.dumps(key)}: {text}")
        return "{\n" + ",\n".join(lines) + "\n}\n"

    def save(self, path) -> Path:
        path = Path(path)
        path.write_text(self.to_json(), encoding="utf-8")
        return path

    @classmethod
    def from_dict(cls, doc) -> "FCCMWeights":
        """Validate a parsed ``fccm_nets.json`` document (extra keys are allowed, as in ``nets.json``)."""
        if not isinstance(doc, dict):
            raise InputError(f"{NETS_FILE} must hold an object, got {type(doc).__name__}")
        required = ("format", "version", "inputs", "outputs", "x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2",
                    "b2")
        for key in required:
            if key not in doc:
                raise InputError(f"key {key!r} is missing (required: {', '.join(required)})")
        if doc["format"] != FORMAT:
            raise InputError(f"format must be {FORMAT!r}, got {doc['format']!r}")
        if isinstance(doc["version"], bool) or doc["version"] != VERSION:
            raise InputError(f"version must be {VERSION}, got {doc['version']!r}")
        obj = cls.__new__(cls)
        for key in required[2:]:
            object.__setattr__(obj, key, doc[key])
        object.__setattr__(obj, "training", doc["training"] if "training" in doc else {})
        obj._validate(prefix="")
        return obj

    @classmethod
    def from_json(cls, text: str) -> "FCCMWeights":
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"not valid JSON ({exc})") from None
        return cls.from_dict(doc)

    def __eq__(self, other):
        if not isinstance(other, FCCMWeights):
            return NotImplemented
        return (self.inputs == other.inputs and self.outputs == other.outputs
                and all(np.array_equal(getattr(self, k), getattr(other, k))
                        for k in ("x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2", "b2")))

    __hash__ = None


def load_fccm_nets(path) -> FCCMWeights:
    """Read and validate ``fccm_nets.json`` (numpy only; torch is not imported).

    Raises
    ------
    InputError
        Invalid JSON, wrong format or version, missing keys, wrong shapes, NaN/inf, ``x_max <= x_min``: the
        message names the file and the key.
    FileNotFoundError
        No such file.
    """
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    try:
        return FCCMWeights.from_json(text)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


# ----------------------------------------------------------------------------------------------------------------
# the estimator
# ----------------------------------------------------------------------------------------------------------------
def hidden_size(n_inputs: int, n_outputs: int, c: int) -> int:
    """Hidden neurons from eq. (3) of paper 003, ``n_hl = sqrt(n_in + n_out) + C``, rounded to the nearest integer.

    Examples
    --------
    >>> [hidden_size(2, 4, c) for c in (1, 8, 10)]   # paper 003: 2 inputs, 4 outputs; it picks 10 (C = 8)
    [3, 10, 12]
    """
    return int(math.floor(math.sqrt(n_inputs + n_outputs) + c + 0.5))  # eq. (3), paper 003


def split_indices(n: int, fractions, rng: np.random.Generator):
    """Seeded random train / validation / test split (paper 003: 30 / 35 / 35 %).

    ``round(f_train n)`` training and ``round(f_val n)`` validation samples, the rest test; each part gets at least
    one sample (training at least 3).

    Examples
    --------
    >>> tr, va, te = split_indices(150, (0.30, 0.35, 0.35), np.random.default_rng(0))
    >>> len(tr), len(va), len(te)
    (45, 52, 53)
    """
    f_train, f_val, _ = fractions
    n_train = max(3, int(round(f_train * n)))
    n_val = max(1, int(round(f_val * n)))
    if n_train + n_val >= n:
        raise InputError(f"{n} samples cannot be split {list(fractions)} into train (>= 3), validation (>= 1) and "
                         "test (>= 1)")
    perm = rng.permutation(n)
    return np.sort(perm[:n_train]), np.sort(perm[n_train:n_train + n_val]), np.sort(perm[n_train + n_val:])


class FCCMNet:
    """Multi-output BP net y(x) of paper 003 (n_in inputs, one logsig hidden layer, n_out linear outputs), trained
    by Levenberg-Marquardt (:mod:`hillchart.nets.lm`, MATLAB ``trainlm``).

    Inputs and outputs are mapped to [-1, 1] by their min/max over all samples (``mapminmax``, as MATLAB configures
    a net from the whole data set); the samples are split at random (seeded) into training, validation and test
    parts (paper 003: 30/35/35 %); each run stops when the validation error has risen ``max_fail`` times and keeps
    its best-validation weights; the best of ``restarts`` Nguyen-Widrow starts is kept. With ``hidden=None`` the
    hidden size follows eq. (3), ``n_hl = sqrt(n_in + n_out) + C``, with C in ``c_values`` chosen by the lowest
    validation error (the test part is never used for a choice).

    Parameters
    ----------
    hidden : int or None, default None
        Fixed hidden size; None: eq. (3) with C chosen by validation.
    c_values : sequence of int, default 1..10
        Candidate C of eq. (3).
    split : (float, float, float), default (0.30, 0.35, 0.35)
        Training, validation and test fractions (sum 1).
    restarts : int, default 5
    seed : int, default 0
        Seeds the split and every initialisation.
    goal, max_epochs, max_fail, mu, mu_dec, mu_inc, mu_max
        ``trainlm`` parameters (goal on the mean squared normalized error of all outputs).
    n_threads : int or None, default None
        Threads running the restarts side by side during ``fit`` (the result does not depend on it). None: the
        processors this process may run on, at most 8 (:func:`hillchart.nets.lm.threads`).

    Attributes
    ----------
    weights_ : FCCMWeights
    hidden_ : int
    c_ : int or None
        The chosen C (None when ``hidden`` was given).
    selection_ : list of dict
        Per candidate: c, hidden, validation MSE (normalized) of its best start.
    train_index_, val_index_, test_index_ : ndarray of int
    train_mse_, val_mse_, test_mse_ : float
        Mean squared normalized errors of the kept net.
    epochs_, stop_reason_ : int, str

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> X = rng.uniform(-1, 1, (120, 2))
    >>> Y = np.column_stack([np.tanh(X[:, 0] + X[:, 1]), X[:, 0] * X[:, 1]])
    >>> net = FCCMNet(hidden=6, restarts=2, seed=0).fit(X, Y)
    >>> bool(np.sqrt(np.mean((net.predict(X) - Y) ** 2)) < 0.02)
    True
    """

    _PARAMS = ("hidden", "c_values", "split", "restarts", "seed", "goal", "max_epochs", "max_fail", "mu", "mu_dec",
               "mu_inc", "mu_max", "n_threads")

    def __init__(self, *, hidden: int | None = None, c_values=tuple(range(1, 11)), split=(0.30, 0.35, 0.35),
                 restarts: int = 5, seed: int = 0, goal: float = 1e-7, max_epochs: int = 1000, max_fail: int = 6,
                 mu: float = 1e-3, mu_dec: float = 0.1, mu_inc: float = 10.0, mu_max: float = 1e10,
                 n_threads: int | None = None):
        self.hidden = hidden
        self.c_values = c_values
        self.split = split
        self.restarts = restarts
        self.seed = seed
        self.goal = goal
        self.max_epochs = max_epochs
        self.max_fail = max_fail
        self.mu = mu
        self.mu_dec = mu_dec
        self.mu_inc = mu_inc
        self.mu_max = mu_max
        self.n_threads = n_threads

    def get_params(self, deep: bool = True) -> dict:
        return {name: getattr(self, name) for name in self._PARAMS}

    def set_params(self, **params) -> "FCCMNet":
        for name, value in params.items():
            if name not in self._PARAMS:
                raise InputError(f"FCCMNet has no parameter {name!r}; valid: {', '.join(self._PARAMS)}")
            setattr(self, name, value)
        return self

    def __repr__(self):
        return "FCCMNet(" + ", ".join(f"{k}={v!r}" for k, v in self.get_params().items()) + ")"

    def _validate_params(self):
        def is_int(value, low):
            return not isinstance(value, bool) and isinstance(value, (int, np.integer)) and value >= low

        if self.hidden is not None and not is_int(self.hidden, 1):
            raise InputError(f"FCCMNet.hidden must be None or an integer >= 1, got {self.hidden!r}")
        if self.n_threads is not None and not is_int(self.n_threads, 1):
            raise InputError(f"FCCMNet.n_threads must be None (the processors available) or an integer >= 1, got "
                             f"{self.n_threads!r}")
        for name, low in (("restarts", 1), ("max_epochs", 0), ("max_fail", 1), ("seed", 0)):
            if not is_int(getattr(self, name), low):
                raise InputError(f"FCCMNet.{name} must be an integer >= {low}, got {getattr(self, name)!r}")
        c_values = self.c_values
        if (not isinstance(c_values, (list, tuple, range)) or len(c_values) == 0
                or not all(is_int(c, 1) and c <= 10 for c in c_values)):
            raise InputError(f"FCCMNet.c_values must be a non-empty list of integers in 1..10 (eq. (3) of paper "
                             f"003), got {c_values!r}")
        split = self.split
        if (not isinstance(split, (list, tuple)) or len(split) != 3
                or not all(isinstance(f, (int, float)) and not isinstance(f, bool) and 0 < f < 1 for f in split)
                or abs(sum(split) - 1.0) > 1e-9):
            raise InputError(f"FCCMNet.split must be three fractions in (0, 1) summing to 1 (train, validation, "
                             f"test), got {split!r}")
        for name in ("goal", "mu", "mu_max"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise InputError(f"FCCMNet.{name} must be a finite number >= 0, got {value!r}")
        if not 0 < self.mu_dec < 1:
            raise InputError(f"FCCMNet.mu_dec must be in (0, 1), got {self.mu_dec!r}")
        if not self.mu_inc > 1:
            raise InputError(f"FCCMNet.mu_inc must be > 1, got {self.mu_inc!r}")

    def fit(self, X, Y, *, input_names=None, output_names=None) -> "FCCMNet":
        """Train on inputs ``X`` (n, n_in) and targets ``Y`` (n, n_out) in physical units.

        Parameters
        ----------
        X : array_like (n, n_in)
        Y : array_like (n, n_out) or (n,)
        input_names, output_names : sequence of str, optional
            Written into ``fccm_nets.json`` (default x0.., y0..).

        Returns
        -------
        self

        Raises
        ------
        InputError
            Bad shapes, NaN/inf, a constant column, too few samples, bad hyperparameters.
        NumericalError
            Training diverged to NaN.
        """
        import time

        from hillchart.nets import lm

        self._validate_params()
        X = np.asarray(X, dtype=float)
        Y = np.asarray(Y, dtype=float)
        if Y.ndim == 1:
            Y = Y[:, None]
        if X.ndim != 2 or X.shape[1] < 1:
            raise InputError(f"X must have shape (n, n_in), got {X.shape}")
        if Y.ndim != 2 or Y.shape[0] != X.shape[0]:
            raise InputError(f"Y must have shape ({X.shape[0]}, n_out) matching X, got {Y.shape}")
        n, n_in = X.shape
        n_out = Y.shape[1]
        input_names = tuple(input_names) if input_names is not None else tuple(f"x{j}" for j in range(n_in))
        output_names = tuple(output_names) if output_names is not None else tuple(f"y{j}" for j in range(n_out))
        if len(input_names) != n_in or len(output_names) != n_out:
            raise InputError(f"input_names / output_names must name the {n_in} input and {n_out} output columns, got "
                             f"{list(input_names)} / {list(output_names)}")
        if n < 10:
            raise InputError(f"need >= 10 samples to train, validate and test, got {n}")
        for name, arr, names in (("X", X, input_names), ("Y", Y, output_names)):
            bad = np.argwhere(~np.isfinite(arr))
            if bad.size:
                i, j = bad[0]
                raise InputError(f"{name}: sample {i}, column {names[j]!r} is {float(arr[i, j])!r}; values must be "
                                 "finite")
        x_min, x_max = X.min(axis=0), X.max(axis=0)
        y_min, y_max = Y.min(axis=0), Y.max(axis=0)
        for lo, hi, names in ((x_min, x_max, input_names), (y_min, y_max, output_names)):
            for j in np.flatnonzero(~(hi > lo)):
                raise InputError(f"column {names[j]!r} is constant ({lo[j]!r}); the net needs a range")
        xn = 2.0 * (X - x_min) / (x_max - x_min) - 1.0  # mapminmax
        yn = 2.0 * (Y - y_min) / (y_max - y_min) - 1.0
        yn_lm = yn[:, 0] if n_out == 1 else yn
        tr, va, te = split_indices(n, self.split, np.random.default_rng(self.seed))
        if self.hidden is not None:
            candidates = [(None, int(self.hidden))]
        else:
            seen, candidates = set(), []
            for c in self.c_values:
                h = hidden_size(n_in, n_out, c)
                if h not in seen:
                    seen.add(h)
                    candidates.append((int(c), h))
        start = time.perf_counter()
        selection, best = [], None
        for c, h in candidates:
            rng = np.random.default_rng([self.seed, h])  # the starts of size h do not depend on the others
            thetas0 = [lm.nguyen_widrow_init(h, rng, n_in, n_out) for _ in range(self.restarts)]
            runs = lm.levenberg_marquardt_many(  # one output: 1-D targets (lm's 2-H-1 path)
                xn[tr], yn_lm[tr], xn[va], yn_lm[va], thetas0, n_threads=self.n_threads, hidden=h, goal=self.goal,
                max_epochs=self.max_epochs, max_fail=self.max_fail, mu=self.mu, mu_dec=self.mu_dec,
                mu_inc=self.mu_inc, mu_max=self.mu_max)
            k = int(np.argmin([r.val_mse for r in runs]))
            selection.append({"c": c, "hidden": h, "validation_mse": runs[k].val_mse,
                              "train_mse": runs[k].train_mse, "best_restart": k})
            if best is None or runs[k].val_mse < best[2].val_mse:
                best = (c, h, runs[k])
        self.fit_time_s_ = time.perf_counter() - start
        c, h, res = best
        if not np.all(np.isfinite(res.theta)):
            raise NumericalError("FCCMNet: the kept weights are not finite")
        w1, b1, w2, b2 = lm.unpack(res.theta, h, n_in, n_out)
        w2 = np.asarray(w2).reshape(n_out, h)
        b2 = np.atleast_1d(np.asarray(b2, dtype=float))
        self.weights_ = FCCMWeights(inputs=input_names, outputs=output_names, x_min=x_min, x_max=x_max, y_min=y_min,
                                    y_max=y_max, W1=w1, b1=b1, W2=w2, b2=b2)
        self.hidden_, self.c_ = h, c
        self.selection_ = selection
        self.train_index_, self.val_index_, self.test_index_ = tr, va, te
        yn_fit = 2.0 * (self.weights_.predict(X) - y_min) / (y_max - y_min) - 1.0
        self.train_mse_ = float(np.mean((yn_fit[tr] - yn[tr]) ** 2))
        self.val_mse_ = float(np.mean((yn_fit[va] - yn[va]) ** 2))
        self.test_mse_ = float(np.mean((yn_fit[te] - yn[te]) ** 2))
        self.epochs_, self.best_epoch_, self.stop_reason_ = res.epochs, res.best_epoch, res.stop_reason
        self.weights_.training.update(self.training_record())
        return self

    def _check_fitted(self):
        if not hasattr(self, "weights_"):
            raise InputError("this FCCMNet is not fitted yet; call fit(X, Y) before predict")

    def predict(self, X) -> np.ndarray:
        """Outputs (n, n_out) at inputs ``X`` (n, n_in)."""
        self._check_fitted()
        return self.weights_.predict(X)

    def training_record(self) -> dict:
        """The ``training`` block of ``fccm_nets.json`` (JSON-serializable, no timings: byte-reproducible)."""
        self._check_fitted()
        return {"seed": self.seed, "split": list(self.split), "restarts": self.restarts,
                "hidden": self.hidden_, "c": self.c_,
                "hidden_rule": ("eq. (3) of Wu et al.: round(sqrt(n_in + n_out) + C)" if self.c_ is not None
                                else "fixed"),
                "selection": self.selection_,
                "n_train": int(self.train_index_.size), "n_validation": int(self.val_index_.size),
                "n_test": int(self.test_index_.size), "train_mse_normalized": self.train_mse_,
                "validation_mse_normalized": self.val_mse_, "test_mse_normalized": self.test_mse_,
                "epochs": self.epochs_, "best_epoch": self.best_epoch_, "stop_reason": self.stop_reason_}


def split_errors(weights: FCCMWeights, X, Y, parts: dict) -> dict:
    """Per output RMSE and max |error| (physical units) on each part (``{"train": idx, "validation": idx, ...}``)."""
    err = weights.predict(X) - np.asarray(Y, dtype=float).reshape(len(X), -1)
    out = {}
    for j, name in enumerate(weights.outputs):
        out[name] = {part: {"rmse": float(np.sqrt(np.mean(err[idx, j] ** 2))),
                            "max_abs_error": float(np.max(np.abs(err[idx, j])))} for part, idx in parts.items()}
    return out
