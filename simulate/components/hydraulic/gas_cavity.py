"""The discrete gas cavity model (DGCM, ``penstock.column_separation = "dgcm"``) of the MOC penstock: a small volume
of free gas at every computing node, which follows the isothermal gas law and which the compatibility equations of
the method of characteristics compress and expand, so that a node's head never falls to the vapour head and a
cavity grows where the gas expands (Wylie, "Simulation of vaporous and gaseous cavitation", J. Fluids Eng. 106
(1984) 307-311; Wylie and Streeter, *Fluid Transients in Systems*, 1993, sect. 8.4; compared with the DVCM on the
Adelaide rig by Bergant and Simpson, "Pipeline column separation flow regimes", J. Hydraul. Eng. 125(8), 1999).

Equations numbered here (the notation of :mod:`simulate.components.hydraulic.cavitation`: heads piezometric above
the tailwater datum, m; H_v the vapour head (C1) of the node; C+ line H = C_P - B_L Q_in from the reach upstream of
the node, C- line H = C_M + B_R Q_out from the reach downstream of it; dt the step, psi ``cavity_weighting``)::

    (G1)  y = H - H_v = (p - p_v) / (rho g)                  the partial pressure of the free gas as a head, m
    (G2)  y V = H_atm alpha_0 V_n = c_g                      isothermal gas law, p_g V_g = p_g0 V_g0 (absolute
                                                             pressures; the reference p_g0 is the atmospheric
                                                             pressure, H_atm, where the gas takes the void
                                                             fraction alpha_0 of the node's pipe volume V_n)
    (G3)  V = V_old + dt [psi (Q_out - Q_in) + (1 - psi) (Q_out,old - Q_in,old)]     continuity, as (C4)
    (G4)  a y^2 + b y - c_g = 0,  a = psi dt (1/B_L + 1/B_R),                        (G1)-(G3) with the C+ and C-
          b = V_old + (1 - psi) dt (Q_out,old - Q_in,old)
              + psi dt [(H_v - C_M) / B_R - (C_P - H_v) / B_L]
          y = 2 c_g / (b + sqrt(b^2 + 4 a c_g))  (b >= 0),   (-b + sqrt(b^2 + 4 a c_g)) / (2 a)  (b < 0)
    (G5)  H = H_v + y,  V = c_g / y,  Q_in = (C_P - H) / B_L,  Q_out = (H - C_M) / B_R
    (G6)  downstream end (the turbine or valve; only C+ reaches it, Q_out the boundary's):
          a = psi dt / B_L,  b = V_old + (1 - psi) dt (...) + psi dt [Q_out - (C_P - H_v) / B_L]
    (G7)  the relation the turbine boundary solves there, H = C_L + k Q_out: the tangent of (G6) at the last step's
          flow q_0, k = -psi dt / (c_g / y_0^2 + psi dt / B_L),  C_L = H_v + y_0 - k q_0
    (G8)  the downstream end after the boundary is solved (H, Q_out its head and flow): Q_in = (C_P - H) / B_L and
          V from (G3), the gas volume that continuity gives at the boundary's head

(G4) has one positive root since a > 0 and c_g > 0, and the two forms take it without cancellation; the node's head
stays above the vapour head, and with alpha_0 -> 0 the model turns into the DVCM ((C2) while y >> c_g / V, (C3)
while the gas volume is large). The DGCM's columns ``cavity_volume_m3`` and ``outlet_cavity_volume_m3`` are the gas
volume beyond :data:`CAVITY_EXPANSION` times its volume at the atmospheric pressure, max(V - E alpha_0 V_n, 0): a
cavity "forms" where the gas's partial pressure falls below H_atm / E (0.1 m of water: the absolute pressure within
a kPa of the vapour pressure, where the DVCM's liquid would stand at the vapour pressure and open its cavity), the
DVCM's cavity volumes in the limit. The gas of a pressure merely below the atmospheric (a draft tube's, a siphon's)
is not a cavity. The node's pipe volume
V_n is half of each reach beside it (the reservoir node holds no gas; its head is the reservoir's); the gas at each
node starts from (G2) at the steady head. (G7) is exact where the boundary's flow does not change over the step (a
shut valve) and exact to first order in the change otherwise. The update keeps the head the boundary was solved with
and the volume continuity gives there, (G8): the pipe's end, the turbine and a manifold's branches share one head
and one flow at every step, and the gas law (G2) at that node is met to second order in the flow's change over the
step (each step solves (G4)-(G6) afresh from the volume, so the error does not accumulate). Where the tangent
overshoots so far that (G8) gives no gas (V <= 0) or a head at or below the vapour head, the update solves (G6) at
the boundary's flow instead (the gas law exactly, the head then one step's tangent error off the boundary's).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from simulate.components.hydraulic.friction import steady_advance as reach_friction_advance
from simulate.components.hydraulic.friction import with_friction
from simulate.components.hydraulic.penstock import (foreseen_outlet_flow, moc_cminus, moc_cplus,
                                                    moc_inlet_characteristic, moc_turbine_relation)

#: E: the gas of a node is a cavity beyond E times its volume at the atmospheric pressure (its partial pressure below
#: H_atm / E, 0.1 m of water; module docstring).
CAVITY_EXPANSION = 100.0


@numba.njit(cache=True)
def dgcm_gas_head(a, b, c_g):
    """The positive root y (m) of a y^2 + b y - c_g = 0, eq. (G4), without cancellation."""
    root = math.sqrt(b * b + 4.0 * a * c_g)
    if b >= 0.0:
        return 2.0 * c_g / (b + root)
    return (-b + root) / (2.0 * a)


@numba.njit(cache=True)
def dgcm_record(track, j, volume, old_volume, reference_m3, step):
    """Keep node ``j``'s gas volume in ``track`` row 0 and the figures of its cavity, the gas beyond
    ``reference_m3`` (rows 1 largest, 2 its step, 5 cavities formed, 6 the step of the first); returns the
    cavity's volume, m^3."""
    track[0, j] = volume
    cavity = volume - reference_m3
    if cavity > track[1, j]:
        track[1, j] = cavity
        track[2, j] = step
    if old_volume <= reference_m3 < volume:
        if track[5, j] == 0.0:
            track[6, j] = step
        track[5, j] += 1.0
    return max(cavity, 0.0)


@numba.njit(cache=True)
def dgcm_outlet_gas_head(c_p, b_l, volume_part, q_out, vapour_head_m, c_g, dt_s, psi):
    """y of the downstream-end node at the boundary flow ``q_out``, eq. (G6); ``volume_part`` = V_old + (1 - psi) dt
    (Q_out,old - Q_in,old)."""
    return dgcm_gas_head(psi * dt_s / b_l, volume_part + psi * dt_s * (q_out - (c_p - vapour_head_m) / b_l), c_g)


@numba.njit(cache=True)
def moc_step_dgcm(heads, flows, inflows, track, totals, impedance, friction, vapour, scal, gas, reservoir_head_m,
                  outlet_head_m, outlet_flow_m3_s, step, new_heads, new_flows, new_inflows):
    """One MOC step with the discrete gas cavity model, eqs. (G1)-(G6): ``flows`` at the reaches' upstream ends,
    ``inflows`` at their downstream ends (each node's Q_out and Q_in), ``gas`` = (c_g per node (m^4), the gas volume
    at the reference pressure per node (m^3)), ``scal`` = [dt (s), psi], ``track`` row 0 the gas volumes,
    ``totals`` = [total cavity volume (m^3), -, nodes with a cavity]; the downstream end takes the boundary's head
    and flow, eq. (G8)."""
    n = heads.size - 1
    dt_s, psi = scal[0], scal[1]
    c_gas, reference = gas[0], gas[1]
    total = 0.0
    count = 0
    c_m = moc_inlet_characteristic(heads, inflows, impedance, friction)
    new_heads[0] = reservoir_head_m
    new_flows[0] = (reservoir_head_m - c_m) / impedance[0]
    new_inflows[0] = new_flows[0]
    for j in range(1, n + 1):
        bl = impedance[j - 1]
        c_p = moc_cplus(heads, flows, impedance, friction, j)
        volume = track[0, j]
        part = volume + (1.0 - psi) * dt_s * (flows[j] - inflows[j])  # eq. (G3), the old flows
        if j < n:
            br = impedance[j]
            c_m = moc_cminus(heads, inflows, impedance, friction, j)
            y = dgcm_gas_head(psi * dt_s * (1.0 / bl + 1.0 / br),
                              part + psi * dt_s * ((vapour[j] - c_m) / br - (c_p - vapour[j]) / bl), c_gas[j])  # (G4)
            h = vapour[j] + y  # eq. (G5)
            new_flows[j] = (h - c_m) / br
            gas_volume = c_gas[j] / y
        else:
            h = outlet_head_m
            gas_volume = part + psi * dt_s * (outlet_flow_m3_s - (c_p - h) / bl)  # eq. (G8)
            if gas_volume <= 0.0 or h <= vapour[n]:  # the tangent (G7) overshot: the gas law at the boundary's flow
                y = dgcm_outlet_gas_head(c_p, bl, part, outlet_flow_m3_s, vapour[n], c_gas[n], dt_s, psi)  # (G6)
                h = vapour[n] + y
                gas_volume = c_gas[n] / y
            new_flows[n] = outlet_flow_m3_s
        new_heads[j] = h
        new_inflows[j] = (c_p - h) / bl  # eq. (G5)
        cavity = dgcm_record(track, j, gas_volume, volume, reference[j], step)
        if cavity > 0.0:
            total += cavity
            count += 1
    reach_friction_advance(friction, flows, new_flows)
    totals[0] = total
    totals[2] = count


# The DGCM's functions in the time loop: the MOC penstock's state and params (see the comment above
# simulate.components.hydraulic.penstock.moc_relation) with params[4] = ``gas`` of :func:`moc_step_dgcm`.
@numba.njit(cache=True)
def moc_dgcm_relation(p, s, upstream_head_m):
    """The relation at the downstream end, the tangent (G7) of the gas law there at the last step's flow; a cavity
    there (its gas beyond the reference volume) is kept in ``s[5][1]`` for the failure message."""
    c = s[2][0]
    flows, inflows, track = s[1][c], s[3][c], s[4]
    n = flows.size - 1
    c_p, k = moc_turbine_relation(s[0][c], flows, p[0], p[1])
    b_l = -k
    dt_s, psi = p[3][0], p[3][1]
    c_g = p[4][0][n]
    q0 = foreseen_outlet_flow(s)  # the tangent at the boundary flow foreseen for the step
    part = track[0, n] + (1.0 - psi) * dt_s * (flows[n] - inflows[n])
    y0 = dgcm_outlet_gas_head(c_p, b_l, part, q0, p[2][n], c_g, dt_s, psi)
    slope = -psi * dt_s / (c_g / (y0 * y0) + psi * dt_s / b_l)  # eq. (G7)
    s[5][1] = 1.0 if c_g / y0 > p[4][1][n] else 0.0
    return p[2][n] + y0 - slope * q0, slope


@numba.njit(cache=True)
def moc_dgcm_inlet_relation(p, s):
    """(C_M, B) of the C- line at the inlet, H = C_M + B Q (a branch's at the manifold): from the flow at the first
    reach's downstream end, which differs from the flow at its upstream end wherever node 1's gas volume changes
    (:func:`simulate.components.hydraulic.penstock.moc_inlet_relation` reads it only while a vapour cavity is
    open)."""
    c = s[2][0]
    return moc_inlet_characteristic(s[0][c], s[3][c], p[0], p[1]), p[0][0]


@numba.njit(cache=True)
def moc_dgcm_update(p, s, upstream_head_m, head_m, flow_m3_s):
    heads, flows, cur, inflows, track, totals = s
    c = cur[0]
    step = cur[1] + 1
    moc_step_dgcm(heads[c], flows[c], inflows[c], track, totals, p[0], p[1], p[2], p[3], p[4], upstream_head_m,
                  head_m, flow_m3_s, float(step), heads[1 - c], flows[1 - c], inflows[1 - c])
    cur[0] = 1 - c
    cur[1] = step
    totals[1] = 0.0


@numba.njit(cache=True)
def moc_dgcm_record(p, s, out):
    """Columns ``cavity_volume_m3`` (the conduit's gas beyond :data:`CAVITY_EXPANSION` times its volume at the
    atmospheric pressure) and ``outlet_cavity_volume_m3`` (the same at the turbine or valve)."""
    track = s[4]
    n = track.shape[1] - 1
    out[0] = s[5][0]
    out[1] = max(track[0, n] - p[4][1][n], 0.0)


def node_pipe_volumes_m3(penstock, x_m) -> np.ndarray:
    """The pipe volume of every node, half of each reach beside it, m^3 (the reservoir node's half reach too; it
    holds no gas)."""
    x = np.asarray(x_m, float)
    mid = 0.5 * (x[1:] + x[:-1])
    area = np.empty(mid.size)
    start = 0.0
    for seg in penstock.segments:
        area[(mid >= start) & (mid <= start + seg.length_m)] = seg.area_m2
        start += seg.length_m
    reach = area * np.diff(x)
    return 0.5 * (np.concatenate(([0.0], reach)) + np.concatenate((reach, [0.0])))


def build_dgcm(penstock, x_m, params, state, friction):
    """The DGCM's functions and parameters for :func:`simulate.components.hydraulic.penstock.build_moc` (registry
    :data:`simulate.components.registry.COLUMN_SEPARATION`): ``params`` gains ``gas`` = (c_g per node, eq. (G2), the
    gas volume beyond which a node's gas is a cavity, :data:`CAVITY_EXPANSION` times its volume at the atmospheric
    pressure); ``state``'s gas volumes (track row 0) start from (G2) at the
    steady heads, which :func:`simulate.components.hydraulic.cavitation.check_steady_heads` has found above the
    vapour heads."""
    from simulate.components.hydraulic import cavitation

    settings = cavitation.vapour_settings(penstock)
    vapour = params[2]
    heads = state[0][0]
    gas_head = heads - vapour  # eq. (G1)
    at_atmosphere = settings.gas_void_fraction * node_pipe_volumes_m3(penstock, x_m)
    at_atmosphere[0] = 0.0
    c_gas = settings.atmospheric_pressure_head_m * at_atmosphere  # eq. (G2)
    reference = CAVITY_EXPANSION * at_atmosphere  # a cavity beyond it
    track = state[4]
    track[0, 1:] = c_gas[1:] / gas_head[1:]
    bind = {"reach_friction_loss": friction.loss, "reach_friction_advance": friction.advance}
    bind.update({f.__name__: friction.bind(f) for f in (moc_cplus, moc_cminus, moc_inlet_characteristic,
                                                          moc_turbine_relation)})
    functions = {"relation": with_friction(moc_dgcm_relation, bind), "update": with_friction(moc_dgcm_update, bind),
                 "record": moc_dgcm_record, "inlet_relation": with_friction(moc_dgcm_inlet_relation, bind)}
    return functions, params + ((c_gas, reference),)


__all__ = ["CAVITY_EXPANSION", "dgcm_gas_head", "moc_step_dgcm", "moc_dgcm_relation", "moc_dgcm_inlet_relation",
           "moc_dgcm_update", "moc_dgcm_record", "node_pipe_volumes_m3", "build_dgcm"]
