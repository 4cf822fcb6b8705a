"""Where the characteristics can be trusted, and where a trajectory leaves that domain.

Three kinds of extrapolation, each reported separately:

``training_range``   outside the nets' training range: N11 or opening outside the input normalization
                     [x_min, x_max] of both nets (the samples they were fitted on, extension included);
``digitized_region`` outside the digitized region: ``characteristics.digitized_region`` (the hull vertices that
                     ``hillsim train`` records in nets.json, so the check travels with the file), else the convex
                     hull of the (N11, opening) points of ``flow.csv`` beside the nets.json (files written before
                     the region was recorded); when neither is known the record says so and the run warns;
``full_stroke``      beyond full stroke: the guide-vane stroke above 1 (``governor.stroke_max`` > 1).

A run never extrapolates silently: :func:`extrapolation_record` goes into ``summary.json`` and the CLI warns.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from hillchart.errors import InputError

KINDS = ("training_range", "digitized_region", "full_stroke")
LABELS = {"training_range": "outside the nets' training range",
          "digitized_region": "outside the digitized region of the chart",
          "full_stroke": "beyond full guide-vane stroke"}


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Vertices of the convex hull of 2-D ``points`` (n, 2), counter-clockwise (Andrew's monotone chain).

    Hand-written because ``scipy.spatial`` costs 1-2 s of start-up on every run; 15 lines, tested against
    ``scipy.spatial.ConvexHull``.

    Examples
    --------
    >>> convex_hull(np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]])).tolist()
    [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    """
    pts = np.unique(np.asarray(points, dtype=float), axis=0)
    if len(pts) < 3:
        return pts

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def inside_hull(hull: np.ndarray, x, y, *, scale=(1.0, 1.0)) -> np.ndarray:
    """True where (x, y) lies inside or on the counter-clockwise convex polygon ``hull`` (tolerance 1e-9 of
    ``scale``).

    Examples
    --------
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> inside_hull(square, [0.5, 1.5, 1.0], [0.5, 0.5, 1.0]).tolist()
    [True, False, True]
    """
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    ok = np.empty(x.shape, dtype=bool)
    _inside_hull(np.ascontiguousarray(hull, dtype=float), np.ascontiguousarray(x).ravel(),
                 np.ascontiguousarray(y).ravel(), 1e-9 * scale[0] * scale[1], ok.reshape(-1))
    return ok


@numba.njit(cache=True, nogil=True)
def _inside_hull(hull, x, y, tol, out):
    """Compiled :func:`inside_hull` (a trajectory of thousands of points against a hull of a hundred edges is
    a third of a millisecond in numpy, a run's worth of Python overhead)."""
    n = hull.shape[0]
    for k in range(x.size):
        inside = True
        for i in range(n):
            j = i + 1 if i + 1 < n else 0
            x0, y0, x1, y1 = hull[i, 0], hull[i, 1], hull[j, 0], hull[j, 1]
            if not ((x1 - x0) * (y[k] - y0) - (y1 - y0) * (x[k] - x0) >= -tol):
                inside = False
                break
        out[k] = inside


@dataclass(frozen=True)
class TrustedDomain:
    """The trusted domain of a set of characteristics (any part may be absent: None)."""

    n11_range: tuple[float, float] | None = None
    opening_range: tuple[float, float] | None = None
    hull: np.ndarray | None = None
    hull_source: str = ""
    hull_unknown: str = ""  # why the digitized region cannot be checked (nets without a recorded region), or ""

    def masks(self, n11, opening, stroke) -> dict[str, np.ndarray]:
        """Boolean arrays per kind: True where the point is outside."""
        n11, opening, stroke = (np.asarray(v, dtype=float) for v in (n11, opening, stroke))
        out = {}
        if self.n11_range is not None:
            (n_lo, n_hi), (a_lo, a_hi) = self.n11_range, self.opening_range
            out["training_range"] = (n11 < n_lo) | (n11 > n_hi) | (opening < a_lo) | (opening > a_hi)
        if self.hull is not None and len(self.hull) >= 3:
            span = np.ptp(self.hull, axis=0)
            out["digitized_region"] = ~inside_hull(self.hull, n11, opening, scale=span)
        out["full_stroke"] = stroke > 1.0 + 1e-12
        return out

    def outside_reason(self, n11: float, opening: float, stroke: float, kinds=("training_range", "full_stroke")):
        """Text naming why a single point is outside (kinds checked: ``kinds``), or ``""``."""
        masks = self.masks(n11, opening, stroke)
        reasons = []
        for kind in kinds:
            if kind in masks and bool(np.any(masks[kind])):
                if kind == "training_range":
                    reasons.append(f"{LABELS[kind]} (N11 {self.n11_range[0]:.4g}-{self.n11_range[1]:.4g} r/min, "
                                   f"opening {self.opening_range[0]:.4g}-{self.opening_range[1]:.4g})")
                else:
                    reasons.append(LABELS[kind])
        return "; ".join(reasons)


def _nets_ranges(characteristics):
    lo = hi = None
    for name in ("flow", "torque"):
        net = getattr(characteristics, name, None)
        if net is None or not hasattr(net, "x_min"):
            return None, None
        x_min, x_max = np.asarray(net.x_min, float), np.asarray(net.x_max, float)
        lo = x_min if lo is None else np.maximum(lo, x_min)
        hi = x_max if hi is None else np.minimum(hi, x_max)
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


def digitized_hull_from_folder(folder) -> np.ndarray | None:
    """Hull of the (N11, opening) points of ``folder/flow.csv`` (None when there is no such file)."""
    path = Path(folder) / "flow.csv"
    if not path.is_file():
        return None
    try:
        table = np.genfromtxt(path, delimiter=",", names=True, encoding="utf-8-sig")
        points = np.column_stack((np.asarray(table["n11"], float), np.asarray(table["opening"], float)))
    except (ValueError, KeyError, OSError) as exc:
        raise InputError(f"{path}: cannot read the digitized points for the trusted domain: {exc}") from None
    points = points[np.all(np.isfinite(points), axis=1)]
    return convex_hull(points) if len(points) >= 3 else None


def trusted_domain(characteristics, *, chart_dir=None) -> TrustedDomain:
    """The trusted domain of ``characteristics`` (see module docstring)."""
    n11_range, opening_range = _nets_ranges(characteristics)
    hull, source = None, ""
    region = getattr(characteristics, "digitized_region", None)
    if region is not None:
        hull, source = convex_hull(np.asarray(region, float)), "characteristics.digitized_region"
    elif chart_dir is not None:
        hull = digitized_hull_from_folder(chart_dir)
        source = str(Path(chart_dir) / "flow.csv") if hull is not None else ""
    unknown = ""
    if hull is None and n11_range is not None:  # nets without a recorded region, away from their chart folder
        unknown = ("the digitized region of the chart is unknown (this nets.json records none and there is no "
                   "flow.csv beside it), so leaving the digitized chart is not checked: retrain the nets with "
                   "hillsim train to record it, or keep the nets.json in its chart folder")
    return TrustedDomain(n11_range, opening_range, hull, source, unknown)


def plant_domain(plant, characteristics) -> TrustedDomain:
    """The domain for a plant run: the chart folder is the folder of ``turbine.characteristics`` when that is a
    nets.json path."""
    from simulate.components.turbine.kinds import nets_path

    path = nets_path(plant.turbine.characteristics, plant.base_dir)
    return trusted_domain(characteristics, chart_dir=None if path is None else path.parent)


@numba.njit(cache=True, nogil=True, inline="always")
def _fold(table, row, col, value, lowest):
    """``table[row, col]``: the minimum (``lowest``) or maximum so far with ``value``, NaN once a NaN came (as
    numpy's ``min`` and ``max``)."""
    if value != value:
        table[row, col] = np.nan
    elif lowest and value < table[row, col]:
        table[row, col] = value
    elif not lowest and value > table[row, col]:
        table[row, col] = value


@numba.njit(cache=True, nogil=True)
def _record_numbers(time_s, n11, opening, stroke, masks, figure_times, kinds, shares, spans, intervals):
    """The numbers of :func:`extrapolation_record` in one pass over the trajectory (a few dozen numpy calls on the
    series cost about a third of a millisecond a run, a sixth of a shipped-plant batch case).

    ``masks`` (K, n): True where a point is outside, per kind. Fills ``kinds`` (K, 7): time outside (s; a step
    counts when it ends outside, row j covering (t_{j-1}, t_j]), first index outside (-1: never), then the
    minimum and maximum N11 and opening and the largest stroke outside; ``shares`` (F, K) and ``spans`` (F): per
    figure time, the time outside up to it and the time up to it; ``intervals`` (n, 2): the runs of indices outside
    any kind. Returns the number of runs. Minima and maxima are NaN when a NaN is among their points."""
    n = time_s.size
    n_kinds = masks.shape[0]
    for k in range(n_kinds):
        kinds[k, 0] = 0.0
        kinds[k, 1] = -1.0
        kinds[k, 2], kinds[k, 3] = np.inf, -np.inf
        kinds[k, 4], kinds[k, 5] = np.inf, -np.inf
        kinds[k, 6] = -np.inf
    shares[:, :] = 0.0
    spans[:] = 0.0
    runs = 0
    inside_run = False
    for j in range(n):
        dt = time_s[j] - time_s[j - 1] if j > 0 else 0.0
        if j > 0:
            for f in range(figure_times.size):
                if time_s[j] <= figure_times[f]:
                    spans[f] += dt
        outside = False
        for k in range(n_kinds):
            if not masks[k, j]:
                continue
            outside = True
            if kinds[k, 1] < 0.0:
                kinds[k, 1] = j
            if j > 0:
                kinds[k, 0] += dt
                for f in range(figure_times.size):
                    if time_s[j] <= figure_times[f]:
                        shares[f, k] += dt
            _fold(kinds, k, 2, n11[j], True)
            _fold(kinds, k, 3, n11[j], False)
            _fold(kinds, k, 4, opening[j], True)
            _fold(kinds, k, 5, opening[j], False)
            _fold(kinds, k, 6, stroke[j], False)
        if outside and not inside_run:
            intervals[runs, 0] = j
            runs += 1
        if outside:
            intervals[runs - 1, 1] = j
        inside_run = outside
    return runs


def extrapolation_record(domain: TrustedDomain, time_s, n11, opening, stroke, *, figure_times=None) -> dict:
    """Per kind: fraction of the time outside, first time, extreme N11 and opening reached outside; plus the merged
    intervals (for the plot) and the list of kinds checked.

    ``figure_times`` (``{figure: time_s}``, e.g. when the maximum speed and head come) adds ``figures``:
    per figure and kind, the share of the trajectory up to that time that ran outside (the figure's
    "extrapolation share": how much of what decided it the chart did not show)."""
    time_s = np.ascontiguousarray(time_s, dtype=float)
    series = [np.ascontiguousarray(v if np.shape(v) == time_s.shape else np.broadcast_to(v, time_s.shape),
                                   dtype=float) for v in (n11, opening, stroke)]
    masks = domain.masks(*series)
    names = list(masks)
    stacked = np.stack([masks[name] for name in names])
    figures = dict(figure_times or {})
    kinds, shares = np.empty((len(names), 7)), np.empty((len(figures), len(names)))
    spans, intervals = np.empty(len(figures)), np.empty((time_s.size, 2), dtype=np.int64)
    runs = _record_numbers(time_s, *series, stacked, np.array(list(figures.values()), dtype=float), kinds, shares,
                           spans, intervals)
    record = {"checked": sorted(masks), "intervals_s": []}
    if figure_times:
        record["figures"] = {}
        for f, (name, t_figure) in enumerate(figures.items()):
            span = float(spans[f])
            record["figures"][name] = {"time_s": float(t_figure), **{
                kind: (float(shares[f, k] / span) if span > 0 else 0.0) for k, kind in enumerate(names)}}
    duration = float(time_s[-1] - time_s[0]) if time_s.size > 1 else 0.0
    for k, kind in enumerate(names):
        if kinds[k, 1] < 0.0:
            record[kind] = {"fraction_of_time": 0.0}
            continue
        record[kind] = {"fraction_of_time": float(kinds[k, 0] / duration) if time_s.size > 1 else 1.0,
                        "first_time_s": float(time_s[int(kinds[k, 1])]),
                        "n11_min": float(kinds[k, 2]), "n11_max": float(kinds[k, 3]),
                        "opening_min": float(kinds[k, 4]), "opening_max": float(kinds[k, 5]),
                        "stroke_max": float(kinds[k, 6])}
    if domain.n11_range is not None:
        record["training_n11_range"] = list(domain.n11_range)
        record["training_opening_range"] = list(domain.opening_range)
    if domain.hull_source:
        record["digitized_region_source"] = domain.hull_source
    if domain.hull_unknown:
        record["digitized_region_unknown"] = domain.hull_unknown
    record["intervals_s"] = [[float(time_s[a]), float(time_s[b])] for a, b in intervals[:runs]]
    return record


def units_record(records: dict, figure_units: dict, lead: str) -> dict:
    """The plant-level extrapolation record of a plant with several units (``records``: each unit's
    :func:`extrapolation_record` by name), for the plant-level figures, which are the worst over the units: per kind
    the entry of the unit that spent the longest time outside (the first in ``records``' order on a tie), naming it
    under ``unit``; per figure the shares of the unit that gives it (``figure_units``: figure -> unit, e.g.
    ``max_head_rise`` -> ``"U2"``); the kinds checked, the training ranges and the ``intervals_s`` shaded on the
    plant-level plot (whose series are the ``lead`` unit's) from ``lead``.

    Examples
    --------
    >>> a = {"checked": ["full_stroke"], "full_stroke": {"fraction_of_time": 0.0}, "intervals_s": [],
    ...      "figures": {"max_head_rise": {"time_s": 9.0, "full_stroke": 0.0}}}
    >>> b = {"checked": ["full_stroke"], "full_stroke": {"fraction_of_time": 0.2, "first_time_s": 3.0},
    ...      "intervals_s": [[3.0, 5.0]], "figures": {"max_head_rise": {"time_s": 7.0, "full_stroke": 0.5}}}
    >>> r = units_record({"U1": a, "U2": b}, {"max_head_rise": "U2"}, "U1")
    >>> r["full_stroke"], r["figures"]["max_head_rise"]["full_stroke"], r["intervals_s"]
    ({'fraction_of_time': 0.2, 'first_time_s': 3.0, 'unit': 'U2'}, 0.5, [])
    """
    out = dict(records[lead])
    for kind in KINDS:
        entries = {name: record[kind] for name, record in records.items() if isinstance(record.get(kind), dict)}
        if entries:
            worst = max(entries, key=lambda name: entries[name].get("fraction_of_time", 0.0))
            out[kind] = {**entries[worst], "unit": worst}
    if isinstance(out.get("figures"), dict):
        out["figures"] = {figure: dict(records.get(figure_units.get(figure, lead), out)["figures"].get(figure, shares))
                          for figure, shares in out["figures"].items()}
    return out


def extrapolation_warnings(record: dict) -> list[str]:
    """One line per kind the trajectory entered."""
    from hillchart.io.tidy import tidy_float

    lines = [record["digitized_region_unknown"]] if record.get("digitized_region_unknown") else []
    for kind in KINDS:
        entry = record.get(kind)
        if not entry or entry.get("fraction_of_time", 0.0) <= 0.0 and "first_time_s" not in entry:
            continue
        # tidy_float: a servo closing exponentially leaves openings like 1e-109, printed as 0
        text = (f"{LABELS[kind]} for {100 * entry['fraction_of_time']:.1f} % of the time from t = "
                f"{entry['first_time_s']:.3g} s (N11 {entry['n11_min']:.4g}-{entry['n11_max']:.4g} r/min, opening "
                f"{tidy_float(entry['opening_min']):.4g}-{entry['opening_max']:.4g}, stroke up to "
                f"{entry['stroke_max']:.4g})")
        if kind == "training_range":
            text += (f"; trained on N11 {record['training_n11_range'][0]:.4g}-{record['training_n11_range'][1]:.4g}, "
                     f"opening {record['training_opening_range'][0]:.4g}-{record['training_opening_range'][1]:.4g}: "
                     f"the nets extrapolate there; extend the chart that far (hillsim extend) and retrain")
        elif kind == "digitized_region":
            text += ("; there the figures rest on the chart's extension, not on digitized lines: summary.json "
                     "(extrapolation.figures) gives each figure's share of it, and --uncertainty its band")
        else:
            text += ": no chart line is above full stroke; set governor.stroke_max = 1 unless the chart goes beyond"
        lines.append(text)
    return lines


def point_warnings(characteristics, n11: float, opening: float, *, chart_dir=None, opening_max=None) -> list[str]:
    """Warnings for one operating point (``hillsim linearize``): training range, digitized region, full stroke."""
    domain = trusted_domain(characteristics, chart_dir=chart_dir)
    stroke = opening / opening_max if opening_max else 0.0
    masks = domain.masks(n11, opening, stroke)
    out = []
    for kind in KINDS:
        if kind in masks and bool(np.any(masks[kind])):
            text = f"N11 = {n11:.4g} r/min, opening {opening:.4g} is {LABELS[kind]}"
            if kind == "training_range":
                text += (f" (N11 {domain.n11_range[0]:.4g}-{domain.n11_range[1]:.4g} r/min, opening "
                         f"{domain.opening_range[0]:.4g}-{domain.opening_range[1]:.4g}): the coefficients are an "
                         f"extrapolation; choose a point in that range, or extend the chart and retrain")
            elif kind == "digitized_region":
                text += (": the nets there follow the extension (runaway, zero opening, zero speed), not a digitized "
                         "line; digitize the chart up to this point to rest the coefficients on data")
            elif kind == "full_stroke":
                text += (f" ({opening_max:g}): no chart line is above full stroke; check --opening against "
                         f"turbine.opening_max")
            out.append(text)
    return out
