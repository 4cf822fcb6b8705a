"""A physically based synthetic double-regulated bulb (tubular) turbine and the model test an engineer would run.

Paper 003 (Wu et al., tubular turbine FCCM) controls a bulb turbine by its runner-blade angle a0 (-18..16 deg) and
its guide-vane angle beta (40..78 deg). This module gives such a turbine exact, smooth characteristics from a
one-dimensional (mean streamline) model of an axial runner, so that nets and interpolation can be judged against
the truth.

Model (mean radius r_m of the blade channel, all velocities in m/s)
-------------------------------------------------------------------
Geometry: tip diameter D, hub ratio nu = d_hub / D, annulus area A = pi/4 D^2 (1 - nu^2),
r_m = D/2 sqrt((1 + nu^2)/2) (the radius that halves the annulus area), blade speed u = 2 pi r_m n / 60.

* Axial velocity through the runner (continuity): cm = Q / A (the same at runner inlet and outlet).
* Guide vanes: the vane angle beta is counted from the closed position; the flow leaves the (conical) guide vanes
  at ``alpha = beta - beta_closed`` from the circumferential direction (beta_closed: vane angle at which the
  vanes touch and the flow angle would be zero); the swirl is carried to the runner as a free vortex, so at r_m
  ``cu1 = s cm cot(alpha)`` with the swirl factor s (area and radius ratio of guide-vane exit to runner, a
  geometry constant).
* Adjustable blades: turning the blades by phi (the blade angle a0) turns the blade inlet and outlet angles
  (from the circumferential direction) equally: ``beta1b = beta1_0 + phi``, ``beta2 = beta2_0 + phi``. The flow
  leaves along the blade: ``cu2 = u - cm cot(beta2)``.
* Energy balance on the head (Euler turbine equation plus losses)::

      g H = u (cu1 - cu2)                                   Euler head: the energy given to the runner
            + k_gv (cm^2 + cu1^2) / 2                       guide-vane and stay-cone friction
            + k_sh (cu1 - u + cm cot(beta1b))^2 / 2          inlet incidence (shock): swirl mismatch with the blade
            + k_r cm^2 / (2 sin^2(beta2))                    runner friction on the relative velocity w2
            + k_dt cm^2 / 2                                  draft tube: unrecovered axial kinetic energy
            + k_sw cu2^2 / 2                                 exit swirl, lost in the draft tube

  is a quadratic ``a cm^2 + b cm + c = 0`` in cm at given u and H; with ``k_sh + k_sw < 2`` its constant term is
  negative and the root with cm > 0 is unique (computed in the cancellation-free form).
* Shaft torque, Euler's moment of momentum minus disc and bearing friction (``rho n^2 D^5`` scaling, i.e.
  ``K_df N11^2`` in unit quantities): ``M = rho Q r_m (cu1 - cu2) - K_df n^2 D^5``; hydraulic efficiency
  ``eta = M omega / (rho g Q H)``; power ``P = M omega``.
* Unit quantities (paper 003 eqs. (1)-(2)): ``n11 = n D / sqrt(H)``, ``Q11 = Q / (D^2 sqrt(H))``; the unit
  characteristic is the same model with D = 1 m, H = 1 m and u = 2 pi r_m n11 / 60 (:meth:`SyntheticBulb.q11`).

Operation: two closures fix the operating point of a setting (a0, beta) at constant speed n (a third, the
propeller curves of :meth:`SyntheticBulb.propeller_points`, measures each setting at several unit speeds).

* ``"water-system"`` (:meth:`SyntheticBulb.operate`, the default of the synthetic test table, as a model
  test on a real water system runs): the head is set by the plant's water system,
  ``H = H_static - K_sys Q^2`` (headwater minus a tailwater that rises with discharge, plus intake and conduit
  losses, lumped as one quadratic). Because u is fixed at constant speed, the system curve only adds
  ``g K_sys A^2`` to the quadratic's leading coefficient: closed form, no iteration. But then n11 and Q11 are both
  functions of Q alone (``n11 = n D / sqrt(H(Q))``, ``Q11 = Q / (D^2 sqrt(H(Q)))``): every setting lands on ONE
  curve of the (Q11, n11) plane, and paper 003's efficiency map over (Q11, n11) (its Fig. 4) degenerates to a line.
  Any passive water system H(Q) does this; it is what a plant on a fixed water system really does.
* ``"best-efficiency"`` (:meth:`SyntheticBulb.best_efficiency_points`): a model-test rig runs at constant speed
  and, for each blade / guide-vane setting, sets the head that gives the setting's best efficiency,
  ``d eta / d n11 = 0`` at fixed (a0, beta): the optimum of each propeller curve, i.e. the point where this
  combination of blade and guide-vane angle is the one to use. This is how the a0 and beta isolines of a
  conventional double-regulated FCCM (paper 003 Fig. 1) pair a setting with one (Q11, n11), and it spreads the
  settings over a 2-D region of the (Q11, n11) plane, with H = (n D / n11)^2.

There is exactly one implementation of the velocity solution (:func:`_axial_velocity`) and one of the torque
(:func:`_torque_nm`), used by both closures and by the unit characteristic.

Default parameters resemble the paper's machine (a 3.8 m runner at 136.36 r/min, 44 poles at 50 Hz). Water-system
closure over the paper's ranges (H_static 14 m): heads 9-14 m, powers 1.6-9.7 MW, n11 139-172 r/min, Q11 0.26-3.2
m^3/s, efficiency 0.55-0.92 (best at a0 = -10.5 deg, beta = 44.5 deg; above 0.85 over a wide diagonal band; the
best blade angle rises with the guide-vane angle). Best-efficiency closure: n11 73-126 r/min, Q11 0.23-2.5 m^3/s,
efficiency 0.80-0.947, heads 17-51 m at this speed (a model-test head range; H scales with n^2).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field, fields
from pathlib import Path

import numba
import numpy as np

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3, RPM_TO_RAD_S
from hillchart.errors import InputError, NumericalError

#: The paper's control ranges (section 3): runner-blade angle a0 and guide-vane angle beta, degrees.
BLADE_RANGE_DEG = (-18.0, 16.0)
GUIDE_VANE_RANGE_DEG = (40.0, 78.0)
#: Operating closures (module docstring).
CLOSURES = ("water-system", "best-efficiency", "propeller-curves")
#: Unit speeds (r/min) of each setting in the ``"propeller-curves"`` closure: a model test's propeller curves, the
#: head stepped at each (blade, guide-vane) setting, over the range around the example plant's N11 (150) up to the
#: overspeed of a rejection's first seconds.
PROPELLER_N11_RPM = (120.0, 140.0, 160.0, 180.0, 200.0)
#: Columns of the synthetic test table (units in the names, efficiency as a fraction).
TABLE_COLUMNS = ("blade_angle_deg", "guide_vane_deg", "efficiency", "head_m", "power_kw", "flow_m3_s")
#: Columns of the dense truth grid (the table's plus exact unit quantities).
TRUTH_COLUMNS = TABLE_COLUMNS + ("n11_rpm", "q11_m3_s")


@dataclass(frozen=True)
class BulbParameters:
    """Geometry, losses and water system of the synthetic bulb turbine.

    Attributes
    ----------
    runner_diameter_m : D, runner tip diameter, m.
    hub_ratio : nu = d_hub / D, in (0, 1).
    swirl_factor : s in ``cu1 = s cm cot(alpha)``, > 0.
    guide_vane_closed_deg : beta_closed, vane angle of zero flow angle (``alpha = beta - beta_closed``), degrees.
    beta1_deg, beta2_deg : blade inlet / outlet angles at a0 = 0, degrees from the circumferential direction.
    k_guide_vane, k_incidence, k_runner, k_draft_tube, k_swirl : loss coefficients (fractions of dynamic heads);
        ``k_incidence + k_swirl < 2``.
    k_disc_friction : K_df, N*m/(r/min)^2 in unit quantities (D = 1 m, H = 1 m).
    speed_rpm : constant speed n of the unit, r/min.
    static_head_m : H_static, m.
    system_loss_s2_m5 : K_sys in ``H = H_static - K_sys Q^2``, s^2/m^5, >= 0.
    """

    runner_diameter_m: float = 3.8
    hub_ratio: float = 0.4
    swirl_factor: float = 0.3
    guide_vane_closed_deg: float = 35.0
    beta1_deg: float = 28.3
    beta2_deg: float = 22.0
    k_guide_vane: float = 0.03
    k_incidence: float = 0.3
    k_runner: float = 0.03
    k_draft_tube: float = 0.12
    k_swirl: float = 0.5
    k_disc_friction: float = 4.0e-4
    speed_rpm: float = 136.36
    static_head_m: float = 14.0
    system_loss_s2_m5: float = 2.5e-4

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise InputError(f"BulbParameters.{f.name} must be a finite number, got {value!r}")
            if f.name == "system_loss_s2_m5":
                if value < 0:
                    raise InputError(f"BulbParameters.system_loss_s2_m5 must be >= 0, got {value!r}")
            elif value <= 0:
                raise InputError(f"BulbParameters.{f.name} must be > 0, got {value!r}")
        if self.hub_ratio >= 1:
            raise InputError(f"BulbParameters.hub_ratio must be in (0, 1), got {self.hub_ratio!r}")
        if self.k_incidence + self.k_swirl >= 2:
            raise InputError(f"BulbParameters.k_incidence + k_swirl must be < 2 (unique flow solution), got "
                             f"{self.k_incidence + self.k_swirl!r}")
        for name in ("beta1_deg", "beta2_deg"):
            lo, hi = getattr(self, name) + BLADE_RANGE_DEG[0], getattr(self, name) + BLADE_RANGE_DEG[1]
            if not (0 < lo and hi < 90):
                raise InputError(f"BulbParameters.{name} must keep the blade angle in (0, 90) deg over a0 in "
                                 f"{list(BLADE_RANGE_DEG)}, got {getattr(self, name)!r}")

    # geometry in units of D (D = 1 m for the unit characteristic)
    @property
    def area_ratio(self) -> float:
        """A / D^2 = pi/4 (1 - nu^2)."""
        return math.pi / 4.0 * (1.0 - self.hub_ratio ** 2)

    @property
    def mean_radius_ratio(self) -> float:
        """r_m / D = sqrt((1 + nu^2)/2) / 2."""
        return 0.5 * math.sqrt(0.5 * (1.0 + self.hub_ratio ** 2))


def _axial_velocity(p: BulbParameters, u, g_head_static, system_term, guide_vane_deg, blade_deg):
    """Axial velocity cm and swirls (cu1, cu2), m/s, from the energy balance (module docstring).

    ``g_head_static`` is g H (unit chart: g, plant: g H_static); ``system_term`` is ``g K_sys A^2`` (0 for the unit
    chart), which moves the system curve's head drop ``g K_sys Q^2 = system_term cm^2`` into the quadratic.
    """
    cot_a = 1.0 / np.tan(np.radians(guide_vane_deg - p.guide_vane_closed_deg))  # alpha = beta - beta_closed
    cot_b1 = 1.0 / np.tan(np.radians(p.beta1_deg + blade_deg))
    beta2 = np.radians(p.beta2_deg + blade_deg)
    cot_b2 = 1.0 / np.tan(beta2)
    swirl = p.swirl_factor * cot_a  # cu1 = swirl cm
    e_inc = swirl + cot_b1  # incidence: cu1 - u + cm cot(beta1b) = e_inc cm - u
    a = 0.5 * (p.k_guide_vane * (1.0 + swirl ** 2) + p.k_incidence * e_inc ** 2
               + p.k_runner / np.sin(beta2) ** 2 + p.k_draft_tube + p.k_swirl * cot_b2 ** 2) + system_term
    b = u * (swirl + cot_b2) - p.k_incidence * e_inc * u - p.k_swirl * u * cot_b2
    c = u * u * (0.5 * (p.k_incidence + p.k_swirl) - 1.0) - g_head_static  # < 0: one positive root
    disc = np.sqrt(b * b - 4.0 * a * c)
    # cancellation-free root with cm > 0 for either sign of b
    cm = np.where(b >= 0, -2.0 * c / np.where(b >= 0, b + disc, 1.0), (disc - b) / (2.0 * a))
    return cm, swirl * cm, u - cm * cot_b2


def _torque_nm(p: BulbParameters, flow, radius_m, cu1, cu2, n_rpm, diameter_m):
    """Shaft torque M = rho Q r_m (cu1 - cu2) - K_df n^2 D^5, N*m (Euler's moment of momentum, disc friction)."""
    return RHO_WATER_KG_M3 * flow * radius_m * (cu1 - cu2) - p.k_disc_friction * n_rpm ** 2 * diameter_m ** 5


#: Layout of :meth:`SyntheticBulb.point_parameters` (the scalars :func:`unit_point` reads).
POINT_PARAMETERS = ("area_ratio", "mean_radius_ratio", "swirl_factor", "guide_vane_closed_deg", "beta1_deg",
                    "beta2_deg", "k_guide_vane", "k_incidence", "k_runner", "k_draft_tube", "k_swirl",
                    "k_disc_friction")
#: Smallest flow angle alpha = beta - beta_closed (deg) :func:`unit_point` evaluates: at the closed vane the swirl
#: cot(alpha) is infinite; Q11 tends to 0 like tan(alpha), so 1e-9 deg gives Q11 ~ 1e-11 of full flow.
MIN_FLOW_ANGLE_DEG = 1e-9


@numba.njit(cache=True)
def unit_point(params, n11, guide_vane_deg, blade_deg):
    """The unit characteristic at one point for the compiled time loop: ``(q11, dq11/dn11, m11, dm11/dn11)``
    (m^3/s, N*m, per r/min), ``params`` = :meth:`SyntheticBulb.point_parameters`.

    The same energy balance as :func:`_axial_velocity` and the same torque as :func:`_torque_nm` (D = 1 m, H = 1 m),
    written on scalars, with the n11-derivative of the root of ``a cm^2 + b cm + c = 0``:
    ``dcm/du = -(cm db/du + dc/du) / (2 a cm + b)`` (a does not depend on u). No range check (the loop must not
    raise): a flow angle below :data:`MIN_FLOW_ANGLE_DEG` is taken at it (the closed vane passes no flow).
    ``tests/hillchart/synthetic/test_bulb_kernel.py`` checks it against :meth:`SyntheticBulb.q11`/``m11`` and the
    derivatives against central differences.
    """
    area, r_m, s_f, closed, beta1, beta2_0 = params[0], params[1], params[2], params[3], params[4], params[5]
    k_gv, k_inc, k_r, k_dt, k_sw, k_df = params[6], params[7], params[8], params[9], params[10], params[11]
    alpha = max(guide_vane_deg - closed, MIN_FLOW_ANGLE_DEG)
    cot_a = 1.0 / math.tan(math.radians(alpha))
    cot_b1 = 1.0 / math.tan(math.radians(beta1 + blade_deg))
    beta2 = math.radians(beta2_0 + blade_deg)
    cot_b2 = 1.0 / math.tan(beta2)
    sin_b2 = math.sin(beta2)
    du_dn = 2.0 * math.pi * r_m / 60.0
    u = du_dn * n11
    swirl = s_f * cot_a
    e_inc = swirl + cot_b1
    a = 0.5 * (k_gv * (1.0 + swirl * swirl) + k_inc * e_inc * e_inc + k_r / (sin_b2 * sin_b2) + k_dt
               + k_sw * cot_b2 * cot_b2)
    db_du = (swirl + cot_b2) - k_inc * e_inc - k_sw * cot_b2
    b = u * db_du
    c = u * u * (0.5 * (k_inc + k_sw) - 1.0) - G_M_S2
    disc = math.sqrt(b * b - 4.0 * a * c)
    if b >= 0.0:
        cm = -2.0 * c / (b + disc)
    else:
        cm = (disc - b) / (2.0 * a)
    dc_du = 2.0 * u * (0.5 * (k_inc + k_sw) - 1.0)
    dcm_du = -(cm * db_du + dc_du) / (2.0 * a * cm + b)
    q11 = area * cm
    dq_dn = area * dcm_du * du_dn
    turn = swirl * cm - (u - cm * cot_b2)  # cu1 - cu2
    dturn_dn = (swirl * dcm_du - 1.0 + dcm_du * cot_b2) * du_dn
    m11 = RHO_WATER_KG_M3 * q11 * r_m * turn - k_df * n11 * n11
    dm_dn = RHO_WATER_KG_M3 * r_m * (dq_dn * turn + q11 * dturn_dn) - 2.0 * k_df * n11
    return q11, dq_dn, m11, dm_dn


@dataclass(frozen=True)
class OperatingPoints:
    """Operating points of the unit at constant speed on its water system (arrays of one shape).

    Attributes
    ----------
    blade_angle_deg, guide_vane_deg : controls, degrees.
    head_m, flow_m3_s, power_kw, efficiency : net head, discharge, shaft power (kW), hydraulic efficiency (fraction).
    n11_rpm, q11_m3_s : unit speed and unit flow (paper 003 eqs. (1)-(2)).
    """

    blade_angle_deg: np.ndarray
    guide_vane_deg: np.ndarray
    head_m: np.ndarray
    flow_m3_s: np.ndarray
    power_kw: np.ndarray
    efficiency: np.ndarray
    n11_rpm: np.ndarray
    q11_m3_s: np.ndarray

    def column(self, name: str) -> np.ndarray:
        return getattr(self, name)


@dataclass(frozen=True)
class SyntheticBulb:
    """Exact characteristics of the synthetic double-regulated bulb turbine.

    Examples
    --------
    >>> bulb = SyntheticBulb()
    >>> op = bulb.operate(blade_angle_deg=-9.5, guide_vane_deg=49.5)
    >>> bool(0.9 < float(op.efficiency) < 0.93), bool(11.0 < float(op.head_m) < 14.0)
    (True, True)
    >>> q = bulb.q11(float(op.n11_rpm), 49.5, -9.5)     # the unit characteristic at the same unit speed
    >>> bool(abs(float(q) - float(op.q11_m3_s)) < 1e-12)
    True
    """

    params: BulbParameters = field(default_factory=BulbParameters)

    def _check_controls(self, guide_vane_deg, blade_deg):
        gv, bl = np.broadcast_arrays(np.asarray(guide_vane_deg, dtype=float), np.asarray(blade_deg, dtype=float))
        if not (np.all(np.isfinite(gv)) and np.all(np.isfinite(bl))):
            raise InputError("synthetic bulb: guide_vane_deg and blade_angle_deg must be finite")
        lo_gv = self.params.guide_vane_closed_deg
        if np.any(gv <= lo_gv) or np.any(gv >= lo_gv + 90):
            raise InputError(f"synthetic bulb: guide_vane_deg must be in ({lo_gv}, {lo_gv + 90}) (open, flow angle "
                             f"0-90 deg), got [{gv.min()}, {gv.max()}]")
        lo, hi = BLADE_RANGE_DEG
        if np.any(bl < lo - 1e-9) or np.any(bl > hi + 1e-9):
            raise InputError(f"synthetic bulb: blade_angle_deg must be in [{lo}, {hi}] (the range the blade "
                             f"angles of the model stay valid over), got [{bl.min()}, {bl.max()}]")
        return gv, bl

    # unit characteristic (D = 1 m, H = 1 m) ---------------------------------------------------------------
    def _unit(self, n11, guide_vane_deg, blade_deg):
        p = self.params
        gv, bl = self._check_controls(guide_vane_deg, blade_deg)
        n11 = np.asarray(n11, dtype=float)
        if np.any(~np.isfinite(n11)) or np.any(n11 < 0):
            raise InputError("synthetic bulb: n11 must be finite and >= 0")
        n11, gv, bl = np.broadcast_arrays(n11, gv, bl)
        r_m = p.mean_radius_ratio
        u = 2.0 * math.pi * r_m * n11 / 60.0
        cm, cu1, cu2 = _axial_velocity(p, u, G_M_S2, 0.0, gv, bl)
        q11 = p.area_ratio * cm
        m11 = _torque_nm(p, q11, r_m, cu1, cu2, n11, 1.0)
        return q11, m11

    def q11(self, n11, guide_vane_deg, blade_angle_deg):
        """Unit flow Q11, m^3/s, at unit speed n11 (r/min), guide-vane angle and blade angle (deg), broadcast."""
        return self._unit(n11, guide_vane_deg, blade_angle_deg)[0]

    def m11(self, n11, guide_vane_deg, blade_angle_deg):
        """Unit torque M11, N*m (D = 1 m, H = 1 m)."""
        return self._unit(n11, guide_vane_deg, blade_angle_deg)[1]

    def unit_efficiency(self, n11, guide_vane_deg, blade_angle_deg):
        """Hydraulic efficiency M11 omega11 / (rho g Q11) on the unit characteristic (fraction)."""
        q11, m11 = self._unit(n11, guide_vane_deg, blade_angle_deg)
        return m11 * np.asarray(n11, dtype=float) * RPM_TO_RAD_S / (RHO_WATER_KG_M3 * G_M_S2 * q11)

    def point_parameters(self) -> np.ndarray:
        """The float vector (layout :data:`POINT_PARAMETERS`) of :func:`unit_point`."""
        p = self.params
        values = {"area_ratio": p.area_ratio, "mean_radius_ratio": p.mean_radius_ratio}
        return np.array([values[name] if name in values else getattr(p, name) for name in POINT_PARAMETERS])

    # the plant: constant speed on the water system -----------------------------------------------------------
    def operate(self, blade_angle_deg, guide_vane_deg) -> OperatingPoints:
        """Operating point(s) at constant speed with ``H = H_static - K_sys Q^2`` (closed form, module docstring).

        Parameters
        ----------
        blade_angle_deg : array_like, deg, in [-18, 16]
        guide_vane_deg : array_like, deg, in (beta_closed, beta_closed + 90) (broadcast with ``blade_angle_deg``)

        Returns
        -------
        OperatingPoints
        """
        p = self.params
        gv, bl = self._check_controls(guide_vane_deg, blade_angle_deg)
        d = p.runner_diameter_m
        area = p.area_ratio * d * d
        radius = p.mean_radius_ratio * d
        u = 2.0 * math.pi * radius * p.speed_rpm / 60.0
        cm, cu1, cu2 = _axial_velocity(p, u, G_M_S2 * p.static_head_m, G_M_S2 * p.system_loss_s2_m5 * area ** 2,
                                       gv, bl)
        flow = area * cm
        head = p.static_head_m - p.system_loss_s2_m5 * flow ** 2
        if np.any(head <= 0):
            raise InputError("synthetic bulb: the water system leaves no head at these controls "
                             f"(min head {float(np.min(head)):.3g} m); lower system_loss_s2_m5")
        torque = _torque_nm(p, flow, radius, cu1, cu2, p.speed_rpm, d)
        power_w = torque * p.speed_rpm * RPM_TO_RAD_S
        efficiency = power_w / (RHO_WATER_KG_M3 * G_M_S2 * flow * head)
        sqrt_h = np.sqrt(head)
        return OperatingPoints(blade_angle_deg=bl, guide_vane_deg=gv, head_m=head, flow_m3_s=flow,
                               power_kw=power_w / 1e3, efficiency=efficiency,
                               n11_rpm=p.speed_rpm * d / sqrt_h,  # eq. (2), paper 003
                               q11_m3_s=flow / (d * d * sqrt_h))  # eq. (1), paper 003

    def best_efficiency_n11(self, blade_angle_deg, guide_vane_deg, *, n11_bounds=(20.0, 400.0)) -> np.ndarray:
        """Unit speed (r/min) of best efficiency of each setting, ``d eta / d n11 = 0`` at fixed (a0, beta).

        Golden-section search on [20, 400] r/min, vectorized over all settings (hand-written: scipy's bounded
        scalar minimizer takes one point at a time; 90 golden steps shrink the bracket by 0.618^90 ~ 1e-19, i.e. to
        machine precision). Efficiency over n11 is single-humped for this model (tests check the optimum against a
        fine scan).

        Raises
        ------
        NumericalError
            An optimum on the bracket's edge (no interior best point).
        """
        gv, bl = self._check_controls(guide_vane_deg, blade_angle_deg)
        lo = np.full(gv.shape, float(n11_bounds[0]))
        hi = np.full(gv.shape, float(n11_bounds[1]))
        ratio = (math.sqrt(5.0) - 1.0) / 2.0
        a, c = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        fa, fc = self.unit_efficiency(a, gv, bl), self.unit_efficiency(c, gv, bl)
        for _ in range(90):
            left = fa > fc  # the maximum lies in [lo, c]
            hi = np.where(left, c, hi)
            lo = np.where(left, lo, a)
            a_new = np.where(left, hi - ratio * (hi - lo), c)
            c_new = np.where(left, a, lo + ratio * (hi - lo))
            f_new = self.unit_efficiency(np.where(left, a_new, c_new), gv, bl)
            fa, fc = np.where(left, f_new, fc), np.where(left, fa, f_new)
            a, c = a_new, c_new
        n11 = 0.5 * (lo + hi)
        edge = (n11 < n11_bounds[0] + 1e-6) | (n11 > n11_bounds[1] - 1e-6)
        if np.any(edge):
            raise NumericalError(f"best_efficiency_n11: the optimum lies on the search bracket {list(n11_bounds)} "
                                 f"r/min for {int(edge.sum())} setting(s)")
        return n11

    def best_efficiency_points(self, blade_angle_deg, guide_vane_deg) -> OperatingPoints:
        """Operating points of the model test: constant speed, head set to each setting's best-efficiency point
        (module docstring), ``H = (n D / n11*)^2`` (eq. (2) of paper 003 solved for H), ``Q = Q11 D^2 sqrt(H)``
        (eq. (1)), ``M = M11 D^3 H``, ``P = M omega``."""
        gv, bl = self._check_controls(guide_vane_deg, blade_angle_deg)
        return self._rig_points(self.best_efficiency_n11(bl, gv), gv, bl)

    def _rig_points(self, n11, gv, bl) -> OperatingPoints:
        """The model test at constant speed and unit speed ``n11`` (the rig sets the head): ``H = (n D / n11)^2``
        (eq. (2) of paper 003 solved for H), ``Q = Q11 D^2 sqrt(H)`` (eq. (1)), ``M = M11 D^3 H``, ``P = M omega``."""
        p = self.params
        q11, m11 = self._unit(n11, gv, bl)
        d = p.runner_diameter_m
        head = (p.speed_rpm * d / n11) ** 2  # eq. (2), paper 003
        flow = q11 * d * d * np.sqrt(head)  # eq. (1), paper 003
        power_w = m11 * d ** 3 * head * p.speed_rpm * RPM_TO_RAD_S
        efficiency = power_w / (RHO_WATER_KG_M3 * G_M_S2 * flow * head)
        return OperatingPoints(blade_angle_deg=bl, guide_vane_deg=gv, head_m=head, flow_m3_s=flow,
                               power_kw=power_w / 1e3, efficiency=efficiency, n11_rpm=n11, q11_m3_s=q11)

    def propeller_points(self, blade_angle_deg, guide_vane_deg, n11_rpm=PROPELLER_N11_RPM) -> OperatingPoints:
        """Operating points of the model test's propeller curves: constant speed, each (blade, guide-vane) setting
        measured at every unit speed of ``n11_rpm`` (the rig steps the head, ``H = (n D / n11)^2``, eq. (2) of paper
        003), flattened setting by setting; the same unit characteristic as the other closures."""
        gv, bl = self._check_controls(guide_vane_deg, blade_angle_deg)
        speeds = np.asarray(n11_rpm, dtype=float)
        if speeds.ndim != 1 or speeds.size == 0 or not np.all(np.isfinite(speeds) & (speeds > 0)):
            raise InputError(f"n11_rpm must be a non-empty list of positive unit speeds, got {n11_rpm!r}")
        gv, bl = np.repeat(gv.ravel(), speeds.size), np.repeat(bl.ravel(), speeds.size)
        return self._rig_points(np.tile(speeds, gv.size // speeds.size), gv, bl)

    def operating_points(self, blade_angle_deg, guide_vane_deg, closure: str) -> OperatingPoints:
        """The points of ``closure`` ``"best-efficiency"``, ``"water-system"`` or ``"propeller-curves"`` (one per
        setting and unit speed of :data:`PROPELLER_N11_RPM`; see the module docstring)."""
        if closure not in CLOSURES:
            raise InputError(f"closure must be one of {CLOSURES}, got {closure!r}")
        if closure == "water-system":
            return self.operate(blade_angle_deg, guide_vane_deg)
        if closure == "propeller-curves":
            return self.propeller_points(blade_angle_deg, guide_vane_deg)
        return self.best_efficiency_points(blade_angle_deg, guide_vane_deg)


# ---------------------------------------------------------------------------------------------------------------
# the model test: scattered test table and dense truth grid
# ---------------------------------------------------------------------------------------------------------------
#: Digits written per column (what a test-rig log keeps).
DIGITS = {"blade_angle_deg": 2, "guide_vane_deg": 2, "efficiency": 5, "head_m": 4, "power_kw": 2, "flow_m3_s": 4,
          "n11_rpm": 4, "q11_m3_s": 6}


def scattered_settings(n_points: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Scattered (blade angle, guide-vane angle) settings of a model test over the paper's ranges, degrees.

    The four corners of the range (so that the points' convex hull is the whole control range and linear
    interpolation is defined everywhere on it) plus ``n_points - 4`` points of a seeded Latin hypercube
    (``scipy.stats.qmc.LatinHypercube``): scattered like a real campaign, not a grid.
    """
    from scipy.stats import qmc

    if isinstance(n_points, bool) or not isinstance(n_points, (int, np.integer)) or n_points < 10:
        raise InputError(f"n_points must be an integer >= 10, got {n_points!r}")
    lo = np.array([BLADE_RANGE_DEG[0], GUIDE_VANE_RANGE_DEG[0]])
    hi = np.array([BLADE_RANGE_DEG[1], GUIDE_VANE_RANGE_DEG[1]])
    sample = qmc.scale(qmc.LatinHypercube(d=2, seed=np.random.default_rng(seed)).random(n_points - 4), lo, hi)
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [lo[0], hi[1]], [hi[0], hi[1]]])
    points = np.vstack([corners, sample])
    return points[:, 0], points[:, 1]


def _fmt_rows(columns, data) -> list[tuple[str, ...]]:
    return [tuple(f"{float(data[c][i]):.{DIGITS[c]}f}" for c in columns) for i in range(len(data[columns[0]]))]


def _csv_text(header, rows) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


TABLE_TOML = """\
name = "hillsim synthetic bulb turbine (double regulated, 1-D axial Euler model){suffix}"
runner_diameter_m = {diameter}
speed_rpm = {speed}
controls = ["blade_angle_deg", "guide_vane_deg"]
"""


def _measured(op: OperatingPoints, noise: float, seed: int) -> dict:
    """The columns :data:`TABLE_COLUMNS` of operating points as a rig measures them: head, flow and power with
    Gaussian relative noise ``noise`` (stream ``[seed, 1]``), the efficiency from those measured values."""
    rng = np.random.default_rng([seed, 1])  # a separate stream for the measurement noise
    size = op.head_m.size
    head = op.head_m * (1.0 + noise * rng.standard_normal(size))
    flow = op.flow_m3_s * (1.0 + noise * rng.standard_normal(size))
    power = op.power_kw * (1.0 + noise * rng.standard_normal(size))
    return {"blade_angle_deg": op.blade_angle_deg, "guide_vane_deg": op.guide_vane_deg, "head_m": head,
            "flow_m3_s": flow, "power_kw": power, "efficiency": power * 1e3 / (RHO_WATER_KG_M3 * G_M_S2 * flow * head)}


def write_bulb_sweep_table(out_dir, *, blade_angles, guide_vanes, n11_rpm, seed: int = 0, noise: float = 0.003,
                           turbine: SyntheticBulb | None = None) -> dict[str, Path]:
    """Write a model test of guide-vane sweeps (``table.csv`` + ``table.toml``): every blade angle of
    ``blade_angles`` at every unit speed of ``n11_rpm`` (the rig steps the head, ``H = (n D / n11)^2``, as for the
    propeller curves) over the guide-vane angles ``guide_vanes`` (deg), less the points beyond a setting's runaway;
    the noise of :func:`write_bulb_table`. A rig such as the 137 kW fixed-blade bulb of the external data measures
    this way (heads x guide-vane sweep); its lowest angles are what :mod:`hillchart.fccm.evidence` holds out.

    Examples
    --------
    >>> import tempfile
    >>> files = write_bulb_sweep_table(tempfile.mkdtemp(), blade_angles=[0.0], guide_vanes=[40.0, 50.0],
    ...                                n11_rpm=[140.0, 160.0])
    >>> len(files["table.csv"].read_text().splitlines())   # header + 2 angles x 2 unit speeds
    5
    """
    if isinstance(noise, bool) or not isinstance(noise, (int, float)) or not (0 <= noise < 0.1):
        raise InputError(f"noise must be a relative standard deviation in [0, 0.1), got {noise!r}")
    turbine = turbine or SyntheticBulb()
    p = turbine.params
    blade, gv = (np.round(g.ravel(), DIGITS[c]) for g, c in zip(
        np.meshgrid(np.asarray(blade_angles, float), np.asarray(guide_vanes, float), indexing="ij"),
        ("blade_angle_deg", "guide_vane_deg")))
    op = turbine.propeller_points(blade, gv, n11_rpm)
    keep = op.power_kw > 0  # a rig measures turbine operation: no point beyond a setting's runaway
    op = OperatingPoints(**{f.name: getattr(op, f.name)[keep] for f in fields(OperatingPoints)})
    table = _measured(op, noise, seed)
    suffix = f", guide-vane sweeps, seed {seed}, noise {noise:g}"
    texts = {"table.toml": TABLE_TOML.format(suffix=suffix, diameter=repr(float(p.runner_diameter_m)),
                                             speed=repr(float(p.speed_rpm))),
             "table.csv": _csv_text(TABLE_COLUMNS, _fmt_rows(TABLE_COLUMNS, table))}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = {}
    for name, text in texts.items():
        written[name] = out / name
        written[name].write_text(text, encoding="utf-8")
    return written


def write_bulb_table(out_dir, *, seed: int = 0, n_points: int = 150, noise: float = 0.003,
                     truth_step_deg: float = 0.5, closure: str = "water-system",
                     turbine: SyntheticBulb | None = None) -> dict[str, Path]:
    """Write the model test of the synthetic bulb turbine: ``table.csv`` + ``table.toml`` and ``truth.csv``.

    ``table.csv`` (columns :data:`TABLE_COLUMNS`) holds ``n_points`` scattered settings (:func:`scattered_settings`)
    as a rig measures them: head, flow and power each with Gaussian relative noise of standard deviation ``noise``
    (0.003 = 0.3 %), efficiency computed from those measured values as ``P / (rho g Q H)`` (so its noise is about
    sqrt(3) ``noise``), angles exact. No n11/Q11 columns: the table loader derives them from D and the speed in
    ``table.toml``. ``truth.csv`` (columns :data:`TRUTH_COLUMNS`) is the exact, noise-free grid of step
    ``truth_step_deg`` over the paper's ranges. ``closure`` picks how a setting's operating point is fixed
    (:data:`CLOSURES`; the default, the plant's water system, puts all points on one curve of the (Q11, n11) plane;
    "best-efficiency", each setting's best-efficiency point, spreads them over a 2-D region of it;
    "propeller-curves", ``n_points // 5`` settings each at the unit speeds :data:`PROPELLER_N11_RPM`, the rig
    stepping the head as a model test's propeller curves do, less the points beyond a setting's runaway). Same seed,
    same bytes; all files are built in memory first.

    Returns
    -------
    dict
        File name -> written path.
    """
    if isinstance(noise, bool) or not isinstance(noise, (int, float)) or not (0 <= noise < 0.1):
        raise InputError(f"noise must be a relative standard deviation in [0, 0.1), got {noise!r}")
    if not (isinstance(truth_step_deg, (int, float)) and 0.05 <= truth_step_deg <= 5):
        raise InputError(f"truth_step_deg must be in [0.05, 5] deg, got {truth_step_deg!r}")
    if closure not in CLOSURES:
        raise InputError(f"closure must be one of {CLOSURES}, got {closure!r}")
    turbine = turbine or SyntheticBulb()
    p = turbine.params
    if closure == "propeller-curves":  # n_points in all, one per setting and unit speed of PROPELLER_N11_RPM
        per_setting = len(PROPELLER_N11_RPM)
        if isinstance(n_points, bool) or not isinstance(n_points, (int, np.integer)) or n_points < 10 * per_setting:
            raise InputError(f"n_points must be an integer >= {10 * per_setting} with closure \"propeller-curves\" "
                             f"(10 settings x {per_setting} unit speeds), got {n_points!r}")
        blade, gv = scattered_settings(n_points // per_setting, seed)
    else:
        blade, gv = scattered_settings(n_points, seed)
    # the rig sets (and logs) the angles to DIGITS decimals: the operating point is that of the logged angles
    blade, gv = np.round(blade, DIGITS["blade_angle_deg"]), np.round(gv, DIGITS["guide_vane_deg"])
    op = turbine.operating_points(blade, gv, closure)
    if closure == "propeller-curves":  # a rig measures turbine operation: no point beyond a setting's runaway
        keep = op.power_kw > 0
        op = OperatingPoints(**{f.name: getattr(op, f.name)[keep] for f in fields(OperatingPoints)})
    table = _measured(op, noise, seed)
    bl_grid = np.arange(BLADE_RANGE_DEG[0], BLADE_RANGE_DEG[1] + 1e-9, truth_step_deg)
    gv_grid = np.arange(GUIDE_VANE_RANGE_DEG[0], GUIDE_VANE_RANGE_DEG[1] + 1e-9, truth_step_deg)
    bb, gg = (g.ravel() for g in np.meshgrid(bl_grid, gv_grid, indexing="ij"))
    truth_op = turbine.operating_points(bb, gg, closure)
    truth = {c: truth_op.column(c) for c in TRUTH_COLUMNS}
    suffix = f", {closure} closure, seed {seed}, noise {noise:g}"
    texts = {
        "table.toml": TABLE_TOML.format(suffix=suffix, diameter=repr(float(p.runner_diameter_m)),
                                        speed=repr(float(p.speed_rpm))),
        "table.csv": _csv_text(TABLE_COLUMNS, _fmt_rows(TABLE_COLUMNS, table)),
        "truth.csv": _csv_text(TRUTH_COLUMNS, _fmt_rows(TRUTH_COLUMNS, truth)),
    }
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = {}
    for name, text in texts.items():
        path = out / name
        path.write_text(text, encoding="utf-8")
        written[name] = path
    return written
