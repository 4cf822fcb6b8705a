"""Relative series (paper 000 eq. (3)) and reading measured ones.

:class:`RelativeSeries` holds uniformly sampled ``x, h, y, m, q`` about an :class:`OperatingPoint` O:
``x = n/n0 - 1``, ``h = H/H0 - 1``, ``y = a/a0 - 1``, ``m = M/M0 - 1``, ``q = Q/Q0 - 1``. It is made from physical
series (the simulator's, or a measured CSV read by :func:`load_measured_series`) by linear interpolation onto the tau
grid (paper 000 section 5). The checks of a measured file (units, outliers, size) are in
:mod:`simulate.identification.series_checks`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from hillchart.errors import InputError

#: CSV columns ``--data`` needs (units in the names; extra columns are ignored). ``opening`` is any unit
#: proportional to the chart opening (stroke fraction or chart units): only a/a0 is used.
MEASURED_COLUMNS = ("time_s", "speed_rpm", "head_m", "opening", "torque_nm", "flow_m3_s")


@dataclass(frozen=True)
class OperatingPoint:
    """The point O the relative variables refer to (physical units)."""

    speed_rpm: float
    head_m: float
    flow_m3_s: float
    torque_nm: float
    opening: float  # same unit as the opening series (stroke fraction for simulated runs)

    def __post_init__(self):
        for name in ("speed_rpm", "head_m", "flow_m3_s", "torque_nm", "opening"):
            value = getattr(self, name)
            if not math.isfinite(value) or value <= 0:
                raise InputError(f"operating point {name} must be finite and > 0 (relative variables divide by it), "
                                 f"got {value!r}")


@dataclass(frozen=True, eq=False)
class RelativeSeries:
    """Uniformly sampled relative series (paper 000 eq. (3)); each array has shape (N,)."""

    time_s: np.ndarray
    x: np.ndarray
    h: np.ndarray
    y: np.ndarray
    m: np.ndarray
    q: np.ndarray
    sample_time_s: float
    operating_point: OperatingPoint

    @classmethod
    def from_physical(cls, time_s, speed_rpm, head_m, opening, torque_nm, flow_m3_s, *, sample_time_s: float,
                      operating_point: OperatingPoint | None = None, t_start_s: float | None = None):
        """Resample physical series to ``sample_time_s`` by linear interpolation (paper 000 section 5) and make
        them relative to ``operating_point`` (default: the first sample).

        Examples
        --------
        >>> t = np.arange(51) * 0.1                       # 10 Hz sensor, 5 s
        >>> s = RelativeSeries.from_physical(t, 200 + 2 * t, 100 + 0 * t, 0.5 + 0 * t, 1e6 + 0 * t, 50 + 0 * t,
        ...                                  sample_time_s=0.5)
        >>> s.time_s[:3].tolist(), [round(float(v), 12) for v in s.x[:3]]
        ([0.0, 0.5, 1.0], [0.0, 0.005, 0.01])
        """
        t = np.asarray(time_s, dtype=float)
        series = {"speed_rpm": speed_rpm, "head_m": head_m, "opening": opening, "torque_nm": torque_nm,
                  "flow_m3_s": flow_m3_s}
        arrays = {}
        for name, values in series.items():
            arr = np.asarray(values, dtype=float)
            if arr.shape != t.shape:
                raise InputError(f"{name} must have as many samples as time_s ({t.size}), got {arr.size}")
            if not np.all(np.isfinite(arr)):
                raise InputError(f"{name} contains a non-finite value at row {int(np.argmax(~np.isfinite(arr)))}")
            arrays[name] = arr
        if t.ndim != 1 or t.size < 10:
            raise InputError(f"time_s must be one-dimensional with at least 10 samples, got shape {t.shape}")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputError("time_s must be finite and strictly increasing")
        tau = float(sample_time_s)
        start = float(t[0]) if t_start_s is None else float(t_start_s)
        n = int(math.floor((t[-1] - start) / tau + 1e-9)) + 1
        if n < 10:
            raise InputError(f"the series lasts {t[-1] - start:.6g} s: fewer than 10 samples at tau = {tau} s")
        grid = start + tau * np.arange(n)
        res = {name: np.interp(grid, t, arr) for name, arr in arrays.items()}
        if operating_point is None:
            operating_point = OperatingPoint(speed_rpm=arrays["speed_rpm"][0], head_m=arrays["head_m"][0],
                                             flow_m3_s=arrays["flow_m3_s"][0], torque_nm=arrays["torque_nm"][0],
                                             opening=arrays["opening"][0])
        op = operating_point
        return cls(time_s=grid - grid[0], x=res["speed_rpm"] / op.speed_rpm - 1.0, h=res["head_m"] / op.head_m - 1.0,
                   y=res["opening"] / op.opening - 1.0, m=res["torque_nm"] / op.torque_nm - 1.0,
                   q=res["flow_m3_s"] / op.flow_m3_s - 1.0, sample_time_s=tau, operating_point=op)

    def with_noise(self, level: float, seed: int) -> "RelativeSeries":
        """A copy with uniform noise in [-level, level] added to x, h, m, q (the opening is the command)."""
        if level == 0:
            return self
        rng = np.random.default_rng(seed)
        noisy = {k: getattr(self, k) + rng.uniform(-level, level, self.x.size) for k in ("x", "h", "m", "q")}
        return replace(self, **noisy)


def load_measured_series(path, *, sample_time_s: float, operating_point: OperatingPoint | None = None):
    """Read a measured series CSV and resample it (Wang et al. 2023, section 5).

    The file has one header line naming the columns with their units (:data:`MEASURED_COLUMNS`: ``time_s,
    speed_rpm, head_m, opening, torque_nm, flow_m3_s``; other columns are ignored, so ``timeseries.csv`` from
    ``hillsim run`` works as is), then one numeric row per sample, time strictly increasing. The sensors may be
    sampled at any rate; every column is interpolated linearly onto the tau grid.
    """
    from hillchart.io.tabular import read_table
    from simulate.identification.series_checks import check_measured_table

    path = Path(path)
    table = read_table(path, MEASURED_COLUMNS, extra="ignore", what="series file")  # BOM, ';'/tab, rows = lines
    if len(table.lines) < 10:
        raise InputError(f"{path}: needs at least 10 data rows, got {len(table.lines)}")
    check_measured_table(path, table.columns, table.lines, sample_time_s=sample_time_s)  # units, outliers, size
    if table.note:
        warnings.warn(table.note, UserWarning, stacklevel=2)
    try:
        return RelativeSeries.from_physical(*(table.columns[c] for c in MEASURED_COLUMNS),
                                            sample_time_s=sample_time_s, operating_point=operating_point)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
