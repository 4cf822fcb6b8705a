"""Net machinery on analytic test functions: LM training, split, determinism, gradients, kernel, estimator contract.

Accuracy against the synthetic Francis truth is in tests/hillchart/nets/test_nets_accuracy.py; nets.json parsing in
tests/hillchart/nets/test_nets_json.py.
"""

import numpy as np
import pytest

from hillchart.nets import lm
from hillchart.characteristics import Characteristics, scalar_kernel
from hillchart.errors import InputError
from hillchart.nets.estimator import HillNet, stratified_split
from hillchart.nets.hill_nets import HillNets
from hillchart.nets.training import train_nets
from hillchart.nets.weights import NetWeights


def smooth_q11(n11, a):
    """A Q11-like analytic surface: rising with opening, falling with speed (m^3/s)."""
    return 0.55 * (a / 32.0) ** 1.2 * (1.0 - 0.25 * (n11 / 100.0) ** 2) + 0.02 * np.sin(n11 / 40.0)


def samples(n=400, seed=3):
    rng = np.random.default_rng(seed)
    X = np.column_stack([rng.uniform(0.0, 150.0, n), rng.uniform(0.0, 32.0, n)])
    groups = np.where(X[:, 1] < 4.0, "zero-opening", np.where(X[:, 0] < 15.0, "zero-speed", "measured"))
    return X, smooth_q11(X[:, 0], X[:, 1]), groups


@pytest.fixture(scope="module")
def fitted():
    X, y, groups = samples()
    return HillNet(restarts=2, seed=0).fit(X, y, groups), X, y, groups


def random_weights(hidden=5, seed=0, y_range=(0.0, 0.6)):
    rng = np.random.default_rng(seed)
    return NetWeights(x_min=[0.0, 0.0], x_max=[150.0, 32.0], y_min=y_range[0], y_max=y_range[1],
                      W1=rng.normal(0, 2, (hidden, 2)), b1=rng.normal(0, 1, hidden), W2=rng.normal(0, 1, hidden),
                      b2=float(rng.normal()))


# ---------------------------------------------------------------------------------------------------- LM core
def test_analytic_jacobian_matches_autograd(torch_autograd):
    """The compiled forward pass and Jacobian against torch autograd of an independent transcription."""
    torch, torch_forward = torch_autograd
    hidden = 5
    rng = np.random.default_rng(0)
    theta = lm.nguyen_widrow_init(hidden, rng)
    xn = rng.uniform(-1, 1, (30, 2))
    yn, jac = lm.residual_jacobian(theta, xn, hidden)
    theta_t, xn_t = torch.as_tensor(theta), torch.as_tensor(xn)
    auto = torch.func.jacrev(lambda th: torch_forward(th, xn_t, hidden))(theta_t)
    assert jac.shape == (30, 21)
    # same floating-point expressions up to ordering (and logsig's stable form): agreement to a few ulps
    np.testing.assert_allclose(jac, auto.numpy(), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(yn, torch_forward(theta_t, xn_t, hidden).numpy(), rtol=1e-13, atol=1e-15)
    np.testing.assert_array_equal(lm.forward(theta, xn, hidden), yn)  # one kernel behind both


def test_lm_reaches_the_goal_on_a_smooth_function():
    rng = np.random.default_rng(2)
    x = rng.uniform(-1, 1, (200, 2))
    y = 0.6 * np.tanh(1.5 * x[:, 0] - x[:, 1]) + 0.2 * x[:, 1] ** 2
    res = lm.levenberg_marquardt(x[:160], y[:160], x[160:], y[160:], lm.nguyen_widrow_init(5, rng), hidden=5)
    assert res.stop_reason == "goal"
    # goal is 1e-5 (trainlm's test: perf <= goal); validation error of the same smooth function stays
    # within a factor 10 of it (no overfitting with 21 parameters on 160 points)
    assert res.train_mse <= 1e-5
    assert res.val_mse < 1e-4
    assert res.epochs < 1000


def test_starts_on_threads_equal_the_sequential_starts():
    """The compiled loop releases the GIL: restarts on two threads give the same results, in order, bit for bit."""
    rng = np.random.default_rng(7)
    x = rng.uniform(-1, 1, (120, 2))
    y = np.sin(2 * x[:, 0]) * x[:, 1] + rng.normal(0, 0.01, 120)
    starts = [lm.nguyen_widrow_init(6, rng) for _ in range(4)]
    options = dict(hidden=6, sample_weight=np.linspace(0.2, 1.0, 96), regularization=1e-5)
    one = lm.levenberg_marquardt_many(x[:96], y[:96], x[96:], y[96:], starts, n_threads=1, **options)
    two = lm.levenberg_marquardt_many(x[:96], y[:96], x[96:], y[96:], starts, n_threads=2, **options)
    assert len({r.val_mse for r in one}) == 4  # four different starts, four different runs
    for a, b in zip(one, two):
        np.testing.assert_array_equal(a.theta, b.theta)
        assert (a.val_mse, a.epochs, a.stop_reason) == (b.val_mse, b.epochs, b.stop_reason)


def test_non_finite_training_error_is_raised():
    """A NaN target makes the training MSE NaN at epoch 0: a NumericalError naming it, not a silent result."""
    from hillchart.errors import NumericalError

    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, (20, 2))
    y = x[:, 0].copy()
    y[3] = np.nan
    with pytest.raises(NumericalError, match=r"training MSE is nan at epoch 0"):
        lm.levenberg_marquardt(x[:16], y[:16], x[16:], y[16:], lm.nguyen_widrow_init(3, rng), hidden=3)


def test_lm_validation_stop_returns_best_validation_weights():
    rng = np.random.default_rng(5)
    x = rng.uniform(-1, 1, (80, 2))
    y = np.sin(2 * x[:, 0]) + rng.normal(0, 0.3, 80)  # noisy: a 20-neuron net overfits, validation rises
    res = lm.levenberg_marquardt(x[:64], y[:64], x[64:], y[64:], lm.nguyen_widrow_init(20, rng), hidden=20,
                                 goal=0.0, max_fail=6)
    assert res.stop_reason == "validation"
    assert res.best_epoch == res.epochs - 6  # six consecutive failures after the best epoch
    err = lm.forward(res.theta, x[64:], 20) - y[64:]
    val = sum((e * e for e in err), 0.0) / err.size  # the kernel's summation order
    assert val == res.val_mse  # the returned weights are the best-validation ones, bit for bit


def test_nguyen_widrow_biases_spread_over_active_range():
    theta = lm.nguyen_widrow_init(5, np.random.default_rng(0))
    b1 = theta[10:15]
    # magnitudes 4 * 0.7 sqrt(5) * |linspace(-1, 1, 5)| exactly
    np.testing.assert_allclose(np.abs(b1), 4 * 0.7 * 5 ** 0.5 * np.abs(np.linspace(-1, 1, 5)), rtol=1e-15)


# ---------------------------------------------------------------------------------------------- split
def test_split_is_stratified_and_80_20():
    groups = np.array(["measured"] * 200 + ["runaway"] * 12 + ["zero-opening"] * 21 + ["zero-speed"] * 3)
    tr, va = stratified_split(groups, 0.2, np.random.default_rng(7))
    assert np.intersect1d(tr, va).size == 0 and tr.size + va.size == groups.size
    for label, n_val in (("measured", 40), ("runaway", 2), ("zero-opening", 4), ("zero-speed", 1)):
        # round(0.2 n) per family (3 -> 1, the clip keeps one in each part)
        assert np.sum(groups[va] == label) == n_val
        assert np.sum(groups[tr] == label) == np.sum(groups == label) - n_val


def test_split_rejects_singleton_family():
    with pytest.raises(InputError, match="runaway.*1 sample"):
        stratified_split(np.array(["measured"] * 10 + ["runaway"]), 0.2, np.random.default_rng(0))


def test_fit_uses_stratified_split(fitted):
    net, _, _, groups = fitted
    for label in np.unique(groups):
        assert np.any(groups[net.train_index_] == label) and np.any(groups[net.val_index_] == label)


# ---------------------------------------------------------------------------------------------- estimator
def test_fit_accuracy_on_unseen_grid(fitted):
    net = fitted[0]
    n11, a = np.meshgrid(np.linspace(5, 145, 40), np.linspace(1, 31, 40))
    X = np.column_stack([n11.ravel(), a.ravel()])
    err = net.predict(X) - smooth_q11(X[:, 0], X[:, 1])
    # goal MSE 1e-5 on [-1, 1] outputs is an RMS of 0.16 % of the range; allow 0.5 % RMS and 3 % max on a grid
    # the net never saw (interpolation between random samples)
    y_range = 0.55 * 1.2 ** 1.2
    assert np.sqrt(np.mean(err ** 2)) < 0.005 * y_range
    assert np.max(np.abs(err)) < 0.03 * y_range


def test_fit_is_deterministic_for_a_seed():
    X, y, groups = samples(200)
    a = HillNet(restarts=2, seed=11).fit(X, y, groups)
    b = HillNet(restarts=2, seed=11).fit(X, y, groups)
    c = HillNet(restarts=2, seed=12).fit(X, y, groups)
    assert a.weights_ == b.weights_  # bit-identical
    assert np.array_equal(a.val_index_, b.val_index_)
    assert not a.weights_ == c.weights_


def test_restarts_keep_best_validation(fitted):
    net = fitted[0]
    assert len(net.restart_val_mse_) == 2
    assert net.val_mse_ == min(net.restart_val_mse_)
    assert net.restart_val_mse_[net.best_restart_] == net.val_mse_


def test_predict_refuses_unfitted_net():
    with pytest.raises(InputError, match="not fitted"):
        HillNet().predict(np.zeros((3, 2)))


@pytest.mark.parametrize("param, value", [("hidden", 0), ("restarts", 0), ("max_fail", 0), ("mu_dec", 1.5),
                                          ("mu_inc", 0.5), ("validation_fraction", 1.0), ("goal", -1.0),
                                          ("hidden", 2.5), ("seed", -1)])
def test_fit_rejects_bad_hyperparameter(param, value):
    X, y, _ = samples(50)
    with pytest.raises(InputError, match=f"HillNet.{param} must be"):
        HillNet(**{param: value}).fit(X, y)


@pytest.mark.parametrize("case, match", [
    ("X_1d", r"X must have shape \(n, 2\)"), ("y_len", r"y must have shape"), ("nan", "X contains NaN"),
    ("y_inf", "y contains NaN or inf"), ("const_a", "column 1 \\(opening\\) is constant"),
    ("const_y", "y is constant"), ("few", ">= 10 samples"), ("groups_len", "groups must have shape")])
def test_fit_rejects_bad_data(case, match):
    X, y, groups = samples(50)
    kwargs = {}
    if case == "X_1d":
        X = X[:, 0]
    elif case == "y_len":
        y = y[:-1]
    elif case == "nan":
        X[3, 1] = np.nan
    elif case == "y_inf":
        y[0] = np.inf
    elif case == "const_a":
        X[:, 1] = 5.0
    elif case == "const_y":
        y = np.full_like(y, 0.3)
    elif case == "few":
        X, y = X[:9], y[:9]
    elif case == "groups_len":
        kwargs["groups"] = groups[:-2]
    with pytest.raises(InputError, match=match):
        HillNet(restarts=1).fit(X, y, **kwargs)


def test_get_set_params_roundtrip():
    net = HillNet(hidden=7, seed=3)
    assert net.get_params()["hidden"] == 7
    assert net.set_params(restarts=9).restarts == 9
    with pytest.raises(InputError, match="no parameter 'hiden'"):
        net.set_params(hiden=3)


def test_lm_net_not_worse_than_sklearn_mlp():
    """Tier-2 cross-check: same data, same 2-5-1 logistic architecture, scikit-learn's lbfgs."""
    from sklearn.neural_network import MLPRegressor
    X, y, groups = samples(300)
    net = HillNet(restarts=2, seed=0).fit(X, y, groups)
    xn = 2 * (X - X.min(0)) / np.ptp(X, 0) - 1
    tr, va = net.train_index_, net.val_index_
    mlp = MLPRegressor(hidden_layer_sizes=(5,), activation="logistic", solver="lbfgs", max_iter=2000, tol=1e-12,
                       random_state=0).fit(xn[tr], y[tr])
    ours = np.sqrt(np.mean((net.predict(X[va]) - y[va]) ** 2))
    theirs = np.sqrt(np.mean((mlp.predict(xn[va]) - y[va]) ** 2))
    # both minimize the same least squares; LM with restarts should land at least as low (20 % slack for
    # a different local minimum of an equally good quality)
    assert ours <= 1.2 * theirs, (ours, theirs)


# ---------------------------------------------------------------------------------------------- evaluation
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_gradient_matches_central_differences(seed):
    w = random_weights(seed=seed)
    rng = np.random.default_rng(seed)
    n11, a = rng.uniform(0, 150, 50), rng.uniform(0, 32, 50)
    _, d_n, d_a = w.evaluate(n11, a)
    h_n, h_a = 1e-3, 1e-4  # r/min, mm: truncation O(h^2) ~ 1e-10 relative, round-off eps*y/h ~ 1e-12
    fd_n = (w.evaluate(n11 + h_n, a)[0] - w.evaluate(n11 - h_n, a)[0]) / (2 * h_n)
    fd_a = (w.evaluate(n11, a + h_a)[0] - w.evaluate(n11, a - h_a)[0]) / (2 * h_a)
    # relative 1e-6 as promised, with an absolute floor of 1e-6 of the largest slope for zero crossings
    np.testing.assert_allclose(d_n, fd_n, rtol=1e-6, atol=1e-6 * np.max(np.abs(d_n)))
    np.testing.assert_allclose(d_a, fd_a, rtol=1e-6, atol=1e-6 * np.max(np.abs(d_a)))


def test_evaluation_matches_training_forward():
    """The evaluation kernel's eq. (11) and the training forward pass are the same function."""
    w = random_weights(seed=4)
    rng = np.random.default_rng(0)
    n11, a = rng.uniform(-20, 170, 100), rng.uniform(-3, 35, 100)  # also outside the input range
    theta = np.concatenate([np.asarray(w.W1).ravel(), w.b1, w.W2, [w.b2]])
    xn = np.column_stack([2 * n11 / 150 - 1, 2 * a / 32 - 1])
    yn = lm.forward(theta, xn, 5)
    expected = (yn + 1) * (w.y_max - w.y_min) / 2 + w.y_min
    np.testing.assert_allclose(w.evaluate(n11, a)[0], expected, rtol=1e-13, atol=1e-15)


def test_logsig_does_not_overflow_for_large_inputs():
    w = NetWeights(x_min=[0.0, 0.0], x_max=[1.0, 1.0], y_min=0.0, y_max=1.0, W1=[[1e4, 0.0]], b1=[0.0],
                   W2=[2.0], b2=-1.0)
    y, d_n, _ = w.evaluate(np.array([-1e3, 1e3]), np.array([0.5, 0.5]))
    np.testing.assert_array_equal(y, [0.0, 1.0])  # saturated logsig, exactly 0 and 1
    assert np.all(np.isfinite(d_n))


def test_hillnets_is_characteristics_and_kernel_agrees():
    nets = HillNets(flow=random_weights(seed=1), torque=random_weights(seed=2, y_range=(-300.0, 900.0)),
                    opening_unit="mm")
    assert isinstance(nets, Characteristics)
    n11 = np.array([[10.0, 70.0], [120.0, 3.0]])
    a = np.array([5.0, 25.0])  # broadcast against (2, 2)
    q = nets.q11(n11, a)
    assert q.shape == (2, 2)
    kernel, params, jitted = scalar_kernel(nets)
    assert jitted
    dq = nets.q11_grad(n11, a)
    m = nets.m11(n11, a)
    dm = nets.m11_grad(n11, a)
    for i in range(2):
        for j in range(2):
            got = kernel(params, n11[i, j], a[j])
            want = (q[i, j], dq[0][i, j], dq[1][i, j], m[i, j], dm[0][i, j], dm[1][i, j])
            assert got == pytest.approx(want, rel=0, abs=0)  # same compiled function: bit-identical


def test_train_nets_on_a_table():
    X, y, groups = samples(200)
    table = {"target": np.array(["q11"] * 200 + ["m11"] * 200),
             "origin": np.concatenate([groups, groups]),
             "n11": np.concatenate([X[:, 0], X[:, 0]]), "opening": np.concatenate([X[:, 1], X[:, 1]]),
             "value": np.concatenate([y, 900 * y - 100])}
    nets = train_nets(table, opening_unit="mm", restarts=1, seed=4)
    assert nets.training["flow"]["seed"] == 4 and nets.training["torque"]["seed"] == 5
    assert "time_s" not in nets.training["flow"]  # byte-reproducible record by default
    # validation (and the selection's cross-validation) runs on the measured samples; boundary samples all train
    assert nets.training["flow"]["samples_by_origin"]["zero-speed"]["validation"] == 0
    assert nets.training["flow"]["samples_by_origin"]["measured"]["validation"] >= 1
    # torque target is an affine map of the flow target: the torque net fits to the same relative accuracy
    rel = np.max(np.abs(nets.m11(X[:, 0], X[:, 1]) - (900 * y - 100))) / np.ptp(900 * y)
    assert rel < 0.02
    bad = dict(table, origin=np.array(["measured"] * 399 + ["guess"]))
    with pytest.raises(InputError, match="origin must be one of"):
        train_nets(bad, opening_unit="mm", restarts=1)
    with pytest.raises(InputError, match="column 'value' is missing"):
        train_nets({k: v for k, v in table.items() if k != "value"}, opening_unit="mm", restarts=1)
