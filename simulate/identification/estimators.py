"""Identification of the linear turbine model from (simulated or measured) series.

Estimators follow scikit-learn's contract (keyword-only hyperparameters stored unchanged in ``__init__``; ``fit``
validates, sets trailing-underscore attributes and returns ``self``; ``predict`` on an unfitted estimator raises
:class:`sklearn.exceptions.NotFittedError`); the recursive ones also have ``partial_fit`` for online use.

- :class:`RecursiveLeastSquares`: paper 000 eqs. (57)-(59), optional exponential forgetting.
- :class:`DeadZoneRLS`: dead-zone normalized RLS, paper 001 eqs. (5)-(8).
- :class:`SixCoefficientLeastSquares`: batch least squares of the six coefficients, paper 000 eqs. (69)-(70).
- :class:`ArmaLeastSquares`: paper 002 eqs. (9)-(12) and the map back to (ey, e, eqh), eq. (8).
- :func:`arx_regressors` builds phi(k) of eq. (55); :func:`simulation_mode_output` is eqs. (62)-(64).

RLS is written by hand: neither scipy nor scikit-learn has a recursive least-squares estimator, and the update is
three lines (the tests check it against :func:`numpy.linalg.lstsq`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from hillchart.errors import InputError, NumericalError
from simulate.linear.models import ArxModel, turbine_parameters_from_arma


# ----------------------------------------------------------------------------------------------------------------
# validation helpers
# ----------------------------------------------------------------------------------------------------------------


def _as_matrix(name: str, value, *, n_cols: int | None = None) -> np.ndarray:
    if np.asarray(value).dtype.kind == "c":  # a float cast would drop the imaginary part silently
        raise InputError(f"{name}: Complex data not supported")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a numeric array, got {type(value).__name__}") from None
    if arr.ndim == 1:
        arr = arr.reshape(-1, 1)
    if arr.ndim != 2:
        raise InputError(f"{name} must be 2-D (n_samples, n_features), got shape {arr.shape}")
    if arr.shape[0] == 0:
        raise InputError(f"{name} has no samples")
    if arr.shape[1] == 0:
        raise InputError(f"{name} has 0 feature(s) (shape={arr.shape}) while a minimum of 1 is required.")
    if n_cols is not None and arr.shape[1] != n_cols:
        raise InputError(f"{name} must have {n_cols} columns, got {arr.shape[1]}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise InputError(f"{name} contains a non-finite value at row {bad[0]}, column {bad[-1]}")
    return arr


def _as_vector(name: str, value, *, n: int | None = None) -> np.ndarray:
    if np.asarray(value).dtype.kind == "c":
        raise InputError(f"{name}: Complex data not supported")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a numeric array, got {type(value).__name__}") from None
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.ravel()
    if arr.ndim != 1:
        raise InputError(f"{name} must be 1-D, got shape {arr.shape}")
    if n is not None and arr.size != n:
        raise InputError(f"{name} must have {n} samples (the rows of the regressors), got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} contains a non-finite value at index {int(np.argmax(~np.isfinite(arr)))}")
    return arr


def _positive_float(name: str, value, *, allow_zero: bool = False, upper: float | None = None,
                    upper_inclusive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"{name} must be a real number, got {value!r}")
    v = float(value)
    ok = np.isfinite(v) and (v >= 0 if allow_zero else v > 0)
    if upper is not None:
        ok = ok and (v <= upper if upper_inclusive else v < upper)
    if not ok:
        lo = "[0" if allow_zero else "(0"
        hi = (f"{upper}]" if upper_inclusive else f"{upper})") if upper is not None else "inf)"
        raise InputError(f"{name} must be in {lo}, {hi}, got {value!r}")
    return v


def _initial_state(theta0, p0, n_features: int):
    if theta0 is None:
        theta = np.zeros(n_features)  # theta(0) = 0, paper 000 section 5.1
    else:
        theta = _as_vector("theta0", theta0)
        if theta.size != n_features:
            raise InputError(f"theta0 must have {n_features} entries (one per regressor), got {theta.size}")
        theta = theta.copy()
    if np.isscalar(p0) and not isinstance(p0, bool):
        scale = _positive_float("p0", p0)
        P = scale * np.eye(n_features)  # P(0) = p0 I (paper 000: I)
    else:
        try:
            P = np.array(p0, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"p0 must be a positive number or an SPD matrix, got {p0!r}") from None
        if P.shape != (n_features, n_features):
            raise InputError(f"p0 must be a scalar or a ({n_features}, {n_features}) matrix, got shape {P.shape}")
        if not np.all(np.isfinite(P)) or not np.allclose(P, P.T):
            raise InputError("p0 must be a finite symmetric matrix")
        if np.min(np.linalg.eigvalsh(P)) <= 0:
            raise InputError(f"p0 must be positive definite, smallest eigenvalue {np.min(np.linalg.eigvalsh(P))}")
    return theta, P


# ----------------------------------------------------------------------------------------------------------------
# regressors and simulation mode
# ----------------------------------------------------------------------------------------------------------------


def _check_structure(n_a, n_b, input_delay):
    for name, value, lo in (("n_a", n_a, 1), ("n_b", n_b, 1), ("input_delay", input_delay, 0)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
            raise InputError(f"{name} must be an integer >= {lo}, got {value!r}")


def arx_start(n_a: int, n_b: int, input_delay: int) -> int:
    """First sample index k for which phi(k) needs no sample before 0."""
    return max(n_a - 1, n_b + input_delay - 1)


def arx_regressors(x, u, *, n_a: int = 3, n_b: int = 2, input_delay: int = 1):
    """Regression rows of the ARX model (paper 000 eqs. (54)-(56)).

    ``phi(k) = [x(k), ..., x(k-n_a+1), u(k-d), ..., u(k-d-n_b+1)]`` and target ``x(k+1)``, for every k with all
    samples available. The defaults are eq. (53) as printed (n_a = 3, n_b = 2, d = 1); the exact zero-order hold of
    the third-order elastic model is n_a = n_b = 3, d = 0 (see :meth:`simulate.linear.models.LinearPlant.arx`).

    Parameters
    ----------
    x : array_like (N,)
        Output samples (relative speed).
    u : array_like (N,)
        Input samples (relative opening), same sampling.
    n_a, n_b : int >= 1
    input_delay : int >= 0

    Returns
    -------
    phi : ndarray (N - 1 - k0, n_a + n_b)
    target : ndarray (N - 1 - k0,)
        x(k+1) for k = k0 .. N-2, k0 = :func:`arx_start`.

    Examples
    --------
    >>> phi, target = arx_regressors([0, 1, 2, 3, 4], [10, 11, 12, 13, 14], n_a=2, n_b=1, input_delay=0)
    >>> phi.tolist(), target.tolist()
    ([[1.0, 0.0, 11.0], [2.0, 1.0, 12.0], [3.0, 2.0, 13.0]], [2.0, 3.0, 4.0])
    """
    _check_structure(n_a, n_b, input_delay)
    x = _as_vector("x", x)
    u = _as_vector("u", u, n=x.size)
    k0 = arx_start(n_a, n_b, input_delay)
    ks = np.arange(k0, x.size - 1)
    if ks.size == 0:
        raise InputError(f"x has {x.size} samples; the ARX structure needs at least {k0 + 2}")
    cols = [x[ks - i] for i in range(n_a)] + [u[ks - input_delay - j] for j in range(n_b)]
    return np.column_stack(cols), x[ks + 1]


@dataclass(frozen=True, eq=False)
class SimulationModeResult:
    """Simulation-mode output of an ARX model (paper 000 eqs. (62)-(64)).

    Attributes
    ----------
    x_hat : ndarray (N,)      model output, own past outputs fed back (eqs. (62)-(63))
    error : ndarray (N,)      e_speed(k) = x(k) - x_hat(k) (eq. (64)), same unit as x (relative speed)
    max_abs_error : float     max |e_speed|, the paper's "0.84 %" figure when x is relative speed
    peak_abs_output : float   max |x|, to judge max_abs_error against the size of the response
    """

    x_hat: np.ndarray
    error: np.ndarray
    max_abs_error: float
    peak_abs_output: float

    @property
    def relative_error(self) -> float:
        """max |e_speed| / max |x| (a stricter figure than the paper's)."""
        return float(self.max_abs_error / self.peak_abs_output) if self.peak_abs_output > 0 else float("nan")

    def to_dict(self) -> dict:
        return {"max_abs_error": float(self.max_abs_error), "peak_abs_output": float(self.peak_abs_output),
                "relative_error": self.relative_error}


def simulation_mode_output(theta, x, u, *, n_a: int = 3, n_b: int = 2, input_delay: int = 1) -> SimulationModeResult:
    """``x_hat(k+1) = theta(k)^T phi_hat(k)`` with ``phi_hat(k) = [x_hat(k), .., u(k-d), ..]`` (eqs. (62)-(64)).

    Parameters
    ----------
    theta : array_like (p,) or (n_rows, p)
        A fixed parameter vector, or one per regression row (row i is the estimate *before* row i is learned, as
        in the paper's on-line run; :attr:`RecursiveLeastSquares.theta_prior_`), n_rows = N - 1 - k0.
    x, u : array_like (N,)
        Measured output (used only for the first k0 + 1 samples and for the error) and input.
    n_a, n_b, input_delay : int

    Returns
    -------
    SimulationModeResult

    Examples
    --------
    >>> r = simulation_mode_output([0.5, 1.0], [0.0, 1.0, 1.5, 1.75], [1.0, 1.0, 1.0, 1.0], n_a=1, n_b=1,
    ...                            input_delay=0)
    >>> r.x_hat.tolist(), r.max_abs_error
    ([0.0, 1.0, 1.5, 1.75], 0.0)
    """
    _check_structure(n_a, n_b, input_delay)
    x = _as_vector("x", x)
    u = _as_vector("u", u, n=x.size)
    k0 = arx_start(n_a, n_b, input_delay)
    n_rows = x.size - 1 - k0
    if n_rows < 1:
        raise InputError(f"x has {x.size} samples; the ARX structure needs at least {k0 + 2}")
    theta = np.asarray(theta, dtype=float)
    p = n_a + n_b
    if theta.ndim == 1:
        if theta.size != p:
            raise InputError(f"theta must have n_a + n_b = {p} entries, got {theta.size}")
        theta = np.broadcast_to(theta, (n_rows, p))
    elif theta.shape != (n_rows, p):
        raise InputError(f"theta must be ({p},) or ({n_rows}, {p}) (one per regression row), got {theta.shape}")
    if not np.all(np.isfinite(theta)):
        raise InputError("theta contains non-finite values")
    x_hat = np.zeros_like(x)
    x_hat[: k0 + 1] = x[: k0 + 1]  # measured initial conditions
    for i, k in enumerate(range(k0, x.size - 1)):
        phi_hat = np.concatenate([x_hat[k - np.arange(n_a)], u[k - input_delay - np.arange(n_b)]])  # eq. (63)
        x_hat[k + 1] = theta[i] @ phi_hat  # eq. (62)
    if not np.all(np.isfinite(x_hat)):
        raise NumericalError("simulation-mode output diverged (non-finite x_hat): the identified model is unstable")
    error = x - x_hat  # eq. (64)
    return SimulationModeResult(x_hat=x_hat, error=error, max_abs_error=float(np.max(np.abs(error))),
                                peak_abs_output=float(np.max(np.abs(x))))


# ----------------------------------------------------------------------------------------------------------------
# recursive estimators
# ----------------------------------------------------------------------------------------------------------------


class _RecursiveBase(RegressorMixin, BaseEstimator):
    """Shared bookkeeping of the recursive estimators: validation, history, fit / partial_fit / predict."""

    def _validate_hyperparameters(self):  # pragma: no cover - overridden
        raise NotImplementedError

    def _reset(self):
        for name in ("theta_", "P_", "theta_history_", "theta_prior_", "residuals_", "updated_",
                     "n_features_in_", "n_samples_seen_", "n_updates_"):
            if hasattr(self, name):
                delattr(self, name)

    def fit(self, X, y):
        """Forget any previous data and learn from the rows of ``X`` in order.

        Parameters
        ----------
        X : array_like (n_samples, n_features)
            Regressors phi(k) (e.g. from :func:`arx_regressors`).
        y : array_like (n_samples,)
            Targets (x(k+1)).

        Returns
        -------
        self
        """
        self._reset()
        return self.partial_fit(X, y)

    def partial_fit(self, X, y):
        """Continue learning from more rows (on-line use); the first call initializes theta(0), P(0).

        Returns
        -------
        self
        """
        self._validate_hyperparameters()
        first = not hasattr(self, "theta_")
        n_features = None if first else self.n_features_in_
        X = _as_matrix("X", X, n_cols=n_features)
        y = _as_vector("y", y, n=X.shape[0])
        if first:
            self.n_features_in_ = X.shape[1]
            self.theta_, self.P_ = _initial_state(self.theta0, self.p0, X.shape[1])
            self.n_samples_seen_ = 0
            self.n_updates_ = 0
            self.theta_history_ = np.empty((0, X.shape[1]))
            self.theta_prior_ = np.empty((0, X.shape[1]))
            self.residuals_ = np.empty(0)
            self.updated_ = np.empty(0, dtype=bool)
        theta, P = self.theta_.copy(), self.P_.copy()
        hist = np.empty((X.shape[0], X.shape[1]))
        prior = np.empty_like(hist)
        eps = np.empty(X.shape[0])
        upd = np.empty(X.shape[0], dtype=bool)
        for i in range(X.shape[0]):
            prior[i] = theta
            with np.errstate(over="ignore", invalid="ignore"):  # overflow is caught just below and raised
                theta, P, eps[i], upd[i] = self._update(theta, P, X[i], y[i])
            if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(P))):
                raise NumericalError(
                    f"{type(self).__name__}: theta or P became non-finite at sample {self.n_samples_seen_ + i} "
                    f"(residual {eps[i]!r}); scale the data or lower p0"
                )
            hist[i] = theta
        self.theta_, self.P_ = theta, P
        self.theta_history_ = np.vstack([self.theta_history_, hist])
        self.theta_prior_ = np.vstack([self.theta_prior_, prior])
        self.residuals_ = np.concatenate([self.residuals_, eps])
        self.updated_ = np.concatenate([self.updated_, upd])
        self.n_samples_seen_ += X.shape[0]
        self.n_updates_ += int(upd.sum())
        return self

    def predict(self, X) -> np.ndarray:
        """One-step-ahead prediction ``theta^T phi`` for each row of ``X``, shape (n_samples,)."""
        check_is_fitted(self, "theta_")
        X = _as_matrix("X", X, n_cols=self.n_features_in_)
        return X @ self.theta_


class RecursiveLeastSquares(_RecursiveBase):
    """Recursive least squares, paper 000 eqs. (57)-(59), with optional exponential forgetting.

    ``theta(k+1) = theta(k) + P(k) phi(k) eps(k) / (lambda + phi^T P(k) phi)``, ``eps(k) = y(k) - theta(k)^T phi(k)``
    and ``P(k+1) = (P - P phi phi^T P / (lambda + phi^T P phi)) / lambda``, which is eq. (59)
    ``P^-1(k+1) = lambda P^-1(k) + phi phi^T`` by the matrix-inversion lemma; lambda = 1 is the paper.

    Parameters
    ----------
    theta0 : array_like (p,), optional
        Initial estimate; zeros by default (paper 000 section 5.1).
    p0 : float > 0 or SPD matrix (p, p)
        Initial covariance, ``p0 * I`` for a scalar; 1.0 (the paper's I) by default. A large p0 (1e6+) makes
        RLS equal to batch least squares on the same data.
    forgetting_factor : float in (0, 1]
        lambda; 1 (default) keeps all data with equal weight.

    Attributes
    ----------
    theta_ : ndarray (p,)           current estimate
    P_ : ndarray (p, p)             current covariance
    theta_history_ : ndarray (n, p) estimate after each sample
    theta_prior_ : ndarray (n, p)   estimate before each sample (what eq. (62) uses on line)
    residuals_ : ndarray (n,)       a-priori residuals eps(k), eq. (58)
    updated_ : ndarray (n,) bool    all True for plain RLS
    n_features_in_, n_samples_seen_, n_updates_ : int

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(50, 2))
    >>> rls = RecursiveLeastSquares(p0=1e8).fit(X, X @ [2.0, -1.0])
    >>> np.round(rls.theta_, 6).tolist()
    [2.0, -1.0]
    """

    def __init__(self, *, theta0=None, p0=1.0, forgetting_factor=1.0):
        self.theta0 = theta0
        self.p0 = p0
        self.forgetting_factor = forgetting_factor

    def _validate_hyperparameters(self):
        self._lambda = _positive_float("forgetting_factor", self.forgetting_factor, upper=1.0)

    def _update(self, theta, P, phi, target):
        lam = self._lambda
        eps = target - theta @ phi  # eq. (58)
        p_phi = P @ phi
        denom = lam + phi @ p_phi
        theta = theta + p_phi * (eps / denom)  # eq. (57)
        P = (P - np.outer(p_phi, p_phi) / denom) / lam  # eq. (59) by the matrix-inversion lemma
        P = 0.5 * (P + P.T)  # keep symmetric against round-off
        return theta, P, eps, True


class DeadZoneRLS(_RecursiveBase):
    """Dead-zone normalized recursive least squares, paper 001 eqs. (5)-(8).

    ``m(k)^2 = delta + phi^T P phi`` (eq. (8)); ``eps(k) = y(k) - theta^T phi`` (eq. (6));
    ``theta(k+1) = theta(k) + P phi eps / m^2`` if ``|eps| > eps0`` else ``theta(k)`` (eq. (5));
    ``P(k+1) = P - P phi phi^T P / m^2`` (eq. (7), every sample, as printed).

    Eq. (5) as printed divides by m(k), not m(k)^2; that is dimensionally inconsistent with eq. (7) (the gain would
    change with the scaling of phi) and would not reduce to RLS. Dividing by m^2 makes the algorithm the normalized
    RLS with delta in place of the 1 of paper 000 eq. (57): with ``delta = 1`` and ``eps0 = 0`` it *is*
    :class:`RecursiveLeastSquares` (a test checks this).

    Parameters
    ----------
    eps0 : float >= 0
        Dead-zone threshold on the a-priori residual; set it to the noise bound of the equation error, about
        ``(1 + sum |a_i|) * w_max`` for output noise bounded by w_max.
    delta : float > 0
        Normalization constant (paper: "typically less than 0.05"); default 0.01.
    theta0, p0
        As for :class:`RecursiveLeastSquares`.
    normalization : {"m2", "m"}
        ``"m2"`` (default): the gain of eq. (5) divided by m(k)^2, as above. ``"m"``: eq. (5) as printed, divided by
        m(k) (P still by m^2, eq. (7)); kept to compare the two readings on the same data.

    Attributes
    ----------
    As :class:`RecursiveLeastSquares`; ``updated_`` marks the samples outside the dead zone.

    Examples
    --------
    >>> dz = DeadZoneRLS(eps0=0.5, delta=0.01).fit([[1.0], [1.0]], [0.3, 2.0])
    >>> dz.updated_.tolist(), dz.theta_history_[0].tolist()
    ([False, True], [0.0])
    """

    def __init__(self, *, eps0, delta=0.01, theta0=None, p0=1.0, normalization="m2"):
        self.eps0 = eps0
        self.delta = delta
        self.theta0 = theta0
        self.p0 = p0
        self.normalization = normalization

    def _validate_hyperparameters(self):
        self._eps0 = _positive_float("eps0", self.eps0, allow_zero=True)
        self._delta = _positive_float("delta", self.delta)
        if self.normalization not in ("m2", "m"):
            raise InputError(f"normalization must be 'm2' or 'm' (eq. (5) divided by m(k)^2 or, as printed, by "
                             f"m(k)), got {self.normalization!r}")

    def _update(self, theta, P, phi, target):
        eps = target - theta @ phi  # eq. (6)
        p_phi = P @ phi
        m2 = self._delta + phi @ p_phi  # eq. (8), m(k)^2
        updated = abs(eps) > self._eps0
        if updated:
            gain = m2 if self.normalization == "m2" else np.sqrt(m2)
            theta = theta + p_phi * (eps / gain)  # eq. (5) (divided by m^2 by default, see class docstring)
        P = P - np.outer(p_phi, p_phi) / m2  # eq. (7)
        P = 0.5 * (P + P.T)
        return theta, P, eps, updated


# ----------------------------------------------------------------------------------------------------------------
# batch estimators
# ----------------------------------------------------------------------------------------------------------------


class SixCoefficientLeastSquares(RegressorMixin, BaseEstimator):
    """Batch least squares of the six coefficients from relative series (paper 000 eqs. (69)-(70)).

    ``[ex, eh, ey] = ([x h y]^T [x h y])^-1 [x h y]^T m`` (eq. (69)) and the same with q for ``[eqx, eqh, eqy]``
    (eq. (70)). Solved with :func:`numpy.linalg.lstsq` (SVD; same solution as the normal equations of the paper but
    without squaring the condition number). No intercept: the series are increments about the operating point.

    Parameters
    ----------
    rcond : float or None
        Passed to :func:`numpy.linalg.lstsq` (None = machine precision times the largest dimension).

    Attributes
    ----------
    coef_ : ndarray (2, 3)
        Rows (m, q), columns (x, h, y): ``[[ex, eh, ey], [eqx, eqh, eqy]]``.
    six_coefficients_ : dict
        ``{"ex", "ey", "eh", "eqx", "eqy", "eqh"}``.
    condition_number_ : float
        Condition number of [x h y]; large values mean x, h and y moved together and the split is uncertain.
    residual_rms_ : ndarray (2,)
        RMS fit residual of m and q.
    rank_ : int

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> X = rng.normal(size=(40, 3))                 # columns x, h, y
    >>> Y = X @ np.array([[-1.0, 1.5, 1.0], [0.0, 0.5, 1.0]]).T
    >>> est = SixCoefficientLeastSquares().fit(X, Y)
    >>> {k: round(v, 9) + 0.0 for k, v in est.six_coefficients_.items()}
    {'ex': -1.0, 'ey': 1.0, 'eh': 1.5, 'eqx': 0.0, 'eqy': 1.0, 'eqh': 0.5}
    """

    def __init__(self, *, rcond=None):
        self.rcond = rcond

    def fit(self, X, Y):
        """Fit.

        Parameters
        ----------
        X : array_like (n, 3)
            Columns x (relative speed), h (relative head), y (relative opening).
        Y : array_like (n, 2)
            Columns m (relative torque), q (relative flow).

        Returns
        -------
        self
        """
        if self.rcond is not None:
            _positive_float("rcond", self.rcond)
        X = _as_matrix("X", X, n_cols=3)
        Y = _as_matrix("Y", Y, n_cols=2)
        if Y.shape[0] != X.shape[0]:
            raise InputError(f"Y must have as many rows as X ({X.shape[0]}), got {Y.shape[0]}")
        if X.shape[0] < 3:
            raise InputError(f"X needs at least 3 samples for 3 coefficients, got {X.shape[0]}")
        coef, _, rank, sv = np.linalg.lstsq(X, Y, rcond=self.rcond)  # eqs. (69)-(70)
        if rank < 3:
            raise NumericalError(
                f"[x h y] has rank {rank} < 3: the series do not separate speed, head and opening effects "
                "(excite the plant with more than one kind of input)"
            )
        self.coef_ = coef.T
        self.rank_ = int(rank)
        self.condition_number_ = float(sv[0] / sv[-1])
        self.residual_rms_ = np.sqrt(np.mean((Y - X @ coef) ** 2, axis=0))
        (ex, eh, ey), (eqx, eqh, eqy) = self.coef_
        self.six_coefficients_ = {"ex": float(ex), "ey": float(ey), "eh": float(eh),
                                  "eqx": float(eqx), "eqy": float(eqy), "eqh": float(eqh)}
        self.n_features_in_ = 3
        return self

    def predict(self, X) -> np.ndarray:
        """``[m, q]`` for rows ``[x, h, y]``, shape (n, 2)."""
        check_is_fitted(self, "coef_")
        X = _as_matrix("X", X, n_cols=3)
        return X @ self.coef_.T


class ArmaLeastSquares(RegressorMixin, BaseEstimator):
    """ARMA least squares of the torque response to opening (paper 002 eqs. (9)-(12)) and (ey, e, eqh) by eq. (8).

    Model ``m(k) = -a m(k-1) + b y(k) + c y(k-1)`` (eq. (7)): rows ``[-m(k-1), y(k), y(k-1)]`` for k = 1..l
    (eq. (9)), ``X* = (H^T H)^-1 H^T Z`` (eq. (12), solved by :func:`numpy.linalg.lstsq`).

    Parameters
    ----------
    water_time_s : float > 0
        Tw, s (needed for the map back to the turbine parameters).
    sample_time_s : float > 0
        Dt, s (the sampling of the series).

    Attributes
    ----------
    a_, b_, c_ : float
        ARMA coefficients.
    ey_, e_, eqh_ : float
        Turbine parameters from eq. (8).
    residual_rms_ : float

    Examples
    --------
    >>> from simulate.linear.models import arma_coefficients
    >>> a, b, c = arma_coefficients(ey=1.0, e=1.0, eqh=0.5, water_time_s=2.0, sample_time_s=0.2)
    >>> y = np.r_[0.0, np.ones(10), np.zeros(10)]
    >>> m = np.zeros_like(y)
    >>> for k in range(1, y.size):
    ...     m[k] = -a * m[k - 1] + b * y[k] + c * y[k - 1]
    >>> est = ArmaLeastSquares(water_time_s=2.0, sample_time_s=0.2).fit(y, m)
    >>> round(est.ey_, 9), round(est.e_, 9), round(est.eqh_, 9)
    (1.0, 1.0, 0.5)
    """

    def __init__(self, *, water_time_s, sample_time_s):
        self.water_time_s = water_time_s
        self.sample_time_s = sample_time_s

    def fit(self, y, m):
        """Fit from the opening series ``y`` (relative) and torque (or power) series ``m`` (relative), same sampling.

        Returns
        -------
        self
        """
        tw = _positive_float("water_time_s", self.water_time_s)
        dt = _positive_float("sample_time_s", self.sample_time_s)
        y = _as_vector("y", y)
        m = _as_vector("m", m, n=y.size)
        if y.size < 4:
            raise InputError(f"y needs at least 4 samples for 3 ARMA coefficients, got {y.size}")
        H = np.column_stack([-m[:-1], y[1:], y[:-1]])  # eq. (9)-(10)
        Z = m[1:]
        sol, _, rank, _ = np.linalg.lstsq(H, Z, rcond=None)  # eq. (12)
        if rank < 3:
            raise NumericalError(f"ARMA regression matrix has rank {rank} < 3: the opening must change")
        self.a_, self.b_, self.c_ = (float(v) for v in sol)
        self.residual_rms_ = float(np.sqrt(np.mean((Z - H @ sol) ** 2)))
        self.ey_, self.e_, self.eqh_ = turbine_parameters_from_arma(self.a_, self.b_, self.c_, water_time_s=tw,
                                                                    sample_time_s=dt)
        return self

    def predict(self, y, m0: float = 0.0) -> np.ndarray:
        """Simulate eq. (7) from ``m(0) = m0`` for the opening series ``y`` (own past outputs), shape (N,)."""
        check_is_fitted(self, "a_")
        y = _as_vector("y", y)
        m = np.empty_like(y)
        m[0] = float(m0)
        for k in range(1, y.size):
            m[k] = -self.a_ * m[k - 1] + self.b_ * y[k] + self.c_ * y[k - 1]  # eq. (7)
        return m

    def score(self, y, m):  # RegressorMixin.score would call predict(X) with the wrong meaning
        """R^2 of the simulated torque against ``m``."""
        m = _as_vector("m", m)
        pred = self.predict(y, m0=m[0])
        return float(1.0 - np.sum((m - pred) ** 2) / np.sum((m - m.mean()) ** 2))


def identified_arx(estimator, *, n_a: int, n_b: int, input_delay: int, sample_time_s: float) -> ArxModel:
    """The :class:`~simulate.linear.models.ArxModel` of a fitted recursive estimator's final theta."""
    check_is_fitted(estimator, "theta_")
    return ArxModel.from_theta(estimator.theta_, n_a=n_a, n_b=n_b, input_delay=input_delay,
                               sample_time_s=sample_time_s)
