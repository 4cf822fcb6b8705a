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
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from hillchart.characteristics import efficiency_from_unit_torque
from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
from hillchart.errors import InputError, NumericalError

_COMPLEX_STEP = 1e-30


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
        """Q11 and M11 on (possibly complex) inputs; the single implementation of the model equations."""
        p = self.params
        u1 = np.pi * n11 / 60.0
        u2 = p.d2 * u1
        sin_a = opening / p.guide_vane_pitch_mm
        cos_a = np.sqrt(1.0 - sin_a * sin_a)
        inlet_area = np.pi * p.b1  # pi D1 B1 with D1 = 1
        outlet_area = np.pi * p.d2**2 / 4.0
        r = inlet_area * sin_a / outlet_area  # cm2 = r c1
        cot_b1 = 1.0 / np.tan(np.radians(p.beta1_deg))
        cot_b2 = 1.0 / np.tan(np.radians(p.beta2_deg))
        sin_b2 = np.sin(np.radians(p.beta2_deg))
        e = cos_a + sin_a * cot_b1  # incidence: cu1 - u1 + cm1 cot(beta1) = e c1 - u1
        f = r * cot_b2  # cu2 = u2 - f c1
        alpha = (
            p.k_guide_vane
            + p.k_incidence * e * e
            + p.k_runner * r * r / sin_b2**2
            + p.k_draft_tube * r * r
            + p.k_swirl * f * f
        )
        beta = 2 * u1 * cos_a + 2 * u2 * f - 2 * p.k_incidence * e * u1 - 2 * p.k_swirl * u2 * f
        gamma = p.k_incidence * u1 * u1 + (p.k_swirl - 2.0) * u2 * u2 - 2.0 * G_M_S2
        if np.any(np.real(gamma) >= 0):
            bad = np.real(n11 + 0 * gamma)[np.real(gamma) >= 0]
            raise InputError(
                f"synthetic turbine: N11 = {float(np.max(bad)):.1f} r/min is beyond the model's range "
                "(no positive flow: pumping region); allowed N11 below about 1.6 x runaway"
            )
        disc = np.sqrt(beta * beta - 4 * alpha * gamma)
        c1 = -2.0 * gamma / (beta + disc)  # stable root of alpha c1^2 + beta c1 + gamma = 0 (beta + disc > 0)
        q11 = inlet_area * sin_a * c1
        cu1 = cos_a * c1
        cu2 = u2 - f * c1
        m11 = RHO_WATER_KG_M3 * q11 * 0.5 * (cu1 - p.d2 * cu2) - p.k_disc_friction * n11 * n11
        return q11, m11

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
        return float(brentq(lambda n: float(self.m11(n, opening)), lo, hi, xtol=1e-12, rtol=1e-14))


# ---------------------------------------------------------------------------------------------------------------
# The chart an engineer digitizes
# ---------------------------------------------------------------------------------------------------------------

#: Window of the manufacturer's model chart: only the high-efficiency, mid-to-large opening region.
CHART_N11_RANGE = (44.0, 92.0)
CHART_OPENINGS_MM = (10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0)
CHART_EFFICIENCIES = (0.80, 0.84, 0.87, 0.89, 0.91, 0.92, 0.93, 0.935, 0.938)
RUNAWAY_OPENINGS_MM = (6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0)
#: Lowest efficiency still drawn on the chart (the opening lines stop where the contours stop).
CHART_EFFICIENCY_FLOOR = 0.80
#: Digitization noise (one standard deviation): reading a printed chart by eye/mouse.
NOISE_N11_RPM = 0.15
NOISE_Q11_M3_S = 0.0015
#: Rounding of digitized values (what a digitizer's export keeps).
DIGITS = {"n11": 2, "q11": 4, "opening": 2, "efficiency": 3}


def _fmt(value: float, digits: int) -> str:
    return f"{value:.{digits}f}"


def _csv_text(header, rows) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


def _digitized_row(label: float, label_digits: int, n11: float, q11: float, rng: np.random.Generator):
    """A point as a digitizer exports it: exact label, N11 and Q11 with reading noise, rounded."""
    return (
        _fmt(label, label_digits),
        _fmt(n11 + rng.normal(0, NOISE_N11_RPM), DIGITS["n11"]),
        _fmt(q11 + rng.normal(0, NOISE_Q11_M3_S), DIGITS["q11"]),
    )


def _flow_lines(turbine: SyntheticFrancis, rng: np.random.Generator):
    rows = []
    n11_grid = np.linspace(*CHART_N11_RANGE, 321)
    for opening in CHART_OPENINGS_MM:
        eta = turbine.efficiency(n11_grid, opening)
        inside = n11_grid[eta >= CHART_EFFICIENCY_FLOOR]
        if inside.size < 2:
            continue
        for n11 in np.linspace(inside[0], inside[-1], 7):
            rows.append(_digitized_row(opening, DIGITS["opening"], n11, float(turbine.q11(n11, opening)), rng))
    return rows


def _efficiency_contours(turbine: SyntheticFrancis, rng: np.random.Generator, points_per_contour: int = 16):
    import contourpy

    n11 = np.linspace(*CHART_N11_RANGE, 161)
    opening = np.linspace(CHART_OPENINGS_MM[0], CHART_OPENINGS_MM[-1], 121)
    nn, aa = np.meshgrid(n11, opening)
    eta = turbine.efficiency(nn, aa)
    generator = contourpy.contour_generator(nn, aa, eta)
    rows = []
    for level in CHART_EFFICIENCIES:
        for line in generator.lines(level):
            if len(line) < 4:
                continue
            arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line / [30.0, 20.0], axis=0).T))])
            for s in np.linspace(0.0, arc[-1], points_per_contour, endpoint=not np.allclose(line[0], line[-1])):
                n, a = np.interp(s, arc, line[:, 0]), np.interp(s, arc, line[:, 1])
                rows.append(_digitized_row(level, DIGITS["efficiency"], n, float(turbine.q11(n, a)), rng))
    return rows


def _runaway_curve(turbine: SyntheticFrancis, rng: np.random.Generator):
    rows = []
    for opening in RUNAWAY_OPENINGS_MM:
        n11 = turbine.runaway_n11(opening)
        rows.append(_digitized_row(opening, DIGITS["opening"], n11, float(turbine.q11(n11, opening)), rng))
    return rows


def truth_n11_max(turbine: SyntheticFrancis) -> float:
    """Upper N11 of the truth grid: 15 % beyond the highest runaway speed, rounded up to 5 r/min."""
    return float(np.ceil(1.15 * turbine.runaway_n11(turbine.opening_max) / 5.0) * 5.0)


def _truth_grid(turbine: SyntheticFrancis):
    n11 = np.arange(0.0, truth_n11_max(turbine) + 1e-9, 2.5)
    opening = np.arange(0.0, turbine.opening_max + 1e-9, 1.0)
    nn, aa = (g.ravel() for g in np.meshgrid(n11, opening))
    q11, m11, eta = turbine.q11(nn, aa), turbine.m11(nn, aa), turbine.efficiency(nn, aa)
    return [
        tuple(f"{v:.10g}" for v in row) for row in zip(nn, aa, q11, m11, eta)
    ]


CHART_TOML = """\
name = "hillsim synthetic Francis (HLA339-like, 1-D Euler model)"
opening_unit = "mm"
opening_max = {opening_max}
q11_unit = "m3/s"
efficiency_unit = "fraction"
runner_diameter_m = 0.35
"""


def write_synthetic_chart(out_dir, *, seed: int = 0, turbine: SyntheticFrancis | None = None) -> dict[str, Path]:
    """Write the digitized chart of the synthetic turbine (and its exact truth grid) into ``out_dir``.

    Files: ``chart.toml``, ``flow.csv`` (opening,n11,q11), ``efficiency.csv`` (efficiency,n11,q11),
    ``runaway.csv`` (opening,n11,q11) and ``truth.csv`` (n11,opening,q11,m11,efficiency; exact, for evaluation).
    Digitization noise: Gaussian, sigma 0.15 r/min on N11 and 0.0015 m^3/s on Q11, drawn from
    ``numpy.random.default_rng(seed)``; values are rounded to what a digitizer exports. The same seed gives
    byte-identical files. All files are built in memory first, so a failure leaves nothing behind.

    Returns
    -------
    dict
        File name -> written path.
    """
    turbine = turbine or SyntheticFrancis()
    rng = np.random.default_rng(seed)
    texts = {
        "chart.toml": CHART_TOML.format(opening_max=repr(float(turbine.opening_max))),
        "flow.csv": _csv_text(("opening", "n11", "q11"), _flow_lines(turbine, rng)),
        "efficiency.csv": _csv_text(("efficiency", "n11", "q11"), _efficiency_contours(turbine, rng)),
        "runaway.csv": _csv_text(("opening", "n11", "q11"), _runaway_curve(turbine, rng)),
        "truth.csv": _csv_text(("n11", "opening", "q11", "m11", "efficiency"), _truth_grid(turbine)),
    }
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = {}
    for name, text in texts.items():
        path = out / name
        path.write_text(text, encoding="utf-8")
        written[name] = path
    return written
