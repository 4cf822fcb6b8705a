"""Side-by-side: our LM-trained 2-5-1 nets against the usual alternatives.

On the same extended samples of ``data_synthetic/francis`` and the same stratified 80/20 split:

* ``LM net (ours)``   : :class:`hillchart.nets.estimator.HillNet`, trainlm-style Levenberg-Marquardt, best of 10
                        restarts.
* ``MLP lbfgs``       : scikit-learn ``MLPRegressor`` (5 logistic neurons, lbfgs), best validation of 10 seeds.
* ``2-5-1 Adam``      : the same net trained by torch Adam (lr 1e-2, 3000 full-batch epochs), best of 3 seeds.
* ``RBF thin-plate``  : scipy ``RBFInterpolator`` (thin-plate spline) exact interpolant, the paper's RBF option.
* ``RBF smoothed``    : the same with the smoothing chosen on the validation set.
* ``linear interp.``  : scipy ``LinearNDInterpolator`` on the scattered samples (nearest value outside their hull):
  the "traditional" interpolation the paper replaces.

Columns: validation RMSE and max error (physical units), error against ``truth.csv`` inside and outside the
measured region (% of the truth's range inside it), training time, and derivative smoothness: the largest jump of
dQ11/dN11 (resp. dM11/dN11) between neighbouring points of a 201 x 201 grid over the nets' input domain (central
differences with the same step for every method). Smooth derivatives are what the pressure iteration needs.

Run::

    OMP_NUM_THREADS=1 PYTHONPATH=. python benchmarks/bench_net_baselines.py [--seed 0] [--plot errors.png]
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import torch  # noqa: E402

from tests.torch_reference import torch_forward  # noqa: E402  (the Adam baseline needs autograd)

from hillchart.nets import lm  # noqa: E402
from hillchart.extension.extend import extend_samples  # noqa: E402
from hillchart.nets.accuracy import read_truth_csv
from hillchart.nets.estimator import HillNet  # noqa: E402
from hillchart.io.samples import measured_region_mask
from hillchart.io.samples import load_chart  # noqa: E402

CHART = Path(__file__).resolve().parents[1] / "data_synthetic" / "francis"


class Scaled:
    """Wrap a regressor on mapminmax-normalized inputs/outputs as ``f(n11, a) -> y`` in physical units."""

    def __init__(self, predict_normalized, x_min, x_max, y_min, y_max):
        self.f, self.x_min, self.x_max, self.y_min, self.y_max = predict_normalized, x_min, x_max, y_min, y_max

    def __call__(self, n11, a):
        n11, a = np.broadcast_arrays(np.asarray(n11, float), np.asarray(a, float))
        x = np.column_stack([n11.ravel(), a.ravel()])
        xn = 2 * (x - self.x_min) / (self.x_max - self.x_min) - 1
        yn = np.asarray(self.f(xn), dtype=float)
        return ((yn + 1) * (self.y_max - self.y_min) / 2 + self.y_min).reshape(n11.shape)


def fit_methods(X, y, groups, seed):
    """Fit every method on one target; returns (split, {name: (predict(n11, a), seconds)})."""
    ours = HillNet(seed=seed)
    t = time.perf_counter()
    ours.fit(X, y, groups)
    methods = {"LM net (ours)": (lambda n, a: ours.predict(np.column_stack(np.broadcast_arrays(
        np.ravel(n), np.ravel(a)))).reshape(np.shape(n)), time.perf_counter() - t)}
    tr, va = ours.train_index_, ours.val_index_
    x_min, x_max = X.min(0), X.max(0)
    y_min, y_max = y.min(), y.max()
    xn = 2 * (X - x_min) / (x_max - x_min) - 1
    yn = 2 * (y - y_min) / (y_max - y_min) - 1

    def wrap(f):
        return Scaled(f, x_min, x_max, y_min, y_max)

    def val_mse(f):
        return float(np.mean((f(xn[va]) - yn[va]) ** 2))

    # scikit-learn MLP, lbfgs, same loop control
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPRegressor

    t = time.perf_counter()
    best = None
    for k in range(10):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            mlp = MLPRegressor(hidden_layer_sizes=(5,), activation="logistic", solver="lbfgs", max_iter=1000,
                               tol=1e-10, random_state=seed * 100 + k).fit(xn[tr], yn[tr])
        score = val_mse(mlp.predict)
        if best is None or score < best[0]:
            best = (score, mlp)
    methods["MLP lbfgs (sklearn)"] = (wrap(best[1].predict), time.perf_counter() - t)

    # the same 2-5-1 net trained by Adam
    t = time.perf_counter()
    torch.set_num_threads(1)
    rng = np.random.default_rng(seed)
    xt, yt = torch.as_tensor(xn[tr]), torch.as_tensor(yn[tr])
    xv, yv = torch.as_tensor(xn[va]), torch.as_tensor(yn[va])
    best = None
    for _ in range(3):
        theta = torch.tensor(lm.nguyen_widrow_init(5, rng), requires_grad=True)
        opt = torch.optim.Adam([theta], lr=1e-2)
        best_run = (np.inf, None)
        for epoch in range(3000):
            opt.zero_grad()
            loss = torch.mean((torch_forward(theta, xt, 5) - yt) ** 2)
            loss.backward()
            opt.step()
            if epoch % 25 == 0:
                with torch.no_grad():
                    v = float(torch.mean((torch_forward(theta, xv, 5) - yv) ** 2))
                if v < best_run[0]:
                    best_run = (v, theta.detach().clone())
        if best is None or best_run[0] < best[0]:
            best = best_run
    theta_adam = best[1]
    methods["2-5-1 Adam (torch)"] = (
        wrap(lambda z: lm.forward(theta_adam.numpy(), z, 5)), time.perf_counter() - t)

    # RBF (thin-plate spline), exact and smoothed
    from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator, RBFInterpolator

    t = time.perf_counter()
    rbf = RBFInterpolator(xn[tr], yn[tr], kernel="thin_plate_spline")
    methods["RBF thin-plate (scipy)"] = (wrap(rbf), time.perf_counter() - t)
    t = time.perf_counter()
    best = None
    for smoothing in (1e-4, 1e-3, 1e-2, 1e-1, 1.0):
        r = RBFInterpolator(xn[tr], yn[tr], kernel="thin_plate_spline", smoothing=smoothing)
        score = val_mse(r)
        if best is None or score < best[0]:
            best = (score, r, smoothing)
    methods[f"RBF smoothed, s={best[2]:g}"] = (wrap(best[1]), time.perf_counter() - t)

    # linear interpolation of the scattered samples, nearest value outside their convex hull
    t = time.perf_counter()
    lin = LinearNDInterpolator(xn[tr], yn[tr])
    near = NearestNDInterpolator(xn[tr], yn[tr])

    def linear(z):
        v = lin(z)
        return np.where(np.isnan(v), near(z), v)

    methods["linear interp. (scipy)"] = (wrap(linear), time.perf_counter() - t)
    return (tr, va), methods


def derivative_jump(f, n_range, a_range, grid=201):
    """Largest jump of df/dN11 between neighbouring points of a grid (central differences, step 1e-3 of the grid
    spacing... i.e. 1e-5 of the N11 range)."""
    n11 = np.linspace(*n_range, grid)
    a = np.linspace(*a_range, grid)
    N, A = np.meshgrid(n11, a)
    h = 1e-5 * (n_range[1] - n_range[0])
    d = (f(N + h, A) - f(N - h, A)) / (2 * h)
    return float(max(np.max(np.abs(np.diff(d, axis=0))), np.max(np.abs(np.diff(d, axis=1)))))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plot", default=None, help="PNG of the LM nets' error maps against truth.csv")
    args = parser.parse_args(argv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        chart = load_chart(CHART)
    ext = extend_samples(chart)
    truth = read_truth_csv(CHART / "truth.csv")
    inside = measured_region_mask(chart.flow_n11, chart.flow_opening, truth["n11"], truth["opening"])
    print(f"data_synthetic/francis: {ext.value.size} extended samples; truth: {inside.sum()} points in the measured "
          f"region, {(~inside).sum()} outside; seed {args.seed}; torch threads 1\n")
    total_ours = 0.0
    fitted = {}
    for key, target, unit in (("flow", "q11", "m^3/s"), ("torque", "m11", "N*m")):
        X, y, groups = ext.select(target)
        (tr, va), methods = fit_methods(X, y, groups, seed=args.seed + (key == "torque"))
        fitted[target] = methods["LM net (ours)"][0]
        total_ours += methods["LM net (ours)"][1]
        scale = float(np.ptp(truth[target][inside]))
        print(f"### {target.upper()} net ({unit}); truth errors in % of the measured-region range {scale:.4g} {unit}")
        print(f"{len(tr)} training / {len(va)} validation samples\n")
        print(f"| method | val RMSE | val max | truth RMS in | truth max in | truth RMS out | truth max out | "
              f"train s | max jump d{target.upper()}/dN11 |")
        print("|---|---|---|---|---|---|---|---|---|")
        n_range = (float(X[:, 0].min()), float(X[:, 0].max()))
        a_range = (float(X[:, 1].min()), float(X[:, 1].max()))
        for name, (f, seconds) in methods.items():
            e_val = f(X[va, 0], X[va, 1]) - y[va]
            e_truth = f(truth["n11"], truth["opening"]) - truth[target]
            jump = derivative_jump(f, n_range, a_range)
            print(f"| {name} | {np.sqrt(np.mean(e_val ** 2)):.3g} | {np.max(np.abs(e_val)):.3g} | "
                  f"{100 * np.sqrt(np.mean(e_truth[inside] ** 2)) / scale:.2f} % | "
                  f"{100 * np.max(np.abs(e_truth[inside])) / scale:.2f} % | "
                  f"{100 * np.sqrt(np.mean(e_truth[~inside] ** 2)) / scale:.2f} % | "
                  f"{100 * np.max(np.abs(e_truth[~inside])) / scale:.1f} % | {seconds:.2f} | {jump:.3g} |")
        print()
    print(f"training time of both default LM nets (10 restarts each, 1 thread): {total_ours:.2f} s")
    if args.plot:
        from hillchart.nets.chartplot import plot_truth_errors
        from hillchart.nets.hill_nets import HillNets  # noqa: F401  (for the reader: the same evaluation

        class Pair:
            def q11(self, n, a):
                return fitted["q11"](n, a)

            def m11(self, n, a):
                return fitted["m11"](n, a)

        axes = plot_truth_errors(Pair(), truth, inside, opening_unit=chart.info.opening_unit)
        axes[0].figure.tight_layout()
        axes[0].figure.savefig(args.plot, dpi=100)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
