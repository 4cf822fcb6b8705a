"""Plant configuration: a TOML file -> frozen dataclasses with units in the names.

Every section is a frozen dataclass whose ``__post_init__`` rejects nonsense with an :class:`InputError` that names
``section.key``, the bad value and the allowed range. The TOML reader is strict: an unknown key or a missing required
key is an error naming the key and the valid ones; optional keys have the documented default below.

File layout (units in the key names; ``[scenario]`` keys depend on ``kind``)::

    [turbine]    rated_head_m, rated_flow_m3_s, rated_speed_rpm, rated_power_mw, runner_diameter_m,
                 opening_max, characteristics            # "ideal" or a nets.json path relative to the file
    [penstock]   model, static_head_m, reaches, [lumped_alpha], [zdomain_feedback]
    [[penstock.segments]]  length_m, diameter_m, wave_speed_m_s, darcy_friction   (upstream first)
    [generator]  inertia_time_s, self_regulation, [model]   # swing (default) | subtransient
    [governor]   kp, ki, kd, derivative_filter_s, permanent_droop, servo_time_s, closing_time_s,
                 opening_time_s, stroke_min, stroke_max, [servo_model] and its servo_* keys
                 (simulate.components.control.governor.GovernorConfig: keys declared with unit and bounds)
    [scenario]   kind, t_end_s, ... (see :data:`SCENARIO_KEYS`)
    [solver]     [dt_s], [pressure_loop], [tolerance], [max_iterations], [relaxation], [output_dt_s],
                 [max_node_steps], [max_output_mb], [fallback], [substeps]
    [surge_tank] optional: area_m2, throttle_loss_coefficient, tunnel_length_m, tunnel_diameter_m,
                 tunnel_darcy_friction, [level_max_m], [level_min_m]
    [blade_servo], [combinator]  double-regulated units (three-input characteristics; see
                 simulate.components.control.blade_servo)
    [draft_tube] optional: model, [[draft_tube.segments]], pressure keys (simulate.components.hydraulic.draft_tube)
    [excitation], [grid]  with generator.model = "subtransient"
                 (simulate.components.control.excitation.ExcitationConfig,
                 simulate.components.electrical.generator.GridConfig); [generator] then also takes the machine keys
                 SUBTRANSIENT_KEYS
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import MISSING, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from hillchart.errors import InputError
from hillchart.validation import check_choice, check_int, check_number

from simulate.components.control.governor import GovernorConfig
from simulate.components.registry import PENSTOCKS  # noqa: E402  (light: no numba)
from simulate.components.turbine.step_up import StepUpConfig
from simulate.scenarios.base import SCENARIO_KEYS, SCENARIO_KINDS, ScenarioConfig

PRESSURE_LOOPS = ("improved", "traditional", "newton")
#: Relative tolerance of ``solver.dt_s`` against the MOC step (shortest travel time) / ``penstock.reaches``: hillsim
#: prints the step with 6 significant digits ("131 steps of 0.0190678 s"), which is up to 5e-6 off the step, so a
#: value copied from its output must pass; a step within it is taken as the grid's own step. (A step 1e-5 off the
#: Courant step would amount to a wave speed 1e-5 off, against the 5 % the grid's wave-speed adjustment allows.)
COURANT_TOLERANCE = 1e-5


@dataclass(frozen=True)
class TurbineConfig:
    """Rated values of the unit and where its characteristics come from.

    ``opening_max`` is the chart opening (chart units, e.g. mm) at full servo stroke y = 1, so the chart opening is
    ``a = y * opening_max``. ``characteristics`` is ``"ideal"``, ``"synthetic"`` (the exact synthetic Francis),
    ``"synthetic-bulb"`` (the exact synthetic double-regulated bulb) or a path to a nets.json (relative to the plant
    file); characteristics with a blade angle (three-input nets, the bulb) need ``[combinator]``.
    ``step_up``: the table ``[turbine.step_up]`` when the chart is a model test to be converted to this prototype
    (IEC 60193 efficiency step-up, see below); absent, the characteristics are used as they are.
    """

    rated_head_m: float
    rated_flow_m3_s: float
    rated_speed_rpm: float
    rated_power_mw: float
    runner_diameter_m: float
    opening_max: float
    characteristics: str
    step_up: StepUpConfig | None = None

    def __post_init__(self):
        if isinstance(self.step_up, (dict, str)):  # the TOML table, or --set turbine.step_up=iec60193
            raw = {"method": self.step_up} if isinstance(self.step_up, str) else self.step_up
            object.__setattr__(self, "step_up", StepUpConfig.from_toml(raw))
        elif self.step_up is not None and not isinstance(self.step_up, StepUpConfig):
            raise InputError(f"turbine.step_up must be a table such as {{method = \"iec60193\"}}, got "
                             f"{self.step_up!r}")
        for name, high in (("rated_head_m", 3000.0), ("rated_flow_m3_s", 1e4), ("rated_speed_rpm", 3600.0),
                           ("rated_power_mw", 2000.0), ("runner_diameter_m", 20.0), ("opening_max", 1e5)):
            check_number(f"turbine.{name}", getattr(self, name), low=0.0, high=high, low_open=True)
        if not isinstance(self.characteristics, str) or not self.characteristics.strip():
            raise InputError(f"turbine.characteristics must be \"ideal\" or a path to a nets.json, "
                             f"got {self.characteristics!r}")
        efficiency = self.rated_efficiency
        if not (0.0 < efficiency <= 1.0):
            raise InputError(
                f"turbine.rated_power_mw = {self.rated_power_mw!r} gives a rated efficiency P_r/(rho g Q_r H_r) = "
                f"{efficiency:.4g}, which must be in (0, 1]; check rated_power_mw, rated_flow_m3_s, rated_head_m")

    @property
    def rated_efficiency(self) -> float:
        """P_r / (rho g Q_r H_r), fraction."""
        from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
        return self.rated_power_mw * 1e6 / (RHO_WATER_KG_M3 * G_M_S2 * self.rated_flow_m3_s * self.rated_head_m)

    @property
    def rated_torque_nm(self) -> float:
        """P_r / omega_r, N*m (the per-unit torque base of the rotor equation)."""
        from hillchart.constants import RPM_TO_RAD_S
        return self.rated_power_mw * 1e6 / (self.rated_speed_rpm * RPM_TO_RAD_S)


#: The slowest pressure wave in water: a bubbly air-water mixture at atmospheric pressure has its minimum sound
#: speed (Wood's equation, half air by volume) at about 24 m/s; water conduits lie at about 100-1500 m/s.
WAVE_SPEED_MIN_M_S = 20.0


@dataclass(frozen=True)
class PenstockSegment:
    """One pipe of uniform section; segments are in series, upstream first. ``elevation_start_m`` /
    ``elevation_end_m`` (optional, both or neither, on every segment or none): the pipe axis above the tailwater
    datum of the heads at the segment's ends, for the pressure-head envelope."""

    length_m: float
    diameter_m: float
    wave_speed_m_s: float
    darcy_friction: float
    elevation_start_m: float | None = None
    elevation_end_m: float | None = None

    def __post_init__(self):
        if (self.elevation_start_m is None) != (self.elevation_end_m is None):
            raise InputError(f"penstock.segments.elevation_start_m and elevation_end_m go together "
                             f"(the pipe axis above the tailwater datum, m); "
                             f"got {self.elevation_start_m!r} and {self.elevation_end_m!r}")
        for key in ("elevation_start_m", "elevation_end_m"):
            if getattr(self, key) is not None:
                check_number(f"penstock.segments.{key}", getattr(self, key), low=-3000.0, high=3000.0)
        check_number("penstock.segments.length_m", self.length_m, low=0.0, high=1e5, low_open=True)
        check_number("penstock.segments.diameter_m", self.diameter_m, low=0.0, high=30.0, low_open=True)
        try:
            check_number("penstock.segments.wave_speed_m_s", self.wave_speed_m_s, low=WAVE_SPEED_MIN_M_S,
                         high=1600.0)
        except InputError as exc:
            raise InputError(f"{exc} (m/s): pressure waves in water conduits travel at about 100 (air-laden water, "
                             f"soft pipes) to 1500 m/s (steel penstocks, rock tunnels about 1000-1400); give the "
                             f"wave speed in m/s") from None
        check_number("penstock.segments.darcy_friction", self.darcy_friction, low=0.0, high=0.2)

    @property
    def area_m2(self) -> float:
        return math.pi * self.diameter_m ** 2 / 4.0

    @property
    def travel_time_s(self) -> float:
        return self.length_m / self.wave_speed_m_s


#: The largest ``penstock.reaches``.
MAX_REACHES = 10000


@dataclass(frozen=True)
class PenstockConfig:
    """Penstock from the upper reservoir to the turbine inlet.

    ``static_head_m`` is the reservoir level above tailwater; heads are piezometric above tailwater, so the head
    at the turbine inlet is the turbine's net head (draft-tube losses and velocity head neglected).
    ``reaches`` is the number of MOC reaches of the segment with the shortest travel time; the time step is that
    travel time divided by ``reaches`` (Courant number 1). ``lumped_alpha`` is alpha in the lumped model
    h = -Tw s / (1 + alpha Te^2 s^2) q (default 4/pi^2 puts its resonance on the pipe's first mode, pi a / (2 L)).
    ``zdomain_feedback`` is F of eq. (17) of the BP hill-chart paper (default 0: lossless characteristic line).
    """

    model: str
    static_head_m: float
    reaches: int
    segments: tuple[PenstockSegment, ...]
    lumped_alpha: float = 4.0 / math.pi ** 2
    zdomain_feedback: float = 0.0

    def __post_init__(self):
        check_choice("penstock.model", self.model, PENSTOCKS.names())
        check_number("penstock.static_head_m", self.static_head_m, low=0.0, high=3000.0, low_open=True)
        check_int("penstock.reaches", self.reaches, 1, MAX_REACHES)
        check_number("penstock.lumped_alpha", self.lumped_alpha, low=0.0, high=10.0, low_open=True)
        check_number("penstock.zdomain_feedback", self.zdomain_feedback, low=0.0, high=100.0)
        if not isinstance(self.segments, tuple) or not self.segments or not all(
                isinstance(s, PenstockSegment) for s in self.segments):
            raise InputError(f"penstock.segments must be a non-empty list of segments, got {self.segments!r}")

    @property
    def length_m(self) -> float:
        return sum(s.length_m for s in self.segments)

    @property
    def travel_time_s(self) -> float:
        """One-way wave travel time L/a summed over the segments, s."""
        return sum(s.travel_time_s for s in self.segments)

    @property
    def inertance_s2_m2(self) -> float:
        """sum L_i / (g A_i), s^2/m^2: head (m) = inertance * dQ/dt (m^3/s^2)."""
        from hillchart.constants import G_M_S2
        return sum(s.length_m / (G_M_S2 * s.area_m2) for s in self.segments)

    @property
    def friction_coefficient_s2_m5(self) -> float:
        """K of the steady friction loss K Q|Q| = sum f L / (2 g D A^2), s^2/m^5."""
        from hillchart.constants import G_M_S2
        return sum(s.darcy_friction * s.length_m / (2.0 * G_M_S2 * s.diameter_m * s.area_m2 ** 2)
                   for s in self.segments)

    def water_time_s(self, rated_flow_m3_s: float, rated_head_m: float) -> float:
        """Water inertia time Tw = sum L_i Q_r / (g A_i H_r), s (eq. (18) of the BP hill-chart paper)."""
        return self.inertance_s2_m2 * rated_flow_m3_s / rated_head_m

    @property
    def moc_time_step_s(self) -> float:
        """Shortest segment travel time / reaches, s (the default time step of every model)."""
        return min(s.travel_time_s for s in self.segments) / self.reaches


#: Keys of ``[generator]`` that only ``model = "subtransient"`` takes (paper 001 eq. (10), Table 1).
SUBTRANSIENT_KEYS = ("xd", "xd_t", "xd_st", "xq", "xq_st", "td0_t_s", "td0_st_s", "tq0_st_s", "rated_mva",
                     "power_factor", "ra")


@dataclass(frozen=True)
class GeneratorConfig:
    """Rotor and load: ``inertia_time_s`` Ta = J w_r^2 / P_r; ``self_regulation`` e_g (per unit torque per unit
    speed) of the connected load, active only while the breaker is closed.

    ``model``: the shaft component (registry :data:`simulate.components.registry.SHAFTS`): ``"swing"`` (default, the
    swing equation with load self-regulation) or ``"subtransient"`` (paper 001's machine, eq. (10), with
    ``[excitation]`` and ``[grid]``; its keys :data:`SUBTRANSIENT_KEYS` are required then (``ra`` optional) and
    rejected otherwise; the load's frequency dependence is ``grid.frequency_p``, so ``self_regulation`` must be 0).
    """

    inertia_time_s: float
    self_regulation: float = 0.0
    model: str = "swing"
    xd: float | None = None
    xd_t: float | None = None
    xd_st: float | None = None
    xq: float | None = None
    xq_st: float | None = None
    td0_t_s: float | None = None
    td0_st_s: float | None = None
    tq0_st_s: float | None = None
    rated_mva: float | None = None
    power_factor: float | None = None
    ra: float | None = None

    def __post_init__(self):
        from simulate.components.registry import SHAFTS

        check_choice("generator.model", self.model, SHAFTS.names())
        check_number("generator.inertia_time_s", self.inertia_time_s, low=0.0, high=100.0, low_open=True)
        check_number("generator.self_regulation", self.self_regulation, low=0.0, high=20.0)
        given = [k for k in SUBTRANSIENT_KEYS if getattr(self, k) is not None]
        if self.model != "subtransient":
            if given:
                raise InputError(f"generator.{given[0]} is a key of generator.model = \"subtransient\"; with model = "
                                 f"{self.model!r} the [generator] keys are inertia_time_s, self_regulation, model")
            return
        missing = [k for k in SUBTRANSIENT_KEYS if k != "ra" and getattr(self, k) is None]
        if missing:
            raise InputError(f"missing required key generator.{missing[0]} for generator.model = \"subtransient\"; "
                             f"it needs {', '.join(k for k in SUBTRANSIENT_KEYS if k != 'ra')} (ra optional)")
        if self.self_regulation != 0.0:
            raise InputError(f"generator.self_regulation = {self.self_regulation!r}: with generator.model = "
                             f"\"subtransient\" the load's frequency dependence is grid.frequency_p (island) and the "
                             f"rotor takes the air-gap torque; set self_regulation = 0 or leave it out")
        self.subtransient  # validates the machine (ordering X''d < X'd < Xd, ...)

    @property
    def subtransient(self):
        """:class:`simulate.components.electrical.generator.SubtransientGeneratorConfig` of the sub-transient keys
        (model "subtransient")."""
        from simulate.components.electrical.generator import SubtransientGeneratorConfig

        if self.model != "subtransient":
            raise InputError(f"generator.model = {self.model!r} has no sub-transient machine")
        keys = {k: getattr(self, k) for k in SUBTRANSIENT_KEYS if getattr(self, k) is not None}
        return SubtransientGeneratorConfig(**keys)


#: The smallest ``solver.tolerance``: the turbine boundary accepts a head within max(tolerance x rated head,
#: :data:`simulate.components.turbine.boundary.ROUNDOFF_TOLERANCE` x (|C_L| + |k Q|)), and |C_L| is about the head.
TOLERANCE_FLOOR = 64 * 2.220446049250313e-16


@dataclass(frozen=True)
class SolverConfig:
    """Time step and the turbine-boundary (pressure-loop) solver.

    ``dt_s`` defaults to the MOC step (shortest travel time / reaches); with ``model = "moc"`` it must equal it
    within a relative 1e-5 (the step hillsim prints with 6 significant digits passes; the run takes the exact step).
    ``output_dt_s`` (optional, a whole multiple of dt) stores every n-th step only (long runs). A run whose
    steps x nodes exceed ``max_node_steps`` (default 3e10, about 100 s of loop) or whose stored series exceed
    ``max_output_mb`` (default 2000) is refused before it starts, with the estimate.
    ``tolerance`` is on the head residual as a fraction of the rated head. ``relaxation`` alpha is used by the
    traditional and improved loops (xi <- alpha D_h(xi) + (1 - alpha) xi). ``fallback`` (default true): a step the
    loop does not solve is retried with half the relaxation, then by Newton, before the run fails (false: the loop
    alone, as the paper states it). ``substeps`` (optional): sub-steps per step of the controls and the shaft
    (default: chosen from their time scales, see :mod:`simulate.loop.timestep`).
    """

    dt_s: float | None = None
    pressure_loop: str = "improved"
    tolerance: float = 1e-10
    max_iterations: int = 50
    relaxation: float = 1.0
    output_dt_s: float | None = None
    max_node_steps: float = 3e10
    max_output_mb: float = 2000.0
    fallback: bool = True
    substeps: int | None = None

    def __post_init__(self):
        if self.dt_s is not None:
            check_number("solver.dt_s", self.dt_s, low=0.0, high=10.0, low_open=True)
        if self.output_dt_s is not None:
            check_number("solver.output_dt_s", self.output_dt_s, low=0.0, high=1e4, low_open=True)
        check_number("solver.max_node_steps", self.max_node_steps, low=0.0, high=1e15, low_open=True)
        check_number("solver.max_output_mb", self.max_output_mb, low=0.0, high=1e7, low_open=True)
        check_choice("solver.pressure_loop", self.pressure_loop, PRESSURE_LOOPS)
        check_number("solver.tolerance", self.tolerance, low=0.0, high=1e-2, low_open=True)
        if self.tolerance < TOLERANCE_FLOOR:
            raise InputError(f"solver.tolerance = {self.tolerance!r} is below {TOLERANCE_FLOOR:.4g} (64 machine "
                             f"epsilons), the round-off floor of the head residual as a fraction of the rated head: "
                             f"no step can be solved closer, so the loop would use the floor; set solver.tolerance in "
                             f"[{TOLERANCE_FLOOR:.4g}, 0.01] (default 1e-10)")
        check_int("solver.max_iterations", self.max_iterations, 1, 100000)
        check_number("solver.relaxation", self.relaxation, low=0.0, high=1.0, low_open=True)
        if self.substeps is not None:
            check_int("solver.substeps", self.substeps, 1, 10000)
        if not isinstance(self.fallback, bool):
            raise InputError(f"solver.fallback must be true or false, got {self.fallback!r}")


@dataclass(frozen=True)
class SurgeTankConfig:
    """Headrace tunnel (rigid water column, reservoir -> tank) and a simple throttled surge tank at the penstock inlet.

    ``area_m2`` tank cross-section A_s; ``throttle_loss_coefficient`` R of the throttle loss R Q_s|Q_s| (s^2/m^5,
    Q_s the flow into the tank; 0 allowed); ``tunnel_length_m`` L, ``tunnel_diameter_m`` D, ``tunnel_darcy_friction``
    f (0 allowed); ``level_max_m`` (optional) overflow crest above the static level: reaching it is a warning;
    ``level_min_m`` (optional, negative) tank bottom below the static level: reaching it is an error (air enters the
    penstock).
    """

    area_m2: float
    throttle_loss_coefficient: float
    tunnel_length_m: float
    tunnel_diameter_m: float
    tunnel_darcy_friction: float
    level_max_m: float | None = None
    level_min_m: float | None = None

    def __post_init__(self):
        check_number("surge_tank.area_m2", self.area_m2, low=0.0, high=1e5, low_open=True)
        check_number("surge_tank.throttle_loss_coefficient", self.throttle_loss_coefficient, low=0.0, high=1e4)
        check_number("surge_tank.tunnel_length_m", self.tunnel_length_m, low=0.0, high=1e5, low_open=True)
        check_number("surge_tank.tunnel_diameter_m", self.tunnel_diameter_m, low=0.0, high=30.0, low_open=True)
        check_number("surge_tank.tunnel_darcy_friction", self.tunnel_darcy_friction, low=0.0, high=0.2)
        if self.level_max_m is not None:
            check_number("surge_tank.level_max_m", self.level_max_m, low=0.0, high=1e4, low_open=True)
        if self.level_min_m is not None:
            check_number("surge_tank.level_min_m", self.level_min_m, low=-1e4, high=0.0, high_open=True)

    @property
    def tunnel_area_m2(self) -> float:
        return math.pi * self.tunnel_diameter_m ** 2 / 4.0

    @property
    def steady_loss_coefficient_s2_m5(self) -> float:
        """K_t = f L / (2 g D A_t^2) of the tunnel's steady loss K_t Q|Q| (the throttle passes no steady flow)."""
        from hillchart.constants import G_M_S2
        return self.tunnel_darcy_friction * self.tunnel_length_m / (2.0 * G_M_S2 * self.tunnel_diameter_m
                                                                     * self.tunnel_area_m2 ** 2)

    def time_constants(self) -> dict:
        """Time constants the simulation step must resolve (see :mod:`simulate.loop.guards`)."""
        return {"surge tank period 2 pi sqrt(L A_s / (g A_t)) (surge_tank.area_m2, tunnel_length_m, "
                "tunnel_diameter_m)": self.period_s}

    @property
    def period_s(self) -> float:
        """Mass-oscillation period 2 pi sqrt(L A_s / (g A_t)) of the frictionless tank, s."""
        from hillchart.constants import G_M_S2
        return 2.0 * math.pi * math.sqrt(self.tunnel_length_m * self.area_m2 / (G_M_S2 * self.tunnel_area_m2))


#: Sections of the plant a unit may override, key by key (``[units.turbine]`` ...).
UNIT_OVERRIDE_SECTIONS = ("turbine", "generator", "governor")


@dataclass(frozen=True)
class UnitConfig:
    """One unit of a plant with several units (``[[units]]``): its branch from the manifold at the downstream end of
    ``[penstock]`` (the common conduit) to its turbine, and its turbine, generator and governor.

    ``name``: the unit's name in the output columns (``U1.speed_rpm``) and in ``scenario.units``: letters, digits,
    ``_`` and ``-``. ``branch``: the pipe segments from the manifold to the turbine (``[[units.branch]]``, the keys of
    ``[[penstock.segments]]``, upstream first), computed by the method of characteristics on the plant's grid.
    ``[units.turbine]``, ``[units.generator]``, ``[units.governor]`` (optional): keys that differ from the plant's
    ``[turbine]``, ``[generator]``, ``[governor]`` for this unit (the resolved sections are stored here).
    ``initial_power_mw`` / ``initial_opening`` (optional): this unit's initial point instead of the scenario's.
    """

    name: str
    branch: tuple[PenstockSegment, ...]
    turbine: TurbineConfig
    generator: GeneratorConfig
    governor: GovernorConfig
    initial_power_mw: float | None = None
    initial_opening: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name or not all(c.isalnum() or c in "_-" for c in self.name):
            raise InputError(f"units.name must be a non-empty name of letters, digits, _ and -, got {self.name!r}")
        if not isinstance(self.branch, tuple) or not self.branch or not all(
                isinstance(s, PenstockSegment) for s in self.branch):
            raise InputError(f"units.branch of unit {self.name!r} must be a non-empty array of tables "
                             f"[[units.branch]] (keys of [[penstock.segments]]), got {self.branch!r}")
        if self.initial_power_mw is not None and self.initial_opening is not None:
            raise InputError(f"unit {self.name!r}: give at most one of units.initial_power_mw and "
                             f"units.initial_opening, got {self.initial_power_mw!r} and {self.initial_opening!r}")
        if self.initial_power_mw is not None:
            check_number(f"units.initial_power_mw (unit {self.name!r})", self.initial_power_mw, low=0.0,
                         high=1.5 * self.turbine.rated_power_mw)
        if self.initial_opening is not None:
            check_number(f"units.initial_opening (unit {self.name!r})", self.initial_opening,
                         low=self.governor.stroke_min, high=self.governor.stroke_max)
        if self.generator.model != "swing":
            raise InputError(f"unit {self.name!r}: generator.model = {self.generator.model!r}; a plant with "
                             f"[[units]] takes generator.model = \"swing\" (one machine per unit on its own load)")

    def branch_penstock(self, penstock: "PenstockConfig") -> "PenstockConfig":
        """The branch as a MOC :class:`PenstockConfig` (the common conduit's ``reaches``; the manifold head as its
        upstream head)."""
        return PenstockConfig(model="moc", static_head_m=penstock.static_head_m, reaches=penstock.reaches,
                              segments=self.branch)


DRAFT_TUBE_MODELS = ("moc", "rigid")


@dataclass(frozen=True)
class DraftTubeConfig:
    """``[draft_tube]``: the conduit from the runner outlet to the tailwater.

    ``model`` ``"moc"`` or ``"rigid"``; ``[[draft_tube.segments]]`` with the penstock's segment keys
    (``length_m``, ``diameter_m``, ``wave_speed_m_s``, ``darcy_friction``), runner outlet first;
    ``atmospheric_pressure_head_m`` (m of water, 10.33 at sea level); ``runner_elevation_m`` the runner outlet above
    the tailwater level (m, negative below it); ``vapour_pressure_head_m`` (m of water, 0.24 at 20 C);
    ``vapour_margin_m``: warn when the outlet pressure head falls below vapour pressure head + this margin (m).
    The component: :mod:`simulate.components.hydraulic.draft_tube`.
    """

    model: str
    segments: tuple
    atmospheric_pressure_head_m: float = 10.33
    runner_elevation_m: float = 0.0
    vapour_pressure_head_m: float = 0.24
    vapour_margin_m: float = 2.0

    def __post_init__(self):
        check_choice("draft_tube.model", self.model, DRAFT_TUBE_MODELS)
        segs = self.segments
        if not isinstance(segs, (list, tuple)) or not segs:
            raise InputError(f"draft_tube.segments must be a non-empty array of tables [[draft_tube.segments]], "
                             f"got {segs!r}")
        objs = []
        keys = ("length_m", "diameter_m", "wave_speed_m_s", "darcy_friction")
        for i, seg in enumerate(segs):
            if isinstance(seg, PenstockSegment):
                objs.append(seg)
                continue
            if not isinstance(seg, dict):
                raise InputError(f"draft_tube.segments[{i}] must be a table, got {seg!r}")
            unknown = sorted(set(seg) - set(keys))
            missing = [k for k in keys if k not in seg]
            if unknown or missing:
                what = f"unknown key {unknown[0]}" if unknown else f"missing key {missing[0]}"
                raise InputError(f"draft_tube.segments[{i}]: {what}; a segment needs {', '.join(keys)}")
            try:
                objs.append(PenstockSegment(**seg))
            except InputError as exc:
                raise InputError(str(exc).replace("penstock.", "draft_tube.") + f" (segment {i})") from None
        object.__setattr__(self, "segments", tuple(objs))
        check_number("draft_tube.atmospheric_pressure_head_m", self.atmospheric_pressure_head_m, low=0.0, high=20.0)
        check_number("draft_tube.runner_elevation_m", self.runner_elevation_m, low=-100.0, high=20.0)
        check_number("draft_tube.vapour_pressure_head_m", self.vapour_pressure_head_m, low=0.0, high=20.0)
        check_number("draft_tube.vapour_margin_m", self.vapour_margin_m, low=0.0, high=50.0)

    def mirrored(self):
        """The conduit as a :class:`simulate.config.PenstockConfig` from the tailwater to the runner outlet."""
        return PenstockConfig(model=self.model, static_head_m=1.0, reaches=1, segments=tuple(reversed(self.segments)))

    @property
    def friction_coefficient_s2_m5(self) -> float:
        """K of the steady loss K Q|Q| from the runner outlet to the tailwater, s^2/m^5."""
        return self.mirrored().friction_coefficient_s2_m5


#: ``combinator.head_m`` may lie from this[0] x ``turbine.rated_head_m`` to this[1] x ``penstock.static_head_m``.
COMBINATOR_HEAD_RANGE = (0.25, 1.5)


@dataclass(frozen=True)
class PlantConfig:
    """The whole plant file. ``base_dir`` resolves a relative ``turbine.characteristics`` path."""

    turbine: TurbineConfig
    penstock: PenstockConfig
    generator: GeneratorConfig
    governor: GovernorConfig
    scenario: ScenarioConfig
    solver: SolverConfig = field(default_factory=SolverConfig)
    base_dir: Path = Path(".")
    surge_tank: SurgeTankConfig | None = None
    excitation: Any = None  # simulate.components.control.excitation.ExcitationConfig (generator.model = "subtransient")
    grid: Any = None  # simulate.components.electrical.generator.GridConfig (generator.model = "subtransient")
    units: tuple[UnitConfig, ...] = ()
    blade_servo: Any = None  # simulate.components.control.blade_servo.BladeServoConfig (double-regulated units)
    combinator: Any = None  # simulate.components.control.blade_servo.CombinatorConfig (double-regulated units)
    draft_tube: DraftTubeConfig | None = None

    def __post_init__(self):
        sc, gov = self.scenario, self.governor
        self._check_units()
        electrical = [name for name in ("excitation", "grid") if getattr(self, name) is not None]
        if self.generator.model == "subtransient":
            for name in ("excitation", "grid"):
                if getattr(self, name) is None:
                    raise InputError(f"missing section [{name}]: generator.model = \"subtransient\" needs [excitation] "
                                     f"and [grid]")
        elif electrical:
            raise InputError(f"section [{electrical[0]}] is used only by generator.model = \"subtransient\" (got "
                             f"generator.model = {self.generator.model!r})")
        sc.check_plant(self)
        self._check_combinator_head()
        if sc.initial_opening is not None and not (gov.stroke_min <= sc.initial_opening <= gov.stroke_max):
            raise InputError(f"scenario.initial_opening must be in [governor.stroke_min, governor.stroke_max] = "
                             f"[{gov.stroke_min!r}, {gov.stroke_max!r}], got {sc.initial_opening!r}")
        if sc.initial_power_mw is not None and sc.initial_power_mw > 1.5 * self.turbine.rated_power_mw:
            raise InputError(f"scenario.initial_power_mw must be in [0, 1.5 * turbine.rated_power_mw] = "
                             f"[0, {1.5 * self.turbine.rated_power_mw!r}], got {sc.initial_power_mw!r}")

    def _check_combinator_head(self) -> None:
        """``combinator.head_m`` within the plant's heads: from a quarter of the rated head (a low-head unit at
        flood) to 1.5 x the static head (the gross head, which the net head stays below)."""
        head = getattr(self.combinator, "head_m", None)
        if head is None:
            return
        low, high = COMBINATOR_HEAD_RANGE[0] * self.turbine.rated_head_m, \
            COMBINATOR_HEAD_RANGE[1] * self.penstock.static_head_m
        if not low <= head <= high:
            raise InputError(f"combinator.head_m = {head!r} m is outside this plant's heads (turbine.rated_head_m = "
                             f"{self.turbine.rated_head_m!r} m, penstock.static_head_m = "
                             f"{self.penstock.static_head_m!r} m); allowed [{low:.4g}, {high:.4g}] m "
                             f"({COMBINATOR_HEAD_RANGE[0]:g} x the rated head "
                             f"to {COMBINATOR_HEAD_RANGE[1]:g} x the static head): give the net head in m of this "
                             f"plant, or leave head_m out (the net head of the initial steady state)")

    def _check_units(self) -> None:
        """The ``[[units]]`` against the rest of the plant (names unique, ``scenario.units`` known, MOC conduit)."""
        sc = self.scenario
        if not self.units:
            if sc.units is not None:
                raise InputError(f"scenario.units = {list(sc.units)!r} needs a plant with [[units]]; this plant has "
                                 f"one unit (leave scenario.units out)")
            return
        names = [u.name for u in self.units]
        duplicate = sorted({n for n in names if names.count(n) > 1})
        if duplicate:
            raise InputError(f"units.name {duplicate[0]!r} is given twice; unit names must be unique, got {names!r}")
        for name in sc.units or ():
            if name not in names:
                raise InputError(f"scenario.units names {name!r}, which is not a unit of this plant; the units are "
                                 f"{', '.join(names)}")
        if not PENSTOCKS.traits(self.penstock.model).computes_branches:
            raise InputError(f"penstock.model = {self.penstock.model!r}: a plant with [[units]] computes the common "
                             f"conduit and the branches by the method of characteristics; set penstock.model = "
                             f"\"moc\"")
        if self.generator.model != "swing":
            raise InputError(f"generator.model = {self.generator.model!r}: a plant with [[units]] takes "
                             f"generator.model = \"swing\"")
        if self.solver.dt_s is not None:
            raise InputError(f"solver.dt_s = {self.solver.dt_s!r}: a plant with [[units]] steps on the grid of its "
                             f"pipes ((shortest travel time) / penstock.reaches); leave solver.dt_s out")
        if sc.initial_power_mw is not None:
            for u in self.units:
                if u.initial_power_mw is None and u.initial_opening is None \
                        and sc.initial_power_mw > 1.5 * u.turbine.rated_power_mw:
                    raise InputError(f"scenario.initial_power_mw = {sc.initial_power_mw!r} is each unit's initial "
                                     f"power; unit {u.name!r} is rated {u.turbine.rated_power_mw!r} MW (at most "
                                     f"1.5 x that): set units.initial_power_mw of that unit")

    def require_one_unit(self, what: str) -> None:
        """An :class:`InputError` when the plant has ``[[units]]``: ``what`` (a command or a study) models one unit."""
        if self.units:
            raise InputError(f"{what} models a plant with one unit; this plant has [[units]] "
                             f"({', '.join(u.name for u in self.units)}): give a plant file without [[units]] (one "
                             f"unit's [turbine], [generator], [governor] and its waterway as [[penstock.segments]])")

    @property
    def event_units(self) -> tuple[str, ...]:
        """Names of the units the scenario's event applies to (``scenario.units``, default all; empty without
        ``[[units]]``)."""
        if not self.units:
            return ()
        return tuple(self.scenario.units) if self.scenario.units is not None else tuple(u.name for u in self.units)

    def unit_plant(self, unit: UnitConfig) -> "PlantConfig":
        """The single-unit view of ``unit``: its turbine, generator and governor, its branch as the penstock (the
        builders of the control and shaft components read a plant); the scenario's initial point replaced by the
        unit's own when it has one."""
        sc = self.scenario
        if unit.initial_power_mw is not None:
            sc = replace(sc, initial_power_mw=unit.initial_power_mw, initial_opening=None, units=None)
        elif unit.initial_opening is not None:
            sc = replace(sc, initial_power_mw=None, initial_opening=unit.initial_opening, units=None)
        else:
            sc = replace(sc, units=None)
        return replace(self, turbine=unit.turbine, generator=unit.generator, governor=unit.governor,
                       penstock=unit.branch_penstock(self.penstock), scenario=sc, units=())

    @property
    def time_step_s(self) -> float:
        """The simulation step, s (checked against the Courant condition for MOC). With ``[[units]]``: the
        shortest travel time of every pipe (common conduit and branches) divided by ``penstock.reaches``."""
        moc_dt = self.penstock.moc_time_step_s
        if self.units:
            moc_dt = min([moc_dt] + [u.branch_penstock(self.penstock).moc_time_step_s for u in self.units])
        if self.solver.dt_s is None:
            if not (math.isfinite(moc_dt) and moc_dt > 0.0):
                raise InputError(f"the time step (shortest travel time)/penstock.reaches = {moc_dt!r} s is not a "
                                 f"positive number: check penstock lengths and wave speeds")
            return moc_dt
        if PENSTOCKS.traits(self.penstock.model).grid_fixes_time_step:
            if abs(self.solver.dt_s - moc_dt) > COURANT_TOLERANCE * moc_dt:
                raise InputError(
                    f"solver.dt_s = {self.solver.dt_s!r} s does not meet the MOC Courant condition: with "
                    f"penstock.reaches = {self.penstock.reaches} the step must be (shortest travel time)/reaches = "
                    f"{moc_dt!r} s (within a relative {COURANT_TOLERANCE:g}); omit solver.dt_s or change "
                    f"penstock.reaches")
            return moc_dt  # the grid's own step: the value hillsim prints, read back, runs the same as none
        return self.solver.dt_s

    @property
    def electrical(self):
        """:class:`simulate.components.electrical.generator.ElectricalConfig` of ``[generator]``, ``[excitation]``,
        ``[grid]`` (model "subtransient"; None for the swing model)."""
        if self.generator.model != "subtransient":
            return None
        from simulate.components.electrical.generator import ElectricalConfig

        return ElectricalConfig(generator=self.generator.subtransient, excitation=self.excitation, grid=self.grid)

    def rotor_self_regulation(self, load_pu: float) -> float:
        """e_g of the rotor's load (per unit of rated torque per unit speed) at a load of ``load_pu`` (rated torque
        units), for the linear models: ``generator.self_regulation`` with the swing model; with the sub-transient
        generator on an island ``grid.frequency_p * load_pu`` (the air-gap power P0 (1 + frequency_p x) with the
        voltage held at its set point by the excitation, which settles much faster than the rotor). On an infinite
        bus the rotor sees a synchronizing torque, which the linear models do not have: :class:`InputError`."""
        if self.generator.model != "subtransient":
            return self.generator.self_regulation
        if self.grid.kind != "island":
            raise InputError(f"grid.kind = {self.grid.kind!r}: the linear turbine models have no synchronizing torque; "
                             f"linearize with grid.kind = 'island' or generator.model = 'swing'")
        return self.grid.island_frequency_p * float(load_pu)

    def with_overrides(self, overrides: dict[str, Any]) -> "PlantConfig":
        """A copy with ``{"section.key": value}`` replaced, validated like the file (see :func:`plant_from_dict`).

        Keys of the sections read from one table of scalars are replaced in place (:func:`dataclasses.replace`,
        which validates each section and the plant as the file does: a batch makes one variant per case, and the
        whole dictionary round trip costs ten times as much); anything else (a list, a switch of scenario kind, an
        optional section, several units, an unknown key) takes the file's path."""
        replaced = self._replaced(overrides)
        if replaced is not None:
            return replaced
        raw = to_dict(self)
        apply_overrides(raw, overrides)
        return plant_from_dict(raw, base_dir=self.base_dir)

    def _replaced(self, overrides: dict[str, Any]) -> "PlantConfig | None":
        """:meth:`with_overrides` by :func:`dataclasses.replace`, or None where the file's path is needed."""
        if self.units or not isinstance(overrides, dict):
            return None
        changes: dict[str, dict[str, Any]] = {}
        for dotted, value in overrides.items():
            if not isinstance(dotted, str) or dotted.count(".") != 1 or isinstance(value, (list, tuple, dict)):
                return None
            section, key = dotted.split(".")
            spec = _SCALAR_FIELDS.get(section, {}).get(key)
            if spec is None or (section, key) in _REBUILT_KEYS:
                return None
            if value is None:  # the file's path removes the key: its default, when it has one
                if spec.default is MISSING:
                    return None
                value = spec.default
            changes.setdefault(section, {})[key] = value
        return replace(self, **{name: replace(getattr(self, name), **kv) for name, kv in changes.items()})


def __getattr__(name: str):
    """``PENSTOCK_MODELS``: the penstock registry's names at the time of the call (a component registered after this
    module was imported is included)."""
    if name == "PENSTOCK_MODELS":
        return PENSTOCKS.names()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


_SECTIONS = {
    "turbine": TurbineConfig,
    "penstock": PenstockConfig,
    "generator": GeneratorConfig,
    "governor": GovernorConfig,
    "scenario": ScenarioConfig,
    "solver": SolverConfig,
    "surge_tank": SurgeTankConfig,
    # imported only when the section is present
    "excitation": "simulate.components.control.excitation:ExcitationConfig",
    "grid": "simulate.components.electrical.generator:GridConfig",
    "units": UnitConfig,  # an array of tables [[units]]
    "blade_servo": "simulate.components.control.blade_servo:BladeServoConfig",
    "combinator": "simulate.components.control.blade_servo:CombinatorConfig",
    "draft_tube": DraftTubeConfig,
}


#: Fields of the sections that :meth:`PlantConfig.with_overrides` may replace in place (one table of scalars each).
_SCALAR_FIELDS = {name: {f.name: f for f in fields(cls)} for name, cls in
                  (("turbine", TurbineConfig), ("penstock", PenstockConfig), ("generator", GeneratorConfig),
                   ("governor", GovernorConfig), ("scenario", ScenarioConfig), ("solver", SolverConfig))}
#: Keys whose change rebuilds more than their own field: the segments (an array of tables) and the scenario kind
#: (it drops the keys the new kind does not use).
_REBUILT_KEYS = {("penstock", "segments"), ("scenario", "kind")}


def _section_class(name: str):
    cls = _SECTIONS[name]
    if isinstance(cls, str):
        import importlib

        module, attr = cls.split(":")
        cls = getattr(importlib.import_module(module), attr)
    return cls
_SEGMENT_KEYS = tuple(f.name for f in fields(PenstockSegment))
_SEGMENT_REQUIRED = tuple(f.name for f in fields(PenstockSegment) if f.default is MISSING)


def _build(section: str, cls, raw: Any, extra_keys: tuple[str, ...] = ()):
    if not isinstance(raw, dict):
        raise InputError(f"[{section}] must be a table of keys, got {raw!r}")
    names = [f.name for f in fields(cls) if f.name not in extra_keys]
    required = [f.name for f in fields(cls) if f.default is MISSING and f.default_factory is MISSING
                and f.name not in extra_keys]
    unknown = sorted(set(raw) - set(names))
    if unknown:
        raise InputError(f"unknown key {section}.{unknown[0]}; valid keys of [{section}]: {', '.join(names)}")
    missing = [k for k in required if k not in raw]
    if missing:
        raise InputError(f"missing required key {section}.{missing[0]}; [{section}] needs {', '.join(required)}")
    return {k: raw[k] for k in names if k in raw}


def _segments(segs: Any, key: str) -> list[PenstockSegment]:
    """Pipe segments from an array of tables at ``key`` (``penstock.segments`` or ``units.branch``), validated."""
    table = "[[" + key + "]]"
    if not isinstance(segs, list) or not segs:
        raise InputError(f"{key} must be a non-empty array of tables {table}, got {segs!r}")
    seg_objs = []
    for i, seg in enumerate(segs):
        if not isinstance(seg, dict):
            raise InputError(f"{key}[{i}] must be a table, got {seg!r}")
        unknown = sorted(set(seg) - set(_SEGMENT_KEYS))
        if unknown:
            raise InputError(f"unknown key {key}.{unknown[0]} (segment {i}); valid keys: "
                             f"{', '.join(_SEGMENT_KEYS)}")
        missing = [k for k in _SEGMENT_REQUIRED if k not in seg]
        if missing:
            raise InputError(f"missing required key {key}.{missing[0]} (segment {i}); a segment "
                             f"needs {', '.join(_SEGMENT_REQUIRED)}")
        try:
            seg_objs.append(PenstockSegment(**seg))
        except InputError as exc:
            raise InputError(f"{str(exc).replace('penstock.segments', key)} (segment {i}, counted from 0 upstream "
                             f"first)") from None
    profiles = [s.elevation_start_m is not None for s in seg_objs]
    if any(profiles) and not all(profiles):
        raise InputError(f"{key}: elevation_start_m/elevation_end_m must be given on every segment or on "
                         f"none; segment {profiles.index(False)} has none")
    for i in range(1, len(seg_objs) if all(profiles) else 0):
        if abs(seg_objs[i].elevation_start_m - seg_objs[i - 1].elevation_end_m) > 1e-9:
            raise InputError(f"{key}: segment {i} starts at elevation {seg_objs[i].elevation_start_m!r} m "
                             f"but segment {i - 1} ends at {seg_objs[i - 1].elevation_end_m!r} m; the profile must be "
                             f"continuous")
    return seg_objs


#: Keys of one ``[[units]]`` table.
UNIT_KEYS = ("name", "branch", *UNIT_OVERRIDE_SECTIONS, "initial_power_mw", "initial_opening")


def _units(raw_units: Any, raw: dict[str, Any]) -> tuple[UnitConfig, ...]:
    """The ``[[units]]`` array of tables, each unit's overrides applied over the plant's sections."""
    if not isinstance(raw_units, list) or not raw_units:
        raise InputError(f"units must be a non-empty array of tables [[units]], got {raw_units!r}")
    out = []
    for i, unit in enumerate(raw_units):
        if not isinstance(unit, dict):
            raise InputError(f"units[{i}] must be a table [[units]], got {unit!r}")
        unknown = sorted(set(unit) - set(UNIT_KEYS))
        if unknown:
            raise InputError(f"unknown key units.{unknown[0]} (unit {i}); valid keys of [[units]]: "
                             f"{', '.join(UNIT_KEYS)}")
        for key in ("name", "branch"):
            if key not in unit:
                raise InputError(f"missing required key units.{key} (unit {i}); a unit needs name and "
                                 f"[[units.branch]]")
        name = unit["name"]
        where = f"unit {name!r}" if isinstance(name, str) else f"unit {i}"
        sections = {}
        for section, cls in (("turbine", TurbineConfig), ("generator", GeneratorConfig),
                             ("governor", GovernorConfig)):
            override = unit.get(section, {})
            if not isinstance(override, dict):
                raise InputError(f"units.{section} ({where}) must be a table [units.{section}] of the keys of "
                                 f"[{section}], got {override!r}")
            merged = dict(raw[section]) | override
            try:
                sections[section] = cls(**_build(section, cls, merged))
            except InputError as exc:
                raise InputError(f"{exc} (in [units.{section}] of {where})") from None
        try:
            branch = tuple(_segments(unit["branch"], "units.branch"))
        except InputError as exc:
            raise InputError(f"{exc} ({where})") from None
        out.append(UnitConfig(name=name, branch=branch, initial_power_mw=unit.get("initial_power_mw"),
                              initial_opening=unit.get("initial_opening"), **sections))
    return tuple(out)


#: Sections of a guarantee study's plant file, which :mod:`simulate.studies.cases` reads; :func:`load_plant` skips
#: them (they are not part of the plant) and :func:`plant_from_dict` names them in its message.
STUDY_SECTIONS = ("limits", "load_cases")


def split_study_sections(raw: dict[str, Any]) -> dict[str, Any]:
    """Take the study sections (:data:`STUDY_SECTIONS`) out of a plant file's TOML document ``raw`` and return
    them, ``{name: value}`` for those present (``raw`` keeps the plant sections).

    Examples
    --------
    >>> raw = {"turbine": {}, "limits": {"max_speed_rise": 0.5}}
    >>> split_study_sections(raw), raw
    ({'limits': {'max_speed_rise': 0.5}}, {'turbine': {}})
    """
    return {name: raw.pop(name) for name in STUDY_SECTIONS if name in raw} if isinstance(raw, dict) else {}


def plant_from_dict(raw: dict[str, Any], *, base_dir: Path | str = ".") -> PlantConfig:
    """Build a :class:`PlantConfig` from the parsed TOML dictionary (strict keys).

    Examples
    --------
    >>> raw = {"turbine": {"rated_head_m": 100.0, "rated_flow_m3_s": 10.0, "rated_speed_rpm": 300.0,
    ...                    "rated_power_mw": 9.0, "runner_diameter_m": 2.0, "opening_max": 1.0,
    ...                    "characteristics": "ideal"},
    ...        "penstock": {"model": "moc", "static_head_m": 100.0, "reaches": 4,
    ...                     "segments": [{"length_m": 400.0, "diameter_m": 2.0, "wave_speed_m_s": 1000.0,
    ...                                   "darcy_friction": 0.0}]},
    ...        "generator": {"inertia_time_s": 8.0, "self_regulation": 0.0},
    ...        "governor": {"kp": 2.0, "ki": 0.5, "kd": 0.0, "derivative_filter_s": 0.0, "permanent_droop": 0.0,
    ...                     "servo_time_s": 0.2, "closing_time_s": 10.0, "opening_time_s": 20.0},
    ...        "scenario": {"kind": "load-rejection", "t_end_s": 20.0, "initial_power_mw": 9.0},
    ...        "solver": {}}
    >>> plant = plant_from_dict(raw)
    >>> plant.time_step_s
    0.1
    >>> raw["penstock"]["reaches"] = 0
    >>> plant_from_dict(raw)
    Traceback (most recent call last):
    ...
    hillchart.errors.InputError: penstock.reaches must be an integer in [1, 10000], got 0
    """
    if not isinstance(raw, dict):
        raise InputError(f"plant file must be a table of sections, got {raw!r}")
    unknown = sorted(set(raw) - set(_SECTIONS))
    if unknown:
        study = ("; [limits] and [[load_cases]] make a guarantee study: read the file with "
                 "simulate.config.load_plant (which skips them) or simulate.studies.cases.load_study (which reads "
                 "them)" if unknown[0] in STUDY_SECTIONS else "")
        raise InputError(f"unknown section [{unknown[0]}]; valid sections: {', '.join(_SECTIONS)}{study}")
    for name in ("turbine", "penstock", "generator", "governor", "scenario"):
        if name not in raw:
            raise InputError(f"missing section [{name}]; a plant file needs turbine, penstock, generator, governor, "
                             f"scenario ([solver], [surge_tank] and [draft_tube] are optional; [excitation] and "
                             f"[grid] go with generator.model = \"subtransient\"; [combinator] and [blade_servo] "
                             f"with three-input characteristics)")
    turbine = TurbineConfig(**_build("turbine", TurbineConfig, raw["turbine"]))
    pen_raw = dict(_build("penstock", PenstockConfig, raw["penstock"]))
    seg_objs = _segments(pen_raw.get("segments"), "penstock.segments")
    pen_raw["segments"] = tuple(seg_objs)
    penstock = PenstockConfig(**pen_raw)
    generator = GeneratorConfig(**_build("generator", GeneratorConfig, raw["generator"]))
    governor = GovernorConfig(**_build("governor", GovernorConfig, raw["governor"]))
    sc_raw = _build("scenario", ScenarioConfig, raw["scenario"])
    for key in ("speed_steps", "opening_steps", "step_times_s", "units"):
        if key in sc_raw and isinstance(sc_raw[key], list):
            sc_raw[key] = tuple(sc_raw[key])
    scenario = ScenarioConfig(**sc_raw)
    solver = SolverConfig(**_build("solver", SolverConfig, raw.get("solver", {})))
    surge_tank = (SurgeTankConfig(**_build("surge_tank", SurgeTankConfig, raw["surge_tank"]))
                  if "surge_tank" in raw else None)
    optional = {}
    for name in ("excitation", "grid", "blade_servo", "combinator", "draft_tube"):
        if name in raw:
            cls = _section_class(name)
            optional[name] = cls(**_build(name, cls, raw[name]))
    if "units" in raw:
        optional["units"] = _units(raw["units"], raw)
    return PlantConfig(turbine=turbine, penstock=penstock, generator=generator, governor=governor,
                       surge_tank=surge_tank, scenario=scenario, solver=solver, base_dir=Path(base_dir), **optional)


def to_dict(plant: PlantConfig) -> dict[str, Any]:
    """The TOML-shaped dictionary of ``plant`` (only keys that differ from their default are kept for scenario)."""
    out: dict[str, Any] = {}
    for name in _SECTIONS:
        obj = getattr(plant, name)
        if obj is None:  # an optional section that is absent
            continue
        if name == "units":
            if obj:
                out["units"] = [_unit_dict(unit, plant) for unit in obj]
            continue
        sec = {}
        for f in fields(obj):
            value = getattr(obj, f.name)
            if name == "scenario" and value == f.default and f.name not in ("kind", "t_end_s"):
                continue
            if name in ("solver", "surge_tank", "generator", "grid", "governor", "blade_servo", "combinator",
                        "draft_tube") and value is None:
                continue
            if name == "turbine" and f.name == "step_up":
                if value is None:
                    continue
                value = value.as_dict()
            elif f.name == "segments":
                value = [{k: getattr(s, k) for k in _SEGMENT_KEYS if getattr(s, k) is not None} for s in value]
            elif isinstance(value, tuple):
                value = list(value)
            sec[f.name] = value
        out[name] = sec
    return out


def _unit_dict(unit: UnitConfig, plant: PlantConfig) -> dict[str, Any]:
    """One ``[[units]]`` table of ``unit``: its keys of turbine, generator and governor that differ from the plant's
    (so an override of the plant's section reaches every unit that does not set the key itself)."""
    out: dict[str, Any] = {"name": unit.name,
                           "branch": [{k: getattr(s, k) for k in _SEGMENT_KEYS if getattr(s, k) is not None}
                                      for s in unit.branch]}
    for section in UNIT_OVERRIDE_SECTIONS:
        obj, common = getattr(unit, section), getattr(plant, section)
        own = {f.name: getattr(obj, f.name) for f in fields(obj)
               if getattr(obj, f.name) is not None and getattr(obj, f.name) != getattr(common, f.name)}
        if isinstance(own.get("step_up"), StepUpConfig):
            own["step_up"] = own["step_up"].as_dict()
        if own:
            out[section] = own
    for key in ("initial_power_mw", "initial_opening"):
        if getattr(unit, key) is not None:
            out[key] = getattr(unit, key)
    return out


def parse_override(text: str) -> tuple[str, Any]:
    """``"section.key=value"`` -> ``("section.key", value)`` with the value parsed as TOML.

    Examples
    --------
    >>> parse_override("penstock.model=\\"rigid\\"")
    ('penstock.model', 'rigid')
    >>> parse_override("scenario.t_end_s=30")
    ('scenario.t_end_s', 30)
    >>> parse_override("solver.pressure_loop=newton")  # a bare word is taken as a string
    ('solver.pressure_loop', 'newton')
    """
    if "=" not in text:
        raise InputError(f"--set expects section.key=value, got {text!r}")
    key, value_text = (s.strip() for s in text.split("=", 1))
    if key.count(".") != 1 or not all(key.split(".")):
        raise InputError(f"--set key must be section.key (e.g. solver.dt_s), got {key!r}")
    try:
        value = tomllib.loads(f"v = {value_text}")["v"]
    except tomllib.TOMLDecodeError:
        if value_text and all(c.isalnum() or c in "-_./" for c in value_text):
            value = value_text  # a bare word: a string such as newton or ideal
        else:
            raise InputError(f"--set {key}: value {value_text!r} is not a TOML value") from None
    return key, value


def apply_overrides(raw: dict[str, Any], overrides: dict[str, Any]) -> None:
    """Set ``raw[section][key] = value`` for each ``"section.key"`` (a ``None`` value removes the key).

    Switching ``scenario.kind`` drops the scenario keys the new kind does not use.
    """
    new_kind = overrides.get("scenario.kind")
    if new_kind in SCENARIO_KEYS and isinstance(raw.get("scenario"), dict):
        keep = set(SCENARIO_KEYS[new_kind]) | {"kind", "t_end_s"}
        raw["scenario"] = {k: v for k, v in raw["scenario"].items() if k in keep}
    for dotted, value in overrides.items():
        if not isinstance(dotted, str) or dotted.count(".") != 1:
            raise InputError(f"override key must be section.key, got {dotted!r}")
        section, key = dotted.split(".", 1)
        if section == "units":
            raise InputError(f"override {dotted!r}: the units are changed in the plant file ([[units]]); an override "
                             f"of [turbine], [generator] or [governor] applies to every unit without its own key")
        if section not in _SECTIONS:
            raise InputError(f"unknown section in override {dotted!r}; valid sections: {', '.join(_SECTIONS)}")
        sec = raw.setdefault(section, {})
        if value is None:
            sec.pop(key, None)
        else:
            sec[key] = value


def load_plant(path: str | Path, overrides: dict[str, Any] | None = None, *,
               skipped: list[str] | None = None) -> PlantConfig:
    """Read a plant TOML file (strict keys), apply ``{"section.key": value}`` overrides, validate.

    A guarantee study's sections (``[limits]``, ``[[load_cases]]``: :data:`STUDY_SECTIONS`) are not part of the plant:
    they are skipped unread (:func:`simulate.studies.cases.load_study` reads and validates them), and their names
    appended to ``skipped`` when given, so a command can say so.

    Raises
    ------
    InputError
        Unknown or missing key, out-of-range value, unreadable file.
    """
    path = Path(path)
    raw, _ = read_plant_toml(path)
    study = split_study_sections(raw)
    if skipped is not None:
        skipped.extend(study)
    if overrides:
        apply_overrides(raw, overrides)
    return plant_from_dict(raw, base_dir=path.resolve().parent)


def read_plant_toml(path: Path) -> tuple[dict, bytes]:
    """The TOML document of a plant file and the file's bytes; a UTF-8 byte-order mark (a Windows editor's) is
    accepted. Every InputError names the file: unreadable, not UTF-8, not TOML, nested beyond reason."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read plant file {str(path)!r}: {exc.strerror}") from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        from hillchart.io.tabular import not_utf8_detail

        raise InputError(f"plant file {str(path)!r} is not UTF-8 text {not_utf8_detail(exc)}") from None
    try:
        return tomllib.loads(text), data
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"plant file {str(path)!r} is not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"plant file {str(path)!r} is not a plant file: arrays or tables nested thousands of "
                         "levels deep") from None


from simulate.components.turbine.component import load_characteristics  # noqa: E402  (the turbine's own)


__all__ = [  # noqa: F822  (PENSTOCK_MODELS: served by the module's __getattr__)
    "PENSTOCK_MODELS", "PRESSURE_LOOPS", "SCENARIO_KINDS", "SCENARIO_KEYS", "TurbineConfig", "PenstockSegment",
    "PenstockConfig", "GeneratorConfig", "GovernorConfig", "ScenarioConfig", "SolverConfig", "UnitConfig",
    "PlantConfig", "plant_from_dict", "to_dict", "parse_override", "apply_overrides", "load_plant",
    "load_characteristics", "replace"]
