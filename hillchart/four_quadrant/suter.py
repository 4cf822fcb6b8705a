"""The Suter transform of four-quadrant characteristics and its inverse, plain and improved, in two sign conventions.

Relative quantities: speed v = n/n_r, flow q = Q/Q_r, head h = H/H_r, torque m = M/M_r (rated values of one point),
guide-vane opening y (relative, 0..1). The plain transform (Marchal, Flesch and Suter 1965; Wylie, Streeter and Suo
1993, ch. 7)::

    x = pi + atan2(q, v)  in [0, 2 pi)         WH = h / (q^2 + v^2)         WM = m / (q^2 + v^2)

maps every operating point except standstill (v = q = 0) to one x per (direction of (v, q), opening), where the
affinity laws make WH and WM single-valued: the multi-valued S-shaped zone of Q11(N11) and the undefined points of
unit quantities at zero head become curves of x. Near a closed guide vane the plain curves are ill-conditioned: the
flow tends to zero on every opening line, WH ~ 1/y^2 grows without bound and a digitized line at small opening
crowds into a narrow range of x near zero flow. The improved transform of the pumped-storage literature moves the
points off the zero-flow axis and bounds the curves with four constants::

    x  = pi + atan2(q + k2 sqrt(h), v)
    WH = (y + C_y)^2 h / (q^2 + v^2 + C_h h)
    WM = (y + C_y)^2 (m + k1 h) / (q^2 + v^2 + C_h h)

(published with ``x = arctan((q + k2 sqrt(h)) / v)`` for v > 0 and ``pi + arctan(...)`` for v < 0, which is the
same angle less pi: here x keeps the plain transform's origin so that zero constants give the plain transform
exactly). k2 > 0 spreads the points of one opening line at unit head over x even where q ~ 0; C_h > 0 bounds WH by
(y + C_y)^2 / C_h; (y + C_y)^2 with C_y > 0 lifts the curves of small openings to the size of the others; k1 >
max(-m/h) keeps m + k1 h > 0. The improved transform needs h >= 0, which holds on a pump-turbine's complete
characteristics (they are measured at positive head).

Conventions
-----------
``"turbine"`` (hillsim's): v > 0 in turbine rotation, q > 0 in turbine flow, h the head across the machine from the
high- to the low-pressure side, m > 0 when the water drives the runner in turbine rotation. ``"wylie-streeter"``
(pump-positive, as Wylie, Streeter and Suo write alpha, v, h, beta for a pump): speed alpha and flow v positive in
pump rotation and pump flow, h the head rise, beta the torque the motor delivers in pump rotation. The two describe
one machine with alpha = -v_turbine, v = -q_turbine, h = h, beta = m (in steady running the motor's torque balances
the water's), so WH and WM are the same and x moves by pi: ``x_wylie_streeter = (x_turbine - pi) mod 2 pi``. The
transform below is defined on turbine-positive quantities; the ``"wylie-streeter"`` convention converts its inputs
and reports x on its own axis, so with zero constants it is exactly Wylie and Streeter's ``x = pi + atan(v/alpha)``.

Zones, in the turbine convention (:data:`ZONES`, :func:`zone`)::

    turbine        v > 0, q > 0    x in (pi, 3 pi/2)     (turbine brake where m < 0: past runaway)
    reverse pump   v > 0, q < 0    x in (pi/2, pi)
    pump           v < 0, q < 0    x in (0, pi/2)        (energy dissipation where h < 0)
    pump brake     v < 0, q > 0    x in (3 pi/2, 2 pi)

Wylie and Streeter name the same zones for a pump "normal turbine", "reverse-speed pumping", "normal pump" and
"energy dissipation" (at x in (0, pi/2), (3 pi/2, 2 pi), (pi, 3 pi/2) and (pi/2, pi) on their axis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from hillchart.errors import InputError

CONVENTIONS = ("turbine", "wylie-streeter")
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class Zone:
    """One quadrant of the (v, q) plane: its name in the turbine convention, the signs of speed and flow there
    (turbine convention), its x-range on each convention's axis (radians) and the Wylie-Streeter name."""

    name: str
    speed_sign: int
    flow_sign: int
    x_turbine: tuple[float, float]
    x_wylie_streeter: tuple[float, float]
    wylie_streeter_name: str


#: The four zones (module docstring); "turbine brake" is the part of "turbine" with m < 0 (:func:`zone`).
ZONES = (
    Zone("turbine", 1, 1, (math.pi, 1.5 * math.pi), (0.0, 0.5 * math.pi), "normal turbine"),
    Zone("reverse pump", 1, -1, (0.5 * math.pi, math.pi), (1.5 * math.pi, TWO_PI), "reverse-speed pumping"),
    Zone("pump", -1, -1, (0.0, 0.5 * math.pi), (math.pi, 1.5 * math.pi), "normal pump"),
    Zone("pump brake", -1, 1, (1.5 * math.pi, TWO_PI), (0.5 * math.pi, math.pi), "energy dissipation"),
)


@dataclass(frozen=True)
class SuterConstants:
    """The constants of the improved Suter transform (module docstring); all zero: the plain transform.

    Attributes
    ----------
    k1 : float >= 0
        Torque shift: WM holds m + k1 h.
    k2 : float >= 0
        Flow shift of the angle: x = pi + atan2(q + k2 sqrt(h), v).
    c_h : float >= 0
        Head term of the denominator q^2 + v^2 + C_h h.
    c_y : float >= 0
        Opening shift of the factor (y + C_y)^2; with C_y = 0 and the plain transform the factor is 1.

    Examples
    --------
    >>> SuterConstants().plain, SuterConstants(k1=1.5, k2=0.8, c_h=0.5, c_y=0.2).plain
    (True, False)
    >>> SuterConstants(k2=-1.0)
    Traceback (most recent call last):
    ...
    hillchart.errors.InputError: SuterConstants.k2 must be a finite number >= 0, got -1.0
    """

    k1: float = 0.0
    k2: float = 0.0
    c_h: float = 0.0
    c_y: float = 0.0

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) \
                    or not math.isfinite(value) or value < 0:
                raise InputError(f"SuterConstants.{f.name} must be a finite number >= 0, got {value!r}")

    @property
    def plain(self) -> bool:
        """True for the plain transform (every constant zero)."""
        return self.k1 == 0 and self.k2 == 0 and self.c_h == 0 and self.c_y == 0

    def opening_factor(self, opening) -> np.ndarray:
        """(y + C_y)^2 of the improved transform; 1 for the plain transform (which does not use the opening)."""
        y = np.asarray(opening, dtype=float)
        return np.ones_like(y) if self.plain else (y + self.c_y) ** 2

    def to_dict(self) -> dict:
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}


#: The plain transform.
PLAIN = SuterConstants()


def _convention(convention: str) -> str:
    if convention not in CONVENTIONS:
        raise InputError(f"convention must be one of {', '.join(CONVENTIONS)}, got {convention!r}")
    return convention


def _to_turbine(speed, flow, convention):
    """Speed and flow in the turbine convention (the inputs as arrays, broadcast)."""
    speed, flow = np.broadcast_arrays(np.asarray(speed, dtype=float), np.asarray(flow, dtype=float))
    if _convention(convention) == "wylie-streeter":
        return -speed, -flow
    return speed, flow


def _check_finite(name: str, value: np.ndarray) -> None:
    bad = ~np.isfinite(value)
    if np.any(bad):
        raise InputError(f"{name} must be finite, got {float(value[bad].flat[0])!r} at index "
                         f"{int(np.flatnonzero(bad.ravel())[0])}")


def _check_head(head: np.ndarray, constants: SuterConstants) -> None:
    if not constants.plain and np.any(head < 0):
        i = int(np.flatnonzero((head < 0).ravel())[0])
        raise InputError(f"head must be >= 0 for the improved Suter transform (sqrt(h) in the angle), got "
                         f"{float(head.flat[i])!r} at index {i}; use the plain transform (SuterConstants()) where the "
                         "head changes sign")


def _denominator(speed, flow, head, constants: SuterConstants) -> np.ndarray:
    denominator = flow**2 + speed**2 + constants.c_h * head
    if np.any(denominator <= 0):
        i = int(np.flatnonzero((denominator <= 0).ravel())[0])
        raise InputError(f"q^2 + v^2 + C_h h must be > 0 (the transform is undefined at standstill), got "
                         f"{float(denominator.flat[i])!r} at index {i} (speed {float(speed.flat[i])!r}, flow "
                         f"{float(flow.flat[i])!r})")
    return denominator


def _angle(v, q, h, constants: SuterConstants, convention: str) -> np.ndarray:
    """x on ``convention``'s axis from turbine-positive v, q and (checked) h."""
    shifted = q + constants.k2 * np.sqrt(h) if constants.k2 != 0 else q
    x = np.mod(math.pi + np.arctan2(shifted, v), TWO_PI)
    return np.mod(x - math.pi, TWO_PI) if convention == "wylie-streeter" else x


def suter_angle(speed, flow, head=None, *, constants: SuterConstants = PLAIN,
                convention: str = "turbine") -> np.ndarray:
    """x in [0, 2 pi) of the (improved) transform: ``pi + atan2(q + k2 sqrt(h), v)`` on turbine-positive
    quantities, reported on the convention's axis. ``head`` is needed only when k2 > 0."""
    v, q = _to_turbine(speed, flow, convention)
    h = None
    if constants.k2 != 0:
        if head is None:
            raise InputError("suter_angle: head is required when k2 > 0 (the angle holds q + k2 sqrt(h))")
        h = np.broadcast_to(np.asarray(head, dtype=float), v.shape)
        _check_finite("head", h)
        _check_head(h, constants)
    return _angle(v, q, h, constants, convention)


def suter_transform(speed, flow, head, torque, opening=1.0, *, constants: SuterConstants = PLAIN,
                    convention: str = "turbine") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(x, WH, WM)`` of operating points (module docstring), arrays broadcast together.

    Parameters
    ----------
    speed, flow, head, torque : array_like
        Relative v, q, h, m in ``convention`` (for "wylie-streeter": alpha, v, h, beta).
    opening : array_like, default 1
        Relative guide-vane opening y (used by the improved transform only).
    constants : SuterConstants
        :data:`PLAIN` or the improved transform's constants.
    convention : "turbine" | "wylie-streeter"

    Returns
    -------
    x : ndarray, radians in [0, 2 pi)
    wh, wm : ndarray

    Raises
    ------
    InputError
        A value that is not finite, standstill (q^2 + v^2 + C_h h = 0), a negative head for the improved transform,
        a negative opening, an unknown convention.

    Examples
    --------
    >>> x, wh, wm = suter_transform(1.0, 1.0, 1.0, 1.0)            # the rated turbine point
    >>> round(float(x / np.pi), 12), float(wh), float(wm)
    (1.25, 0.5, 0.5)
    >>> x, wh, wm = suter_transform(1.0, 1.0, 1.0, 1.0, convention="wylie-streeter")   # the rated pump point
    >>> round(float(x / np.pi), 12)
    1.25
    """
    v, q = _to_turbine(speed, flow, convention)
    h, m, y = np.broadcast_arrays(np.asarray(head, dtype=float), np.asarray(torque, dtype=float),
                                  np.asarray(opening, dtype=float))
    v, q, h, m, y = np.broadcast_arrays(v, q, h, m, y)
    for name, value in (("speed", v), ("flow", q), ("head", h), ("torque", m), ("opening", y)):
        _check_finite(name, value)
    if np.any(y < 0):
        raise InputError(f"opening must be >= 0 (relative guide-vane opening), got {float(y[y < 0].flat[0])!r}")
    _check_head(h, constants)
    denominator = _denominator(v, q, h, constants)
    factor = constants.opening_factor(y)
    wh = factor * h / denominator
    wm = factor * (m + constants.k1 * h) / denominator
    return _angle(v, q, h, constants, convention), wh, wm


def inverse_suter_transform(wh, wm, speed, flow, opening=1.0, *, constants: SuterConstants = PLAIN,
                            convention: str = "turbine") -> tuple[np.ndarray, np.ndarray]:
    """Head and torque ``(h, m)`` from the curves' values WH, WM at an operating point's speed, flow and opening.

    Plain: ``h = WH (q^2 + v^2)``, ``m = WM (q^2 + v^2)``. Improved, solving the definitions for h and m::

        h = WH (q^2 + v^2) / ((y + C_y)^2 - C_h WH),    m = WM (q^2 + v^2 + C_h h) / (y + C_y)^2 - k1 h

    WH and WM must be the curves' values at this point's x, which with k2 > 0 depends on h itself
    (:func:`suter_angle`): a caller that knows the curves and not h iterates h -> x(h) -> WH(x) -> h.

    Raises
    ------
    InputError
        Standstill, a value that is not finite, ``(y + C_y)^2 <= C_h WH`` (no finite head has this WH).

    Examples
    --------
    >>> c = SuterConstants(k1=1.5, k2=0.8, c_h=0.5, c_y=0.2)
    >>> x, wh, wm = suter_transform(0.9, 0.7, 1.3, -0.2, 0.6, constants=c)
    >>> [round(float(v), 12) for v in inverse_suter_transform(wh, wm, 0.9, 0.7, 0.6, constants=c)]
    [1.3, -0.2]
    """
    v, q = _to_turbine(speed, flow, convention)
    wh, wm, y = np.broadcast_arrays(np.asarray(wh, dtype=float), np.asarray(wm, dtype=float),
                                    np.asarray(opening, dtype=float))
    v, q, wh, wm, y = np.broadcast_arrays(v, q, wh, wm, y)
    for name, value in (("wh", wh), ("wm", wm), ("speed", v), ("flow", q), ("opening", y)):
        _check_finite(name, value)
    radius_sq = q**2 + v**2
    if np.any(radius_sq <= 0):
        raise InputError("speed and flow must not both be 0: the transform is undefined at standstill")
    factor = constants.opening_factor(y)
    rest = factor - constants.c_h * wh
    if np.any(rest <= 0):
        i = int(np.flatnonzero((rest <= 0).ravel())[0])
        raise InputError(f"wh must be < (y + C_y)^2 / C_h = {float(factor.flat[i] / constants.c_h)!r} for a finite "
                         f"head, got {float(wh.flat[i])!r} at index {i}")
    head = wh * radius_sq / rest
    torque = wm * (radius_sq + constants.c_h * head) / factor - constants.k1 * head
    return head, torque


def zone(speed, flow, torque=None, *, convention: str = "turbine") -> np.ndarray:
    """Zone names (:data:`ZONES`) of operating points, by the signs of speed and flow in the turbine convention;
    with ``torque``, "turbine brake" where a turbine-zone point has m < 0. Zero speed or flow belongs to the zone
    the point enters as x increases (so each zone is a half-open x-range ``[start, end)``); standstill is
    refused."""
    v, q = _to_turbine(speed, flow, convention)
    if np.any((v == 0) & (q == 0)):
        raise InputError("speed and flow must not both be 0: standstill belongs to no zone")
    x = np.mod(math.pi + np.arctan2(q, v), TWO_PI)
    names = np.empty(x.shape, dtype=object)
    for z in ZONES:
        lo, hi = z.x_turbine
        names[(x >= lo) & (x < hi)] = z.name
    if torque is not None:
        m = np.broadcast_to(np.asarray(torque, dtype=float), names.shape)
        names[(names == "turbine") & (m < 0)] = "turbine brake"
    return names


def wylie_streeter_x_to_turbine(x) -> np.ndarray:
    """A Wylie-Streeter x (pump-positive axis) on the turbine convention's axis: ``(x + pi) mod 2 pi``.

    Examples
    --------
    >>> float(wylie_streeter_x_to_turbine(1.25 * np.pi) / np.pi)     # the rated pump point
    0.25
    """
    return np.mod(np.asarray(x, dtype=float) + math.pi, TWO_PI)
