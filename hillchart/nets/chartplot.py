"""Figures from trained nets: a manufacturer-style hill chart, the net surfaces and the error plots.

* :func:`plot_hill_chart`: N11 (r/min) vs Q11 (m^3/s) with iso-efficiency contours, iso-opening lines, the runaway
  curve (M11 = 0) and, optionally, the digitized samples, as a turbine manufacturer draws a model hill chart.
  Efficiency is recovered from the nets by inverting eq. (5) of the BP hill-chart paper (004):
  ``eta = M11 omega11 / (rho g Q11)``, ``omega11 = 2 pi N11 / 60``.
* :func:`plot_surfaces`: filled contours of Q11(N11, a) and M11(N11, a) over the whole extended domain with the
  training samples on top (paper Figs. 5-6).
* :func:`plot_sample_errors`: net output minus sample value for every extended sample, by origin (paper Figs. 7-8).
* :func:`plot_truth_errors`: error maps against an exact reference (``truth.csv``) with the measured region outlined.
* :func:`chart_figure`: all of the above on one page (what ``hillsim chart`` writes).

Every function takes an object with ``q11``/``m11`` (:class:`hillchart.nets.hill_nets.HillNets` or any
:class:`hillchart.characteristics.Characteristics`) and draws on given axes or returns a new figure; nothing is
written unless a path is given.
"""

from __future__ import annotations

import numpy as np

from hillchart.characteristics import efficiency_from_characteristics, efficiency_from_unit_torque  # noqa: F401
from hillchart.extension.extend import ORIGIN_COLOURS

#: Iso-efficiency levels drawn when the caller gives none (those below the chart's best are used).
DEFAULT_EFFICIENCY_LEVELS = (0.50, 0.60, 0.70, 0.75, 0.80, 0.82, 0.84, 0.86, 0.88, 0.90, 0.91, 0.92, 0.93, 0.94,
                             0.95)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _domain(nets):
    """(n11_min, n11_max), (opening_min, opening_max) of the nets' inputs, or None for other objects."""
    flow = getattr(nets, "flow", None)
    if flow is None:
        return None
    return (float(flow.x_min[0]), float(flow.x_max[0])), (float(flow.x_min[1]), float(flow.x_max[1]))


def _view_from_samples(samples, domain):
    n11 = np.concatenate([samples.flow_n11, samples.eff_n11, samples.runaway_n11])
    lo, hi = float(n11.min()), float(n11.max())
    span = hi - lo
    n11_range = (max(lo - 0.25 * span, 1e-3), hi + 0.08 * span)
    if domain is not None:
        n11_range = (max(n11_range[0], domain[0][0], 1e-3), min(n11_range[1], domain[0][1]))
    return n11_range


def samples_hull_mask(samples, n11, q11, *, margin: float = 0.05) -> np.ndarray:
    """True where (N11, Q11) lies inside the convex hull of all digitized points (opening lines, efficiency
    contours, runaway), enlarged by ``margin`` (fraction of the hull's size) about its centroid: the part of the
    (N11, Q11) plane the chart itself covers."""
    from scipy.spatial import Delaunay

    pts = np.column_stack([np.concatenate([samples.flow_n11, samples.eff_n11, samples.runaway_n11]),
                           np.concatenate([samples.flow_q11, samples.eff_q11, samples.runaway_q11])])
    scale = np.ptp(pts, axis=0)
    centre = pts.mean(axis=0)
    hull = Delaunay((centre + (1.0 + margin) * (pts - centre)) / scale)
    query = np.column_stack([np.ravel(n11), np.ravel(q11)]) / scale
    return (hull.find_simplex(query) >= 0).reshape(np.shape(n11))


def hill_chart_grid(nets, *, samples=None, n11_range=None, opening_range=None, grid: int = 241,
                    clip_to_samples: bool = True):
    """The (N11, a) evaluation grid behind :func:`plot_hill_chart`.

    Parameters
    ----------
    clip_to_samples : bool
        With ``samples``: efficiency only inside the region the digitized points cover (:func:`samples_hull_mask`);
        outside it the nets extrapolate and a manufacturer's chart draws nothing either.

    Returns
    -------
    N, A, Q, M, eta : ndarray (grid, grid)
        Rows: opening, columns: N11. ``eta`` is NaN where Q11 is below 3 % of its maximum (efficiency is 0/0
        there), not positive, or (clipped) outside the samples' region.
    """
    domain = _domain(nets)
    if n11_range is None:
        if samples is not None:
            n11_range = _view_from_samples(samples, domain)
        elif domain is not None:
            n11_range = (max(domain[0][0], 0.05 * domain[0][1]), domain[0][1])
        else:
            raise ValueError("n11_range is required for characteristics without input ranges")
    if opening_range is None:
        if domain is None:
            raise ValueError("opening_range is required for characteristics without input ranges")
        opening_range = domain[1]
    N, A = np.meshgrid(np.linspace(*n11_range, grid), np.linspace(*opening_range, grid))
    Q = np.asarray(nets.q11(N, A), dtype=float)
    M = np.asarray(nets.m11(N, A), dtype=float)
    eta = efficiency_from_characteristics(nets, N, A)
    eta = np.where(Q > 0.03 * float(np.nanmax(Q)), eta, np.nan)
    if samples is not None and clip_to_samples:
        eta = np.where(samples_hull_mask(samples, N, Q), eta, np.nan)
    return N, A, Q, M, eta


def efficiency_at_points(nets, n11, q11, *, opening_range=None, iterations: int = 60) -> np.ndarray:
    """Efficiency of the nets at given (N11, Q11) points, e.g. the digitized iso-efficiency points.

    For each point the opening with ``Q11(N11, a) = q11`` is found by bisection (Q11 rises with a), then
    ``eta = M11 omega11 / (rho g Q11)`` (eq. (5) of paper 004, inverted). NaN where no opening in the range gives
    that flow.

    Parameters
    ----------
    nets : HillNets or Characteristics
    n11 : array_like, r/min
    q11 : array_like, m^3/s
    opening_range : (float, float), optional
        Default: the nets' input range of the opening.

    Examples
    --------
    >>> from hillchart.characteristics import IdealTurbine
    >>> t = IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.9)
    >>> [round(float(e), 9) for e in efficiency_at_points(t, [60.0, 80.0], [0.3, 0.5], opening_range=(0, 30))]
    [0.9, 0.9]
    """
    n11 = np.asarray(n11, dtype=float)
    q11 = np.asarray(q11, dtype=float)
    if opening_range is None:
        opening_range = _domain(nets)[1]
    lo = np.full(n11.shape, float(opening_range[0]))
    hi = np.full(n11.shape, float(opening_range[1]))
    reachable = (np.asarray(nets.q11(n11, lo)) <= q11) & (np.asarray(nets.q11(n11, hi)) >= q11)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        below = np.asarray(nets.q11(n11, mid)) < q11
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    eta = efficiency_from_characteristics(nets, n11, 0.5 * (lo + hi))
    return np.where(reachable, eta, np.nan)


def efficiency_islands(nets, levels, *, samples=None, n11_range=None, opening_range=None, grid: int = 241,
                       clip_to_samples: bool = True):
    """Iso-efficiency lines of the nets in the (N11, Q11) plane and whether each is a closed loop.

    A hill chart is plausible when its high-efficiency contours are closed islands around one best point.

    Parameters
    ----------
    nets : HillNets or Characteristics
    levels : sequence of float
        Efficiency levels (fractions).

    Returns
    -------
    dict
        level -> list of ``(closed: bool, points: ndarray (k, 2) of (N11, Q11))``, one per contour line.
    """
    import contourpy

    N, A, Q, M, eta = hill_chart_grid(nets, samples=samples, n11_range=n11_range, opening_range=opening_range,
                                      grid=grid, clip_to_samples=clip_to_samples)
    gen = contourpy.contour_generator(x=N, y=Q, z=np.ma.masked_invalid(eta), line_type="Separate")
    out = {}
    for level in levels:
        lines = gen.lines(level)
        out[float(level)] = [(bool(np.allclose(line[0], line[-1]) and len(line) > 3), line) for line in lines]
    return out


def plot_hill_chart(nets, ax=None, *, samples=None, n11_range=None, opening_range=None, openings=None,
                    efficiency_levels=None, grid: int = 241, opening_unit: str | None = None,
                    title: str | None = None, clip_to_samples: bool = True):
    """Manufacturer-style hill chart from the nets: N11 vs Q11, iso-efficiency contours, iso-opening lines,
    runaway curve, samples.

    Parameters
    ----------
    nets : HillNets or Characteristics
    ax : matplotlib Axes, optional
    samples : hillchart.io.samples.ChartSamples, optional
        Digitized points to overlay; they also set the default view.
    n11_range : (float, float), optional
        N11 axis range, r/min. Default: the samples' span with margins, else the nets' input range.
    opening_range : (float, float), optional
        Openings evaluated (chart units). Default: the nets' input range.
    openings : sequence of float, optional
        Iso-opening lines drawn. Default: the samples' openings, else 10 equal steps.
    efficiency_levels : sequence of float, optional
        Iso-efficiency levels (fractions). Default: :data:`DEFAULT_EFFICIENCY_LEVELS` below the best efficiency.
    grid : int
        Points per axis of the evaluation grid.
    clip_to_samples : bool
        With ``samples``: draw efficiency contours only where the digitized points are (see
        :func:`hill_chart_grid`).

    Returns
    -------
    matplotlib Axes
    """
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 6.5))
    if opening_unit is None:
        opening_unit = getattr(nets, "opening_unit", "")
    N, A, Q, M, eta = hill_chart_grid(nets, samples=samples, n11_range=n11_range, opening_range=opening_range,
                                      grid=grid, clip_to_samples=clip_to_samples)
    n11 = N[0]
    n11_range = (float(n11[0]), float(n11[-1]))
    opening_range = (float(A[0, 0]), float(A[-1, 0]))
    q_top = float(np.nanmax(Q))
    best = float(np.nanmax(np.where(M > 0, eta, np.nan)))
    if efficiency_levels is None:
        efficiency_levels = [lv for lv in DEFAULT_EFFICIENCY_LEVELS if lv < best]
    # iso-efficiency contours on the curvilinear (N11, Q11(N11, a)) grid
    if len(efficiency_levels):
        cs = ax.contour(N, Q, eta, levels=sorted(efficiency_levels), cmap="viridis", linewidths=1.1)
        ax.clabel(cs, fmt=lambda v: f"{100 * v:.0f}" if abs(100 * v - round(100 * v)) < 1e-6 else f"{100 * v:.1f}",
                  fontsize=7, inline=True)
    # runaway curve: M11 = 0
    ax.contour(N, Q, M, levels=[0.0], colors="tab:red", linestyles="--", linewidths=1.6)
    # iso-opening lines
    if openings is None:
        openings = samples.openings if samples is not None else np.linspace(opening_range[0], opening_range[1], 11)[1:]
    for a in openings:
        q_line = np.asarray(nets.q11(n11, np.full_like(n11, a)), dtype=float)
        ax.plot(n11, q_line, color="0.35", lw=0.8)
        ax.annotate(f"{a:g}", (n11[-1], q_line[-1]), xytext=(2, 0), textcoords="offset points", fontsize=7,
                    color="0.3", va="center")
    # best efficiency point on the grid
    i, j = np.unravel_index(np.nanargmax(np.where(M > 0, eta, -np.inf)), eta.shape)
    ax.plot(N[i, j], Q[i, j], marker="*", color="k", ms=11, zorder=5,
            label=f"best eta = {100 * eta[i, j]:.1f} % at N11 = {N[i, j]:.1f}, a = {A[i, j]:.1f}")
    if samples is not None:
        ax.plot(samples.flow_n11, samples.flow_q11, "k.", ms=3, label="digitized opening lines")
        ax.scatter(samples.eff_n11, samples.eff_q11, s=6, c="0.6", marker="o", label="digitized efficiency points")
        if samples.runaway_n11.size:
            ax.plot(samples.runaway_n11, samples.runaway_q11, "^", color="tab:red", ms=4, label="digitized runaway")
    ax.plot([], [], "--", color="tab:red", label="runaway curve of the nets (M11 = 0)")
    ax.plot([], [], color="0.35", lw=0.8, label=f"iso-opening lines (a in {opening_unit})")
    ax.set_xlim(*n11_range)
    ax.set_ylim(0.0, 1.05 * q_top)
    ax.set_xlabel("N11 (r/min)")
    ax.set_ylabel("Q11 (m$^3$/s)")
    ax.set_title(title or "hill chart from the nets (iso-efficiency in %)")
    ax.legend(loc="upper left", fontsize=7)
    ax.grid(alpha=0.25)
    return ax


def plot_surfaces(nets, axes=None, *, extended=None, grid: int = 121):
    """Filled contours of Q11(N11, a) and M11(N11, a) over the nets' input domain (paper 004, Figs. 5-6).

    Parameters
    ----------
    nets : HillNets
    axes : pair of Axes, optional
    extended : hillchart.extension.extend.ExtendedSamples, optional
        Training samples to overlay, coloured by origin.

    Returns
    -------
    pair of Axes
    """
    plt = _pyplot()
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    (n_lo, n_hi), (a_lo, a_hi) = _domain(nets)
    N, A = np.meshgrid(np.linspace(n_lo, n_hi, grid), np.linspace(a_lo, a_hi, grid))
    unit = getattr(nets, "opening_unit", "")
    for ax, name, label, cmap in ((axes[0], "q11", "Q11 (m$^3$/s)", "Blues"), (axes[1], "m11", "M11 (N m)", "RdBu_r")):
        Z = np.asarray(getattr(nets, name)(N, A), dtype=float)
        if name == "m11":
            lim = float(np.max(np.abs(Z)))
            cf = ax.contourf(N, A, Z, levels=np.linspace(-lim, lim, 25), cmap=cmap)
            ax.contour(N, A, Z, levels=[0.0], colors="k", linewidths=1.0, linestyles="--")
        else:
            cf = ax.contourf(N, A, Z, levels=24, cmap=cmap)
        plt.colorbar(cf, ax=ax, label=label)
        if extended is not None:
            mask = extended.target == name
            for origin, colour in ORIGIN_COLOURS.items():
                sel = mask & (extended.origin == origin)
                if sel.any():
                    ax.scatter(extended.n11[sel], extended.opening[sel], s=7, color=colour, edgecolors="k",
                               linewidths=0.3, label=origin)
            ax.legend(loc="upper right", fontsize=7)
        ax.set_xlabel("N11 (r/min)")
        ax.set_ylabel(f"opening a ({unit})")
        ax.set_title(f"{name.upper()} net over (N11, a)" + ("; dashed: M11 = 0" if name == "m11" else ""))
    return axes


def plot_sample_errors(nets, extended, axes=None):
    """Net output minus sample value for every extended sample, coloured by origin (paper 004, Figs. 7-8).

    Returns
    -------
    pair of Axes
    """
    plt = _pyplot()
    if axes is None:
        _, axes = plt.subplots(2, 1, figsize=(8, 6))
    for ax, name, unit in ((axes[0], "q11", "m$^3$/s"), (axes[1], "m11", "N m")):
        mask = extended.target == name
        pred = np.asarray(getattr(nets, name)(extended.n11[mask], extended.opening[mask]), dtype=float)
        err = pred - extended.value[mask]
        origin = extended.origin[mask]
        index = np.arange(err.size)
        for o, colour in ORIGIN_COLOURS.items():
            sel = origin == o
            if sel.any():
                ax.plot(index[sel], err[sel], "o", ms=3, color=colour,
                        label=f"{o}: max |e| = {np.max(np.abs(err[sel])):.3g}")
        span = float(np.ptp(extended.value[mask]))
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel(f"{name.upper()} net - sample ({unit})")
        ax.set_title(f"{name.upper()} fit error (range of samples {span:.3g} {unit.replace('$', '')})", fontsize=9)
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.25)
    axes[1].set_xlabel("sample index")
    return axes


def plot_truth_errors(nets, truth: dict, inside: np.ndarray, axes=None, *, opening_unit: str = ""):
    """Error maps ``net - truth`` (in % of the measured-region range) over a regular (N11, a) truth grid, the
    measured region outlined (errors in the extended region, with a plot).

    Parameters
    ----------
    nets : Characteristics
    truth : dict of ndarray
        ``n11``, ``opening``, ``q11``, ``m11`` on a full regular grid (as ``truth.csv``).
    inside : ndarray of bool
        Measured-region mask of the truth points.

    Returns
    -------
    pair of Axes
    """
    plt = _pyplot()
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    n_values, a_values = np.unique(truth["n11"]), np.unique(truth["opening"])
    if n_values.size * a_values.size != truth["n11"].size:
        raise ValueError("truth points must form a full regular (n11, opening) grid")
    order = np.lexsort((truth["n11"], truth["opening"]))  # rows: opening, columns: N11
    shape = (a_values.size, n_values.size)
    N = truth["n11"][order].reshape(shape)
    A = truth["opening"][order].reshape(shape)
    IN = inside[order].reshape(shape).astype(float)
    for ax, name in zip(axes, ("q11", "m11")):
        true = truth[name][order].reshape(shape)
        scale = float(np.ptp(truth[name][inside]))
        err = 100.0 * (np.asarray(getattr(nets, name)(N, A), dtype=float) - true) / scale
        lim = max(float(np.max(np.abs(err))), 1e-12)
        levels = np.array([-20, -10, -5, -2, -1, -0.5, 0.5, 1, 2, 5, 10, 20], dtype=float)
        levels = np.concatenate([[-max(lim, 21)], levels, [max(lim, 21)]])
        cf = ax.contourf(N, A, err, levels=levels, cmap="RdBu_r", norm=_symlog_norm())
        plt.colorbar(cf, ax=ax, label="% of the measured-region range", ticks=levels[1:-1])
        ax.contour(N, A, IN, levels=[0.5], colors="k", linewidths=1.4)
        e_in = err[IN > 0.5]
        ax.set_title(f"{name.upper()} net - truth; measured region (black): RMS {np.sqrt(np.mean(e_in ** 2)):.2f} %, "
                     f"max {np.max(np.abs(e_in)):.2f} %", fontsize=9)
        ax.set_xlabel("N11 (r/min)")
        ax.set_ylabel(f"opening a ({opening_unit})")
    return axes


def _symlog_norm():
    from matplotlib.colors import SymLogNorm

    return SymLogNorm(linthresh=0.5, vmin=-25, vmax=25)


def trust_map(nets, *, grid: int = 81, percentiles=(5.0, 95.0)):
    """Width of the ensemble's band over (N11, a): ``(N, A, width_pct)``.

    ``width_pct`` is the larger of the Q11 and M11 band widths (``percentiles``), each in percent of the nets'
    output range (``y_max - y_min`` of the point nets): where it is large the nets are not to be trusted.
    """
    (n_lo, n_hi), (a_lo, a_hi) = _domain(nets)
    N, A = np.meshgrid(np.linspace(n_lo, n_hi, grid), np.linspace(a_lo, a_hi, grid))
    widths = []
    for name, weights in (("q11", nets.flow), ("m11", nets.torque)):
        band = nets.band(name, N, A, percentiles=percentiles)
        widths.append(100.0 * (band["high"] - band["low"]) / (weights.y_max - weights.y_min))
    return N, A, np.maximum(*widths)


def plot_trust_map(nets, ax=None, *, samples=None, grid: int = 81):
    """The trust map: shaded width of the 5-95 % ensemble band over (N11, a), with the
    digitized region (hull of the opening-line points) outlined. Returns the Axes."""
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 5))
    N, A, width = trust_map(nets, grid=grid)
    levels = [0, 0.5, 1, 2, 5, 10, 20, 50]
    top = float(np.nanmax(width))
    cf = ax.contourf(N, A, np.clip(width, 0, 50), levels=[v for v in levels if v < max(top, 0.5)] + [max(top, 50)],
                     cmap="Reds")
    plt.colorbar(cf, ax=ax, label="5-95 % band width, % of range (max of Q11, M11)")
    if samples is not None:
        from scipy.spatial import ConvexHull, QhullError

        points = np.column_stack([samples.flow_n11, samples.flow_opening])
        try:
            hull = ConvexHull(points)
            loop = np.append(hull.vertices, hull.vertices[0])
            ax.plot(points[loop, 0], points[loop, 1], "k-", lw=1.5, label="digitized region")
            ax.legend(loc="upper right", fontsize=8)
        except QhullError:
            pass
    ax.set_xlabel("N11 (r/min)")
    ax.set_ylabel(f"opening a ({getattr(nets, 'opening_unit', '')})")
    ax.set_title(f"trust map: ensemble of {len(nets.ensemble)} (light = trust)")
    return ax


def chart_figure(nets, *, samples=None, extended=None, path=None, title: str | None = None):
    """One page: hill chart, Q11 and M11 surfaces, (with ``extended``) the sample error plots and (when the nets
    have an ensemble) the trust map.

    Parameters
    ----------
    nets : HillNets
    samples : ChartSamples, optional
    extended : ExtendedSamples, optional
    path : str or Path, optional
        PNG to write; nothing is written without it.

    Returns
    -------
    matplotlib Figure
    """
    plt = _pyplot()
    has_band = bool(getattr(nets, "ensemble", None))
    ncols = 2 + (extended is not None) + has_band
    fig = plt.figure(figsize=(7.5 * ncols, 10.5))
    gs = fig.add_gridspec(2, ncols, width_ratios=[1.5] + [1.0] * (ncols - 1))
    ax_chart = fig.add_subplot(gs[:, 0])
    plot_hill_chart(nets, ax_chart, samples=samples, title=title)
    plot_surfaces(nets, (fig.add_subplot(gs[0, 1]), fig.add_subplot(gs[1, 1])), extended=extended)
    if extended is not None:
        plot_sample_errors(nets, extended, (fig.add_subplot(gs[0, 2]), fig.add_subplot(gs[1, 2])))
    if has_band:
        plot_trust_map(nets, fig.add_subplot(gs[0, ncols - 1]), samples=samples)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=100)
    return fig
