"""Levenberg-Marquardt training of a 2-H-1 logsig/purelin net, as MATLAB's ``trainlm`` does it.

The BP hill-chart paper (004, section 2.4) trains its nets with ``newff(minmax(p), [5 1], {'logsig' 'purelin'})``
and ``train``; the default training function of ``newff`` is ``trainlm``. This module reproduces that algorithm
(float64) as one numba-compiled loop:

* residuals ``e = yn_net(theta; xn) - yn_target`` on inputs and targets already mapped to [-1, 1];
* performance ``mse = mean(e^2)``; goal, epoch limit and ``min_grad`` stop as in ``trainlm``;
* step ``dtheta = -(J^T J + mu I)^-1 J^T e`` with the adaptive damping of ``trainlm``: try the step, on
  success accept it and multiply ``mu`` by ``mu_dec``, otherwise multiply ``mu`` by ``mu_inc`` and retry, give up
  when ``mu > mu_max``;
* early stopping on the validation set: ``max_fail`` consecutive epochs whose validation error is higher than the
  best one stop training, and the weights with the best validation error are returned (``trainlm`` restores them).

The Jacobian of the residuals is analytic (the net has only ``4 H + 1`` parameters, 21 for H = 5); a test checks it
against ``torch.func.jacrev``. Hand-written rather than a library optimizer because neither torch nor scipy offers
LM with validation early stopping (``scipy.optimize.least_squares(method="lm")`` is MINPACK without a validation
set or per-epoch control); the algorithm is the published one and is short. Compiled rather than written with
torch tensors: with 21 parameters and ~150 residuals an epoch is a few microseconds of arithmetic, and torch's
per-operation overhead (about 0.7 ms an epoch over its ~15 tensor calls) made training about 7 x slower
(``hillsim train data_synthetic/francis``: 9.2 s of training with the torch loop, 1.35 s compiled, same selection
and nets equal to 1e-13 of their range; measured 2026-11-22). The loop releases the GIL, so independent starts run
on several threads (:func:`levenberg_marquardt_many`).

Parameter vector layout (``theta``, length ``4 H + 1``)::

    theta = [W1 (H x 2, row-major: w_n11, w_opening per neuron), b1 (H), W2 (H), b2]

General n_in-H-n_out nets (paper 003's full-characteristic net, :mod:`hillchart.fccm`) use the same functions with
``n_inputs`` / ``n_outputs`` (defaults 2 and 1 give the layout above unchanged)::

    theta = [W1 (H x n_in, row-major), b1 (H), W2 (n_out x H, row-major), b2 (n_out)]
    length H (n_in + 1 + n_out) + n_out

with targets of shape (n, n_out); the residual vector is the (n, n_out) error array flattened row-major and the
performance is its mean square (``trainlm``'s ``mse`` over all outputs).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from hillchart.errors import NumericalError


def n_parameters(hidden: int, n_inputs: int = 2, n_outputs: int = 1) -> int:
    """Number of weights and biases of an ``n_inputs``-``hidden``-``n_outputs`` net (``4 hidden + 1`` for 2-H-1).

    Examples
    --------
    >>> n_parameters(5)
    21
    >>> n_parameters(10, 2, 4)  # paper 003's 2-10-4 net
    74
    """
    return hidden * (n_inputs + 1 + n_outputs) + n_outputs


def unpack(theta, hidden: int, n_inputs: int = 2, n_outputs: int = 1):
    """Split a parameter vector into ``(W1 (H, n_in), b1 (H,), W2, b2)`` views (numpy or torch): for one output
    ``W2 (H,)`` and ``b2 ()`` (the 2-H-1 layout), else ``W2 (n_out, H)`` and ``b2 (n_out,)``."""
    h, k = hidden, n_inputs * hidden
    w1, b1 = theta[:k].reshape(h, n_inputs), theta[k: k + h]
    if n_outputs == 1:
        return w1, b1, theta[k + h: k + 2 * h], theta[k + 2 * h]
    return w1, b1, theta[k + h: k + h + n_outputs * h].reshape(n_outputs, h), theta[k + h + n_outputs * h:]


@numba.njit(cache=True, nogil=True)
def _outputs(theta, xn, hidden, n_outputs, want_jacobian):
    """Net outputs (n n_out,) flattened row-major and, when ``want_jacobian``, their Jacobian (n n_out, n_par);
    else a (0, n_par) array. The one implementation behind :func:`forward`, :func:`residual_jacobian` and the
    training kernel."""
    n, n_in = xn.shape
    h, k = hidden, n_in * hidden
    n_par = h * (n_in + 1 + n_outputs) + n_outputs
    y = np.empty(n * n_outputs)
    jac = np.zeros((n * n_outputs if want_jacobian else 0, n_par))
    f = np.empty(h)
    for i in range(n):
        for j in range(h):
            z = theta[k + j]
            for m in range(n_in):
                z += theta[j * n_in + m] * xn[i, m]
            # eq. (10), paper 004: logsig, evaluated without overflow for either sign of z
            if z >= 0.0:
                f[j] = 1.0 / (1.0 + math.exp(-z))
            else:
                ez = math.exp(z)
                f[j] = ez / (1.0 + ez)
        for o in range(n_outputs):
            r = i * n_outputs + o
            w2 = k + h + o * h
            s = theta[k + h + n_outputs * h + o]
            for j in range(h):
                s += theta[w2 + j] * f[j]  # eq. (11), paper 004
            y[r] = s
            if want_jacobian:
                for j in range(h):
                    d = theta[w2 + j] * f[j] * (1.0 - f[j])
                    for m in range(n_in):
                        jac[r, j * n_in + m] = d * xn[i, m]
                    jac[r, k + j] = d
                    jac[r, w2 + j] = f[j]
                jac[r, k + h + n_outputs * h + o] = 1.0
    return y, jac


def _as_inputs(theta, xn):
    return (np.ascontiguousarray(theta, dtype=np.float64).ravel(),
            np.ascontiguousarray(np.atleast_2d(np.asarray(xn, dtype=np.float64))))


def forward(theta, xn, hidden: int, n_outputs: int = 1) -> np.ndarray:
    """Normalized net output ``yn`` (n,) for one output, (n, n_out) for several, at normalized inputs ``xn``
    (n, n_in).

    eq. (11), BP hill-chart paper (004): ``yn = sum_i W2_i f(W1_i . xn + b1_i) + b2`` with the log-sigmoid
    ``f(z) = 1 / (1 + exp(-z))`` of eq. (10).
    """
    theta, xn = _as_inputs(theta, xn)
    y, _ = _outputs(theta, xn, int(hidden), int(n_outputs), False)
    return y if n_outputs == 1 else y.reshape(xn.shape[0], n_outputs)


def residual_jacobian(theta, xn, hidden: int, n_outputs: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Net output ``yn`` and its analytic Jacobian ``d yn / d theta``: (n,) and (n, 4 H + 1) for 2-H-1; for
    ``n_outputs`` > 1 the output flattened row-major (n n_out,) and (n n_out, n_parameters).

    With ``f = sigmoid(z)``, ``z = W1 xn + b1`` and ``d_k = W2_k f (1 - f)`` for output k:
    ``dyn_k/dW1_ij = d_ki xn_j``, ``dyn_k/db1_i = d_ki``, ``dyn_k/dW2_ki = f_i``, ``dyn_k/db2_k = 1``.
    """
    theta, xn = _as_inputs(theta, xn)
    return _outputs(theta, xn, int(hidden), int(n_outputs), True)


def nguyen_widrow_init(hidden: int, rng: np.random.Generator, n_inputs: int = 2, n_outputs: int = 1) -> np.ndarray:
    """Initial parameter vector as MATLAB's ``initnw`` for a logsig layer on inputs in [-1, 1].

    Hidden layer: weight rows of random direction and norm ``0.7 H^(1/n_in)`` (``H^(1/2)`` for 2 inputs), biases
    spread evenly over ``[-0.7 H^(1/n_in), 0.7 H^(1/n_in)]`` with the sign of the first weight, then scaled by 4 to
    the logsig active input range [-4, 4]. Output layer (purelin, infinite active range): uniform in [-1, 1] as
    ``rands``. The defaults draw exactly the random numbers of the 2-H-1 net.

    Examples
    --------
    >>> theta = nguyen_widrow_init(5, np.random.default_rng(0))
    >>> theta.shape
    (21,)
    >>> w1 = theta[:10].reshape(5, 2)
    >>> np.allclose(np.linalg.norm(w1, axis=1), 4 * 0.7 * 5 ** 0.5)
    True
    """
    magw = 0.7 * hidden ** (1.0 / n_inputs)
    w = rng.uniform(-1.0, 1.0, size=(hidden, n_inputs))
    w = magw * w / np.linalg.norm(w, axis=1, keepdims=True)
    if hidden == 1:
        b = np.zeros(1)
    else:
        b = magw * np.linspace(-1.0, 1.0, hidden) * np.sign(w[:, 0])
    active_half_width = 4.0  # logsig active input range [-4, 4]
    w, b = active_half_width * w, active_half_width * b
    if n_outputs == 1:
        w2 = rng.uniform(-1.0, 1.0, size=hidden)
        b2 = [rng.uniform(-1.0, 1.0)]
    else:
        w2 = rng.uniform(-1.0, 1.0, size=(n_outputs, hidden)).ravel()
        b2 = rng.uniform(-1.0, 1.0, size=n_outputs)
    return np.concatenate([w.ravel(), b, w2, b2])


@dataclass(frozen=True)
class LMResult:
    """Outcome of one Levenberg-Marquardt run (all errors on normalized outputs, i.e. in [-1, 1] units).

    Attributes
    ----------
    theta : ndarray (4 H + 1,)
        Weights with the best validation error.
    train_mse, val_mse : float
        Mean squared errors at ``theta``.
    best_epoch : int
        Epoch at which ``theta`` was reached.
    epochs : int
        Epochs run.
    stop_reason : str
        ``"goal"``, ``"max_epochs"``, ``"validation"``, ``"mu_max"`` or ``"min_grad"``.
    """

    theta: np.ndarray
    train_mse: float
    val_mse: float
    best_epoch: int
    epochs: int
    stop_reason: str


#: Stop reasons by the training kernel's code.
_STOP_REASONS = ("goal", "max_epochs", "min_grad", "mu_max", "validation")
_NOT_FINITE = len(_STOP_REASONS)


@numba.njit(cache=True, nogil=True)
def _cholesky_solve(a, b, out):
    """Solve ``a x = b`` for a symmetric positive definite ``a`` (p x p, p <= a few dozen) into ``out``; False when
    ``a`` is not numerically positive definite (a failed LM step). Hand-written: inside the compiled loop, with a
    failure flag instead of the exception ``np.linalg.cholesky`` raises."""
    p = a.shape[0]
    low = np.zeros((p, p))
    for j in range(p):
        s = a[j, j]
        for m in range(j):
            s -= low[j, m] * low[j, m]
        if not s > 0.0:  # NaN too
            return False
        low[j, j] = math.sqrt(s)
        for i in range(j + 1, p):
            t = a[i, j]
            for m in range(j):
                t -= low[i, m] * low[j, m]
            low[i, j] = t / low[j, j]
    for i in range(p):  # L z = b
        t = b[i]
        for m in range(i):
            t -= low[i, m] * out[m]
        out[i] = t / low[i, i]
    for i in range(p - 1, -1, -1):  # L^T x = z
        t = out[i]
        for m in range(i + 1, p):
            t -= low[m, i] * out[m]
        out[i] = t / low[i, i]
    return True


@numba.njit(cache=True, nogil=True)
def _performance(theta, xn, yn, weights, hidden, n_outputs, regularization):
    """``mean(w e^2) + lambda mean(theta^2)`` at ``theta`` (``weights`` of every residual, 1 for ``trainlm``)."""
    y, _ = _outputs(theta, xn, hidden, n_outputs, False)
    total = 0.0
    for r in range(y.shape[0]):
        e = y[r] - yn[r]
        total += weights[r] * e * e
    perf = total / y.shape[0]
    if regularization != 0.0:
        perf += regularization * np.mean(theta * theta)
    return perf


@numba.njit(cache=True, nogil=True)
def _lm_kernel(xt, yt, xv, yv, theta0, weights, hidden, n_outputs, regularization, goal, max_epochs, max_fail, mu,
               mu_dec, mu_inc, mu_max, min_grad):
    """The loop of :func:`levenberg_marquardt`; returns ``(best_theta, best_val_mse, best_epoch, epochs, code,
    perf)`` with ``code`` an index into ``_STOP_REASONS`` or ``_NOT_FINITE`` (``perf`` then the offending MSE)."""
    theta = theta0.copy()
    n_par = theta.shape[0]
    m = yt.shape[0]
    ones = np.ones(yv.shape[0])
    decay = m * regularization / n_par  # the penalty in the sum form used by J^T J and J^T e
    best_theta = theta.copy()
    best_vperf = _performance(theta, xv, yv, ones, hidden, n_outputs, 0.0)
    best_epoch = 0
    val_fail = 0
    code = 1
    epoch = 0
    jtj = np.empty((n_par, n_par))
    jte = np.empty(n_par)
    system = np.empty((n_par, n_par))
    step = np.empty(n_par)
    rhs = np.empty(n_par)
    for epoch in range(max_epochs + 1):
        yn, jac = _outputs(theta, xt, hidden, n_outputs, True)
        total = 0.0
        jtj[:, :] = 0.0
        jte[:] = 0.0
        for r in range(m):
            e = yn[r] - yt[r]
            total += weights[r] * e * e
            for a in range(n_par):
                wa = weights[r] * jac[r, a]
                jte[a] += wa * e
                for b in range(a + 1):
                    jtj[a, b] += wa * jac[r, b]
        for a in range(n_par):
            for b in range(a):
                jtj[b, a] = jtj[a, b]
        perf = total / m
        if regularization != 0.0:
            perf += regularization * np.mean(theta * theta)
            for a in range(n_par):
                jte[a] += decay * theta[a]
                jtj[a, a] += decay
        if not np.isfinite(perf):
            return best_theta, best_vperf, best_epoch, epoch, _NOT_FINITE, perf
        gradient = 2.0 * math.sqrt(np.sum(jte * jte))
        # stopping tests in trainlm's order
        if perf <= goal:
            code = 0
            break
        if epoch == max_epochs:
            code = 1
            break
        if gradient <= min_grad:
            code = 2
            break
        if mu > mu_max:
            code = 3
            break
        if val_fail >= max_fail:
            code = 4
            break
        # damped Gauss-Newton step; raise mu until the training error decreases
        for a in range(n_par):
            rhs[a] = -jte[a]
        while mu <= mu_max:
            system[:, :] = jtj
            for a in range(n_par):
                system[a, a] += mu
            perf2 = math.inf
            if _cholesky_solve(system, rhs, step):  # a singular system counts as a failed step
                trial = theta + step
                perf2 = _performance(trial, xt, yt, weights, hidden, n_outputs, regularization)
            if perf2 < perf:  # NaN compares False: also a failed step
                theta = trial
                mu = max(mu * mu_dec, 1e-20)
                break
            mu *= mu_inc
        vperf = _performance(theta, xv, yv, ones, hidden, n_outputs, 0.0)
        if vperf < best_vperf:
            best_theta = theta.copy()
            best_vperf = vperf
            best_epoch = epoch + 1
            val_fail = 0
        elif vperf > best_vperf:
            val_fail += 1
    return best_theta, best_vperf, best_epoch, epoch, code, 0.0


def levenberg_marquardt(xn_train, yn_train, xn_val, yn_val, theta0, *, hidden: int, goal: float = 1e-5,
                        max_epochs: int = 1000, max_fail: int = 6, mu: float = 1e-3, mu_dec: float = 0.1,
                        mu_inc: float = 10.0, mu_max: float = 1e10, min_grad: float = 1e-15,
                        sample_weight=None, regularization: float = 0.0) -> LMResult:
    """Train one net by ``trainlm``'s Levenberg-Marquardt with validation early stopping.

    Parameters
    ----------
    xn_train : ndarray (n, 2) or (n, n_in)
        Normalized training inputs.
    yn_train : ndarray (n,) or (n, n_out)
        Normalized training targets; a 2-D array trains an n_in-H-n_out net (layout in the module docstring).
    xn_val, yn_val : ndarray (m, 2), (m,) or (m, n_in), (m, n_out)
        Normalized validation set (m >= 1).
    theta0 : ndarray (n_parameters(H, n_in, n_out),)
        Initial weights.
    hidden : int
        Hidden neurons H.
    goal, max_epochs, max_fail, mu, mu_dec, mu_inc, mu_max, min_grad
        As ``net.trainParam`` of ``trainlm``.
    sample_weight : ndarray (n,), optional
        Weights of the training residuals (weighted least squares: ``perf = mean(w e^2)``); None: all 1, the
        unweighted ``trainlm``. hillsim gives boundary samples a weight < 1 (soft constraints).
    regularization : float >= 0
        lambda of a weight-decay term: ``perf = mean(w e^2) + lambda mean(theta^2)`` (as MATLAB's ``msereg``
        mixes the MSE with the mean squared weights). 0: none.

    Returns
    -------
    LMResult

    Raises
    ------
    NumericalError
        When the residuals become NaN or infinite.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> x = rng.uniform(-1, 1, size=(60, 2)); y = 0.5 * np.tanh(x[:, 0] + 0.5 * x[:, 1])
    >>> res = levenberg_marquardt(x[:48], y[:48], x[48:], y[48:], nguyen_widrow_init(5, rng), hidden=5)
    >>> res.train_mse < 1e-5
    True
    """
    xt, yt, xv, yv = (np.ascontiguousarray(v, dtype=np.float64) for v in (xn_train, yn_train, xn_val, yn_val))
    n_out = 1 if yt.ndim == 1 else yt.shape[1]  # a 2-D target array: n_in-H-n_out net
    theta = np.array(theta0, dtype=np.float64).ravel()
    if sample_weight is None:
        weights = np.ones(yt.size)
    else:
        # a sample's weight holds for each of its outputs (row-major)
        weights = np.repeat(np.asarray(sample_weight, dtype=np.float64).ravel(), n_out)
    yt_flat, yv_flat = yt.ravel(), yv.ravel()
    best_theta, best_vperf, best_epoch, epochs, code, bad = _lm_kernel(
        xt, yt_flat, xv, yv_flat, theta, weights, int(hidden), int(n_out), float(regularization), float(goal),
        int(max_epochs), int(max_fail), float(mu), float(mu_dec), float(mu_inc), float(mu_max), float(min_grad))
    if code == _NOT_FINITE:
        raise NumericalError(f"Levenberg-Marquardt: training MSE is {bad} at epoch {epochs}")
    # trainlm returns the weights with the best validation performance, whatever stopped it
    train_mse = float(_performance(best_theta, xt, yt_flat, weights, int(hidden), int(n_out), float(regularization)))
    return LMResult(theta=best_theta, train_mse=train_mse, val_mse=float(best_vperf),
                    best_epoch=int(best_epoch), epochs=int(epochs), stop_reason=_STOP_REASONS[code])


#: Most threads a training uses by default (:func:`threads`): beyond a few the runs are too short to share out.
MAX_DEFAULT_THREADS = 8


def threads(n_threads: int | None) -> int:
    """The threads a training runs its independent starts on: ``n_threads``, or with None the processors this
    process may run on (at most :data:`MAX_DEFAULT_THREADS`). The results do not depend on it."""
    if n_threads is not None:
        return int(n_threads)
    try:
        available = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        available = os.cpu_count() or 1
    return max(1, min(available, MAX_DEFAULT_THREADS))


def run_threads(jobs, n_threads: int | None = None) -> list:
    """The results of the callables ``jobs``, in order, run on :func:`threads` threads (the compiled loop releases
    the GIL); the same as running them one after the other when they are independent."""
    n = threads(n_threads)
    if n <= 1 or len(jobs) <= 1:
        return [job() for job in jobs]
    with ThreadPoolExecutor(max_workers=min(n, len(jobs))) as pool:
        return list(pool.map(lambda job: job(), jobs))


def levenberg_marquardt_many(xn_train, yn_train, xn_val, yn_val, thetas0, *, n_threads: int | None = 1,
                             **options) -> list[LMResult]:
    """:func:`levenberg_marquardt` from each start in ``thetas0`` (same data and options), in order. The compiled
    loop releases the GIL, so ``n_threads`` > 1 (None: :func:`threads`) runs the starts side by side; each result is
    the same as the sequential one (the starts are independent)."""
    def one(theta0):
        return lambda: levenberg_marquardt(xn_train, yn_train, xn_val, yn_val, theta0, **options)

    return run_threads([one(t) for t in thetas0], n_threads)
