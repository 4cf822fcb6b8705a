"""Penstock models. Each one gives, for the current step, a linear relation at the turbine inlet

    H = C_L + k Q,   k <= 0   (H head above tailwater in m, Q flow in m^3/s),

which the turbine boundary (:mod:`simulate.components.turbine.boundary`) solves together with the turbine equation,
and then an update of its own state with the solved (H, Q). Four models:

``moc``      method of characteristics on every segment (Courant number 1, quadratic friction, segments in series
             joined at junctions with equal head and flow); k = -B = -a/(g A) of the last reach (the C+ line
             H_P = C_P - B Q_P).
``zdomain``  the single-reach characteristic-line transfer function, eq. (17) of the BP hill-chart paper (004),
             resampled by Tustin from T_so = L/a to the simulation step (eqs. (13)-(20)).
``lumped``   h = -Tw s / (1 + alpha Te^2 s^2) q (paper 000, eqs. (15)-(18)), discretized by Tustin.
``rigid``    Tw dq/dt = -h (inelastic column), discretized by backward Euler.

The last three are written as one second-order difference equation on per-unit deviations
``h = (H - H_st + K Q_prev|Q_prev|)/H_r`` and ``q = (Q - Q_0)/Q_r``::

    h[k] = b0 q[k] + b1 q[k-1] + b2 q[k-2] - a1 h[k-1] - a2 h[k-2]

with coefficients ``(b0, b1, b2, a1, a2)`` from the functions below, and the steady friction loss K Q|Q| taken at
the previous step's flow (explicit, so the relation stays linear in the current Q). Their transfer functions have no
gain at zero frequency, so friction is carried only by the K Q|Q| term and the steady state is exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from hillchart.constants import G_M_S2
from hillchart.errors import InputError
from simulate.components.contract import ENTRIES, ENTRIES_BY_NODE, LEVELS_BY_NODE, LinearBlock, StateArray
from simulate.components.hydraulic.friction import steady_advance as reach_friction_advance
from simulate.components.hydraulic.friction import steady_reach_loss as reach_friction_loss
# the zdomain, lumped and rigid models' equations, read here by their components and by name from here
from simulate.components.hydraulic.difference_equations import (iir_step, iir_turbine_relation,  # noqa: F401
                                                                lumped_coefficients, rigid_coefficients,
                                                                zdomain_coefficients, zdomain_original)

#: Largest relative change of a segment's wave speed accepted to fit a whole number of reaches.
MAX_WAVE_SPEED_ADJUSTMENT = 0.05


# --- Method of characteristics ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class MocGrid:
    """Reaches of the MOC grid, upstream first (reach r joins nodes r and r+1).

    Attributes
    ----------
    impedance_s_m2 : ndarray, shape (n_reaches,)
        B = a / (g A) per reach, m per (m^3/s).
    friction_s2_m5 : ndarray, shape (n_reaches,)
        R = f dx / (2 g D A^2) per reach, m per (m^3/s)^2.
    reaches_per_segment : tuple of int
    wave_speed_used_m_s : tuple of float
        Wave speed per segment after fitting a whole number of reaches (dx = a dt).
    max_wave_speed_adjustment : float
        Largest |a_used / a - 1| over the segments.
    """

    impedance_s_m2: np.ndarray
    friction_s2_m5: np.ndarray
    reaches_per_segment: tuple[int, ...]
    wave_speed_used_m_s: tuple[float, ...]
    max_wave_speed_adjustment: float


def build_moc_grid(penstock, dt_s: float) -> MocGrid:
    """Reach impedances and friction for a Courant-1 grid at step ``dt_s``.

    Each segment gets N = round(L / (a dt)) >= 1 reaches and the wave speed L / (N dt) (the usual wave-speed
    adjustment); more than :data:`MAX_WAVE_SPEED_ADJUSTMENT` change is an :class:`InputError`.

    Examples
    --------
    >>> from simulate.config import PenstockConfig, PenstockSegment
    >>> p = PenstockConfig(model="moc", static_head_m=100.0, reaches=4, segments=(
    ...     PenstockSegment(length_m=400.0, diameter_m=2.0, wave_speed_m_s=1000.0, darcy_friction=0.0),))
    >>> g = build_moc_grid(p, p.moc_time_step_s)
    >>> g.reaches_per_segment, round(float(g.impedance_s_m2[0]), 4)
    ((4,), 32.4475)
    """
    impedance, friction, counts, speeds = [], [], [], []
    worst = 0.0
    for i, seg in enumerate(penstock.segments):
        n = max(1, int(round(seg.travel_time_s / dt_s)))
        a_used = seg.length_m / (n * dt_s)
        change = abs(a_used / seg.wave_speed_m_s - 1.0)
        if change > MAX_WAVE_SPEED_ADJUSTMENT:
            raise InputError(
                f"penstock.reaches = {penstock.reaches}: segment {i} (L/a = {seg.travel_time_s:.6g} s) would need "
                f"its wave speed changed by {100 * change:.1f} % to fit {n} reaches of dt = {dt_s:.6g} s; at most "
                f"{100 * MAX_WAVE_SPEED_ADJUSTMENT:.0f} % is allowed: increase penstock.reaches")
        worst = max(worst, change)
        dx = seg.length_m / n
        area = seg.area_m2
        impedance += [a_used / (G_M_S2 * area)] * n
        friction += [seg.darcy_friction * dx / (2.0 * G_M_S2 * seg.diameter_m * area ** 2)] * n
        counts.append(n)
        speeds.append(a_used)
    return MocGrid(np.array(impedance), np.array(friction), tuple(counts), tuple(speeds), worst)


def moc_steady_state(grid: MocGrid, reservoir_head_m: float, flow_m3_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Node heads (m) and flows (m^3/s) of steady flow: the head falls by R Q|Q| over every reach.

    Examples
    --------
    >>> g = MocGrid(np.array([1.0, 1.0]), np.array([0.5, 0.5]), (2,), (1000.0,), 0.0)
    >>> moc_steady_state(g, 100.0, 2.0)[0].tolist()
    [100.0, 98.0, 96.0]
    """
    losses = grid.friction_s2_m5 * flow_m3_s * abs(flow_m3_s)
    heads = reservoir_head_m - np.concatenate(([0.0], np.cumsum(losses)))
    return heads, np.full(heads.size, float(flow_m3_s))


@numba.njit(cache=True)
def moc_cplus(heads, flows, impedance, friction, j):
    """C_P of the C+ characteristic reaching node ``j`` from node j-1: H_P = C_P - B Q_P (B of reach j-1; ``flows``
    the flows at the reaches' upstream ends)."""
    b = impedance[j - 1]
    return heads[j - 1] + b * flows[j - 1] - reach_friction_loss(friction, flows, j - 1, j - 1)


@numba.njit(cache=True)
def moc_cminus(heads, flows, impedance, friction, j):
    """C_M of the C- characteristic reaching node ``j`` from node j+1: H_P = C_M + B Q_P (B of reach j; ``flows``
    the flows at the reaches' downstream ends: the same as at their upstream ends where no cavity divides a node)."""
    b = impedance[j]
    return heads[j + 1] - b * flows[j + 1] + reach_friction_loss(friction, flows, j, j + 1)


@numba.njit(cache=True)
def moc_turbine_relation(heads, flows, impedance, friction):
    """(C_L, k) of the C+ characteristic reaching the turbine node: H_P = C_P - B Q_P (B of the last reach)."""
    j = heads.size - 1
    return moc_cplus(heads, flows, impedance, friction, j), -impedance[j - 1]


@numba.njit(cache=True)
def moc_inlet_characteristic(heads, flows, impedance, friction):
    """C_M of the C- characteristic reaching the inlet node (node 0) from node 1: H_P = C_M + B Q_P there (B of the
    first reach, Q_P the flow into the pipe)."""
    return moc_cminus(heads, flows, impedance, friction, 0)


@numba.njit(cache=True)
def moc_step(heads, flows, impedance, friction, reservoir_head_m, turbine_head_m, turbine_flow_m3_s,
             new_heads, new_flows):
    """One MOC step at Courant number 1: fill ``new_heads``/``new_flows`` from ``heads``/``flows``.

    Reservoir node: H = H_res with the C- line; interior and junction nodes: C+ from the left reach, C- from the
    right reach (H_P = C_P - B_L Q_P = C_M + B_R Q_P); turbine node: the solved boundary values.
    """
    n = heads.size - 1
    b0 = impedance[0]
    c_m = moc_inlet_characteristic(heads, flows, impedance, friction)
    new_heads[0] = reservoir_head_m
    new_flows[0] = (reservoir_head_m - c_m) / b0
    for j in range(1, n):
        bl = impedance[j - 1]
        br = impedance[j]
        c_p = moc_cplus(heads, flows, impedance, friction, j)
        c_m = moc_cminus(heads, flows, impedance, friction, j)
        q = (c_p - c_m) / (bl + br)
        new_flows[j] = q
        new_heads[j] = c_p - bl * q
    new_heads[n] = turbine_head_m
    new_flows[n] = turbine_flow_m3_s
    reach_friction_advance(friction, flows, new_flows)


@numba.njit(cache=True)
def dvcm_volume(volume, q_out, q_in, q_out_old, q_in_old, dt_s, psi):
    """The cavity volume after a step, m^3: eq. (C4) of :mod:`simulate.components.hydraulic.cavitation`."""
    return volume + dt_s * (psi * (q_out - q_in) + (1.0 - psi) * (q_out_old - q_in_old))  # eq. (C4)


@numba.njit(cache=True)
def dvcm_record(track, j, volume, old_volume, step):
    """Keep node ``j``'s cavity volume and its figures in ``track`` (rows: 0 volume m^3, 1 largest volume, 2 step
    of the largest, 5 cavities formed, 6 step of the first); returns the volume."""
    track[0, j] = volume
    if volume > track[1, j]:
        track[1, j] = volume
        track[2, j] = step
    if old_volume <= 0.0 and volume > 0.0:
        if track[5, j] == 0.0:
            track[6, j] = step
        track[5, j] += 1.0
    return volume


@numba.njit(cache=True)
def dvcm_outlet_cavity(c_p, b, q_out, q_out_old, q_in_old, volume, vapour_head_m, dt_s, psi):
    """Whether the downstream-end node (the turbine or valve) is a cavity this step, decided before its boundary is
    solved from the boundary flow foreseen for it, ``q_out`` (the last step's ``q_out_old`` continued by the last
    change): a cavity that (C4) keeps open, or a liquid node whose C+ line at that flow would fall below the vapour
    head (eqs. (C3)-(C5) of :mod:`simulate.components.hydraulic.cavitation`). A wrong guess is corrected by the update
    (one step late)."""
    if volume > 0.0:
        q_in = (c_p - vapour_head_m) / b  # eq. (C3), C+
        return dvcm_volume(volume, q_out, q_in, q_out_old, q_in_old, dt_s, psi) > 0.0
    return c_p - b * q_out < vapour_head_m


@numba.njit(cache=True)
def foreseen_outlet_flow(s):
    """The downstream end's boundary flow foreseen for this step, m^3/s: the last step's continued by its last change,
    ``2 Q_n - Q_(n-1)`` (the MOC state's two levels; the cavity models decide their end with it)."""
    c = s[2][0]
    n = s[1].shape[1] - 1
    return 2.0 * s[1][c][n] - s[1][1 - c][n]


@numba.njit(cache=True)
def moc_liquid_below_vapour(heads, flows, impedance, friction, vapour, reservoir_head_m, new_heads, new_flows):
    """The liquid step of the inlet and the interior nodes (:func:`moc_step`'s equations, eq. (C2) of
    :mod:`simulate.components.hydraulic.cavitation`) where no cavity is open; returns whether a node fell below its
    vapour head (then :func:`moc_step_dvcm` redoes the step with cavities)."""
    n = heads.size - 1
    c_m = moc_inlet_characteristic(heads, flows, impedance, friction)
    new_heads[0] = reservoir_head_m
    new_flows[0] = (reservoir_head_m - c_m) / impedance[0]
    low = False
    for j in range(1, n):
        bl = impedance[j - 1]
        br = impedance[j]
        c_p = moc_cplus(heads, flows, impedance, friction, j)
        c_m = moc_cminus(heads, flows, impedance, friction, j)
        q = (c_p - c_m) / (bl + br)
        h = c_p - bl * q
        new_flows[j] = q
        new_heads[j] = h
        low |= h < vapour[j]
    return low


@numba.njit(cache=True)
def moc_step_dvcm(heads, flows, inflows, track, totals, impedance, friction, vapour, scal, reservoir_head_m,
                  outlet_head_m, outlet_flow_m3_s, step, new_heads, new_flows, new_inflows):
    """One MOC step with the discrete vapour cavity model (eqs. (C2)-(C5) of
    :mod:`simulate.components.hydraulic.cavitation`): like :func:`moc_step`, with ``inflows`` the flows at the
    reaches' downstream ends (``flows`` at their upstream ends; the two differ only at a cavity, and ``inflows`` is
    kept only while a cavity is open), ``vapour`` the vapour head per node (m), ``scal`` = [dt (s), psi], ``track``
    the cavity volumes and figures (:func:`dvcm_record`; row 0 updated in place), ``totals`` = [total cavity volume
    (m^3), 1 when the downstream end's relation held the vapour head (:func:`dvcm_outlet_cavity`), nodes with an open
    cavity], ``step`` the number of the new level (t = step dt). :func:`moc_dvcm_update` calls it only where a
    cavity is open or a head fell below the vapour head; otherwise the step is :func:`moc_step`'s, to the last bit."""
    n = heads.size - 1
    outlet_cavity = totals[1] == 1.0
    active = totals[2] > 0.0
    old_in = inflows if active else flows  # without an open cavity the flows at both ends of a reach are one
    dt_s, psi = scal[0], scal[1]
    total = 0.0
    count = 0
    c_m = moc_inlet_characteristic(heads, old_in, impedance, friction)
    new_heads[0] = reservoir_head_m
    new_flows[0] = (reservoir_head_m - c_m) / impedance[0]
    new_inflows[0] = new_flows[0]
    for j in range(1, n):
        bl = impedance[j - 1]
        br = impedance[j]
        c_p = moc_cplus(heads, flows, impedance, friction, j)
        c_m = moc_cminus(heads, old_in, impedance, friction, j)
        volume = track[0, j]
        if volume <= 0.0:
            q = (c_p - c_m) / (bl + br)  # eq. (C2)
            h = c_p - bl * q
            if h >= vapour[j]:
                new_flows[j] = q
                new_inflows[j] = q
                new_heads[j] = h
                continue
        q_in = (c_p - vapour[j]) / bl  # eq. (C3)
        q_out = (vapour[j] - c_m) / br
        v = dvcm_volume(volume, q_out, q_in, flows[j], old_in[j], dt_s, psi)  # eq. (C4)
        if v <= 0.0:  # eq. (C5): collapse, the node is liquid again
            dvcm_record(track, j, 0.0, volume, step)
            q = (c_p - c_m) / (bl + br)  # eq. (C2)
            new_flows[j] = q
            new_inflows[j] = q
            new_heads[j] = c_p - bl * q
            continue
        total += dvcm_record(track, j, v, volume, step)
        count += 1
        new_heads[j] = vapour[j]
        new_flows[j] = q_out
        new_inflows[j] = q_in
    # the downstream end: the boundary's flow leaves the node, C+ brings the pipe's
    c_p = moc_cplus(heads, flows, impedance, friction, n)
    b = impedance[n - 1]
    volume = track[0, n]
    new_flows[n] = outlet_flow_m3_s
    q_in = (c_p - vapour[n]) / b  # eq. (C3), C+
    cavity = False
    if outlet_cavity or outlet_head_m < vapour[n]:
        v = dvcm_volume(volume, outlet_flow_m3_s, q_in, flows[n], old_in[n], dt_s, psi)  # eq. (C4)
        if v > 0.0:
            total += dvcm_record(track, n, v, volume, step)
            count += 1
            new_heads[n] = vapour[n]
            new_inflows[n] = q_in
            cavity = True
    if not cavity:
        if volume > 0.0:
            dvcm_record(track, n, 0.0, volume, step)  # eq. (C5)
        new_heads[n] = outlet_head_m if not outlet_cavity else c_p - b * outlet_flow_m3_s
        new_inflows[n] = outlet_flow_m3_s
    reach_friction_advance(friction, flows, new_flows)
    totals[0] = total
    totals[2] = count


def iir_coefficients(model: str, *, water_time_s: float, travel_time_s: float, step_s: float,
                     lumped_alpha: float = 4.0 / math.pi ** 2, zdomain_feedback: float = 0.0) -> np.ndarray:
    """``[b0, b1, b2, a1, a2]`` of h[k] = b0 q[k] + b1 q[k-1] + b2 q[k-2] - a1 h[k-1] - a2 h[k-2] (per unit) of
    the ``zdomain`` (eq. (20), b1 = 0), ``lumped`` or ``rigid`` model (:mod:`simulate.components.hydraulic.
    difference_equations`).

    Examples
    --------
    >>> iir_coefficients("rigid", water_time_s=2.0, travel_time_s=0.5, step_s=0.01).tolist()
    [-200.0, 200.0, 0.0, 0.0, 0.0]
    """
    if model == "zdomain":
        a_c, b_c, d_c, e_c = zdomain_coefficients(travel_time_s, water_time_s, step_s, zdomain_feedback)
        return np.array([a_c, 0.0, b_c, d_c, e_c])
    if model == "lumped":
        return lumped_coefficients(water_time_s, travel_time_s, step_s, lumped_alpha)
    if model == "rigid":
        return rigid_coefficients(water_time_s, step_s)
    raise InputError(f"penstock.model must be one of zdomain, lumped, rigid for a difference equation, got {model!r}")


# --- Components for the time loop (registry kind "penstock"; see simulate.components.registry) -----------------
# Every penstock model offers the functions of the registry's table (simulate.components.registry: relation, update,
# inlet_flow, envelope, node_heads; params and state are tuples of arrays); the MOC also inlet_relation (a branch's).
# The MOC state: (heads (2, nodes), flows (2, nodes), [current level, steps done], inflows (2, nodes), track
# (7, nodes), [total cavity volume, 1 while the relation holds the outlet at the vapour head, open cavities]);
# ``flows`` at the reaches' upstream ends, ``inflows`` at their downstream ends (kept while a cavity is open; the same
# array object without column separation); track rows: 0 cavity volume (m^3; the DGCM's: its gas volume), 1 its
# largest, 2 the step of the largest, 3 the step of the lowest head, 4 the lowest head (m), 5 cavities formed, 6 the
# step of the first. Params: (B per reach, the friction model's arrays, vapour head per node (m), [dt (s), psi]).
@numba.njit(cache=True)
def moc_relation(p, s, upstream_head_m):
    c = s[2][0]
    return moc_turbine_relation(s[0][c], s[1][c], p[0], p[1])


@numba.njit(cache=True)
def moc_update(p, s, upstream_head_m, head_m, flow_m3_s):
    heads, flows, cur = s[0], s[1], s[2]
    c = cur[0]
    moc_step(heads[c], flows[c], p[0], p[1], upstream_head_m, head_m, flow_m3_s, heads[1 - c], flows[1 - c])
    cur[0] = 1 - c
    cur[1] += 1


@numba.njit(cache=True)
def moc_dvcm_relation(p, s, upstream_head_m):
    """The relation at the downstream end: the C+ line, or H = H_v (k = 0) while a cavity holds the node
    (:func:`dvcm_outlet_cavity`; its decision is kept in ``s[5][1]`` for the update)."""
    c = s[2][0]
    flows = s[1][c]
    n = flows.size - 1
    c_p, k = moc_turbine_relation(s[0][c], flows, p[0], p[1])
    vapour = p[2][n]
    foreseen = foreseen_outlet_flow(s)
    if s[5][2] == 0.0 and c_p + k * foreseen >= vapour:  # no cavity open, and the C+ line stays above H_v
        return c_p, k
    inflows = s[3][c] if s[5][2] > 0.0 else flows  # kept only while a cavity is open
    if dvcm_outlet_cavity(c_p, -k, foreseen, flows[n], inflows[n], s[4][0, n], vapour, p[3][0], p[3][1]):
        s[5][1] = 1.0  # for the update, and for the failure message should the boundary find no solution
        return vapour, 0.0
    return c_p, k


@numba.njit(cache=True)
def moc_dvcm_update(p, s, upstream_head_m, head_m, flow_m3_s):
    heads, flows, cur, inflows, track, totals = s
    c = cur[0]
    step = cur[1] + 1
    vapour = p[2]
    n = vapour.size - 1
    liquid = totals[2] == 0.0 and totals[1] != 1.0 and head_m >= vapour[n]  # no cavity open, none at the outlet
    if liquid and not moc_liquid_below_vapour(heads[c], flows[c], p[0], p[1], vapour, upstream_head_m,
                                              heads[1 - c], flows[1 - c]):
        heads[1 - c][n] = head_m  # the liquid step, as moc_step
        flows[1 - c][n] = flow_m3_s
        reach_friction_advance(p[1], flows[c], flows[1 - c])
        totals[0] = 0.0
    else:
        moc_step_dvcm(heads[c], flows[c], inflows[c], track, totals, p[0], p[1], vapour, p[3], upstream_head_m,
                      head_m, flow_m3_s, float(step), heads[1 - c], flows[1 - c], inflows[1 - c])
    cur[0] = 1 - c
    cur[1] = step
    totals[1] = 0.0


@numba.njit(cache=True)
def moc_dvcm_record(p, s, out):
    """Columns ``cavity_volume_m3`` (all the conduit's cavities) and ``outlet_cavity_volume_m3`` (at the turbine or
    valve)."""
    track = s[4]
    out[0] = s[5][0]
    out[1] = track[0, track.shape[1] - 1]


@numba.njit(cache=True)
def moc_inlet_flow(p, s):
    return s[1][s[2][0], 0]


@numba.njit(cache=True)
def moc_inlet_relation(p, s):
    """(C_M, B) of the C- line at the inlet for this step, H = C_M + B Q (Q into the pipe): a branch's at the manifold
    (:mod:`simulate.components.hydraulic.junction`); the flows at the reaches' downstream ends, ``s[3]``, while a
    vapour cavity is open (``s[5][2] > 0``)."""
    c = s[2][0]
    flows = s[3][c] if s[5][2] > 0.0 else s[1][c]
    return moc_inlet_characteristic(s[0][c], flows, p[0], p[1]), p[0][0]


@numba.njit(cache=True)
def moc_node_heads(p, s, upstream_head_m, head_m, out):
    heads = s[0][s[2][0]]
    for j in range(heads.size):
        out[j] = heads[j]


@numba.njit(cache=True)
def moc_envelope(p, s, upstream_head_m, head_m, env_max, env_min):
    """Fold the node heads into the envelope; the step and value of every node's lowest head go to the track (in a
    second pass, taken only on a step that lowers the envelope: the first stays a loop the compiler vectorises)."""
    heads = s[0][s[2][0]]
    lower = False
    for j in range(heads.size):
        h = heads[j]
        if h > env_max[j]:
            env_max[j] = h
        lower |= h < env_min[j]
    if lower:
        for j in range(heads.size):
            if heads[j] < env_min[j]:
                env_min[j] = heads[j]
        moc_track_lowest(s)


@numba.njit(cache=True)
def moc_track_lowest(s):
    """Every node's lowest head (track row 4, m) and the step of it (row 3): :func:`moc_envelope`'s, whose
    ``env_min`` starts from the same steady heads; a draft tube keeps no envelope and calls it each step."""
    heads, track = s[0][s[2][0]], s[4]
    for j in range(heads.size):
        if heads[j] < track[4, j]:
            track[4, j] = heads[j]
            track[3, j] = s[2][1]


@numba.njit(cache=True)
def iir_relation(p, s, upstream_head_m):
    coef, scal = p
    return iir_turbine_relation(coef, s[0], upstream_head_m, scal[0], scal[1], scal[2], scal[3])


@numba.njit(cache=True)
def iir_update(p, s, upstream_head_m, head_m, flow_m3_s):
    coef, scal = p
    iir_step(coef, s[0], flow_m3_s, scal[3], scal[2])


@numba.njit(cache=True)
def iir_inlet_flow(p, s):
    return s[0][4]  # no storage in the column: the inlet carries the turbine flow


@numba.njit(cache=True)
def iir_node_heads(p, s, upstream_head_m, head_m, out):
    out[0] = upstream_head_m
    out[1] = head_m


@numba.njit(cache=True)
def iir_envelope(p, s, upstream_head_m, head_m, env_max, env_min):
    env_max[0] = max(env_max[0], upstream_head_m)
    env_min[0] = min(env_min[0], upstream_head_m)
    env_max[1] = max(env_max[1], head_m)
    env_min[1] = min(env_min[1], head_m)


def node_positions_m(penstock, model: str, dt_s: float, grid: MocGrid | None = None) -> np.ndarray:
    """Distance of every computing node from the penstock inlet, m (MOC: the grid, ``grid`` when the caller has
    built it; other models: inlet, turbine)."""
    if model != "moc":
        return np.array([0.0, penstock.length_m])
    grid = build_moc_grid(penstock, dt_s) if grid is None else grid
    x = [0.0]
    for seg, n in zip(penstock.segments, grid.reaches_per_segment):
        x += list(x[-1] + seg.length_m * np.arange(1, n + 1) / n)
    return np.array(x)


def build_moc(plant, steady, dt_s: float, upstream_head_m: float):
    """Compiled MOC penstock: params (B per reach, the friction model's arrays, the vapour head per node, [dt, psi],
    and a column-separation model's own), state (see the comment above :func:`moc_relation`). The friction model
    (``penstock.friction_model``, :data:`simulate.components.registry.FRICTION`) is bound into the relation and the
    update; with ``penstock.column_separation = "dvcm"`` they and the recorded cavity volumes are the discrete vapour
    cavity model's (:mod:`simulate.components.hydraulic.cavitation`), with another model of
    :data:`simulate.components.registry.COLUMN_SEPARATION` its module's (``"dgcm"``: the discrete gas cavity model)."""
    from simulate.components.hydraulic import cavitation
    from simulate.components.registry import COLUMN_SEPARATION, FRICTION, CompiledPart, PartHooks

    pen = plant.penstock
    grid = build_moc_grid(pen, dt_s)
    friction = FRICTION.builder(pen.friction_model)(pen, grid, steady.flow_m3_s)
    heads, flows = moc_steady_state(grid, upstream_head_m, steady.flow_m3_s)
    x = node_positions_m(pen, "moc", dt_s, grid)
    settings = cavitation.vapour_settings(pen)
    dvcm = settings.model != "off"  # cavities: the DVCM's functions here, or another model's
    flows2 = np.vstack((flows, flows))
    track = np.zeros((7, heads.size))
    track[4] = heads
    state = (np.vstack((heads, heads)), flows2, np.zeros(2, dtype=np.int64),
             flows2.copy() if dvcm else flows2, track, np.zeros(3))
    params = (grid.impedance_s_m2, friction.arrays, cavitation.node_vapour_heads_m(pen, x, settings),
              np.array([dt_s, settings.cavity_weighting]))
    cavitation.check_steady_heads(pen, x, heads, params[2])
    if settings.model == "dvcm":
        functions = {"relation": friction.bind(moc_dvcm_relation), "update": friction.bind(moc_dvcm_update),
                     "record": moc_dvcm_record}
    elif dvcm:
        functions, params = COLUMN_SEPARATION.builder(settings.model)(pen, x, params, state, friction)
    else:
        functions = {"relation": friction.bind(moc_relation), "update": friction.bind(moc_update)}
    functions = {"inlet_flow": moc_inlet_flow, "inlet_relation": friction.bind(moc_inlet_relation),
                 "envelope": moc_envelope, "node_heads": moc_node_heads, **functions}
    record = cavitation.CavityRecord(pen, x, dt_s, settings, track, state[5], params[2])
    return CompiledPart(
        kind="penstock", name="moc", functions=functions, params=params, state=state,
        signals=cavitation.SIGNALS if dvcm else (),
        hooks=PartHooks(summary={"moc_reaches": int(sum(grid.reaches_per_segment)),
                                 "moc_max_wave_speed_adjustment": grid.max_wave_speed_adjustment,
                                 **friction.summary, **record.settings_summary()},
                        initial_signals=(0.0, 0.0) if dvcm else (),
                        summary_after=record.figures,
                        warnings_after=lambda signals: pen.unread_key_warnings() + record.warnings(),
                        failure=record.failure),
        n_nodes=heads.size, node_x_m=x)


def _build_iir(model: str):
    def build(plant, steady, dt_s: float, upstream_head_m: float):
        from simulate.components.registry import CompiledPart, PartHooks

        pen, turbine = plant.penstock, plant.turbine
        tw = pen.water_time_s(turbine.rated_flow_m3_s, turbine.rated_head_m)
        coef = iir_coefficients(model, water_time_s=tw, travel_time_s=pen.travel_time_s, step_s=dt_s,
                                lumped_alpha=pen.lumped_alpha, zdomain_feedback=pen.zdomain_feedback)
        scal = np.array([pen.friction_coefficient_s2_m5, turbine.rated_head_m, turbine.rated_flow_m3_s,
                         steady.flow_m3_s])
        hist = np.array([0.0, 0.0, 0.0, 0.0, steady.flow_m3_s])
        return CompiledPart(
            kind="penstock", name=model,
            functions={"relation": iir_relation, "update": iir_update, "inlet_flow": iir_inlet_flow,
                       "envelope": iir_envelope, "node_heads": iir_node_heads},
            params=(coef, scal), state=(hist,), n_nodes=2, node_x_m=node_positions_m(pen, model, dt_s),
            hooks=PartHooks(warnings_after=lambda signals: pen.unread_key_warnings()))
    build.__name__ = f"build_{model}"
    return build


build_zdomain = _build_iir("zdomain")
build_lumped = _build_iir("lumped")
build_rigid = _build_iir("rigid")


def time_scales(plant, schedules) -> list:
    """What the step must resolve of the penstock (see :mod:`simulate.loop.timestep`): the water time Tw for the rigid,
    lumped and z-domain models (one relation per step for the whole column); nothing for the method of
    characteristics, which is exact on its own grid."""
    from simulate.components.timescale import TimeScale

    if plant.penstock.model == "moc":
        return []
    t = plant.turbine
    return [TimeScale("penstock water time Tw (lengths, diameters, rated flow and head)",
                      plant.penstock.water_time_s(t.rated_flow_m3_s, t.rated_head_m), coupled=True)]


# --- What the models declare (simulate.components.contract): their states and their linear counterparts, by builder
#: The method of characteristics: heads and flows at every node on two time levels, and which level is current.
MOC_STATES = (StateArray("heads", "m", "the piezometric head at every node, the current and the next level",
                         LEVELS_BY_NODE),
              StateArray("flows", "m^3/s", "the flow at every node, the current and the next level", LEVELS_BY_NODE),
              StateArray("current", "1; step", "the index (0 or 1) of the current level and the step count", ENTRIES,
                         entries=("level", "step")),
              StateArray("inflows", "m^3/s", "the flow into every node from upstream, the current and the next level "
                         "(differs from flows only at a node a vapour cavity holds; the flows array itself when "
                         "column separation is off)", LEVELS_BY_NODE),
              StateArray("track", "m^3; m^3; step; step; m; 1; step", "per node: the cavity volume, its largest, "
                         "the step of the largest, the step of the lowest head, the lowest head, the cavities "
                         "formed, the step of the first (simulate.components.hydraulic.cavitation.CavityRecord)",
                         ENTRIES_BY_NODE, entries=("volume_m3", "max_volume_m3", "max_volume_step", "min_head_step",
                                           "min_head_m", "cavities", "first_cavity_step")),
              StateArray("totals", "m^3; 1; 1", "the total cavity volume, 1 while the relation held the downstream "
                         "end at the vapour head, the number of open cavities", ENTRIES,
                         entries=("volume_m3", "outlet_held", "open_cavities")))
#: The difference equations (zdomain, lumped, rigid): ``hist`` of :func:`iir_turbine_relation`.
IIR_STATES = (StateArray("history", "pu flow; pu flow; pu head; pu head; m^3/s", "the per-unit flow and head of the "
                         "last two steps and the last flow", ENTRIES,
                         entries=("q_km1", "q_km2", "h_km1", "h_km2", "flow_prev_m3_s")),)
STATES = {"build_moc": MOC_STATES, "build_zdomain": IIR_STATES, "build_lumped": IIR_STATES,
          "build_rigid": IIR_STATES}

#: The units of the numbers of a penstock's linear block.
_UNITS = {"water_time_s": "s", "wave_time_s": "s", "alpha": "1", "friction_slope": "pu head/pu flow"}


def _column(plant, steady) -> dict:
    """Tw = L Q0 / (g A H0) (paper 000 eq. (9); L / (g A) summed over the segments) and the linearized friction
    slope r_f = 2 K Q0^2 / H0 at the steady state."""
    pen = plant.penstock
    return {"water_time_s": pen.inertance_s2_m2 * steady.flow_m3_s / steady.head_m,
            "friction_slope": 2.0 * pen.friction_coefficient_s2_m5 * steady.flow_m3_s**2 / steady.head_m}


def rigid_counterpart(plant, steady) -> LinearBlock:
    """The inelastic column: h = -Tw dq/dt - r_f q (paper 000 eq. (9), the friction as
    :meth:`simulate.linear.models.LinearPlant.effective_coefficients` adds it)."""
    values = {**_column(plant, steady), "wave_time_s": 0.0}
    return LinearBlock("h = -Tw dq/dt - r_f q (paper 000 eq. (9))", values, {k: _UNITS[k] for k in values})


def elastic_counterpart(plant, steady) -> LinearBlock:
    """The lumped elastic column every model with waves is compared with: h = -Tw s / (1 + alpha Te^2 s^2) q - r_f q
    (paper 000 eqs. (15)-(18)) with Te = sum L / a and the section's ``lumped_alpha``."""
    pen = plant.penstock
    values = {**_column(plant, steady), "wave_time_s": pen.travel_time_s, "alpha": pen.lumped_alpha}
    return LinearBlock("h = -Tw s / (1 + alpha Te^2 s^2) q - r_f q (paper 000 eqs. (15)-(18))", values,
                       {k: _UNITS[k] for k in values})


LINEAR_COUNTERPART = {"build_moc": elastic_counterpart, "build_zdomain": elastic_counterpart,
                      "build_lumped": elastic_counterpart, "build_rigid": rigid_counterpart}
