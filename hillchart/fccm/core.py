"""Full characteristic curve map (FCCM) of a double-regulated turbine: test tables, a multi-output BP net and the
analyses of paper 003 (Wu et al., "Advanced modelling of full characteristic curve of tubular turbine based on
back-propagation neural network").

Pieces
------
:func:`load_test_table`
    A test-table folder (``table.csv`` + ``table.toml``) -> :class:`TestTable`, with n11 and Q11 derived from
    eqs. (1)-(2) of paper 003 when the table has head, flow and speed instead.
:class:`FCCMNet`
    scikit-learn style estimator: one logsig hidden layer, linear outputs, several outputs at once, trained by the
    Levenberg-Marquardt code of :mod:`hillchart.nets.lm`; hidden size from eq. (3) with C chosen by validation; the
    paper's seeded 30/35/35 train/validation/test split, validation stop, multi-start.
:class:`FCCMWeights`
    The exported net (``fccm_nets.json``); evaluation is plain numpy (no torch).
Analyses
    :func:`efficiency_maps` (Fig. 4), :func:`grey_images` and :func:`image_similarity` (eqs. (4)-(5), Figs. 5-6),
    :func:`grey_relational_analysis` (Table 1), :func:`truth_comparison` (net vs linear interpolation against an
    exact grid), the figures (:func:`plot_efficiency_maps`, :func:`plot_control_maps` (Fig. 7),
    :func:`plot_operating_characteristic` (Fig. 8)), and the three-input hill chart of a double-regulated turbine
    (:func:`train_double_regulated_nets`, :func:`on_cam_relation`).

Torch is imported only inside :meth:`FCCMNet.fit`; matplotlib and scipy only where a function needs them.
"""

from __future__ import annotations

import csv
import json
import math
import shutil
import tempfile
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hillchart.errors import InputError, NumericalError

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
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
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


def _parse_cell(path: Path, line_no: int, column: str, cell: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        raise InputError(f"{path}: row {line_no}, column {column!r}: not a number: {cell!r}") from None
    if not math.isfinite(value):
        raise InputError(f"{path}: row {line_no}, column {column!r}: value must be finite, got {cell!r}")
    return value


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
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            lines = [(no, line) for no, line in enumerate(handle, start=1) if not line.lstrip().startswith("#")]
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file ({exc})") from None
    rows = [(no, row) for (no, _), row in zip(lines, csv.reader(line for _, line in lines))]
    rows = [(no, row) for no, row in rows if row and any(cell.strip() for cell in row)]
    if not rows:
        raise InputError(f"{path}: empty file; expected a header line such as "
                         "blade_angle_deg,guide_vane_deg,efficiency,head_m,power_kw,flow_m3_s")
    header_no, header = rows[0]
    header = [name.strip() for name in header]
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
    columns, text_columns = {}, []
    for name in header:
        if name in KNOWN_COLUMNS:
            values = np.array([_parse_cell(path, no, name, c) for no, c in zip(line_numbers, cells[name])])
            _, ok, allowed = KNOWN_COLUMNS[name]
            bad = np.flatnonzero(~ok(values))
            if bad.size:
                i = bad[0]
                raise InputError(f"{path}: row {line_numbers[i]}, column {name!r}: {float(values[i])!r} is out of "
                                 f"range; allowed {allowed}")
            columns[name] = values
        else:  # extra column: numeric if every cell is a finite number, else kept out as text
            try:
                values = np.array([float(c) for c in cells[name]])
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
    for control in info.controls:
        if control not in columns:
            raise InputError(f"{folder / INFO_FILE}: controls: {control!r} is not a numeric column of {path} "
                             f"(columns: {', '.join(columns)})")
        if np.ptp(columns[control]) == 0:
            raise InputError(f"{path}: column {control!r} (a control) is constant ({columns[control][0]!r}); a "
                             "control must vary over the test")
    return table


# ----------------------------------------------------------------------------------------------------------------
# the exported net: fccm_nets.json (numpy evaluation, no torch)
# ----------------------------------------------------------------------------------------------------------------
FORMAT = "hillsim.fccm"
VERSION = 1
NETS_FILE = "fccm_nets.json"
METRICS_FILE = "metrics.json"


def _finite_float(value, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise InputError(f"{key} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise InputError(f"{key} must be finite, got {value!r}")
    return value


def _float_vector(value, key: str, length: int | None = None) -> np.ndarray:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise InputError(f"{key} must be a list of numbers, got {value!r}")
    if length is not None and len(value) != length:
        raise InputError(f"{key} must have {length} entries, got {len(value)}")
    return np.array([_finite_float(v, f"{key}[{i}]") for i, v in enumerate(value)], dtype=float)


def _float_matrix(value, key: str, rows: int | None, cols: int) -> np.ndarray:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) == 0:
        raise InputError(f"{key} must be a non-empty list of rows, got {value!r}")
    if rows is not None and len(value) != rows:
        raise InputError(f"{key} must have {rows} rows, got {len(value)}")
    return np.array([_float_vector(row, f"{key}[{i}]", cols) for i, row in enumerate(value)])


def _names(value, key: str) -> tuple:
    if isinstance(value, tuple):
        value = list(value)
    if (not isinstance(value, list) or not value
            or not all(isinstance(v, str) and v.strip() for v in value)):
        raise InputError(f"{key} must be a non-empty list of column names, got {value!r}")
    if len(set(value)) != len(value):
        raise InputError(f"{key} must be distinct, got {value!r}")
    return tuple(value)


def _logsig(z):
    """eq. (10) of paper 004, the log-sigmoid, without overflow for either sign of z."""
    out = np.empty_like(z)
    pos = z >= 0
    out[pos] = 1.0 / (1.0 + np.exp(-z[pos]))
    ez = np.exp(z[~pos])
    out[~pos] = ez / (1.0 + ez)
    return out


@dataclass(frozen=True, eq=False)
class FCCMWeights:
    """An n_in-H-n_out logsig/purelin net with its input/output scaling (``fccm_nets.json``)::

        xn = 2 (x - x_min) / (x_max - x_min) - 1;  h = 1 / (1 + exp(-(W1 xn + b1)));  yn = W2 h + b2
        y = (yn + 1) (y_max - y_min) / 2 + y_min          (per output)

    Parameters
    ----------
    inputs, outputs : sequence of str
        Column names (units in the names).
    x_min, x_max : array_like (n_in,)
    y_min, y_max : array_like (n_out,)
    W1 : array_like (H, n_in)
    b1 : array_like (H,)
    W2 : array_like (n_out, H)
    b2 : array_like (n_out,)
    training : dict, optional
        Training record (JSON-serializable).

    Raises
    ------
    InputError
        Wrong shapes, NaN/inf, ``x_max <= x_min``, ``y_max <= y_min``, bad names: the message names the key.

    Examples
    --------
    >>> w = FCCMWeights(inputs=["a", "b"], outputs=["y"], x_min=[0, 0], x_max=[2, 2], y_min=[0], y_max=[1],
    ...                 W1=[[1.0, 0.0]], b1=[0.0], W2=[[2.0]], b2=[-1.0])
    >>> w.predict([[1.0, 5.0]]).tolist()   # xn = 0 -> h = 0.5 -> yn = 0 -> y = 0.5
    [[0.5]]
    """

    inputs: tuple
    outputs: tuple
    x_min: np.ndarray
    x_max: np.ndarray
    y_min: np.ndarray
    y_max: np.ndarray
    W1: np.ndarray
    b1: np.ndarray
    W2: np.ndarray
    b2: np.ndarray
    training: dict = field(default_factory=dict)

    def __post_init__(self):
        self._validate(prefix="")

    def _validate(self, prefix: str):
        put = object.__setattr__
        inputs = _names(self.inputs, f"{prefix}inputs")
        outputs = _names(self.outputs, f"{prefix}outputs")
        n_in, n_out = len(inputs), len(outputs)
        x_min = _float_vector(self.x_min, f"{prefix}x_min", n_in)
        x_max = _float_vector(self.x_max, f"{prefix}x_max", n_in)
        for j, name in enumerate(inputs):
            if not x_max[j] > x_min[j]:
                raise InputError(f"{prefix}x_max[{j}] ({name}) must be > {prefix}x_min[{j}] = {x_min[j]!r}, "
                                 f"got {x_max[j]!r}")
        y_min = _float_vector(self.y_min, f"{prefix}y_min", n_out)
        y_max = _float_vector(self.y_max, f"{prefix}y_max", n_out)
        for j, name in enumerate(outputs):
            if not y_max[j] > y_min[j]:
                raise InputError(f"{prefix}y_max[{j}] ({name}) must be > {prefix}y_min[{j}] = {y_min[j]!r}, "
                                 f"got {y_max[j]!r}")
        w1 = _float_matrix(self.W1, f"{prefix}W1", None, n_in)
        hidden = w1.shape[0]
        b1 = _float_vector(self.b1, f"{prefix}b1", hidden)
        w2 = _float_matrix(self.W2, f"{prefix}W2", n_out, hidden)
        b2 = _float_vector(self.b2, f"{prefix}b2", n_out)
        training = self.training if self.training is not None else {}
        if not isinstance(training, dict):
            raise InputError(f"{prefix}training must be an object, got {type(training).__name__}")
        for name, value in (("x_min", x_min), ("x_max", x_max), ("y_min", y_min), ("y_max", y_max), ("W1", w1),
                            ("b1", b1), ("W2", w2), ("b2", b2)):
            value.setflags(write=False)
            put(self, name, value)
        put(self, "inputs", inputs)
        put(self, "outputs", outputs)
        put(self, "training", dict(training))

    @property
    def hidden(self) -> int:
        return int(self.W1.shape[0])

    def predict(self, X) -> np.ndarray:
        """Outputs (n, n_out) in physical units at inputs ``X`` (n, n_in), the columns in ``inputs`` order."""
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != len(self.inputs):
            raise InputError(f"X must have shape (n, {len(self.inputs)}) with columns {list(self.inputs)}, got "
                             f"{X.shape}")
        xn = 2.0 * (X - self.x_min) / (self.x_max - self.x_min) - 1.0  # mapminmax
        h = _logsig(xn @ self.W1.T + self.b1)  # eq. (10) of paper 004, one hidden layer
        yn = h @ self.W2.T + self.b2  # linear outputs
        return (yn + 1.0) * (self.y_max - self.y_min) / 2.0 + self.y_min  # reverse mapminmax

    def predict_grad(self, X) -> np.ndarray:
        """Analytic Jacobian dy/dx (n, n_out, n_in) in physical units at inputs ``X`` (n, n_in).

        ``dy_k/dx_j = (y_max_k - y_min_k)/2 sum_i W2_ki h_i (1 - h_i) W1_ij 2/(x_max_j - x_min_j)``.
        """
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != len(self.inputs):
            raise InputError(f"X must have shape (n, {len(self.inputs)}) with columns {list(self.inputs)}, got "
                             f"{X.shape}")
        xn = 2.0 * (X - self.x_min) / (self.x_max - self.x_min) - 1.0
        h = _logsig(xn @ self.W1.T + self.b1)
        dh = h * (1.0 - h)  # (n, H)
        jac = np.einsum("ki,ni,ij->nkj", self.W2, dh, self.W1)
        return jac * ((self.y_max - self.y_min) / 2.0)[None, :, None] * (2.0 / (self.x_max - self.x_min))[None, None, :]

    def predict_columns(self, **inputs) -> dict:
        """Outputs by name from inputs by name (arrays broadcast together), e.g.
        ``predict_columns(blade_angle_deg=a, guide_vane_deg=b)["efficiency"]``."""
        missing = [n for n in self.inputs if n not in inputs]
        unknown = [n for n in inputs if n not in self.inputs]
        if missing or unknown:
            raise InputError(f"predict_columns needs exactly the inputs {list(self.inputs)}; missing {missing}, "
                             f"unknown {unknown}")
        arrays = np.broadcast_arrays(*(np.asarray(inputs[n], dtype=float) for n in self.inputs))
        shape = arrays[0].shape
        y = self.predict(np.column_stack([a.ravel() for a in arrays]))
        return {name: y[:, j].reshape(shape) for j, name in enumerate(self.outputs)}

    def outside_domain(self, X) -> np.ndarray:
        """True for rows of ``X`` outside the box the net was fitted on (extrapolation)."""
        X = np.asarray(X, dtype=float)
        return np.any((X < self.x_min) | (X > self.x_max), axis=1)

    # fccm_nets.json -------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {"format": FORMAT, "version": VERSION, "inputs": list(self.inputs), "outputs": list(self.outputs),
                "x_min": [float(v) for v in self.x_min], "x_max": [float(v) for v in self.x_max],
                "y_min": [float(v) for v in self.y_min], "y_max": [float(v) for v in self.y_max],
                "W1": [[float(v) for v in row] for row in self.W1], "b1": [float(v) for v in self.b1],
                "W2": [[float(v) for v in row] for row in self.W2], "b2": [float(v) for v in self.b2],
                "training": self.training}

    def to_json(self) -> str:
        """``fccm_nets.json`` text: one line per key, floats in shortest round-trip form (loading is bit-exact)."""
        doc = self.to_dict()
        lines = []
        for key, value in doc.items():
            if key == "training":
                text = json.dumps(value, indent=1, allow_nan=False).replace("\n", "\n ")
            else:
                text = json.dumps(value, allow_nan=False)
            lines.append(f" {json.dumps(key)}: {text}")
        return "{\n" + ",\n".join(lines) + "\n}\n"

    def save(self, path) -> Path:
        path = Path(path)
        path.write_text(self.to_json(), encoding="utf-8")
        return path

    @classmethod
    def from_dict(cls, doc) -> "FCCMWeights":
        """Validate a parsed ``fccm_nets.json`` document (extra keys are allowed, as in ``nets.json``)."""
        if not isinstance(doc, dict):
            raise InputError(f"{NETS_FILE} must hold an object, got {type(doc).__name__}")
        required = ("format", "version", "inputs", "outputs", "x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2",
                    "b2")
        for key in required:
            if key not in doc:
                raise InputError(f"key {key!r} is missing (required: {', '.join(required)})")
        if doc["format"] != FORMAT:
            raise InputError(f"format must be {FORMAT!r}, got {doc['format']!r}")
        if isinstance(doc["version"], bool) or doc["version"] != VERSION:
            raise InputError(f"version must be {VERSION}, got {doc['version']!r}")
        obj = cls.__new__(cls)
        for key in required[2:]:
            object.__setattr__(obj, key, doc[key])
        object.__setattr__(obj, "training", doc["training"] if "training" in doc else {})
        obj._validate(prefix="")
        return obj

    @classmethod
    def from_json(cls, text: str) -> "FCCMWeights":
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"not valid JSON ({exc})") from None
        return cls.from_dict(doc)

    def __eq__(self, other):
        if not isinstance(other, FCCMWeights):
            return NotImplemented
        return (self.inputs == other.inputs and self.outputs == other.outputs
                and all(np.array_equal(getattr(self, k), getattr(other, k))
                        for k in ("x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2", "b2")))

    __hash__ = None


def load_fccm_nets(path) -> FCCMWeights:
    """Read and validate ``fccm_nets.json`` (numpy only; torch is not imported).

    Raises
    ------
    InputError
        Invalid JSON, wrong format or version, missing keys, wrong shapes, NaN/inf, ``x_max <= x_min``: the
        message names the file and the key.
    FileNotFoundError
        No such file.
    """
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    try:
        return FCCMWeights.from_json(text)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


# ----------------------------------------------------------------------------------------------------------------
# the estimator
# ----------------------------------------------------------------------------------------------------------------
def hidden_size(n_inputs: int, n_outputs: int, c: int) -> int:
    """Hidden neurons from eq. (3) of paper 003, ``n_hl = sqrt(n_in + n_out) + C``, rounded to the nearest integer.

    Examples
    --------
    >>> [hidden_size(2, 4, c) for c in (1, 8, 10)]   # paper 003: 2 inputs, 4 outputs; it picks 10 (C = 8)
    [3, 10, 12]
    """
    return int(math.floor(math.sqrt(n_inputs + n_outputs) + c + 0.5))  # eq. (3), paper 003


def split_indices(n: int, fractions, rng: np.random.Generator):
    """Seeded random train / validation / test split (paper 003: 30 / 35 / 35 %).

    ``round(f_train n)`` training and ``round(f_val n)`` validation samples, the rest test; each part gets at least
    one sample (training at least 3).

    Examples
    --------
    >>> tr, va, te = split_indices(150, (0.30, 0.35, 0.35), np.random.default_rng(0))
    >>> len(tr), len(va), len(te)
    (45, 52, 53)
    """
    f_train, f_val, _ = fractions
    n_train = max(3, int(round(f_train * n)))
    n_val = max(1, int(round(f_val * n)))
    if n_train + n_val >= n:
        raise InputError(f"{n} samples cannot be split {list(fractions)} into train (>= 3), validation (>= 1) and "
                         "test (>= 1)")
    perm = rng.permutation(n)
    return np.sort(perm[:n_train]), np.sort(perm[n_train:n_train + n_val]), np.sort(perm[n_train + n_val:])


class FCCMNet:
    """Multi-output BP net y(x) of paper 003 (n_in inputs, one logsig hidden layer, n_out linear outputs), trained
    by Levenberg-Marquardt (:mod:`hillchart.nets.lm`, MATLAB ``trainlm``).

    Inputs and outputs are mapped to [-1, 1] by their min/max over all samples (``mapminmax``, as MATLAB configures
    a net from the whole data set); the samples are split at random (seeded) into training, validation and test
    parts (paper 003: 30/35/35 %); each run stops when the validation error has risen ``max_fail`` times and keeps
    its best-validation weights; the best of ``restarts`` Nguyen-Widrow starts is kept. With ``hidden=None`` the
    hidden size follows eq. (3), ``n_hl = sqrt(n_in + n_out) + C``, with C in ``c_values`` chosen by the lowest
    validation error (the test part is never used for a choice).

    Parameters
    ----------
    hidden : int or None, default None
        Fixed hidden size; None: eq. (3) with C chosen by validation.
    c_values : sequence of int, default 1..10
        Candidate C of eq. (3).
    split : (float, float, float), default (0.30, 0.35, 0.35)
        Training, validation and test fractions (sum 1).
    restarts : int, default 5
    seed : int, default 0
        Seeds the split and every initialisation.
    goal, max_epochs, max_fail, mu, mu_dec, mu_inc, mu_max
        ``trainlm`` parameters (goal on the mean squared normalized error of all outputs).
    n_threads : int, default 1
        Threads running the restarts side by side during ``fit`` (the result does not depend on it).

    Attributes
    ----------
    weights_ : FCCMWeights
    hidden_ : int
    c_ : int or None
        The chosen C (None when ``hidden`` was given).
    selection_ : list of dict
        Per candidate: c, hidden, validation MSE (normalized) of its best start.
    train_index_, val_index_, test_index_ : ndarray of int
    train_mse_, val_mse_, test_mse_ : float
        Mean squared normalized errors of the kept net.
    epochs_, stop_reason_ : int, str

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> X = rng.uniform(-1, 1, (120, 2))
    >>> Y = np.column_stack([np.tanh(X[:, 0] + X[:, 1]), X[:, 0] * X[:, 1]])
    >>> net = FCCMNet(hidden=6, restarts=2, seed=0).fit(X, Y)
    >>> bool(np.sqrt(np.mean((net.predict(X) - Y) ** 2)) < 0.02)
    True
    """

    _PARAMS = ("hidden", "c_values", "split", "restarts", "seed", "goal", "max_epochs", "max_fail", "mu", "mu_dec",
               "mu_inc", "mu_max", "n_threads")

    def __init__(self, *, hidden: int | None = None, c_values=tuple(range(1, 11)), split=(0.30, 0.35, 0.35),
                 restarts: int = 5, seed: int = 0, goal: float = 1e-7, max_epochs: int = 1000, max_fail: int = 6,
                 mu: float = 1e-3, mu_dec: float = 0.1, mu_inc: float = 10.0, mu_max: float = 1e10,
                 n_threads: int = 1):
        self.hidden = hidden
        self.c_values = c_values
        self.split = split
        self.restarts = restarts
        self.seed = seed
        self.goal = goal
        self.max_epochs = max_epochs
        self.max_fail = max_fail
        self.mu = mu
        self.mu_dec = mu_dec
        self.mu_inc = mu_inc
        self.mu_max = mu_max
        self.n_threads = n_threads

    def get_params(self, deep: bool = True) -> dict:
        return {name: getattr(self, name) for name in self._PARAMS}

    def set_params(self, **params) -> "FCCMNet":
        for name, value in params.items():
            if name not in self._PARAMS:
                raise InputError(f"FCCMNet has no parameter {name!r}; valid: {', '.join(self._PARAMS)}")
            setattr(self, name, value)
        return self

    def __repr__(self):
        return "FCCMNet(" + ", ".join(f"{k}={v!r}" for k, v in self.get_params().items()) + ")"

    def _validate_params(self):
        def is_int(value, low):
            return not isinstance(value, bool) and isinstance(value, (int, np.integer)) and value >= low

        if self.hidden is not None and not is_int(self.hidden, 1):
            raise InputError(f"FCCMNet.hidden must be None or an integer >= 1, got {self.hidden!r}")
        for name, low in (("restarts", 1), ("max_epochs", 0), ("max_fail", 1), ("n_threads", 1), ("seed", 0)):
            if not is_int(getattr(self, name), low):
                raise InputError(f"FCCMNet.{name} must be an integer >= {low}, got {getattr(self, name)!r}")
        c_values = self.c_values
        if (not isinstance(c_values, (list, tuple, range)) or len(c_values) == 0
                or not all(is_int(c, 1) and c <= 10 for c in c_values)):
            raise InputError(f"FCCMNet.c_values must be a non-empty list of integers in 1..10 (eq. (3) of paper "
                             f"003), got {c_values!r}")
        split = self.split
        if (not isinstance(split, (list, tuple)) or len(split) != 3
                or not all(isinstance(f, (int, float)) and not isinstance(f, bool) and 0 < f < 1 for f in split)
                or abs(sum(split) - 1.0) > 1e-9):
            raise InputError(f"FCCMNet.split must be three fractions in (0, 1) summing to 1 (train, validation, "
                             f"test), got {split!r}")
        for name in ("goal", "mu", "mu_max"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise InputError(f"FCCMNet.{name} must be a finite number >= 0, got {value!r}")
        if not 0 < self.mu_dec < 1:
            raise InputError(f"FCCMNet.mu_dec must be in (0, 1), got {self.mu_dec!r}")
        if not self.mu_inc > 1:
            raise InputError(f"FCCMNet.mu_inc must be > 1, got {self.mu_inc!r}")

    def fit(self, X, Y, *, input_names=None, output_names=None) -> "FCCMNet":
        """Train on inputs ``X`` (n, n_in) and targets ``Y`` (n, n_out) in physical units.

        Parameters
        ----------
        X : array_like (n, n_in)
        Y : array_like (n, n_out) or (n,)
        input_names, output_names : sequence of str, optional
            Written into ``fccm_nets.json`` (default x0.., y0..).

        Returns
        -------
        self

        Raises
        ------
        InputError
            Bad shapes, NaN/inf, a constant column, too few samples, bad hyperparameters.
        NumericalError
            Training diverged to NaN.
        """
        import time

        from hillchart.nets import lm

        self._validate_params()
        X = np.asarray(X, dtype=float)
        Y = np.asarray(Y, dtype=float)
        if Y.ndim == 1:
            Y = Y[:, None]
        if X.ndim != 2 or X.shape[1] < 1:
            raise InputError(f"X must have shape (n, n_in), got {X.shape}")
        if Y.ndim != 2 or Y.shape[0] != X.shape[0]:
            raise InputError(f"Y must have shape ({X.shape[0]}, n_out) matching X, got {Y.shape}")
        n, n_in = X.shape
        n_out = Y.shape[1]
        input_names = tuple(input_names) if input_names is not None else tuple(f"x{j}" for j in range(n_in))
        output_names = tuple(output_names) if output_names is not None else tuple(f"y{j}" for j in range(n_out))
        if len(input_names) != n_in or len(output_names) != n_out:
            raise InputError(f"input_names / output_names must name the {n_in} input and {n_out} output columns, got "
                             f"{list(input_names)} / {list(output_names)}")
        if n < 10:
            raise InputError(f"need >= 10 samples to train, validate and test, got {n}")
        for name, arr, names in (("X", X, input_names), ("Y", Y, output_names)):
            bad = np.argwhere(~np.isfinite(arr))
            if bad.size:
                i, j = bad[0]
                raise InputError(f"{name}: sample {i}, column {names[j]!r} is {float(arr[i, j])!r}; values must be "
                                 "finite")
        x_min, x_max = X.min(axis=0), X.max(axis=0)
        y_min, y_max = Y.min(axis=0), Y.max(axis=0)
        for lo, hi, names in ((x_min, x_max, input_names), (y_min, y_max, output_names)):
            for j in np.flatnonzero(~(hi > lo)):
                raise InputError(f"column {names[j]!r} is constant ({lo[j]!r}); the net needs a range")
        xn = 2.0 * (X - x_min) / (x_max - x_min) - 1.0  # mapminmax
        yn = 2.0 * (Y - y_min) / (y_max - y_min) - 1.0
        yn_lm = yn[:, 0] if n_out == 1 else yn
        tr, va, te = split_indices(n, self.split, np.random.default_rng(self.seed))
        if self.hidden is not None:
            candidates = [(None, int(self.hidden))]
        else:
            seen, candidates = set(), []
            for c in self.c_values:
                h = hidden_size(n_in, n_out, c)
                if h not in seen:
                    seen.add(h)
                    candidates.append((int(c), h))
        start = time.perf_counter()
        selection, best = [], None
        for c, h in candidates:
            rng = np.random.default_rng([self.seed, h])  # the starts of size h do not depend on the others
            thetas0 = [lm.nguyen_widrow_init(h, rng, n_in, n_out) for _ in range(self.restarts)]
            runs = lm.levenberg_marquardt_many(  # one output: 1-D targets (lm's 2-H-1 path)
                xn[tr], yn_lm[tr], xn[va], yn_lm[va], thetas0, n_threads=self.n_threads, hidden=h, goal=self.goal,
                max_epochs=self.max_epochs, max_fail=self.max_fail, mu=self.mu, mu_dec=self.mu_dec,
                mu_inc=self.mu_inc, mu_max=self.mu_max)
            k = int(np.argmin([r.val_mse for r in runs]))
            selection.append({"c": c, "hidden": h, "validation_mse": runs[k].val_mse,
                              "train_mse": runs[k].train_mse, "best_restart": k})
            if best is None or runs[k].val_mse < best[2].val_mse:
                best = (c, h, runs[k])
        self.fit_time_s_ = time.perf_counter() - start
        c, h, res = best
        if not np.all(np.isfinite(res.theta)):
            raise NumericalError("FCCMNet: the kept weights are not finite")
        w1, b1, w2, b2 = lm.unpack(res.theta, h, n_in, n_out)
        w2 = np.asarray(w2).reshape(n_out, h)
        b2 = np.atleast_1d(np.asarray(b2, dtype=float))
        self.weights_ = FCCMWeights(inputs=input_names, outputs=output_names, x_min=x_min, x_max=x_max, y_min=y_min,
                                    y_max=y_max, W1=w1, b1=b1, W2=w2, b2=b2)
        self.hidden_, self.c_ = h, c
        self.selection_ = selection
        self.train_index_, self.val_index_, self.test_index_ = tr, va, te
        yn_fit = 2.0 * (self.weights_.predict(X) - y_min) / (y_max - y_min) - 1.0
        self.train_mse_ = float(np.mean((yn_fit[tr] - yn[tr]) ** 2))
        self.val_mse_ = float(np.mean((yn_fit[va] - yn[va]) ** 2))
        self.test_mse_ = float(np.mean((yn_fit[te] - yn[te]) ** 2))
        self.epochs_, self.best_epoch_, self.stop_reason_ = res.epochs, res.best_epoch, res.stop_reason
        self.weights_.training.update(self.training_record())
        return self

    def _check_fitted(self):
        if not hasattr(self, "weights_"):
            raise InputError("this FCCMNet is not fitted yet; call fit(X, Y) before predict")

    def predict(self, X) -> np.ndarray:
        """Outputs (n, n_out) at inputs ``X`` (n, n_in)."""
        self._check_fitted()
        return self.weights_.predict(X)

    def training_record(self) -> dict:
        """The ``training`` block of ``fccm_nets.json`` (JSON-serializable, no timings: byte-reproducible)."""
        self._check_fitted()
        return {"seed": self.seed, "split": list(self.split), "restarts": self.restarts,
                "hidden": self.hidden_, "c": self.c_,
                "hidden_rule": ("eq. (3) of paper 003: round(sqrt(n_in + n_out) + C)" if self.c_ is not None
                                else "fixed"),
                "selection": self.selection_,
                "n_train": int(self.train_index_.size), "n_validation": int(self.val_index_.size),
                "n_test": int(self.test_index_.size), "train_mse_normalized": self.train_mse_,
                "validation_mse_normalized": self.val_mse_, "test_mse_normalized": self.test_mse_,
                "epochs": self.epochs_, "best_epoch": self.best_epoch_, "stop_reason": self.stop_reason_}


def split_errors(weights: FCCMWeights, X, Y, parts: dict) -> dict:
    """Per output RMSE and max |error| (physical units) on each part (``{"train": idx, "validation": idx, ...}``)."""
    err = weights.predict(X) - np.asarray(Y, dtype=float).reshape(len(X), -1)
    out = {}
    for j, name in enumerate(weights.outputs):
        out[name] = {part: {"rmse": float(np.sqrt(np.mean(err[idx, j] ** 2))),
                            "max_abs_error": float(np.max(np.abs(err[idx, j])))} for part, idx in parts.items()}
    return out


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
    """Issue 11's acceptance on a truth comparison: every output's net RMS <= ``bound_pct`` % of its range, and the
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
            data[h].append(_parse_cell(path, line_no, h, cell))
    return {h: np.asarray(v) for h, v in data.items()}


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


# ----------------------------------------------------------------------------------------------------------------
# the whole analysis (what ``hillsim fccm`` runs)
# ----------------------------------------------------------------------------------------------------------------
@dataclass
class FCCMReport:
    """Everything ``hillsim fccm`` writes: the net, ``metrics.json`` and the figures (built in memory)."""

    weights: FCCMWeights
    metrics: dict
    figures: dict  # file name -> callable(path) drawing it

    def write(self, out_dir, *, plots: bool = True) -> dict:
        """Write ``fccm_nets.json``, ``metrics.json`` and (``plots``) the PNGs into ``out_dir``; returns
        name -> path. Figures are drawn into a temporary folder first, so a failure leaves no partial set."""
        out = Path(out_dir)
        created = not out.exists()
        out.mkdir(parents=True, exist_ok=True)
        try:
            return self._write_via(out, plots)
        except BaseException:
            if created and out.is_dir() and not any(out.iterdir()):
                out.rmdir()  # a folder this call created stays only with the complete set in it
            raise

    def _write_via(self, out: Path, plots: bool) -> dict:
        with tempfile.TemporaryDirectory(dir=out, prefix=".fccm-") as tmp:
            tmp = Path(tmp)
            names = [NETS_FILE, METRICS_FILE]
            self.weights.save(tmp / NETS_FILE)
            (tmp / METRICS_FILE).write_text(json.dumps(self.metrics, indent=1, allow_nan=False) + "\n",
                                            encoding="utf-8")
            if plots:
                for name, draw in self.figures.items():
                    draw(tmp / name)
                    names.append(name)
            written = {}
            for name in names:
                shutil.move(str(tmp / name), str(out / name))
                written[name] = out / name
        return written


def analyse_fccm(table: TestTable, inputs, outputs, *, net: FCCMNet | None = None, truth: dict | None = None,
                 pixels: int = 160) -> FCCMReport:
    """Train the net on the table and run paper 003's analyses.

    Parameters
    ----------
    table : TestTable
    inputs, outputs : sequence of str
        Column names (e.g. the controls, and efficiency, head, power, flow).
    net : FCCMNet, optional
        Unfitted estimator with the wanted hyperparameters (default ``FCCMNet()``).
    truth : dict of str -> ndarray, optional
        Exact values on a dense grid (:func:`read_truth_csv`) for the net-vs-interpolation comparison.

    Returns
    -------
    FCCMReport
        ``metrics`` holds: ``errors`` (per output RMSE and max error on train / validation / test), the hidden-size
        choice, ``similarity`` and ``grey_relational`` (+ ``grey_relational_order``) when they apply, ``truth`` and
        ``acceptance`` when a truth grid is given, ``skipped`` (analysis -> reason) and ``warnings``.
    """
    inputs, outputs = tuple(inputs), tuple(outputs)
    for kind, names in (("inputs", inputs), ("outputs", outputs)):
        if not names:
            raise InputError(f"{kind}: give at least one column")
        if len(set(names)) != len(names):
            raise InputError(f"{kind} must be distinct, got {list(names)}")
    overlap = sorted(set(inputs) & set(outputs))
    if overlap:
        raise InputError(f"columns {overlap} are both inputs and outputs")
    X, Y = table.matrix(inputs), table.matrix(outputs)
    net = net if net is not None else FCCMNet()
    net.fit(X, Y, input_names=inputs, output_names=outputs)
    weights = net.weights_
    weights.training["table"] = table.info.name
    parts = {"train": net.train_index_, "validation": net.val_index_, "test": net.test_index_}
    metrics = {"table": table.info.name, "inputs": list(inputs), "outputs": list(outputs), "n_points": table.n_rows,
               "hidden": net.hidden_, "c": net.c_, "hidden_selection": net.selection_,
               "errors": split_errors(weights, X, Y, parts), "skipped": {}, "warnings": []}
    figures = {}
    # grey relational analysis on the test points (Table 1)
    controls = table.info.controls
    refs = {o: table.column(o) for o in outputs}
    try:
        degrees = grey_relational_analysis(refs, {c: table.column(c) for c in controls})
        metrics["grey_relational"] = degrees
        metrics["grey_relational_order"] = grey_relational_order(degrees)
    except InputError as exc:
        metrics["skipped"]["grey_relational"] = str(exc)
    # maps and image similarity (Figs. 4-6)
    try:
        maps = efficiency_maps(table, weights, pixels=pixels)
        ga, gb, mask = grey_images(maps.interpolated, maps.net)
        sim = image_similarity(ga, gb, mask)
        metrics["similarity"] = {k: sim[k] for k in ("euclidean", "cosine", "angle_deg", "pixel_rms", "pixels")}
        metrics["similarity"]["grey_range"] = [float(min(maps.interpolated[mask].min(), maps.net[mask].min())),
                                               float(max(maps.interpolated[mask].max(), maps.net[mask].max()))]
        figures["fccm_efficiency_maps.png"] = lambda p, m=maps, a=ga, b=gb, s=sim: plot_efficiency_maps(m, a, b, s, p)
        if mask.sum() < 0.02 * mask.size:
            metrics["warnings"].append(
                f"the efficiency maps overlap on {int(mask.sum())} of {mask.size} pixels only: the test points lie "
                "(nearly) on one curve of the (Q11, n11) plane (e.g. a plant at constant speed on a water system "
                "H(Q)), so the image similarity measures little")
    except InputError as exc:
        metrics["skipped"]["similarity"] = str(exc)
    if len(inputs) == 2:
        figures["fccm_control_maps.png"] = lambda p: plot_control_maps(weights, table, p)
    else:
        metrics["skipped"]["control_maps"] = f"needs 2 inputs, got {len(inputs)}"
    if {"efficiency", "power_kw"} <= set(outputs) and "head_m" in inputs + outputs and len(inputs) == 2:
        figures["fccm_operating_characteristic.png"] = lambda p: plot_operating_characteristic(weights, table, p)
    else:
        metrics["skipped"]["operating_characteristic"] = ("needs 2 inputs, efficiency and power_kw among the outputs "
                                                          "and head_m among inputs or outputs")
    if truth is not None:
        comparison = truth_comparison(weights, table, truth)
        metrics["truth"] = comparison
        metrics["acceptance"] = truth_acceptance(comparison, outputs)
        Xt = np.column_stack([np.asarray(truth[n], dtype=float) for n in inputs])
        outside = int(weights.outside_domain(Xt).sum())
        if outside:
            metrics["warnings"].append(f"{outside} truth points lie outside the input box the net was fitted on "
                                       "(extrapolation)")
    return FCCMReport(weights=weights, metrics=metrics, figures=figures)


# ----------------------------------------------------------------------------------------------------------------
# beyond the paper: a three-input hill chart of a double-regulated turbine and its on-cam relation
# ----------------------------------------------------------------------------------------------------------------
#: Inputs of the three-input NET blocks (nets.json NET format): unit speed, guide-vane opening, blade angle.
NET3_INPUTS = ("n11", "opening", "blade_angle")


def _net_block(weights: FCCMWeights, output: str) -> dict:
    """A single-output :class:`FCCMWeights` as a ``nets.json`` NET block with three inputs."""
    return {"inputs": list(NET3_INPUTS), "output": output,
            "x_min": [float(v) for v in weights.x_min], "x_max": [float(v) for v in weights.x_max],
            "y_min": float(weights.y_min[0]), "y_max": float(weights.y_max[0]),
            "W1": [[float(v) for v in row] for row in weights.W1], "b1": [float(v) for v in weights.b1],
            "W2": [float(v) for v in weights.W2[0]], "b2": float(weights.b2[0])}


def _weights_from_block(block, key: str, output: str) -> FCCMWeights:
    if not isinstance(block, dict):
        raise InputError(f"{key} must be an object, got {type(block).__name__}")
    required = ("inputs", "output", "x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2", "b2")
    for name in required:
        if name not in block:
            raise InputError(f"{key}.{name} is missing (a NET needs keys {', '.join(required)})")
    if block["inputs"] != list(NET3_INPUTS):
        raise InputError(f"{key}.inputs must be {list(NET3_INPUTS)}, got {block['inputs']!r}")
    if block["output"] != output:
        raise InputError(f"{key}.output must be {output!r}, got {block['output']!r}")
    for name in ("y_min", "y_max", "b2"):
        _finite_float(block[name], f"{key}.{name}")
    if not isinstance(block["W2"], list):
        raise InputError(f"{key}.W2 must be a list of numbers, got {block['W2']!r}")
    try:
        return FCCMWeights(inputs=NET3_INPUTS, outputs=(output,), x_min=block["x_min"], x_max=block["x_max"],
                           y_min=[block["y_min"]], y_max=[block["y_max"]], W1=block["W1"], b1=block["b1"],
                           W2=[block["W2"]], b2=[block["b2"]])
    except InputError as exc:
        raise InputError(f"{key}.{exc}") from None


class DoubleRegulatedNets:
    """Q11(N11, a, phi) (m^3/s) and M11(N11, a, phi) (N*m) of a double-regulated turbine: two three-input nets in
    the ``nets.json`` NET format with ``"inputs": ["n11", "opening", "blade_angle"]`` (numpy evaluation, no torch).

    Parameters
    ----------
    flow, torque : FCCMWeights
        Three inputs (n11 r/min, opening, blade angle deg), one output each.
    opening_unit : str
    training : dict, optional
    """

    def __init__(self, flow: FCCMWeights, torque: FCCMWeights, opening_unit: str = "deg",
                 training: dict | None = None):
        for name, w in (("flow", flow), ("torque", torque)):
            if not isinstance(w, FCCMWeights) or len(w.inputs) != 3 or len(w.outputs) != 1:
                raise InputError(f"DoubleRegulatedNets.{name} must be a 3-input, 1-output FCCMWeights")
        self.flow, self.torque = flow, torque
        self.opening_unit = opening_unit
        self.training = dict(training or {})

    def _x(self, n11, opening, blade_angle):
        arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (n11, opening, blade_angle)))
        return np.column_stack([a.ravel() for a in arrays]), arrays[0].shape

    def q11(self, n11, opening, blade_angle):
        """Unit flow Q11, m^3/s (broadcast)."""
        x, shape = self._x(n11, opening, blade_angle)
        return self.flow.predict(x)[:, 0].reshape(shape)

    def m11(self, n11, opening, blade_angle):
        """Unit torque M11, N*m (broadcast)."""
        x, shape = self._x(n11, opening, blade_angle)
        return self.torque.predict(x)[:, 0].reshape(shape)

    def q11_grad(self, n11, opening, blade_angle):
        """(dQ11/dN11, dQ11/da, dQ11/dphi), analytic."""
        x, shape = self._x(n11, opening, blade_angle)
        g = self.flow.predict_grad(x)[:, 0, :]
        return tuple(g[:, j].reshape(shape) for j in range(3))

    def m11_grad(self, n11, opening, blade_angle):
        """(dM11/dN11, dM11/da, dM11/dphi), analytic."""
        x, shape = self._x(n11, opening, blade_angle)
        g = self.torque.predict_grad(x)[:, 0, :]
        return tuple(g[:, j].reshape(shape) for j in range(3))

    def efficiency(self, n11, opening, blade_angle):
        """Hydraulic efficiency M11 omega11 / (rho g Q11) (inverse of eq. (5) of paper 004); NaN where Q11 <= 0."""
        from hillchart.characteristics import efficiency_from_unit_torque

        return efficiency_from_unit_torque(self.q11(n11, opening, blade_angle), n11,
                                           self.m11(n11, opening, blade_angle))

    def on_cam(self, openings, heads_m, *, speed_rpm: float, runner_diameter_m: float, **kwargs) -> dict:
        """:func:`on_cam_relation` of these nets, with ``outside_domain`` (per head: n11 = n D / sqrt(H) or an
        opening outside the box the nets were fitted on) and a :class:`UserWarning` when any is (extrapolation)."""
        import warnings

        cam = on_cam_relation(self.efficiency, openings, heads_m, speed_rpm=speed_rpm,
                              runner_diameter_m=runner_diameter_m, **kwargs)
        n11 = speed_rpm * runner_diameter_m / np.sqrt(cam["head_m"])
        lo, hi = self.flow.x_min, self.flow.x_max
        outside = (n11 < lo[0]) | (n11 > hi[0])
        outside = outside | bool(np.any((cam["opening"] < lo[1]) | (cam["opening"] > hi[1])))
        cam["outside_domain"] = outside
        if outside.any():
            warnings.warn(f"on_cam: heads {cam['head_m'][outside].tolist()} m (or the openings) lie outside the "
                          f"nets' fitted box (n11 {lo[0]:.4g}-{hi[0]:.4g} r/min, opening {lo[1]:.4g}-{hi[1]:.4g}): "
                          "extrapolated", UserWarning, stacklevel=2)
        return cam

    def to_dict(self) -> dict:
        return {"format": "hillsim.nets", "version": 1,
                "units": {"n11": "r/min", "opening": self.opening_unit, "blade_angle": "deg", "q11": "m^3/s",
                          "m11": "N*m"},
                "flow": _net_block(self.flow, "q11"), "torque": _net_block(self.torque, "m11"),
                "training": self.training}

    def to_json(self) -> str:
        doc = self.to_dict()
        lines = []
        for key, value in doc.items():
            if key in ("flow", "torque"):
                inner = ",\n".join(f"  {json.dumps(k)}: {json.dumps(v, allow_nan=False)}" for k, v in value.items())
                lines.append(f" {json.dumps(key)}: {{\n{inner}\n }}")
            else:
                text = json.dumps(value, indent=1, allow_nan=False).replace("\n", "\n ")
                lines.append(f" {json.dumps(key)}: {text}")
        return "{\n" + ",\n".join(lines) + "\n}\n"

    def save(self, path) -> Path:
        path = Path(path)
        path.write_text(self.to_json(), encoding="utf-8")
        return path

    @classmethod
    def from_dict(cls, doc) -> "DoubleRegulatedNets":
        """Validate a three-input ``nets.json`` document (format hillsim.nets, version 1, NET blocks with inputs
        n11, opening, blade_angle)."""
        if not isinstance(doc, dict):
            raise InputError(f"nets.json must hold an object, got {type(doc).__name__}")
        for key in ("format", "version", "units", "flow", "torque"):
            if key not in doc:
                raise InputError(f"key {key!r} is missing (required: format, version, units, flow, torque)")
        if doc["format"] != "hillsim.nets":
            raise InputError(f"format must be 'hillsim.nets', got {doc['format']!r}")
        if isinstance(doc["version"], bool) or doc["version"] != 1:
            raise InputError(f"version must be 1, got {doc['version']!r}")
        units = doc["units"]
        fixed = {"n11": "r/min", "blade_angle": "deg", "q11": "m^3/s", "m11": "N*m"}
        if not isinstance(units, dict) or any(units.get(k) != v for k, v in fixed.items()):
            raise InputError(f"units must hold {fixed} and the opening unit, got {units!r}")
        if not isinstance(units.get("opening"), str) or not units.get("opening"):
            raise InputError(f"units.opening must be a non-empty string, got {units.get('opening')!r}")
        training = doc["training"] if "training" in doc else {}
        if not isinstance(training, dict):
            raise InputError(f"training must be an object, got {type(training).__name__}")
        return cls(flow=_weights_from_block(doc["flow"], "flow", "q11"),
                   torque=_weights_from_block(doc["torque"], "torque", "m11"), opening_unit=units["opening"],
                   training=training)


def load_double_regulated_nets(path) -> DoubleRegulatedNets:
    """Read a three-input ``nets.json`` (see :class:`DoubleRegulatedNets`); errors name the file and the key."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None
    try:
        return DoubleRegulatedNets.from_dict(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def bulb_chart_samples(turbine=None, *, n_points: int = 600, seed: int = 0, n11_range=(110.0, 230.0)) -> dict:
    """Scattered samples of the synthetic bulb's unit characteristic (its 'chart'): the 8 corners of the box plus a
    seeded Latin hypercube over n11 (r/min), guide-vane angle and blade angle (the paper's ranges), with exact Q11
    (m^3/s) and M11 (N*m)."""
    from scipy.stats import qmc

    from hillchart.synthetic.bulb import BLADE_RANGE_DEG, GUIDE_VANE_RANGE_DEG, SyntheticBulb

    turbine = turbine or SyntheticBulb()
    lo = np.array([n11_range[0], GUIDE_VANE_RANGE_DEG[0], BLADE_RANGE_DEG[0]])
    hi = np.array([n11_range[1], GUIDE_VANE_RANGE_DEG[1], BLADE_RANGE_DEG[1]])
    corners = np.array([[lo[0] if i & 1 == 0 else hi[0], lo[1] if i & 2 == 0 else hi[1],
                         lo[2] if i & 4 == 0 else hi[2]] for i in range(8)])  # the fitted box = the chart's ranges
    x = np.vstack([corners, qmc.scale(qmc.LatinHypercube(d=3, seed=np.random.default_rng(seed)).random(n_points - 8),
                                      lo, hi)])
    n11, gv, blade = x.T
    return {"n11": n11, "opening": gv, "blade_angle": blade, "q11": turbine.q11(n11, gv, blade),
            "m11": turbine.m11(n11, gv, blade)}


def train_double_regulated_nets(samples: dict, *, hidden: int = 15, restarts: int = 3, seed: int = 0,
                                split=(0.70, 0.15, 0.15)) -> DoubleRegulatedNets:
    """Q11 and M11 nets (3-H-1 logsig, Levenberg-Marquardt, as :class:`FCCMNet`) from chart samples with keys
    n11, opening, blade_angle, q11, m11; the flow net uses ``seed``, the torque net ``seed + 1``."""
    X = np.column_stack([np.asarray(samples[k], dtype=float) for k in NET3_INPUTS])
    nets, record = {}, {"hidden": hidden, "restarts": restarts, "split": list(split), "n_samples": int(len(X))}
    for offset, (key, out) in enumerate((("flow", "q11"), ("torque", "m11"))):
        est = FCCMNet(hidden=hidden, restarts=restarts, seed=seed + offset, split=split).fit(
            X, np.asarray(samples[out], dtype=float), input_names=NET3_INPUTS, output_names=(out,))
        nets[key] = est.weights_
        record[key] = est.training_record()
    return DoubleRegulatedNets(flow=nets["flow"], torque=nets["torque"], opening_unit="deg", training=record)


def on_cam_relation(efficiency, openings, heads_m, *, speed_rpm: float, runner_diameter_m: float,
                    blade_range=(-18.0, 16.0), step_deg: float = 0.05) -> dict:
    """The on-cam (combinator) relation phi(a, H): the blade angle of best efficiency at each guide-vane opening a
    and head H of a unit at constant speed, ``n11 = n D / sqrt(H)`` (eq. (2) of paper 003).

    Parameters
    ----------
    efficiency : callable (n11, opening, blade_angle) -> eta, broadcast
        E.g. :meth:`DoubleRegulatedNets.efficiency` or :meth:`hillchart.synthetic.bulb.SyntheticBulb.unit_efficiency`.
    openings, heads_m : array_like
    blade_range : (lo, hi), deg
    step_deg : float
        Scan step; the optimum is refined by the vertex of the parabola through the best scan point and its
        neighbours (exact for a locally quadratic efficiency).

    Returns
    -------
    dict
        ``opening`` (na,), ``head_m`` (nh,), ``blade_angle`` (nh, na) in deg, ``efficiency`` (nh, na), ``at_bound``
        (nh, na) bool: the optimum is on the blade range's edge (the cam saturates there).
    """
    openings = np.atleast_1d(np.asarray(openings, dtype=float))
    heads = np.atleast_1d(np.asarray(heads_m, dtype=float))
    if np.any(heads <= 0):
        raise InputError(f"heads_m must be > 0, got {heads.tolist()}")
    phi = np.arange(blade_range[0], blade_range[1] + 1e-9, step_deg)
    n11 = speed_rpm * runner_diameter_m / np.sqrt(heads)  # eq. (2), paper 003
    eta = np.asarray(efficiency(n11[:, None, None], openings[None, :, None], phi[None, None, :]), dtype=float)
    if not np.all(np.isfinite(eta)):
        raise NumericalError("on_cam_relation: efficiency is not finite on the scan (Q11 <= 0 somewhere)")
    k = np.argmax(eta, axis=2)
    kk = np.clip(k, 1, phi.size - 2)
    take = lambda off: np.take_along_axis(eta, (kk + off)[..., None], axis=2)[..., 0]  # noqa: E731
    e0, em, ep = take(0), take(-1), take(1)
    curvature = em - 2 * e0 + ep
    shift = np.where(curvature < 0, 0.5 * (em - ep) / np.where(curvature < 0, curvature, -1.0), 0.0)
    at_bound = (k == 0) | (k == phi.size - 1)
    best = np.where(at_bound, phi[k], phi[kk] + np.clip(shift, -1, 1) * step_deg)
    best_eta = np.where(at_bound, np.take_along_axis(eta, k[..., None], axis=2)[..., 0],
                        e0 - 0.125 * (em - ep) ** 2 / np.where(curvature < 0, curvature, -1.0))
    return {"opening": openings, "head_m": heads, "blade_angle": best, "efficiency": best_eta, "at_bound": at_bound}


def plot_on_cam(nets_cam: dict, truth_cam: dict | None, path) -> Path:
    """The on-cam relation phi(a) for each head (nets solid, exact dashed) and its efficiency."""
    plt, (fig, ax) = _figure(1, 2, (13, 5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, h in enumerate(nets_cam["head_m"]):
        c = colors[i % len(colors)]
        ax[0, 0].plot(nets_cam["opening"], nets_cam["blade_angle"][i], "-", color=c, label=f"H = {h:g} m (nets)")
        ax[0, 1].plot(nets_cam["opening"], nets_cam["efficiency"][i], "-", color=c, label=f"H = {h:g} m (nets)")
        if truth_cam is not None:
            ax[0, 0].plot(truth_cam["opening"], truth_cam["blade_angle"][i], "--", color=c, label="exact")
            ax[0, 1].plot(truth_cam["opening"], truth_cam["efficiency"][i], "--", color=c, label="exact")
    ax[0, 0].set(xlabel="guide-vane opening a (deg)", ylabel="blade angle phi (deg)",
                 title="on-cam relation phi(a, H): blade angle of best efficiency")
    ax[0, 1].set(xlabel="guide-vane opening a (deg)", ylabel="efficiency on cam", title="efficiency on the cam")
    ax[0, 0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
