"""The governor (``[governor]``: :class:`GovernorConfig`) and prescribed guide-vane laws, registry kind "control".

What the governor controls is its mode, ``governor.mode`` (:data:`simulate.components.registry.GOVERNORS`, one
module each): ``speed`` (the default: paper 000 sections 2.5-2.7's parallel PID on the per-unit speed error with the
permanent droop on the servo stroke, :mod:`simulate.components.control.speed_governor`), ``power`` (the droop on the
electrical power, :mod:`simulate.components.control.power_governor`), ``opening`` (the stroke follows an opening
reference, :mod:`simulate.components.control.opening_governor`) and ``dashpot`` (OpenHPL's transient-droop governor,
:mod:`simulate.components.control.dashpot_governor`). The servo between the governor and the vanes is a component of
its own (``governor.servo_model``, :data:`simulate.components.registry.SERVOS`; the first-order one in
:mod:`simulate.components.control.servo`). A mode's step reads the named signals
(:mod:`simulate.components.signals`) its builder resolved.

Signals: x = n / n_r - 1 (per-unit speed deviation), x_ref the per-unit speed reference, y the servo stroke
(fraction of full stroke; chart opening a = y * opening_max).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.contract import StatesOf
from simulate.components.control.pid import (  # noqa: F401  (the PID's parts, re-exported)
    GOVERNOR_PARAMS, PID_KEYS, governor_parameters, governor_step, pid_time_scales)
from simulate.components.control.speed_governor import CONTROLS
from simulate.components.parameters import (Declared, component_store, parameter, section_fields,
                                            validate_parameters, with_component_keys)
from simulate.components.registry import GOVERNORS, SERVOS, CompiledPart, Registry
from simulate.components.schedules import GOVERNOR, piecewise_linear


def own_keys_of(registry: Registry, name: str) -> tuple[Declared, ...]:
    """The ``[governor]`` keys component ``name`` of ``registry`` (a mode or a servo) declares as its own: its
    module's ``OWN_KEYS`` (:func:`simulate.components.parameters.own_keys`)."""
    return tuple(registry.attribute(name, "OWN_KEYS", ()))


def keys_read(registry: Registry, name: str) -> tuple[str, ...]:
    """The ``[governor]`` keys component ``name`` of ``registry`` reads beside the section's common ones: those its
    module's ``GOVERNOR_KEYS`` names (the PID's, shared by several modes) and its own (:func:`own_keys_of`); the
    section refuses them under another mode or servo."""
    shared = tuple(registry.attribute(name, "GOVERNOR_KEYS", ()))
    return shared + tuple(d.name for d in own_keys_of(registry, name) if d.name not in shared)


def _owners(registry: Registry, key: str) -> str:
    return " or ".join(repr(n) for n in registry.names() if key in keys_read(registry, n))


#: The component keys of each state of the registries ({(modes' targets, servos' targets): declarations}).
_COMPONENT_KEYS: dict[tuple, tuple[Declared, ...]] = {}


def _component_keys(field_names: set[str]) -> tuple[Declared, ...]:
    """Every registered mode's own keys, then every servo's (cached per state of the registries); a key declared
    twice, differently, or named as a field of the section is the components' error (:class:`TypeError`)."""
    state = (GOVERNORS.targets(), SERVOS.targets())
    if state not in _COMPONENT_KEYS:
        found: dict[str, tuple[Declared, str]] = {}
        for registry in (GOVERNORS, SERVOS):
            for name in registry.names():
                owner = f"{registry.key} = {name!r}"
                for declared in own_keys_of(registry, name):
                    first = found.setdefault(declared.name, (declared, owner))
                    if declared.name in field_names or first[0] != declared:
                        other = "[governor] itself" if declared.name in field_names else first[1]
                        raise TypeError(f"governor.{declared.name} is declared by {owner} and by {other}: a "
                                        f"component's own key needs a name of its own")
        _COMPONENT_KEYS[state] = tuple(declared for declared, _ in found.values())
    return _COMPONENT_KEYS[state]


@with_component_keys
@dataclass(frozen=True, kw_only=True)
class GovernorConfig:
    """The governor: its control law (``mode``), the servo behind it and the stroke limits.

    ``mode``: what the governor controls (:data:`simulate.components.registry.GOVERNORS`; the keys of a mode are
    refused under another, the ones it needs are required):

    * ``"speed"`` (default): parallel PID on the per-unit speed error e = x_ref - x - b_p (y - y0) with the
      permanent droop on the servo stroke; keys ``kp`` (stroke per unit speed), ``ki`` (1/s), ``kd`` (s),
      ``derivative_filter_s`` T_f of kd s / (1 + T_f s), ``permanent_droop`` b_p (per-unit speed per stroke);
    * ``"power"``: the same PID on e = x_ref - x - b_p (P - P_ref), the permanent droop on the electrical power P
      (per unit of the turbine's rated power) from ``power_reference_mw`` P_ref (default: the initial electrical
      power), the mode of a grid-connected unit (:mod:`simulate.components.control.power_governor`);
    * ``"opening"``: the stroke follows ``opening_reference`` (stroke fraction; default the initial stroke) through
      the servo, speed not controlled (:mod:`simulate.components.control.opening_governor`);
    * ``"dashpot"``: OpenHPL's transient-droop governor, ``permanent_droop``, ``transient_droop``,
      ``dashpot_time_s``, ``pilot_servo_time_s``, ``gate_servo_time_s``
      (:mod:`simulate.components.control.dashpot_governor`);
    * ``"level"``: the headwater level controller of a run-of-river plant, a PI on the upstream level (the signal
      ``upstream_level_m``: the surge tank's, else the reservoir's) to ``level_setpoint_m`` (default the initial
      level), gains ``level_kp`` (stroke/m) and ``level_ki`` (stroke/(m s))
      (:mod:`simulate.components.control.level_governor`).

    Every mode drives the vanes through the servo: ``servo_time_s`` T_y (required by every servo but
    ``rate-limit``); ``closing_time_s`` and ``opening_time_s``: time for a full stroke at the rate limit;
    ``stroke_min``/``stroke_max`` stroke limits.

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
      once the stroke is at or below ``servo_break_stroke`` (:mod:`simulate.components.control.two_stage`);
    * ``"rate-limit"``: a pure ramp limiter, the stroke moves to the command at no more than a full stroke per
      ``closing_time_s``/``opening_time_s``, no lag (:mod:`simulate.components.control.rate_limit`; it reads no
      ``servo_time_s``, which every other servo requires).

    A scenario that prescribes the vane stroke (no governor in control) refuses a servo other than the default.

    The keys after ``servo_model`` are the modes' and servos' own, each declared in the module of the mode or servo
    that owns it (its ``OWN_KEYS``): a mode or servo registered later brings its keys into the section.
    """

    mode: str = parameter("speed", unit="", choices=GOVERNORS, description="what the governor controls")
    kp: float | None = parameter(None, unit="stroke/pu speed", low=0.0, high=1000.0,
                                 description="proportional gain (modes speed, power)")
    ki: float | None = parameter(None, unit="stroke/(pu speed s)", low=0.0, high=1000.0,
                                 description="integral gain (modes speed, power)")
    kd: float | None = parameter(None, unit="stroke s/pu speed", low=0.0, high=1000.0,
                                 description="derivative gain (modes speed, power)")
    derivative_filter_s: float | None = parameter(None, unit="s", low=0.0, high=100.0,
                                                  description="time constant T_f of the derivative filter (modes "
                                                              "speed, power)")
    permanent_droop: float | None = parameter(None, unit="pu speed/stroke (power: pu speed/pu power)", low=0.0,
                                              high=1.0, high_open=True,
                                              description="permanent droop b_p, on the servo stroke (modes speed, "
                                                          "dashpot) or on the electrical power (mode power)")
    servo_time_s: float | None = parameter(None, unit="s", low=0.0, low_open=True, high=100.0,
                                           description="time constant T_y of the first-order servo (every servo "
                                                       "but rate-limit)")
    closing_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=1000.0,
                                      description="time of a full closing stroke at the rate limit")
    opening_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=1000.0,
                                      description="time of a full opening stroke at the rate limit")
    stroke_min: float = parameter(0.0, unit="stroke fraction", low=0.0, high=1.0, description="lower stroke limit")
    stroke_max: float = parameter(1.0, unit="stroke fraction", low=0.0, low_open=True, high=1.5,
                                  description="upper stroke limit")
    servo_model: str = parameter("first-order", unit="", choices=SERVOS,
                                 description="the servo between the governor and the guide vanes")
    #: The values of the registered modes' and servos' own keys (:meth:`component_declarations`), read as
    #: attributes (``governor.servo_dead_time_s``; ``None`` when left out).
    component_keys: tuple = component_store()

    def __post_init__(self):
        validate_parameters("governor", self)
        if self.stroke_min >= self.stroke_max:
            raise InputError(f"governor.stroke_min must be < governor.stroke_max = {self.stroke_max!r}, "
                             f"got {self.stroke_min!r}")
        self._refuse_keys_of_others(GOVERNORS, self.mode, self.mode_keys())
        missing = [f"governor.{k}" for k in GOVERNORS.attribute(self.mode, "REQUIRED_KEYS", ())
                   if getattr(self, k) is None]
        if missing:
            raise InputError(f"governor.mode = \"{self.mode}\" needs {' and '.join(missing)}")
        check = GOVERNORS.attribute(self.mode, "check_governor")
        if check is not None:
            check(self)
        self._refuse_keys_of_others(SERVOS, self.servo_model, self.servo_keys())
        if SERVOS.attribute(self.servo_model, "LAG", True) != (self.servo_time_s is not None):
            raise InputError(f"governor.servo_model = \"{self.servo_model}\" needs governor.servo_time_s (its time "
                             f"constant T_y)" if self.servo_time_s is None else
                             f"governor.servo_time_s would be ignored: governor.servo_model = "
                             f"\"{self.servo_model}\" has no lag; remove the key")
        check = SERVOS.attribute(self.servo_model, "check_governor")
        if check is not None:
            check(self)

    def _refuse_keys_of_others(self, registry: Registry, chosen: str, keys: tuple[str, ...]) -> None:
        """:class:`InputError` for a key of ``keys`` that is set but not read by the ``chosen`` component of
        ``registry`` (the mode or the servo), naming the components that read it."""
        reads = keys_read(registry, chosen)
        field = registry.key.split(".")[1]
        for key in keys:
            if getattr(self, key) is not None and key not in reads:
                raise InputError(f"governor.{key} is a key of {registry.key} = {_owners(registry, key)}; with "
                                 f"{field} = {chosen!r} it would be ignored: set {registry.key} or remove the key")

    @classmethod
    def component_declarations(cls) -> tuple[Declared, ...]:
        """The keys the registered modes and servos declare as their own (each module's ``OWN_KEYS``): the modes'
        in registry order, then the servos'; read from the registries at the time of the call, so a component
        registered later brings its keys. Optional in the section; a key of one mode (servo) is refused under
        another, and the one that owns it requires what it needs."""
        return _component_keys(_FIELD_NAMES)

    @classmethod
    def servo_keys(cls) -> tuple[str, ...]:
        """The servos' own keys (each belongs to one servo model, its module's ``OWN_KEYS``)."""
        return tuple(d.name for name in SERVOS.names() for d in own_keys_of(SERVOS, name))

    @classmethod
    def mode_keys(cls) -> tuple[str, ...]:
        """The optional keys of the modes: the PID's gains and droop (fields of the section, read by the modes whose
        module's ``GOVERNOR_KEYS`` name them) and each mode's own (its module's ``OWN_KEYS``); refused under a mode
        that does not read them."""
        shared = tuple(f.name for f in section_fields(cls) if f.default is None and f.name != "servo_time_s")
        return shared + tuple(d.name for name in GOVERNORS.names() for d in own_keys_of(GOVERNORS, name))


#: The keys of ``[governor]`` that are fields of :class:`GovernorConfig` (no component may declare one).
_FIELD_NAMES = frozenset(f.name for f in section_fields(GovernorConfig))
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
# and offers  step(p, s, signals, t_s, t_next_s, dt_s) -> controls  (the vector at t_next, an array of its state;
# ``signals``: the named signals at t_s, simulate.components.signals).
@numba.njit(cache=True)
def prescribed_control_step(p, s, sig, t_s, t_next_s, dt_s):
    """The prescribed stroke law at t_next (piecewise linear; reads no signal)."""
    law_times, law_strokes, scal = p
    controls = s[0]
    controls[0] = piecewise_linear(law_times, law_strokes, t_next_s + scal[0])
    return controls


def build_governor(plant, steady, dt_s: float, schedules):
    """The governor of ``governor.mode`` (:data:`simulate.components.registry.GOVERNORS`) with the servo
    ``governor.servo_model`` names, on the guide vane."""
    return GOVERNORS.builder(plant.governor.mode)(plant, steady, dt_s, schedules)


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
    """The governor's servo and its mode's time scales (each declared by its module,
    :meth:`simulate.components.registry.Registry.contract`) while it is in control (a prescribed law has none);
    sub-stepped within the MOC step (see :mod:`simulate.loop.timestep`)."""
    gov = plant.governor
    if schedules.mode != GOVERNOR:
        return []
    return SERVOS.time_scales(gov.servo_model, plant, schedules) + GOVERNORS.time_scales(gov.mode, plant, schedules)


def mode_counterpart(plant, steady):
    """The governor's linear counterpart: its mode's (:class:`InputError` for a mode without one)."""
    return GOVERNORS.linear_counterpart(plant.governor.mode, plant, steady)


#: The prescribed law's state: the control vector it sets (the governor's is its mode's part).
STATES = {"build_governor": StatesOf("governor", "governor.mode"), "build_prescribed": (CONTROLS,)}
#: The governor's is its mode's; a prescribed law is an input of the linear model, not a block of it.
LINEAR_COUNTERPART = {"build_governor": mode_counterpart, "build_prescribed": None}
