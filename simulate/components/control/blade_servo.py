"""Runner-blade servo and combinator of a double-regulated (Kaplan, bulb) unit: a control component whose control
vector is ``[guide-vane stroke, blade stroke]`` (fractions of each servo's full stroke).

The guide vanes follow the governor (PID + servo, :mod:`simulate.components.control.governor`) or the scenario's
prescribed law; the blades follow, through their own servo (first order, rate limited; :func:`servo_step` with the
blade's time constant and closing/opening times), a command chosen by ``blade_servo.mode``:

``"combinator"``  the combinator's cam phi(a, H) at the current vane opening (``[combinator]``; with
                  ``relation = "off"`` the blades stay at ``combinator.fixed_angle_deg``);
``"held"``        the initial angle (the blades do not move);
``"law"``         the initial angle until ``law_start_s``, then ``law_target_deg`` (default ``angle_min_deg``): the
                  servo's rate limit makes the ramp (e.g. ``closing_time_s = 30``: blades close in 30 s).

Columns (the component's record): ``blade_angle_deg`` (where the blades are) and ``blade_angle_cam_deg`` (what the
combinator asks at the vane opening of the step).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.contract import ENTRIES, PART, StateArray
from simulate.components.control.governor import build_governor, build_prescribed
from simulate.components.control.speed_governor import governor_control_step
from simulate.components.control.servo import servo_step
from simulate.components.parameters import parameter, validate_parameters
from simulate.components.registry import Bound, CompiledPart, PartHooks
from simulate.components.schedules import GOVERNOR, piecewise_linear

BLADE_MODES = ("combinator", "held", "law")
COMBINATOR_RELATIONS = ("cam", "model", "table", "off")


@dataclass(frozen=True)
class BladeServoConfig:
    """``[blade_servo]``: the runner-blade servo.

    ``servo_time_s`` first-order time constant T_b (s); ``closing_time_s`` / ``opening_time_s``: time of a full
    stroke (``angle_max_deg`` - ``angle_min_deg``) towards the smaller / larger angle (s, the rate limits);
    ``angle_min_deg`` / ``angle_max_deg``: blade angle at zero / full stroke (deg, the characteristics' blade-angle
    convention); ``mode`` (module docstring), ``law_start_s`` and ``law_target_deg`` for ``mode = "law"``.
    """

    servo_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=600.0,
                                    description="time constant T_b of the blade servo")
    closing_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=3600.0,
                                      description="time of a full stroke towards the smaller angle")
    opening_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=3600.0,
                                      description="time of a full stroke towards the larger angle")
    angle_min_deg: float = parameter(unit="deg", low=-90.0, high=90.0, description="blade angle at zero stroke")
    angle_max_deg: float = parameter(unit="deg", low=-90.0, high=90.0, description="blade angle at full stroke")
    mode: str = parameter("combinator", unit="", choices=BLADE_MODES, description="what the blades follow")
    law_start_s: float = parameter(0.0, unit="s", low=0.0, high=1e6, description="start of the blade law (mode law)")
    law_target_deg: float | None = parameter(None, unit="deg", low="angle_min_deg", high="angle_max_deg",
                                             description="the blade law's angle (mode law; default angle_min_deg)")

    def __post_init__(self):
        validate_parameters("blade_servo", self)
        if not self.angle_max_deg > self.angle_min_deg:
            raise InputError(f"blade_servo.angle_max_deg must be > blade_servo.angle_min_deg = "
                             f"{self.angle_min_deg!r}, got {self.angle_max_deg!r}")
        law_keys = (("law_start_s", 0.0), ("law_target_deg", None))  # with their defaults
        given = [f"blade_servo.{key} = {getattr(self, key)!r}" for key, default in law_keys
                 if getattr(self, key) != default]
        if self.mode != "law" and given:
            raise InputError(f"{', '.join(given)}: the blade law's keys go with mode = \"law\"; with "
                             f"mode = {self.mode!r} the blades follow "
                             f"{'the combinator' if self.mode == 'combinator' else 'their initial angle'} and the law "
                             f"would be ignored: set mode = \"law\" or remove the key(s)")


@dataclass(frozen=True)
class CombinatorConfig:
    """``[combinator]``: the relation that sets the blades from the guide vanes.

    ``relation``: ``"cam"`` (the blade angle of best efficiency of the characteristics at the plant's speed,
    phi(a, H)), ``"model"`` (the same of the physical model fitted to the test table, which nets from
    ``hillsim fccm --simulator-nets`` carry: smooth where the nets' flat efficiency optimum moves with their
    misfit), ``"table"`` (the user's cam: ``table_openings`` (chart units of the characteristics),
    ``table_heads_m`` (increasing), ``table_angles_deg`` (one row of angles per head)) or ``"off"`` (blades fixed
    at ``fixed_angle_deg``). ``opening_at_zero_stroke``: the characteristics' guide-vane opening at the closed vane
    (their units; the plant's opening a = y opening_max is counted from it). ``head_m``: the head the combinator
    reads (m; default the net head of the initial steady state, held over the run).
    """

    relation: str = parameter(unit="", choices=COMBINATOR_RELATIONS, description="what sets the blades")
    opening_at_zero_stroke: float = parameter(0.0, unit="chart opening", low=-1e5, high=1e5,
                                              description="the characteristics' opening at the closed vane")
    fixed_angle_deg: float | None = parameter(None, unit="deg", low=-90.0, high=90.0,
                                              description="the blades' angle with relation off")
    head_m: float | None = parameter(None, unit="m", low=0.0, low_open=True, high=3000.0,
                                     description="the head the combinator reads (default: the initial net head)")
    table_openings: tuple | None = parameter(None, unit="chart opening", kind="array",
                                             description="the cam's openings (relation table), increasing")
    table_heads_m: tuple | None = parameter(None, unit="m", kind="array",
                                            description="the cam's heads (relation table), increasing")
    table_angles_deg: tuple | None = parameter(None, unit="deg", kind="array",
                                               description="the cam's angles, one row per head (relation table)")

    def __post_init__(self):
        validate_parameters("combinator", self)
        if self.relation == "off" and self.fixed_angle_deg is None:
            raise InputError("combinator.relation = \"off\" (blades fixed) needs combinator.fixed_angle_deg (deg)")
        if self.relation != "off" and self.fixed_angle_deg is not None:
            raise InputError(f"combinator.fixed_angle_deg = {self.fixed_angle_deg!r} goes with relation = \"off\" "
                             f"(blades fixed); with relation = {self.relation!r} the blades follow the combinator and "
                             f"it would be ignored: set relation = \"off\" or remove the key")
        table = (self.table_openings, self.table_heads_m, self.table_angles_deg)
        if self.relation == "table":
            if any(v is None for v in table):
                raise InputError("combinator.relation = \"table\" needs table_openings, table_heads_m and "
                                 "table_angles_deg")
            openings = self._vector("table_openings", self.table_openings)
            heads = self._vector("table_heads_m", self.table_heads_m)
            if np.any(heads <= 0):
                raise InputError(f"combinator.table_heads_m must be > 0, got {heads.tolist()}")
            try:
                angles = np.asarray(self.table_angles_deg, dtype=float)
            except (TypeError, ValueError):
                raise InputError(f"combinator.table_angles_deg must be a list of rows of numbers, got "
                                 f"{self.table_angles_deg!r}") from None
            if angles.shape != (heads.size, openings.size) or not np.all(np.isfinite(angles)):
                raise InputError(f"combinator.table_angles_deg must hold {heads.size} rows (one per head) of "
                                 f"{openings.size} finite angles (one per opening), got shape {angles.shape}")
            object.__setattr__(self, "table_angles_deg", tuple(tuple(float(v) for v in row) for row in angles))
        elif any(v is not None for v in table):
            raise InputError(f"combinator.table_* keys go with relation = \"table\", got relation = "
                             f"{self.relation!r}")

    @staticmethod
    def _vector(name: str, value) -> np.ndarray:
        try:
            out = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"combinator.{name} must be a list of numbers, got {value!r}") from None
        if out.ndim != 1 or out.size < 2 or not np.all(np.isfinite(out)) or np.any(np.diff(out) <= 0):
            raise InputError(f"combinator.{name} must be at least two finite, increasing numbers, got {value!r}")
        return out


# ---------------------------------------------------------------------------------------------------------------
# compiled steps (registry kind "control")
# ---------------------------------------------------------------------------------------------------------------
# blade params vector: the first-order servo's layout (simulate.components.control.servo.SERVO_PARAMS, indices 0-4:
# y_min, y_max, decay, close_step, open_step, in blade stroke fractions), y0 (index 5), then
# [mode, angle_min, span, opening_max, law_start_s, law_target_stroke]
_Y0, _MODE, _ANGLE_MIN, _SPAN, _OPENING_MAX, _LAW_START, _LAW_TARGET = 5, 6, 7, 8, 9, 10, 11
#: The vanes' control step the blades' step calls: bound by the builder to the vane component of the scenario (the
#: governor with its servo, or the prescribed law; :class:`simulate.components.registry.Bound`); this default is the
#: governor's.
vane_control = governor_control_step


@numba.njit(cache=True)
def blade_step(blade, cam_openings, cam_angles, bstate, controls, t_next_s):
    """The blade stroke at t_next from the vane stroke at t_next (``controls[0]``); ``bstate[0]`` = the cam's
    angle at that opening (deg)."""
    cam = piecewise_linear(cam_openings, cam_angles, controls[0] * blade[_OPENING_MAX])
    bstate[0] = cam
    mode = blade[_MODE]
    if mode == 0.0:
        command = (cam - blade[_ANGLE_MIN]) / blade[_SPAN]
    elif mode == 1.0 or t_next_s < blade[_LAW_START]:
        command = blade[_Y0]
    else:
        command = blade[_LAW_TARGET]
    return servo_step(blade, command, controls[1])


@numba.njit(cache=True)
def blade_control_step(p, s, sig, t_s, t_next_s, dt_s):
    """The vanes' control step (``vane_control``: the governor's or the prescribed law's, with its own parameters
    ``p[0]`` and state ``s[0]``, whose last entry is the control vector), then the blades: controls at t_next."""
    vane_p, blade, cam_openings, cam_angles, scal = p
    vane_s, bstate = s
    controls = vane_control(vane_p, vane_s, sig, t_s, t_next_s, dt_s)
    controls[1] = blade_step(blade, cam_openings, cam_angles, bstate, controls, t_next_s + scal[0])
    return controls


@numba.njit(cache=True)
def blade_record(p, s, out):
    """Columns ``blade_angle_deg``, ``blade_angle_cam_deg``."""
    blade = p[1]
    controls, bstate = s[0][-1], s[1]
    out[0] = blade[_ANGLE_MIN] + controls[1] * blade[_SPAN]
    out[1] = bstate[0]


SIGNALS = ("blade_angle_deg", "blade_angle_cam_deg")
#: Its state: the vane component's (its control vector widened to [vanes, blades]) and the cam's angle.
CAM = StateArray("cam", "deg", "the cam's blade angle at the vane opening of the last step", ENTRIES,
                 entries=("cam_angle_deg",))
STATES = {"build_governor_blades": (StateArray("vanes", "", "the governor's state", PART, kind="control",
                                               component="governor"), CAM),
          "build_prescribed_blades": (StateArray("vanes", "", "the prescribed law's state", PART, kind="control",
                                                 component="prescribed"), CAM)}
#: None: the linear model of the plant is single-regulated (the blades on the cam are in its six coefficients).
LINEAR_COUNTERPART = None


def blade_parameters(plant, turbine_view, initial_blade_stroke: float, dt_s: float) -> np.ndarray:
    """The blade params vector (layout in the module source) for the plant's ``[blade_servo]`` (blades fixed: a
    servo that never moves)."""
    servo = plant.blade_servo
    span = turbine_view.angle_span_deg
    if servo is None or plant.combinator.relation == "off":
        mode, decay, close_step, open_step, target = 1.0, 1.0, 0.0, 0.0, initial_blade_stroke
    else:
        mode = float(BLADE_MODES.index(servo.mode))
        decay = float(np.exp(-dt_s / servo.servo_time_s))
        close_step, open_step = dt_s / servo.closing_time_s, dt_s / servo.opening_time_s
        target_deg = servo.angle_min_deg if servo.law_target_deg is None else servo.law_target_deg
        target = turbine_view.blade_stroke(target_deg)
    law_start = servo.law_start_s if servo is not None else 0.0
    return np.array([0.0, 1.0, decay, close_step, open_step, initial_blade_stroke,
                     mode, turbine_view.angle_min_deg, span, plant.turbine.opening_max, law_start, target])


def _blade_setup(plant, steady, dt_s, characteristics):
    """(blade params, cam openings, cam angles at the combinator's head, initial blade state, initial controls)."""
    from simulate.components.turbine.double_regulated import DoubleRegulatedTurbine

    view = characteristics
    if not isinstance(view, DoubleRegulatedTurbine):
        raise InputError("the blade servo needs three-input characteristics (a DoubleRegulatedTurbine view)")
    a0 = steady.stroke * plant.turbine.opening_max
    if view.cam is None:
        openings = np.array([0.0, plant.turbine.opening_max])
        angles = np.full(2, float(view.fixed_angle_deg))
        phi0 = float(view.fixed_angle_deg)
    else:
        head = plant.combinator.head_m if plant.combinator.head_m is not None else steady.head_m
        openings = view.cam.openings.copy()
        angles = view.cam.slice(float(head))
        phi0 = float(view.blade_angle(steady.unit_speed_rpm, a0)) if plant.combinator.head_m is None else float(
            view.cam.angle(a0, head))
    y_b0 = view.blade_stroke(phi0)
    blade = blade_parameters(plant, view, y_b0, dt_s)
    return blade, openings, angles, np.array([phi0]), np.array([steady.stroke, y_b0])


def build_governor_blades(plant, steady, dt_s: float, schedules, characteristics=None):
    """Governor on the vanes through the servo ``governor.servo_model`` names (the governor component itself,
    :func:`simulate.components.control.governor.build_governor`), blades through their servo (module docstring)."""
    return _with_blades(build_governor(plant, steady, dt_s, schedules), plant, steady, dt_s, characteristics)


def build_prescribed_blades(plant, steady, dt_s: float, schedules, characteristics=None):
    """The scenario's vane law (:func:`simulate.components.control.governor.build_prescribed`), blades through their
    servo."""
    return _with_blades(build_prescribed(plant, steady, dt_s, schedules), plant, steady, dt_s, characteristics)


def _with_blades(vane, plant, steady, dt_s: float, characteristics):
    """The vane component ``vane`` (a :class:`CompiledPart` of one control) with the blades as control 1: its step
    bound into :func:`blade_control_step`, its control vector lengthened to two."""
    blade, openings, angles, bstate, controls = _blade_setup(plant, steady, dt_s, characteristics)
    vane_state = (*vane.state[:-1], controls)  # the vane component's control vector, now [vanes, blades]
    params = (vane.params, blade, openings, angles, np.array([1e-9 * dt_s]))
    step = Bound(blade_control_step, (("vane_control", vane.functions["step"]),))
    return _part(vane.name, step, params, (vane_state, bstate), blade, bstate, characteristics.blade_range_deg,
                 vane.hooks.summary, vane.hooks.reads)


def _part(name, step, params, state, blade, bstate, blade_range, summary=None, reads=()):
    phi0 = blade[_ANGLE_MIN] + blade[_Y0] * blade[_SPAN]
    warnings_after = None
    if blade_range is not None:
        lo, hi = blade_range

        def warnings_after(signals):
            angles = signals["blade_angle_deg"]
            if angles.min() < lo - 1e-9 or angles.max() > hi + 1e-9:
                return [f"the blade angle went to {angles.min():.4g}-{angles.max():.4g} deg, outside the nets' "
                        f"training range {lo:.4g}-{hi:.4g} deg (extrapolated): narrow blade_servo.angle_min_deg/"
                        f"angle_max_deg or train the nets over the blade angles the run visits"]
            return []

    controls = state[0][-1]
    hooks = PartHooks(summary=dict(summary or {}), initial_signals=(phi0, float(bstate[0])), n_controls=2,
                      initial_controls=(float(controls[0]), float(controls[1])), warnings_after=warnings_after,
                      reads=tuple(reads))
    return CompiledPart(kind="control", name=f"{name} + blades", functions={"step": step, "record": blade_record},
                        params=params, state=state, signals=SIGNALS, hooks=hooks)


def time_scales(plant, schedules) -> list:
    """The governor's (while it is in control) and the blade servo's time constant."""
    from simulate.components.control.governor import time_scales as governor_scales
    from simulate.components.timescale import TimeScale

    out = governor_scales(plant, schedules) if schedules.mode == GOVERNOR else []
    servo = plant.blade_servo
    if servo is not None and plant.combinator is not None and plant.combinator.relation != "off":
        out.append(TimeScale("blade_servo.servo_time_s", servo.servo_time_s))
    return out
