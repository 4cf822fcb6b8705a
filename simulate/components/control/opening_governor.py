"""Governor mode ``opening`` (``governor.mode``): opening control, as a gate limiter or a manual set point holds the
guide vanes. The servo's command is the opening reference::

    u = y_ref

so the stroke follows ``opening_reference`` y_ref (stroke fraction; default: the initial stroke) through the servo
(``governor.servo_model``: its lag and rate limits) and stays there; the speed is not controlled (it settles where
the turbine's torque meets the load). A scenario's speed-reference steps (``frequency-steps``) are refused: there is
no speed reference to step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.control.servo import build_vane_servo, first_order_servo_step
from simulate.components.control.speed_governor import CONTROLS, SERVO_STATE, refuse_speed_steps
from simulate.components.parameters import own_keys, parameter
from simulate.components.registry import Bound, CompiledPart, PartHooks


@dataclass(frozen=True)
class OpeningModeConfig:
    """The opening mode's own key of ``[governor]``."""

    opening_reference: float | None = parameter(None, unit="stroke fraction", low=0.0, high=1.5,
                                                description="the stroke mode opening holds (default: the initial "
                                                            "stroke)")


#: Its own key of ``[governor]`` (refused under another mode), the keys it reads (none required: the reference
#: defaults to the initial stroke).
OWN_KEYS = own_keys(OpeningModeConfig)
GOVERNOR_KEYS = tuple(d.name for d in OWN_KEYS)
REQUIRED_KEYS: tuple[str, ...] = ()
#: The named signals it reads: none (the stroke it holds is its own control vector's).
READS: tuple[str, ...] = ()
#: Its state: the servo's, the control vector.
STATES = (SERVO_STATE, CONTROLS)
#: None of its own: the command is the constant reference (the servo's are the servo's).
TIME_SCALES = ()
#: None: the command is a constant reference, no feedback to linearize (the speed is not controlled).
LINEAR_COUNTERPART = None
#: The servo its step calls (bound by the builder, :class:`simulate.components.registry.Bound`).
vane_servo = first_order_servo_step


def check_governor(governor) -> None:
    """The reference within the stroke limits."""
    y_ref = governor.opening_reference
    if y_ref is not None and not governor.stroke_min <= y_ref <= governor.stroke_max:
        raise InputError(f"governor.opening_reference must be in [governor.stroke_min, governor.stroke_max] = "
                         f"[{governor.stroke_min!r}, {governor.stroke_max!r}], got {y_ref!r}")


@numba.njit(cache=True)
def opening_control_step(p, s, sig, t_s, t_next_s, dt_s):
    """The servo on the command y_ref (module docstring): controls at t_next."""
    reference, servo = p
    servo_state, controls = s
    controls[0] = vane_servo(servo, servo_state, reference[0], controls[0], dt_s)
    return controls


def build_opening_governor(plant, steady, dt_s: float, schedules):
    """The opening mode's control part (refused with a scenario that steps the speed reference)."""
    refuse_speed_steps('opening', 'holds the opening', plant, schedules)
    gov = plant.governor
    reference = steady.stroke if gov.opening_reference is None else gov.opening_reference
    servo = build_vane_servo(plant, steady.stroke, dt_s)
    summary = {**servo.summary, "governor_mode": "opening", "opening_reference": float(reference)}
    return CompiledPart(kind="control", name="governor",
                        functions={"step": Bound(opening_control_step, (("vane_servo", servo.step),))},
                        params=(np.array([float(reference)]), servo.params),
                        state=(servo.state, np.array([steady.stroke])), hooks=PartHooks(summary=summary, reads=READS))


__all__ = ["OpeningModeConfig", "OWN_KEYS", "GOVERNOR_KEYS", "REQUIRED_KEYS", "READS", "check_governor",
           "STATES", "TIME_SCALES", "LINEAR_COUNTERPART",
           "opening_control_step", "build_opening_governor"]
