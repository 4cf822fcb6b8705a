"""Plausibility checks of a measured series before identification (``hillsim identify --data``).

Pure functions on the columns as read (physical units named by the header, rows numbered as the file's lines):

- :func:`check_measured_table` (the loader calls it): time strictly increasing (the row named), sampling not coarser
  than the identification step (time in ms or us shows up here), the resampled size within a memory bound, opening a
  stroke fraction (not % or chart units), speed and head positive, isolated outliers (a 1e308 or a sensor dropout
  that linear resampling would hide) named by row;
- :func:`check_against_plant`: the operating point against the plant's rated values, naming the likely unit mix-up
  (speed in rad/s or r/s, flow in l/s, torque in kN*m, ...);
- :func:`small_signal_warning`: a warning when the series leaves the range where the linear model applies.

Every failure is an :class:`~hillchart.errors.InputError` that names the file, the column, the row(s) and what is
expected.
"""

from __future__ import annotations

import math

import numpy as np

from hillchart.errors import InputError

#: Largest stroke fraction the simulator accepts (``governor.stroke_max`` <= 1.5).
STROKE_MAX = 1.5
#: Sampling coarser than this many identification steps is refused (interpolation would invent the data between).
MAX_SAMPLING_RATIO = 5.0
#: Bytes per resampled sample over the whole identification (6 series, regressors and theta histories of the
#: recursive estimators, step and simulation-mode responses): tracemalloc peak of ``identify_measured`` measured 520-575
#: B per sample (300 and 1200 samples of the shipped load rejection), rounded up to 1 KiB for the figures.
BYTES_PER_SAMPLE = 1024
#: Default memory bound of the resampled series (bytes).
MAX_BYTES = 2 * 1024**3
#: A step between samples longer than this many median sampling intervals (and than MAX_SAMPLING_RATIO tau) is a
#: hole in the record, refused.
MAX_GAP_STEPS = 50.0
#: Hampel outlier test: window half-width (samples) and threshold (robust standard deviations).
HAMPEL_HALF_WIDTH = 3
HAMPEL_SIGMAS = 10.0
#: ... and the smallest deviation flagged, as a fraction of the range of the window medians (so quantization and noise
#: are never flagged, while a dropout to 0 or a spike is).
HAMPEL_RANGE_FRACTION = 0.25


def _rows(rows: np.ndarray, idx, limit: int = 5) -> str:
    picked = [int(rows[i]) for i in idx[:limit]]
    more = f" and {len(idx) - limit} more" if len(idx) > limit else ""
    return f"row{'s' if len(idx) > 1 else ''} {', '.join(map(str, picked))}{more}"


def _num(value: float) -> str:
    """A number for a message: plain Python formatting, never a numpy repr."""
    return f"{float(value):.6g}"


def check_time(path, time_s: np.ndarray, rows: np.ndarray, *, sample_time_s: float,
               max_bytes: float = MAX_BYTES) -> None:
    """Strictly increasing time (the first offending row named), sampling not coarser than
    ``MAX_SAMPLING_RATIO * sample_time_s``, and the resampled series within ``max_bytes``.

    Examples
    --------
    >>> check_time("s.csv", np.array([0.0, 0.1, 0.1]), np.array([2, 3, 4]), sample_time_s=0.2)
    ... # doctest: +NORMALIZE_WHITESPACE
    Traceback (most recent call last):
    ...
    hillchart.errors.InputError: s.csv: column 'time_s' must be strictly increasing: row 4 has 0.1 s after 0.1 s
    at row 3
    """
    t = np.asarray(time_s, dtype=float)
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0])
        raise InputError(f"{path}: column 'time_s' must be strictly increasing: row {int(rows[i + 1])} has "
                         f"{_num(t[i + 1])} s after {_num(t[i])} s at row {int(rows[i])}")
    if t.size < 2:
        return
    tau = float(sample_time_s)
    step = float(np.median(np.diff(t)))
    gaps = np.diff(t)
    worst = int(np.argmax(gaps))
    if gaps[worst] > max(MAX_SAMPLING_RATIO * tau, MAX_GAP_STEPS * step):
        # interpolating across a hole in the record invents the data the estimators would fit
        raise InputError(f"{path}: column 'time_s' jumps by {_num(gaps[worst])} s from row {int(rows[worst])} to "
                         f"row {int(rows[worst + 1])} (the median sampling interval is {_num(step)} s): a hole in "
                         "the record; identify the parts before and after it separately")
    duration = float(t[-1] - t[0])
    hint = _time_unit_hint(step, duration, tau)
    if step > MAX_SAMPLING_RATIO * tau:
        raise InputError(f"{path}: column 'time_s': the median sampling interval is {_num(step)} s, more than "
                         f"{MAX_SAMPLING_RATIO:g} x the identification step tau = {tau:g} s{hint}; give time in "
                         "seconds, or a larger --tau")
    samples = duration / tau + 1
    need = samples * BYTES_PER_SAMPLE
    if need > max_bytes:
        hint = hint if duration > 86400.0 else ""  # longer than a day: units more likely wrong than the test
        raise InputError(f"{path}: column 'time_s' spans {_num(duration)} s: at tau = {tau:g} s that is "
                         f"{samples:.3g} samples, about {need / 1024**3:.3g} GiB to identify (limit "
                         f"{max_bytes / 1024**3:.3g} GiB){hint}; shorten the series or give a larger --tau")


def _time_unit_hint(step: float, duration: float, tau: float) -> str:
    """' (is time in ms? ...)' when reading the column as ms or us gives a usable sampling interval."""
    for unit, factor in (("ms", 1e-3), ("us", 1e-6)):
        if step * factor <= MAX_SAMPLING_RATIO * tau:
            return (f" (is time in {unit}? then the sampling interval is {_num(step * factor)} s and the series "
                    f"lasts {_num(duration * factor)} s)")
    return ""


def hampel_outliers(values: np.ndarray, *, half_width: int = HAMPEL_HALF_WIDTH, sigmas: float = HAMPEL_SIGMAS,
                    range_fraction: float = HAMPEL_RANGE_FRACTION) -> np.ndarray:
    """Indices of isolated outliers: samples farther from the median of their window (2 half_width + 1) than both
    ``sigmas`` robust standard deviations (1.4826 MAD) of the window and ``range_fraction`` of the range of the
    window medians (at least 0.1 % of the column's median) and ``sigmas`` times the column's noise (from its successive
    differences). A step or a ramp is followed by the window median (a jump that persists for more than
    ``half_width`` samples moves it): never flagged; a dropout of up to ``half_width`` samples is.

    Examples
    --------
    >>> x = np.r_[np.full(20, 200.0), np.full(20, 210.0)]     # a step: no outlier
    >>> hampel_outliers(x).tolist()
    []
    >>> x[7] = 1e308; x[30] = 0.0                              # a spike and a dropout
    >>> hampel_outliers(x).tolist()
    [7, 30]
    """
    x = np.asarray(values, dtype=float)
    n = x.size
    if n < 2 * half_width + 1:
        return np.empty(0, dtype=int)
    windows = np.lib.stride_tricks.sliding_window_view(np.pad(x, half_width, mode="edge"), 2 * half_width + 1)
    med = np.median(windows, axis=1)
    mad = 1.4826 * np.median(np.abs(windows - med[:, None]), axis=1)
    span = float(np.max(med) - np.min(med))  # range of the window medians: isolated spikes do not widen it
    with np.errstate(over="ignore", invalid="ignore"):
        steps = np.abs(np.diff(x))
        # the column's noise (robust standard deviation of a sample, from its successive differences: a few steps or
        # spikes do not move it): a 7-sample window's MAD is often far below it by chance, and on a column that barely
        # moves (the speed of an opening-step test) the range floor is too, so 0.1 % noise was flagged
        noise = 1.4826 * float(np.median(steps)) / math.sqrt(2.0)
        floor = max(range_fraction * max(span, 1e-3 * abs(float(np.median(x))), np.finfo(float).tiny),
                    sigmas * noise)
        deviation = np.abs(x - med)
    return np.flatnonzero((deviation > sigmas * mad) & (deviation > floor))


def check_measured_table(path, columns: dict, rows: np.ndarray, *, sample_time_s: float,
                         max_bytes: float = MAX_BYTES) -> None:
    """Every check of the module docstring that needs no plant, on the columns ``time_s, speed_rpm, head_m,
    opening, torque_nm, flow_m3_s`` as read from ``path`` (``rows``: their file line numbers)."""
    rows = np.asarray(rows)
    check_time(path, columns["time_s"], rows, sample_time_s=sample_time_s, max_bytes=max_bytes)
    for name, unit in (("speed_rpm", "r/min"), ("head_m", "m")):
        bad = np.flatnonzero(np.asarray(columns[name]) <= 0)
        if bad.size:
            raise InputError(f"{path}: column {name!r} must be > 0 {unit}: {_num(columns[name][bad[0]])} at "
                             f"{_rows(rows, bad)}")
    opening = np.asarray(columns["opening"], dtype=float)
    bad = np.flatnonzero((opening < 0) | (opening > STROKE_MAX))
    if bad.size:
        top = float(np.max(opening))
        hint = (" (the values look like % or the chart's units, e.g. mm: divide by 100 or by the opening at full "
                "stroke)" if top > STROKE_MAX else "")
        raise InputError(f"{path}: column 'opening' must be the stroke fraction in [0, {STROKE_MAX:g}] (1 = full "
                         f"servo stroke): {_num(opening[bad[0]])} at {_rows(rows, bad)}{hint}")
    for name in ("speed_rpm", "head_m", "opening", "torque_nm", "flow_m3_s"):
        idx = hampel_outliers(columns[name])
        if idx.size:
            values = ", ".join(_num(columns[name][i]) for i in idx[:5])
            raise InputError(f"{path}: column {name!r}: isolated outlier(s) at {_rows(rows, idx)} (values {values}, "
                             "far from their neighbours); correct or remove those rows")


#: Unit mix-ups recognised by :func:`check_against_plant`: (column, factor the value was multiplied by, wrong unit).
UNIT_SLIPS = {
    "speed_rpm": ((2 * math.pi / 60, "rad/s"), (1 / 60, "r/s"), (2 * math.pi / 60 * 180 / math.pi, "deg/s")),
    "head_m": ((9.81 * 1000 / 1e6, "MPa"), (9.81 * 1000 / 1e5, "bar"), (9.81 * 1000 / 1e3, "kPa"),
               ),
    "flow_m3_s": ((1000.0, "l/s"), (3600.0, "m3/h")),
    "torque_nm": ((1e-3, "kN*m"), (1e-6, "MN*m")),
}


#: Speed at the first sample, as a fraction of the plant's rated speed: a unit under test runs near rated speed (a
#: start-up or a runaway test is not an identification series); outside, the data are likely another unit's.
SPEED_RANGE = (0.7, 1.4)
#: Net head at the first sample, as a fraction of the plant's static (gross) head: the steady net head is the gross
#: head less the losses (above half of it on any plant) and exceeds it only by a headwater above the plant file's
#: level or a gauge error (20 %); outside, the data are likely another plant's.
HEAD_RANGE_OF_STATIC = (0.5, 1.2)


def check_duration_against_plant(path, time_s, plant) -> None:
    """A series much shorter than the unit's inertia time T_a cannot show its speed dynamics: most likely the time
    column is in minutes (or hours). An InputError that says so."""
    t = np.asarray(time_s, dtype=float)
    if t.size < 2:
        return
    duration = float(t[-1] - t[0])
    ta = float(plant.generator.inertia_time_s)
    if duration < 0.5 * ta:
        raise InputError(f"{path}: column 'time_s' spans {_num(duration)} s, less than half the unit's inertia time "
                         f"generator.inertia_time_s = {ta:g} s, too short to identify the speed dynamics; is time "
                         f"in minutes (then it spans {_num(duration * 60)} s)? the column must be in seconds")


def check_against_plant(path, operating_point, plant, *, low: float = 0.2, high: float = 5.0) -> None:
    """The operating point (first sample) against the plant's rated values: an error when a value is what the
    rated one would be in another unit (within a factor 2 of :data:`UNIT_SLIPS`), or when speed or head are outside
    [low, high] x rated (flow and torque may be small at part load or near no load)."""
    tur = plant.turbine
    torque_rated = tur.rated_power_mw * 1e6 / (tur.rated_speed_rpm * 2 * math.pi / 60)
    rated = {"speed_rpm": (tur.rated_speed_rpm, "r/min"), "head_m": (tur.rated_head_m, "m"),
             "flow_m3_s": (tur.rated_flow_m3_s, "m3/s"), "torque_nm": (torque_rated, "N*m")}
    for name, (value_rated, unit) in rated.items():
        value = float(getattr(operating_point, name))
        ratio = value / value_rated
        if low <= ratio <= high or ratio <= 0:
            continue
        slip = min(UNIT_SLIPS[name], key=lambda s: abs(math.log(ratio / s[0])))
        start = (f"{path}: column {name!r} starts at {_num(value)}, {_num(ratio)} x the plant's rated "
                 f"{_num(value_rated)} {unit}")
        if abs(math.log(ratio / slip[0])) < math.log(2.0):
            raise InputError(f"{start}: it looks like {slip[1]}; the column must be in {unit}")
        if name in ("speed_rpm", "head_m"):
            raise InputError(f"{start}: expected {low:g} to {high:g} x rated; is the column in {unit}, and is this "
                             "the plant the data come from?")
    speed = float(operating_point.speed_rpm)
    ratio = speed / tur.rated_speed_rpm
    if not SPEED_RANGE[0] <= ratio <= SPEED_RANGE[1]:
        raise InputError(f"{path}: column 'speed_rpm' starts at {_num(speed)} r/min, {_num(ratio)} x the plant's "
                         f"rated {_num(tur.rated_speed_rpm)} r/min; a unit under test runs at {SPEED_RANGE[0]:g} to "
                         f"{SPEED_RANGE[1]:g} x rated: is this the plant the data come from?")
    head = float(operating_point.head_m)
    static = plant.penstock.static_head_m
    if not HEAD_RANGE_OF_STATIC[0] <= head / static <= HEAD_RANGE_OF_STATIC[1]:
        raise InputError(f"{path}: column 'head_m' starts at {_num(head)} m, {_num(head / static)} x the plant's "
                         f"penstock.static_head_m = {_num(static)} m; a unit's net head lies at "
                         f"{HEAD_RANGE_OF_STATIC[0]:g} to {HEAD_RANGE_OF_STATIC[1]:g} x the static head: is this the "
                         "plant the data come from (or is the head gauge's datum or unit another)?")


def small_signal_warning(series, *, limit: float = 0.1) -> str | None:
    """A warning when a relative series (speed x, head h, opening y, torque m, flow q) moves by more than ``limit``
    of its operating point: the six coefficients and the ARX model are a linearization, valid for small
    deviations (the simulator's +1 % step already departs 1.4 % from the linear prediction)."""
    names = {"x": "speed", "h": "head", "y": "opening", "m": "torque", "q": "flow"}
    excursions = {k: float(np.max(np.abs(getattr(series, k)))) for k in names}
    over = {k: v for k, v in excursions.items() if v > limit}
    if not over:
        return None
    parts = ", ".join(f"{names[k]} by {100 * v:.0f} %" for k, v in sorted(over.items(), key=lambda kv: -kv[1]))
    return (f"the series leaves the small-signal range: {parts} of the operating point (the linear model holds for "
            f"a few %; limit {100 * limit:.0f} %); the identified coefficients describe no single operating point "
            "and the acceptance checks are not meaningful")
