"""A physically based synthetic Francis turbine and the hill chart an engineer would digitize from it.

The model is a one-dimensional (mean streamline) Francis runner written directly in unit quantities
(runner inlet diameter D1 = 1 m, head H = 1 m), so it returns Q11 (m^3/s) and M11 (N*m) without scaling.

Equations
---------
Velocities, with N11 in r/min, D2 = d2 D1 the runner outlet diameter, B1 = b1 D1 the inlet height::

    u1 = pi D1 N11 / 60,          u2 = d2 u1                     (blade speeds)
    sin(alpha1) = a / t_gv                                       (guide-vane opening a sets the inlet flow angle)
    cm1 = c1 sin(alpha1),         cu1 = c1 cos(alpha1)            (absolute inlet velocity c1)
    Q11 = pi D1 B1 cm1,           cm2 = Q11 / A2, A2 = pi D2^2/4  (continuity)
    cu2 = u2 - cm2 cot(beta2)                                     (exit flow leaves along the blade angle beta2)

Energy balance on the unit head (Euler turbine equation plus losses)::

    g H = (u1 cu1 - u2 cu2)                                       (Euler head, energy given to the runner)
          + k_gv c1^2 / 2                                         (spiral casing and guide vanes)
          + k_sh (cu1 - u1 + cm1 cot(beta1))^2 / 2                (inlet incidence: tangential mismatch with blade)
          + k_r w2^2 / 2,  w2 = cm2 / sin(beta2)                  (runner friction)
          + k_dt cm2^2 / 2                                        (draft tube: unrecovered meridional energy)
          + k_sw cu2^2 / 2                                        (exit swirl, lost)

is a quadratic ``alpha c1^2 + beta c1 + gamma = 0`` in the inlet velocity c1, solved in closed form (the root with
c1 > 0). Torque on the shaft, Euler's moment of momentum minus disc friction::

    M11 = rho Q11 (r1 cu1 - r2 cu2) - K_df N11^2

So at zero opening (sin(alpha1) = 0) Q11 = 0 exactly and M11 = -K_df N11^2; the runaway speed is where M11 = 0; the
centrifugal and incidence terms make Q11 fall with N11 at small openings as in real medium-head Francis runners. The
quadratic has a positive root while ``gamma < 0``, i.e. up to N11 about 1.6 times runaway; beyond that (the
pumping "S" region) the model raises.

Derivatives are exact: every operation above is analytic, so they come from complex-step differentiation
(``f'(x) = Im f(x + i h) / h`` with h = 1e-30), accurate to machine precision.

Default parameters were chosen so the turbine resembles the BP hill-chart paper's HLA339-LJ-450 (rated 176 m,
225 MW, 200 r/min, 142.5 m^3/s, D1 = 4.5 m, rated N11 = 67.8 r/min, Q11 = 0.53 m^3/s): best efficiency about 0.94 at
N11 about 65 r/min, runaway N11 110-126 r/min (1.7-1.9 times the best-efficiency N11), the rated point at about 73 %
opening inside the chart.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np
from numba.extending import register_jitable

from hillchart.characteristics import efficiency_from_unit_torque
from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
from hillchart.errors import InputError, NumericalError

_COMPLEX_STEP = 1e-30


@register_jitable
def _francis_angles(p):
    """``(cot beta1, cot beta2, sin beta2)`` of the parameters ``p`` (see :func:`_francis_terms`): the blade-angle
    terms, constants of a runner. The simulator's kernels take them packed with the parameters
    (:func:`_synthetic_values_at`), so a step does not evaluate three trigonometric functions of constants.
    ``math`` (the C library) in Python and compiled alike, so the packed terms are the ones the compiled model
    computes, to the bit."""
    return 1.0 / math.tan(math.radians(p[3])), 1.0 / math.tan(math.radians(p[4])), math.sin(math.radians(p[4]))


def _francis_terms(p, n11, opening):
    """``(Q11, M11, gamma)`` of the 1-D model (module docstring) for parameters ``p`` = (d2, b1, t_gv, beta1_deg,
    beta2_deg, k_gv, k_sh, k_r, k_dt, k_sw, k_df, opening_max) at real or complex N11 (r/min) and opening (mm),
    arrays or scalars. The single implementation of the model equations (:func:`_francis_terms_at`): numpy evaluates
    it on arrays, numba compiles it for the simulator's kernel (:func:`_synthetic_kernel`). ``gamma >= 0`` means no
    positive flow."""
    return _francis_terms_at(p, _francis_angles(p), n11, opening)


@register_jitable
def _francis_terms_at(p, angles, n11, opening):
    """:func:`_francis_terms` with the blade-angle terms ``angles`` of :func:`_francis_angles` given."""
    d2, b1, pitch, k_gv, k_sh, k_r, k_dt, k_sw, k_df = p[0], p[1], p[2], p[5], p[6], p[7], p[8], p[9], p[10]
    cot_b1, cot_b2, sin_b2 = angles
    u1 = np.pi * n11 / 60.0
    u2 = d2 * u1
    sin_a = opening / pitch
    cos_a = np.sqrt(1.0 - sin_a * sin_a)
    inlet_area = np.pi * b1  # pi D1 B1 with D1 = 1
    outlet_area = np.pi * d2**2 / 4.0
    r = inlet_area * sin_a / outlet_area  # cm2 = r c1
    e = cos_a + sin_a * cot_b1  # incidence: cu1 - u1 + cm1 cot(beta1) = e c1 - u1
    f = r * cot_b2  # cu2 = u2 - f c1
    alpha = k_gv + k_sh * e * e + k_r * r * r / sin_b2**2 + k_dt * r * r + k_sw * f * f
    beta = 2 * u1 * cos_a + 2 * u2 * f - 2 * k_sh * e * u1 - 2 * k_sw * u2 * f
    gamma = k_sh * u1 * u1 + (k_sw - 2.0) * u2 * u2 - 2.0 * G_M_S2
    disc = np.sqrt(beta * beta - 4 * alpha * gamma)
    c1 = -2.0 * gamma / (beta + disc)  # stable root of alpha c1^2 + beta c1 + gamma = 0 (beta + disc > 0)
    q11 = inlet_area * sin_a * c1
    cu1 = cos_a * c1
    cu2 = u2 - f * c1
    m11 = RHO_WATER_KG_M3 * q11 * 0.5 * (cu1 - d2 * cu2) - k_df * n11 * n11
    return q11, m11, gamma


_francis_terms_at_compiled = numba.njit(cache=True)(_francis_terms_at)


def francis_angles(params) -> tuple[float, float, float]:
    """The blade-angle terms (:func:`_francis_angles`) of ``params``, for a kernel's packed parameters: kernels given
    them (:func:`_synthetic_values_at`) return what :func:`_francis_terms` computes, to the bit."""
    return _francis_angles([float(v) for v in params[:5]])


@numba.njit(cache=True)
def _synthetic_values_at(params, angles, n11, opening):
    """``(q11, m11)`` of :func:`_francis_terms` at a scalar point, with the blade-angle terms ``angles``; NaN
    outside ``0 <= opening <= opening_max``, N11 >= 0 or beyond the model's range (no positive flow)."""
    q, m, gamma = _francis_terms_at_compiled(params, angles, n11, opening)
    if not (gamma < 0.0 and n11 >= 0.0 and 0.0 <= opening <= params[11]):
        return np.nan, np.nan
    return q, m


@numba.njit(cache=True)
def _synthetic_kernel_at(params, angles, n11, opening):
    """Simulator kernel ``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` at a scalar point, with the
    blade-angle terms ``angles``: the values of :func:`_synthetic_values_at` and complex-step derivatives
    (``f'(x) = Im f(x + i h) / h``) of :func:`_francis_terms_at`."""
    q, m = _synthetic_values_at(params, angles, n11, opening)
    if q != q:
        return np.nan, np.nan, np.nan, np.nan, np.nan, np.nan
    h = _COMPLEX_STEP
    q_n, m_n, _ = _francis_terms_at_compiled(params, angles, complex(n11, h), complex(opening, 0.0))
    q_a, m_a, _ = _francis_terms_at_compiled(params, angles, complex(n11, 0.0), complex(opening, h))
    return q, q_n.imag / h, q_a.imag / h, m, m_n.imag / h, m_a.imag / h


@numba.njit(cache=True)
def _synthetic_kernel(params, n11, opening):
    """:func:`_synthetic_kernel_at` with the angles computed from ``params``."""
    return _synthetic_kernel_at(params, _francis_angles(params), n11, opening)


@dataclass(frozen=True)
class FrancisParameters:
    """Geometry and loss coefficients of the 1-D Francis model (all lengths relative to D1, angles in degrees).

    Attributes
    ----------
    d2 : D2/D1, runner outlet diameter ratio.
    b1 : B1/D1, runner inlet height ratio.
    guide_vane_pitch_mm : t_gv, opening (chart units, mm) at which the inlet flow would be radial (sin alpha1 = 1).
    beta1_deg, beta2_deg : blade inlet and outlet angles (from the tangential direction), degrees.
    k_guide_vane, k_incidence, k_runner, k_draft_tube, k_swirl : loss coefficients (fractions of dynamic heads).
    k_disc_friction : K_df in M11 = ... - K_df N11^2, N*m/(r/min)^2.
    opening_max : full-stroke opening, mm.
    """

    d2: float = 0.85
    b1: float = 0.20
    guide_vane_pitch_mm: float = 70.0
    beta1_deg: float = 45.0
    beta2_deg: float = 16.0
    k_guide_vane: float = 0.05
    k_incidence: float = 0.9
    k_runner: float = 0.06
    k_draft_tube: float = 0.2
    k_swirl: float = 1.0
    k_disc_friction: float = 1.5e-3
    opening_max: float = 32.0

    def __post_init__(self):
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise InputError(f"FrancisParameters.{name} must be finite and > 0, got {value!r}")
        if self.opening_max >= self.guide_vane_pitch_mm:
            raise InputError(
                f"FrancisParameters.opening_max must be < guide_vane_pitch_mm = {self.guide_vane_pitch_mm}, "
                f"got {self.opening_max!r}"
            )


@dataclass(frozen=True)
class SyntheticFrancis:
    """Exact characteristics of the synthetic Francis turbine (implements the ``Characteristics`` protocol).

    Examples
    --------
    >>> turbine = SyntheticFrancis()
    >>> round(float(turbine.q11(0.0, 0.0)), 12), float(turbine.m11(60.0, 0.0)) < 0
    (0.0, True)
    >>> round(float(turbine.efficiency(65.0, 18.5)), 3)
    0.935
    """

    params: FrancisParameters = field(default_factory=FrancisParameters)

    @property
    def opening_max(self) -> float:
        return self.params.opening_max

    def _solve(self, n11, opening):
        """Q11 and M11 on (possibly complex) inputs, by :func:`_francis_terms` (the model equations)."""
        with np.errstate(invalid="ignore"):  # sqrt of a negative discriminant where gamma >= 0: raised below
            q11, m11, gamma = _francis_terms(self._terms_params(), n11, opening)
        if np.any(np.real(gamma) >= 0):
            bad = np.real(n11 + 0 * gamma)[np.real(gamma) >= 0]
            raise InputError(
                f"synthetic turbine: N11 = {float(np.max(bad)):.1f} r/min is beyond the model's range "
                "(no positive flow: pumping region); allowed N11 below about 1.6 x runaway"
            )
        return q11, m11

    def _terms_params(self) -> tuple:
        p = self.params
        return (p.d2, p.b1, p.guide_vane_pitch_mm, p.beta1_deg, p.beta2_deg, p.k_guide_vane, p.k_incidence,
                p.k_runner, p.k_draft_tube, p.k_swirl, p.k_disc_friction, p.opening_max)

    def numba_kernel(self):
        """``(kernel, params)`` for the simulator's compiled time loop: values and complex-step derivatives of the
        same equations (:func:`_francis_terms`, compiled); NaN outside ``0 <= opening <= opening_max``, N11 >= 0 or
        beyond the model's range, which the loop reports as a numerical failure."""
        return _synthetic_kernel, tuple(float(v) for v in self._terms_params())

    def _checked(self, n11, opening):
        n11, opening = np.broadcast_arrays(np.asarray(n11, dtype=float), np.asarray(opening, dtype=float))
        if np.any(n11 < 0) or np.any(opening < 0) or np.any(opening > self.params.opening_max):
            raise InputError(
                f"synthetic turbine: need n11 >= 0 and 0 <= opening <= {self.params.opening_max}, got n11 in "
                f"[{n11.min()}, {n11.max()}], opening in [{opening.min()}, {opening.max()}]"
            )
        return n11, opening

    def q11(self, n11, opening):
        return np.real(self._solve(*self._checked(n11, opening))[0])

    def m11(self, n11, opening):
        return np.real(self._solve(*self._checked(n11, opening))[1])

    def _grad(self, n11, opening, index):
        n11, opening = self._checked(n11, opening)
        h = _COMPLEX_STEP
        d_n = np.imag(self._solve(n11 + 1j * h, opening.astype(complex))[index]) / h
        d_a = np.imag(self._solve(n11.astype(complex), opening + 1j * h)[index]) / h
        return d_n, d_a

    def q11_grad(self, n11, opening):
        return self._grad(n11, opening, 0)

    def m11_grad(self, n11, opening):
        return self._grad(n11, opening, 1)

    def efficiency(self, n11, opening):
        """Hydraulic efficiency M11 omega11 / (rho g Q11); 0 where Q11 = 0 (no flow, no efficiency)."""
        n11, opening = self._checked(n11, opening)
        q11, m11 = (np.real(v) for v in self._solve(n11, opening))
        # at N11 = 0 with flow the runner does no work: 0, not the NaN of the general inverse of eq. (5)
        return np.where((q11 > 0) & (n11 > 0), efficiency_from_unit_torque(q11, n11, m11), 0.0)

    def runaway_n11(self, opening: float) -> float:
        """Runaway unit speed (M11 = 0) at one opening > 0, r/min (Brent's method on a bracket)."""
        if not (0 < opening <= self.params.opening_max):
            raise InputError(f"runaway_n11: opening must be in (0, {self.params.opening_max}], got {opening!r}")
        lo, hi = 1.0, 1.0
        while float(self.m11(hi, opening)) > 0:
            hi *= 1.2
            if hi > 1000:  # pragma: no cover - the default geometry never gets here
                raise NumericalError(f"runaway_n11: no zero torque below N11 = 1000 at opening {opening}")
        from scipy.optimize import brentq  # here: scipy.optimize costs about a second of every run's start-up

        return float(brentq(lambda n: float(self.m11(n, opening)), lo, hi, xtol=1e-12, rtol=1e-14))


# ---------------------------------------------------------------------------------------------------------------
# The family: three geometries spanning specific speed
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ChartLayout:
    """What a manufacturer's model chart of one turbine shows (model units: N11 r/min, openings mm).

    Attributes
    ----------
    n11_range : (float, float)
        N11 window of the chart, r/min.
    openings_mm : tuple of float
        Equal-opening lines drawn, mm.
    efficiencies : tuple of float
        Iso-efficiency contour levels drawn (fractions, ascending).
    runaway_openings_mm : tuple of float
        Openings of the runaway curve points, mm.
    name : str
        The ``name`` written into ``chart.toml``.
    axis_full_scale : (float, float)
        Full scale of the chart's N11 (r/min) and Q11 (m^3/s) axes: digitization noise is a percentage of it.
    """

    n11_range: tuple[float, float]
    openings_mm: tuple[float, ...]
    efficiencies: tuple[float, ...]
    runaway_openings_mm: tuple[float, ...]
    name: str
    axis_full_scale: tuple[float, float] = (100.0, 1.0)

    @property
    def efficiency_floor(self) -> float:
        """Lowest efficiency drawn: the opening lines stop where the contours stop."""
        return self.efficiencies[0]


@dataclass(frozen=True)
class FamilyTurbine:
    """One member of the synthetic Francis family: geometry (the exact turbine) and the chart drawn of it."""

    params: FrancisParameters
    layout: ChartLayout
    description: str

    def turbine(self) -> SyntheticFrancis:
        return SyntheticFrancis(self.params)


#: Window of the manufacturer's model chart of the medium turbine: only the high-efficiency, mid-to-large opening
#: region.
CHART_N11_RANGE = (44.0, 92.0)
CHART_OPENINGS_MM = (10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0)
CHART_EFFICIENCIES = (0.80, 0.84, 0.87, 0.89, 0.91, 0.92, 0.93, 0.935, 0.938)
RUNAWAY_OPENINGS_MM = (6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0)
#: Lowest efficiency still drawn on the medium chart (the opening lines stop where the contours stop).
CHART_EFFICIENCY_FLOOR = 0.80

#: The family (``hillsim synth --turbine NAME``). Specific speed n_s ~ N11_best sqrt(Q11_best eta_best): slow 28,
#: medium 43 (the shipped turbine), fast 64. Best efficiency and runaway/best N11 ratios are held by
#: ``tests/hillchart/synthetic/test_synthetic_family.py``: slow 0.942 / 1.6-1.8, medium 0.936 / 1.6-1.9,
#: fast 0.913 / 1.5-2.0.
FAMILY = {
    "slow": FamilyTurbine(
        params=FrancisParameters(d2=0.70, b1=0.12, beta1_deg=70.0, beta2_deg=15.0, opening_max=24.0),
        layout=ChartLayout(
            n11_range=(40.0, 86.0),
            openings_mm=tuple(7.5 + 1.5 * i for i in range(12)),
            efficiencies=(0.80, 0.84, 0.87, 0.89, 0.91, 0.92, 0.93, 0.935, 0.94),
            runaway_openings_mm=tuple(4.5 + 1.5 * i for i in range(14)),
            name="hillsim synthetic Francis, slow (low specific speed, 1-D Euler model)",
            axis_full_scale=(100.0, 0.5),
        ),
        description="low specific speed: narrow runner (B1/D1 0.12, D2/D1 0.70), best eta 0.942 at N11 60, Q11 0.23",
    ),
    "medium": FamilyTurbine(
        params=FrancisParameters(),
        layout=ChartLayout(
            n11_range=CHART_N11_RANGE,
            openings_mm=CHART_OPENINGS_MM,
            efficiencies=CHART_EFFICIENCIES,
            runaway_openings_mm=RUNAWAY_OPENINGS_MM,
            name="hillsim synthetic Francis (HLA339-like, 1-D Euler model)",
        ),
        description="HLA339-like medium head (the shipped chart): best eta 0.936 at N11 65, Q11 0.46",
    ),
    "fast": FamilyTurbine(
        params=FrancisParameters(d2=0.90, b1=0.30, beta1_deg=35.0, beta2_deg=24.0, guide_vane_pitch_mm=90.0,
                                 opening_max=40.0),
        layout=ChartLayout(
            n11_range=(48.0, 100.0),
            openings_mm=tuple(12.5 + 2.5 * i for i in range(12)),
            efficiencies=(0.78, 0.82, 0.85, 0.87, 0.88, 0.89, 0.90, 0.905, 0.91),
            runaway_openings_mm=tuple(10.0 + 2.5 * i for i in range(13)),
            name="hillsim synthetic Francis, fast (high specific speed, 1-D Euler model)",
            axis_full_scale=(120.0, 1.2),
        ),
        description="high specific speed: wide runner (B1/D1 0.30, beta2 24 deg), best eta 0.913 at N11 70, Q11 0.90",
    ),
}


def family_turbine(name: str) -> FamilyTurbine:
    """The family member called ``name`` (one of :data:`FAMILY`); InputError names the allowed ones."""
    if name not in FAMILY:
        raise InputError(f"turbine must be one of {', '.join(FAMILY)}, got {name!r}")
    return FAMILY[name]


# ---------------------------------------------------------------------------------------------------------------
# The chart an engineer digitizes
# ---------------------------------------------------------------------------------------------------------------

#: Digitization noise (one standard deviation) at the default noise level 0.15 % on the medium chart (axes 0-100
#: r/min, 0-1 m^3/s): reading a printed chart by eye/mouse. A noise level p % is p % of each axis' full scale
#: (:attr:`ChartLayout.axis_full_scale`).
NOISE_N11_RPM = 0.15
NOISE_Q11_M3_S = 0.0015
DEFAULT_NOISE_PCT = 0.15
#: Rounding of digitized values (what a digitizer's export keeps), in the default units.
DIGITS = {"n11": 2, "q11": 4, "opening": 2, "efficiency": 3}
#: Guide-vane angle at full stroke when a chart gives openings in degrees (the opening maps linearly to the angle).
FULL_STROKE_DEG = 30.0
OPENING_UNITS = ("mm", "deg", "%")
Q11_UNITS = ("m3/s", "l/s")
EFFICIENCY_UNITS = ("fraction", "percent")


@dataclass(frozen=True)
class DigitizationOptions:
    """How the chart is digitized (defaults: the shipped chart).

    Attributes
    ----------
    points_per_line : int in [3, 12]
        Points read along each equal-opening line.
    spacing : {"even", "uneven"}
        Even spacing in N11, or random gaps (Dirichlet(2) fractions of the line, seeded from ``seed``).
    noise_pct : float in [0, 5]
        Digitization noise level: sigma N11 and sigma Q11 = noise_pct % of the chart's axis full scale (medium
        chart: 100 r/min and 1 m^3/s; slow: 100 r/min, 0.5 m^3/s; fast: 120 r/min, 1.2 m^3/s).
    opening_unit : {"mm", "deg", "%"}
        Openings in mm (the model's unit), guide-vane degrees (full stroke = 30 deg) or % of full stroke.
    q11_unit : {"m3/s", "l/s"}
    efficiency_unit : {"fraction", "percent"}
    runaway : bool
        Write ``runaway.csv``.
    opening_lines : int or None
        Use only this many of the layout's opening lines (evenly chosen, >= 3); None: all.
    """

    points_per_line: int = 7
    spacing: str = "even"
    noise_pct: float = DEFAULT_NOISE_PCT
    opening_unit: str = "mm"
    q11_unit: str = "m3/s"
    efficiency_unit: str = "fraction"
    runaway: bool = True
    opening_lines: int | None = None

    def __post_init__(self):
        if isinstance(self.points_per_line, bool) or not isinstance(self.points_per_line, int) or not (
                3 <= self.points_per_line <= 12):
            raise InputError(f"points_per_line must be an integer in [3, 12], got {self.points_per_line!r}")
        if self.spacing not in ("even", "uneven"):
            raise InputError(f"spacing must be 'even' or 'uneven', got {self.spacing!r}")
        if isinstance(self.noise_pct, bool) or not isinstance(self.noise_pct, (int, float)) or not (
                0 <= self.noise_pct <= 5):
            raise InputError(f"noise_pct must be a number in [0, 5] (percent), got {self.noise_pct!r}")
        for name, allowed in (("opening_unit", OPENING_UNITS), ("q11_unit", Q11_UNITS),
                              ("efficiency_unit", EFFICIENCY_UNITS)):
            if getattr(self, name) not in allowed:
                raise InputError(f"{name} must be one of {allowed}, got {getattr(self, name)!r}")
        if not isinstance(self.runaway, bool):
            raise InputError(f"runaway must be True or False, got {self.runaway!r}")
        if self.opening_lines is not None and (
                isinstance(self.opening_lines, bool) or not isinstance(self.opening_lines, int)
                or self.opening_lines < 3):
            raise InputError(f"opening_lines must be an integer >= 3 or None, got {self.opening_lines!r}")


def _fmt(value: float, digits: int) -> str:
    return f"{value:.{digits}f}"


def _csv_text(header, rows) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


class _Digitizer:
    """Turns exact points into exported rows: label and values in the chart's units, noise, rounding."""

    def __init__(self, options: DigitizationOptions, opening_max_mm: float, rng: np.random.Generator,
                 axis_full_scale: tuple[float, float] = (100.0, 1.0)):
        self.options = options
        self.rng = rng
        scale = options.noise_pct / DEFAULT_NOISE_PCT  # exactly 1.0 at the default level
        self.sigma_n11 = NOISE_N11_RPM * scale * (axis_full_scale[0] / 100.0)  # exact on the medium chart's axes
        self.sigma_q11 = NOISE_Q11_M3_S * scale * (axis_full_scale[1] / 1.0)
        self.opening_factor = {"mm": 1.0, "%": 100.0 / opening_max_mm,
                               "deg": FULL_STROKE_DEG / opening_max_mm}[options.opening_unit]
        self.q11_factor, self.q11_digits = (1.0, DIGITS["q11"]) if options.q11_unit == "m3/s" else (1000.0, 1)
        self.eff_factor, self.eff_digits = ((1.0, DIGITS["efficiency"]) if options.efficiency_unit == "fraction"
                                            else (100.0, 1))

    def opening(self, opening_mm: float) -> float:
        return opening_mm * self.opening_factor if self.opening_factor != 1.0 else opening_mm

    def row(self, label: float, label_digits: int, n11: float, q11: float):
        """A point as a digitizer exports it: exact label, N11 and Q11 with reading noise, rounded."""
        n = n11 + self.rng.normal(0, self.sigma_n11)  # N11 drawn first, then Q11 (the shipped chart's order)
        q = q11 + self.rng.normal(0, self.sigma_q11)
        return (_fmt(label, label_digits), _fmt(n, DIGITS["n11"]),
                _fmt(q * self.q11_factor if self.q11_factor != 1.0 else q, self.q11_digits))


def _line_positions(options: DigitizationOptions, rng: np.random.Generator) -> np.ndarray:
    """Fractions in [0, 1] of a line's visible N11 span where points are read (both ends included)."""
    k = options.points_per_line
    if options.spacing == "even":
        return np.linspace(0.0, 1.0, k)
    gaps = rng.dirichlet(np.full(k - 1, 2.0))
    return np.concatenate([[0.0], np.cumsum(gaps)[:-1], [1.0]])


def _chosen_openings(layout: ChartLayout, options: DigitizationOptions) -> tuple[float, ...]:
    openings = layout.openings_mm
    if options.opening_lines is None or options.opening_lines >= len(openings):
        return openings
    index = np.round(np.linspace(0, len(openings) - 1, options.opening_lines)).astype(int)
    return tuple(openings[i] for i in index)


def _flow_lines(turbine: SyntheticFrancis, layout: ChartLayout, options: DigitizationOptions,
                digitizer: _Digitizer, spacing_rng: np.random.Generator):
    rows = []
    n11_grid = np.linspace(*layout.n11_range, 321)
    for opening in _chosen_openings(layout, options):
        eta = turbine.efficiency(n11_grid, opening)
        inside = n11_grid[eta >= layout.efficiency_floor]
        if inside.size < 2:
            continue
        if options.spacing == "even":
            points = np.linspace(inside[0], inside[-1], options.points_per_line)  # the shipped chart's arithmetic
        else:
            points = inside[0] + (inside[-1] - inside[0]) * _line_positions(options, spacing_rng)
        for n11 in points:
            rows.append(digitizer.row(digitizer.opening(opening), DIGITS["opening"], n11,
                                      float(turbine.q11(n11, opening))))
    return rows


def _efficiency_contours(turbine: SyntheticFrancis, layout: ChartLayout, digitizer: _Digitizer,
                         points_per_contour: int = 16):
    import contourpy

    n11 = np.linspace(*layout.n11_range, 161)
    opening = np.linspace(layout.openings_mm[0], layout.openings_mm[-1], 121)
    nn, aa = np.meshgrid(n11, opening)
    eta = turbine.efficiency(nn, aa)
    generator = contourpy.contour_generator(nn, aa, eta)
    rows = []
    for level in layout.efficiencies:
        for line in generator.lines(level):
            if len(line) < 4:
                continue
            arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line / [30.0, 20.0], axis=0).T))])
            for s in np.linspace(0.0, arc[-1], points_per_contour, endpoint=not np.allclose(line[0], line[-1])):
                n, a = np.interp(s, arc, line[:, 0]), np.interp(s, arc, line[:, 1])
                a = min(max(a, opening[0]), opening[-1])  # a contour on the grid's edge, rounded past it
                rows.append(digitizer.row(level * digitizer.eff_factor if digitizer.eff_factor != 1.0 else level,
                                          digitizer.eff_digits, n, float(turbine.q11(n, a))))
    return rows


def _runaway_curve(turbine: SyntheticFrancis, layout: ChartLayout, digitizer: _Digitizer):
    rows = []
    for opening in layout.runaway_openings_mm:
        n11 = turbine.runaway_n11(opening)
        rows.append(digitizer.row(digitizer.opening(opening), DIGITS["opening"], n11,
                                  float(turbine.q11(n11, opening))))
    return rows


def truth_n11_max(turbine: SyntheticFrancis) -> float:
    """Upper N11 of the truth grid: 15 % beyond the highest runaway speed, rounded up to 5 r/min."""
    return float(np.ceil(1.15 * turbine.runaway_n11(turbine.opening_max) / 5.0) * 5.0)


def _truth_grid(turbine: SyntheticFrancis, opening_factor: float = 1.0):
    n11 = np.arange(0.0, truth_n11_max(turbine) + 1e-9, 2.5)
    opening = np.arange(0.0, turbine.opening_max + 1e-9, 1.0)
    nn, aa = (g.ravel() for g in np.meshgrid(n11, opening))
    q11, m11, eta = turbine.q11(nn, aa), turbine.m11(nn, aa), turbine.efficiency(nn, aa)
    chart_a = aa * opening_factor if opening_factor != 1.0 else aa
    return [
        tuple(f"{v:.10g}" for v in row) for row in zip(nn, chart_a, q11, m11, eta)
    ]


CHART_TOML = """\
name = "{name}"
opening_unit = "{opening_unit}"
opening_max = {opening_max}
q11_unit = "{q11_unit}"
efficiency_unit = "{efficiency_unit}"
runner_diameter_m = 0.35
"""


def synthetic_chart_texts(*, seed: int = 0, turbine: str | FamilyTurbine | SyntheticFrancis | None = None,
                          options: DigitizationOptions | None = None) -> dict[str, str]:
    """The chart files of a synthetic turbine as text (see :func:`write_synthetic_chart`)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    options = options or DigitizationOptions()
    if turbine is None or isinstance(turbine, str):
        member = family_turbine("medium" if turbine is None else turbine)
        exact, layout = member.turbine(), member.layout
    elif isinstance(turbine, FamilyTurbine):
        exact, layout = turbine.turbine(), turbine.layout
    elif isinstance(turbine, SyntheticFrancis):
        exact, layout = turbine, FAMILY["medium"].layout
    else:
        raise InputError(f"turbine must be a family name ({', '.join(FAMILY)}), a family member or a "
                         f"SyntheticFrancis, got {turbine!r}")
    rng = np.random.default_rng(seed)
    spacing_rng = np.random.default_rng([seed, 1])  # uneven spacing never disturbs the noise stream
    digitizer = _Digitizer(options, exact.opening_max, rng, layout.axis_full_scale)
    opening_max = digitizer.opening(float(exact.opening_max))
    texts = {
        "chart.toml": CHART_TOML.format(name=layout.name, opening_unit=options.opening_unit,
                                        opening_max=repr(float(opening_max)), q11_unit=options.q11_unit,
                                        efficiency_unit=options.efficiency_unit),
        "flow.csv": _csv_text(("opening", "n11", "q11"), _flow_lines(exact, layout, options, digitizer, spacing_rng)),
        "efficiency.csv": _csv_text(("efficiency", "n11", "q11"), _efficiency_contours(exact, layout, digitizer)),
    }
    runaway_rows = _runaway_curve(exact, layout, digitizer)  # drawn always: the noise stream stays the same
    if options.runaway:
        texts["runaway.csv"] = _csv_text(("opening", "n11", "q11"), runaway_rows)
    texts["truth.csv"] = _csv_text(("n11", "opening", "q11", "m11", "efficiency"),
                                   _truth_grid(exact, digitizer.opening_factor))
    return texts


def write_synthetic_chart(out_dir, *, seed: int = 0, turbine: str | FamilyTurbine | SyntheticFrancis | None = None,
                          options: DigitizationOptions | None = None) -> dict[str, Path]:
    """Write the digitized chart of a synthetic turbine (and its exact truth grid) into ``out_dir``.

    Files: ``chart.toml``, ``flow.csv`` (opening,n11,q11), ``efficiency.csv`` (efficiency,n11,q11),
    ``runaway.csv`` (opening,n11,q11; unless ``options.runaway`` is False) and ``truth.csv``
    (n11,opening,q11,m11,efficiency; exact, for evaluation: Q11 in m^3/s, efficiency a fraction, opening in the
    chart's unit). Digitization noise: Gaussian, sigma 0.15 r/min on N11 and 0.0015 m^3/s on Q11 at the default
    level, drawn from ``numpy.random.default_rng(seed)``; values are rounded to what a digitizer exports. The same
    seed and options give byte-identical files; the medium turbine with default options is the shipped chart. All
    files are built in memory first, so a failure leaves nothing behind.

    Parameters
    ----------
    out_dir : path
    seed : int >= 0
    turbine : str, FamilyTurbine or SyntheticFrancis, optional
        A family name (``"slow"``, ``"medium"``, ``"fast"``; default medium), a family member drawn with its own
        layout (e.g. one of :data:`hillchart.synthetic.francis_variants.OUT_OF_CLASS_FAMILY`) or a turbine drawn
        with the medium chart's layout.
    options : DigitizationOptions, optional

    Returns
    -------
    dict
        File name -> written path.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     files = write_synthetic_chart(d, turbine="fast", options=DigitizationOptions(runaway=False))
    ...     sorted(files)
    ['chart.toml', 'efficiency.csv', 'flow.csv', 'truth.csv']
    """
    texts = synthetic_chart_texts(seed=seed, turbine=turbine, options=options)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = {}
    for name, text in texts.items():
        path = out / name
        path.write_text(text, encoding="utf-8")
        written[name] = path
    return written
