"""Analyses of the full characteristic curve map: efficiency maps (Fig. 4), grey images and their similarity
(eqs. (4)-(5)), grey relational analysis (Table 1), net against interpolation against an exact grid."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hillchart.errors import InputError
from hillchart.fccm.net import FCCMWeights
from hillchart.fccm.table import TableInfo, TestTable
from hillchart.io.tabular import parse_number


# ----------------------------------------------------------------------------------------------------------------
# analyses of paper 003
# ----------------------------------------------------------------------------------------------------------------
def unit_quantities_from(values: dict, info: TableInfo) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(n11, Q11) from whichever columns ``values`` holds: ``n11_rpm`` / ``q11_m3_s`` directly, else eqs. (1)-(2)
    of paper 003 from ``head_m``, ``flow_m3_s``, the speed (``speed_rpm`` column or key) and ``runner_diameter_m``.
    None for a quantity that cannot be formed."""
    n11 = values.get("n11_rpm")  # presence test on a dict of the caller's columns, not a default
    q11 = values.get("q11_m3_s")
    d = info.runner_diameter_m
    head = values.get("head_m")
    if head is not None and d is not None:
        head = np.asarray(head, dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            sqrt_h = np.where(head > 0, np.sqrt(np.abs(head)), np.nan)  # a net may predict H <= 0 far outside
        speed = values.get("speed_rpm", info.speed_rpm)
        if n11 is None and speed is not None:
            n11 = speed * d / sqrt_h  # eq. (2), paper 003
        if q11 is None and values.get("flow_m3_s") is not None:
            q11 = np.asarray(values["flow_m3_s"], dtype=float) / (d * d * sqrt_h)  # eq. (1), paper 003
    return n11, q11


@dataclass(frozen=True)
class EfficiencyMaps:
    """Efficiency over (Q11, n11) from linear interpolation of the test points and from the net (Fig. 4).

    Attributes
    ----------
    q11, n11 : ndarray (nq,), (nn,)
        Pixel centres, m^3/s and r/min.
    interpolated, net : ndarray (nn, nq)
        Efficiency (fraction); NaN where the map is undefined (outside the test points' hull, or outside the image
        of the net's input box).
    mask : ndarray of bool (nn, nq)
        Pixels where both are defined (the images are compared there).
    points_q11, points_n11, points_efficiency : ndarray
        The test points.
    """

    q11: np.ndarray
    n11: np.ndarray
    interpolated: np.ndarray
    net: np.ndarray
    mask: np.ndarray
    points_q11: np.ndarray
    points_n11: np.ndarray
    points_efficiency: np.ndarray


def _net_grid(weights: FCCMWeights, resolution: int):
    """The net's outputs on a ``resolution``^n_in grid over its input box (inputs and outputs by name)."""
    axes = [np.linspace(lo, hi, resolution) for lo, hi in zip(weights.x_min, weights.x_max)]
    mesh = np.meshgrid(*axes, indexing="ij")
    values = {name: m for name, m in zip(weights.inputs, mesh)}
    values.update(weights.predict_columns(**values))
    return values


def _box_boundary_path(u, v):
    """Closed polygon of the image of a 2-D grid's boundary (arrays (n, m)), for point-in-region tests."""
    from matplotlib.path import Path as MplPath

    edge_u = np.concatenate([u[0, :], u[1:, -1], u[-1, -2::-1], u[-2:0:-1, 0]])
    edge_v = np.concatenate([v[0, :], v[1:, -1], v[-1, -2::-1], v[-2:0:-1, 0]])
    return MplPath(np.column_stack([edge_u, edge_v]))


def efficiency_maps(table: TestTable, weights: FCCMWeights, *, pixels: int = 160,
                    net_resolution: int = 161) -> EfficiencyMaps:
    """Fig. 4 of paper 003: efficiency over (Q11, n11) by linear interpolation of the test points
    (``scipy.interpolate.griddata``, Delaunay on coordinates scaled to the unit box: Q11 ~ 1 and n11 ~ 100 would
    otherwise give skinny triangles and striped maps) and from the net, on the same pixel grid.

    The net's map: the net evaluated on a dense grid over its 2-D input box, each grid point carried to (Q11, n11)
    by eqs. (1)-(2), then linearly interpolated onto the pixels and masked to the image of the input box (a map
    over (Q11, n11) is only defined where some input setting reaches it).

    Raises
    ------
    InputError
        The net does not have 2 inputs, efficiency is not an output, or n11/Q11 cannot be formed.
    """
    from scipy.interpolate import griddata

    if len(weights.inputs) != 2:
        raise InputError(f"efficiency maps need a net with 2 inputs, got {list(weights.inputs)}")
    if "efficiency" not in weights.outputs:
        raise InputError(f"efficiency maps need 'efficiency' among the net's outputs, got {list(weights.outputs)}")
    n11_pts, q11_pts = unit_quantities_from(table.columns, table.info)
    if n11_pts is None or q11_pts is None:
        raise InputError("efficiency maps need n11 and Q11 of the test points: columns n11_rpm and q11_m3_s, or "
                         "head_m, flow_m3_s, a speed and runner_diameter_m")
    eta_pts = table.column("efficiency")
    grid = _net_grid(weights, net_resolution)
    n11_net, q11_net = unit_quantities_from(grid, table.info)
    if n11_net is None or q11_net is None:
        raise InputError("efficiency maps need n11 and Q11 from the net: among its inputs/outputs n11_rpm and "
                         "q11_m3_s, or head_m and flow_m3_s (with a speed and runner_diameter_m in table.toml)")
    n11_net, q11_net = np.broadcast_to(n11_net, grid["efficiency"].shape), np.broadcast_to(q11_net,
                                                                                           grid["efficiency"].shape)
    ok = np.isfinite(n11_net) & np.isfinite(q11_net)
    q_lo = min(q11_pts.min(), q11_net[ok].min())
    q_hi = max(q11_pts.max(), q11_net[ok].max())
    n_lo = min(n11_pts.min(), n11_net[ok].min())
    n_hi = max(n11_pts.max(), n11_net[ok].max())
    q_axis, n_axis = np.linspace(q_lo, q_hi, pixels), np.linspace(n_lo, n_hi, pixels)
    qq, nn = np.meshgrid(q_axis, n_axis)
    interp = griddata(np.column_stack([q11_pts, n11_pts]), eta_pts, (qq, nn), method="linear", rescale=True)
    net = griddata(np.column_stack([q11_net[ok], n11_net[ok]]), grid["efficiency"][ok], (qq, nn), method="linear",
                   rescale=True)
    inside = _box_boundary_path(q11_net, n11_net).contains_points(np.column_stack([qq.ravel(), nn.ravel()]))
    net = np.where(inside.reshape(qq.shape), net, np.nan)
    mask = np.isfinite(interp) & np.isfinite(net)
    return EfficiencyMaps(q11=q_axis, n11=n_axis, interpolated=interp, net=net, mask=mask, points_q11=q11_pts,
                          points_n11=n11_pts, points_efficiency=eta_pts)


def grey_images(a, b, *, value_range=None):
    """Two maps as 8-bit grey images with the same linear mapping and the same mask (Fig. 5 of paper 003).

    Parameters
    ----------
    a, b : ndarray, same shape
        Maps (e.g. efficiency); NaN where undefined.
    value_range : (lo, hi), optional
        Values mapped to 0 and 255; default the min and max of both maps inside the common mask.

    Returns
    -------
    grey_a, grey_b : ndarray of uint8
        ``round(255 (v - lo) / (hi - lo))`` clipped to 0-255; 0 outside the mask.
    mask : ndarray of bool
        Pixels where both maps are defined.

    Examples
    --------
    >>> ga, gb, m = grey_images(np.array([[0.0, 0.5, 1.0]]), np.array([[0.0, 1.0, np.nan]]))
    >>> ga.tolist(), gb.tolist(), m.tolist()
    ([[0, 128, 0]], [[0, 255, 0]], [[True, True, False]])
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise InputError(f"grey_images: the maps must have the same shape, got {a.shape} and {b.shape}")
    mask = np.isfinite(a) & np.isfinite(b)
    if not mask.any():
        raise InputError("grey_images: the two maps have no pixel where both are defined")
    lo, hi = (min(a[mask].min(), b[mask].min()), max(a[mask].max(), b[mask].max())) if value_range is None \
        else value_range
    if not hi > lo:
        raise InputError(f"grey_images: value range must have hi > lo, got ({lo!r}, {hi!r})")

    def to_grey(m):
        g = np.zeros(m.shape, dtype=np.uint8)
        g[mask] = np.clip(np.round(255.0 * (m[mask] - lo) / (hi - lo)), 0, 255).astype(np.uint8)
        return g

    return to_grey(a), to_grey(b), mask


def grey_histogram(grey, mask, bins: int = 25) -> np.ndarray:
    """Grey-level histogram inside ``mask``, ``bins`` equal bins over 0-255, normalized to sum 1 (Fig. 6)."""
    counts, _ = np.histogram(np.asarray(grey)[mask], bins=bins, range=(0.0, 256.0))
    total = counts.sum()
    if total == 0:
        raise InputError("grey_histogram: the mask is empty")
    return counts / total


def image_similarity(grey_a, grey_b, mask, *, bins: int = 25) -> dict:
    """Similarity of two grey images (paper 003, eqs. (4)-(5)) plus a pixel-wise measure.

    Returns
    -------
    dict
        ``euclidean``: eq. (4) between the two normalized ``bins``-bin histograms; ``cosine``: eq. (5) between them;
        ``angle_deg``: arccos of the cosine; ``pixel_rms``: RMS grey-level difference over the pixels in ``mask``
        (0-255 scale); ``pixels``: pixels compared; ``histogram_a``, ``histogram_b``.

    Examples
    --------
    >>> g = np.arange(256, dtype=np.uint8).reshape(16, 16); m = np.ones_like(g, dtype=bool)
    >>> s = image_similarity(g, g, m)
    >>> s["euclidean"], s["cosine"], s["pixel_rms"]
    (0.0, 1.0, 0.0)
    """
    mask = np.asarray(mask, dtype=bool)
    ha, hb = grey_histogram(grey_a, mask, bins), grey_histogram(grey_b, mask, bins)
    euclid = float(np.sqrt(np.sum((ha - hb) ** 2)))  # eq. (4), paper 003
    cosine = float(np.sum(ha * hb) / (np.sqrt(np.sum(ha ** 2)) * np.sqrt(np.sum(hb ** 2))))  # eq. (5), paper 003
    cosine = min(cosine, 1.0)  # rounding can give 1 + 1e-16
    diff = np.asarray(grey_a, dtype=float)[mask] - np.asarray(grey_b, dtype=float)[mask]
    return {"euclidean": euclid, "cosine": cosine, "angle_deg": float(np.degrees(np.arccos(cosine))),
            "pixel_rms": float(np.sqrt(np.mean(diff ** 2))), "pixels": int(mask.sum()),
            "histogram_a": ha.tolist(), "histogram_b": hb.tolist()}


def grey_relational_analysis(references: dict, comparisons: dict, *, rho: float = 0.5) -> dict:
    """Grey relational degrees of each comparison sequence to each reference sequence (Table 1 of paper 003).

    For one reference x0 (an output over the test points) and the comparisons xi (the controls): every sequence
    min-max normalized to [0, 1]; ``delta_i(k) = |x0(k) - xi(k)|``; the two-level minimum and maximum of delta over
    all comparisons i and points k; coefficient ``xi_i(k) = (d_min + rho d_max) / (delta_i(k) + rho d_max)``;
    degree ``r_i = mean_k xi_i(k)``.

    Parameters
    ----------
    references, comparisons : dict of str -> array (n,)
    rho : float in (0, 1], default 0.5
        Distinguishing coefficient.

    Returns
    -------
    dict
        ``{reference: {comparison: degree}}``.

    Examples
    --------
    >>> r = grey_relational_analysis({"y": [0, 1, 2, 3]}, {"same": [0, 2, 4, 6], "reverse": [3, 2, 1, 0]})
    >>> # same shape -> 1; reverse: 0.5 / (delta + 0.5) with delta = 1, 1/3, 1/3, 1
    >>> r["y"]["same"], round(r["y"]["reverse"], 4)
    (1.0, 0.4667)
    """
    if isinstance(rho, bool) or not isinstance(rho, (int, float)) or not 0 < rho <= 1:
        raise InputError(f"rho must be in (0, 1], got {rho!r}")

    def normalized(name, values):
        v = np.asarray(values, dtype=float)
        if v.ndim != 1 or v.size < 2 or not np.all(np.isfinite(v)):
            raise InputError(f"grey relational analysis: {name!r} must be a finite sequence of >= 2 values")
        span = np.ptp(v)
        if span == 0:
            raise InputError(f"grey relational analysis: {name!r} is constant; it cannot be normalized")
        return (v - v.min()) / span

    comp = {name: normalized(name, v) for name, v in comparisons.items()}
    sizes = {v.size for v in comp.values()}
    out = {}
    for ref_name, ref_values in references.items():
        x0 = normalized(ref_name, ref_values)
        if sizes != {x0.size}:
            raise InputError(f"grey relational analysis: all sequences need {x0.size} values")
        delta = np.array([np.abs(x0 - xi) for xi in comp.values()])  # (n_comparisons, n_points)
        d_min, d_max = float(delta.min()), float(delta.max())  # two-level min and max
        if d_max == 0:
            out[ref_name] = {name: 1.0 for name in comp}
            continue
        coeff = (d_min + rho * d_max) / (delta + rho * d_max)
        out[ref_name] = {name: float(coeff[i].mean()) for i, name in enumerate(comp)}
    return out


def grey_relational_order(degrees: dict) -> dict:
    """``{reference: {comparison: rank}}`` with rank 1 for the largest degree (the paper's "CO")."""
    out = {}
    for ref, row in degrees.items():
        ranked = sorted(row, key=lambda name: -row[name])
        out[ref] = {name: ranked.index(name) + 1 for name in row}
    return out


def format_grey_relational_table(degrees: dict) -> str:
    """Table 1 of paper 003 as text: one row per control, CD (degree) and CO (order) per output."""
    order = grey_relational_order(degrees)
    refs = list(degrees)
    controls = list(next(iter(degrees.values())))
    width = max(len(c) for c in controls + ["influencing factor"])
    head1 = f"{'influencing factor':<{width}} " + " ".join(f"{r[:13]:>13}" for r in refs)
    head2 = f"{'':<{width}} " + " ".join(f"{'CD':>8} {'CO':>4}" for _ in refs)
    lines = [head1, head2]
    for c in controls:
        lines.append(f"{c:<{width}} " + " ".join(f"{degrees[r][c]:>8.4f} {order[r][c]:>4d}" for r in refs))
    lines.append("CD: grey relational (correlation) degree, CO: order (1 = strongest); rho = 0.5")
    return "\n".join(lines)


def truth_comparison(weights: FCCMWeights, table: TestTable, truth: dict) -> dict:
    """The net and linear interpolation of the test points against exact values on a dense grid (section 4).

    Linear interpolation is ``scipy.interpolate.griddata(method="linear", rescale=True)`` (Delaunay on
    coordinates scaled to the unit box) of all test points in the net's input space; grid points outside their
    convex hull (where interpolation is undefined) are left out of both errors and counted.

    Parameters
    ----------
    truth : dict of str -> ndarray
        Exact values, with every input and output column of the net.

    Returns
    -------
    dict
        Per output: ``range`` (truth max - min), ``net_rms``, ``net_max``, ``interpolation_rms``,
        ``interpolation_max`` (physical units), the RMS values as percent of the range (``*_rms_pct``), and
        ``net_better``; plus ``points`` and ``points_outside_hull``.
    """
    from scipy.interpolate import griddata

    for name in weights.inputs + weights.outputs:
        if name not in truth:
            raise InputError(f"truth: column {name!r} is missing (have {', '.join(truth)})")
    Xt = np.column_stack([np.asarray(truth[n], dtype=float) for n in weights.inputs])
    Yt = np.column_stack([np.asarray(truth[n], dtype=float) for n in weights.outputs])
    pred = weights.predict(Xt)
    X = table.matrix(weights.inputs)
    Y = table.matrix(weights.outputs)
    interp = griddata(X, Y, Xt, method="linear", rescale=True) if X.shape[1] > 1 else np.column_stack(
        [np.interp(Xt[:, 0], np.sort(X[:, 0]), Y[np.argsort(X[:, 0]), j], left=np.nan, right=np.nan)
         for j in range(Y.shape[1])])
    inside = np.all(np.isfinite(interp), axis=1)
    out = {"points": int(inside.sum()), "points_outside_hull": int((~inside).sum())}
    for j, name in enumerate(weights.outputs):
        scale = float(np.ptp(Yt[:, j]))
        e_net = pred[inside, j] - Yt[inside, j]
        e_int = interp[inside, j] - Yt[inside, j]
        rec = {"range": scale, "net_rms": float(np.sqrt(np.mean(e_net ** 2))), "net_max": float(np.max(np.abs(e_net))),
               "interpolation_rms": float(np.sqrt(np.mean(e_int ** 2))),
               "interpolation_max": float(np.max(np.abs(e_int)))}
        rec["net_rms_pct"] = 100.0 * rec["net_rms"] / scale
        rec["interpolation_rms_pct"] = 100.0 * rec["interpolation_rms"] / scale
        rec["net_better"] = bool(rec["net_rms"] < rec["interpolation_rms"])
        out[name] = rec
    return out


def truth_acceptance(comparison: dict, outputs, *, bound_pct: float = 1.5, min_better: int = 3) -> dict:
    """The acceptance of a truth comparison: every output's net RMS <= ``bound_pct`` % of its range, and the
    net below interpolation for at least ``min_better`` outputs. Returns the checks and ``passed``."""
    within = {o: comparison[o]["net_rms_pct"] <= bound_pct for o in outputs}
    better = sum(comparison[o]["net_better"] for o in outputs)
    return {"bound_pct": bound_pct, "within_bound": within, "net_better_count": int(better),
            "min_better": min(min_better, len(list(outputs))),
            "passed": bool(all(within.values()) and better >= min(min_better, len(list(outputs))))}


def read_truth_csv(path) -> dict:
    """A truth grid CSV (header with column names, numeric rows) as ``{column: ndarray}``; errors name the file,
    row and column."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: missing file (the truth grid, e.g. truth.csv of hillsim synth --turbine bulb)")
    with path.open(newline="", encoding="utf-8") as handle:
        rows = [row for row in csv.reader(handle) if row and not row[0].lstrip().startswith("#")]
    if len(rows) < 2:
        raise InputError(f"{path}: needs a header and at least one data row")
    header = [h.strip() for h in rows[0]]
    data = {h: [] for h in header}
    for line_no, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise InputError(f"{path}: row {line_no} has {len(row)} fields, the header has {len(header)}")
        for h, cell in zip(header, row):
            data[h].append(parse_number(path, line_no, h, cell))
    return {h: np.asarray(v) for h, v in data.items()}
