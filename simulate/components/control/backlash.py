"""Backlash (a dead band) between the first-order servo and the guide vanes (``governor.servo_model =
"backlash"``): the linkage has a play of ``servo_backlash`` b (stroke fraction). The servo piston p follows the
governor's command as the first-order servo does; the vanes y follow the piston only once the play is taken up::

    y <- p - b/2   when p - y > b/2   (the piston drags the vanes open)
    y <- p + b/2   when y - p > b/2   (... or closed)
    y unchanged    otherwise          (the piston moves inside the play)

At t = 0 the piston sits in the middle of the play (p = y = the initial stroke). The vanes stay within half the play
of the piston, so with the piston at a stroke limit they stop b/2 short of it (the play is on the other side of the
linkage), as in the dead-band backlash of the IEEE governor models.

State layout: ``[piston stroke]``; parameters: the first-order servo's vector (:data:`simulate.components.control.
servo.SERVO_PARAMS`) and b/2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from simulate.components.contract import SCALAR, StateArray
from simulate.components.control.servo import Servo, first_order_parameters, require_keys, servo_step
from simulate.components.control.servo import time_scales as first_order_time_scales
from simulate.components.parameters import own_keys, parameter, validate_parameters

#: Index of b/2 in the parameter vector (after the first-order servo's five entries).
_HALF_PLAY = 5


@dataclass(frozen=True)
class BacklashConfig:
    """The play of ``governor.servo_model = "backlash"`` (``[governor]`` key ``servo_backlash``)."""

    backlash: float = parameter(unit="stroke fraction", low=0.0, low_open=True, high=0.2,
                                description="play b of the linkage between the servo and the vanes (backlash "
                                            "servo)")

    def __post_init__(self):
        validate_parameters("servo", self)


#: Its own keys of ``[governor]``, ``servo_`` and a key of :class:`BacklashConfig` (refused under another servo),
#: and so the keys of ``[governor]`` it reads besides the first-order servo's.
OWN_KEYS = own_keys(BacklashConfig, prefix="servo_")
GOVERNOR_KEYS = tuple(d.name for d in OWN_KEYS)


def check_governor(governor) -> None:
    """``servo_backlash`` is required with this servo."""
    require_keys(governor, "backlash", GOVERNOR_KEYS, "the play of the linkage, stroke fraction")


@numba.njit(cache=True)
def backlash(position, driver, half_play):
    """The driven position after its driver moved to ``driver``, with a play of 2 ``half_play``.

    >>> y, out = 0.5, []
    >>> for p in (0.54, 0.58, 0.50, 0.42):
    ...     y = float(backlash(y, p, 0.05))
    ...     out.append(round(y, 9))
    >>> out
    [0.5, 0.53, 0.53, 0.47]
    """
    if driver - position > half_play:
        return driver - half_play
    if position - driver > half_play:
        return driver + half_play
    return position


@numba.njit(cache=True)
def backlash_servo_step(sp, ss, command, stroke, dt_s):
    """The piston by the first-order servo (:func:`simulate.components.control.servo.servo_step`), then the vanes
    through the play (``ss[0]``: the piston stroke)."""
    ss[0] = servo_step(sp, command, ss[0])
    return backlash(stroke, ss[0], sp[_HALF_PLAY])


def build_backlash_servo(governor, initial_stroke: float, dt_s: float) -> Servo:
    """The first-order servo of ``[governor]`` with a play of ``servo_backlash`` between it and the vanes."""
    params = np.append(first_order_parameters(governor, dt_s), 0.5 * governor.servo_backlash)
    return Servo(backlash_servo_step, params, np.array([float(initial_stroke)]),
                 summary={"servo_model": "backlash", "servo_backlash": governor.servo_backlash})


#: Its state: the piston's stroke (the vanes follow it through the play).
STATES = (StateArray("piston", "stroke fraction", "the stroke of the servo's piston, before the play", SCALAR),)
#: None: the play is not linear (no motion for a small signal inside it, the lag outside).
LINEAR_COUNTERPART = None


def time_scales(plant, schedules) -> list:
    """The first-order servo's."""
    return first_order_time_scales(plant, schedules)


__all__ = ["OWN_KEYS", "GOVERNOR_KEYS", "BacklashConfig", "check_governor", "backlash", "backlash_servo_step",
           "build_backlash_servo", "STATES", "LINEAR_COUNTERPART", "time_scales"]
