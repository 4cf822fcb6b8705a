"""Figures of the full characteristic curve map: efficiency maps, control maps (Fig. 7), the operating characteristic
(Fig. 8)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hillchart.errors import InputError
from hillchart.fccm.maps import EfficiencyMaps, _net_grid
from hillchart.fccm.net import FCCMWeights
from hillchart.fccm.table import TestTable


# ----------------------------------------------------------------------------------------------------------------
# figures (matplotlib imported here only)
# ----------------------------------------------------------------------------------------------------------------
def _figure(nrows, ncols, size):
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt, plt.subplots(nrows, ncols, figsize=size, squeeze=False)


def plot_efficiency_maps(maps: EfficiencyMaps, grey_a, grey_b, similarity: dict, path) -> Path:
    """Figs. 4-6 of paper 003 in one PNG: efficiency over (Q11, n11) from interpolation and from the net (same
    colour scale), the grey-level difference image, and the two 25-bin grey histograms."""
    plt, (fig, ax) = _figure(2, 2, (12, 9.5))
    both = np.concatenate([maps.interpolated[maps.mask], maps.net[maps.mask]])
    lo, hi = float(both.min()), float(both.max())
    levels = np.linspace(lo, hi, 21)
    extent = (maps.q11[0], maps.q11[-1], maps.n11[0], maps.n11[-1])
    for a, data, title in ((ax[0, 0], maps.interpolated, "(a) linear interpolation of the test points"),
                           (ax[0, 1], maps.net, "(b) neural network")):
        cs = a.contourf(maps.q11, maps.n11, np.where(maps.mask, data, np.nan), levels=levels, cmap="viridis")
        a.contour(maps.q11, maps.n11, np.where(maps.mask, data, np.nan), levels=levels[::2], colors="k",
                  linewidths=0.4)
        a.plot(maps.points_q11, maps.points_n11, "r.", ms=3, label="test points")
        a.set(xlabel="Q11 (m^3/s)", ylabel="n11 (r/min)", title=title, xlim=extent[:2], ylim=extent[2:])
        fig.colorbar(cs, ax=a, label="efficiency")
    ax[0, 0].legend(loc="upper right", fontsize=8)
    diff = np.abs(grey_a.astype(float) - grey_b.astype(float))
    im = ax[1, 0].imshow(np.where(maps.mask, diff, np.nan), origin="lower", extent=extent, aspect="auto",
                         cmap="gray", vmin=0, vmax=max(1.0, float(diff[maps.mask].max())))
    fig.colorbar(im, ax=ax[1, 0], label="|grey difference| (0-255)")
    ax[1, 0].set(xlabel="Q11 (m^3/s)", ylabel="n11 (r/min)",
                 title=f"grey-level difference (Fig. 5), pixel RMS {similarity['pixel_rms']:.2f}")
    bins = np.arange(len(similarity["histogram_a"]))
    ax[1, 1].bar(bins - 0.2, similarity["histogram_a"], width=0.4, label="interpolation")
    ax[1, 1].bar(bins + 0.2, similarity["histogram_b"], width=0.4, label="net")
    ax[1, 1].set(xlabel="grey-level bin (25 bins over 0-255)", ylabel="fraction of pixels",
                 title=f"histograms (Fig. 6): Euclidean {similarity['euclidean']:.4f}, cosine "
                       f"{similarity['cosine']:.5f}, angle {similarity['angle_deg']:.2f} deg")
    ax[1, 1].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def plot_control_maps(weights: FCCMWeights, table: TestTable, path, *, resolution: int = 121) -> Path:
    """Fig. 7 of paper 003: each output of the net over its two inputs (e.g. a0-beta), with the test points."""
    if len(weights.inputs) != 2:
        raise InputError(f"control maps need a net with 2 inputs, got {list(weights.inputs)}")
    grid = _net_grid(weights, resolution)
    n = len(weights.outputs)
    ncols = min(n, 2)
    nrows = (n + ncols - 1) // ncols
    plt, (fig, ax) = _figure(nrows, ncols, (6.2 * ncols, 4.8 * nrows))
    u, v = weights.inputs
    for k, name in enumerate(weights.outputs):
        a = ax[k // ncols, k % ncols]
        cs = a.contourf(grid[u], grid[v], grid[name], levels=20, cmap="viridis")
        a.contour(grid[u], grid[v], grid[name], levels=10, colors="k", linewidths=0.4)
        a.plot(table.column(u), table.column(v), "r.", ms=3)
        a.set(xlabel=u, ylabel=v, title=f"({'abcdefgh'[k % 8]}) {name} (net)")
        fig.colorbar(cs, ax=a, label=name)
    for k in range(n, nrows * ncols):
        ax[k // ncols, k % ncols].set_visible(False)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def plot_operating_characteristic(weights: FCCMWeights, table: TestTable, path, *, resolution: int = 121) -> Path:
    """Fig. 8 of paper 003: efficiency over (power, head), the net evaluated over its input box and drawn on the
    triangulation of that box mapped to (P, H); the test points on top."""
    import matplotlib.tri as mtri

    for name in ("efficiency", "power_kw"):
        if name not in weights.outputs:
            raise InputError(f"the operating characteristic needs {name!r} among the outputs")
    if "head_m" not in weights.outputs + weights.inputs:
        raise InputError("the operating characteristic needs 'head_m' among the inputs or outputs")
    if len(weights.inputs) != 2:
        raise InputError(f"the operating characteristic needs a net with 2 inputs, got {list(weights.inputs)}")
    grid = _net_grid(weights, resolution)
    p, h, eta = (np.asarray(grid[k], dtype=float) for k in ("power_kw", "head_m", "efficiency"))
    ni, nj = p.shape
    idx = np.arange(ni * nj).reshape(ni, nj)
    tri = np.concatenate([np.column_stack([idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()]),
                          np.column_stack([idx[:-1, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()])])
    triangulation = mtri.Triangulation(p.ravel() / 1e3, h.ravel(), tri)
    plt, (fig, ax) = _figure(1, 1, (7.5, 5.5))
    a = ax[0, 0]
    cs = a.tricontourf(triangulation, eta.ravel(), levels=20, cmap="viridis")
    a.tricontour(triangulation, eta.ravel(), levels=10, colors="k", linewidths=0.4)
    a.plot(table.column("power_kw") / 1e3, table.column("head_m"), "r.", ms=3, label="test points")
    a.set(xlabel="power P (MW)", ylabel="head H (m)", title="operating characteristic: efficiency over (P, H) (net)")
    a.legend(loc="upper right", fontsize=8)
    fig.colorbar(cs, ax=a, label="efficiency")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
