"""The multi-output BP net of paper 003 (hillchart.fccm.net.FCCMNet), the generalized LM code and fccm_nets.json."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hillchart.nets import lm
from hillchart.errors import InputError
from hillchart.fccm.net import FCCMNet, FCCMWeights, hidden_size, load_fccm_nets, split_indices

REPO = Path(__file__).resolve().parents[3]


def smooth_data(n=150, seed=0):
    rng = np.random.default_rng(seed)
    X = np.column_stack([rng.uniform(-18, 16, n), rng.uniform(40, 78, n)])
    a, b = (X[:, 0] + 1) / 17, (X[:, 1] - 59) / 19
    Y = np.column_stack([0.9 - 0.1 * (a - 0.2 * b) ** 2 - 0.05 * b ** 2, 12 - 2 * a * (1 + 0.3 * b),
                         5000 + 3000 * a + 800 * b,
                         60 + 40 * a + 15 * b + 5 * a * b])
    return X, Y


def test_multi_output_jacobian_matches_autograd(torch_autograd):
    torch, torch_forward = torch_autograd
    rng = np.random.default_rng(0)
    h, n_in, n_out = 6, 3, 4
    theta = lm.nguyen_widrow_init(h, rng, n_in, n_out)
    xn = rng.uniform(-1, 1, (9, n_in))
    yn, jac = lm.residual_jacobian(theta, xn, h, n_out)
    theta_t, xn_t = torch.as_tensor(theta), torch.as_tensor(xn)
    auto = torch.func.jacrev(lambda t: torch_forward(t, xn_t, h, n_out))(theta_t)
    assert theta.size == lm.n_parameters(h, n_in, n_out) == 6 * (3 + 1 + 4) + 4
    np.testing.assert_array_equal(yn, lm.forward(theta, xn, h, n_out).reshape(-1))  # one kernel behind both
    np.testing.assert_allclose(yn, torch_forward(theta_t, xn_t, h, n_out).numpy(), rtol=0, atol=1e-15)
    np.testing.assert_allclose(jac, auto.numpy(), rtol=0, atol=1e-12)  # analytic = autograd to rounding


def test_two_input_one_output_layout_and_draws_are_unchanged():
    """The generalization must not change the hill-chart nets: same parameter layout, same random draws."""
    h = 5
    theta = np.arange(lm.n_parameters(h), dtype=float)
    w1, b1, w2, b2 = lm.unpack(theta, h)
    assert lm.n_parameters(h) == 21
    np.testing.assert_array_equal(w1, theta[:10].reshape(5, 2))
    np.testing.assert_array_equal(b1, theta[10:15])
    np.testing.assert_array_equal(w2, theta[15:20])
    assert b2 == theta[20]
    # the 2-H-1 initialisation draws exactly what the original code drew
    rng_old, rng_new = np.random.default_rng(7), np.random.default_rng(7)
    magw = 0.7 * h ** 0.5
    w = rng_old.uniform(-1, 1, size=(h, 2))
    w = magw * w / np.linalg.norm(w, axis=1, keepdims=True)
    b = magw * np.linspace(-1, 1, h) * np.sign(w[:, 0])
    old = np.concatenate([(4 * w).ravel(), 4 * b, rng_old.uniform(-1, 1, size=h), [rng_old.uniform(-1, 1)]])
    np.testing.assert_array_equal(lm.nguyen_widrow_init(h, rng_new), old)


def test_hidden_size_rule_and_split():
    assert [hidden_size(2, 4, c) for c in range(1, 11)] == list(range(3, 13))  # eq. (3): sqrt(6) + C, rounded
    tr, va, te = split_indices(150, (0.30, 0.35, 0.35), np.random.default_rng(0))
    assert (len(tr), len(va), len(te)) == (45, 52, 53)
    assert np.array_equal(np.sort(np.concatenate([tr, va, te])), np.arange(150))
    with pytest.raises(InputError, match="cannot be split"):
        split_indices(5, (0.6, 0.35, 0.05), np.random.default_rng(0))


@pytest.fixture(scope="module")
def fitted():
    X, Y = smooth_data()
    net = FCCMNet(seed=0, restarts=2, c_values=(2, 4, 6, 8)).fit(
        X, Y, input_names=["blade_angle_deg", "guide_vane_deg"],
        output_names=["efficiency", "head_m", "power_kw", "flow_m3_s"])
    return X, Y, net


def test_fit_chooses_c_by_validation_and_is_accurate(fitted):
    X, Y, net = fitted
    sel = net.selection_
    assert [s["hidden"] for s in sel] == [4, 6, 8, 10]
    best = min(sel, key=lambda s: s["validation_mse"])
    assert net.hidden_ == best["hidden"] and net.c_ == best["c"]
    # smooth noise-free target: test RMS below 1 % of each output's range (a 2-H-4 logsig net represents it well)
    err = net.predict(X[net.test_index_]) - Y[net.test_index_]
    assert np.all(np.sqrt(np.mean(err ** 2, axis=0)) < 0.01 * np.ptp(Y, axis=0))
    rec = net.weights_.training
    assert rec["n_train"] == 45 and rec["c"] == net.c_ and rec["hidden_rule"].startswith("eq. (3)")


def test_fit_is_reproducible(fitted):
    X, Y, net = fitted
    again = FCCMNet(seed=0, restarts=2, c_values=(2, 4, 6, 8)).fit(X, Y, input_names=net.weights_.inputs,
                                                                   output_names=net.weights_.outputs)
    assert again.weights_ == net.weights_ and again.weights_.to_json() == net.weights_.to_json()


def test_not_worse_than_sklearn_mlp_on_the_same_split(fitted):
    """Cross-check: scikit-learn's MLPRegressor (lbfgs, same hidden size, logistic) on the same training points;
    our LM net's test error must be at most 1.5 x its (both see the same 45 points)."""
    from sklearn.neural_network import MLPRegressor

    X, Y, net = fitted
    lo, hi = X.min(0), X.max(0)
    ylo, yhi = Y.min(0), Y.max(0)
    xn = 2 * (X - lo) / (hi - lo) - 1
    yn = 2 * (Y - ylo) / (yhi - ylo) - 1
    best = np.inf
    for seed in range(3):
        mlp = MLPRegressor(hidden_layer_sizes=(net.hidden_,), activation="logistic", solver="lbfgs", max_iter=5000,
                           alpha=0.0, random_state=seed).fit(xn[net.train_index_], yn[net.train_index_])
        best = min(best, float(np.mean((mlp.predict(xn[net.test_index_]) - yn[net.test_index_]) ** 2)))
    assert net.test_mse_ <= 1.5 * best


def test_json_round_trip_and_the_documented_formula(fitted, tmp_path):
    X, _, net = fitted
    path = net.weights_.save(tmp_path / "fccm_nets.json")
    back = load_fccm_nets(path)
    assert back == net.weights_ and back.to_json() == path.read_text()
    np.testing.assert_array_equal(back.predict(X), net.predict(X))
    doc = json.loads(path.read_text())
    assert list(doc)[:12] == ["format", "version", "inputs", "outputs", "x_min", "x_max", "y_min", "y_max", "W1",
                              "b1", "W2", "b2"]
    assert doc["format"] == "hillsim.fccm" and doc["version"] == 1
    assert len(doc["W1"]) == net.hidden_ and len(doc["W1"][0]) == 2 and len(doc["W2"]) == 4
    # the net's formula (normalize, tanh hidden layer, linear output), written out independently of the package
    x = X[:7]
    xn = 2 * (x - doc["x_min"]) / (np.array(doc["x_max"]) - doc["x_min"]) - 1
    h = 1 / (1 + np.exp(-(xn @ np.array(doc["W1"]).T + doc["b1"])))
    yn = h @ np.array(doc["W2"]).T + doc["b2"]
    y = (yn + 1) * (np.array(doc["y_max"]) - doc["y_min"]) / 2 + doc["y_min"]
    np.testing.assert_allclose(y, net.predict(x), rtol=1e-13)


def test_evaluating_a_saved_net_does_not_import_torch(fitted, tmp_path):
    path = fitted[2].weights_.save(tmp_path / "fccm_nets.json")
    code = ("import sys; from hillchart.fccm.net import load_fccm_nets; w = load_fccm_nets(sys.argv[1]); "
            "w.predict([[0.0, 50.0]]); w.predict_columns(blade_angle_deg=0.0, guide_vane_deg=50.0); "
            "assert 'torch' not in sys.modules, 'torch was imported'")
    done = subprocess.run([sys.executable, "-c", code, str(path)], cwd=REPO, capture_output=True, text=True,
                          env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr


def make_doc():
    w = FCCMWeights(inputs=["a", "b"], outputs=["y", "z"], x_min=[0, 0], x_max=[1, 2], y_min=[0, -1], y_max=[1, 1],
                    W1=[[1.0, 2.0], [0.5, -1.0], [0.1, 0.2]], b1=[0.0, 0.1, 0.2], W2=[[1.0, 2.0, 3.0], [0.0, 1.0, 0.5]],
                    b2=[0.1, 0.2])
    return w.to_dict()


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.update(format="hillsim.nets"), "format must be 'hillsim.fccm'"),
    (lambda d: d.update(version=2), "version must be 1, got 2"),
    (lambda d: d.update(version=True), "version must be 1, got True"),
    (lambda d: d.pop("W2"), "key 'W2' is missing"),
    (lambda d: d.update(inputs="a"), "inputs must be a non-empty list"),
    (lambda d: d.update(inputs=["a", "a"]), "inputs must be distinct"),
    (lambda d: d.update(outputs=[]), "outputs must be a non-empty list"),
    (lambda d: d.update(x_min=[0]), r"x_min must have 2 entries, got 1"),
    (lambda d: d.update(x_max=[1, 0]), r"x_max\[1\] \(b\) must be > x_min\[1\]"),
    (lambda d: d.update(y_max=[1, -1]), r"y_max\[1\] \(z\) must be > y_min\[1\]"),
    (lambda d: d["W1"][1].append(3.0), r"W1\[1\] must have 2 entries, got 3"),
    (lambda d: d.update(W1=[]), "W1 must be a non-empty list of rows"),
    (lambda d: d.update(b1=[0.0, 0.1]), "b1 must have 3 entries, got 2"),
    (lambda d: d.update(W2=[[1.0, 2.0, 3.0]]), "W2 must have 2 rows, got 1"),
    (lambda d: d["W2"][0].pop(), r"W2\[0\] must have 3 entries, got 2"),
    (lambda d: d.update(b2=[0.1]), "b2 must have 2 entries, got 1"),
    (lambda d: d.update(b2=0.1), "b2 must be a list of numbers"),
    (lambda d: d["W1"][0].__setitem__(0, "x"), r"W1\[0\]\[0\] must be a number, got 'x'"),
    (lambda d: d["W1"][0].__setitem__(0, True), r"W1\[0\]\[0\] must be a number, got True"),
    (lambda d: d.update(training=[1]), "training must be an object"),
])
def test_malformed_files_are_rejected(tmp_path, edit, message):
    doc = make_doc()
    edit(doc)
    path = tmp_path / "fccm_nets.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=message) as info:
        load_fccm_nets(path)
    assert str(path) in str(info.value)  # the file is named


@pytest.mark.parametrize("text, message", [
    ("{", "not valid JSON"),
    ("[]", "must hold an object"),
    (json.dumps(make_doc()).replace("[0.1, 0.2]", "[NaN, 0.2]"), r"W1\[2\]\[0\] must be finite, got nan"),
    (json.dumps(make_doc()).replace("[0.1, 0.2]", "[1e999, 0.2]"), r"W1\[2\]\[0\] must be finite, got inf"),
    (json.dumps(make_doc()).replace("[0.1, 0.2]", "[Infinity, 0.2]"), r"W1\[2\]\[0\] must be finite"),
])
def test_malformed_text_is_rejected(tmp_path, text, message):
    path = tmp_path / "fccm_nets.json"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        load_fccm_nets(path)


def test_extra_keys_and_missing_training_are_allowed(tmp_path):
    doc = make_doc()
    doc["comment"] = "by hand"
    del doc["training"]
    path = tmp_path / "n.json"
    path.write_text(json.dumps(doc))
    assert load_fccm_nets(path).training == {}


@pytest.mark.parametrize("params, message", [
    ({"hidden": 0}, "hidden must be None or an integer >= 1"),
    ({"restarts": 0}, "restarts must be an integer >= 1"),
    ({"seed": -1}, "seed must be an integer >= 0"),
    ({"c_values": (0, 3)}, "c_values must be a non-empty list of integers in 1..10"),
    ({"c_values": (11,)}, "c_values must be a non-empty list of integers in 1..10"),
    ({"split": (0.3, 0.3, 0.3)}, "split must be three fractions in \\(0, 1\\) summing to 1"),
    ({"split": (0.5, 0.5)}, "split must be three fractions"),
    ({"mu_dec": 2.0}, "mu_dec must be in \\(0, 1\\)"),
    ({"goal": float("nan")}, "goal must be a finite number >= 0"),
])
def test_bad_hyperparameters(params, message):
    X, Y = smooth_data(30)
    with pytest.raises(InputError, match=message):
        FCCMNet(**params).fit(X, Y)


def test_bad_data():
    X, Y = smooth_data(30)
    with pytest.raises(InputError, match="not fitted"):
        FCCMNet().predict(X)
    with pytest.raises(InputError, match="has no parameter 'hiden'"):
        FCCMNet().set_params(hiden=3)
    bad = Y.copy()
    bad[4, 2] = np.nan
    with pytest.raises(InputError, match="Y: sample 4, column 'y2' is nan"):
        FCCMNet(hidden=2, restarts=1).fit(X, bad)
    const = X.copy()
    const[:, 1] = 50.0
    with pytest.raises(InputError, match="column 'x1' is constant"):
        FCCMNet(hidden=2, restarts=1).fit(const, Y)
    with pytest.raises(InputError, match=">= 10 samples"):
        FCCMNet(hidden=2, restarts=1).fit(X[:8], Y[:8])
    with pytest.raises(InputError, match="Y must have shape"):
        FCCMNet(hidden=2, restarts=1).fit(X, Y[:20])
    with pytest.raises(InputError, match="input_names / output_names"):
        FCCMNet(hidden=2, restarts=1).fit(X, Y, input_names=["a"])
