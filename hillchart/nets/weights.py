"""One net of the unit characteristics as stored in nets.json: its weights (:class:`NetWeights`), their validation, and
the compiled evaluation with gradients (eqs. (10)-(11) of Li et al. 2017) that the simulator calls."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np

from hillchart.errors import InputError
from hillchart.validation import check_finite, check_vector

FORMAT = "hillsim.nets"
VERSION = 1
#: Units fixed by the format (the opening unit is the chart's).
FIXED_UNITS = {"n11": "r/min", "q11": "m^3/s", "m11": "N*m"}
#: Origin families of the extended samples (see :mod:`hillchart.extension.extend`).
ORIGINS = ("measured", "runaway", "zero-opening", "zero-speed", "silent-region")


# ----------------------------------------------------------------------------------------------------------------
# evaluation: the single implementation of eq. (11) and its gradient
# ----------------------------------------------------------------------------------------------------------------
# Packed layout of one net (float64 vector):
#   [H, n11_min, a_min, n11_max, a_max, y_min, y_max, b2, W1 (H x 2 row-major), b1 (H), W2 (H)]
_HEADER = 8


@numba.njit(cache=True)
def _net_value_grad(p, n11, opening):
    """Value y and (dy/dN11, dy/da) of one packed net at a scalar point (physical units)."""
    hidden = int(p[0])
    n11_min, a_min, n11_max, a_max = p[1], p[2], p[3], p[4]
    y_min, y_max, b2 = p[5], p[6], p[7]
    s_n = 2.0 / (n11_max - n11_min)  # d xn / d x of mapminmax
    s_a = 2.0 / (a_max - a_min)
    xn_n = s_n * (n11 - n11_min) - 1.0
    xn_a = s_a * (opening - a_min) - 1.0
    yn = b2
    g_n = 0.0
    g_a = 0.0
    for i in range(hidden):
        w_n = p[_HEADER + 2 * i]
        w_a = p[_HEADER + 2 * i + 1]
        b1 = p[_HEADER + 2 * hidden + i]
        w2 = p[_HEADER + 3 * hidden + i]
        z = w_n * xn_n + w_a * xn_a + b1
        # eq. (10), paper 004: logsig, evaluated without overflow for either sign of z
        if z >= 0.0:
            f = 1.0 / (1.0 + math.exp(-z))
        else:
            ez = math.exp(z)
            f = ez / (1.0 + ez)
        yn += w2 * f  # eq. (11), paper 004
        d = w2 * f * (1.0 - f)
        g_n += d * w_n
        g_a += d * w_a
    half_range = 0.5 * (y_max - y_min)
    y = (yn + 1.0) * half_range + y_min  # reverse mapminmax
    return y, half_range * g_n * s_n, half_range * g_a * s_a


@numba.njit(cache=True)
def _net_eval_many(p, n11, opening, y, dy_dn11, dy_da):
    for k in range(n11.shape[0]):
        y[k], dy_dn11[k], dy_da[k] = _net_value_grad(p, n11[k], opening[k])


@numba.njit(cache=True)
def _nets_kernel(params, n11, opening):
    """Simulator kernel: ``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` at a scalar point."""
    q, dq_dn, dq_da = _net_value_grad(params[0], n11, opening)
    m, dm_dn, dm_da = _net_value_grad(params[1], n11, opening)
    return q, dq_dn, dq_da, m, dm_dn, dm_da


@numba.njit(cache=True)
def _nets_flow(params, n11, opening):
    """Q11 of :func:`_nets_kernel` (value only: the pressure loop's iterations)."""
    return _net_value_grad(params[0], n11, opening)[0]


@numba.njit(cache=True)
def _nets_torque(params, n11, opening):
    """M11 of :func:`_nets_kernel` (value only: the torque at the converged head)."""
    return _net_value_grad(params[1], n11, opening)[0]


#: Up to this many points ``evaluate`` runs the kernel's Python source (``py_func``): a process evaluating a few
#: points (``hillsim linearize``) need not load the compiled kernel from numba's cache, about half a second of
#: start-up (numba's first cache load initialises its compiler), against about 10 us a point in Python.
_PYTHON_POINTS = 64


def _evaluate(packed: np.ndarray, n11, opening):
    n11 = np.asarray(n11, dtype=float)
    opening = np.asarray(opening, dtype=float)
    n11_b, opening_b = np.broadcast_arrays(n11, opening)
    shape = n11_b.shape
    flat_n = np.ascontiguousarray(n11_b, dtype=float).ravel()
    flat_a = np.ascontiguousarray(opening_b, dtype=float).ravel()
    y, d_n, d_a = np.empty_like(flat_n), np.empty_like(flat_n), np.empty_like(flat_n)
    if flat_n.size <= _PYTHON_POINTS:  # the same kernel's Python source: loading the compiled one costs more
        point = _net_value_grad.py_func
        for k in range(flat_n.size):
            y[k], d_n[k], d_a[k] = point(packed, float(flat_n[k]), float(flat_a[k]))
    else:
        _net_eval_many(packed, flat_n, flat_a, y, d_n, d_a)
    return y.reshape(shape), d_n.reshape(shape), d_a.reshape(shape)


def ensemble_blocks(doc: dict, *, prefix: str = "", silent_hint: str = "") -> list[dict]:
    """The members of ``doc["ensemble"]`` of a nets.json (none when absent): each an object with the keys flow and
    torque and, optionally, silent_model; anything else is an :class:`InputError` naming the member (``prefix``
    begins the message, ``silent_hint`` follows "silent_model" in it)."""
    members = doc.get("ensemble", [])
    if not isinstance(members, list):
        raise InputError(f"{prefix}ensemble must be a list of {{\"flow\": NET, \"torque\": NET}}, got "
                         f"{type(members).__name__}")
    for i, member in enumerate(members):
        if not isinstance(member, dict) or set(member) - {"silent_model"} != {"flow", "torque"}:
            raise InputError(f"{prefix}ensemble[{i}] must be an object with the keys flow and torque (and "
                             f"silent_model{silent_hint}), got "
                             f"{member if not isinstance(member, dict) else sorted(member)!r}")
    return members


# ----------------------------------------------------------------------------------------------------------------
# weights of one net
# ----------------------------------------------------------------------------------------------------------------
#: Largest magnitude accepted for any number of a NET block: trained nets stay orders of magnitude below it, and
#: beyond it the evaluation overflows (e.g. y_max - y_min of 2e300 times a weight gives inf, then NaN).
MAX_ABS_NET_VALUE = 1e9


@dataclass(frozen=True, eq=False)
class NetWeights:
    """Weights of one 2-H-1 logsig/purelin net and its input/output scaling (one ``NET`` block of ``nets.json``).

    Parameters
    ----------
    x_min, x_max : array_like (2,)
        mapminmax ranges of the inputs (N11 in r/min, opening in chart units); ``x_max > x_min``.
    y_min, y_max : float
        mapminmax range of the output (Q11 in m^3/s or M11 in N*m); ``y_max > y_min``.
    W1 : array_like (H, 2)
        Hidden weights, columns (N11, opening), on normalized inputs.
    b1, W2 : array_like (H,)
        Hidden biases and output weights.
    b2 : float
        Output bias.

    Raises
    ------
    InputError
        Wrong shapes, NaN/inf or empty ranges; the message names the field.

    Examples
    --------
    >>> w = NetWeights(x_min=[0.0, 0.0], x_max=[100.0, 30.0], y_min=0.0, y_max=1.0,
    ...                W1=[[1.0, 0.0]], b1=[0.0], W2=[2.0], b2=-1.0)
    >>> float(w.evaluate(50.0, 10.0)[0])  # xn_n11 = 0 -> f = 0.5 -> yn = 0 -> y = 0.5
    0.5
    """

    x_min: np.ndarray
    x_max: np.ndarray
    y_min: float
    y_max: float
    W1: np.ndarray
    b1: np.ndarray
    W2: np.ndarray
    b2: float
    _packed: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self._set_validated(key="")

    def _set_validated(self, key: str):
        put = object.__setattr__
        x_min = check_vector(f"{key}x_min", self.x_min, 2, max_abs=MAX_ABS_NET_VALUE)
        x_max = check_vector(f"{key}x_max", self.x_max, 2, max_abs=MAX_ABS_NET_VALUE)
        for j, name in enumerate(("n11", "opening")):
            if not x_max[j] > x_min[j]:
                raise InputError(f"{key}x_max[{j}] ({name}) must be > {key}x_min[{j}] = {x_min[j]!r}, "
                                 f"got {x_max[j]!r}")
        y_min = check_finite(f"{key}y_min", self.y_min, max_abs=MAX_ABS_NET_VALUE)
        y_max = check_finite(f"{key}y_max", self.y_max, max_abs=MAX_ABS_NET_VALUE)
        if not y_max > y_min:
            raise InputError(f"{key}y_max must be > {key}y_min = {y_min!r}, got {y_max!r}")
        w1_raw = self.W1.tolist() if isinstance(self.W1, np.ndarray) else self.W1
        if not isinstance(w1_raw, (list, tuple)) or len(w1_raw) == 0:
            raise InputError(f"{key}W1 must be a non-empty list of H rows [w_n11, w_opening], got {w1_raw!r}")
        w1 = np.array([check_vector(f"{key}W1[{i}]", row, 2, max_abs=MAX_ABS_NET_VALUE)
                       for i, row in enumerate(w1_raw)])
        hidden = w1.shape[0]
        b1 = check_vector(f"{key}b1", self.b1, hidden, max_abs=MAX_ABS_NET_VALUE)
        w2 = check_vector(f"{key}W2", self.W2, hidden, max_abs=MAX_ABS_NET_VALUE)
        b2 = check_finite(f"{key}b2", self.b2, max_abs=MAX_ABS_NET_VALUE)
        for name, value in (("x_min", x_min), ("x_max", x_max), ("W1", w1), ("b1", b1), ("W2", w2)):
            value.setflags(write=False)
            put(self, name, value)
        put(self, "y_min", y_min)
        put(self, "y_max", y_max)
        put(self, "b2", b2)
        packed = np.concatenate([[hidden], x_min, x_max, [y_min, y_max, b2], w1.ravel(), b1, w2]).astype(float)
        packed.setflags(write=False)
        put(self, "_packed", packed)

    @property
    def hidden(self) -> int:
        """Number of hidden neurons H."""
        return int(self.W1.shape[0])

    @classmethod
    def from_dict(cls, block, *, key: str, output: str) -> "NetWeights":
        """Validate a ``NET`` block of ``nets.json`` (``key`` names it in messages, ``output`` is expected)."""
        if not isinstance(block, dict):
            raise InputError(f"{key} must be an object, got {type(block).__name__}")
        required = ("inputs", "output", "x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2", "b2")
        for name in required:
            if name not in block:
                raise InputError(f"{key}.{name} is missing (a NET needs keys {', '.join(required)})")
        if block["inputs"] != ["n11", "opening"]:
            three = block["inputs"] == ["n11", "opening", "blade_angle"]
            raise InputError(f'{key}.inputs must be ["n11", "opening"], got {block["inputs"]!r}' + (
                ": these are a double-regulated unit's three-input nets; a plant file reads them (with [combinator] "
                "and [blade_servo]), hillsim report draws the unit's chart on its cam and hillsim linearize gives "
                "their eight coefficients" if three else ""))
        if block["output"] != output:
            raise InputError(f"{key}.output must be {output!r}, got {block['output']!r}")
        obj = cls.__new__(cls)
        for name in ("x_min", "x_max", "y_min", "y_max", "W1", "b1", "W2", "b2"):
            object.__setattr__(obj, name, block[name])
        obj._set_validated(key=f"{key}.")
        return obj

    def to_dict(self, output: str) -> dict:
        """The ``NET`` block (plain Python floats, so ``json`` writes them exactly)."""
        return {"inputs": ["n11", "opening"], "output": output,
                "x_min": [float(v) for v in self.x_min], "x_max": [float(v) for v in self.x_max],
                "y_min": float(self.y_min), "y_max": float(self.y_max),
                "W1": [[float(v) for v in row] for row in self.W1],
                "b1": [float(v) for v in self.b1], "W2": [float(v) for v in self.W2], "b2": float(self.b2)}

    def packed(self) -> np.ndarray:
        """Read-only float64 vector consumed by the numba kernels (layout in the module source)."""
        return self._packed

    def evaluate(self, n11, opening):
        """Output and analytic gradient, vectorized.

        Parameters
        ----------
        n11 : array_like, r/min
        opening : array_like, chart units (broadcast with ``n11``)

        Returns
        -------
        y, dy_dn11, dy_da : ndarray, broadcast shape
        """
        return _evaluate(self._packed, n11, opening)

    def __eq__(self, other):
        if not isinstance(other, NetWeights):
            return NotImplemented
        return bool(np.array_equal(self._packed, other._packed))

    __hash__ = None
