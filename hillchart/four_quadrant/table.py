"""Complete-characteristics tables of pump-turbines and the Wylie-Streeter pump curves: read, check, transform.

A complete-characteristics folder holds::

    table.toml    name, opening_unit ("mm" | "deg" | "%"), opening_max, and
                  for unit quantities:  q11_unit ("m3/s" | "l/s"), rated_n11_rpm, rated_q11, rated_m11_nm
                  for Suter curves:     suter_convention ("turbine" | "wylie-streeter"), suter_k1, suter_k2,
                                        suter_c_h, suter_c_y (the transform the curves were made with)
    table.csv     opening,n11,q11,m11   points on the opening lines over all four quadrants (unit quantities at
                                        H = 1 m, turbine-positive: N11 r/min, Q11 in q11_unit, M11 N*m), or
                  opening,x,wh,wm       the curves themselves (x in radians on the convention's axis)

The rated point (one turbine-mode point, usually the best-efficiency point) makes the Suter ratios:
v = N11/N11_r, q = Q11/Q11_r, h = 1, m = M11/M11_r (unit quantities are at unit head); y = opening/opening_max.
:func:`load_complete_characteristics` returns a :class:`CompleteCharacteristics`; its
:meth:`~CompleteCharacteristics.suter` gives the curves' samples for any transform constants. Anything wrong is an
:class:`~hillchart.errors.InputError` naming the file, the row (line in the file) and the column, the value
and what is allowed.

:func:`load_wylie_streeter_curves` reads the Suter curves WH(x), WB(x) of pumps as Wylie, Streeter and Suo (1993)
tabulate them (Fig. 7-2: a radial, a mixed-flow and an axial pump), pump-positive.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hillchart.errors import InputError
from hillchart.four_quadrant.suter import CONVENTIONS, SuterConstants, suter_transform
from hillchart.io.samples import N11_MAX_RPM, OPENING_MAX_PLAUSIBLE, OPENING_UNITS, Q11_UNITS
from hillchart.io.tabular import numbered_rows, read_table, read_text

UNIT_COLUMNS = ("opening", "n11", "q11", "m11")
SUTER_COLUMNS = ("opening", "x", "wh", "wm")
COMMON_KEYS = ("name", "opening_unit", "opening_max")
UNIT_KEYS = ("q11_unit", "rated_n11_rpm", "rated_q11", "rated_m11_nm")
SUTER_KEYS = ("suter_convention", "suter_k1", "suter_k2", "suter_c_h", "suter_c_y")
#: Fewest points an opening line needs.
MIN_POINTS_PER_LINE = 3


@dataclass(frozen=True, eq=False)
class CompleteCharacteristics:
    """A validated complete-characteristics table.

    Attributes
    ----------
    name, opening_unit : str
    opening_max : float
        Full-stroke opening in ``opening_unit``: y = opening / opening_max.
    opening : ndarray (n,)
        Opening of each point, ``opening_unit``.
    n11, q11, m11 : ndarray (n,) or None
        Unit quantities (r/min, m^3/s, N*m) of a unit-quantity table; None for a table of curves.
    rated : dict or None
        ``{"n11_rpm", "q11_m3_s", "m11_nm"}`` of a unit-quantity table.
    x, wh, wm : ndarray (n,) or None
        The curves of a table of curves (x in radians on ``convention``'s axis); None otherwise.
    constants : SuterConstants or None
        The transform of a table of curves.
    convention : str or None
    source : str
        The file read.
    """

    name: str
    opening_unit: str
    opening_max: float
    opening: np.ndarray
    n11: np.ndarray | None = None
    q11: np.ndarray | None = None
    m11: np.ndarray | None = None
    rated: dict | None = None
    x: np.ndarray | None = None
    wh: np.ndarray | None = None
    wm: np.ndarray | None = None
    constants: SuterConstants | None = None
    convention: str | None = None
    source: str = ""

    @property
    def is_curves(self) -> bool:
        """True when the table holds the Suter curves themselves."""
        return self.x is not None

    def relative(self) -> dict:
        """Suter ratios of a unit-quantity table: ``speed``, ``flow``, ``head`` (1), ``torque``, ``opening``
        (turbine convention)."""
        if self.is_curves:
            raise InputError(f"{self.source}: a table of curves has no unit quantities to make ratios of")
        r = self.rated
        return {"speed": self.n11 / r["n11_rpm"], "flow": self.q11 / r["q11_m3_s"], "head": np.ones_like(self.n11),
                "torque": self.m11 / r["m11_nm"], "opening": self.opening / self.opening_max}

    def suter(self, constants: SuterConstants | None = None, convention: str = "turbine") -> dict:
        """The curves' samples ``{"x", "opening", "wh", "wm"}`` (x in radians, opening relative) under
        ``constants``; a table of curves gives its own (and refuses other constants or another convention)."""
        if self.is_curves:
            if (constants is not None and constants != self.constants) or convention != self.convention:
                raise InputError(f"{self.source}: the table holds curves of the transform {self.constants} in the "
                                 f"{self.convention!r} convention; it cannot be re-transformed to {constants} in "
                                 f"{convention!r} (that needs the unit quantities)")
            return {"x": self.x, "opening": self.opening / self.opening_max, "wh": self.wh, "wm": self.wm}
        rel = self.relative()
        signs = 1.0 if convention == "turbine" else -1.0
        x, wh, wm = suter_transform(signs * rel["speed"], signs * rel["flow"], rel["head"], rel["torque"],
                                    rel["opening"], constants=constants or SuterConstants(), convention=convention)
        return {"x": x, "opening": rel["opening"], "wh": wh, "wm": wm}


def _number(path, key: str, value, *, positive: bool = True, nonnegative: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or (positive and value <= 0) or (nonnegative and value < 0):
        need = "> 0" if positive else ">= 0"
        raise InputError(f"{path}: {key} must be a finite number {need}, got {value!r}")
    return float(value)


def _read_info(path: Path) -> dict:
    try:
        doc = tomllib.loads(read_text(path, "table.toml"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    allowed = COMMON_KEYS + UNIT_KEYS + SUTER_KEYS
    unknown = sorted(set(doc) - set(allowed))
    if unknown:
        raise InputError(f"{path}: unknown key(s) {unknown}; allowed: {', '.join(allowed)}")
    missing = [k for k in COMMON_KEYS if k not in doc]
    if missing:
        raise InputError(f"{path}: missing key(s) {missing} (required: {', '.join(COMMON_KEYS)})")
    if not isinstance(doc["name"], str) or not doc["name"].strip():
        raise InputError(f"{path}: name must be a non-empty string, got {doc['name']!r}")
    if doc["opening_unit"] not in OPENING_UNITS:
        raise InputError(f"{path}: opening_unit must be one of {OPENING_UNITS}, got {doc['opening_unit']!r}")
    top = OPENING_MAX_PLAUSIBLE[doc["opening_unit"]]
    opening_max = _number(path, "opening_max", doc["opening_max"])
    if opening_max > top:
        raise InputError(f"{path}: opening_max = {opening_max!r} {doc['opening_unit']} is implausible (at most about "
                         f"{top:g}); check the value and opening_unit")
    return doc


def load_complete_characteristics(folder) -> CompleteCharacteristics:
    """Read a complete-characteristics folder (module docstring).

    Raises
    ------
    InputError
        A missing or unknown key or column, keys of the other form, a value outside its range (opening in
        (0, opening_max], |N11| <= 1000 r/min, x in [0, 2 pi], a rated value <= 0), a point at standstill, an
        opening line with fewer than 3 points: the message names the file, the row and the column.

    Examples
    --------
    >>> from data_synthetic import PUMP_TURBINE_DIR
    >>> table = load_complete_characteristics(PUMP_TURBINE_DIR)
    >>> table.is_curves, sorted(set(table.opening.tolist()))[:3]
    (False, [4.0, 6.0, 8.0])
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a complete-characteristics folder (no such directory)")
    info_path, csv_path = folder / "table.toml", folder / "table.csv"
    for path in (info_path, csv_path):
        if not path.is_file():
            raise InputError(f"{path}: missing file (a complete-characteristics folder needs table.toml and table.csv)")
    doc = _read_info(info_path)
    _, rows = numbered_rows(read_text(csv_path, "CSV file"), csv_path, comments=True)
    header = [c.strip() for c in rows[0][1]] if rows else []
    curves = "x" in header
    columns = SUTER_COLUMNS if curves else UNIT_COLUMNS
    own, other = (SUTER_KEYS, UNIT_KEYS) if curves else (UNIT_KEYS, SUTER_KEYS)
    stray = [k for k in other if k in doc]
    if stray:
        raise InputError(f"{info_path}: key(s) {stray} belong to a table with columns "
                         f"{','.join(UNIT_COLUMNS if curves else SUTER_COLUMNS)}, but table.csv has "
                         f"{','.join(columns)}")
    missing = [k for k in own if k not in doc]
    if missing:
        raise InputError(f"{info_path}: missing key(s) {missing} (a table with columns {','.join(columns)} needs "
                         f"{', '.join(own)})")
    table = read_table(csv_path, columns)
    values, lines = table.columns, table.lines
    opening_max = float(doc["opening_max"])

    def refuse(column: str, bad: np.ndarray, allowed: str):
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{csv_path}: row {int(lines[i])}, column {column!r}: {values[column][i]!r} is outside "
                         f"{allowed}")

    opening = values["opening"]
    if np.any((opening <= 0) | (opening > opening_max)):
        refuse("opening", (opening <= 0) | (opening > opening_max),
               f"(0, opening_max = {opening_max:g}] (a closed vane passes no flow at unit head)")
    levels, counts = np.unique(opening, return_counts=True)
    if np.any(counts < MIN_POINTS_PER_LINE):
        raise InputError(f"{csv_path}: the opening line(s) at {levels[counts < MIN_POINTS_PER_LINE].tolist()} have "
                         f"fewer than {MIN_POINTS_PER_LINE} points")
    common = dict(name=doc["name"], opening_unit=doc["opening_unit"], opening_max=opening_max, opening=opening,
                  source=str(csv_path))
    if curves:
        if doc["suter_convention"] not in CONVENTIONS:
            raise InputError(f"{info_path}: suter_convention must be one of {CONVENTIONS}, got "
                             f"{doc['suter_convention']!r}")
        constants = SuterConstants(**{k: _number(info_path, f"suter_{k}", doc[f"suter_{k}"], positive=False,
                                                 nonnegative=True) for k in ("k1", "k2", "c_h", "c_y")})
        x = values["x"]
        if np.any((x < 0) | (x > 2 * math.pi)):
            refuse("x", (x < 0) | (x > 2 * math.pi), "[0, 2 pi] (radians)")
        return CompleteCharacteristics(**common, x=x, wh=values["wh"], wm=values["wm"], constants=constants,
                                       convention=doc["suter_convention"])
    if doc["q11_unit"] not in Q11_UNITS:
        raise InputError(f"{info_path}: q11_unit must be one of {tuple(Q11_UNITS)}, got {doc['q11_unit']!r}")
    scale = Q11_UNITS[doc["q11_unit"]]
    rated = {"n11_rpm": _number(info_path, "rated_n11_rpm", doc["rated_n11_rpm"]),
             "q11_m3_s": _number(info_path, "rated_q11", doc["rated_q11"]) * scale,
             "m11_nm": _number(info_path, "rated_m11_nm", doc["rated_m11_nm"])}
    n11, q11 = values["n11"], values["q11"]
    if np.any(np.abs(n11) > N11_MAX_RPM):
        refuse("n11", np.abs(n11) > N11_MAX_RPM, f"[-{N11_MAX_RPM:g}, {N11_MAX_RPM:g}] r/min")
    if np.any((n11 == 0) & (q11 == 0)):
        refuse("q11", (n11 == 0) & (q11 == 0), "the plane without the origin (N11 = Q11 = 0 is standstill, no "
               "point at unit head)")
    return CompleteCharacteristics(**common, n11=n11, q11=q11 * scale, m11=values["m11"], rated=rated)


@dataclass(frozen=True, eq=False)
class PumpCurves:
    """Suter curves of one pump, pump-positive (Wylie-Streeter convention): x (rad, ascending over [0, 2 pi]),
    WH and WB (= WM) at each x, and the pump's specific speed as the table names it (US units)."""

    name: str
    specific_speed: float
    x: np.ndarray
    wh: np.ndarray
    wb: np.ndarray


def load_wylie_streeter_curves(path) -> dict[str, PumpCurves]:
    """Read a table of pumps' Suter curves: columns ``x_rad``, ``x_deg`` and pairs ``WH_Ns<N>_<name>``,
    ``WB_Ns<N>_<name>`` (WH and WB of one pump, N its specific speed); ``#`` lines are comments.

    Returns
    -------
    dict
        ``{name: PumpCurves}`` in the file's order.

    Raises
    ------
    InputError
        No x_rad or x_deg column, x_rad not ascending over [0, 2 pi], x_deg not x_rad in degrees (to 0.06 deg, the
        table's rounding), a WH column without its WB (or the reverse), a WH or WB column not named as above.
    """
    path = Path(path)
    _, rows = numbered_rows(read_text(path, "CSV file"), path, comments=True)
    if not rows:
        raise InputError(f"{path}: empty file; expected a header x_rad,x_deg,WH_Ns<N>_<name>,WB_Ns<N>_<name>,...")
    header = [c.strip() for c in rows[0][1]]
    for name in ("x_rad", "x_deg"):
        if name not in header:
            raise InputError(f"{path}: missing column {name!r}; the header must start x_rad,x_deg,WH_...,WB_...")
    table = read_table(path, tuple(header))
    x = table.columns["x_rad"]
    if x[0] < 0 or x[-1] > 2 * math.pi + 1e-9 or np.any(np.diff(x) <= 0):
        raise InputError(f"{path}: column 'x_rad' must ascend within [0, 2 pi], got {x[0]!r} .. {x[-1]!r}"
                         + (" (not ascending)" if np.any(np.diff(x) <= 0) else ""))
    off = np.abs(np.degrees(x) - table.columns["x_deg"])
    if np.any(off > 0.06):
        i = int(np.argmax(off))
        raise InputError(f"{path}: row {int(table.lines[i])}: x_deg = {table.columns['x_deg'][i]!r} is not x_rad = "
                         f"{x[i]!r} in degrees ({np.degrees(x[i]):.3f})")
    pumps = {}
    for column in header[2:]:
        parts = column.split("_", 2)
        if len(parts) != 3 or parts[0] not in ("WH", "WB") or not parts[1].startswith("Ns"):
            raise InputError(f"{path}: column {column!r} is not WH_Ns<N>_<name> or WB_Ns<N>_<name>")
        try:
            specific_speed = float(parts[1][2:])
        except ValueError:
            raise InputError(f"{path}: column {column!r}: the specific speed {parts[1][2:]!r} is not a "
                             "number") from None
        partner = ("WB_" if parts[0] == "WH" else "WH_") + "_".join(parts[1:])
        if partner not in header:
            raise InputError(f"{path}: column {column!r} has no partner {partner!r}")
        if parts[0] == "WH":
            pumps[parts[2]] = PumpCurves(name=parts[2], specific_speed=specific_speed, x=x,
                                         wh=table.columns[column], wb=table.columns[partner])
    return pumps
