"""Headrace tunnel and surge tank between the reservoir and the penstock (registry kind "upstream").

Plant file: the optional ``[surge_tank]`` section (:class:`SurgeTankConfig`, below). Heads are piezometric
above the tailwater datum, as everywhere in the simulator. With z the tank level, Q_t the tunnel flow (reservoir ->
tank), Q_p the penstock inlet flow and Q_s = Q_t - Q_p the flow into the tank:

    tunnel (rigid column):  L / (g A_t) dQ_t/dt = H_res - H_j - K_t Q_t|Q_t|,   K_t = f L / (2 g D A_t^2)
    throttle:               H_j = z + R Q_s|Q_s|          (H_j: head at the junction = the penstock's upstream head)
    tank continuity:        A_s dz/dt = Q_s

(the classical mass-oscillation equations, e.g. Chaudhry, Applied Hydraulic Transients, ch. 11; no paper of this
project covers the tank). They are integrated by symplectic Euler (tunnel flow first, then the level with the new
flow): for the frictionless tank it keeps the oscillation's energy bounded with no drift, amplitude error about
omega dt / 2 (1e-4 at dt = 0.02 s and a 200 s period). The penstock sees H_j of the previous step (explicit coupling:
the mass oscillation is 3-4 orders slower than the step).

Timeseries columns: ``surge_level_m`` (z) and ``tunnel_flow_m3_s`` (Q_t); the named signal ``upstream_level_m``
(:mod:`simulate.components.signals`) is z.

Linearized about the steady flow Q0 and the turbine's head H0 (per unit: q = dQ/Q0, h = dz/H0; the throttle's loss
R Q_s|Q_s| has no slope at Q_s = 0), the equations are the block of :func:`linear_counterpart`::

    T_wt dq_t/dt = -h_z - r_t q_t,   T_s dh_z/dt = q_t - q_p,   h_j = h_z
    T_wt = L Q0 / (g A_t H0),  T_s = A_s H0 / Q0,  r_t = 2 K_t Q0^2 / H0
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from hillchart.constants import G_M_S2
from simulate.components.contract import ENTRIES, LinearBlock, StateArray
from simulate.components.parameters import parameter, validate_parameters

SIGNALS = ("surge_level_m", "tunnel_flow_m3_s")
#: Its state: the tank level z (m above tailwater), the tunnel flow Q_t and the flow into the tank Q_s of the last step.
STATES = (StateArray("tank", "m; m^3/s; m^3/s", "the tank level z, the tunnel flow Q_t, the flow into the tank Q_s",
                     ENTRIES, entries=("level_m", "tunnel_flow_m3_s", "tank_flow_m3_s")),)


@numba.njit(cache=True)
def surge_tank_head(p, s):
    """H_j = z + R Q_s|Q_s| with the flows of the last step."""
    scal = p[0]
    state = s[0]
    q_s = state[2]
    return state[0] + scal[1] * q_s * abs(q_s)


@numba.njit(cache=True)
def surge_tank_level(p, s):
    """The tank level z, m above tailwater (the datum of the heads)."""
    return s[0][0]


@numba.njit(cache=True)
def surge_tank_step(p, s, inlet_flow_m3_s, dt_s):
    scal = p[0]
    state = s[0]
    h_res, throttle, gat_over_l, k_t, area = scal[0], scal[1], scal[2], scal[3], scal[4]
    z, q_t = state[0], state[1]
    q_s = q_t - inlet_flow_m3_s
    h_j = z + throttle * q_s * abs(q_s)
    q_t = q_t + dt_s * gat_over_l * (h_res - h_j - k_t * q_t * abs(q_t))
    q_s = q_t - inlet_flow_m3_s
    state[0] = z + dt_s * q_s / area
    state[1] = q_t
    state[2] = q_s


@numba.njit(cache=True)
def surge_tank_record(p, s, out):
    out[0] = s[0][0]
    out[1] = s[0][1]


def build_surge_tank(plant, steady, dt_s: float):
    """Compiled surge tank at the steady state: Q_t = Q_p = Q0, z = H_res - K_t Q0|Q0|, no flow into the tank."""
    from simulate.components.registry import CompiledPart, PartHooks

    tank = plant.surge_tank
    q0 = steady.flow_m3_s
    k_t = tank.steady_loss_coefficient_s2_m5
    h_res = plant.penstock.static_head_m
    z0 = h_res - k_t * q0 * abs(q0)
    scal = np.array([h_res, tank.throttle_loss_coefficient, G_M_S2 * tank.tunnel_area_m2 / tank.tunnel_length_m,
                     k_t, tank.area_m2])
    state = np.array([z0, q0, 0.0])

    def warnings_after(signals):
        out = []
        if tank.level_max_m is not None:
            crest = h_res + tank.level_max_m
            top = float(np.max(signals["surge_level_m"]))
            if top >= crest:
                out.append(f"the surge tank level reached {top:.4g} m, at or above the overflow crest "
                           f"(surge_tank.level_max_m = {tank.level_max_m!r} m above the static level {h_res:.4g} m): "
                           f"the tank would overflow, which the model does not represent")
        return out

    def summary_after(time_s, signals):
        """The highest and lowest surge-tank level and when (m above the tailwater, the datum of the heads): what
        a tank's design is judged on."""
        level = signals["surge_level_m"]
        i, j = int(np.argmax(level)), int(np.argmin(level))
        return {"surge_level_max_m": float(level[i]), "t_surge_level_max_s": float(time_s[i]),
                "surge_level_min_m": float(level[j]), "t_surge_level_min_s": float(time_s[j])}

    def error_after(time_s, signals):
        if tank.level_min_m is None:
            return ""
        bottom = h_res + tank.level_min_m
        low = signals["surge_level_m"] <= bottom
        if not np.any(low):
            return ""
        i = int(np.argmax(low))
        return (f"the surge tank level fell to {signals['surge_level_m'][i]:.4g} m at t = {time_s[i]:.4g} s, at or "
                f"below the tank bottom (surge_tank.level_min_m = {tank.level_min_m!r} m below the static level "
                f"{h_res:.4g} m): air would enter the penstock; enlarge surge_tank.area_m2 or raise the bottom")

    return CompiledPart(
        kind="upstream", name="surge_tank",
        functions={"head": surge_tank_head, "step": surge_tank_step, "record": surge_tank_record,
                   "level": surge_tank_level},
        params=(scal,), state=(state,), signals=SIGNALS,
        hooks=PartHooks(initial_head_m=z0, initial_signals=(z0, q0), warnings_after=warnings_after,
                        error_after=error_after, summary_after=summary_after,
                        summary={"surge_tank_period_s": tank.period_s}))


def time_scales(plant, schedules) -> list:
    """The mass-oscillation period, exchanged with the penstock every step (see :mod:`simulate.loop.timestep`)."""
    from simulate.components.timescale import TimeScale

    return [TimeScale(label, value, coupled=True) for label, value in plant.surge_tank.time_constants().items()]


def linear_counterpart(plant, steady) -> LinearBlock:
    """The mass-oscillation equations linearized at the steady state (module docstring): the tunnel's water time,
    the tank's filling time and the tunnel's friction slope, per unit of the turbine's steady flow and head."""
    tank, q0, h0 = plant.surge_tank, steady.flow_m3_s, steady.head_m
    values = {"tunnel_water_time_s": tank.tunnel_length_m * q0 / (G_M_S2 * tank.tunnel_area_m2 * h0),
              "tank_filling_time_s": tank.area_m2 * h0 / q0,
              "tunnel_friction_slope": 2.0 * tank.steady_loss_coefficient_s2_m5 * q0 ** 2 / h0}
    return LinearBlock("T_wt dq_t/dt = -h_z - r_t q_t, T_s dh_z/dt = q_t - q_p (the linearized mass oscillation)",
                       values, {"tunnel_water_time_s": "s", "tank_filling_time_s": "s",
                                "tunnel_friction_slope": "pu head/pu flow"})


@dataclass(frozen=True)
class SurgeTankConfig:
    """Headrace tunnel (rigid water column, reservoir -> tank) and a simple throttled surge tank at the penstock inlet.

    ``area_m2`` tank cross-section A_s; ``throttle_loss_coefficient`` R of the throttle loss R Q_s|Q_s| (s^2/m^5,
    Q_s the flow into the tank; 0 allowed); ``tunnel_length_m`` L, ``tunnel_diameter_m`` D, ``tunnel_darcy_friction``
    f (0 allowed); ``level_max_m`` (optional) overflow crest above the static level: reaching it is a warning;
    ``level_min_m`` (optional, negative) tank bottom below the static level: reaching it is an error (air enters the
    penstock).
    """

    area_m2: float = parameter(unit="m^2", low=0.0, low_open=True, high=1e5, description="tank cross-section A_s")
    throttle_loss_coefficient: float = parameter(unit="s^2/m^5", low=0.0, high=1e4,
                                                 description="R of the throttle loss R Q_s|Q_s|")
    tunnel_length_m: float = parameter(unit="m", low=0.0, low_open=True, high=1e5, description="headrace length L")
    tunnel_diameter_m: float = parameter(unit="m", low=0.0, low_open=True, high=30.0,
                                         description="headrace diameter D")
    tunnel_darcy_friction: float = parameter(unit="1", low=0.0, high=0.2,
                                             description="headrace Darcy-Weisbach friction factor f")
    level_max_m: float | None = parameter(None, unit="m", low=0.0, low_open=True, high=1e4,
                                          description="overflow crest above the static level (a warning)")
    level_min_m: float | None = parameter(None, unit="m", low=-1e4, high=0.0, high_open=True,
                                          description="tank bottom below the static level (an error)")

    def __post_init__(self):
        validate_parameters("surge_tank", self)

    @property
    def tunnel_area_m2(self) -> float:
        return math.pi * self.tunnel_diameter_m ** 2 / 4.0

    @property
    def steady_loss_coefficient_s2_m5(self) -> float:
        """K_t = f L / (2 g D A_t^2) of the tunnel's steady loss K_t Q|Q| (the throttle passes no steady flow)."""
        return self.tunnel_darcy_friction * self.tunnel_length_m / (2.0 * G_M_S2 * self.tunnel_diameter_m
                                                                     * self.tunnel_area_m2 ** 2)

    def time_constants(self) -> dict:
        """Time constants the simulation step must resolve (see :mod:`simulate.loop.guards`)."""
        return {"surge tank period 2 pi sqrt(L A_s / (g A_t)) (surge_tank.area_m2, tunnel_length_m, "
                "tunnel_diameter_m)": self.period_s}

    @property
    def period_s(self) -> float:
        """Mass-oscillation period 2 pi sqrt(L A_s / (g A_t)) of the frictionless tank, s."""
        return 2.0 * math.pi * math.sqrt(self.tunnel_length_m * self.area_m2 / (G_M_S2 * self.tunnel_area_m2))
