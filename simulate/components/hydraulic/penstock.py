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
from simulate.components.contract import ENTRIES, LEVELS_BY_NODE, SCALAR, LinearBlock, StateArray
from simulate.components.hydraulic.friction import steady_advance as reach_friction_advance
from simulate.components.hydraulic.friction import steady_reach_loss as reach_friction_loss

#: Largest relative change of a segment's wave speed accepted to fit a whole number of reaches.
MAX_WAVE_SPEED_ADJUSTMENT = 0.05


# ---------------------------------------------------------------------------------------------------------------
# Method of characteristics
# ---------------------------------------------------------------------------------------------------------------
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
def moc_turbine_relation(heads, flows, impedance, friction):
    """(C_L, k) of the C+ characteristic reaching the turbine node: H_P = C_P - B Q_P (B of the last reach)."""
    j = heads.size - 1
    b = impedance[j - 1]
    c_p = heads[j - 1] + b * flows[j - 1] - reach_friction_loss(friction, flows, j - 1, j - 1)
    return c_p, -b


@numba.njit(cache=True)
def moc_inlet_characteristic(heads, flows, impedance, friction):
    """C_M of the C- characteristic reaching the inlet node (node 0) from node 1: H_P = C_M + B Q_P there (B of the
    first reach, Q_P the flow into the pipe)."""
    b0 = impedance[0]
    return heads[1] - b0 * flows[1] + reach_friction_loss(friction, flows, 0, 1)


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
        c_p = heads[j - 1] + bl * flows[j - 1] - reach_friction_loss(friction, flows, j - 1, j - 1)
        c_m = heads[j + 1] - br * flows[j + 1] + reach_friction_loss(friction, flows, j, j + 1)
        q = (c_p - c_m) / (bl + br)
        new_flows[j] = q
        new_heads[j] = c_p - bl * q
    new_heads[n] = turbine_head_m
    new_flows[n] = turbine_flow_m3_s
    reach_friction_advance(friction, flows, new_flows)


# ---------------------------------------------------------------------------------------------------------------
# Second-order difference equations: zdomain, lumped, rigid
# ---------------------------------------------------------------------------------------------------------------
def zdomain_original(travel_time_s: float, water_time_s: float, feedback: float = 0.0):
    """Numerator and denominator (in z, highest power first, monic) of eq. (17), sampled at T_so = L/a.

    G(z) = (-1 + z^-2) / (F + C_a - (F - C_a) z^-2) with C_a = T_so / T_w (eq. (18)).

    Examples
    --------
    >>> num, den = zdomain_original(0.1, 2.0, 0.01)   # eq. (21) of the BP hill-chart paper
    >>> [round(float(v), 2) for v in num], [round(float(v), 4) for v in den]
    ([-16.67, 0.0, 16.67], [1.0, 0.0, 0.6667])
    """
    ca = travel_time_s / water_time_s  # eq. (18)
    c, d = feedback + ca, feedback - ca
    return (np.array([-1.0 / c, 0.0, 1.0 / c]), np.array([1.0, 0.0, -d / c]))  # eq. (17) times z^2 / c


def zdomain_coefficients(travel_time_s: float, water_time_s: float, step_s: float, feedback: float = 0.0):
    """``(A/C, B/C, D/C, E/C)`` of the resampled transfer function, eqs. (19)-(20) of the BP hill-chart paper:

    H_A/Q = ((A/C) z^2 + B/C) / (z^2 + (D/C) z + E/C) at the new period T_sn = ``step_s``.

    Examples
    --------
    >>> [round(float(v), 4) for v in zdomain_coefficients(0.1, 2.0, 0.01, 0.01)]   # eq. (22)
    [-3.8095, 3.8095, -1.8857, 0.9238]
    """
    t_so, t_sn = travel_time_s, step_s
    ca = t_so / water_time_s  # eq. (18)
    a_coef = -4.0 * t_sn * t_so  # eq. (20), A
    b_coef = 4.0 * t_sn * t_so  # eq. (20), B
    c_coef = 4.0 * feedback * t_sn * t_so + 2.0 * ca * (t_sn ** 2 + t_so ** 2)  # eq. (20), C
    d_coef = 4.0 * ca * (t_sn ** 2 - t_so ** 2)  # eq. (20), D
    e_coef = -4.0 * feedback * t_sn * t_so + 2.0 * ca * (t_sn ** 2 + t_so ** 2)  # eq. (20), E
    return a_coef / c_coef, b_coef / c_coef, d_coef / c_coef, e_coef / c_coef


def iir_coefficients(model: str, *, water_time_s: float, travel_time_s: float, step_s: float,
                     lumped_alpha: float = 4.0 / math.pi ** 2, zdomain_feedback: float = 0.0) -> np.ndarray:
    """``[b0, b1, b2, a1, a2]`` of h[k] = b0 q[k] + b1 q[k-1] + b2 q[k-2] - a1 h[k-1] - a2 h[k-2] (per unit).

    ``zdomain``: eq. (20) (b1 = 0). ``lumped``: scipy's bilinear (Tustin) transform of -Tw s / (1 + alpha Te^2 s^2)
    (paper 000 eq. (15)): Tustin keeps the undamped resonance undamped. ``rigid``: backward Euler of h = -Tw dq/dt,
    b0 = -Tw/dt, b1 = Tw/dt (the trapezoidal rule would make the algebraic head alternate +-h forever once the
    vanes are shut, backward Euler does not).

    Examples
    --------
    >>> iir_coefficients("rigid", water_time_s=2.0, travel_time_s=0.5, step_s=0.01).tolist()
    [-200.0, 200.0, 0.0, 0.0, 0.0]
    """
    tw, te, dt = water_time_s, travel_time_s, step_s
    if model == "zdomain":
        a_c, b_c, d_c, e_c = zdomain_coefficients(te, tw, dt, zdomain_feedback)
        return np.array([a_c, 0.0, b_c, d_c, e_c])
    if model == "lumped":
        from scipy import signal  # lazy: scipy.signal costs about 1 s of start-up and only this model needs it

        num, den, _ = signal.cont2discrete(([-tw, 0.0], [lumped_alpha * te ** 2, 0.0, 1.0]), dt, method="bilinear")
        num = np.ravel(num)
        num = np.concatenate((np.zeros(3 - num.size), num)) / den[0]
        den = np.asarray(den, float) / den[0]
        return np.array([num[0], num[1], num[2], den[1], den[2]])
    if model == "rigid":
        return np.array([-tw / dt, tw / dt, 0.0, 0.0, 0.0])
    raise InputError(f"penstock.model must be one of zdomain, lumped, rigid for a difference equation, got {model!r}")


@numba.njit(cache=True)
def iir_turbine_relation(coef, hist, static_head_m, friction_s2_m5, rated_head_m, rated_flow_m3_s, flow0_m3_s):
    """(C_L, k) of H = H_st - K Q_prev|Q_prev| + H_r h[k] with h[k] = b0 (Q - Q0)/Q_r + (known past terms).

    ``hist`` = [q[k-1], q[k-2], h[k-1], h[k-2], Q_prev (m^3/s)].
    """
    known = coef[1] * hist[0] + coef[2] * hist[1] - coef[3] * hist[2] - coef[4] * hist[3]
    q_prev = hist[4]
    base = static_head_m - friction_s2_m5 * q_prev * abs(q_prev)
    k = rated_head_m * coef[0] / rated_flow_m3_s
    return base + rated_head_m * known - k * flow0_m3_s, k


@numba.njit(cache=True)
def iir_step(coef, hist, flow_m3_s, flow0_m3_s, rated_flow_m3_s):
    """Shift the history after the turbine flow of this step is known."""
    q = (flow_m3_s - flow0_m3_s) / rated_flow_m3_s
    h = coef[0] * q + coef[1] * hist[0] + coef[2] * hist[1] - coef[3] * hist[2] - coef[4] * hist[3]
    hist[1] = hist[0]
    hist[0] = q
    hist[3] = hist[2]
    hist[2] = h
    hist[4] = flow_m3_s


# ---------------------------------------------------------------------------------------------------------------
# Components for the time loop (registry kind "penstock"; see simulate.components.registry)
# ---------------------------------------------------------------------------------------------------------------
# Every penstock model offers the same five functions (params and state are tuples of arrays):
#   relation(p, s, upstream_head_m) -> (C_L, k)      H = C_L + k Q at the turbine for this step
#   update(p, s, upstream_head_m, head_m, flow_m3_s)   advance the state with the solved boundary values
#   inlet_flow(p, s) -> Q                              flow at the upstream end after the update, m^3/s
#   envelope(p, s, upstream_head_m, head_m, env_max, env_min)   fold this step's node heads into the envelope
#   node_heads(p, s, upstream_head_m, head_m, out)    the piezometric head at every computing node, m
@numba.njit(cache=True)
def moc_relation(p, s, upstream_head_m):
    heads, flows, cur = s
    c = cur[0]
    return moc_turbine_relation(heads[c], flows[c], p[0], p[1])


@numba.njit(cache=True)
def moc_update(p, s, upstream_head_m, head_m, flow_m3_s):
    heads, flows, cur = s
    c = cur[0]
    moc_step(heads[c], flows[c], p[0], p[1], upstream_head_m, head_m, flow_m3_s, heads[1 - c], flows[1 - c])
    cur[0] = 1 - c


@numba.njit(cache=True)
def moc_inlet_flow(p, s):
    return s[1][s[2][0], 0]


@numba.njit(cache=True)
def moc_node_heads(p, s, upstream_head_m, head_m, out):
    heads = s[0][s[2][0]]
    for j in range(heads.size):
        out[j] = heads[j]


@numba.njit(cache=True)
def moc_envelope(p, s, upstream_head_m, head_m, env_max, env_min):
    heads = s[0][s[2][0]]
    for j in range(heads.size):
        h = heads[j]
        if h > env_max[j]:
            env_max[j] = h
        if h < env_min[j]:
            env_min[j] = h


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
    """Compiled MOC penstock: params (B per reach, the friction model's arrays), state (heads (2, nodes), flows
    (2, nodes), [current]). The friction model is ``penstock.friction_model``
    (:data:`simulate.components.registry.FRICTION`, :mod:`simulate.components.hydraulic.friction`), bound into the
    relation and the update (the steady model's arrays are R per reach)."""
    from simulate.components.registry import FRICTION, CompiledPart, PartHooks

    pen = plant.penstock
    grid = build_moc_grid(pen, dt_s)
    friction = FRICTION.builder(pen.friction_model)(pen, grid, steady.flow_m3_s)
    heads, flows = moc_steady_state(grid, upstream_head_m, steady.flow_m3_s)
    state = (np.vstack((heads, heads)), np.vstack((flows, flows)), np.zeros(1, dtype=np.int64))
    return CompiledPart(
        kind="penstock", name="moc",
        functions={"relation": friction.bind(moc_relation), "update": friction.bind(moc_update),
                   "inlet_flow": moc_inlet_flow, "envelope": moc_envelope, "node_heads": moc_node_heads},
        params=(grid.impedance_s_m2, friction.arrays), state=state,
        hooks=PartHooks(summary={"moc_reaches": int(sum(grid.reaches_per_segment)),
                                 "moc_max_wave_speed_adjustment": grid.max_wave_speed_adjustment,
                                 **friction.summary},
                        warnings_after=lambda signals: pen.unread_key_warnings()),
        n_nodes=heads.size, node_x_m=node_positions_m(pen, "moc", dt_s, grid))


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


# ---------------------------------------------------------------------------------------------------------------
# What the models declare (simulate.components.contract): their states and their linear counterparts, by builder
# ---------------------------------------------------------------------------------------------------------------
#: The method of characteristics: heads and flows at every node on two time levels, and which level is current.
MOC_STATES = (StateArray("heads", "m", "the piezometric head at every node, the current and the next level",
                         LEVELS_BY_NODE),
              StateArray("flows", "m^3/s", "the flow at every node, the current and the next level", LEVELS_BY_NODE),
              StateArray("current", "1", "the index (0 or 1) of the current level", SCALAR))
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
