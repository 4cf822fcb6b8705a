"""The seam between the hill chart and the simulator.

The simulator needs from a turbine only four vectorized methods, all taking unit speed ``n11`` (r/min) and
guide-vane opening ``opening`` (in the chart's opening unit) as broadcastable arrays:

``q11(n11, opening)``       unit flow Q11, m^3/s
``m11(n11, opening)``       unit torque M11, N*m
``q11_grad(n11, opening)``  (dQ11/dN11, dQ11/da)
``m11_grad(n11, opening)``  (dM11/dN11, dM11/da)

Unit quantities follow the usual model-law definitions (D1 runner diameter in m, H head in m, n speed in r/min)::

    N11 = n D1 / sqrt(H),   Q11 = Q / (D1^2 sqrt(H)),   M11 = M / (D1^3 H)

Anything with those four methods (the trained nets, :class:`IdealTurbine`, the synthetic turbine, a user's own
model) can drive the simulator.

Fast path. An object may also offer ``numba_kernel() -> (kernel, params)``: ``kernel`` is a numba-jitted function
``kernel(params, n11, a) -> (q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` on scalars, ``params`` a tuple of
floats/arrays. The simulator's time loop is one numba function that takes ``(kernel, params)``; for an object without
a kernel, :func:`scalar_kernel` wraps the four methods and the same loop runs as plain Python (``loop.py_func``), so
there is never a second implementation of the physics.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numba
import numpy as np

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3, RPM_TO_RAD_S


@runtime_checkable
class Characteristics(Protocol):
    """Turbine characteristics Q11(N11, a), M11(N11, a) with their partial derivatives."""

    def q11(self, n11, opening) -> np.ndarray: ...

    def m11(self, n11, opening) -> np.ndarray: ...

    def q11_grad(self, n11, opening) -> tuple[np.ndarray, np.ndarray]: ...

    def m11_grad(self, n11, opening) -> tuple[np.ndarray, np.ndarray]: ...


class KernelCharacteristics:
    """The four methods of :class:`Characteristics` from the six-value scalar kernel of ``numba_kernel()`` (module
    docstring), evaluated point by point over broadcast arrays: characteristics that have their compiled kernel only
    (a four-quadrant table, a user's own kind) get the Python methods the steady state and the checks read without
    writing them. A subclass defines ``numba_kernel()``."""

    def numba_kernel(self):
        raise NotImplementedError(f"{type(self).__name__} must define numba_kernel() -> (kernel, params)")

    def _values(self, n11, opening) -> list[np.ndarray]:
        kernel, params = self.numba_kernel()
        n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
        out = np.array([kernel(params, a, b) for a, b in zip(n11.ravel(), opening.ravel())], dtype=float)
        return [out[:, i].reshape(n11.shape) for i in range(6)]

    def q11(self, n11, opening):
        return self._values(n11, opening)[0]

    def m11(self, n11, opening):
        return self._values(n11, opening)[3]

    def q11_grad(self, n11, opening):
        return tuple(self._values(n11, opening)[1:3])

    def m11_grad(self, n11, opening):
        return tuple(self._values(n11, opening)[4:6])


def unit_torque_from_efficiency(q11, n11, efficiency):
    """Unit torque M11 (N*m) from unit flow, unit speed and hydraulic efficiency.

    Power balance on the unit turbine (D1 = 1 m, H = 1 m): ``M11 * omega11 = rho g Q11 eta`` with
    ``omega11 = 2 pi N11 / 60``, hence ``M11 = rho g Q11 eta 60 / (2 pi N11)`` = 93 679 Q11 eta / N11 N*m.

    The BP hill-chart paper writes this as eq. (5), ``M11 = 0.93706 Q11 eta / N11`` "in kN*m": its constant is
    rho g 60 / (2 pi) = 93.68 kN*m scaled by 1/100 (and a slightly different g or rho), i.e. the paper's M11 is in
    units of 100 kN*m. hillsim keeps SI: M11 in N*m, Q11 in m^3/s, N11 in r/min.

    Parameters
    ----------
    q11 : array_like, m^3/s
    n11 : array_like, r/min, > 0
    efficiency : array_like, fraction

    Returns
    -------
    ndarray, N*m

    Examples
    --------
    >>> round(float(unit_torque_from_efficiency(0.5, 70.0, 0.9)), 2)
    602.22
    """
    q11 = np.asarray(q11, dtype=float)
    n11 = np.asarray(n11, dtype=float)
    return RHO_WATER_KG_M3 * G_M_S2 * q11 * np.asarray(efficiency, dtype=float) / (n11 * RPM_TO_RAD_S)


def unit_speed(speed_rpm, head_m, runner_diameter_m):
    """``N11 = n D1 / sqrt(H)`` (r/min) of a speed (r/min) at a net head (m, > 0) for runner diameter D1 (m): the
    model law of every paper (eq. (23) of paper 004, eq. (2) of paper 003); arrays broadcast.

    Examples
    --------
    >>> round(float(unit_speed(200.0, 176.0, 4.5)), 6)
    67.840053
    """
    return np.asarray(speed_rpm, dtype=float) * float(runner_diameter_m) / np.sqrt(np.asarray(head_m, dtype=float))


def unit_quantities(speed_rpm, flow_m3_s, head_m, runner_diameter_m):
    """``(N11, Q11)`` of a plant operating point by the model law: ``N11 = n D1 / sqrt(H)`` (r/min),
    ``Q11 = Q / (D1^2 sqrt(H))`` (m^3/s); arrays broadcast.

    Parameters
    ----------
    speed_rpm : array_like, r/min
    flow_m3_s : array_like, m^3/s
    head_m : array_like, m, > 0 (the net head at the turbine)
    runner_diameter_m : float, m

    Examples
    --------
    >>> [round(float(v), 6) for v in unit_quantities(200.0, 142.5, 176.0, 4.5)]
    [67.840053, 0.530437]
    """
    sqrt_h = np.sqrt(np.asarray(head_m, dtype=float))
    d1 = float(runner_diameter_m)
    return unit_speed(speed_rpm, head_m, d1), np.asarray(flow_m3_s, dtype=float) / (d1 * d1 * sqrt_h)


def efficiency_from_unit_torque(q11, n11, m11):
    """Hydraulic efficiency (fraction) ``eta = M11 (2 pi N11 / 60) / (rho g Q11)``: eq. (5) of the BP hill-chart
    paper solved for eta, the inverse of :func:`unit_torque_from_efficiency`. NaN where Q11 <= 0 or N11 <= 0.

    Examples
    --------
    >>> round(float(efficiency_from_unit_torque(0.5, 70.0, unit_torque_from_efficiency(0.5, 70.0, 0.9))), 12)
    0.9
    >>> float(efficiency_from_unit_torque(0.0, 70.0, -5.0))
    nan
    """
    q11, n11, m11 = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (q11, n11, m11)))
    ok = (q11 > 0) & (n11 > 0)
    eta = np.full(q11.shape, np.nan)
    eta[ok] = m11[ok] * n11[ok] * RPM_TO_RAD_S / (RHO_WATER_KG_M3 * G_M_S2 * q11[ok])
    return eta


@numba.njit(cache=True)
def _ideal_kernel(params, n11, opening):
    q11_max, opening_max, torque_const = params  # torque_const = rho g eta 60 / (2 pi), N*m*min/m^3
    dq_da = q11_max / opening_max
    q = dq_da * opening
    m = torque_const * q / n11
    return q, 0.0, dq_da, m, -m / n11, torque_const * dq_da / n11


@dataclass(frozen=True)
class IdealTurbine:
    """The classical ideal turbine (IEEE working group 1992) written as unit characteristics.

    ``Q11 = q11_max_m3_s * a / opening_max`` (independent of N11) and constant efficiency, so
    ``M11 = rho g Q11 eta 60 / (2 pi N11)``: in plant terms ``Q = Q_r y sqrt(H/H_r)`` and
    ``P = P_r y (H/H_r)^1.5``. Its six coefficients are exactly
    ``(ex, ey, eh, eqx, eqy, eqh) = (-1, 1, 1.5, 0, 1, 0.5)``. M11 is singular at N11 = 0; use it away from standstill.

    Parameters
    ----------
    q11_max_m3_s : float
        Unit flow at full opening, m^3/s.
    opening_max : float
        Opening at full stroke, chart units.
    efficiency : float
        Constant hydraulic efficiency, fraction in (0, 1].

    Examples
    --------
    >>> t = IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.9)
    >>> float(t.q11(70.0, 15.0))
    0.3
    >>> [float(g) for g in t.q11_grad(70.0, 15.0)]
    [0.0, 0.02]
    """

    q11_max_m3_s: float
    opening_max: float
    efficiency: float = 1.0

    def __post_init__(self):
        for name in ("q11_max_m3_s", "opening_max"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"IdealTurbine.{name} must be finite and > 0, got {value!r}")
        if not (0 < self.efficiency <= 1):
            raise ValueError(f"IdealTurbine.efficiency must be in (0, 1], got {self.efficiency!r}")

    def q11(self, n11, opening):
        n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
        return self.q11_max_m3_s * opening / self.opening_max

    def m11(self, n11, opening):
        return unit_torque_from_efficiency(self.q11(n11, opening), n11, self.efficiency)

    def q11_grad(self, n11, opening):
        n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
        return np.zeros_like(n11), np.full_like(n11, self.q11_max_m3_s / self.opening_max)

    def m11_grad(self, n11, opening):
        n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
        m = self.m11(n11, opening)
        return -m / n11, unit_torque_from_efficiency(self.q11_max_m3_s / self.opening_max, n11, self.efficiency)

    def numba_kernel(self):
        """``(kernel, params)`` for the simulator's compiled time loop (see module docstring)."""
        torque_const = float(unit_torque_from_efficiency(1.0, 1.0, self.efficiency))
        return _ideal_kernel, (float(self.q11_max_m3_s), float(self.opening_max), torque_const)


def scalar_kernel(characteristics):
    """``(kernel, params)`` for any :class:`Characteristics`: its own numba kernel if it has one, else a plain
    Python function with the same signature built from the four methods (for ``loop.py_func``).

    Returns
    -------
    kernel : callable ``(params, n11, a) -> (q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)``
    params : tuple
    jitted : bool
        True when ``kernel`` is numba-compiled (the loop can be jitted too).

    Examples
    --------
    >>> kernel, params, jitted = scalar_kernel(IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.9))
    >>> jitted, [round(float(v), 4) for v in kernel(params, 70.0, 15.0)][:3]
    (True, [0.3, 0.0, 0.02])
    """
    if hasattr(characteristics, "numba_kernel"):
        kernel, params = characteristics.numba_kernel()
        return kernel, params, True

    def kernel(params, n11, opening):
        q = float(characteristics.q11(n11, opening))
        dq_dn, dq_da = characteristics.q11_grad(n11, opening)
        m = float(characteristics.m11(n11, opening))
        dm_dn, dm_da = characteristics.m11_grad(n11, opening)
        return q, float(dq_dn), float(dq_da), m, float(dm_dn), float(dm_da)

    return kernel, (), False


def efficiency_from_characteristics(characteristics, n11, opening) -> np.ndarray:
    """Hydraulic efficiency (fraction) ``eta = M11 (2 pi N11 / 60) / (rho g Q11)``: eq. (5) of paper 004 solved
    for eta. NaN where Q11 <= 0 or N11 <= 0.

    Examples
    --------
    >>> from hillchart.characteristics import IdealTurbine
    >>> t = IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.9)
    >>> round(float(efficiency_from_characteristics(t, 70.0, 15.0)), 12)
    0.9
    """
    n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
    return efficiency_from_unit_torque(characteristics.q11(n11, opening), n11, characteristics.m11(n11, opening))
