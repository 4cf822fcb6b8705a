"""The water downstream of the runner: a draft tube / tailrace conduit to the tailwater (registry kind
"downstream"), and the tailwater itself when the plant has no ``[draft_tube]``.

Each gives, for the current step, a linear relation at the runner outlet

    H_out = C_M + B_M Q,   B_M >= 0   (H_out piezometric head above the tailwater, m; Q the turbine flow, m^3/s),

so that with the penstock's H_in = C_L + k Q the turbine's net head is again linear in Q,
``H = H_in - H_out = (C_L - C_M) + (k - B_M) Q``: the relation the turbine boundary solves
(:mod:`simulate.components.turbine.boundary`). After the boundary, ``update(p, s, H_out, Q)`` advances the conduit.

The conduit is the penstock code run mirrored (one implementation of each model): a pipe from the tailwater
(the "reservoir", head 0) to the runner outlet carrying the flow -Q, so its C+ relation H_out = C + k' (-Q) gives
C_M = C, B_M = -k'. ``model = "moc"`` (method of characteristics on the plant's step, Courant number 1, the same
wave-speed adjustment as the penstock) or ``"rigid"`` (the inelastic column, backward Euler).

The runner-outlet pressure (absolute, as a head of water) is ``H_out + atmospheric_pressure_head_m -
runner_elevation_m`` (the runner outlet's elevation above the tailwater: negative for a runner set below it, as a
bulb is); its minimum over the run is ``min_outlet_pressure_head_m`` in the summary, with a warning below the vapour
pressure head plus the user's margin.

Water-column separation in the ``moc`` draft tube (``column_separation``, the penstock's models of
:mod:`simulate.components.hydraulic.cavitation`: the discrete gas cavity model by default) is the mirrored pipe's:
its downstream end is the runner outlet, so a cavity below the runner is the cavity the penstock's models open at
their turbine end. The pipe's axis is the segments' profile where they carry one (``elevation_start_m`` /
``elevation_end_m``, runner outlet first, ``moc`` only), else the runner outlet's level along the whole draft tube
(a draft tube descends from the runner, so its lower nodes hold more pressure than this gives them: cavities there
are taken to form sooner, not later); the vapour pressure is ``vapour_pressure_head_m`` (the mirrored pipe's water
temperature is the one whose IAPWS-IF97 vapour pressure it is).

The guarantee's figure ``min_draft_tube_pressure_head_m`` (absolute, m of water) is the runner outlet's minimum and,
along a profile, the lowest over every node of every step where that is lower (the mirrored conduit's lowest head
per node): never above ``min_outlet_pressure_head_m``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, fields

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.hydraulic.cavitation import (COLUMN_SEPARATION_MODELS, DVCM_KEYS, MODEL_NAMES,
                                                      BoilingSteadyState, has_profile, vapour_pressure_head_m)
from simulate.components.hydraulic.brunone import BrunoneConfig
from simulate.components.hydraulic.conduit import PROFILE_KEYS, PenstockConfig, check_friction_keys, read_segments
from simulate.components.hydraulic.convolution import ConvolutionConfig
from simulate.components.hydraulic.penstock import (iir_relation, iir_update, moc_dvcm_record, moc_relation,
                                                    moc_track_lowest, moc_update)
from simulate.components.contract import PART, SCALAR, LinearBlock, StateArray
from simulate.components.parameters import borrowed, parameter, validate_parameters
from simulate.components.registry import FRICTION, PENSTOCKS

SIGNALS = ("draft_tube_head_m", "outlet_pressure_head_m")
#: The columns of a draft tube with column separation besides: the volume of all its cavities and of the one below
#: the runner, m^3.
CAVITY_SIGNALS = ("draft_tube_cavity_volume_m3", "runner_outlet_cavity_volume_m3")
#: The tailwater keeps no state (one unused value); the draft tube the state of its conduit (a penstock model's, run
#: mirrored) and the outlet head of the last step.
STATES = {"build_tailwater": (StateArray("unused", "", "none: a constant level (one unused value)", SCALAR),),
          "build_draft_tube": (StateArray("conduit", "", "the state of the conduit, a penstock model run mirrored",
                                          PART, kind="penstock", chosen_by="draft_tube.model"),
                               StateArray("outlet_head", "m", "the runner-outlet head of the last step", SCALAR))}


# ---------------------------------------------------------------------------------------------------------------
# compiled functions: relation(p, s) -> (C_M, B_M); update(p, s, outlet_head_m, flow_m3_s); record(p, s, out)
# p = (inner params, [atmospheric - elevation]); s = (inner state, [outlet head of the last step])
# ---------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def tailwater_relation(p, s):
    """No conduit: the runner outlet is at the tailwater, H_out = 0."""
    return 0.0, 0.0


@numba.njit(cache=True)
def tailwater_update(p, s, outlet_head_m, flow_m3_s):
    return


@numba.njit(cache=True)
def moc_draft_relation(p, s):
    c, k = moc_relation(p[0], s[0], 0.0)
    return c, -k


@numba.njit(cache=True)
def moc_draft_update(p, s, outlet_head_m, flow_m3_s):
    moc_update(p[0], s[0], 0.0, outlet_head_m, -flow_m3_s)
    moc_track_lowest(s[0])  # every node's lowest head: the minimum pressure along a draft tube with a profile
    s[1][0] = outlet_head_m


@numba.njit(cache=True)
def rigid_draft_relation(p, s):
    c, k = iir_relation(p[0], s[0], 0.0)
    return c, -k


@numba.njit(cache=True)
def rigid_draft_update(p, s, outlet_head_m, flow_m3_s):
    iir_update(p[0], s[0], 0.0, outlet_head_m, -flow_m3_s)
    s[1][0] = outlet_head_m


@numba.njit(cache=True)
def draft_record(p, s, out):
    """Columns ``draft_tube_head_m``, ``outlet_pressure_head_m``."""
    out[0] = s[1][0]
    out[1] = s[1][0] + p[1][0]


#: The cavity columns' function of the mirrored conduit, bound per cavity model by :func:`build_draft_tube`.
conduit_record = moc_dvcm_record


@numba.njit(cache=True)
def draft_cavity_record(p, s, out):
    """:func:`draft_record`'s columns, then :data:`CAVITY_SIGNALS` (the mirrored conduit's cavity columns)."""
    draft_record(p, s, out)
    conduit_record(p[0], s[0], out[2:])


def build_tailwater(plant, steady, dt_s: float):
    from simulate.components.registry import CompiledPart

    return CompiledPart(kind="downstream", name="tailwater",
                        functions={"relation": tailwater_relation, "update": tailwater_update},
                        params=(np.zeros(1),), state=(np.zeros(1),))


def _calling(func, name: str, target):
    """``func`` calling ``target`` as its global ``name``: the MOC function the inner conduit's builder bound to its
    friction model (a :class:`simulate.components.registry.Bound`); ``func`` itself when that is the module's own
    (the steady loss: the loop's text is the same as without a friction model)."""
    from simulate.components.registry import Bound

    return func if target is func.py_func.__globals__[name] else Bound(func, ((name, target),))


def build_draft_tube(plant, steady, dt_s: float):
    """The plant's ``[draft_tube]`` on the step ``dt_s``, started at the steady flow."""
    from types import SimpleNamespace

    from simulate.components.registry import CompiledPart, PartHooks

    config = plant.draft_tube  # DraftTubeConfig
    mirrored = config.mirrored()
    fake_plant = SimpleNamespace(penstock=mirrored, turbine=plant.turbine)
    fake_steady = SimpleNamespace(flow_m3_s=-steady.flow_m3_s)
    try:
        inner = PENSTOCKS.builder(config.model)(fake_plant, fake_steady, dt_s, 0.0)
    except BoilingSteadyState as exc:
        # the node's absolute pressure head: H - z + atmospheric, its vapour head z - atmospheric + vapour (eq. (C1))
        absolute = exc.head_m - exc.vapour_head_m + config.vapour_pressure_head_m
        from_runner_m = mirrored.length_m - exc.x_m
        if config.has_profile and from_runner_m > 1e-9 * mirrored.length_m:
            raise InputError(
                f"draft_tube.segments: the absolute pressure head in the draft tube {from_runner_m:.4g} m from the "
                f"runner outlet in steady flow, {absolute:.3g} m, is not above draft_tube.vapour_pressure_head_m = "
                f"{config.vapour_pressure_head_m:g}: the water would boil there; lower the draft tube there (the "
                f"segments' elevation_start_m/elevation_end_m) or set the runner lower") from None
        raise InputError(
            f"draft_tube.runner_elevation_m = {config.runner_elevation_m:g}: the absolute pressure head below the "
            f"runner in steady flow, {absolute:.3g} m, is not above draft_tube.vapour_pressure_head_m = "
            f"{config.vapour_pressure_head_m:g}: the water would boil there; set the runner lower (a smaller "
            f"runner_elevation_m)") from None
    except InputError as exc:
        # the grid's message names the mirrored section (its own placeholder reaches); the draft tube has no reaches:
        # its step is the plant's, set by the penstock
        text = re.sub(r"^penstock\.reaches = \d+: segment", "draft_tube.segments: segment", str(exc))
        text = text.replace("increase penstock.reaches",
                            f"the step is the plant's (penstock.reaches = {plant.penstock.reaches}); change "
                            f"penstock.reaches or the draft tube's length_m or wave_speed_m_s")
        raise InputError(f"[draft_tube]: {text}") from None
    head0 = config.friction_coefficient_s2_m5 * steady.flow_m3_s * abs(steady.flow_m3_s)
    on_grid = PENSTOCKS.traits(config.model).grid_fixes_time_step  # the draft tube on its MOC grid
    cavities = on_grid and config.column_separation != "off"
    if on_grid:
        head0 = float(inner.state[0][0, -1])  # the grid's own steady head at the outlet
        record = (_calling(draft_cavity_record, "conduit_record", inner.functions["record"]) if cavities
                  else draft_record)
        functions = {"relation": _calling(moc_draft_relation, "moc_relation", inner.functions["relation"]),
                     "update": _calling(moc_draft_update, "moc_update", inner.functions["update"]),
                     "record": record}
    else:
        functions = {"relation": rigid_draft_relation, "update": rigid_draft_update, "record": draft_record}
    offset = config.atmospheric_pressure_head_m - config.runner_elevation_m
    limit = config.vapour_pressure_head_m + config.vapour_margin_m
    profile = on_grid and config.has_profile

    def lowest(signals, time_s=None):
        """The guarantee's figure: the lowest absolute pressure head (m of water), its distance from the runner outlet
        (m) and its time (s; None without ``time_s``): the runner outlet's recorded pressure, and along a profile
        every node's lowest head of every step (the mirrored conduit's track) where that is lower or the same."""
        values = signals["outlet_pressure_head_m"]
        i = int(np.argmin(values))
        out = (float(values[i]), 0.0, None if time_s is None else float(time_s[i]))
        if profile:
            track = inner.state[4]
            absolute = track[4] - mirrored.axis_elevations_m(inner.node_x_m) + config.atmospheric_pressure_head_m
            j = int(np.argmin(absolute))
            if absolute[j] <= out[0]:
                x = float(mirrored.length_m - inner.node_x_m[j])
                out = (float(absolute[j]), 0.0 if x <= 1e-9 * mirrored.length_m else x, float(track[3, j] * dt_s))
        return out

    def summary_after(time_s, signals):
        values = signals["outlet_pressure_head_m"]
        i = int(np.argmin(values))
        low, x, t = lowest(signals, time_s)
        out = {"min_outlet_pressure_head_m": float(values[i]), "t_min_outlet_pressure_s": float(time_s[i]),
               "min_draft_tube_head_m": float(np.min(signals["draft_tube_head_m"])),
               "min_draft_tube_pressure_head_m": low, "min_draft_tube_pressure_x_m": x,
               "t_min_draft_tube_pressure_s": t}
        if cavities:  # the mirrored conduit's cavity figures (its x from the draft tube's outlet)
            figures = inner.hooks.summary_after(time_s, signals)
            out.update({f"draft_tube_{key}": value for key, value in figures.items()
                        if "cavit" in key})
        return out

    def warnings_after(signals):
        out = []
        low, x, _ = lowest(signals)
        where = "at the runner outlet" if x == 0.0 else f"in the draft tube {x:.4g} m from the runner outlet"
        if low < limit:
            modelled = (f"the {MODEL_NAMES[config.column_separation]} represents the column's separation there"
                        if cavities else "the water column may separate in the draft tube (not modelled)")
            out.append(f"the absolute pressure head {where} falls to {low:.3g} m, below the vapour "
                       f"pressure head plus margin ({config.vapour_pressure_head_m:g} + {config.vapour_margin_m:g} "
                       f"m): {modelled}; close the guide vanes more slowly, set the runner deeper "
                       f"(draft_tube.runner_elevation_m) or check the draft tube")
        if cavities:
            for text in inner.hooks.warnings_after(signals):
                if text.startswith("water-column separation:"):
                    out.append(text.replace("water-column separation:", "water-column separation in the draft tube:")
                               .replace("from the pipe's inlet", "from the draft tube's outlet"))
        return out

    summary = {"draft_tube_model": config.model, "draft_tube_friction_s2_m5": config.friction_coefficient_s2_m5,
               "draft_tube_friction_model": config.friction_model,
               "draft_tube_column_separation": config.column_separation if on_grid else "off"}
    if on_grid:
        summary["draft_tube_moc_reaches"] = inner.hooks.summary["moc_reaches"]
    hooks = PartHooks(summary=summary, initial_signals=(head0, head0 + offset) + ((0.0, 0.0) if cavities else ()),
                      summary_after=summary_after, warnings_after=warnings_after,
                      failure=_draft_failure(config, inner, mirrored.length_m) if cavities else None)
    return CompiledPart(kind="downstream", name=f"draft_tube ({config.model})", functions=functions,
                        params=(inner.params, np.array([offset])), state=(inner.state, np.array([head0])),
                        signals=SIGNALS + (CAVITY_SIGNALS if cavities else ()), hooks=hooks)


def _draft_failure(config, inner, length_m: float):
    """Why a run stopped that had a cavity in the draft tube: its collapse drives the draft tube's head up, and a
    turbine whose net head then falls toward zero is outside its characteristics. The cavity below the runner when
    one formed there, else the largest (at a high point of the draft tube's profile)."""
    track = inner.state[4]

    def failure() -> str:
        formed = np.flatnonzero(track[5] > 0)
        if formed.size == 0:
            return ""
        model = MODEL_NAMES[config.column_separation]
        if track[5, -1] > 0:
            return (f"a cavity below the runner (the {model} of the draft tube) formed and collapsed: the draft "
                    f"tube's head rose to the turbine inlet's and the turbine's net head is not positive, which its "
                    f"characteristics do not cover; close the guide vanes more slowly or set the runner deeper "
                    f"(draft_tube.runner_elevation_m)")
        j = int(formed[np.argmax(track[1, formed])])
        return (f"a cavity in the draft tube {length_m - inner.node_x_m[j]:.4g} m from the runner outlet (the {model}) "
                f"formed and collapsed: the draft tube's head rose toward the turbine inlet's and drove the turbine's "
                f"net head toward zero, beyond its characteristics; lower the draft tube there "
                f"([[draft_tube.segments]] elevations), close the guide vanes more slowly or set the runner deeper")
    return failure


def time_scales(plant, schedules) -> list:
    """The rigid draft tube's water time (one relation per step for the whole column); nothing for MOC."""
    from simulate.components.timescale import TimeScale

    config = getattr(plant, "draft_tube", None)
    if config is None or PENSTOCKS.traits(config.model).grid_fixes_time_step:
        return []
    t = plant.turbine
    return [TimeScale("draft tube water time (draft_tube segments, rated flow and head)",
                      config.mirrored().water_time_s(t.rated_flow_m3_s, t.rated_head_m), coupled=True)]


def tailwater_counterpart(plant, steady) -> LinearBlock:
    """h_out = 0: the constant tailwater the linear model of the plant assumes."""
    return LinearBlock("h_out = 0 (a constant level)")


#: The draft tube has none: the linear model of the plant (paper 000's) has no column below the runner.
LINEAR_COUNTERPART = {"build_tailwater": tailwater_counterpart, "build_draft_tube": None}


#: The conduit models of a draft tube (the penstock models it runs mirrored).
DRAFT_TUBE_MODELS = ("moc", "rigid")


@dataclass(frozen=True)
class DraftTubeConfig:
    """``[draft_tube]``: the conduit from the runner outlet to the tailwater.

    ``model`` ``"moc"`` or ``"rigid"``; ``[[draft_tube.segments]]`` with the penstock's segment keys
    (``length_m``, ``diameter_m``, ``wave_speed_m_s``, ``darcy_friction``; with ``moc`` also the profile
    ``elevation_start_m``/``elevation_end_m``, m above the tailwater level, on every segment or none, the first
    starting at ``runner_elevation_m``), runner outlet first;
    ``atmospheric_pressure_head_m`` (m of water, 10.33 at sea level); ``runner_elevation_m`` the runner outlet above
    the tailwater level (m, negative below it); ``vapour_pressure_head_m`` (m of water, 0.24 at 20 C);
    ``vapour_margin_m``: warn when the outlet pressure head falls below vapour pressure head + this margin (m).
    ``friction_model`` and its keys: the wall friction of the ``moc`` draft tube, as the penstock's
    (:class:`simulate.components.hydraulic.conduit.PenstockConfig`; a friction model's keys are refused under
    another). ``column_separation``: the ``moc`` draft tube's water-column separation, as the penstock's (the
    discrete gas cavity model by default). The component: :mod:`simulate.components.hydraulic.draft_tube`.
    """

    model: str = parameter(unit="", choices=DRAFT_TUBE_MODELS, description="the conduit model")
    segments: tuple = parameter(unit="", kind="array", what="a non-empty array of tables [[draft_tube.segments]]",
                                description="the pipes, runner outlet first")
    atmospheric_pressure_head_m: float = parameter(10.33, unit="m", low=0.0, high=20.0,
                                                   description="atmospheric pressure as a head of water")
    runner_elevation_m: float = parameter(0.0, unit="m", low=-100.0, high=20.0,
                                          description="runner outlet above the tailwater level")
    vapour_pressure_head_m: float = parameter(0.24, unit="m", low=0.0, high=20.0,
                                              description="vapour pressure as a head of water")
    vapour_margin_m: float = parameter(2.0, unit="m", low=0.0, high=50.0,
                                       description="warning margin above the vapour pressure head")
    friction_model: str = parameter("convolution", unit="", choices=FRICTION,
                                    description="the wall friction of the method of characteristics (moc)")
    brunone_k3: float | None = borrowed(BrunoneConfig, "k3")
    brunone_viscosity_m2_s: float | None = borrowed(BrunoneConfig, "kinematic_viscosity_m2_s")
    convolution_viscosity_m2_s: float | None = borrowed(ConvolutionConfig, "kinematic_viscosity_m2_s")
    column_separation: str = parameter("dgcm", unit="", choices=COLUMN_SEPARATION_MODELS,
                                       description="water-column separation in the method of characteristics (moc): "
                                                   "the discrete vapour or gas cavity model, or off")

    def __post_init__(self):
        validate_parameters("draft_tube", self)
        # a profile only where there are nodes along the conduit to take it (the method of characteristics)
        on_grid = PENSTOCKS.traits(self.model).grid_fixes_time_step
        if not on_grid and isinstance(self.segments, (list, tuple)):
            given = [k for seg in self.segments for k in PROFILE_KEYS
                     if (seg.get(k) if isinstance(seg, dict) else getattr(seg, k, None)) is not None]
            if given:
                raise InputError(f"draft_tube.segments.{given[0]} is read only by draft_tube.model = \"moc\" (the "
                                 f"pressure along the draft tube at its nodes); with model = {self.model!r} it would "
                                 f"be ignored: set draft_tube.model = \"moc\" or remove the segments' elevations")
        object.__setattr__(self, "segments", read_segments(self.segments, "draft_tube.segments", profile=on_grid,
                                                          first="runner outlet"))
        if self.has_profile and abs(self.segments[0].elevation_start_m - self.runner_elevation_m) > 1e-9:
            raise InputError(f"draft_tube.segments[0].elevation_start_m = {self.segments[0].elevation_start_m:g} "
                             f"but draft_tube.runner_elevation_m = {self.runner_elevation_m:g}: the profile starts "
                             f"at the runner outlet (m above the tailwater level); set runner_elevation_m = "
                             f"{self.segments[0].elevation_start_m:g} or correct the first segment's elevation")
        for key in ("friction_model", "column_separation"):
            default = next(f.default for f in fields(self) if f.name == key)
            if getattr(self, key) != default and key not in PENSTOCKS.traits(self.model).reads:
                owners = [m for m in DRAFT_TUBE_MODELS if key in PENSTOCKS.traits(m).reads]
                raise InputError(f"draft_tube.{key} = {getattr(self, key)!r} is read only by draft_tube.model = "
                                 f"{' or '.join(owners)}; with model = {self.model!r} it would be ignored: set "
                                 f"draft_tube.model or remove the key")
        check_friction_keys("draft_tube", self)
        if self.column_separation != "off" and "column_separation" in PENSTOCKS.traits(self.model).reads:
            low, high = vapour_pressure_head_m(0.0), vapour_pressure_head_m(100.0)
            if not low <= self.vapour_pressure_head_m <= high:
                raise InputError(f"draft_tube.vapour_pressure_head_m = {self.vapour_pressure_head_m!r}: with "
                                 f"draft_tube.column_separation = {self.column_separation!r} it must be water's "
                                 f"vapour pressure between 0 and 100 degC, [{low:.4g}, {high:.4g}] m; or set "
                                 f"column_separation = \"off\"")

    def mirrored(self) -> PenstockConfig:
        """The conduit as a :class:`simulate.components.hydraulic.conduit.PenstockConfig` from the tailwater to the
        runner outlet (every key the two sections share is passed on; the mirrored pipe has no reservoir head and
        one reach, the draft tube having none of its own), its segments reversed with their ends swapped. With column
        separation and no profile its segments' axis lies at the runner outlet's level; with column separation its
        atmospheric pressure and water temperature are the draft tube's atmospheric pressure and the temperature of
        its vapour pressure (module docstring)."""
        from dataclasses import replace

        shared = {f.name: getattr(self, f.name) for f in fields(PenstockConfig)
                  if hasattr(self, f.name) and f.name not in DVCM_KEYS}
        # from the tailwater to the runner: each segment's ends swap with the direction
        segments = tuple(replace(s, elevation_start_m=s.elevation_end_m, elevation_end_m=s.elevation_start_m)
                         for s in reversed(self.segments))
        if "column_separation" not in PENSTOCKS.traits(self.model).reads:
            shared.pop("column_separation")
        elif self.column_separation != "off":
            from scipy.optimize import brentq

            shared.update(atmospheric_pressure_head_m=self.atmospheric_pressure_head_m,
                          water_temperature_c=brentq(lambda t: vapour_pressure_head_m(t) - self.vapour_pressure_head_m,
                                                     0.0, 100.0, xtol=1e-12))
            if not self.has_profile:
                z = self.runner_elevation_m
                segments = tuple(replace(s, elevation_start_m=z, elevation_end_m=z) for s in segments)
        return PenstockConfig(**{**shared, "static_head_m": 1.0, "reaches": 1, "segments": segments})

    @property
    def has_profile(self) -> bool:
        """Whether the segments carry the draft tube's axis (``elevation_start_m``/``elevation_end_m``, runner outlet
        first, m above the tailwater level)."""
        return has_profile(self)

    @property
    def friction_coefficient_s2_m5(self) -> float:
        """K of the steady loss K Q|Q| from the runner outlet to the tailwater, s^2/m^5."""
        return self.mirrored().friction_coefficient_s2_m5
