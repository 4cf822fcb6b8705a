"""A branched valve network against TSNet (optional extra, ``pip install tsnet``): a reservoir, a main pipe and two
branch pipes ending in valves; one valve closes linearly, the other stays open. Heads at the junction and at the
two valves, hillsim's manifold loop against TSNet's method of characteristics, over 20 s.

TSNet's valve at the end of a pipe prescribes the flow, Q = Q_0 s(t) (s the valve's opening). In hillsim the same
boundary is a "unit" whose characteristics pass the flow Q = a (the chart opening, m^3/s) whatever the head:
Q11(N11, a) = a N11 / (n_r D1^3), with no torque, so the speed stays at n_r. The friction factors are TSNet's (from
EPANET's steady state), the grid the same (Courant number 1, dt = 0.05 s, no wave-speed adjustment).

TSNet 0.3.1 predates numpy 2 (it converts one-element arrays with ``int()``); the shims below make its
discretization and node functions return scalars, without changing its arithmetic.

Run:  PYTHONPATH=$PWD python benchmarks/bench_tsnet_branches.py        (prints the table; skips without TSNet)
"""

from __future__ import annotations

import contextlib
import functools
import io
import tempfile
import warnings
from pathlib import Path

import numpy as np

#: The network: (name, start, end, length m, diameter m) and the valves' steady flows (m^3/s).
PIPES = (("P1", "R1", "J1", 1000.0, 0.8), ("P2", "J1", "J2", 500.0, 0.5), ("P3", "J1", "J3", 500.0, 0.5))
VALVE_FLOWS = {"V1": 0.20, "V2": 0.15}
RESERVOIR_HEAD_M, WAVE_SPEED_M_S, DT_S, T_END_S = 100.0, 1000.0, 0.05, 20.0
CLOSE_START_S, CLOSE_TIME_S = 1.0, 5.0
#: Agreement asked of the heads at the valves (m).
TOLERANCE_M = 0.5

INP = """[TITLE]
branched valve network
[JUNCTIONS]
 J1 0 0
 J2 0 0
 J3 0 0
 J4 0 {q1}
 J5 0 {q2}
[RESERVOIRS]
 R1 {h0}
[PIPES]
{pipes}
[VALVES]
 V1 J2 J4 500 TCV 0 0
 V2 J3 J5 500 TCV 0 0
[OPTIONS]
 Units LPS
 Headloss D-W
[TIMES]
 Duration 0
[END]
"""


def tsnet_available() -> bool:
    try:
        import tsnet  # noqa: F401
    except ImportError:
        return False
    return True


def _numpy2_shims() -> None:
    import tsnet.network.discretize as discretize
    import tsnet.simulation.single as single

    def cal_n(tm, dt):
        n = np.zeros(tm.num_pipes)
        for _, pipe in tm.pipes():
            n[int(pipe.id) - 1] = round(pipe.length / (pipe.wavev * dt))
        return n

    def adjust_wavev(tm):
        phi = np.array([pipe.length / pipe.wavev / pipe.number_of_segments for _, pipe in tm.pipes()])
        tm.wavespeed_adj = float(np.sum(phi ** 2))
        theta = float(np.sum(phi) / np.sum(phi ** 2))
        for _, pipe in tm.pipes():
            pipe.wavev = float(pipe.wavev * phi[int(pipe.id) - 1] * theta)
        tm.time_step = 1.0 / theta
        return tm

    def scalars(func):
        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            out = func(*args, **kwargs)
            return tuple(float(np.ravel(x)[0]) if isinstance(x, np.ndarray) and x.size == 1 else x for x in out)
        return wrapper

    discretize.cal_N, discretize.adjust_wavev = cal_n, adjust_wavev
    for name in ("add_leakage", "valve_node", "valve_end", "dead_end", "pump_node", "surge_tank", "air_chamber"):
        if hasattr(single, name) and not hasattr(getattr(single, name), "__wrapped__"):
            setattr(single, name, scalars(getattr(single, name)))


def run_tsnet(folder: Path) -> dict:
    """TSNet's heads (m) at J1, J2, J3 every step, and the friction factor it took for each pipe."""
    import tsnet

    _numpy2_shims()
    pipes = "\n".join(f" {n} {a} {b} {length:g} {1000 * d:g} 0.2 0 Open" for n, a, b, length, d in PIPES)
    inp = folder / "branches.inp"
    inp.write_text(INP.format(q1=1000 * VALVE_FLOWS["V1"], q2=1000 * VALVE_FLOWS["V2"], h0=RESERVOIR_HEAD_M,
                              pipes=pipes), encoding="utf-8")
    # TSNet prints its progress; EPANET (through wntr) writes temp.inp/.rpt/.bin into the working folder
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), contextlib.chdir(folder):
        warnings.simplefilter("ignore")
        tm = tsnet.network.TransientModel(inp.name)
        tm.set_wavespeed(WAVE_SPEED_M_S)
        tm.set_time(T_END_S, DT_S)
        tm.valve_closure("V1", [CLOSE_TIME_S, CLOSE_START_S, 0.0, 1])
        tm.valve_closure("V2", [CLOSE_TIME_S, CLOSE_START_S, 1.0, 1])  # an "operation" that keeps it open
        tm = tsnet.simulation.Initializer(tm, 0, "DD")
        tm = tsnet.simulation.MOCSimulator(tm, "results", "steady")
    heads = {n: np.asarray(tm.get_node(n).head, float) for n in ("J1", "J2", "J3")}
    return {"heads": heads, "friction": {n: float(tm.get_link(n).roughness) for n, *_ in PIPES},
            "dt_s": float(tm.time_step)}


class PrescribedFlowValve:
    """Characteristics of a valve that passes the flow Q = a (chart opening in m^3/s) at any head, at the speed
    ``speed_rpm`` of a runner of diameter ``d1_m``: Q11 = a N11 / (n D1^3), no torque."""

    def __init__(self, speed_rpm: float, d1_m: float):
        self.scale = 1.0 / (speed_rpm * d1_m ** 3)

    def q11(self, n11, a):
        return np.asarray(a, float) * np.asarray(n11, float) * self.scale

    def q11_grad(self, n11, a):
        return np.asarray(a, float) * self.scale, np.asarray(n11, float) * self.scale

    def m11(self, n11, a):
        return np.zeros(np.broadcast(np.asarray(n11), np.asarray(a)).shape)

    def m11_grad(self, n11, a):
        zero = self.m11(n11, a)
        return zero, zero


def hillsim_plant(friction: dict):
    from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
    from simulate.config import plant_from_dict

    def segment(name):
        _, _, _, length, diameter = next(p for p in PIPES if p[0] == name)
        return {"length_m": length, "diameter_m": diameter, "wave_speed_m_s": WAVE_SPEED_M_S,
                "darcy_friction": friction[name]}

    def turbine(flow):
        return {"rated_head_m": RESERVOIR_HEAD_M, "rated_flow_m3_s": flow, "rated_speed_rpm": 100.0,
                "rated_power_mw": 0.9 * RHO_WATER_KG_M3 * G_M_S2 * flow * RESERVOIR_HEAD_M * 1e-6,
                "runner_diameter_m": 1.0, "opening_max": flow, "characteristics": "ideal"}

    shortest = min(length / WAVE_SPEED_M_S for _, _, _, length, _ in PIPES)
    raw = {"turbine": turbine(VALVE_FLOWS["V1"]),
           "penstock": {"model": "moc", "static_head_m": RESERVOIR_HEAD_M, "reaches": int(round(shortest / DT_S)),
                        "segments": [segment("P1")], "friction_model": "steady"},  # TSNet's quasi-steady loss
           "generator": {"inertia_time_s": 5.0, "self_regulation": 0.0},
           "governor": {"kp": 0.0, "ki": 0.0, "kd": 0.0, "derivative_filter_s": 0.0, "permanent_droop": 0.0,
                        "servo_time_s": 0.2, "closing_time_s": CLOSE_TIME_S, "opening_time_s": CLOSE_TIME_S},
           "scenario": {"kind": "closure-law", "t_end_s": T_END_S, "initial_opening": 1.0,
                        "event_time_s": CLOSE_START_S, "closing_time_s": CLOSE_TIME_S, "units": ["V1"]},
           "solver": {"pressure_loop": "newton"},
           "units": [{"name": "V1", "branch": [segment("P2")]},
                     {"name": "V2", "branch": [segment("P3")], "turbine": turbine(VALVE_FLOWS["V2"])}]}
    return plant_from_dict(raw)


def compare() -> dict:
    """Heads of both models at J1 (the manifold), J2 (valve V1) and J3 (valve V2), and the largest differences."""
    from simulate.loop.engine import run_simulation

    with tempfile.TemporaryDirectory() as tmp:
        ts = run_tsnet(Path(tmp))
    plant = hillsim_plant(ts["friction"])
    result = run_simulation(plant, characteristics=PrescribedFlowValve(100.0, 1.0))
    ours = {"J1": result.signals["manifold_head_m"], "J2": result.units["V1"]["head_m"],
            "J3": result.units["V2"]["head_m"]}
    n = min(len(ts["heads"]["J1"]), len(ours["J1"]))
    out = {"dt_s": (ts["dt_s"], result.meta["dt_s"]), "rows": n, "nodes": {}}
    for node, label in (("J1", "junction J1 (manifold)"), ("J2", "valve V1 (closing)"), ("J3", "valve V2 (open)")):
        a, b = ts["heads"][node][:n], ours[node][:n]
        out["nodes"][node] = {"label": label, "tsnet_max_m": float(a.max()), "hillsim_max_m": float(b.max()),
                              "tsnet_min_m": float(a.min()), "hillsim_min_m": float(b.min()),
                              "max_abs_diff_m": float(np.max(np.abs(a - b)))}
    return out


def table(data: dict) -> str:
    rows = ["| node | max head TSNet / hillsim (m) | min head TSNet / hillsim (m) | largest difference (m) |",
            "|---|---|---|---|"]
    for fig in data["nodes"].values():
        rows.append(f"| {fig['label']} | {fig['tsnet_max_m']:.2f} / {fig['hillsim_max_m']:.2f} | "
                    f"{fig['tsnet_min_m']:.2f} / {fig['hillsim_min_m']:.2f} | {fig['max_abs_diff_m']:.3f} |")
    return "\n".join(rows) + "\n"


def main() -> int:
    if not tsnet_available():
        print("TSNet is not installed (pip install tsnet): comparison skipped")
        return 0
    data = compare()
    print(f"{data['rows']} steps of {data['dt_s'][1]:g} s (TSNet {data['dt_s'][0]:g} s)")
    print(table(data), end="")
    worst = max(fig["max_abs_diff_m"] for fig in data["nodes"].values())
    print(f"largest difference {worst:.3f} m ({'within' if worst <= TOLERANCE_M else 'OUTSIDE'} {TOLERANCE_M} m)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
