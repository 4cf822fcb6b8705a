"""Six transfer coefficients of a turbine from its unit characteristics (the linear turbine of paper 000).

A turbine near an operating point O = (n0, H0, a0) is the linear map (paper 000, eqs. 4-7; ``ey`` is that paper's
``e_u``)::

    m = ex x + ey y + eh h          # relative torque
    q = eqx x + eqy y + eqh h       # relative flow

with ``x = dn/n0``, ``y = da/a0``, ``h = dH/H0``, ``m = dM/M0``, ``q = dQ/Q0``. This module computes the six
coefficients from *any* :class:`~hillchart.characteristics.Characteristics` (the BP nets, the synthetic turbine,
the ideal turbine) using its analytic partial derivatives, so no finite-difference step has to be chosen.

Derivation from the unit quantities
-----------------------------------
With ``N11 = n D1 / sqrt(H)``, ``Q = Q11(N11, a) D1^2 sqrt(H)`` and ``M = M11(N11, a) D1^3 H`` take logarithmic
differentials (D1 is fixed)::

    d ln N11 = d ln n - 1/2 d ln H = x - h/2
    d ln M   = (N11/M11 dM11/dN11) d ln N11 + (a/M11 dM11/da) d ln a + d ln H
             = ex (x - h/2) + ey y + h
    d ln Q   = (N11/Q11 dQ11/dN11) d ln N11 + (a/Q11 dQ11/da) d ln a + 1/2 d ln H
             = eqx (x - h/2) + eqy y + h/2

so, collecting the coefficients of x, y and h::

    ex  = (N11/M11) dM11/dN11        ey  = (a/M11) dM11/da        eh  = 1 - ex/2
    eqx = (N11/Q11) dQ11/dN11        eqy = (a/Q11) dQ11/da        eqh = 1/2 - eqx/2

The head coefficients are therefore not independent: the unit-quantity scaling fixes them once ex and eqx are known.
For the ideal turbine (Q11 proportional to a, M11 proportional to a / N11) this gives exactly
(ex, ey, eh, eqx, eqy, eqh) = (-1, 1, 1.5, 0, 1, 0.5), the coefficients paper 002 uses in its eq. (4).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from hillchart.errors import InputError
from hillchart.characteristics import unit_speed

#: Names of the six coefficients, in the order used everywhere in hillsim.
COEFFICIENT_NAMES = ("ex", "ey", "eh", "eqx", "eqy", "eqh")


@dataclass(frozen=True)
class SixCoefficients:
    """The six transfer coefficients at one operating point (all dimensionless).

    Attributes
    ----------
    ex, ey, eh : float
        Relative torque sensitivities to speed, opening and head (``m = ex x + ey y + eh h``).
    eqx, eqy, eqh : float
        Relative flow sensitivities to speed, opening and head (``q = eqx x + eqy y + eqh h``).
    n11_rpm : float
        Unit speed N11 of the operating point, r/min.
    opening : float
        Guide-vane opening of the operating point, chart units.
    q11_m3_s : float
        Unit flow Q11 at the operating point, m^3/s.
    m11_nm : float
        Unit torque M11 at the operating point, N*m.
    """

    ex: float
    ey: float
    eh: float
    eqx: float
    eqy: float
    eqh: float
    n11_rpm: float
    opening: float
    q11_m3_s: float
    m11_nm: float

    def as_tuple(self) -> tuple[float, float, float, float, float, float]:
        """``(ex, ey, eh, eqx, eqy, eqh)``."""
        return tuple(float(getattr(self, name)) for name in COEFFICIENT_NAMES)

    def to_dict(self) -> dict:
        """Plain-float dictionary (JSON ready) with the six coefficients and the operating point."""
        return {key: float(value) for key, value in asdict(self).items()}

    @property
    def e(self) -> float:
        """Paper 002's combined coefficient ``e = eqy eh / ey - eqh`` (eq. (1) of paper 002)."""
        if self.ey == 0:
            raise InputError("six coefficients: e = eqy eh / ey - eqh needs ey != 0, got ey = 0")
        return self.eqy * self.eh / self.ey - self.eqh


def _check_point(name: str, value, *, positive: bool) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite, got {value!r}")
    if positive and np.any(arr <= 0):
        raise InputError(f"{name} must be > 0 (relative coefficients divide by it), got {value!r}")
    return arr


def _coefficient_arrays(characteristics, n11, opening):
    """Vectorized core: six coefficient arrays plus Q11, M11 at broadcast (n11, opening)."""
    n11 = _check_point("n11", n11, positive=True)
    opening = _check_point("opening", opening, positive=True)
    n11, opening = np.broadcast_arrays(n11, opening)
    q11 = np.asarray(characteristics.q11(n11, opening), dtype=float)
    m11 = np.asarray(characteristics.m11(n11, opening), dtype=float)
    dq_dn, dq_da = (np.asarray(g, dtype=float) for g in characteristics.q11_grad(n11, opening))
    dm_dn, dm_da = (np.asarray(g, dtype=float) for g in characteristics.m11_grad(n11, opening))
    return n11, opening, q11, m11, dq_dn, dq_da, dm_dn, dm_da


def _relative(n11, opening, q11, m11, dq_dn, dq_da, dm_dn, dm_da):
    ex = n11 / m11 * dm_dn  # ex = (N11/M11) dM11/dN11
    ey = opening / m11 * dm_da  # ey = (a/M11) dM11/da   (paper 000's e_u)
    eh = 1.0 - ex / 2.0  # from M = M11 D1^3 H, see module docstring
    eqx = n11 / q11 * dq_dn  # eqx = (N11/Q11) dQ11/dN11
    eqy = opening / q11 * dq_da  # eqy = (a/Q11) dQ11/da
    eqh = 0.5 - eqx / 2.0  # from Q = Q11 D1^2 sqrt(H), see module docstring
    return ex, ey, eh, eqx, eqy, eqh


def six_coefficients(characteristics, *, n11: float, opening: float) -> SixCoefficients:
    """Six transfer coefficients at unit speed ``n11`` and opening ``opening`` from analytic derivatives.

    Parameters
    ----------
    characteristics : Characteristics
        Any object with ``q11``, ``m11``, ``q11_grad``, ``m11_grad`` (see :mod:`hillchart.characteristics`).
    n11 : float
        Unit speed N11 of the operating point, r/min, > 0.
    opening : float
        Guide-vane opening of the operating point, chart units, > 0 (the coefficients are relative to it).

    Returns
    -------
    SixCoefficients

    Raises
    ------
    InputError
        Non-finite or non-positive ``n11``/``opening``, or Q11 or M11 zero or non-finite at the point (the relative
        coefficients divide by them).

    Examples
    --------
    >>> from hillchart.characteristics import IdealTurbine
    >>> c = six_coefficients(IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.9), n11=70.0, opening=15.0)
    >>> [round(v, 12) for v in c.as_tuple()]
    [-1.0, 1.0, 1.5, 0.0, 1.0, 0.5]
    """
    if not np.isscalar(n11) and np.ndim(n11) != 0:
        raise InputError(f"n11 must be a scalar (use coefficient_maps for grids), got shape {np.shape(n11)}")
    if not np.isscalar(opening) and np.ndim(opening) != 0:
        raise InputError(f"opening must be a scalar (use coefficient_maps for grids), got shape {np.shape(opening)}")
    n11_a, a_a, q11, m11, dq_dn, dq_da, dm_dn, dm_da = _coefficient_arrays(characteristics, n11, opening)
    q11_f, m11_f = float(q11), float(m11)
    for name, value in (("Q11", q11_f), ("M11", m11_f)):
        if not np.isfinite(value) or value == 0.0:
            raise InputError(
                f"{name} at (n11={float(n11_a)}, opening={float(a_a)}) is {value!r}: the relative coefficients need a "
                "finite, non-zero value (choose an operating point inside the chart)"
            )
    coeffs = _relative(n11_a, a_a, q11, m11, dq_dn, dq_da, dm_dn, dm_da)
    values = [float(c) for c in coeffs]
    if not all(np.isfinite(values)):
        raise InputError(f"six coefficients at (n11={float(n11_a)}, opening={float(a_a)}) are not finite: {values}")
    return SixCoefficients(*values, n11_rpm=float(n11_a), opening=float(a_a), q11_m3_s=q11_f, m11_nm=m11_f)


def six_coefficients_at(
    characteristics, *, speed_rpm: float, head_m: float, runner_diameter_m: float, opening: float
) -> SixCoefficients:
    """Six coefficients at a plant operating point given in physical units.

    ``N11 = n D1 / sqrt(H)`` (model law), then :func:`six_coefficients`.

    Parameters
    ----------
    characteristics : Characteristics
    speed_rpm : float
        Shaft speed n, r/min, > 0.
    head_m : float
        Net head H at the turbine, m, > 0.
    runner_diameter_m : float
        Runner diameter D1, m, > 0.
    opening : float
        Guide-vane opening, chart units, > 0.

    Returns
    -------
    SixCoefficients

    Examples
    --------
    >>> from hillchart.characteristics import IdealTurbine
    >>> c = six_coefficients_at(IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0), speed_rpm=150.0, head_m=100.0,
    ...                         runner_diameter_m=4.0, opening=20.0)
    >>> c.n11_rpm, round(c.ex, 12)
    (60.0, -1.0)
    """
    for name, value in (("speed_rpm", speed_rpm), ("head_m", head_m), ("runner_diameter_m", runner_diameter_m)):
        if not np.isscalar(value) or not np.isfinite(value) or value <= 0:
            raise InputError(f"{name} must be a finite scalar > 0, got {value!r}")
    n11 = float(unit_speed(float(speed_rpm), float(head_m), float(runner_diameter_m)))
    return six_coefficients(characteristics, n11=n11, opening=opening)


def six_coefficients_band(nets, *, n11: float, opening: float, percentiles=(5.0, 95.0)) -> dict:
    """Mean and percentile band of the six coefficients over the ensemble members of ``nets``.

    Parameters
    ----------
    nets : HillNets
        Nets with an ensemble (``hillsim train --ensemble N``).
    n11 : float, r/min
    opening : float, chart units
    percentiles : (low, high), percent

    Returns
    -------
    dict
        Coefficient name -> ``{"mean", "low", "high"}`` (dimensionless).

    Raises
    ------
    InputError
        No ensemble, or bad percentiles.
    """
    members = nets.members() if hasattr(nets, "members") else []
    if not members:
        raise InputError("these characteristics have no ensemble (train with --ensemble N)")
    low_p, high_p = percentiles
    if not (0 <= low_p < high_p <= 100):
        raise InputError(f"percentiles must satisfy 0 <= low < high <= 100, got {percentiles!r}")
    values = np.array([six_coefficients(m, n11=n11, opening=opening).as_tuple() for m in members])
    return {name: {"mean": float(np.mean(values[:, j])), "low": float(np.percentile(values[:, j], low_p)),
                   "high": float(np.percentile(values[:, j], high_p))} for j, name in enumerate(COEFFICIENT_NAMES)}


def coefficient_maps(characteristics, n11, opening) -> dict[str, np.ndarray]:
    """The six coefficients on a grid of unit speeds and openings.

    Parameters
    ----------
    characteristics : Characteristics
    n11 : array_like, shape (n,), r/min, > 0
    opening : array_like, shape (m,), chart units, > 0

    Returns
    -------
    dict
        ``"n11"`` (n,), ``"opening"`` (m,), ``"q11"``, ``"m11"`` and one array of shape (m, n) per coefficient
        name (rows = openings,
        columns = unit speeds). Torque coefficients are NaN where M11 is zero or not finite, flow coefficients
        where Q11 is.

    Examples
    --------
    >>> from hillchart.characteristics import IdealTurbine
    >>> maps = coefficient_maps(IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0), [60.0, 70.0, 80.0], [10.0, 20.0])
    >>> maps["eh"].shape, float(maps["eh"][1, 2])
    ((2, 3), 1.5)
    """
    n11 = _check_point("n11", n11, positive=True).ravel()
    opening = _check_point("opening", opening, positive=True).ravel()
    if n11.size == 0 or opening.size == 0:
        raise InputError("coefficient_maps needs at least one n11 and one opening value")
    n_grid, a_grid = np.meshgrid(n11, opening)
    n_grid, a_grid, q11, m11, dq_dn, dq_da, dm_dn, dm_da = _coefficient_arrays(characteristics, n_grid, a_grid)
    bad_m = ~np.isfinite(m11) | (m11 == 0)
    bad_q = ~np.isfinite(q11) | (q11 == 0)
    q_safe = np.where(bad_q, 1.0, q11)
    m_safe = np.where(bad_m, 1.0, m11)
    coeffs = _relative(n_grid, a_grid, q_safe, m_safe, dq_dn, dq_da, dm_dn, dm_da)
    out = {"n11": n11, "opening": opening, "q11": q11, "m11": m11}
    for name, values in zip(COEFFICIENT_NAMES, coeffs):
        bad = bad_q if name.startswith("eq") else bad_m
        out[name] = np.where(bad | ~np.isfinite(values), np.nan, values)
    return out


def plot_coefficient_maps(maps: dict, path=None, *, operating_point: tuple[float, float] | None = None,
                          opening_unit: str = "chart units"):
    """Filled-contour plot of each of the six coefficients over (N11, a).

    Parameters
    ----------
    maps : dict
        Output of :func:`coefficient_maps`.
    path : str or Path, optional
        Where to save the PNG; nothing is written when omitted.
    operating_point : (n11, opening), optional
        Marked with a cross on every panel.
    opening_unit : str
        Label of the opening axis.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    missing = [k for k in ("n11", "opening", *COEFFICIENT_NAMES) if k not in maps]
    if missing:
        raise InputError(f"maps is missing keys {missing}; pass the output of coefficient_maps")
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), sharex=True, sharey=True)
    m11 = np.asarray(maps["m11"], dtype=float) if "m11" in maps else None
    q11 = np.asarray(maps["q11"], dtype=float) if "q11" in maps else None
    for ax, name in zip(axes.ravel(), COEFFICIENT_NAMES):
        values = np.asarray(maps[name], dtype=float)
        # relative coefficients only mean something in turbine operation (M11 > 0, Q11 > 0): blank the brake
        # region beyond runaway, where M11 -> 0 makes them blow up
        if m11 is not None and q11 is not None:
            values = np.where((m11 > 0) & (q11 > 0), values, np.nan)
        finite = values[np.isfinite(values)]
        if finite.size:
            lo, hi = np.percentile(finite, [5, 95])  # colour scale of the bulk: near runaway M11 -> 0 still grows
            if hi <= lo:
                lo, hi = lo - 0.5, hi + 0.5
            levels = np.linspace(lo, hi, 21)
            cs = ax.contourf(maps["n11"], maps["opening"], values, levels=levels, cmap="viridis", extend="both")
            lines = ax.contour(maps["n11"], maps["opening"], values, levels=levels[::4], colors="w", linewidths=0.6)
            ax.clabel(lines, fontsize=7, fmt="%.2f")
            fig.colorbar(cs, ax=ax)
        if m11 is not None and np.nanmin(m11) < 0 < np.nanmax(m11):
            ax.contour(maps["n11"], maps["opening"], m11, levels=[0.0], colors="k", linewidths=1.2)
        if operating_point is not None:
            ax.plot(*operating_point, "rx", ms=9, mew=2)
        ax.set_title(name)
    for ax in axes[1]:
        ax.set_xlabel("N11 (r/min)")
    for ax in axes[:, 0]:
        ax.set_ylabel(f"opening a ({opening_unit})")
    fig.suptitle("Six transfer coefficients from the characteristics (analytic derivatives); "
                 "black line: runaway (M11 = 0), blank: no turbine operation")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


# ---------------------------------------------------------------------------------------------------------------
# double-regulated turbines: eight coefficients
# ---------------------------------------------------------------------------------------------------------------
#: Names of the eight coefficients of a double-regulated turbine (the six plus the blade angle's two).
EIGHT_COEFFICIENT_NAMES = COEFFICIENT_NAMES + ("ephi", "eqphi")
#: Central-difference step (deg of blade angle, and the same fraction of N11 and of the opening) for
#: three-input characteristics without analytic gradients (the exact synthetic bulb).
BLADE_DIFFERENCE_STEP = 1e-4


@dataclass(frozen=True)
class EightCoefficients:
    """The eight transfer coefficients of a double-regulated (Kaplan, bulb) turbine at one operating point::

        m = ex x + ey y + eh h + ephi dphi          # relative torque
        q = eqx x + eqy y + eqh h + eqphi dphi      # relative flow

    with ``x, y, h`` as for :class:`SixCoefficients` and ``dphi`` the blade-angle change in degrees (the blade
    angle has no natural reference value: near phi = 0 a relative change is meaningless), so ``ephi =
    (1/M11) dM11/dphi`` and ``eqphi = (1/Q11) dQ11/dphi`` are per degree. The other six follow the derivation in
    the module docstring at fixed blade angle.
    """

    ex: float
    ey: float
    eh: float
    eqx: float
    eqy: float
    eqh: float
    ephi: float
    eqphi: float
    n11_rpm: float
    opening: float
    blade_angle_deg: float
    q11_m3_s: float
    m11_nm: float

    def as_tuple(self) -> tuple:
        return tuple(float(getattr(self, name)) for name in EIGHT_COEFFICIENT_NAMES)

    def to_dict(self) -> dict:
        return {key: float(value) for key, value in asdict(self).items()}


def _three_input_gradients(characteristics, n11, opening, blade):
    """(q11, m11, dq/dn11, dq/da, dq/dphi, dm/dn11, dm/da, dm/dphi) at one point: analytic where the object has
    three-component gradients, else central differences of :data:`BLADE_DIFFERENCE_STEP`."""
    q = float(np.asarray(characteristics.q11(n11, opening, blade)))
    m = float(np.asarray(characteristics.m11(n11, opening, blade)))
    if hasattr(characteristics, "q11_grad") and hasattr(characteristics, "m11_grad"):
        dq = [float(np.asarray(g)) for g in characteristics.q11_grad(n11, opening, blade)]
        dm = [float(np.asarray(g)) for g in characteristics.m11_grad(n11, opening, blade)]
        return q, m, dq, dm
    steps = (BLADE_DIFFERENCE_STEP * n11, BLADE_DIFFERENCE_STEP * opening, BLADE_DIFFERENCE_STEP)
    dq, dm = [], []
    for j, h in enumerate(steps):
        up = [n11, opening, blade]
        down = [n11, opening, blade]
        up[j] += h
        down[j] -= h
        dq.append(float((characteristics.q11(*up) - characteristics.q11(*down)) / (2 * h)))
        dm.append(float((characteristics.m11(*up) - characteristics.m11(*down)) / (2 * h)))
    return q, m, dq, dm


def eight_coefficients(characteristics, *, n11: float, opening: float, blade_angle: float) -> EightCoefficients:
    """Eight transfer coefficients of three-input characteristics Q11(N11, a, phi), M11(N11, a, phi).

    Parameters
    ----------
    characteristics : object with ``q11(n11, opening, blade_angle)`` and ``m11(...)`` (and, optionally, their
        three-component gradients ``q11_grad``/``m11_grad``, e.g. the three-input nets)
    n11 : float, r/min, > 0
    opening : float, chart units, > 0
    blade_angle : float, deg

    Examples
    --------
    >>> from hillchart.synthetic.bulb import SyntheticBulb
    >>> c = eight_coefficients(SyntheticBulb(), n11=150.0, opening=50.0, blade_angle=-7.0)
    >>> round(c.eh - (1 - c.ex / 2), 12), c.eqphi > 0   # opening the blades passes more water
    (0.0, True)
    """
    n11_a = float(_check_point("n11", n11, positive=True))
    a_a = float(_check_point("opening", opening, positive=True))
    phi = float(_check_point("blade_angle", blade_angle, positive=False))
    q, m, dq, dm = _three_input_gradients(characteristics, n11_a, a_a, phi)
    for name, value in (("Q11", q), ("M11", m)):
        if not np.isfinite(value) or value == 0.0:
            raise InputError(f"{name} at (n11={n11_a}, opening={a_a}, blade_angle={phi}) is {value!r}: the relative "
                             "coefficients need a finite, non-zero value (choose a point inside the chart)")
    six = _relative(n11_a, a_a, q, m, dq[0], dq[1], dm[0], dm[1])
    values = [float(v) for v in six] + [dm[2] / m, dq[2] / q]
    if not all(np.isfinite(values)):
        raise InputError(f"eight coefficients at (n11={n11_a}, opening={a_a}, blade_angle={phi}) are not finite")
    return EightCoefficients(*values, n11_rpm=n11_a, opening=a_a, blade_angle_deg=phi, q11_m3_s=q, m11_nm=m)
