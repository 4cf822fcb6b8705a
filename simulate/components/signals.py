"""The named signals a control component reads: one float vector of a fixed layout, an argument of the time loop
(the compiled loop allocates nothing), which fills the signals the control reads (``PartHooks.reads``) before each
control sub-step; a signal no control reads is not computed (its entry keeps its value at t = 0).

=================== ============================ =============================================================
name                unit                         filled from
=================== ============================ =============================================================
speed_rpm           r/min                        the shaft's ``speed`` at t
electrical_power_mw MW                           the shaft's ``power(p, s, t)``: the swing rotor's load torque x
                                                 speed, the sub-transient machine's air-gap power (NaN for a
                                                 shaft without one)
turbine_power_mw    MW                           the turbine torque (held over the step) x the shaft's speed at t
net_head_m          m                            the turbine's net head of the last step
vane_stroke         fraction of the full stroke  control 0 (the guide vanes) after the last control sub-step
grid_frequency_hz   Hz                           the shaft's ``grid_frequency(p, s)``: the island's frequency (the
                                                 unit's, f_n n / n_r) or the infinite bus's (f_n (1 + x_bus), x_bus
                                                 stepped by the scenario ``grid-frequency-step``); NaN for a shaft
                                                 without a grid (the swing rotor)
upstream_level_m    m above tailwater            the upstream part's ``level(p, s)``: the surge tank's water level,
                                                 the reservoir's (the static head) without one (NaN for an upstream
                                                 part without one)
=================== ============================ =============================================================

A control component's builder resolves the names it reads to indices (:func:`signal_indices`) and declares them
(``PartHooks.reads``); the engine refuses a plant whose shaft or upstream part does not fill a signal its control reads
(:func:`check_provided`), so a NaN never reaches a control law.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from hillchart.errors import InputError

#: The layout of the signals vector (index = position).
SIGNALS = ("speed_rpm", "electrical_power_mw", "turbine_power_mw", "net_head_m", "vane_stroke", "grid_frequency_hz",
           "upstream_level_m")
(SPEED_RPM, ELECTRICAL_POWER_MW, TURBINE_POWER_MW, NET_HEAD_M, VANE_STROKE, GRID_FREQUENCY_HZ,
 UPSTREAM_LEVEL_M) = range(len(SIGNALS))
#: Power in MW of a torque in N m at a speed in r/min: 2 pi / 60 x 1e-6.
RPM_NM_TO_MW = 2.0 * math.pi / 60.0 * 1e-6
#: The shaft's optional functions behind the signals that only some shafts fill: role -> signal.
SHAFT_SIGNALS = {"power": "electrical_power_mw", "grid_frequency": "grid_frequency_hz"}
#: The upstream part's optional functions behind the signals it fills: role -> signal.
UPSTREAM_SIGNALS = {"level": "upstream_level_m"}


def signal_index(name: str, who: str) -> int:
    """The index of signal ``name`` in the layout; :class:`InputError` naming ``who`` reads it and the layout.

    Examples
    --------
    >>> signal_index("electrical_power_mw", "governor.mode = 'power'")
    1
    """
    if name not in SIGNALS:
        raise InputError(f"{who} reads signal {name!r}, which is not one of the named signals "
                         f"{', '.join(SIGNALS)}")
    return SIGNALS.index(name)


def signal_indices(names, who: str) -> np.ndarray:
    """The indices of ``names`` (int64 vector, for a control's parameter tuple)."""
    return np.array([signal_index(n, who) for n in names], dtype=np.int64)


@numba.njit(cache=True)
def no_electrical_power(p, s, t_s):
    """The electrical power of a shaft without one (NaN: a control reading it is refused before the run)."""
    return math.nan


@numba.njit(cache=True)
def no_grid_frequency(p, s):
    """The grid frequency of a shaft without a grid (NaN: a control reading it is refused before the run)."""
    return math.nan


@numba.njit(cache=True)
def no_upstream_level(p, s):
    """The level of an upstream part without one (NaN: a control reading it is refused before the run)."""
    return math.nan


#: role -> the function the loop calls for a shaft that does not offer it
SHAFT_DEFAULTS = {"power": no_electrical_power, "grid_frequency": no_grid_frequency}
#: role -> the function the loop calls for an upstream part that does not offer it
UPSTREAM_DEFAULTS = {"level": no_upstream_level}


def shaft_function(shaft, role: str):
    """The shaft part's function ``role`` (``power``, ``grid_frequency``), or its NaN default."""
    return shaft.functions.get(role, SHAFT_DEFAULTS[role])


def upstream_function(upstream, role: str):
    """The upstream part's function ``role`` (``level``), or its NaN default."""
    return upstream.functions.get(role, UPSTREAM_DEFAULTS[role])


def provided(shaft, upstream=None) -> tuple[str, ...]:
    """The signals the loop fills with a value for a plant with this shaft part and this upstream part (without
    one, the upstream part's signals are left out)."""
    missing = {signal for role, signal in SHAFT_SIGNALS.items() if role not in shaft.functions}
    missing |= {signal for role, signal in UPSTREAM_SIGNALS.items()
                if upstream is None or role not in upstream.functions}
    return tuple(name for name in SIGNALS if name not in missing)


def check_provided(control, shaft, where: str = "", upstream=None) -> None:
    """:class:`InputError` when the control part reads a signal the shaft part or the upstream part does not fill
    (``where``: a prefix naming the unit)."""
    have = provided(shaft, upstream)
    for name in control.hooks.reads:
        if name in have:
            continue
        if name in UPSTREAM_SIGNALS.values():
            who = "no upstream part is given" if upstream is None else f"the upstream part {upstream.name!r} does not"
            raise InputError(f"{where}the control {control.name!r} reads {name}, which {who} give (an upstream "
                             f"part gives it with a function {', '.join(UPSTREAM_SIGNALS)}(p, s))")
        raise InputError(f"{where}the control {control.name!r} reads {name}, which the shaft "
                         f"{shaft.name!r} does not give (it gives {', '.join(provided(shaft))})")


def initial_signals(control, shaft, head_m: float, torque_nm: float, upstream=None) -> np.ndarray:
    """The signals vector at t = 0: the shaft's values, the turbine's steady head and power, the initial stroke, the
    upstream part's level (NaN without an upstream part)."""
    python = lambda f: getattr(f, "py_func", f)  # noqa: E731  (one-off calls at build time)
    out = np.zeros(len(SIGNALS))
    speed = python(shaft.functions["speed"])(shaft.params, shaft.state)
    out[SPEED_RPM] = speed
    out[ELECTRICAL_POWER_MW] = python(shaft_function(shaft, "power"))(shaft.params, shaft.state, 0.0)
    out[TURBINE_POWER_MW] = torque_nm * speed * RPM_NM_TO_MW
    out[NET_HEAD_M] = head_m
    controls = control.hooks.initial_controls
    out[VANE_STROKE] = controls[0] if controls else control.state[-1][0]
    out[GRID_FREQUENCY_HZ] = python(shaft_function(shaft, "grid_frequency"))(shaft.params, shaft.state)
    out[UPSTREAM_LEVEL_M] = math.nan if upstream is None else python(upstream_function(upstream, "level"))(
        upstream.params, upstream.state)
    return out


__all__ = ["SIGNALS", "SPEED_RPM", "ELECTRICAL_POWER_MW", "TURBINE_POWER_MW", "NET_HEAD_M", "VANE_STROKE",
           "GRID_FREQUENCY_HZ", "UPSTREAM_LEVEL_M", "RPM_NM_TO_MW", "SHAFT_SIGNALS", "UPSTREAM_SIGNALS", "signal_index",
           "signal_indices", "no_electrical_power", "no_grid_frequency", "no_upstream_level", "SHAFT_DEFAULTS",
           "UPSTREAM_DEFAULTS", "shaft_function", "upstream_function", "provided", "check_provided",
           "initial_signals"]
