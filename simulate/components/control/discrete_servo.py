"""Second-order discrete hydraulic servo of paper 000 eq. (37) (the NTNU rig's servo, sampled at tau = 0.2 s).

    u(k) / u_s(k) = b0 / (1 - a1 z^-1 - a2 z^-2),  printed: 0.5 / (1 - z^-1 + 0.5 z^-2)      eq. (37)

i.e. ``u(k) = a1 u(k-1) + a2 u(k-2) + b0 u_s(k)`` with a1 = 1, a2 = -0.5, b0 = 0.5 (the text lost the minus signs;
this reading has DC gain b0 / (1 - a1 - a2) = 1, as a servo must, and poles 0.5 +- 0.5j, |z| = 0.707: stable,
damping ratio 0.40, natural frequency 4.3 rad/s at tau = 0.2 s; the other sign patterns give DC gains 0.2 or
1/3 or an unstable pair). u is the guide-vane stroke, u_s the governor's command; the paper writes both as
relative increments, and with DC gain 1 the same recursion holds for absolute strokes started at rest (u = u_s =
y0).

The servo is a sampled device: it updates every ``sample_time_s`` and holds its output in between, so it can sit in
a loop whose step dt divides tau (:func:`check_servo_step`). Pure numba step (``cache=True``):
``discrete_servo_step(params, state, command, dt_s) -> stroke``; layouts :data:`SERVO_PARAMS`, :data:`SERVO_STATE`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.contract import ENTRIES, LinearBlock, StateArray
from simulate.components.control.servo import Servo
from simulate.components.parameters import own_keys, parameter, validate_parameters

#: Layout of the parameter vector (``close_step``/``open_step``: the largest stroke change per sample).
SERVO_PARAMS = ("b0", "a1", "a2", "sample_time_s", "stroke_min", "stroke_max", "close_step", "open_step")
#: Layout of the state vector: the last two outputs and the time left to the next sample (s).
SERVO_STATE = ("u_km1", "u_km2", "time_to_sample_s")
STATES = (StateArray("servo", "stroke fraction; stroke fraction; s", "the last two outputs of eq. (37) and the time "
                     "left to the next sample", ENTRIES, entries=SERVO_STATE),)
#: None: a sampled device, exact at its sample time, which the step divides (:func:`check_servo_step`).
TIME_SCALES = ()


@dataclass(frozen=True)
class DiscreteServoConfig:
    """Coefficients of eq. (37) (defaults: the printed 0.5 / (1 - z^-1 + 0.5 z^-2)) and the sampling time (s).

    ``closing_time_s``/``opening_time_s`` (optional): rate limits, a full stroke in that time (the plant loop passes
    the governor's; eq. (37) is a small-signal model, and without them a load rejection shuts the vanes within a
    few samples). Validated: finite coefficients, DC gain b0 / (1 - a1 - a2) within 1e-9 of 1, poles inside the
    unit circle.
    """

    b0: float = parameter(0.5, unit="1", low=-10.0, high=10.0,
                          description="b0 of eq. (37), the weight of the command")
    a1: float = parameter(1.0, unit="1", low=-10.0, high=10.0,
                          description="a1 of eq. (37), the weight of the last stroke")
    a2: float = parameter(-0.5, unit="1", low=-10.0, high=10.0,
                          description="a2 of eq. (37), the weight of the stroke before it")
    sample_time_s: float = parameter(0.2, unit="s", low=0.0, low_open=True, high=10.0,
                                     description="sampling time tau (a whole multiple of the time step)")
    stroke_min: float = parameter(0.0, unit="stroke fraction", low=0.0, high=1.0, description="lower stroke limit")
    stroke_max: float = parameter(1.0, unit="stroke fraction", low=0.0, low_open=True, high=1.5,
                                  description="upper stroke limit")
    closing_time_s: float | None = parameter(None, unit="s", low=0.0, low_open=True, high=1000.0,
                                             description="time of a full closing stroke at the rate limit")
    opening_time_s: float | None = parameter(None, unit="s", low=0.0, low_open=True, high=1000.0,
                                             description="time of a full opening stroke at the rate limit")

    def __post_init__(self):
        validate_parameters("servo", self)
        if self.stroke_min >= self.stroke_max:
            raise InputError(f"servo.stroke_min must be < servo.stroke_max = {self.stroke_max!r}, "
                             f"got {self.stroke_min!r}")
        denominator = 1.0 - self.a1 - self.a2
        if denominator == 0.0 or abs(self.b0 / denominator - 1.0) > 1e-9:
            raise InputError(f"servo: DC gain b0 / (1 - a1 - a2) must be 1 (a servo follows its command), got "
                             f"{self.b0!r} / {denominator!r}")
        poles = np.roots([1.0, -self.a1, -self.a2])
        if np.max(np.abs(poles)) >= 1.0:
            raise InputError(f"servo: poles of 1 - a1 z^-1 - a2 z^-2 must be inside the unit circle, got "
                             f"|z| = {np.max(np.abs(poles)):.4g} for a1 = {self.a1!r}, a2 = {self.a2!r}")

    def transfer_function(self) -> tuple[np.ndarray, np.ndarray]:
        """``(num, den)`` in powers of z (highest first) for :class:`scipy.signal.dlti`: b0 z^2 / (z^2 - a1 z - a2)."""
        return np.array([self.b0, 0.0, 0.0]), np.array([1.0, -self.a1, -self.a2])


#: Its own keys of ``[governor]``, ``servo_`` and a key of :class:`DiscreteServoConfig` (refused under another servo),
#: and so the keys of ``[governor]`` it reads besides the first-order servo's.
OWN_KEYS = own_keys(DiscreteServoConfig, "b0", "a1", "a2", "sample_time_s", prefix="servo_")
GOVERNOR_KEYS = tuple(d.name for d in OWN_KEYS)


def discrete_servo_parameters(config: DiscreteServoConfig) -> np.ndarray:
    """The float vector (:data:`SERVO_PARAMS`)."""
    tau = config.sample_time_s
    close = np.inf if config.closing_time_s is None else tau / config.closing_time_s
    opening = np.inf if config.opening_time_s is None else tau / config.opening_time_s
    return np.array([config.b0, config.a1, config.a2, tau, config.stroke_min, config.stroke_max, close, opening])


def initial_servo_state(stroke: float) -> np.ndarray:
    """At rest at ``stroke``; the first call samples at once."""
    return np.array([float(stroke), float(stroke), 0.0])


def check_servo_step(config: DiscreteServoConfig, dt_s: float) -> int:
    """Loop steps per servo sample; :class:`InputError` unless ``dt_s`` divides ``sample_time_s``."""
    ratio = config.sample_time_s / dt_s
    if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6 * ratio:
        raise InputError(f"servo.sample_time_s = {config.sample_time_s!r} must be a whole multiple of the time step "
                         f"{dt_s!r} s (the servo samples every tau and holds in between)")
    return int(round(ratio))


@numba.njit(cache=True)
def discrete_servo_step(params, state, command, dt_s):
    """Stroke held over the coming step; at a sampling instant ``u(k) = a1 u(k-1) + a2 u(k-2) + b0 u_s(k)``
    (eq. (37)), rate limited (at most ``close_step``/``open_step`` per sample) and clipped to the stroke limits; the
    recursion continues from the limited stroke (the stroke the vanes have). Updates ``state`` in place.

    Examples
    --------
    >>> p = np.array([0.5, 1.0, -0.5, 0.2, 0.0, 1.0, np.inf, np.inf]); s = np.array([0.0, 0.0, 0.0])
    >>> [round(float(discrete_servo_step(p, s, 0.1, 0.1)), 4) for _ in range(6)]   # step: 0.05 held, 0.1 held, ...
    [0.05, 0.05, 0.1, 0.1, 0.125, 0.125]
    """
    b0, a1, a2, tau = params[0], params[1], params[2], params[3]
    if state[2] <= 1e-9 * tau:
        u = a1 * state[0] + a2 * state[1] + b0 * command  # eq. (37)
        u = min(max(u, state[0] - params[6]), state[0] + params[7])
        u = min(max(u, params[4]), params[5])
        state[1] = state[0]
        state[0] = u
        state[2] += tau
    state[2] -= dt_s
    return state[0]


@numba.njit(cache=True)
def discrete_servo_component_step(sp, ss, command, stroke, dt_s):
    """The servo component's step (:mod:`simulate.components.control.servo`): :func:`discrete_servo_step`."""
    return discrete_servo_step(sp, ss, command, dt_s)


def servo_config(governor) -> DiscreteServoConfig:
    """The :class:`DiscreteServoConfig` of a ``[governor]`` section's ``servo_*`` keys (:data:`GOVERNOR_KEYS`), with
    its stroke and rate limits; errors name the ``[governor]`` keys."""
    keys = {k[len("servo_"):]: getattr(governor, k) for k in GOVERNOR_KEYS if getattr(governor, k) is not None}
    try:
        return DiscreteServoConfig(**keys, stroke_min=governor.stroke_min, stroke_max=governor.stroke_max,
                                   closing_time_s=governor.closing_time_s, opening_time_s=governor.opening_time_s)
    except InputError as exc:
        raise InputError("governor (servo_model = \"discrete\", eq. (37)): "
                         + str(exc).replace("servo.", "governor.servo_").replace("servo: ", "")) from None


def check_governor(governor) -> None:
    """Validate the ``[governor]`` section's eq. (37) keys (called when it is read)."""
    servo_config(governor)


def build_discrete_servo(governor, initial_stroke: float, dt_s: float):
    """Paper 000's discrete servo (eq. (37)) as the governor's servo; ``dt_s`` must divide
    ``governor.servo_sample_time_s``."""
    config = servo_config(governor)
    try:
        check_servo_step(config, dt_s)
    except InputError as exc:
        raise InputError(str(exc).replace("servo.sample_time_s", "governor.servo_sample_time_s")
                         + "; set solver.dt_s (or penstock.reaches) or governor.servo_sample_time_s") from None
    return Servo(discrete_servo_component_step, discrete_servo_parameters(config), initial_servo_state(initial_stroke),
                 summary={"servo_model": "discrete (Wang et al. 2023, eq. (37))",
                          "servo_sample_time_s": config.sample_time_s})


def linear_counterpart(plant, steady) -> LinearBlock:
    """Eq. (37) itself (linear; its rate and stroke limits dropped): b0, a1, a2 at the sample time tau."""
    config = servo_config(plant.governor)
    return LinearBlock("u(k) = a1 u(k-1) + a2 u(k-2) + b0 u_s(k) every tau (paper 000 eq. (37))",
                       {"servo_b0": config.b0, "servo_a1": config.a1, "servo_a2": config.a2,
                        "servo_sample_time_s": config.sample_time_s},
                       {"servo_b0": "1", "servo_a1": "1", "servo_a2": "1", "servo_sample_time_s": "s"})


__all__ = ["STATES", "TIME_SCALES", "linear_counterpart", "OWN_KEYS", "GOVERNOR_KEYS", "servo_config", "check_governor",
           "build_discrete_servo",
           "discrete_servo_component_step", "DiscreteServoConfig", "SERVO_PARAMS", "SERVO_STATE",
           "discrete_servo_parameters", "initial_servo_state", "check_servo_step", "discrete_servo_step"]
