"""The nets against an exact turbine: reading its truth table and the errors inside and outside the measured region."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hillchart.errors import InputError


# ----------------------------------------------------------------------------------------------------------------
# accuracy against an exact reference (the synthetic turbine's truth.csv)
# ----------------------------------------------------------------------------------------------------------------
def read_truth_csv(path) -> dict[str, np.ndarray]:
    """Read ``truth.csv`` (columns ``n11,opening,q11,m11,efficiency``; r/min, chart units, m^3/s, N*m, fraction).

    Raises
    ------
    InputError
        Missing column or non-finite value (naming the file and column).
    """
    path = Path(path)
    data = np.genfromtxt(path, delimiter=",", names=True, dtype=float)
    names = data.dtype.names or ()
    out = {}
    for column in ("n11", "opening", "q11", "m11"):
        if column not in names:
            raise InputError(f"{path}: column {column!r} is missing (have {', '.join(names)})")
        values = np.atleast_1d(np.asarray(data[column], dtype=float))
        if not np.all(np.isfinite(values)):
            raise InputError(f"{path}: column {column!r} has non-numeric or non-finite values")
        out[column] = values
    return out


def truth_errors(characteristics, truth: dict, inside: np.ndarray) -> dict:
    """Errors of ``characteristics`` against exact values, inside and outside the measured region.

    Parameters
    ----------
    characteristics : object with ``q11(n11, a)`` and ``m11(n11, a)``
    truth : dict of ndarray
        ``n11``, ``opening``, ``q11``, ``m11`` (see :func:`read_truth_csv`).
    inside : ndarray of bool
        Measured-region mask of the truth points (see :func:`hillchart.io.samples.measured_region_mask`).

    Returns
    -------
    dict
        For ``q11`` and ``m11``: ``range_measured`` (truth max - min inside, the scale of the issue's
        percentages), ``rms_measured``, ``max_measured``, ``rms_extended``, ``max_extended`` (physical units) and
        the same as percentages of ``range_measured`` (``*_pct``).
    """
    out = {}
    for name in ("q11", "m11"):
        pred = getattr(characteristics, name)(truth["n11"], truth["opening"])
        err = np.asarray(pred, dtype=float) - truth[name]
        scale = float(np.ptp(truth[name][inside]))
        rec = {"range_measured": scale,
               "rms_measured": float(np.sqrt(np.mean(err[inside] ** 2))),
               "max_measured": float(np.max(np.abs(err[inside]))),
               "rms_extended": float(np.sqrt(np.mean(err[~inside] ** 2))),
               "max_extended": float(np.max(np.abs(err[~inside])))}
        for key in ("rms_measured", "max_measured", "rms_extended", "max_extended"):
            rec[key + "_pct"] = 100.0 * rec[key] / scale
        out[name] = rec
    return out
