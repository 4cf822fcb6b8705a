"""Floats for result files: derived figures rounded to what they mean, numerical dust set to zero.

A simulation or a fit returns ``8.999999999999988`` for an inertia of 9 s recomputed from J, ``225.00000000000028``
MW for a steady state found by Brent's method, ``3.7e-111`` for a servo that has closed. :func:`tidy_floats` writes
them as ``9.0``, ``225.0`` and ``0.0``: every float is rounded to :data:`SIGNIFICANT` significant digits (far below
any tolerance the results are computed to: the steady state to 1e-9, the pressure loop to 1e-10) and magnitudes
below :data:`TINY` (no physical or per-unit quantity in hillsim's outputs is that small; subnormals included) become
0. Integers, strings, booleans and None pass unchanged. Files that must round-trip bit-exactly (``nets.json``) are
not tidied.
"""

from __future__ import annotations

import math

#: Significant digits kept.
SIGNIFICANT = 12
#: Magnitudes below this are numerical dust.
TINY = 1e-30


def tidy_float(value: float, significant: int = SIGNIFICANT, tiny: float = TINY) -> float:
    """One float rounded to ``significant`` digits, 0.0 below ``tiny``; NaN and inf unchanged.

    >>> tidy_float(8.999999999999988), tidy_float(225.00000000000028), tidy_float(3.719570726996532e-111)
    (9.0, 225.0, 0.0)
    >>> tidy_float(-0.026190859337745735), tidy_float(4.2e-16)
    (-0.0261908593377, 4.2e-16)
    """
    if not math.isfinite(value):
        return value
    if abs(value) < tiny:
        return 0.0
    return float(f"{value:.{significant}g}")


def tidy_floats(obj, significant: int = SIGNIFICANT, tiny: float = TINY):
    """A copy of a JSON-like structure (dicts, lists, tuples, scalars) with every float tidied (:func:`tidy_float`).

    >>> tidy_floats({"a": [1.0000000000000002, 2], "b": {"c": 1e-200, "d": "x", "e": True}})
    {'a': [1.0, 2], 'b': {'c': 0.0, 'd': 'x', 'e': True}}
    """
    if isinstance(obj, bool) or obj is None or isinstance(obj, (int, str)):
        return obj
    if isinstance(obj, float):
        return tidy_float(obj, significant, tiny)
    if isinstance(obj, dict):
        return {k: tidy_floats(v, significant, tiny) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [tidy_floats(v, significant, tiny) for v in obj]
    if hasattr(obj, "item") and callable(obj.item) and getattr(obj, "ndim", None) == 0:  # numpy scalar
        return tidy_floats(obj.item(), significant, tiny)
    if hasattr(obj, "tolist"):  # numpy array
        return tidy_floats(obj.tolist(), significant, tiny)
    return obj
