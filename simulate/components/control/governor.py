"""Speed governor (parallel PID with permanent droop and derivative filter) and prescribed guide-vane laws. Pure
step functions on per-unit quantities (paper 000 sections 2.5-2.7). The servo between the governor and the vanes is
a component of its own (``governor.servo_model``, :data:`simulate.components.registry.SERVOS`; the first-order one
in :mod:`simulate.components.control.servo`).

Signals: x = n / n_r - 1 (per-unit speed deviation), x_ref the per-unit speed reference, y the servo stroke
(fraction of full stroke; chart opening a = y * opening_max).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.control.backlash import BacklashConfig
from simulate.components.control.dead_time import DeadTimeConfig
from simulate.components.control.discrete_servo import DiscreteServoConfig
from simulate.components.control.servo import first_order_servo_step
from simulate.components.control.two_stage import TwoStageConfig
from simulate.components.parameters import borrowed, declarations, parameter, validate_parameters
from simulate.components.registry import SERVOS, Bound, CompiledPart, PartHooks
from simulate.components.schedules import GOVERNOR, piecewise_constant, piecewise_linear

@dataclass(frozen=True)
class GovernorConfig:
    """Parallel PID on the per-unit speed error with permanent droop, derivative filter and a first-order servo.

    ``kp`` (stroke per unit speed), ``ki`` (1/s), ``kd`` (s); ``derivative_filter_s`` T_f of kd s / (1 + T_f s);
    ``permanent_droop`` b_p (per-unit speed per stroke); ``servo_time_s`` T_y; ``closing_time_s`` and
    ``opening_time_s``: time for a full stroke at the rate limit; ``stroke_min``/``stroke_max`` stroke limits.

    ``servo_model``: the servo between the governor and the vanes, a component of its own
    (:data:`simulate.components.registry.SERVOS`; the ``servo_*`` keys belong to one servo each and are refused under
    another):

    * ``"first-order"`` (default): T_y, rate limits, stroke limits (:mod:`simulate.components.control.servo`);
    * ``"discrete"``: paper 000's second-order sampled servo, eq. (37), u(k) = a1 u(k-1) + a2 u(k-2) + b0 u_s(k) every
      ``servo_sample_time_s`` (held in between; a whole multiple of the time step), keys ``servo_b0``, ``servo_a1``,
      ``servo_a2``, ``servo_sample_time_s`` (defaults: the printed 0.5 / (1 - z^-1 + 0.5 z^-2) at 0.2 s; DC gain 1
      and stable poles required), with the stroke limits and the rate limits ``closing_time_s``/``opening_time_s``
      applied at each sample (``servo_time_s`` then acts only through the time-step guards);
    * ``"dead-time"``: the first-order servo receiving the command ``servo_dead_time_s`` late
      (:mod:`simulate.components.control.dead_time`);
    * ``"backlash"``: the first-order servo with a play of ``servo_backlash`` (stroke fraction) between it and the
      vanes (:mod:`simulate.components.control.backlash`);
    * ``"two-stage"``: the first-order servo closing at the rate of a full stroke per ``servo_break_closing_time_s``
      once the stroke is at or below ``servo_break_stroke`` (:mod:`simulate.components.control.two_stage`).

    A scenario that prescribes the vane stroke (no governor in control) refuses a servo other than the default.
    """

    kp: float = parameter(unit="stroke/pu speed", low=0.0, high=1000.0, description="proportional gain")
    ki: float = parameter(unit="stroke/(pu speed s)", low=0.0, high=1000.0, description="integral gain")
    kd: float = parameter(unit="stroke s/pu speed", low=0.0, high=1000.0, description="derivative gain")
    derivative_filter_s: float = parameter(unit="s", low=0.0, high=100.0,
                                           description="time constant T_f of the derivative filter")
    permanent_droop: float = parameter(unit="pu speed/stroke", low=0.0, high=1.0, high_open=True,
                                       description="permanent droop b_p, on the servo stroke")
    servo_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=100.0,
                                    description="time constant T_y of the first-order servo")
    closing_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=1000.0,
                                      description="time of a full closing stroke at the rate limit")
    opening_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=1000.0,
                                      description="time of a full opening stroke at the rate limit")
    stroke_min: float = parameter(0.0, unit="stroke fraction", low=0.0, high=1.0, description="lower stroke limit")
    stroke_max: float = parameter(1.0, unit="stroke fraction", low=0.0, low_open=True, high=1.5,
                                  description="upper stroke limit")
    servo_model: str = parameter("first-order", unit="", choices=SERVOS,
                                 description="the servo between the governor and the guide vanes")
    servo_b0: float | None = borrowed(DiscreteServoConfig, "b0")
    servo_a1: float | None = borrowed(DiscreteServoConfig, "a1")
    servo_a2: float | None = borrowed(DiscreteServoConfig, "a2")
    servo_sample_time_s: float | None = borrowed(DiscreteServoConfig, "sample_time_s")
    servo_dead_time_s: float | None = borrowed(DeadTimeConfig, "dead_time_s")
    servo_backlash: float | None = borrowed(BacklashConfig, "backlash")
    servo_break_stroke: float | None = borrowed(TwoStageConfig, "break_stroke")
    servo_break_closing_time_s: float | None = borrowed(TwoStageConfig, "break_closing_time_s")

    def __post_init__(self):
        validate_parameters("governor", self)
        if self.stroke_min >= self.stroke_max:
            raise InputError(f"governor.stroke_min must be < governor.stroke_max = {self.stroke_max!r}, "
                             f"got {self.stroke_min!r}")
        own = SERVOS.attribute(self.servo_model, "GOVERNOR_KEYS", ())
        for key in self.servo_keys():
            if getattr(self, key) is not None and key not in own:
                owners = [name for name in SERVOS.names() if key in SERVOS.attribute(name, "GOVERNOR_KEYS", ())]
                raise InputError(f"governor.{key} is a key of governor.servo_model = {' or '.join(owners)!r}; "
                                 f"with servo_model = {self.servo_model!r} it would be ignored: set servo_model "
                                 f"or remove the key")
        check = SERVOS.attribute(self.servo_model, "check_governor")
        if check is not None:
            check(self)

    @classmethod
    def servo_keys(cls) -> tuple[str, ...]:
        """The optional ``servo_*`` keys: each belongs to one servo model (its module's ``GOVERNOR_KEYS``)."""
        return tuple(d.name for d in declarations(cls) if d.name.startswith("servo_") and d.default is None)


#: Layout of the governor parameter vector passed to the compiled loop.
GOVERNOR_PARAMS = ("kp", "ki", "kd", "derivative_filter_s", "permanent_droop", "initial_stroke", "stroke_min",
                   "stroke_max")


def governor_parameters(governor, initial_stroke: float) -> np.ndarray:
    """The float vector (layout :data:`GOVERNOR_PARAMS`) for :func:`governor_step`.

    Examples
    --------
    >>> g = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.04,
    ...                    servo_time_s=0.2, closing_time_s=10.0, opening_time_s=20.0)
    >>> governor_parameters(g, 0.8).tolist()
    [2.0, 0.5, 0.0, 0.0, 0.04, 0.8, 0.0, 1.0]
    """
    return np.array([governor.kp, governor.ki, governor.kd, governor.derivative_filter_s, governor.permanent_droop,
                     initial_stroke, governor.stroke_min, governor.stroke_max])


@numba.njit(cache=True)
def governor_step(params, state, speed_dev, speed_ref, stroke, dt_s):
    """Controller output u (stroke command) after one step; updates ``state`` = [integral, derivative, e_prev].

    e = x_ref - x - b_p (y - y0) (permanent droop on the servo stroke);
    u = y0 + kp e + I + D, I' = ki e, T_f D' + D = kd e' (backward Euler). The command is clipped to the stroke
    limits. Anti-windup by integrator clamping: the integral stays within [stroke_min - y0, stroke_max - y0], so
    it can always bring the command back from either limit. (Back-calculation of the clipped amount would load the
    derivative kick of a reference step into the integral, which then drives the vanes the wrong way as the kick
    decays; conditional integration would freeze the integral during a long overspeed, and the proportional part
    alone would reopen the vanes while the unit is still far above speed.)

    Examples
    --------
    >>> p = np.array([2.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.9, 0.01, 0.01])
    >>> s = np.zeros(3)
    >>> round(float(governor_step(p, s, -0.01, 0.0, 0.5, 0.1)), 4)   # 0.5 + 2*0.01 + 0.5*0.01*0.1
    0.5205
    """
    kp, ki, kd, tf = params[0], params[1], params[2], params[3]
    droop, y0, y_min, y_max = params[4], params[5], params[6], params[7]
    error = speed_ref - speed_dev - droop * (stroke - y0)
    state[1] = (tf * state[1] + kd * (error - state[2])) / (tf + dt_s)
    state[2] = error
    state[0] = min(max(state[0] + ki * error * dt_s, y_min - y0), y_max - y0)
    command = y0 + kp * error + state[0] + state[1]
    return min(max(command, y_min), y_max)


def closure_law(initial_stroke: float, start_s: float, closing_time_s: float, break_opening: float | None = None,
                break_time_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Breakpoints (times s, strokes) of a linear or two-stage closure from ``initial_stroke`` to 0.

    First stage at the rate of a full stroke per ``closing_time_s`` (0: closes within one step); below
    ``break_opening`` the rate of a full stroke per ``break_time_s``.

    Examples
    --------
    >>> t, y = closure_law(0.8, 1.0, 10.0)
    >>> t.tolist(), y.tolist()
    ([1.0, 9.0], [0.8, 0.0])
    >>> t, y = closure_law(0.8, 1.0, 10.0, break_opening=0.2, break_time_s=20.0)
    >>> [round(float(v), 6) for v in t], y.tolist()
    ([1.0, 7.0, 11.0], [0.8, 0.2, 0.0])
    """
    times, strokes = [start_s], [initial_stroke]
    level, now = initial_stroke, start_s
    if break_opening is not None and break_opening < initial_stroke:
        now += (level - break_opening) * closing_time_s
        times.append(now)
        strokes.append(break_opening)
        level = break_opening
        now += level * break_time_s
    else:
        now += level * closing_time_s
    times.append(now)
    strokes.append(0.0)
    return np.array(times), np.array(strokes)


# ---------------------------------------------------------------------------------------------------------------
# Components for the time loop (registry kind "control"; see simulate.components.registry)
# ---------------------------------------------------------------------------------------------------------------
# A control component owns the control vector (fractions of each control's full stroke; control 0 the guide vane)
# and offers  step(p, s, speed_rpm, t_s, t_next_s, dt_s) -> controls  (the vector at t_next, an array of its state).
#: The servo the governor's step calls: its builder binds the plant's (:class:`Bound`); this default, the first-order
#: servo, serves a call of the step outside the assembled loop.
vane_servo = first_order_servo_step


@numba.njit(cache=True)
def governor_control_step(p, s, speed_rpm, t_s, t_next_s, dt_s):
    """Governor PID on the speed at t, then the guide-vane servo (``vane_servo``): controls at t_next."""
    gov, ref_times, ref_values, scal, servo = p
    state, servo_state, controls = s
    x = speed_rpm / scal[0] - 1.0
    x_ref = piecewise_constant(ref_times, ref_values, t_s + scal[1], 0.0)
    command = governor_step(gov, state, x, x_ref, controls[0], dt_s)
    controls[0] = vane_servo(servo, servo_state, command, controls[0], dt_s)
    return controls


@numba.njit(cache=True)
def prescribed_control_step(p, s, speed_rpm, t_s, t_next_s, dt_s):
    """The prescribed stroke law at t_next (piecewise linear)."""
    law_times, law_strokes, scal = p
    controls = s[0]
    controls[0] = piecewise_linear(law_times, law_strokes, t_next_s + scal[0])
    return controls


def build_vane_servo(plant, initial_stroke: float, dt_s: float):
    """The plant's guide-vane servo (``governor.servo_model``), a :class:`simulate.components.control.servo.Servo`."""
    return SERVOS.builder(plant.governor.servo_model)(plant.governor, initial_stroke, dt_s)


def build_governor(plant, steady, dt_s: float, schedules):
    """Governor + servo on the guide vane; the speed reference follows the scenario's schedule. The servo is the
    one ``governor.servo_model`` names (:data:`simulate.components.registry.SERVOS`)."""
    servo = build_vane_servo(plant, steady.stroke, dt_s)
    scal = np.array([plant.turbine.rated_speed_rpm, 1e-9 * dt_s])
    params = (governor_parameters(plant.governor, steady.stroke), schedules.ref_times_s, schedules.ref_values, scal,
              servo.params)
    state = (np.zeros(3), servo.state, np.array([steady.stroke]))
    return CompiledPart(kind="control", name="governor",
                        functions={"step": Bound(governor_control_step, (("vane_servo", servo.step),))},
                        params=params, state=state, signals=(), hooks=PartHooks(summary=dict(servo.summary)))


def refuse_servo_without_governor(plant, what: str) -> None:
    """:class:`InputError` when ``governor.servo_model`` is not the default servo but no governor drives the vanes
    (``what``: who does): the servo would be accepted and ignored."""
    default = SERVOS.names()[0]
    if plant.governor.servo_model != default:
        raise InputError(f"governor.servo_model = {plant.governor.servo_model!r} would be ignored: {what} drives the "
                         f"guide vanes, not the governor through its servo; leave governor.servo_model out (or "
                         f"{default!r}) for this scenario, or use a scenario in which the governor is in control")


def build_prescribed(plant, steady, dt_s: float, schedules):
    """The guide vane follows the scenario's prescribed law (no governor)."""
    refuse_servo_without_governor(plant, f"the prescribed law of scenario.kind = {plant.scenario.kind!r}")
    params = (schedules.law_times_s, schedules.law_strokes, np.array([1e-9 * dt_s]))
    return CompiledPart(kind="control", name="prescribed", functions={"step": prescribed_control_step},
                        params=params, state=(np.array([steady.stroke]),))


def time_scales(plant, schedules) -> list:
    """The governor's servo, derivative filter and integral time while it is in control (a prescribed law has
    none); sub-stepped within the MOC step (see :mod:`simulate.loop.timestep`)."""
    from simulate.components.timescale import TimeScale

    gov = plant.governor
    if schedules.mode != GOVERNOR:
        return []
    out = SERVOS.time_scales(gov.servo_model, plant, schedules)
    if gov.kd > 0.0 and gov.derivative_filter_s > 0.0:
        # implicit Euler (first order, unlike the servo's exact exponential): 0.05 x T_f keeps the step-halving
        # change of the head rise below 0.1 point on the shipped plant
        out.append(TimeScale("governor.derivative_filter_s", gov.derivative_filter_s, resolve_fraction=0.05))
    if gov.ki > 0.0 and gov.kp > 0.0:
        out.append(TimeScale("governor integral time kp/ki", gov.kp / gov.ki))
    return out
