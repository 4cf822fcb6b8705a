"""A physically based synthetic reversible pump-turbine over all four quadrants, with an S-shaped zone, and the
complete-characteristics table an engineer would digitize from it.

The machine is a low-specific-speed radial runner (n_q about 34 in turbine mode), written, as the synthetic Francis
turbine, in unit quantities: runner high-pressure-side diameter D1 = 1 m. Unlike the Francis model, which solves for
the flow at a given head, it gives the head and the torque at a given speed, flow and guide-vane opening, so it is
defined everywhere: turbine, turbine brake, reverse pump, pump and pump brake.

Sign convention (turbine-positive): speed n > 0 in turbine rotation, flow Q > 0 from the high-pressure to the
low-pressure side (turbine direction), head H = high-pressure minus low-pressure side, torque M > 0 when the water
drives the runner in turbine rotation. In pump mode n < 0, Q < 0, H > 0 and M > 0 (the motor drives the runner
against the water's torque); water power rho g Q H and shaft power M omega are then both negative.

Equations
---------
Velocities at D1 (radius r1 = 1/2, height B1 = b1 D1) and D2 = d2 D1 (radius r2, area A2 = pi D2^2/4), tangential
components positive in turbine rotation, meridional ones positive in turbine flow::

    u1 = pi D1 n / 60,  u2 = d2 u1,  cm1 = Q / (pi D1 B1),  cm2 = Q / A2
    sin(alpha) = a / t_gv                       guide-vane angle law: opening a (mm) over the vane pitch t_gv (mm)

Turbine through-flow (enters the runner at D1 from the guide vanes, leaves at D2 along the blades)::

    cu1 = cm1 cot(alpha),  cu2 = u2 - cm2 cot(beta2)
    g H_T = (u1 cu1 - u2 cu2)                                     Euler head
            + k_gv c1^2/2,  c1 = cm1 / sin(alpha)                  guide-vane friction
            + k_sh (cu1 - u1 + cm1 cot(beta1))^2 / 2               incidence (shock) at the runner inlet
            + k_r w2^2/2 + k_dt cm2^2/2 + k_sw cu2^2/2             runner friction, draft tube, exit swirl
    M_T = rho Q (r1 cu1 - r2 cu2)                                  Euler torque

Pump through-flow (enters at D2 from the draft tube without swirl, leaves at D1 along the blades with slip sigma,
then through the guide vanes, which destroy the swirl that does not match them)::

    cu2 = 0,  cu1 = sigma u1 - cm1 cot(beta1)
    g H_P = u1 cu1 - [k_in (u2 - cm2 cot(beta2))^2 + k_gd (cu1 - cm1 cot(alpha))^2 + k_gv c1^2
                      + k_rp w1^2 + k_dp cm2^2] / 2                Euler head less the losses (pump inlet incidence,
    M_P = rho Q r1 cu1                                             diffuser incidence, vane and runner friction)

The blade line is the same in both directions (relative velocity w_u = -cm cot(beta), signed), so running backward
(reverse pump: n > 0, Q < 0; pump brake: n < 0, Q > 0) follows from the same formulas. Which formula holds depends
on which side the water enters; near zero flow the two are blended over the runner-inlet flow angle
``psi = cm1 / sqrt(cm1^2 + u1^2)``, and the runner's periphery pumps the recirculating water (inlet recirculation,
the mechanism of the S-shaped zone: a head that rises as the through-flow falls)::

    w = (1 + tanh(psi / delta)) / 2,            phi = exp(-(psi / psi_rec)^2)
    H = w H_T + (1 - w) H_P + kappa u1^2 phi / (2 g)
    M = w M_T + (1 - w) M_P - K_df n |n| - K_rec n |n| phi         disc friction; recirculation brakes the runner

Every term is a quadratic form of (n, Q) times a function of the direction psi, so H and M are homogeneous of degree
2 in (n, Q): the affinity laws hold exactly, the unit quantities N11 = n D1 / sqrt(H), Q11 = Q / (D1^2 sqrt(H)),
M11 = M / (D1^3 H) depend on the direction of (n, Q) alone, and so do the Suter curves.

The loss coefficients and angles are chosen, not fitted: at the defaults the turbine-mode best efficiency is 0.930 at
N11 = 73.7 r/min, Q11 = 0.194 m^3/s, opening 17.7 mm (n_q = N11 sqrt(Q11) = 32), the pump-mode best hydraulic
efficiency 0.931 at N11 = -86.7 r/min, Q11 = -0.209 m^3/s, and
every opening from 4 mm up has an S-shaped zone (Q11 falls and then rises again as N11 falls past its largest value
on the turbine side, before the flow reverses).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
from hillchart.errors import InputError

#: Openings of the digitized complete-characteristics table (mm): the opening lines a model test reports.
TABLE_OPENINGS_MM = (4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 24.0, 26.0, 28.0)
#: Window of the table: |N11| and |Q11| at most these (r/min, m^3/s); the opening lines that leave it are cut there.
TABLE_N11_LIMIT_RPM = 160.0
TABLE_Q11_LIMIT_M3_S = 0.6
#: Points per opening line of the table (spread evenly in the direction of (N11, Q11), then cut to the window).
TABLE_POINTS_PER_LINE = 72


@dataclass(frozen=True)
class PumpTurbineParameters:
    """Geometry and loss coefficients of the synthetic pump-turbine (lengths relative to D1, angles in degrees).

    Attributes
    ----------
    d2 : D2/D1, low-pressure-side (turbine outlet, pump eye) diameter ratio.
    b1 : B1/D1, runner height at D1.
    guide_vane_pitch_mm : t_gv, opening at which the inlet flow would be radial (sin alpha = 1), mm.
    opening_max_mm : full-stroke guide-vane opening, mm.
    beta1_deg, beta2_deg : blade angles at D1 and D2 from the tangential direction, degrees.
    slip_factor : sigma, pump-mode slip at D1 (cu1 = sigma u1 - cm1 cot beta1).
    k_guide_vane, k_incidence, k_runner, k_draft_tube, k_swirl : turbine-flow loss coefficients (fractions of the
        dynamic heads named in the module docstring).
    k_pump_inlet, k_diffuser, k_pump_runner, k_pump_draft_tube : pump-flow loss coefficients.
    k_disc_friction : K_df, N*m/(r/min)^2 (unit runner).
    k_recirculation_torque : K_rec, N*m/(r/min)^2, the runner-inlet recirculation's braking torque at zero flow.
    recirculation_head : kappa, the recirculation's head at zero flow in units of u1^2 / (2 g).
    recirculation_flow_angle : psi_rec, width of the recirculation in the runner-inlet flow angle psi.
    direction_blend : delta, width of the blend between the turbine and the pump through-flow in psi.
    """

    d2: float = 0.55
    b1: float = 0.08
    guide_vane_pitch_mm: float = 60.0
    opening_max_mm: float = 28.0
    beta1_deg: float = 28.0
    beta2_deg: float = 23.0
    slip_factor: float = 0.85
    k_guide_vane: float = 0.08
    k_incidence: float = 1.0
    k_runner: float = 0.10
    k_draft_tube: float = 0.25
    k_swirl: float = 1.0
    k_pump_inlet: float = 0.9
    k_diffuser: float = 0.6
    k_pump_runner: float = 0.12
    k_pump_draft_tube: float = 0.3
    k_disc_friction: float = 4e-4
    k_recirculation_torque: float = 3e-3
    recirculation_head: float = 0.5
    recirculation_flow_angle: float = 0.06
    direction_blend: float = 0.03

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value <= 0:
                raise InputError(f"PumpTurbineParameters.{f.name} must be a finite number > 0, got {value!r}")
        for name in ("d2", "b1", "slip_factor"):
            if getattr(self, name) >= 1:
                raise InputError(f"PumpTurbineParameters.{name} must be in (0, 1), got {getattr(self, name)!r}")
        if self.opening_max_mm >= self.guide_vane_pitch_mm:
            raise InputError(f"PumpTurbineParameters.opening_max_mm must be < guide_vane_pitch_mm = "
                             f"{self.guide_vane_pitch_mm!r}, got {self.opening_max_mm!r}")
        for name in ("beta1_deg", "beta2_deg"):
            if getattr(self, name) >= 90:
                raise InputError(f"PumpTurbineParameters.{name} must be in (0, 90) deg, got {getattr(self, name)!r}")


@dataclass(frozen=True)
class SyntheticPumpTurbine:
    """Exact four-quadrant characteristics of the synthetic pump-turbine (module docstring), unit runner D1 = 1 m.

    Examples
    --------
    >>> pt = SyntheticPumpTurbine()
    >>> h, m = pt.head_torque(73.0, 0.2, 20.0)            # turbine mode: n r/min, Q m^3/s, opening mm
    >>> bool(h > 0 and m > 0)
    True
    >>> h, m = pt.head_torque(-85.0, -0.19, 20.0)         # pump mode: head up, the motor drives (M > 0)
    >>> bool(h > 0 and m > 0)
    True
    """

    params: PumpTurbineParameters = field(default_factory=PumpTurbineParameters)

    @property
    def opening_max(self) -> float:
        return self.params.opening_max_mm

    def _opening(self, opening_mm) -> np.ndarray:
        a = np.asarray(opening_mm, dtype=float)
        bad = ~np.isfinite(a) | (a <= 0) | (a > self.params.opening_max_mm)
        if np.any(bad):
            raise InputError(f"synthetic pump-turbine: opening_mm must be in (0, {self.params.opening_max_mm}] "
                             f"(the closed vane passes no flow: its head is undefined), got "
                             f"{float(a[bad].flat[0])!r}")
        return a

    def head_torque(self, speed_rpm, flow_m3_s, opening_mm) -> tuple[np.ndarray, np.ndarray]:
        """Head H (m) and torque M (N*m) of the unit runner at speed n (r/min), flow Q (m^3/s) and opening a (mm),
        arrays broadcast together; turbine-positive signs (module docstring)."""
        p = self.params
        a = self._opening(opening_mm)
        n, q, a = np.broadcast_arrays(np.asarray(speed_rpm, dtype=float), np.asarray(flow_m3_s, dtype=float), a)
        if not (np.all(np.isfinite(n)) and np.all(np.isfinite(q))):
            raise InputError("synthetic pump-turbine: speed_rpm and flow_m3_s must be finite")
        u1 = np.pi * n / 60.0
        u2 = p.d2 * u1
        sin_a = a / p.guide_vane_pitch_mm  # guide-vane angle law
        cot_a = np.sqrt(1.0 - sin_a**2) / sin_a
        cm1 = q / (np.pi * p.b1)
        cm2 = q / (np.pi * p.d2**2 / 4.0)
        cot_b1 = 1.0 / math.tan(math.radians(p.beta1_deg))
        cot_b2 = 1.0 / math.tan(math.radians(p.beta2_deg))
        c1_sq = (cm1 / sin_a) ** 2
        # turbine through-flow
        cu1 = cm1 * cot_a
        cu2 = u2 - cm2 * cot_b2
        loss_t = (p.k_guide_vane * c1_sq + p.k_incidence * (cu1 - u1 + cm1 * cot_b1) ** 2
                  + p.k_runner * cm2**2 * (1.0 + cot_b2**2) + p.k_draft_tube * cm2**2 + p.k_swirl * cu2**2) / 2.0
        gh_t = u1 * cu1 - u2 * cu2 + loss_t
        m_t = RHO_WATER_KG_M3 * q * (0.5 * cu1 - 0.5 * p.d2 * cu2)
        # pump through-flow
        cu1_p = p.slip_factor * u1 - cm1 * cot_b1
        loss_p = (p.k_pump_inlet * (u2 - cm2 * cot_b2) ** 2 + p.k_diffuser * (cu1_p - cm1 * cot_a) ** 2
                  + p.k_guide_vane * c1_sq + p.k_pump_runner * cm1**2 * (1.0 + cot_b1**2)
                  + p.k_pump_draft_tube * cm2**2) / 2.0
        gh_p = u1 * cu1_p - loss_p
        m_p = RHO_WATER_KG_M3 * q * 0.5 * cu1_p
        # which side the water enters, and the runner-inlet recirculation near zero through-flow
        speed_sq = cm1**2 + u1**2
        psi = np.divide(cm1, np.sqrt(speed_sq), out=np.zeros_like(cm1), where=speed_sq > 0)
        w = 0.5 * (1.0 + np.tanh(psi / p.direction_blend))
        phi = np.exp(-((psi / p.recirculation_flow_angle) ** 2))
        head = (w * gh_t + (1.0 - w) * gh_p + p.recirculation_head * u1**2 * phi / 2.0) / G_M_S2
        torque = (w * m_t + (1.0 - w) * m_p - p.k_disc_friction * n * np.abs(n)
                  - p.k_recirculation_torque * n * np.abs(n) * phi)
        return head, torque

    def unit_curve(self, opening_mm, direction_rad, *, n11_scale: float = 75.0,
                   q11_scale: float = 0.22) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """N11 (r/min), Q11 (m^3/s), M11 (N*m) at unit head along one opening line, at the directions
        ``theta`` of (n, Q) = (n11_scale cos theta, q11_scale sin theta); NaN where the head in that direction is
        not positive (no point of the line at H = 1 m: the opening line runs off to infinity there)."""
        theta = np.asarray(direction_rad, dtype=float)
        n = n11_scale * np.cos(theta)
        q = q11_scale * np.sin(theta)
        head, torque = self.head_torque(n, q, opening_mm)
        positive = head > 0
        scale = np.where(positive, 1.0 / np.sqrt(np.where(positive, head, 1.0)), np.nan)
        return n * scale, q * scale, torque * scale**2

    def turbine_efficiency(self, opening_mm, direction_rad) -> np.ndarray:
        """Hydraulic efficiency M omega / (rho g Q H) in turbine mode (N11 > 0, Q11 > 0) along an opening line; NaN
        elsewhere."""
        n11, q11, m11 = self.unit_curve(opening_mm, direction_rad)
        turbine = (n11 > 0) & (q11 > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            eta = m11 * np.pi * n11 / 30.0 / (RHO_WATER_KG_M3 * G_M_S2 * q11)
        return np.where(turbine, eta, np.nan)

    def pump_efficiency(self, opening_mm, direction_rad) -> np.ndarray:
        """Hydraulic efficiency rho g Q H / (M omega) in pump mode (N11 < 0, Q11 < 0, M11 > 0); NaN elsewhere."""
        n11, q11, m11 = self.unit_curve(opening_mm, direction_rad)
        pump = (n11 < 0) & (q11 < 0) & (m11 > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            eta = RHO_WATER_KG_M3 * G_M_S2 * q11 / (m11 * np.pi * n11 / 30.0)
        return np.where(pump, eta, np.nan)

    def best_efficiency_point(self, mode: str = "turbine") -> dict:
        """The best hydraulic efficiency over the openings and its point: ``{"efficiency", "opening_mm", "n11",
        "q11", "m11"}`` (a grid of 0.1 mm and 2e-4 rad refined by a bounded search on each)."""
        from scipy.optimize import minimize_scalar

        if mode not in ("turbine", "pump"):
            raise InputError(f"best_efficiency_point: mode must be 'turbine' or 'pump', got {mode!r}")
        eff = self.turbine_efficiency if mode == "turbine" else self.pump_efficiency
        theta = np.linspace(0.0, np.pi / 2, 2001) if mode == "turbine" else np.linspace(-np.pi, -np.pi / 2, 2001)

        def best_on_line(a):
            values = np.nan_to_num(eff(a, theta), nan=-1.0)
            i = int(np.argmax(values))
            lo, hi = theta[max(i - 1, 0)], theta[min(i + 1, theta.size - 1)]
            res = minimize_scalar(lambda t: -float(np.nan_to_num(eff(a, t), nan=-1.0)), bounds=(lo, hi),
                                  method="bounded", options={"xatol": 1e-10})
            return -float(res.fun), float(res.x)

        openings = np.arange(2.0, self.params.opening_max_mm + 1e-9, 1.0)
        scores = [best_on_line(a)[0] for a in openings]
        k = int(np.argmax(scores))
        lo, hi = openings[max(k - 1, 0)], openings[min(k + 1, openings.size - 1)]
        res = minimize_scalar(lambda a: -best_on_line(a)[0], bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-8})
        a = float(res.x)
        efficiency, t = best_on_line(a)
        n11, q11, m11 = (float(v) for v in self.unit_curve(a, t))
        return {"efficiency": efficiency, "opening_mm": a, "n11": n11, "q11": q11, "m11": m11}

    def complete_characteristics(self, openings_mm=TABLE_OPENINGS_MM, *, points_per_line: int = TABLE_POINTS_PER_LINE,
                                 n11_limit: float = TABLE_N11_LIMIT_RPM,
                                 q11_limit: float = TABLE_Q11_LIMIT_M3_S) -> dict:
        """The complete-characteristics table as digitized from a model test: on each opening line, points at
        ``points_per_line`` directions of (N11, Q11) evenly spread over the circle, kept where the line exists at
        unit head and lies inside the window |N11| <= n11_limit, |Q11| <= q11_limit. Returns arrays ``opening``
        (mm), ``n11`` (r/min), ``q11`` (m^3/s), ``m11`` (N*m), one row per point, ordered by opening and direction
        (the pump quadrant first)."""
        rows = {"opening": [], "n11": [], "q11": [], "m11": []}
        # directions offset by half a step from the axes, so no point lies exactly at zero speed or zero flow
        theta = -np.pi + (np.arange(points_per_line) + 0.5) * 2.0 * np.pi / points_per_line
        for a in openings_mm:
            n11, q11, m11 = self.unit_curve(a, theta)
            keep = np.isfinite(n11) & (np.abs(n11) <= n11_limit) & (np.abs(q11) <= q11_limit)
            rows["opening"].append(np.full(int(keep.sum()), float(a)))
            for key, value in (("n11", n11), ("q11", q11), ("m11", m11)):
                rows[key].append(value[keep])
        return {key: np.concatenate(value) for key, value in rows.items()}


def write_complete_characteristics(out_dir, turbine: SyntheticPumpTurbine | None = None) -> Path:
    """Write the synthetic pump-turbine's complete-characteristics table folder (``table.csv`` with columns
    ``opening,n11,q11,m11`` and ``table.toml`` with its units and rated point, the turbine-mode best-efficiency
    point) to ``out_dir``; returns the folder. Deterministic: no random numbers."""
    turbine = turbine or SyntheticPumpTurbine()
    table = turbine.complete_characteristics()
    bep = turbine.best_efficiency_point("turbine")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["opening", "n11", "q11", "m11"])
    for row in zip(*(table[k] for k in ("opening", "n11", "q11", "m11"))):
        writer.writerow([f"{row[0]:g}", f"{row[1]:.6f}", f"{row[2]:.7f}", f"{row[3]:.5f}"])
    (out / "table.csv").write_text(buffer.getvalue(), encoding="utf-8")
    toml = (f'name = "synthetic pump-turbine (n_q {bep["n11"] * math.sqrt(bep["q11"]):.0f})"\n'
            f'opening_unit = "mm"\n'
            f"opening_max = {turbine.opening_max:g}\n"
            f'q11_unit = "m3/s"\n'
            f"rated_n11_rpm = {bep['n11']:.4f}\n"
            f"rated_q11 = {bep['q11']:.6f}\n"
            f"rated_m11_nm = {bep['m11']:.4f}\n")
    (out / "table.toml").write_text(toml, encoding="utf-8")
    return out
