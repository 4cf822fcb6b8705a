"""The conduits' plant-file sections: ``[penstock]`` (:class:`PenstockConfig`) and its pipes
``[[penstock.segments]]`` (:class:`PenstockSegment`, also the pipes of ``[[units.branch]]`` and
``[[draft_tube.segments]]``), with every key declared as data (:mod:`simulate.components.parameters`). The models
that compute them are the penstock registry's (:data:`simulate.components.registry.PENSTOCKS`, in
:mod:`simulate.components.hydraulic.penstock`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from hillchart.constants import G_M_S2
from hillchart.errors import InputError
from simulate.components.hydraulic.brunone import BrunoneConfig
from simulate.components.hydraulic.convolution import ConvolutionConfig
from simulate.components.hydraulic.cavitation import (COLUMN_SEPARATION_MODELS, ColumnSeparationConfig,
                                                      axis_elevations_m, vapour_settings)
from simulate.components.hydraulic.cavitation import check_penstock as check_column_separation
from simulate.components.parameters import borrowed, parameter, validate_parameters
from simulate.components.registry import FRICTION, PENSTOCKS

#: The slowest pressure wave in water: a bubbly air-water mixture at atmospheric pressure has its minimum sound
#: speed (Wood's equation, half air by volume) at about 24 m/s; water conduits lie at about 100-1500 m/s.
WAVE_SPEED_MIN_M_S = 20.0
#: The largest ``penstock.reaches``.
MAX_REACHES = 10000
#: ``[penstock]`` keys that one model's run reads (its registry traits' ``reads``); ``lumped_alpha`` also sets the
#: identification's linear reference of every elastic model (:mod:`simulate.identification.linear_reference`), so
#: under another model it is kept and the run warns that it does not read it; ``zdomain_feedback`` is refused.
MODEL_KEYS = ("lumped_alpha", "zdomain_feedback", "friction_model", "column_separation", "water_temperature_c",
              "atmospheric_pressure_head_m", "cavity_weighting", "gas_void_fraction")
KEYS_READ_OUTSIDE_THE_RUN = ("lumped_alpha",)


@dataclass(frozen=True)
class PenstockSegment:
    """One pipe of uniform section; segments are in series, upstream first. ``elevation_start_m`` /
    ``elevation_end_m`` (optional, both or neither, on every segment or none): the pipe axis above the tailwater
    datum of the heads at the segment's ends, for the pressure-head envelope."""

    length_m: float = parameter(unit="m", low=0.0, low_open=True, high=1e5, description="pipe length")
    diameter_m: float = parameter(unit="m", low=0.0, low_open=True, high=30.0, description="inner diameter")
    wave_speed_m_s: float = parameter(
        unit="m/s", low=WAVE_SPEED_MIN_M_S, high=1600.0, description="pressure-wave speed a",
        hint="(m/s): pressure waves in water conduits travel at about 100 (air-laden water, soft pipes) to 1500 m/s "
             "(steel penstocks, rock tunnels about 1000-1400); give the wave speed in m/s")
    darcy_friction: float = parameter(unit="1", low=0.0, high=0.2, description="Darcy-Weisbach friction factor f")
    elevation_start_m: float | None = parameter(None, unit="m", low=-3000.0, high=3000.0,
                                                description="pipe axis above the tailwater datum, upstream end")
    elevation_end_m: float | None = parameter(None, unit="m", low=-3000.0, high=3000.0,
                                              description="pipe axis above the tailwater datum, downstream end")

    def __post_init__(self):
        validate_parameters("penstock.segments", self)
        if (self.elevation_start_m is None) != (self.elevation_end_m is None):
            raise InputError(f"penstock.segments.elevation_start_m and elevation_end_m go together "
                             f"(the pipe axis above the tailwater datum, m); "
                             f"got {self.elevation_start_m!r} and {self.elevation_end_m!r}")

    @property
    def area_m2(self) -> float:
        return math.pi * self.diameter_m ** 2 / 4.0

    @property
    def travel_time_s(self) -> float:
        return self.length_m / self.wave_speed_m_s


#: Keys of a segment; the profile keys (elevations) are refused where a conduit has no profile (the draft tube).
SEGMENT_KEYS = tuple(f.name for f in fields(PenstockSegment))
PROFILE_KEYS = ("elevation_start_m", "elevation_end_m")


def read_segments(segs: Any, key: str, *, profile: bool = True,
                  first: str = "upstream") -> tuple[PenstockSegment, ...]:
    """The pipes of the array of tables at ``key`` (``penstock.segments``, ``units.branch``,
    ``draft_tube.segments``), validated: the one segment reader. A :class:`PenstockSegment` passes as it is;
    ``profile=False`` refuses the elevations (a conduit without a pressure-head profile); ``first`` names the end
    the first segment starts at (for the messages)."""
    table = "[[" + key + "]]"
    if not isinstance(segs, (list, tuple)) or not segs:
        raise InputError(f"{key} must be a non-empty array of tables {table}, got {segs!r}")
    keys = SEGMENT_KEYS if profile else tuple(k for k in SEGMENT_KEYS if k not in PROFILE_KEYS)
    required = tuple(f.name for f in fields(PenstockSegment) if f.default is not None)
    out = []
    for i, seg in enumerate(segs):
        if isinstance(seg, PenstockSegment) and (profile or seg.elevation_start_m is None):
            out.append(seg)
            continue
        if not isinstance(seg, dict):
            raise InputError(f"{key}[{i}] must be a table, got {seg!r}")
        unknown = sorted(set(seg) - set(keys))
        if unknown:
            raise InputError(f"unknown key {key}.{unknown[0]} (segment {i}); valid keys: {', '.join(keys)}")
        missing = [k for k in required if k not in seg]
        if missing:
            raise InputError(f"missing required key {key}.{missing[0]} (segment {i}); a segment needs "
                             f"{', '.join(required)}")
        try:
            out.append(PenstockSegment(**seg))
        except InputError as exc:
            raise InputError(f"{str(exc).replace('penstock.segments', key)} (segment {i}, counted from 0 {first} "
                             f"first)") from None
    profiles = [s.elevation_start_m is not None for s in out]
    if any(profiles) and not all(profiles):
        raise InputError(f"{key}: elevation_start_m/elevation_end_m must be given on every segment or on "
                         f"none; segment {profiles.index(False)} has none")
    for i in range(1, len(out) if all(profiles) else 0):
        if abs(out[i].elevation_start_m - out[i - 1].elevation_end_m) > 1e-9:
            raise InputError(f"{key}: segment {i} starts at elevation {out[i].elevation_start_m!r} m "
                             f"but segment {i - 1} ends at {out[i - 1].elevation_end_m!r} m; the profile must be "
                             f"continuous")
    return tuple(out)


@dataclass(frozen=True)
class PenstockConfig:
    """Penstock from the upper reservoir to the turbine inlet.

    ``static_head_m`` is the reservoir level above tailwater; heads are piezometric above tailwater, so the head
    at the turbine inlet is the turbine's net head (draft-tube losses and velocity head neglected).
    ``reaches`` is the number of MOC reaches of the segment with the shortest travel time; the time step is that
    travel time divided by ``reaches`` (Courant number 1). ``lumped_alpha`` is alpha in the lumped model
    h = -Tw s / (1 + alpha Te^2 s^2) q (default 4/pi^2 puts its resonance on the pipe's first mode, pi a / (2 L)).
    ``zdomain_feedback`` is F of eq. (17) of the BP hill-chart paper (default 0: lossless characteristic line).
    ``friction_model`` is the wall friction of the method of characteristics
    (:data:`simulate.components.registry.FRICTION`: ``"steady"``, the Darcy-Weisbach loss; ``"brunone"``, the
    unsteady friction of :mod:`simulate.components.hydraulic.brunone` with its keys ``brunone_k3`` and
    ``brunone_viscosity_m2_s``; ``"convolution"``, the Zielke / Vardy-Brown convolution of
    :mod:`simulate.components.hydraulic.convolution` with its key ``convolution_viscosity_m2_s``; a friction model's
    keys are refused under another). ``column_separation`` is what the
    method of characteristics does where the head falls to the vapour head
    (:mod:`simulate.components.hydraulic.cavitation`: ``"dgcm"``, the default, the discrete gas cavity model of
    :mod:`simulate.components.hydraulic.gas_cavity`, with ``water_temperature_c``, ``atmospheric_pressure_head_m``,
    ``cavity_weighting`` and ``gas_void_fraction``; ``"dvcm"``, the discrete vapour cavity model, with the same keys
    but the last; ``"off"``: nothing).
    """

    model: str = parameter(unit="", choices=PENSTOCKS, description="the penstock model")
    static_head_m: float = parameter(unit="m", low=0.0, low_open=True, high=3000.0,
                                     description="reservoir level above tailwater")
    reaches: int = parameter(unit="1", kind="integer", low=1, high=MAX_REACHES,
                             description="MOC reaches of the segment with the shortest travel time")
    segments: tuple[PenstockSegment, ...] = parameter(
        unit="", kind="array", what="a non-empty array of tables [[penstock.segments]]",
        description="the pipes, upstream first")
    lumped_alpha: float = parameter(4.0 / math.pi ** 2, unit="1", low=0.0, low_open=True, high=10.0,
                                    description="alpha of the lumped model's second-order term")
    zdomain_feedback: float = parameter(0.0, unit="1", low=0.0, high=100.0,
                                        description="F of the z-domain model's friction feedback")
    friction_model: str = parameter("convolution", unit="", choices=FRICTION,
                                    description="the wall friction of the method of characteristics")
    brunone_k3: float | None = borrowed(BrunoneConfig, "k3")
    brunone_viscosity_m2_s: float | None = borrowed(BrunoneConfig, "kinematic_viscosity_m2_s")
    convolution_viscosity_m2_s: float | None = borrowed(ConvolutionConfig, "kinematic_viscosity_m2_s")
    column_separation: str = parameter("dgcm", unit="", choices=COLUMN_SEPARATION_MODELS,
                                       description="water-column separation in the method of characteristics: the "
                                                   "discrete vapour cavity model, the discrete gas cavity model, "
                                                   "or off")
    water_temperature_c: float | None = borrowed(ColumnSeparationConfig, "water_temperature_c")
    atmospheric_pressure_head_m: float | None = borrowed(ColumnSeparationConfig, "atmospheric_pressure_head_m")
    cavity_weighting: float | None = borrowed(ColumnSeparationConfig, "cavity_weighting")
    gas_void_fraction: float | None = borrowed(ColumnSeparationConfig, "gas_void_fraction")

    def __post_init__(self):
        validate_parameters("penstock", self)
        object.__setattr__(self, "segments", read_segments(self.segments, "penstock.segments"))
        check_friction_keys("penstock", self)
        check_column_separation(self)
        for key in self.unread_keys():
            if key not in KEYS_READ_OUTSIDE_THE_RUN:
                owners = [m for m in PENSTOCKS.names() if key in getattr(PENSTOCKS.traits(m), "reads", ())]
                raise InputError(f"penstock.{key} = {getattr(self, key)!r} is read only by penstock.model = "
                                 f"{' or '.join(owners)}; with model = {self.model!r} it would be ignored: set "
                                 f"penstock.model or remove the key")

    def unread_keys(self) -> tuple[str, ...]:
        """The model keys (:data:`MODEL_KEYS`) set away from their default that this model's run does not read."""
        default = {f.name: f.default for f in fields(self)}
        changed = [k for k in MODEL_KEYS if getattr(self, k) != default[k]]
        return tuple(k for k in changed if k not in PENSTOCKS.traits(self.model).reads) if changed else ()

    def unread_key_warnings(self) -> list[str]:
        """The run's warnings about keys set for another model that this one does not read."""
        return [f"penstock.{key} = {getattr(self, key)!r} has no effect on this run: penstock.model = "
                f"{self.model!r} does not read it (it sets the lumped model and the identification's linear "
                f"reference)" for key in self.unread_keys()]

    @property
    def length_m(self) -> float:
        return sum(s.length_m for s in self.segments)

    def axis_elevations_m(self, x_m):
        """The pipe axis above the tailwater datum at ``x_m`` (m from the inlet), or None without a profile
        (:func:`simulate.components.hydraulic.cavitation.axis_elevations_m`)."""
        return axis_elevations_m(self, x_m)

    @property
    def vapour_gauge_head_m(self) -> float:
        """The vapour pressure as a gauge head at ``water_temperature_c`` and ``atmospheric_pressure_head_m`` (their
        defaults where not given), m."""
        return vapour_settings(self).gauge_vapour_head_m

    @property
    def travel_time_s(self) -> float:
        """One-way wave travel time L/a summed over the segments, s."""
        return sum(s.travel_time_s for s in self.segments)

    @property
    def inertance_s2_m2(self) -> float:
        """sum L_i / (g A_i), s^2/m^2: head (m) = inertance * dQ/dt (m^3/s^2)."""
        return sum(s.length_m / (G_M_S2 * s.area_m2) for s in self.segments)

    @property
    def friction_coefficient_s2_m5(self) -> float:
        """K of the steady friction loss K Q|Q| = sum f L / (2 g D A^2), s^2/m^5."""
        return sum(s.darcy_friction * s.length_m / (2.0 * G_M_S2 * s.diameter_m * s.area_m2 ** 2)
                   for s in self.segments)

    def water_time_s(self, rated_flow_m3_s: float, rated_head_m: float) -> float:
        """Water inertia time Tw = sum L_i Q_r / (g A_i H_r), s (eq. (18) of the BP hill-chart paper)."""
        return self.inertance_s2_m2 * rated_flow_m3_s / rated_head_m

    @property
    def moc_time_step_s(self) -> float:
        """Shortest segment travel time / reaches, s (the default time step of every model)."""
        return min(s.travel_time_s for s in self.segments) / self.reaches


def check_friction_keys(section: str, config) -> None:
    """Refuse a friction model's keys set under another model (they would be ignored) and run the model's own
    check of its keys (its module's ``check_penstock(config, section)``); ``section`` names the keys in messages
    (``penstock`` or ``draft_tube``)."""
    own = FRICTION.attribute(config.friction_model, "PENSTOCK_KEYS", ())
    for key in friction_keys():
        if getattr(config, key) is not None and key not in own:
            owners = [m for m in FRICTION.names() if key in FRICTION.attribute(m, "PENSTOCK_KEYS", ())]
            raise InputError(f"{section}.{key} is a key of {section}.friction_model = {' or '.join(owners)!r}; "
                             f"with friction_model = {config.friction_model!r} it would be ignored: set "
                             f"friction_model or remove the key")
    check = FRICTION.attribute(config.friction_model, "check_penstock")
    if check is not None:
        check(config, section)


def friction_keys() -> tuple[str, ...]:
    """The ``[penstock]`` keys of every friction model (each its module's ``PENSTOCK_KEYS``)."""
    return tuple(k for name in FRICTION.names() for k in FRICTION.attribute(name, "PENSTOCK_KEYS", ()))


__all__ = ["WAVE_SPEED_MIN_M_S", "MAX_REACHES", "MODEL_KEYS", "SEGMENT_KEYS", "PenstockSegment", "PenstockConfig",
           "read_segments", "check_friction_keys", "friction_keys"]
