"""Water-column separation in the method-of-characteristics conduits: the keys of the discrete vapour cavity model
(DVCM, ``penstock.column_separation = "dvcm"``) and of the discrete gas cavity model (``"dgcm"``, the default), the
vapour pressure of water and the vapour head at the computing nodes. The time-loop functions of the DVCM are the MOC
penstock's (:func:`simulate.components.hydraulic.penstock.moc_step_dvcm`), written with the compatibility equations
there.

Equations numbered here (heads piezometric above the tailwater datum, m; flows m^3/s; the notation of the MOC
module: C+ line H = C_P - B_L Q from the reach upstream of the node, C- line H = C_M + B_R Q from the reach
downstream of it)::

    (C1)  H_v = z - H_atm + p_v(T) / (rho g)               vapour head at a node of axis elevation z (absolute
                                                           pressure = vapour pressure)
    (C2)  H_P = (C_P B_R + C_M B_L) / (B_L + B_R)           liquid node (one flow Q_P on both sides)
    (C3)  H_P = H_v,  Q_in = (C_P - H_v) / B_L,  Q_out = (H_v - C_M) / B_R      cavity at the node
    (C4)  V = V_old + dt [psi (Q_out - Q_in) + (1 - psi) (Q_out,old - Q_in,old)]   cavity volume, m^3
    (C5)  V <= 0: the cavity collapses, V = 0 and the node is liquid again, (C2)
    (C6)  p_v(T): the saturation line of IAPWS-IF97, eq. (30) (quadratic in p^(1/4), theta = T + n9 / (T - n10))

With ``column_separation = "dgcm"`` the discrete gas cavity model of
:mod:`simulate.components.hydraulic.gas_cavity` takes the place of (C2)-(C5), with the same (C1), (C4) and (C6).

(C1)-(C5) are the discrete vapour cavity model (Wylie and Streeter, *Fluid Transients in Systems*, 1993, ch. 8;
reviewed as the DVCM by Bergant, Simpson and Tijsseling, "Water hammer with column separation: a historical review",
J. Fluids Struct. 22, 2006); the numbers are this module's. A cavity may form at every computing node, the liquid
between nodes keeps its wave speed, and a node whose head from (C2) falls below the vapour head (C1) holds the
vapour head while its upstream and downstream flows are computed separately, (C3), from the two characteristics;
the cavity volume follows the continuity of (C4). The weighting psi of (C4) (``cavity_weighting``) is 1 by default
(the new flows only): a psi close to 1 damps the spurious pressure spikes the trapezoidal psi = 0.5 gives (Simpson
and Bergant, "Numerical comparison of pipe-column-separation models", J. Hydraul. Eng. 120(3), 1994); 0.5 is
allowed. At the downstream end (the turbine or valve) the flow leaving the node is the boundary's and only C+ reaches
the node (:func:`simulate.components.hydraulic.penstock.dvcm_outlet_cavity`).

At the reservoir node the head is the reservoir's and no cavity forms. Where the segments carry no profile
(``elevation_start_m``/``elevation_end_m``) the pipe axis is taken at the tailwater level (z = 0) at every node,
and the run's cavity warning says so.

References: E. B. Wylie, V. L. Streeter, *Fluid Transients in Systems*, Prentice Hall, 1993, ch. 8. A. Bergant,
A. R. Simpson, A. S. Tijsseling, "Water hammer with column separation: a historical review", J. Fluids Struct. 22
(2006) 135-171. A. R. Simpson, A. Bergant, "Numerical comparison of pipe-column-separation models", J. Hydraul. Eng.
120(3) (1994) 361-377. W. Wagner et al., "The IAPWS Industrial Formulation 1997 for the thermodynamic properties of
water and steam", J. Eng. Gas Turbines Power 122 (2000) 150-182 (eq. (30), table 34).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
from hillchart.errors import InputError
from simulate.components.parameters import parameter, validate_parameters

#: The ways a MOC conduit treats a head below the vapour head: the discrete vapour cavity model, the discrete gas
#: cavity model (:mod:`simulate.components.hydraulic.gas_cavity`; the default of ``penstock.column_separation``: its
#: collapse peaks converge with the step on the Bergant-Simpson rig, the DVCM's spikes grow as the grid is refined),
#: or nothing (the head goes on falling; the turbine boundary stops the run when its net head reaches zero).
COLUMN_SEPARATION_MODELS = ("dvcm", "dgcm", "off")
#: The names the reports give the models.
MODEL_NAMES = {"dvcm": "discrete vapour cavity model", "dgcm": "discrete gas cavity model"}
#: What the warnings call a cavity of each model (the DGCM's: its free gas beyond its volume at the atmospheric
#: pressure).
CAVITY_WORDS = {"dvcm": "vapour cavity", "dgcm": "gas cavity"}
#: The ``[penstock]`` keys of both cavity models (refused with ``column_separation = "off"``).
DVCM_KEYS = ("water_temperature_c", "atmospheric_pressure_head_m", "cavity_weighting")
#: The ``[penstock]`` keys of the DGCM alone (refused unless ``column_separation = "dgcm"``).
DGCM_KEYS = ("gas_void_fraction",)
#: Defaults of the optional keys.
WATER_TEMPERATURE_C = 20.0
ATMOSPHERIC_PRESSURE_HEAD_M = 10.33  # 101.325 kPa / (rho g), rho = 1000 kg/m^3, g = 9.81 m/s^2
CAVITY_WEIGHTING = 1.0
#: The free gas per volume of pipe at the atmospheric pressure: 1e-7, the void fraction Bergant and Simpson (1999) and
#: He et al. (2025) run the Adelaide rig with.
GAS_VOID_FRACTION = 1e-7

#: IAPWS-IF97 coefficients n1..n10 of the saturation line, table 34.
_IF97_N = (0.11670521452767e4, -0.72421316703206e6, -0.17073846940092e2, 0.12020824702470e5,
           -0.32325550322333e7, 0.14915108613530e2, -0.48232657361591e4, 0.40511340542057e6,
           -0.23855557567849, 0.65017534844798e3)


@dataclass(frozen=True)
class ColumnSeparationConfig:
    """The optional ``[penstock]`` keys of the cavity models (``column_separation = "dgcm"`` or ``"dvcm"``)."""

    water_temperature_c: float | None = parameter(
        None, unit="degC", low=0.0, high=100.0,
        description="water temperature of the vapour pressure (dvcm, dgcm; default 20 degC: 2.34 kPa)")
    atmospheric_pressure_head_m: float | None = parameter(
        None, unit="m", low=0.0, high=20.0,
        description="atmospheric pressure as a head of water at the plant (dvcm, dgcm; default 10.33 m, sea "
                    "level)")
    cavity_weighting: float | None = parameter(
        None, unit="1", low=0.5, high=1.0,
        description="weighting psi of the new flows in the cavity volume (dvcm, dgcm; default 1)")
    gas_void_fraction: float | None = parameter(
        None, unit="1", low=0.0, low_open=True, high=1e-2,
        description="free gas per volume of pipe at the atmospheric pressure (dgcm; default 1e-7)")

    def __post_init__(self):
        validate_parameters("penstock", self)


def check_penstock(penstock) -> None:
    """The cavity models' keys (:data:`DVCM_KEYS`) would be ignored with ``column_separation = "off"``, the DGCM's
    (:data:`DGCM_KEYS`) under any other model: refused."""
    model = penstock.column_separation
    for keys, owners in ((DVCM_KEYS, ("dvcm", "dgcm")), (DGCM_KEYS, ("dgcm",))):
        for key in keys:
            if model not in owners and getattr(penstock, key) is not None:
                raise InputError(f"penstock.{key} = {getattr(penstock, key)!r} is a key of penstock.column_separation"
                                 f" = {' or '.join(repr(o) for o in owners)}; with column_separation = {model!r} it "
                                 f"would be ignored: set column_separation = \"{owners[-1]}\" or remove the key")


def vapour_pressure_pa(temperature_c: float) -> float:
    """Saturation pressure of water at ``temperature_c`` (degC), Pa: eq. (C6) of this module (IAPWS-IF97 eq. (30)).

    Examples
    --------
    >>> round(vapour_pressure_pa(26.85), 1)   # IF97 table 35: T = 300 K, p = 0.353658941e-2 MPa
    3536.6
    >>> round(vapour_pressure_pa(20.0))
    2339
    """
    if not (isinstance(temperature_c, (int, float)) and 0.0 <= temperature_c <= 100.0):
        raise InputError(f"the water temperature must be a number in [0.0, 100.0] degC, got {temperature_c!r}")
    n = _IF97_N
    t = temperature_c + 273.15
    theta = t + n[8] / (t - n[9])  # eq. (29b) of IF97
    a = theta * theta + n[0] * theta + n[1]
    b = n[2] * theta * theta + n[3] * theta + n[4]
    c = n[5] * theta * theta + n[6] * theta + n[7]
    return 1e6 * (2.0 * c / (-b + math.sqrt(b * b - 4.0 * a * c))) ** 4  # eq. (30) of IF97, MPa -> Pa


def vapour_pressure_head_m(temperature_c: float) -> float:
    """p_v / (rho g), m of water (rho = 1000 kg/m^3: the density of every head of the simulator).

    >>> round(vapour_pressure_head_m(20.0), 4)
    0.2385
    """
    return vapour_pressure_pa(temperature_c) / (RHO_WATER_KG_M3 * G_M_S2)


@dataclass(frozen=True)
class VapourSettings:
    """The settings a conduit's column separation runs with (the keys' values or their defaults)."""

    model: str
    water_temperature_c: float
    atmospheric_pressure_head_m: float
    cavity_weighting: float
    gas_void_fraction: float = GAS_VOID_FRACTION

    @property
    def vapour_pressure_head_m(self) -> float:
        return vapour_pressure_head_m(self.water_temperature_c)

    @property
    def gauge_vapour_head_m(self) -> float:
        """The vapour pressure as a gauge head, p_v / (rho g) - H_atm, m (negative)."""
        return self.vapour_pressure_head_m - self.atmospheric_pressure_head_m


def vapour_settings(penstock) -> VapourSettings:
    """The column-separation settings of a :class:`simulate.components.hydraulic.conduit.PenstockConfig`."""
    def value(key, default):
        v = getattr(penstock, key, None)
        return default if v is None else float(v)

    return VapourSettings(getattr(penstock, "column_separation", "off"),
                          value("water_temperature_c", WATER_TEMPERATURE_C),
                          value("atmospheric_pressure_head_m", ATMOSPHERIC_PRESSURE_HEAD_M),
                          value("cavity_weighting", CAVITY_WEIGHTING),
                          value("gas_void_fraction", GAS_VOID_FRACTION))


def has_profile(penstock) -> bool:
    """Whether the segments carry the pipe axis's elevations."""
    return all(s.elevation_start_m is not None for s in penstock.segments)


def axis_elevations_m(penstock, x_m) -> np.ndarray | None:
    """Elevation of the pipe axis above the tailwater datum at ``x_m`` (distance from the inlet, m), from the
    segments' profile (linear within a segment), or None without a profile.

    Examples
    --------
    >>> from simulate.components.hydraulic.conduit import PenstockSegment
    >>> from types import SimpleNamespace
    >>> seg = PenstockSegment(length_m=100.0, diameter_m=1.0, wave_speed_m_s=1000.0, darcy_friction=0.0,
    ...                       elevation_start_m=50.0, elevation_end_m=0.0)
    >>> axis_elevations_m(SimpleNamespace(segments=(seg,)), [0.0, 50.0, 100.0]).tolist()
    [50.0, 25.0, 0.0]
    """
    segs = penstock.segments
    if not has_profile(penstock):
        return None
    xs, zs = [0.0], [segs[0].elevation_start_m]
    for s in segs:
        xs.append(xs[-1] + s.length_m)
        zs.append(s.elevation_end_m)
    # within segment i the axis is linear from elevation_start to elevation_end (continuity checked by the config)
    return np.interp(np.asarray(x_m, float), np.array(xs), np.array(zs))


def node_vapour_heads_m(penstock, x_m, settings: VapourSettings) -> np.ndarray:
    """The vapour head H_v of eq. (C1) at every node ``x_m`` (m above the tailwater datum); without a profile the
    axis is at the tailwater level, z = 0."""
    z = axis_elevations_m(penstock, x_m)
    z = np.zeros(np.asarray(x_m).shape) if z is None else z
    return z - settings.atmospheric_pressure_head_m + settings.vapour_pressure_head_m  # eq. (C1)


class BoilingSteadyState(InputError):
    """:func:`check_steady_heads`'s refusal, with the node's steady head and vapour head (m above the tailwater
    datum) and its distance from the pipe's inlet ``x_m`` (m) for a caller that words it for its own section (the
    draft tube)."""

    def __init__(self, message: str, head_m: float, vapour_head_m: float, x_m: float = 0.0):
        super().__init__(message)
        self.head_m, self.vapour_head_m, self.x_m = head_m, vapour_head_m, x_m


def check_steady_heads(penstock, x_m, heads_m, vapour_heads_m) -> None:
    """A steady head at or below a node's vapour head (eq. (C1); the reservoir node's excepted) is refused
    (:class:`BoilingSteadyState`): the water would boil in steady flow, which neither cavity model starts from. The
    error names the node, both heads and the segment's profile keys that put the axis there. Nothing to check with
    ``column_separation = "off"``."""
    low = np.asarray(heads_m, float)[1:] - np.asarray(vapour_heads_m, float)[1:]
    if penstock.column_separation == "off" or not np.any(low <= 0.0):
        return
    j = 1 + int(np.argmin(low))
    x = float(x_m[j])
    where = ""
    if has_profile(penstock):
        start = 0.0
        for i, seg in enumerate(penstock.segments, start=1):
            if x <= start + seg.length_m * (1.0 + 1e-12) or i == len(penstock.segments):
                where = (f" (the pipe axis there from penstock.segments.elevation_start_m = {seg.elevation_start_m:g}"
                         f" and penstock.segments.elevation_end_m = {seg.elevation_end_m:g} of segment {i})")
                break
            start += seg.length_m
    raise BoilingSteadyState(
        f"penstock.column_separation = {penstock.column_separation!r}: the steady head at node {j} (x = {x:.4g} m), "
        f"{heads_m[j]:.4g} m, is not above its vapour head {vapour_heads_m[j]:.4g} m{where}: the water would boil in "
        f"steady flow; raise the reservoir or lower the pipe", float(heads_m[j]), float(vapour_heads_m[j]), x)


def no_profile_note(penstock) -> str:
    """What the cavity warning says about the elevations the vapour head was taken at."""
    if has_profile(penstock):
        return ""
    return (" (the segments carry no profile: the pipe axis is taken at the tailwater level, z = 0, at every node; "
            "give [[penstock.segments]] elevation_start_m and elevation_end_m)")


#: The columns a conduit with the DVCM records: the volume of all its cavities and of the one at its downstream end
#: (the turbine or valve), m^3.
SIGNALS = ("cavity_volume_m3", "outlet_cavity_volume_m3")
#: Cavity warnings named one by one (the largest first); the rest are counted.
MAX_CAVITY_WARNINGS = 5
#: A cavity whose largest volume stays below this fraction of the pipe's volume per node is the rounding of a node
#: whose exact head is the vapour head (a wave at the vapour pressure passing it: (C3) then gives Q_out - Q_in of a
#: few ulp of Q), not reported as a cavity.
ROUNDING_VOLUME_FRACTION = 1e-12


class CavityRecord:
    """The figures and warnings of a MOC conduit's cavities after the run, read from its ``track`` array (rows: 0
    cavity volume, 1 its largest, 2 the step of the largest, 3 the step of the lowest head, 4 the lowest head, 5
    cavities formed, 6 the step of the first; see :func:`simulate.components.hydraulic.penstock.moc_dvcm_update`),
    its nodes ``x_m``, the step ``dt_s``, its ``totals`` ([total volume, 1 while the relation held the downstream end
    at the vapour head]) and the vapour head per node ``vapour_m``."""

    def __init__(self, penstock, x_m, dt_s: float, settings: VapourSettings, track: np.ndarray, totals: np.ndarray,
                 vapour_m: np.ndarray):
        self.penstock, self.x_m, self.dt_s, self.settings, self.track = penstock, np.asarray(x_m), dt_s, settings, track
        self.totals, self.vapour_m = totals, vapour_m

    def settings_summary(self) -> dict:
        """The run's column-separation settings (fixed figures of the summary)."""
        out = {"column_separation_model": self.settings.model}
        if self.settings.model != "off":
            out.update({"water_temperature_c": self.settings.water_temperature_c,
                        "vapour_pressure_head_m": self.settings.vapour_pressure_head_m,
                        "atmospheric_pressure_head_m": self.settings.atmospheric_pressure_head_m,
                        "cavity_weighting": self.settings.cavity_weighting})
        if self.settings.model == "dgcm":
            out["gas_void_fraction"] = self.settings.gas_void_fraction
        return out

    def cavity_nodes(self) -> np.ndarray:
        """The nodes where a cavity formed (above :data:`ROUNDING_VOLUME_FRACTION`), the largest cavity first."""
        volume = sum(s.area_m2 * s.length_m for s in self.penstock.segments) / self.x_m.size
        nodes = np.flatnonzero((self.track[5] > 0) & (self.track[1] > ROUNDING_VOLUME_FRACTION * volume))
        return nodes[np.argsort(-self.track[1, nodes], kind="stable")]

    def figures(self, time_s, signals) -> dict:
        """``max_cavity_volume_m3`` and, when a cavity formed, where (``max_cavity_x_m``) and when
        (``t_max_cavity_s``), the number of nodes that cavitated and the first cavity's place and time; the time of
        the envelope's lowest head (``t_envelope_min_head_s``); with a profile the lowest absolute pressure along
        the pipe (head of water, m, and kPa), where and when."""
        track, dt = self.track, self.dt_s
        out = {}
        if self.settings.model != "off":
            nodes = self.cavity_nodes()
            out["max_cavity_volume_m3"] = float(track[1].max())
            out["cavity_nodes"] = int(nodes.size)
            if nodes.size:
                j = int(nodes[0])
                first = int(nodes[np.argmin(track[6, nodes])])
                out.update({"max_cavity_x_m": float(self.x_m[j]), "t_max_cavity_s": float(track[2, j] * dt),
                            "first_cavity_x_m": float(self.x_m[first]),
                            "t_first_cavity_s": float(track[6, first] * dt)})
        j = int(np.argmin(track[4]))
        out["t_envelope_min_head_s"] = float(track[3, j] * dt)
        z = axis_elevations_m(self.penstock, self.x_m)
        if z is not None:
            absolute = track[4] - z + self.settings.atmospheric_pressure_head_m
            j = int(np.argmin(absolute))
            out.update({"min_absolute_pressure_head_m": float(absolute[j]),
                        "min_absolute_pressure_kpa": float(absolute[j] * RHO_WATER_KG_M3 * G_M_S2 / 1e3),
                        "min_absolute_pressure_x_m": float(self.x_m[j]),
                        "t_min_absolute_pressure_s": float(track[3, j] * dt)})
        return out

    def failure(self) -> str:
        """Why the run stopped, when its turbine boundary found no solution with the downstream end held at the
        vapour head by a cavity ("" otherwise): the cavity is modelled, a turbine at a net head of zero or below is
        not."""
        if self.settings.model == "off" or self.totals[1] != 1.0:
            return ""
        about = "" if self.settings.model == "dvcm" else "about "  # the DGCM's gas adds its partial pressure
        # above the tailwater datum the net head may still be positive (a draft tube's head aside): the boundary
        # then found no point at that head, which the characteristics' own words (after this) say
        why = ("the turbine's net head is not positive there, which its characteristics do not cover"
               if self.vapour_m[-1] <= 0.0 else "the turbine boundary found no operating point at that head")
        return (f"a {CAVITY_WORDS[self.settings.model]} holds the downstream end of the pipe (the turbine inlet) at "
                f"{about}the vapour head, "
                f"{self.vapour_m[-1]:.3g} m above the tailwater datum{no_profile_note(self.penstock)}, from "
                f"t = {(self.track[6, -1] if self.track[5, -1] > 0 else 0.0) * self.dt_s:.4g} s or this step: {why} "
                f"(the cavity is modelled by the {MODEL_NAMES[self.settings.model]}; close the guide vanes more "
                f"slowly or set the turbine lower)")

    def warnings(self) -> list[str]:
        """One warning per node where a cavity formed (the largest :data:`MAX_CAVITY_WARNINGS`): where, when first,
        how often, and its largest volume and when."""
        if self.settings.model == "off":
            return []
        track, dt, nodes = self.track, self.dt_s, self.cavity_nodes()
        out = []
        for j in nodes[:MAX_CAVITY_WARNINGS]:
            count = int(track[5, j])
            out.append(f"water-column separation: a {CAVITY_WORDS[self.settings.model]} formed at x = "
                       f"{self.x_m[j]:.4g} m from the pipe's inlet (node {j} of {self.x_m.size - 1}) at "
                       f"t = {track[6, j] * dt:.4g} s"
                       f"{f' ({count} times)' if count > 1 else ''}; its largest volume {track[1, j]:.3g} m^3 at "
                       f"t = {track[2, j] * dt:.4g} s ({MODEL_NAMES[self.settings.model]}, vapour head "
                       f"{self.settings.gauge_vapour_head_m:.3g} m gauge){no_profile_note(self.penstock)}")
        if nodes.size > MAX_CAVITY_WARNINGS:
            out.append(f"water-column separation: vapour cavities formed at {nodes.size - MAX_CAVITY_WARNINGS} more "
                       f"nodes between x = {self.x_m[nodes].min():.4g} m and {self.x_m[nodes].max():.4g} m")
        return out


__all__ = ["COLUMN_SEPARATION_MODELS", "MODEL_NAMES", "CAVITY_WORDS", "DVCM_KEYS", "DGCM_KEYS",
           "ColumnSeparationConfig", "check_penstock", "vapour_pressure_pa",
           "vapour_pressure_head_m", "VapourSettings", "vapour_settings", "has_profile", "axis_elevations_m",
           "node_vapour_heads_m", "no_profile_note", "SIGNALS", "CavityRecord"]
