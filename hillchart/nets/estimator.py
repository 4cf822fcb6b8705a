"""The scikit-learn style estimator of one 2-H-1 logsig net (:class:`HillNet`): a stratified split, Levenberg-Marquardt
from several starts, validation stop."""

from __future__ import annotations

import math
import time
from functools import partial

import numpy as np

from hillchart.errors import InputError
from hillchart.nets import lm
from hillchart.nets.weights import NetWeights


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


def _lm_jobs(xn, yn, train_index, val_index, weight, hidden, regularization, thetas0, lm_params):
    """One Levenberg-Marquardt run from each start in ``thetas0``, as callables (:func:`hillchart.nets.lm.run_threads`
    runs them); each returns its :class:`hillchart.nets.lm.LMResult`."""
    sample_weight = None if np.all(weight[train_index] == 1.0) else weight[train_index]
    return [partial(lm.levenberg_marquardt, xn[train_index], yn[train_index], xn[val_index], yn[val_index], theta0,
                    hidden=hidden, sample_weight=sample_weight, regularization=regularization, **lm_params)
            for theta0 in thetas0]


def _lm_runs(xn, yn, train_index, val_index, weight, hidden, regularization, rng, restarts, n_threads, lm_params):
    """``restarts`` Levenberg-Marquardt runs from Nguyen-Widrow initialisations ("loop control", section 2.3 of
    paper 004), side by side on ``n_threads`` threads (None: :func:`hillchart.nets.lm.threads`); returns the list of
    :class:`hillchart.nets.lm.LMResult`."""
    thetas0 = [lm.nguyen_widrow_init(hidden, rng) for _ in range(restarts)]
    return lm.run_threads(_lm_jobs(xn, yn, train_index, val_index, weight, hidden, regularization, thetas0,
                                   lm_params), n_threads)


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
    n_threads : int or None, default None
        Threads running the restarts side by side during ``fit`` (the compiled LM loop releases the GIL; the
        result does not depend on it: the restarts are independent and drawn before they run). None: the
        processors this process may run on, at most 8 (:func:`hillchart.nets.lm.threads`).

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
                 n_threads: int | None = None, boundary_weight: float = 1.0, regularization: float = 0.0,
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
        threads = self.n_threads
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
                                    or threads < 1):
            raise InputError(f"HillNet.n_threads must be None (the processors available) or an integer >= 1, got "
                             f"{threads!r}")
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
