"""Pump trip of the Wylie-Streeter radial pump: the simulator's four-quadrant boundary against an independent
integration of the rigid-column equations.

A radial pump (Wylie, Streeter and Suo 1993, Fig. 7-2, N_s 25: ``../shared/external/suter_wylie1993_fig7-2.csv``)
lifts 0.25 m^3/s through 50 m at 1450 r/min (efficiency 0.8) into a reservoir 47 m above its sump, through a 300 m
pipe of 0.4 m (Darcy f 0.02: 3.0 m of loss at the rated flow); its motor is tripped at 0.2 s (load torque to 0, the
vanes do not matter: a pump's curves are of x alone). The simulator runs the rigid column (``penstock.model =
"rigid"``: backward Euler, friction at the last step's flow) and the swing rotor (explicit Euler) on the pump's
tabulated curves (linear in x). The reference is scipy's ``solve_ivp`` (RK45, rtol 1e-10) on

    L/(g A) dQ/dt = H_st - h(Q, n) H_r - R Q|Q|,      J dw/dt = M(Q, n)        (turbine-positive signs)

with h = WH(x) (q^2 + v^2), m = WM(x) (q^2 + v^2), x = pi + atan2(q, v), the curves read from the CSV and
interpolated linearly and periodically by ``numpy.interp`` on the Wylie-Streeter axis moved by pi (not the
simulator's table or kernel). Figures: the time from the trip to flow reversal and the largest reverse (turbine
direction) speed.

Run: ``python benchmarks/bench_pump_trip.py`` (prints the Markdown table of docs/pump-turbines.md).
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3, RPM_TO_RAD_S  # noqa: E402

CSV = "suter_wylie1993_fig7-2.csv"
EXTERNAL = Path(os.environ.get("HILLSIM_EXTERNAL_DIR", ROOT.parent / "shared" / "external"))
H_R, Q_R, N_R, EFFICIENCY, D1 = 50.0, 0.25, 1450.0, 0.8, 0.4
STATIC_HEAD_M, LENGTH_M, DIAMETER_M, DARCY = 47.0, 300.0, 0.4, 0.02
INERTIA_TIME_S, TRIP_S, END_S = 0.6, 0.2, 6.0
P_R_W = RHO_WATER_KG_M3 * G_M_S2 * Q_R * H_R / EFFICIENCY   # the motor's shaft power at the rated point
M_R = P_R_W / (N_R * RPM_TO_RAD_S)


def curves_file(folder: Path, csv_path: Path = EXTERNAL / CSV, pump: str = "radial") -> Path:
    """The pump's curves as a hillsim.suter_curves file in ``folder``, its rated unit point from the values above."""
    from simulate.components.turbine.four_quadrant import wylie_streeter_pump_curves, write_suter_curves

    x, wh, wm = wylie_streeter_pump_curves(csv_path, pump)
    rated = {"n11_rpm": N_R * D1 / math.sqrt(H_R), "q11_m3_s": Q_R / (D1 ** 2 * math.sqrt(H_R)),
             "m11_nm": M_R / (D1 ** 3 * H_R)}
    return write_suter_curves(Path(folder) / f"{pump}_pump.json", x_rad=x, wh=wh, wm=wm, rated=rated,
                              name=f"Wylie-Streeter {pump} pump")


def pump_plant(curves: Path, dt_s: float):
    """The plant (pump mode, rigid column, trip at :data:`TRIP_S`) on the curves file ``curves``."""
    from simulate.config import (GeneratorConfig, GovernorConfig, PenstockConfig, PenstockSegment, PlantConfig,
                                 ScenarioConfig, SolverConfig, TurbineConfig)

    turbine = TurbineConfig(rated_head_m=H_R, rated_flow_m3_s=Q_R, rated_speed_rpm=N_R, rated_power_mw=P_R_W * 1e-6,
                            runner_diameter_m=D1, opening_max=1.0, characteristics=str(curves),
                            operating_mode="pump")
    segment = PenstockSegment(length_m=LENGTH_M, diameter_m=DIAMETER_M, wave_speed_m_s=1200.0, darcy_friction=DARCY)
    governor = GovernorConfig(kp=0.0, ki=0.0, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0, servo_time_s=0.2,
                              closing_time_s=10.0, opening_time_s=10.0)
    scenario = ScenarioConfig(kind="load-rejection", t_end_s=END_S, initial_opening=1.0, event_time_s=TRIP_S)
    return PlantConfig(turbine=turbine, penstock=PenstockConfig(model="rigid", static_head_m=STATIC_HEAD_M, reaches=1,
                                                                segments=(segment,)),
                       generator=GeneratorConfig(inertia_time_s=INERTIA_TIME_S, self_regulation=0.0),
                       governor=governor, scenario=scenario, solver=SolverConfig(dt_s=dt_s))


def figures(time_s, flow_m3_s, speed_rpm) -> dict:
    """Time from the trip to flow reversal (Q crosses 0 upward, linear between samples), s, and the largest reverse
    speed (turbine direction), r/min."""
    i = int(np.flatnonzero((flow_m3_s[:-1] < 0.0) & (flow_m3_s[1:] >= 0.0))[0])
    t0 = time_s[i] - flow_m3_s[i] * (time_s[i + 1] - time_s[i]) / (flow_m3_s[i + 1] - flow_m3_s[i])
    return {"reversal_s": float(t0 - TRIP_S), "max_reverse_speed_rpm": float(np.max(speed_rpm))}


def reference(csv_path: Path = EXTERNAL / CSV, pump: str = "radial", initial=None) -> dict:
    """The figures of scipy's ``solve_ivp`` on the rigid-column equations (module docstring), from the steady pump
    point ``initial = (Q0 m^3/s, n0 r/min)`` (the simulator's steady state)."""
    from scipy.integrate import solve_ivp

    from hillchart.four_quadrant.table import load_wylie_streeter_curves

    c = load_wylie_streeter_curves(csv_path)[pump]
    x_t, order = np.mod(c.x[:-1] + math.pi, 2 * math.pi), None
    order = np.argsort(x_t)
    x_t, wh, wm = x_t[order], c.wh[:-1][order], c.wb[:-1][order]
    area = math.pi * DIAMETER_M ** 2 / 4.0
    resistance = DARCY * LENGTH_M / (2.0 * G_M_S2 * DIAMETER_M * area ** 2)
    inertia = INERTIA_TIME_S * P_R_W / (N_R * RPM_TO_RAD_S) ** 2  # J = Ta P_r / w_r^2

    def rhs(t, z):
        flow, omega = z
        q, v = flow / Q_R, omega / (N_R * RPM_TO_RAD_S)
        x = math.pi + math.atan2(q, v)
        r2 = q * q + v * v
        head = np.interp(x, x_t, wh, period=2 * math.pi) * r2 * H_R
        torque = np.interp(x, x_t, wm, period=2 * math.pi) * r2 * M_R
        return [G_M_S2 * area / LENGTH_M * (STATIC_HEAD_M - head - resistance * flow * abs(flow)), torque / inertia]

    q0, n0 = initial
    sol = solve_ivp(rhs, (TRIP_S, END_S), [q0, n0 * RPM_TO_RAD_S], method="RK45", rtol=1e-10, atol=1e-12,
                    dense_output=True)
    t = np.linspace(TRIP_S, END_S, 200001)
    flow, omega = sol.sol(t)
    return figures(t, flow, omega / RPM_TO_RAD_S)


def comparison(dt_s: float = 0.002) -> dict:
    """The simulator at ``dt_s`` and ``dt_s / 2`` and the reference: ``{"dt": figures, "dt/2": figures,
    "reference": figures, "steady": (Q0, n0, H0)}``."""
    from simulate.loop.engine import run_simulation

    with tempfile.TemporaryDirectory() as folder:
        curves = curves_file(Path(folder))
        runs = {}
        for label, dt in (("dt", dt_s), ("dt/2", dt_s / 2)):
            result = run_simulation(pump_plant(curves, dt))
            runs[label] = figures(result.time_s, result.flow_m3_s, result.speed_rpm)
        steady = (result.flow_m3_s[0], result.speed_rpm[0], result.head_m[0])
    runs["reference"] = reference(initial=steady[:2])
    runs["steady"] = steady
    return runs


def table(runs: dict, dt_s: float = 0.002) -> str:
    ref = runs["reference"]
    lines = ["| | flow reversal after the trip, s | largest reverse speed, r/min |", "|---|---|---|"]
    for label, name in (("reference", "scipy solve_ivp (RK45, rtol 1e-10)"), ("dt", f"hillsim, dt = {dt_s:g} s"),
                        ("dt/2", f"hillsim, dt = {dt_s / 2:g} s")):
        f = runs[label]
        if label == "reference":
            lines.append(f"| {name} | {f['reversal_s']:.4f} | {f['max_reverse_speed_rpm']:.1f} |")
        else:
            dr = 100 * (f["reversal_s"] / ref["reversal_s"] - 1)
            ds = 100 * (f["max_reverse_speed_rpm"] / ref["max_reverse_speed_rpm"] - 1)
            lines.append(f"| {name} | {f['reversal_s']:.4f} ({dr:+.2f} %) | {f['max_reverse_speed_rpm']:.1f} "
                         f"({ds:+.2f} %) |")
    return "\n".join(lines)


if __name__ == "__main__":
    if not (EXTERNAL / CSV).is_file():
        raise SystemExit(f"{EXTERNAL / CSV} is absent (external data)")
    runs = comparison()
    q0, n0, h0 = runs["steady"]
    print(f"steady pumping: Q0 = {q0:.5f} m^3/s, n0 = {n0:.2f} r/min, H0 = {h0:.4f} m\n")
    print(table(runs))
