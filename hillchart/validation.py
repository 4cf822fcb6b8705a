"""Checks of user-given values, one message format for every package: ``NAME must be ..., got VALUE``.

``NAME`` is what the user wrote (``governor.kp``, ``chart.toml: runner_diameter_m``, ``flow.w1[3]``); the message
says the allowed range in interval notation and repeats the bad value. Booleans are never numbers here (TOML and JSON
``true`` is not ``1``), and neither are strings such as ``"3"``.

Examples
--------
>>> check_number("governor.kp", 2.5, low=0.0, high=1000.0)
2.5
>>> check_number("grid.x_line_pu", -1, low=0.0, high=5.0, low_open=True)
Traceback (most recent call last):
...
hillchart.errors.InputError: grid.x_line_pu must be in (0.0, 5.0], got -1.0
>>> check_number("penstock.reaches", True, low=1)
Traceback (most recent call last):
...
hillchart.errors.InputError: penstock.reaches must be a number in [1.0, inf), got True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from hillchart.errors import InputError

_REAL = (int, float, np.integer, np.floating)


def interval(low: float | None = None, high: float | None = None, *, low_open: bool = False,
             high_open: bool = False) -> str:
    """The allowed range in interval notation: ``[0.0, 1.0)``, ``(0.0, inf)``."""
    low_txt = "-inf" if low is None else repr(float(low))
    high_txt = "inf" if high is None else repr(float(high))
    return (f"{'(' if low_open or low is None else '['}{low_txt}, {high_txt}"
            f"{')' if high_open or high is None else ']'}")


def check_number(name: str, value: Any, *, low: float | None = None, high: float | None = None,
                 low_open: bool = False, high_open: bool = False) -> float:
    """``value`` as a finite float inside the range, or :class:`InputError` naming ``name``, the value and the range."""
    allowed = interval(low, high, low_open=low_open, high_open=high_open)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, _REAL):
        raise InputError(f"{name} must be a number in {allowed}, got {value!r}")
    try:
        number = float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise InputError(f"{name} must be a number in {allowed}, got an integer of {len(str(abs(value)))} "
                         f"digits") from None
    bad = not math.isfinite(number)
    if low is not None:
        bad |= number <= low if low_open else number < low
    if high is not None:
        bad |= number >= high if high_open else number > high
    if bad:
        raise InputError(f"{name} must be in {allowed}, got {number!r}")
    return number


def check_int(name: str, value: Any, low: int, high: int) -> int:
    """An integer (not a bool, not a float) in ``[low, high]``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise InputError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


def check_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    """One of ``choices``."""
    if not isinstance(value, str) or value not in choices:
        raise InputError(f"{name} must be one of {', '.join(choices)}; got {value!r}")
    return value


def check_float_list(name: str, value: Any, *, low: float, high: float) -> tuple[float, ...]:
    """A non-empty list of numbers, each in ``[low, high]`` (an element is named ``name[i]``)."""
    if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__iter__"):
        raise InputError(f"{name} must be a list of numbers in [{low}, {high}], got {value!r}")
    out = tuple(check_number(f"{name}[{i}]", v, low=low, high=high) for i, v in enumerate(value))
    if not out:
        raise InputError(f"{name} must be a non-empty list of numbers, got {value!r}")
    return out


def check_finite(name: str, value: Any, *, max_abs: float | None = None) -> float:
    """A finite number, of magnitude at most ``max_abs`` when given (stored weights, file values).

    >>> check_finite("flow.b2", float("nan"))
    Traceback (most recent call last):
    ...
    hillchart.errors.InputError: flow.b2 must be finite, got nan
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, _REAL):
        raise InputError(f"{name} must be a number, got {value!r}")
    try:
        number = float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise InputError(f"{name} must be a number of magnitude <= {max_abs or 1.8e308:g}, got an integer of "
                         f"{len(str(abs(value)))} digits") from None
    if not math.isfinite(number):
        raise InputError(f"{name} must be finite, got {value!r}")
    if max_abs is not None and abs(number) > max_abs:
        raise InputError(f"{name} must have magnitude <= {max_abs:g}, got {value!r}")
    return number


def check_vector(name: str, value: Any, length: int | None = None, *, max_abs: float | None = None) -> np.ndarray:
    """A list (or 1-D array) of finite numbers, of ``length`` entries when given."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise InputError(f"{name} must be a list of numbers, got {value!r}")
    if length is not None and len(value) != length:
        raise InputError(f"{name} must have {length} entries, got {len(value)}")
    return np.array([check_finite(f"{name}[{i}]", v, max_abs=max_abs) for i, v in enumerate(value)], dtype=float)
