"""Test tables of a double-regulated turbine: a folder with ``table.csv`` and ``table.toml`` -> :class:`TestTable`
(n11 and Q11 derived by eqs. (1)-(2) of Wu et al. when the table has head, flow and speed)."""

from __future__ import annotations

import math
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hillchart.errors import InputError
from hillchart.io.tabular import decimal_commas, numbered_rows, parse_number, read_text, without_empty_trailing_columns

# ----------------------------------------------------------------------------------------------------------------
# test-table folder
# ----------------------------------------------------------------------------------------------------------------
TABLE_FILE = "table.csv"
INFO_FILE = "table.toml"
REQUIRED_KEYS = ("name", "controls")
OPTIONAL_KEYS = ("runner_diameter_m", "speed_rpm")
#: Columns with a meaning (units in the names) and the values they allow; any other column is allowed too.
KNOWN_COLUMNS = {
    "blade_angle_deg": ("runner-blade angle, deg", lambda v: np.abs(v) <= 180.0, "[-180, 180] deg"),
    "guide_vane_deg": ("guide-vane angle, deg", lambda v: np.abs(v) <= 180.0, "[-180, 180] deg"),
    "n11_rpm": ("unit speed n D / sqrt(H), r/min", lambda v: v >= 0, ">= 0 r/min"),
    "q11_m3_s": ("unit flow Q / (D^2 sqrt(H)), m^3/s", lambda v: v >= 0, ">= 0 m^3/s"),
    "efficiency": ("efficiency, fraction", lambda v: (v >= 0) & (v <= 1), "[0, 1] (a fraction, not percent)"),
    "head_m": ("net head, m", lambda v: v > 0, "> 0 m"),
    "power_kw": ("shaft power, kW", lambda v: np.isfinite(v), "finite kW"),
    "flow_m3_s": ("discharge, m^3/s", lambda v: v >= 0, ">= 0 m^3/s"),
    "speed_rpm": ("rotational speed, r/min", lambda v: v > 0, "> 0 r/min"),
}


@dataclass(frozen=True)
class TableInfo:
    """The contents of ``table.toml``.

    Attributes
    ----------
    name : str
    controls : tuple of str
        Column names of the controls (e.g. blade and guide-vane angle), the comparison sequences of the grey
        relational analysis.
    runner_diameter_m : float or None
        D for eqs. (1)-(2) of paper 003 when the table has no n11 / Q11 columns.
    speed_rpm : float or None
        Constant test speed when the table has no ``speed_rpm`` column.
    """

    name: str
    controls: tuple
    runner_diameter_m: float | None = None
    speed_rpm: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError(f"{INFO_FILE}: name must be a non-empty string, got {self.name!r}")
        controls = self.controls
        if (not isinstance(controls, (list, tuple)) or not controls
                or not all(isinstance(c, str) and c.strip() for c in controls)):
            raise InputError(f"{INFO_FILE}: controls must be a non-empty list of column names, got {controls!r}")
        if len(set(controls)) != len(controls):
            raise InputError(f"{INFO_FILE}: controls must be distinct, got {list(controls)!r}")
        object.__setattr__(self, "controls", tuple(controls))
        for key in OPTIONAL_KEYS:
            value = getattr(self, key)
            if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))
                                      or not math.isfinite(value) or value <= 0):
                raise InputError(f"{INFO_FILE}: {key} must be a finite number > 0, got {value!r}")


def read_table_info(path) -> TableInfo:
    """Read and validate ``table.toml`` (exactly the keys name, controls, optional runner_diameter_m, speed_rpm)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: missing file (a test-table folder needs {TABLE_FILE} and {INFO_FILE})")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8-sig"))  # a byte-order mark is accepted
    except UnicodeDecodeError as exc:
        from hillchart.io.tabular import not_utf8_detail

        raise InputError(f"{path}: not a UTF-8 text file {not_utf8_detail(exc)}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"{path}: not a table.toml: arrays or tables nested thousands of levels deep") from None
    unknown = sorted(set(data) - set(REQUIRED_KEYS) - set(OPTIONAL_KEYS))
    if unknown:
        raise InputError(f"{path}: unknown key(s) {unknown}; valid keys are {list(REQUIRED_KEYS + OPTIONAL_KEYS)}")
    missing = [key for key in REQUIRED_KEYS if key not in data]
    if missing:
        raise InputError(f"{path}: missing required key(s) {missing}")
    try:
        return TableInfo(**data)
    except InputError as exc:
        raise InputError(f"{path}: {str(exc).removeprefix(INFO_FILE + ': ')}") from None


@dataclass(frozen=True)
class TestTable:
    """A validated test table: numeric columns by name (units in the names), the table.toml contents.

    Attributes
    ----------
    info : TableInfo
    columns : dict of str -> ndarray (n,)
        Every numeric column of ``table.csv`` plus the derived ones.
    derived : tuple of str
        Columns computed by the loader (``n11_rpm``, ``q11_m3_s``), not read.
    text_columns : tuple of str
        Extra columns that are not numeric (kept out of ``columns``).
    folder : Path
    """

    __test__ = False  # not a pytest test class

    info: TableInfo
    columns: dict
    derived: tuple
    text_columns: tuple
    folder: Path

    @property
    def n_rows(self) -> int:
        return int(next(iter(self.columns.values())).size)

    def column(self, name: str) -> np.ndarray:
        """One numeric column; the error names what is available."""
        if name in self.columns:
            return self.columns[name]
        why = " (it is not numeric)" if name in self.text_columns else ""
        hint = ""
        if name in ("n11_rpm", "q11_m3_s"):
            hint = ("; it is derived only when the table has head_m and flow_m3_s (Q11) or a speed (n11: speed_rpm "
                    "column or key) and table.toml has runner_diameter_m")
        raise InputError(f"{self.folder / TABLE_FILE}: no numeric column {name!r}{why}; available: "
                         f"{', '.join(self.columns)}{hint}")

    def matrix(self, names) -> np.ndarray:
        """Columns ``names`` side by side, (n, len(names))."""
        return np.column_stack([self.column(n) for n in names])


#: Plausible ranges of the quantities a model-test table gives in fixed units: unit flow Q11 (m^3/s, eq. (1) of
#: paper 003), efficiency P / (rho g Q H) from the power column, angles (deg).
Q11_PLAUSIBLE_M3_S = 10.0
ANGLE_SPAN_MIN_DEG = 3.2
#: Net heads of double-regulated turbines (Kaplan up to about 80 m, bulb below about 30 m) and of their model rigs
#: (IEC 60193 tests, a few to some tens of metres) lie below this; a median above it is a head in kPa (x 9.81) or Pa.
HEAD_PLAUSIBLE_M = 100.0
G_KPA_PER_M = 9.81  # 1 m of water = 9.81 kPa


def unit_warnings(columns: dict, path) -> list[str]:
    """Warnings for columns whose values look like another unit than their name says: flow in l/s (Q11 1000 x too
    large), power in W or MW (efficiency 1000 x off), head in kPa or Pa (a median above
    :data:`HEAD_PLAUSIBLE_M`, or P / (rho g Q H) 9.81 x below the efficiency column), angles in radians (a control
    spanning less than pi)."""
    out = []
    head = columns.get("head_m")
    head_scale, head_note = 1.0, ""
    if head is not None and np.median(head) > HEAD_PLAUSIBLE_M:
        median = float(np.median(head))
        unit, factor = (("kPa", G_KPA_PER_M) if median / G_KPA_PER_M <= HEAD_PLAUSIBLE_M else
                        ("Pa", 1e3 * G_KPA_PER_M))
        out.append(f"{path}: head_m has a median of {median:.4g} m; double-regulated turbines (Kaplan, bulb) and "
                   f"their model rigs run at heads below about {HEAD_PLAUSIBLE_M:g} m: is the head in {unit} (divide "
                   f"by {factor:g} to give metres of water)?")
        # the power and the flow are judged against the head in metres: a head in kPa must not blame them too
        head_scale, head_note = 1.0 / factor, f" with the head divided by {factor:g}"
    q11 = columns.get("q11_m3_s")
    flow_scale, flow_note = 1.0, ""
    if q11 is not None and np.median(np.abs(q11)) > Q11_PLAUSIBLE_M3_S:
        out.append(f"{path}: flow_m3_s gives a median unit flow Q11 = {float(np.median(q11)):.4g} m^3/s; turbines "
                   f"have Q11 below about {Q11_PLAUSIBLE_M3_S:g}: is the flow in l/s (divide by 1000)?")
        # the power is judged against the flow in m^3/s: a flow in l/s alone must not blame the power too
        flow_scale, flow_note = 1e-3, " with the flow divided by 1000"
    if all(k in columns for k in ("power_kw", "flow_m3_s", "head_m")):
        with np.errstate(divide="ignore", invalid="ignore"):
            eta = columns["power_kw"] * 1e3 / (1000.0 * 9.81 * flow_scale * columns["flow_m3_s"] * head_scale
                                                * columns["head_m"])
        median = float(np.nanmedian(eta)) if np.any(np.isfinite(eta)) else float("nan")
        stated = float(np.median(columns["efficiency"])) if "efficiency" in columns else float("nan")
        if median > 2.0 or median < 0.02:
            guess = "W (divide by 1000)" if median > 2.0 else "MW (multiply by 1000)"
            out.append(f"{path}: power_kw gives a median efficiency P / (rho g Q H) = {median:.4g}{flow_note}"
                       f"{head_note}, not 0.3-0.95: is the power in {guess}?")
        elif not head_note and 0.7 * G_KPA_PER_M < stated / median < 1.4 * G_KPA_PER_M:
            # a low-head rig's head in kPa stays below HEAD_PLAUSIBLE_M; the efficiency column tells it (x 9.81)
            out.append(f"{path}: power_kw, flow_m3_s and head_m give a median efficiency P / (rho g Q H) = "
                       f"{median:.4g}{flow_note}, {stated / median:.3g} x below the efficiency column's {stated:.4g}: "
                       f"is the head in kPa (divide by {G_KPA_PER_M:g} to give metres of water)?")
    for name, values in columns.items():
        if name.endswith("_deg") and values.size > 1 and 0 < np.ptp(values) and np.max(np.abs(values)) < \
                ANGLE_SPAN_MIN_DEG:
            out.append(f"{path}: column {name!r} spans {float(np.min(values)):.4g} to {float(np.max(values)):.4g}, "
                       "less than pi: are the angles in radians (multiply by 180/pi)?")
    return out


#: A point's efficiency is named as an outlier when it departs from the local linear fit through its nearest points
#: (controls and n11, each scaled to its span) by more than this and by more than EFFICIENCY_OUTLIER_SIGMAS robust
#: standard deviations of all departures. A rig's scatter is below 0.01 (IEC 60193: about 0.2-0.3 %); on the
#: synthetic bulb table (150 points, 0.3 % noise) the chart's curvature gives departures up to 0.033.
EFFICIENCY_OUTLIER = 0.1
EFFICIENCY_OUTLIER_SIGMAS = 8.0
EFFICIENCY_OUTLIERS_NAMED = 5


def efficiency_outliers(columns: dict, controls, lines, path) -> list[str]:
    """Warnings naming the rows whose efficiency lies far from their neighbours' (a typo such as 0.45 for 0.85),
    worst first, each found with the ones before it left out; none when the table has no efficiency column or
    fewer than three neighbourhoods of points."""
    eff = columns.get("efficiency")
    names = [n for n in dict.fromkeys([*controls, "n11_rpm"]) if n in columns and np.ptp(columns[n]) > 0]
    if eff is None or not names:
        return []
    k = 2 * (len(names) + 1) + 2  # twice the parameters of the local plane, and two more
    if eff.size < 3 * k:
        return []
    from scipy.spatial import cKDTree

    x = np.column_stack([(columns[n] - columns[n].min()) / np.ptp(columns[n]) for n in names])
    keep = np.arange(eff.size)
    out = []
    for _ in range(EFFICIENCY_OUTLIERS_NAMED):
        xs, es = x[keep], eff[keep]
        _, nb = cKDTree(xs).query(xs, k=k + 1)
        own = nb == np.arange(keep.size)[:, None]
        nb = np.take_along_axis(nb, np.argsort(~own, axis=1, kind="stable"), axis=1)[:, 1:]  # the point itself out
        a = np.concatenate([np.ones((keep.size, k, 1)), xs[nb] - xs[:, None, :]], axis=2)
        fit = (np.linalg.pinv(a) @ es[nb][:, :, None])[:, 0, 0]  # the local plane at the point
        departure = es - fit
        limit = max(EFFICIENCY_OUTLIER, EFFICIENCY_OUTLIER_SIGMAS * 1.4826 * float(np.median(np.abs(departure))))
        worst = int(np.argmax(np.abs(departure)))
        if abs(departure[worst]) <= limit:
            break
        out.append(f"{path}: row {int(lines[keep[worst]])}: efficiency {float(es[worst]):.4g} is "
                   f"{float(departure[worst]):+.3g} from the {float(fit[worst]):.4g} of its {k} nearest points in "
                   f"({', '.join(names)}); neighbouring points of a test differ by less than {limit:.2g}: correct "
                   "the row (a typo?) or remove it")
        keep = np.delete(keep, worst)
    return out


def load_test_table(folder) -> TestTable:
    """Read a test-table folder (``table.csv`` + ``table.toml``) into a validated :class:`TestTable`.

    ``table.csv``: one header line naming the columns (units in the names, any order, extra columns allowed;
    lines starting with ``#`` are comments), one row per measured operating point. Known columns
    (:data:`KNOWN_COLUMNS`) must be numeric and in range; efficiency is a fraction. When ``n11_rpm`` is absent it is
    derived as ``n D / sqrt(H)`` (eq. (2), paper 003) from ``head_m``, the speed (``speed_rpm`` column or key) and
    ``runner_diameter_m``; ``q11_m3_s`` as ``Q / (D^2 sqrt(H))`` (eq. (1)) from ``flow_m3_s`` and ``head_m``.

    Raises
    ------
    InputError
        Naming the file, the row (line number, header = 1) and the column: missing file, bad TOML key, empty
        file, repeated or empty column name, a row with the wrong number of fields, a non-numeric or non-finite
        value in a known column, a value out of range, a control that is not a numeric column or is constant,
        a speed given both as column and key.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "table.toml").write_text('name = "t"\\nrunner_diameter_m = 2.0\\nspeed_rpm = 100.0\\n'
    ...                                   'controls = ["guide_vane_deg"]\\n')
    >>> _ = (d / "table.csv").write_text("guide_vane_deg,head_m,flow_m3_s\\n40,4,8\\n50,9,12\\n")
    >>> t = load_test_table(d)
    >>> t.column("n11_rpm").tolist(), t.column("q11_m3_s").tolist(), t.derived
    ([100.0, 66.66666666666667], [1.0, 1.0], ('n11_rpm', 'q11_m3_s'))
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a test-table folder (no such directory)")
    info = read_table_info(folder / INFO_FILE)
    path = folder / TABLE_FILE
    if not path.is_file():
        raise InputError(f"{path}: missing file (a test-table folder needs {TABLE_FILE} and {INFO_FILE})")
    # a byte-order mark, and a spreadsheet's semicolon- or tab-separated export with decimal commas, are read as
    # every hillsim CSV is (hillchart.io.tabular)
    delimiter, rows = numbered_rows(read_text(path, "test table"), path, comments=True)
    if not rows:
        raise InputError(f"{path}: empty file; expected a header line such as "
                         "blade_angle_deg,guide_vane_deg,efficiency,head_m,power_kw,flow_m3_s")
    header_no, header = rows[0]
    # names of known columns match whatever their case ("Guide_Vane_Deg"); a spreadsheet's empty trailing column is
    # dropped (hillchart.io.tabular)
    known = {name.lower(): name for name in KNOWN_COLUMNS}
    header, body = without_empty_trailing_columns([name.strip() for name in header], rows[1:])
    header = [known.get(name.lower(), name) for name in header]
    rows = [rows[0], *body]
    if any(not name for name in header):
        raise InputError(f"{path}: row {header_no}: empty column name in header {header}")
    repeated = sorted({name for name in header if header.count(name) > 1})
    if repeated:
        raise InputError(f"{path}: row {header_no}: repeated column name(s) {repeated}")
    cells = {name: [] for name in header}
    line_numbers = []
    for line_no, row in rows[1:]:
        if len(row) != len(header):
            raise InputError(f"{path}: row {line_no} has {len(row)} fields, the header has {len(header)}")
        line_numbers.append(line_no)
        for name, cell in zip(header, row):
            cells[name].append(cell.strip())
    if not line_numbers:
        raise InputError(f"{path}: no data rows below the header")
    decimal_comma, note = decimal_commas(path, delimiter, (c for name in header if name in KNOWN_COLUMNS
                                                           for c in cells[name]))
    if note:
        warnings.warn(note, UserWarning, stacklevel=2)
    columns, text_columns = {}, []
    for name in header:
        if name in KNOWN_COLUMNS:
            values = np.array([parse_number(path, no, name, c, decimal_comma=decimal_comma)
                               for no, c in zip(line_numbers, cells[name])])
            _, ok, allowed = KNOWN_COLUMNS[name]
            bad = np.flatnonzero(~ok(values))
            if bad.size:
                i = bad[0]
                raise InputError(f"{path}: row {line_numbers[i]}, column {name!r}: {float(values[i])!r} is out of "
                                 f"range; allowed {allowed}")
            columns[name] = values
        else:  # extra column: numeric if every cell is a finite number, else kept out as text
            if any("_" in c for c in cells[name]):  # float() reads '4_4' as 44: a typo, kept out as text
                text_columns.append(name)
                continue
            try:
                values = np.array([float(c.replace(",", ".") if decimal_comma else c) for c in cells[name]])
            except ValueError:
                text_columns.append(name)
                continue
            if np.all(np.isfinite(values)):
                columns[name] = values
            else:
                text_columns.append(name)
    derived = []
    if "speed_rpm" in columns and info.speed_rpm is not None:
        raise InputError(f"{folder / INFO_FILE}: speed_rpm = {info.speed_rpm!r} is given but {path} also has a "
                         "speed_rpm column; give the speed in one place only")
    speed = columns.get("speed_rpm", info.speed_rpm)  # column or key; None when neither (no n11 derivation)
    d = info.runner_diameter_m
    if "head_m" in columns and d is not None:
        sqrt_h = np.sqrt(columns["head_m"])
        if "n11_rpm" not in columns and speed is not None:
            columns["n11_rpm"] = np.broadcast_to(speed, sqrt_h.shape) * d / sqrt_h  # eq. (2), paper 003
            derived.append("n11_rpm")
        if "q11_m3_s" not in columns and "flow_m3_s" in columns:
            columns["q11_m3_s"] = columns["flow_m3_s"] / (d * d * sqrt_h)  # eq. (1), paper 003
            derived.append("q11_m3_s")
    table = TestTable(info=info, columns=columns, derived=tuple(derived), text_columns=tuple(text_columns),
                      folder=folder)
    for text in unit_warnings(columns, path) + efficiency_outliers(columns, info.controls, line_numbers, path):
        warnings.warn(text, UserWarning, stacklevel=2)
    for control in info.controls:
        if control not in columns:
            raise InputError(f"{folder / INFO_FILE}: controls: {control!r} is not a numeric column of {path} "
                             f"(columns: {', '.join(columns)})")
        if np.ptp(columns[control]) == 0:
            raise InputError(f"{path}: column {control!r} (a control) is constant ({columns[control][0]!r}); a "
                             "control must vary over the test")
    return table
