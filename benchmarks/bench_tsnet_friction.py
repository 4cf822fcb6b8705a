"""Unsteady friction on the reservoir-pipe-valve case, hillsim against TSNet (optional extra, ``pip install tsnet``),
each at the step dt and dt / 2.

A reservoir 100 m above the valve, a pipe of 1000 m and 0.5 m (a = 1000 m/s, so 4 L / a = 4 s), 0.1 m^3/s through
the valve (V0 = 0.51 m/s, Re = 2.5e5), the valve shut linearly in 0.1 s from 0.1 s; 20.2 s. TSNet's valve at the end
of a pipe prescribes the flow (Q = Q0 s(t)); here the same boundary is the prescribed-flow "turbine" of
``benchmarks/bench_tsnet_branches.py`` (:class:`PrescribedFlowValve`), so that after the closure both hold Q = 0 at
the valve and the decay of the head peaks is the pipe's alone. The friction factor is TSNet's (from EPANET's steady
state, Darcy-Weisbach with 0.2 mm roughness), the grid the same (20 reaches at dt = 0.05 s, 40 at 0.025 s).

Both unsteady models are Brunone's with Vardy and Brown's k3 = sqrt(C*) / 2 at the steady Reynolds number
(:mod:`simulate.components.hydraulic.brunone`, TSNet's ``friction="unsteady"``). TSNet adds its unsteady slope
k3/(2g) (dV/dt + a sgn(V) |dV/dx|) to the velocity characteristic without the factor g dt that its steady term
carries, so its unsteady term is 1 / (g dt) times (B1)'s: about 2 at dt = 0.05 s, 4 at 0.025 s; hillsim's
(B4) keeps both terms in the same units. Prints the largest head rise above the reservoir in each period 4 L / a
after the closure and the mean logarithmic decrement per period, for each model and step.

Run:  PYTHONPATH=$PWD python benchmarks/bench_tsnet_friction.py        (skips the TSNet rows without TSNet)
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import math
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
RESERVOIR_HEAD_M, LENGTH_M, DIAMETER_M, WAVE_SPEED_M_S = 100.0, 1000.0, 0.5, 1000.0
FLOW_M3_S, CLOSE_START_S, CLOSE_TIME_S, T_END_S = 0.1, 0.1, 0.1, 20.2
PERIOD_S = 4.0 * LENGTH_M / WAVE_SPEED_M_S
STEPS_S = (0.05, 0.025)

INP = """[TITLE]
reservoir, pipe, valve
[JUNCTIONS]
 J1 0 0
 J2 0 {q}
[RESERVOIRS]
 R1 {h0}
[PIPES]
 P1 R1 J1 {length:g} {diameter_mm:g} 0.2 0 Open
[VALVES]
 V1 J1 J2 500 TCV 0 0
[OPTIONS]
 Units LPS
 Headloss D-W
[TIMES]
 Duration 0
[END]
"""


def _branches():
    spec = importlib.util.spec_from_file_location("bench_tsnet_branches", HERE / "bench_tsnet_branches.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_tsnet(folder: Path, dt_s: float, friction: str, *, reservoir_head_m: float = RESERVOIR_HEAD_M,
              length_m: float = LENGTH_M, diameter_m: float = DIAMETER_M, wave_speed_m_s: float = WAVE_SPEED_M_S,
              flow_m3_s: float = FLOW_M3_S, close_start_s: float = CLOSE_START_S,
              close_time_s: float = CLOSE_TIME_S, t_end_s: float = T_END_S) -> dict:
    """TSNet's time (s) and head at the valve (m), and its Darcy friction factor of the pipe (the case of the module
    docstring, or another reservoir-pipe-valve case given by the keywords)."""
    import tsnet

    _branches()._numpy2_shims()
    inp = folder / "valve.inp"
    inp.write_text(INP.format(q=1000 * flow_m3_s, h0=reservoir_head_m, length=length_m,
                              diameter_mm=1000 * diameter_m), encoding="utf-8")
    # TSNet prints its progress; EPANET (through wntr) writes temp.inp/.rpt/.bin into the working folder
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), contextlib.chdir(folder):
        warnings.simplefilter("ignore")
        tm = tsnet.network.TransientModel(inp.name)
        tm.set_wavespeed(wave_speed_m_s)
        tm.set_time(t_end_s, dt_s)
        tm.valve_closure("V1", [close_time_s, close_start_s, 0.0, 1])
        tm = tsnet.simulation.Initializer(tm, 0, "DD")
        tm = tsnet.simulation.MOCSimulator(tm, "results", friction)
    head = np.asarray(tm.get_node("J1").head, float)
    return {"time_s": np.asarray(tm.simulation_timestamps, float)[:head.size], "head_m": head,
            "darcy_friction": float(tm.get_link("P1").roughness), "dt_s": float(tm.time_step)}


def hillsim_plant(darcy_friction: float, reaches: int, friction_model: str):
    """The case as a plant: the prescribed-flow valve as a "turbine" of rated flow Q0 at full stroke."""
    from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
    from simulate.config import plant_from_dict

    raw = {"turbine": {"rated_head_m": RESERVOIR_HEAD_M, "rated_flow_m3_s": FLOW_M3_S, "rated_speed_rpm": 100.0,
                       "rated_power_mw": 0.9 * RHO_WATER_KG_M3 * G_M_S2 * FLOW_M3_S * RESERVOIR_HEAD_M * 1e-6,
                       "runner_diameter_m": 1.0, "opening_max": FLOW_M3_S, "characteristics": "ideal"},
           "penstock": {"model": "moc", "static_head_m": RESERVOIR_HEAD_M, "reaches": reaches,
                        "friction_model": friction_model,
                        "segments": [{"length_m": LENGTH_M, "diameter_m": DIAMETER_M,
                                      "wave_speed_m_s": WAVE_SPEED_M_S, "darcy_friction": darcy_friction}]},
           "generator": {"inertia_time_s": 5.0, "self_regulation": 0.0},
           "governor": {"kp": 0.0, "ki": 0.0, "kd": 0.0, "derivative_filter_s": 0.0, "permanent_droop": 0.0,
                        "servo_time_s": 0.2, "closing_time_s": CLOSE_TIME_S, "opening_time_s": CLOSE_TIME_S},
           "scenario": {"kind": "closure-law", "t_end_s": T_END_S, "initial_opening": 1.0,
                        "event_time_s": CLOSE_START_S, "closing_time_s": CLOSE_TIME_S},
           "solver": {"pressure_loop": "newton"}}
    return plant_from_dict(raw)


def run_hillsim(darcy_friction: float, dt_s: float, friction_model: str) -> dict:
    from simulate.loop.engine import run_simulation

    plant = hillsim_plant(darcy_friction, int(round(LENGTH_M / (WAVE_SPEED_M_S * dt_s))), friction_model)
    result = run_simulation(plant, characteristics=_branches().PrescribedFlowValve(100.0, 1.0))
    return {"time_s": result.time_s, "head_m": result.head_m, "dt_s": float(result.meta["dt_s"])}


def period_peaks(time_s: np.ndarray, head_m: np.ndarray) -> np.ndarray:
    """The largest head rise above the reservoir in each whole period 4 L / a after the closure began, m."""
    t = time_s - CLOSE_START_S
    rise = head_m - RESERVOIR_HEAD_M
    return np.array([rise[(t >= k * PERIOD_S) & (t < (k + 1) * PERIOD_S)].max()
                     for k in range(int((t[-1] + 1e-9) // PERIOD_S))])


def log_decrement(peaks: np.ndarray) -> float:
    """Mean logarithmic decrement per period, ln(A_1 / A_m) / (m - 1)."""
    return math.log(peaks[0] / peaks[-1]) / (peaks.size - 1)


def compare(with_tsnet: bool = True) -> list[dict]:
    """Peaks and decrement of every (tool, friction, step); the friction factor is TSNet's where TSNet runs, else
    the one it takes for this pipe (0.0180, :data:`TSNET_DARCY_FRICTION`)."""
    rows, f = [], TSNET_DARCY_FRICTION
    if with_tsnet:
        with tempfile.TemporaryDirectory() as tmp:
            for friction in ("steady", "unsteady"):
                for dt in STEPS_S:
                    run = run_tsnet(Path(tmp), dt, friction)
                    f = run["darcy_friction"]
                    rows.append({"tool": "TSNet", "friction": friction, **run})
    for friction in ("steady", "brunone"):
        for dt in STEPS_S:
            rows.append({"tool": "hillsim", "friction": friction, "darcy_friction": f,
                         **run_hillsim(f, dt, friction)})
    for row in rows:
        row["peaks_m"] = period_peaks(row["time_s"], row["head_m"])
        row["decrement"] = log_decrement(row["peaks_m"])
    return rows


#: TSNet's Darcy friction factor of the pipe (EPANET's steady state, 0.2 mm roughness), for runs without TSNet.
TSNET_DARCY_FRICTION = 0.0180


def table(rows: list[dict]) -> str:
    lines = ["| tool | friction | dt (s) | head rise peaks per period 4 L / a (m) | decrement per period |",
             "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['tool']} | {r['friction']} | {r['dt_s']:g} | "
                     f"{', '.join(f'{p:.2f}' for p in r['peaks_m'])} | {r['decrement']:.4f} |")
    return "\n".join(lines) + "\n"


def main() -> int:
    available = _branches().tsnet_available()
    if not available:
        print("TSNet is not installed (pip install tsnet): hillsim's rows only", file=sys.stderr)
    print(table(compare(with_tsnet=available)), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
