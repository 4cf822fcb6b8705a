"""The residual of measured samples to their fitted physical model, carried into the region between them and the
boundaries (:func:`continued_residual`). The three-input nets of a double-regulated table learn the residual to the
bulb model (:func:`hillchart.fccm.double_regulated.train_table_nets`); at the model's samples there they learn this,
so that they are not pulled off the table where the model misses it."""

from __future__ import annotations

import numpy as np


#: Bounds of the length scales of :func:`continued_residual`, in units of the measured samples' span along each
#: input.
RESIDUAL_LENGTH_BOUNDS = (0.05, 0.5)


def continued_residual(x_measured, residual, x_silent) -> np.ndarray:
    """The measured samples' residual to the fitted model (measured minus model at the rows of ``x_measured``: the
    model's inputs, N11 r/min and opening, and the blade angle of a double-regulated table) carried to the rows of
    ``x_silent``: the posterior mean of a Gaussian process fitted to it (scikit-learn: a constant times an anisotropic
    squared-exponential kernel plus white noise, the hyperparameters by marginal likelihood from one start, so no
    random choice; three seeded restarts gave the rig's nets the same fit at 3.5 times the cost). It follows the
    residual's trend near the samples and fades to 0 (the model alone) a few length scales away; reading noise alone
    is absorbed by the white noise and carries nothing.

    Why not 0 at once: the samples between the measured ones and the boundaries are the model's, and where it misses
    the torque's slope by a quarter of the measured torque range (the real 137 kW bulb rig), a residual of 0 a grid
    step beyond the table's last unit speed forced the nets to turn back within it, and they missed the table itself
    (M11 5.6 % of its range RMS, worst 21 %; 1.8 % and 4.7 % with the residual carried). The length scales lie within
    :data:`RESIDUAL_LENGTH_BOUNDS` (times the samples' span): a trend is carried about one span and gone at two, and
    never beyond the largest residual measured (a linear trend grew 2.6 x within 1.5 spans unclipped). The inputs are
    scaled by the samples' span; one that does not vary (a fixed-blade table) is left out.
    """
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    x_measured, x_silent = np.asarray(x_measured, float), np.asarray(x_silent, float)
    residual = np.asarray(residual, float)
    span = np.ptp(x_measured, axis=0)
    varies = span > 0
    scale = float(np.sqrt(np.mean(residual ** 2))) if residual.size else 0.0
    if not varies.any() or scale == 0.0:
        return np.zeros(x_silent.shape[0])
    low = x_measured.min(axis=0)
    scaled = lambda v: (v[:, varies] - low[varies]) / span[varies]  # noqa: E731
    kernel = (ConstantKernel(1.0, (1e-4, 1e2)) * RBF(np.full(int(varies.sum()), 0.3), RESIDUAL_LENGTH_BOUNDS)
              + WhiteKernel(0.1, (1e-6, 1.0)))
    # the prior mean is 0 (the model), so far from the table the residual is 0; scaled by its RMS, not centred
    gp = GaussianProcessRegressor(kernel, normalize_y=False, n_restarts_optimizer=0)
    with warnings.catch_warnings():  # a length scale at its bound is the bound doing its work, not a failure
        warnings.simplefilter("ignore", ConvergenceWarning)
        gp.fit(scaled(x_measured), residual / scale)
    reach = float(np.max(np.abs(residual)))  # a trend is carried, never grown beyond what the table shows
    return np.clip(scale * gp.predict(scaled(x_silent)), -reach, reach)
