"""Levenberg-Marquardt training of a 2-H-1 logsig/purelin net, as MATLAB's ``trainlm`` does it.

The BP hill-chart paper (004, section 2.4) trains its nets with ``newff(minmax(p), [5 1], {'logsig' 'purelin'})``
and ``train``; the default training function of ``newff`` is ``trainlm``. This module reproduces that algorithm in
torch (float64):

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
set or per-epoch control); the algorithm is the published one and is short.

Parameter vector layout (``theta``, length ``4 H + 1``)::

    theta = [W1 (H x 2, row-major: w_n11, w_opening per neuron), b1 (H), W2 (H), b2]

General n_in-H-n_out nets (paper 003's full-characteristic net, :mod:`hillchart.fccm`) use the same functions with
``n_inputs`` / ``n_outputs`` (defaults 2 and 1 give the layout above unchanged)::

    theta = [W1 (H x n_in, row-major), b1 (H), W2 (n_out x H, row-major), b2 (n_out)]   length H (n_in + 1 + n_out) + n_out

with targets of shape (n, n_out); the residual vector is the (n, n_out) error array flattened row-major and the
performance is its mean square (``trainlm``'s ``mse`` over all outputs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hillchart.errors import NumericalError

# torch is imported inside the training functions: evaluating exported nets (hillchart.nets) never needs it.
if TYPE_CHECKING:  # pragma: no cover - annotations only
    import torch


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


def forward(theta: torch.Tensor, xn: torch.Tensor, hidden: int, n_outputs: int = 1) -> torch.Tensor:
    """Normalized net output ``yn`` (n,) for one output, (n, n_out) for several, at normalized inputs ``xn``
    (n, n_in).

    eq. (11), BP hill-chart paper (004): ``yn = sum_i W2_i f(W1_i . xn + b1_i) + b2`` with the log-sigmoid
    ``f(z) = 1 / (1 + exp(-z))`` of eq. (10).
    """
    import torch

    w1, b1, w2, b2 = unpack(theta, hidden, xn.shape[1], n_outputs)
    return torch.sigmoid(xn @ w1.T + b1) @ (w2 if n_outputs == 1 else w2.T) + b2  # eqs. (10)-(11), paper 004


def residual_jacobian(theta: torch.Tensor, xn: torch.Tensor, hidden: int,
                      n_outputs: int = 1) -> tuple[torch.Tensor, torch.Tensor]:
    """Net output ``yn`` and its analytic Jacobian ``d yn / d theta``: (n,) and (n, 4 H + 1) for 2-H-1; for
    ``n_outputs`` > 1 the output flattened row-major (n n_out,) and (n n_out, n_parameters).

    With ``f = sigmoid(z)``, ``z = W1 xn + b1`` and ``d_k = W2_k f (1 - f)`` for output k:
    ``dyn_k/dW1_ij = d_ki xn_j``, ``dyn_k/db1_i = d_ki``, ``dyn_k/dW2_ki = f_i``, ``dyn_k/db2_k = 1``.
    """
    import torch

    n_in = xn.shape[1]
    w1, b1, w2, b2 = unpack(theta, hidden, n_in, n_outputs)
    f = torch.sigmoid(xn @ w1.T + b1)
    n, h, k = xn.shape[0], hidden, n_in * hidden
    if n_outputs == 1:
        yn = f @ w2 + b2
        d = f * (1.0 - f) * w2
        jac = torch.empty((n, n_parameters(hidden, n_in)), dtype=theta.dtype)
        jac[:, :k] = (d[:, :, None] * xn[:, None, :]).reshape(n, k)
        jac[:, k: k + h] = d
        jac[:, k + h: k + 2 * h] = f
        jac[:, k + 2 * h] = 1.0
        return yn, jac
    yn = f @ w2.T + b2  # (n, n_out)
    d = (f * (1.0 - f))[:, None, :] * w2[None, :, :]  # (n, n_out, H)
    jac = torch.zeros((n, n_outputs, n_parameters(hidden, n_in, n_outputs)), dtype=theta.dtype)
    jac[:, :, :k] = (d[:, :, :, None] * xn[:, None, None, :]).reshape(n, n_outputs, k)
    jac[:, :, k: k + h] = d
    for o in range(n_outputs):
        jac[:, o, k + h + o * h: k + h + (o + 1) * h] = f
        jac[:, o, k + h + n_outputs * h + o] = 1.0
    return yn.reshape(-1), jac.reshape(n * n_outputs, -1)


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
        unweighted ``trainlm``. hillsim gives boundary samples a weight < 1 (soft constraints, issue 9).
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
    import torch

    dtype = torch.float64
    xt = torch.as_tensor(np.asarray(xn_train, dtype=float), dtype=dtype)
    yt = torch.as_tensor(np.asarray(yn_train, dtype=float), dtype=dtype)
    xv = torch.as_tensor(np.asarray(xn_val, dtype=float), dtype=dtype)
    yv = torch.as_tensor(np.asarray(yn_val, dtype=float), dtype=dtype)
    theta = torch.as_tensor(np.array(theta0, dtype=float), dtype=dtype)
    eye = torch.eye(theta.shape[0], dtype=dtype)
    n_out = 1 if yt.ndim == 1 else yt.shape[1]  # a 2-D target array: n_in-H-n_out net
    yt_flat = yt.reshape(-1)
    n_par = theta.shape[0]
    weights = None if sample_weight is None else torch.as_tensor(np.asarray(sample_weight, dtype=float), dtype=dtype)
    if weights is not None and n_out > 1:
        weights = weights.repeat_interleave(n_out)  # a sample's weight holds for each of its outputs (row-major)
    decay = yt_flat.shape[0] * float(regularization) / n_par  # the penalty in the sum form used by J^T J and J^T e

    def train_perf(th, err):
        sq = err * err if weights is None else weights * err * err
        perf_ = torch.mean(sq)
        if decay:
            perf_ = perf_ + float(regularization) * torch.mean(th * th)
        return float(perf_)

    def val_mse(th):
        return float(torch.mean((forward(th, xv, hidden, n_out) - yv) ** 2))

    best_theta, best_vperf, best_epoch = theta.clone(), val_mse(theta), 0
    val_fail = 0
    stop_reason = "max_epochs"
    epoch = 0
    for epoch in range(max_epochs + 1):
        yn, jac = residual_jacobian(theta, xt, hidden, n_out)
        err = yn - yt_flat
        perf = train_perf(theta, err)
        if not np.isfinite(perf):
            raise NumericalError(f"Levenberg-Marquardt: training MSE is {perf} at epoch {epoch}")
        wjac = jac if weights is None else weights[:, None] * jac
        jte = wjac.T @ err
        jtj = wjac.T @ jac
        if decay:
            jte = jte + decay * theta
            jtj = jtj + decay * eye
        gradient = 2.0 * float(torch.linalg.vector_norm(jte))
        # stopping tests in trainlm's order
        if perf <= goal:
            stop_reason = "goal"
            break
        if epoch == max_epochs:
            stop_reason = "max_epochs"
            break
        if gradient <= min_grad:
            stop_reason = "min_grad"
            break
        if mu > mu_max:
            stop_reason = "mu_max"
            break
        if val_fail >= max_fail:
            stop_reason = "validation"
            break
        # damped Gauss-Newton step; raise mu until the training error decreases
        while mu <= mu_max:
            step, info = torch.linalg.solve_ex(jtj + mu * eye, -jte)
            if int(info) == 0:  # a singular system (saturated neurons, tiny mu) counts as a failed step
                trial = theta + step
                perf2 = train_perf(trial, (forward(trial, xt, hidden, n_out) - yt).reshape(-1))
            else:
                perf2 = math.inf
            if perf2 < perf:  # NaN compares False: also a failed step
                theta = trial
                mu = max(mu * mu_dec, 1e-20)
                break
            mu *= mu_inc
        vperf = val_mse(theta)
        if vperf < best_vperf:
            best_theta, best_vperf, best_epoch = theta.clone(), vperf, epoch + 1
            val_fail = 0
        elif vperf > best_vperf:
            val_fail += 1
    # trainlm returns the weights with the best validation performance, whatever stopped it
    train_mse = train_perf(best_theta, (forward(best_theta, xt, hidden, n_out) - yt).reshape(-1))
    return LMResult(theta=best_theta.numpy().copy(), train_mse=train_mse, val_mse=best_vperf,
                    best_epoch=best_epoch, epochs=epoch, stop_reason=stop_reason)
