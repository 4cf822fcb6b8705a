"""Read and validate the points a user digitized from a model hill chart (BP hill-chart paper, section 2.1 (a)-(c)).

A chart folder holds::

    chart.toml       name, opening_unit ("mm" | "deg" | "%"), opening_max, q11_unit ("m3/s" | "l/s"),
                     efficiency_unit ("fraction" | "percent"), optional runner_diameter_m
    flow.csv         opening,n11,q11          points on equal-opening lines          eq. (1)
    efficiency.csv   efficiency,n11,q11       points on iso-efficiency contours      eq. (2)
    runaway.csv      opening,n11,q11          points of the runaway curve (optional) eq. (3)

:func:`load_chart` returns a :class:`ChartSamples` with Q11 in m^3/s, efficiency as a fraction, N11 in r/min and the
opening in the chart's own unit. Anything wrong is an :class:`~hillchart.errors.InputError` naming the file, the row
(line number in the file, header = line 1) and the column.
"""

from __future__ import annotations

import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hillchart.errors import InputError

OPENING_UNITS = ("mm", "deg", "%")
#: Largest plausible full-stroke opening per unit (the largest units open their guide vanes about 1 m, 45 deg).
OPENING_MAX_PLAUSIBLE = {"mm": 3000.0, "deg": 90.0, "%": 150.0}
#: Efficiencies above this are implausible for a turbine (the best reach about 0.96): warned, not refused.
EFFICIENCY_PLAUSIBLE = 0.98
Q11_UNITS = {"m3/s": 1.0, "l/s": 1e-3}
EFFICIENCY_UNITS = {"fraction": 1.0, "percent": 1e-2}
REQUIRED_KEYS = ("name", "opening_unit", "opening_max", "q11_unit", "efficiency_unit")
OPTIONAL_KEYS = ("runner_diameter_m",)
FILES = {
    "flow.csv": ("opening", "n11", "q11"),
    "efficiency.csv": ("efficiency", "n11", "q11"),
    "runaway.csv": ("opening", "n11", "q11"),
}
#: Fewest points an equal-opening line needs (a quadratic through it must be determined).
MIN_POINTS_PER_LINE = 3
#: Most points a chart file may hold (a digitized chart has hundreds; training time grows with the count).
MAX_POINTS_PER_FILE = 20000
#: Upper limits of values in the file's units (N11 of any turbine chart is below 1000 r/min; Q11 below 100 000 in
#: either unit); far beyond them the numerics overflow.
N11_MAX_RPM = 1000.0
Q11_MAX = {"m3/s": 100000.0, "l/s": 100000.0}  # m3/s as l/s too: the plausibility check names the unit mix-up


@dataclass(frozen=True)
class ChartInfo:
    """The contents of ``chart.toml``."""

    name: str
    opening_unit: str
    opening_max: float
    q11_unit: str
    efficiency_unit: str
    runner_diameter_m: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError(f"chart.toml: name must be a non-empty string, got {self.name!r}")
        for key in ("opening_unit", "q11_unit", "efficiency_unit"):
            value = getattr(self, key)
            if not isinstance(value, str):  # a list or table would fail the lookups below with a TypeError
                allowed = {"opening_unit": OPENING_UNITS, "q11_unit": tuple(Q11_UNITS),
                           "efficiency_unit": tuple(EFFICIENCY_UNITS)}[key]
                raise InputError(f"chart.toml: {key} must be a string, one of {allowed}, got {value!r}")
        if self.opening_unit not in OPENING_UNITS:
            raise InputError(f"chart.toml: opening_unit must be one of {OPENING_UNITS}, got {self.opening_unit!r}")
        if self.q11_unit not in Q11_UNITS:
            raise InputError(f"chart.toml: q11_unit must be one of {tuple(Q11_UNITS)}, got {self.q11_unit!r}")
        if self.efficiency_unit not in EFFICIENCY_UNITS:
            raise InputError(
                f"chart.toml: efficiency_unit must be one of {tuple(EFFICIENCY_UNITS)}, got {self.efficiency_unit!r}"
            )
        _positive_number("chart.toml: opening_max", self.opening_max)
        top = OPENING_MAX_PLAUSIBLE[self.opening_unit]
        if self.opening_max > top:  # a typo or another unit (1e5 mm is a 100 m guide-vane opening)
            raise InputError(f"chart.toml: opening_max = {self.opening_max!r} {self.opening_unit} is implausible: a "
                             f"guide-vane opening in {self.opening_unit} is at most about {top:g}; check the value "
                             "and opening_unit")
        if self.runner_diameter_m is not None:
            _positive_number("chart.toml: runner_diameter_m", self.runner_diameter_m)


def _positive_number(label: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
        raise InputError(f"{label} must be a finite number > 0, got {value!r}")


@dataclass(frozen=True)
class ChartSamples:
    """Validated, unit-normalized hill-chart samples.

    Attributes
    ----------
    info : ChartInfo
    flow_opening, flow_n11, flow_q11 : ndarray (F,)
        Equal-opening line points: opening (chart unit), N11 (r/min), Q11 (m^3/s).
    eff_efficiency, eff_n11, eff_q11 : ndarray (E,)
        Iso-efficiency contour points: efficiency (fraction), N11 (r/min), Q11 (m^3/s).
    runaway_opening, runaway_n11, runaway_q11 : ndarray (R,)
        Runaway curve points (R = 0 when the chart has no runaway file).
    folder : Path
    rows : dict or None
        ``{"flow": ..., "eff": ..., "runaway": ...}``: the line number in its file of every point (for messages).
    """

    info: ChartInfo
    flow_opening: np.ndarray
    flow_n11: np.ndarray
    flow_q11: np.ndarray
    eff_efficiency: np.ndarray
    eff_n11: np.ndarray
    eff_q11: np.ndarray
    runaway_opening: np.ndarray
    runaway_n11: np.ndarray
    runaway_q11: np.ndarray
    folder: Path
    rows: dict | None = None

    @property
    def has_runaway(self) -> bool:
        return self.runaway_n11.size > 0

    @property
    def openings(self) -> np.ndarray:
        """The distinct openings of the equal-opening lines, ascending."""
        return np.unique(self.flow_opening)

    def per_line(self, values: np.ndarray):
        """``(opening, n11, values)`` of each equal-opening line, lowest opening first, sorted by N11; ``values``
        are per flow point (e.g. the flow points' Q11 or torque)."""
        values = np.asarray(values)
        for opening in self.openings:
            m = self.flow_opening == opening
            order = np.argsort(self.flow_n11[m])
            yield opening, self.flow_n11[m][order], values[m][order]


def read_chart_info(path) -> ChartInfo:
    """Read and validate ``chart.toml``."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: missing file (a chart folder needs chart.toml)")
    from hillchart.io.tabular import read_text

    try:
        data = tomllib.loads(read_text(path, "chart.toml"))  # a byte-order mark is accepted
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"{path}: not a chart.toml: arrays or tables nested thousands of levels deep") from None
    unknown = sorted(set(data) - set(REQUIRED_KEYS) - set(OPTIONAL_KEYS))
    if unknown:
        raise InputError(
            f"{path}: unknown key(s) {unknown}; valid keys are {list(REQUIRED_KEYS + OPTIONAL_KEYS)}"
        )
    missing = [key for key in REQUIRED_KEYS if key not in data]
    if missing:
        raise InputError(f"{path}: missing required key(s) {missing}")
    return ChartInfo(**data)


def _read_csv(path: Path, columns: tuple[str, ...]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Read a numeric CSV with exactly ``columns`` (any order); errors name file, row (line number) and column.
    Returns the columns and the line number of every data row. A byte-order mark, semicolon/tab delimiters and
    decimal commas are handled by :func:`hillchart.io.tabular.read_table` (how an unusual file was read is a
    UserWarning)."""
    from hillchart.io.tabular import read_table

    table = read_table(path, columns)
    if table.note:
        warnings.warn(table.note, UserWarning, stacklevel=3)
    if len(table.lines) > MAX_POINTS_PER_FILE:
        raise InputError(f"{path}: {len(table.lines)} rows; a digitized chart file has at most "
                         f"{MAX_POINTS_PER_FILE} points (thin the export)")
    return dict(table.columns), np.asarray(table.lines, dtype=int)


def _check_range(path: Path, name: str, values: np.ndarray, ok: np.ndarray, allowed: str,
                 rows: np.ndarray | None = None) -> None:
    bad = np.flatnonzero(~ok)
    if bad.size:
        i = bad[0]
        row = int(rows[i]) if rows is not None else i + 2
        hint = ""
        if name == "efficiency" and "fraction" in allowed and np.all((values > 1) & (values <= 100)):
            hint = " (the values look like percent: set efficiency_unit = \"percent\" in chart.toml)"
        raise InputError(
            f"{path}: row {row}, column {name!r}: {float(values[i])!r} is out of range; allowed {allowed}{hint}"
        )


def _check_duplicates(path: Path, table: dict[str, np.ndarray], rows=None) -> None:
    stacked = np.column_stack(list(table.values()))
    _, first, counts = np.unique(stacked, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 1):
        row = stacked[first[counts > 1][0]]
        where = np.flatnonzero(np.all(stacked == row, axis=1))
        where = rows[where] if rows is not None else where + 2
        raise InputError(f"{path}: duplicate point {dict(zip(table, row.tolist()))} at rows {where.tolist()}")


def _validate_points(path: Path, table: dict[str, np.ndarray], info: ChartInfo, rows=None) -> None:
    _check_range(path, "n11", table["n11"], (table["n11"] >= 0) & (table["n11"] <= N11_MAX_RPM),
                 f"n11 >= 0 and n11 <= {N11_MAX_RPM:g} r/min", rows)
    q_max = Q11_MAX[info.q11_unit]
    _check_range(path, "q11", table["q11"], (table["q11"] >= 0) & (table["q11"] <= q_max),
                 f"q11 >= 0 and q11 <= {q_max:g} {info.q11_unit}", rows)
    if "opening" in table:
        op = table["opening"]
        _check_range(path, "opening", op, (op >= 0) & (op <= info.opening_max), f"0 <= opening <= {info.opening_max}",
                     rows)
    if "efficiency" in table:
        eta = table["efficiency"] * EFFICIENCY_UNITS[info.efficiency_unit]
        full = "1" if info.efficiency_unit == "fraction" else "100"
        allowed = f"(0, {full}] ({info.efficiency_unit})"
        _check_range(path, "efficiency", table["efficiency"], (eta > 0) & (eta <= 1), allowed, rows)
        _check_range(path, "n11", table["n11"], table["n11"] > 0,
                     "n11 > 0 on an efficiency contour (the efficiency is 0 at standstill)", rows)
        high = np.flatnonzero(eta > EFFICIENCY_PLAUSIBLE)
        if high.size:
            row = int(rows[high[0]]) if rows is not None else int(high[0]) + 2
            warnings.warn(f"{path}: row {row}: efficiency {float(table['efficiency'][high[0]])!r} is implausible "
                          f"(the best turbines reach about 0.96; above {EFFICIENCY_PLAUSIBLE} is kept but suspect): "
                          "check the contour value", UserWarning, stacklevel=3)
    _check_duplicates(path, table, rows)


def load_chart(folder) -> ChartSamples:
    """Read a chart folder into validated, unit-normalized :class:`ChartSamples`.

    ``runaway.csv`` is optional: without it a :class:`UserWarning` says that the runaway boundary will be missing.
    The flow and runaway points come in their natural order, by opening and then N11, whatever the files' order
    (``rows`` still names each point's line in its file); the contour points keep the file's order.

    Examples
    --------
    >>> from data_synthetic import FRANCIS_DIR
    >>> chart = load_chart(FRANCIS_DIR)
    >>> chart.info.opening_unit, chart.openings.size >= 8, chart.has_runaway
    ('mm', True, True)
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a chart folder (no such directory)")
    info = read_chart_info(folder / "chart.toml")
    tables, line_numbers = {}, {}
    for name, columns in FILES.items():
        path = folder / name
        if not path.is_file():
            if name == "runaway.csv":
                warnings.warn(f"{path} is absent: the runaway boundary (M11 = 0) comes from the fitted turbine model "
                              "(extension boundaries='model', the default) or is not added ('polynomial')",
                              UserWarning, stacklevel=2)
                tables[name] = {c: np.empty(0) for c in columns}
                line_numbers[name] = np.zeros(0, int)
                continue
            raise InputError(f"{path}: missing file "
                             f"(a chart folder needs {', '.join(n for n in FILES if n != 'runaway.csv')})")
        table, line_numbers[name] = _read_csv(path, columns)
        _validate_points(path, table, info, line_numbers[name])
        if name == "runaway.csv":  # an open runner passes flow at runaway
            _check_range(path, "q11", table["q11"], (table["q11"] > 0) | (table["opening"] == 0),
                         "q11 > 0 where the opening is above 0 (an open runner passes flow at runaway)",
                         line_numbers[name])
        tables[name] = table
    # the lines' points in their natural order, opening then N11 (a stable sort: the row numbers follow), so that
    # what is fitted and chosen from them (cross-validation folds, held-out points) depends on the points and not on
    # the order the digitizer exported them in; the contours keep the file's order (along each contour)
    for name in ("flow.csv", "runaway.csv"):
        order = np.lexsort((tables[name]["n11"], tables[name]["opening"]))
        tables[name] = {column: values[order] for column, values in tables[name].items()}
        line_numbers[name] = line_numbers[name][order]
    flow = tables["flow.csv"]
    lines, counts = np.unique(flow["opening"], return_counts=True)
    if np.any(counts < MIN_POINTS_PER_LINE):
        short = lines[counts < MIN_POINTS_PER_LINE]
        raise InputError(
            f"{folder / 'flow.csv'}: the equal-opening line(s) at opening {short.tolist()} have fewer than "
            f"{MIN_POINTS_PER_LINE} points (counts {counts[counts < MIN_POINTS_PER_LINE].tolist()})"
        )
    q_scale = Q11_UNITS[info.q11_unit]
    eff = tables["efficiency.csv"]
    run = tables["runaway.csv"]
    return ChartSamples(
        info=info,
        flow_opening=flow["opening"],
        flow_n11=flow["n11"],
        flow_q11=flow["q11"] * q_scale,
        eff_efficiency=eff["efficiency"] * EFFICIENCY_UNITS[info.efficiency_unit],
        eff_n11=eff["n11"],
        eff_q11=eff["q11"] * q_scale,
        runaway_opening=run["opening"],
        runaway_n11=run["n11"],
        runaway_q11=run["q11"] * q_scale,
        folder=folder,
        rows={"flow": line_numbers["flow.csv"], "eff": line_numbers["efficiency.csv"],
              "runaway": line_numbers["runaway.csv"]},
    )


def measured_region_mask(measured_n11, measured_opening, n11, opening) -> np.ndarray:
    """True where (N11, a) lies inside the convex hull of the measured (digitized) flow samples.

    This is the chart's "measured region": where the chart itself has data.

    Examples
    --------
    >>> measured_region_mask([0, 1, 0, 1], [0, 0, 1, 1], [0.5, 2.0], [0.5, 0.5]).tolist()
    [True, False]
    """
    from scipy.spatial import Delaunay

    hull = Delaunay(np.column_stack([np.asarray(measured_n11, float), np.asarray(measured_opening, float)]))
    points = np.column_stack([np.ravel(n11), np.ravel(opening)]).astype(float)
    return (hull.find_simplex(points) >= 0).reshape(np.shape(n11))
