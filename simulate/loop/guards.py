"""Checks before a run starts: the size of the run and the initial operating point
against the characteristics (the time step against the plant's dynamics: :mod:`simulate.loop.timestep`).

Every refusal is an :class:`InputError` naming the estimate or the value, the bound, and the key to change.
"""

from __future__ import annotations

import math

import numpy as np

from hillchart.errors import InputError
from simulate.components.registry import PENSTOCKS

#: The loop's cost per step beyond its nodes, in node-equivalents (measured: the shipped plant's 3147 steps of 26
#: MOC nodes take about 1 ms, i.e. ~0.3 us a step where a node costs ~3 ns).
STEP_OVERHEAD_NODES = 100
#: bytes per stored row (time, speed, head, flow, torque, iterations, one control) plus 8 per extra signal
ROW_BYTES = 56


def output_stride(plant, dt_s: float) -> int:
    """Steps per stored row: ``solver.output_dt_s`` / dt rounded (1 when not set)."""
    out_dt = plant.solver.output_dt_s
    if out_dt is None:
        return 1
    stride = int(round(out_dt / dt_s))
    if stride < 1 or abs(stride * dt_s - out_dt) > 1e-6 * out_dt:
        raise InputError(f"solver.output_dt_s = {out_dt!r} s must be a whole multiple of the time step "
                         f"dt = {dt_s:.9g} s (e.g. {max(1, stride) * dt_s:.9g})")
    return stride


def estimate(plant, dt_s: float, n_steps: int, stride: int, substeps: int = 1) -> dict:
    """Node-steps of the run (steps x (nodes + :data:`STEP_OVERHEAD_NODES` x sub-steps of the control and the shaft))
    and the memory of its stored series (bytes)."""
    if PENSTOCKS.traits(plant.penstock.model).grid_fixes_time_step:  # the penstock; with [[units]] the branches
        pipes = [plant.penstock.segments] + [unit.branch for unit in getattr(plant, "units", ())]
        nodes = sum(1 + sum(max(1, int(round(s.travel_time_s / dt_s))) for s in segments) for segments in pipes)
    else:
        nodes = 2
    rows = n_steps // stride + 1
    return {"steps": n_steps, "nodes": nodes, "substeps": substeps,
            "node_steps": float(n_steps) * (nodes + STEP_OVERHEAD_NODES * float(substeps)),
            "output_bytes": float(rows) * (ROW_BYTES + 16)}


def check_run_size(plant, dt_s: float, n_steps: int, stride: int, substeps: int = 1) -> dict:
    """Refuse a run whose node-steps or stored series exceed ``solver.max_node_steps`` / ``solver.max_output_mb``."""
    est = estimate(plant, dt_s, n_steps, stride, substeps)
    sol = plant.solver
    if est["node_steps"] > sol.max_node_steps and substeps > 1:  # a time constant far below the step
        raise InputError(
            f"the run needs {est['steps']:.4g} steps of {substeps:.3g} sub-steps each for the control and the shaft "
            f"(dt = {dt_s:.3g} s) = {est['node_steps']:.3g} node-steps, more than solver.max_node_steps = "
            f"{sol.max_node_steps:.3g}: a time scale of the governor or the generator (a time constant, or a gain "
            f"that sets one) is far shorter than any plant's; check the [governor] and [generator] values and their "
            f"units (s, not ms), or set solver.substeps")
    if est["node_steps"] > sol.max_node_steps:
        raise InputError(
            f"the run needs {est['steps']:.4g} steps x ({est['nodes']} nodes + {STEP_OVERHEAD_NODES} for the step) = "
            f"{est['node_steps']:.3g} node-steps "
            f"(about {est['node_steps'] / 3e8:.3g} s at 3e8 node-steps/s), more than solver.max_node_steps = "
            f"{sol.max_node_steps:.3g}: shorten scenario.t_end_s, use fewer penstock.reaches (dt = {dt_s:.3g} s), "
            f"check lengths and wave speeds (units: m, m/s), or raise solver.max_node_steps")
    mb = est["output_bytes"] / 1e6
    if mb > sol.max_output_mb:
        raise InputError(
            f"the stored series would take about {mb:.4g} MB ({n_steps // stride + 1} rows), more than "
            f"solver.max_output_mb = {sol.max_output_mb:g}: set solver.output_dt_s (e.g. "
            f"{dt_s * max(2, math.ceil(mb / sol.max_output_mb)):.3g} s) to store a decimated series, or raise "
            f"solver.max_output_mb")
    return est


def check_initial_state(plant, steady, domain=None, *, remember=None) -> None:
    """A negative or implausible initial power, or a start outside the characteristics' trusted domain, is an
    error naming the cause. ``remember(key, compute)``: where the verdict of ``domain`` on a point is remembered
    (the engine's memo of the domain's characteristics: a batch's cases share a few steady states)."""
    t = plant.turbine
    pump = getattr(t, "operating_mode", "turbine") == "pump"  # pumping absorbs power: P = M n < 0
    if pump and steady.power_mw > 1e-6 * t.rated_power_mw:
        raise InputError(f"the initial operating point in pump mode gives power {steady.power_mw:.4g} MW > 0 (speed "
                         f"{steady.speed_rpm:.4g} r/min, flow {steady.flow_m3_s:.4g} m^3/s): it does not pump; check "
                         f"turbine.operating_mode, scenario.initial_opening and penstock.static_head_m")
    if not pump and steady.power_mw < -1e-6 * t.rated_power_mw:
        raise InputError(
            f"the initial operating point has negative power {steady.power_mw:.4g} MW (N11 = "
            f"{steady.unit_speed_rpm:.4g} r/min, stroke {steady.stroke:.4g}): the turbine would brake, not drive; "
            f"check turbine.rated_speed_rpm = {t.rated_speed_rpm!r}, turbine.runner_diameter_m and "
            f"penstock.static_head_m")
    if abs(steady.power_mw) > 1.5 * t.rated_power_mw:
        raise InputError(f"the initial power {steady.power_mw:.4g} MW is more than 1.5 x turbine.rated_power_mw = "
                         f"{t.rated_power_mw!r}: check scenario.initial_opening and the rated values")
    if domain is not None:
        def outside():
            return domain.outside_reason(steady.unit_speed_rpm, steady.opening_chart, steady.stroke)

        point = ("outside", steady.unit_speed_rpm, steady.opening_chart, steady.stroke)
        problem = outside() if remember is None else remember(point, outside)
        if problem:
            raise InputError(
                f"the initial operating point is outside the characteristics' trusted domain: {problem} (N11 = "
                f"{steady.unit_speed_rpm:.4g} r/min at {steady.speed_rpm:.4g} r/min, head {steady.head_m:.4g} m); "
                f"check turbine.rated_speed_rpm, turbine.runner_diameter_m, penstock.static_head_m and the "
                f"scenario's initial point")


#: Bounds beyond which a valid plant value is implausible for a hydro unit (warned, not refused): the fastest
#: guide-vane servos close in about 2 s, the best turbines reach about 0.96 efficiency at rated power.
SHORTEST_PLAUSIBLE_STROKE_TIME_S = 1.0
#: The runner-blade servo turns every blade through the hub's crosshead against the blades' hydraulic torque: its
#: time constant is longer than the guide-vane servo's (0.1-0.3 s), about 0.5 s to a minute (bulb example: 1 s).
SHORTEST_PLAUSIBLE_BLADE_SERVO_TIME_S = 0.5
HIGHEST_PLAUSIBLE_RATED_EFFICIENCY = 0.98


#: ``turbine.opening_max`` (the chart opening at full stroke) against the characteristics' largest digitized opening
#: line: outside these ratios the full stroke ends far above every line or far below the chart's upper lines, which
#: is what an opening_max in another unit than the chart gives (100 for a chart in mm up to 32, 32 for one in %).
#: The shipped plants' full stroke is the largest line (1.0); a chart's lines often stop somewhat short of the full
#: opening.
STROKE_TO_TOP_LINE = (0.5, 1.5)
#: The rated unit speed ``N11 = n D / sqrt(H)`` against the digitized lines' N11 range: a turbine is chosen so that
#: it runs on its chart (the shipped plant: 67.8 r/min on lines of 43.8-88.3); below 0.7 x the range's bottom or above
#: 1.3 x its top, a rated speed, diameter or head is likely in another unit (a speed in rad/s: N11 = 7.1).
RATED_N11_TO_LINES = (0.7, 1.3)


def characteristics_warnings(turbine, characteristics) -> list[str]:
    """What the turbine section's values say against the digitized region of ``characteristics`` (none without a
    recorded region): a full stroke outside :data:`STROKE_TO_TOP_LINE` times the largest opening line, a rated unit
    speed outside :data:`RATED_N11_TO_LINES` of the lines' N11 range. Each names the values and the chart's unit."""
    region = getattr(characteristics, "digitized_region", None)
    unit = getattr(characteristics, "opening_unit", None)
    if region is None or len(region) < 3 or not isinstance(unit, str):
        return []
    region = np.asarray(region, float)
    out = []
    top = float(np.max(region[:, 1]))
    ratio = turbine.opening_max / top if top > 0 else math.inf
    if not STROKE_TO_TOP_LINE[0] <= ratio <= STROKE_TO_TOP_LINE[1]:
        where = ("far above every digitized line" if ratio > STROKE_TO_TOP_LINE[1] else
                 "far below the chart's upper lines")
        out.append(f"turbine.opening_max = {turbine.opening_max:g} (the chart opening at full stroke) is {ratio:.3g} "
                   f"times the largest digitized opening line of the characteristics, {top:g} {unit}: the full "
                   f"stroke reads the nets {where}. Give turbine.opening_max in the chart's opening unit ({unit}), "
                   "as the opening the guide vanes reach at full servo stroke")
    n11 = turbine.rated_speed_rpm * turbine.runner_diameter_m / math.sqrt(turbine.rated_head_m)
    low, high = float(np.min(region[:, 0])), float(np.max(region[:, 0]))
    if not RATED_N11_TO_LINES[0] * low <= n11 <= RATED_N11_TO_LINES[1] * high:
        out.append(f"the rated unit speed N11 = n D / sqrt(H) = {n11:.4g} r/min (turbine.rated_speed_rpm = "
                   f"{turbine.rated_speed_rpm:g}, runner_diameter_m = {turbine.runner_diameter_m:g}, rated_head_m = "
                   f"{turbine.rated_head_m:g}) lies far from the digitized lines' N11, {low:.4g}-{high:.4g} r/min: "
                   "check the three values and their units (r/min, m, m)")
    return out


#: ``penstock.static_head_m`` against ``turbine.rated_head_m``: the gross head exceeds the rated net head by the
#: losses and moves with the reservoirs (the shipped plants: 0.77-1.08); outside these ratios one of them is likely in
#: another unit (kPa for m: 9.81 x).
STATIC_TO_RATED_HEAD = (0.5, 2.0)


def plausibility_warnings(plant) -> list[str]:
    """Warnings for values the config accepts but no real unit has (each names the value and what is plausible)."""
    out = []
    gov = plant.governor
    for key in ("closing_time_s", "opening_time_s"):
        value = getattr(gov, key)
        if value < SHORTEST_PLAUSIBLE_STROKE_TIME_S:
            out.append(f"governor.{key} = {value:.3g} s is implausibly short: guide-vane servos take about 2-30 s "
                       "for the full stroke (the water hammer grows as the closing time shrinks); check the value "
                       "and its unit (s)")
    blades = getattr(plant, "blade_servo", None)
    if blades is not None and blades.servo_time_s < SHORTEST_PLAUSIBLE_BLADE_SERVO_TIME_S:
        out.append(f"blade_servo.servo_time_s = {blades.servo_time_s:.3g} s is implausibly short: runner-blade "
                   f"servos, which turn the blades through the hub, have time constants of about "
                   f"{SHORTEST_PLAUSIBLE_BLADE_SERVO_TIME_S:g}-60 s (slower than the guide-vane servo); check the "
                   "value and its unit (s, not ms)")
    waterway = sum(seg.length_m for seg in plant.penstock.segments)
    tank = getattr(plant, "surge_tank", None)
    waterway += float(getattr(tank, "tunnel_length_m", 0.0) or 0.0) if tank is not None else 0.0
    if waterway < plant.penstock.static_head_m:
        out.append(f"the waterway is {waterway:g} m long (the penstock's segments and any headrace tunnel), shorter "
                   f"than the {plant.penstock.static_head_m:g} m of head it drops: water cannot fall further than it "
                   "flows; check the lengths and their unit (m, not km)")
    static, rated = plant.penstock.static_head_m, plant.turbine.rated_head_m
    if not STATIC_TO_RATED_HEAD[0] <= static / rated <= STATIC_TO_RATED_HEAD[1]:
        out.append(f"penstock.static_head_m = {static:g} m is {static / rated:.3g} times turbine.rated_head_m = "
                   f"{rated:g} m: the gross head exceeds the rated net head by the losses, and moves with the "
                   "reservoirs by tens of %; check both values and their unit (m of water, not kPa)")
    eta = plant.turbine.rated_efficiency
    if eta > HIGHEST_PLAUSIBLE_RATED_EFFICIENCY:
        out.append(f"the rated efficiency P_r/(rho g Q_r H_r) = {eta:.4g} from turbine.rated_power_mw, "
                   f"rated_flow_m3_s and rated_head_m is implausible (turbines reach about 0.96 at rated power); "
                   "check the three values")
    return out
