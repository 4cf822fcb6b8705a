"""Sub-transient generator (paper 001 eq. (10), Table 1): validation numbers, step throughput, figures.

Run: ``python benchmarks/bench_generator.py [--figures docs]`` (a few seconds). Prints the short-circuit current
against the closed form and the classical envelope, the field-step time constant, the electromechanical mode on an
infinite bus, and the cost of one generator step (compiled) in steps per second. Speed is measured here, never
asserted in a test.
"""

from __future__ import annotations

import argparse
import math
import time
from importlib import resources
from pathlib import Path

import numpy as np

from simulate.components.electrical.generator import (
    GridConfig,
    generator_step,
    initial_generator_state,
    load_electrical,
)
from simulate.components.electrical.standalone import (
    classical_short_circuit_current,
    field_step_test,
    short_circuit_test,
    simulate_generator,
    simulate_unit,
    transient_synchronizing_torque,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--figures", default=None, help="folder for short_circuit.png and voltage_control.png")
    args = parser.parse_args()
    elec = load_electrical(resources.files("data_synthetic") / "generator_table1.toml")
    gen, exc, island = elec.generator, elec.excitation, elec.grid

    sc = short_circuit_test(gen, event_time_s=0.1, t_end_s=5.0, dt_s=1e-3)
    after = sc["time_s"] >= 0.1 - 1e-9
    tau = sc["time_s"][after] - 0.1
    current = np.hypot(sc["current_d_pu"], sc["current_q_pu"])[after]
    classical = classical_short_circuit_current(gen, 1.0, tau)
    dev = np.abs(current - classical)
    print(f"short circuit from 1 pu: i(0+) = {current[0]:.4f} pu (E/X''d = {1 / gen.xd_st:.4f}), i(5 s) = "
          f"{current[-1]:.4f}; classical envelope max deviation {dev.max() / classical[0]:.2%} of i(0+) at "
          f"t = {tau[np.argmax(dev)]:.3f} s")

    fs = field_step_test(gen, field_step_pu=0.1, event_time_s=1.0, t_end_s=40.0, dt_s=0.01)
    s = fs["time_s"] - 1.0
    v = fs["terminal_voltage_pu"]
    window = (s > 5 * gen.td0_st_s) & (s < 3 * gen.td0_t_s)
    slope = np.polyfit(s[window], np.log(1.1 - v[window]), 1)[0]
    print(f"field step +0.1 pu at open circuit: fitted time constant {-1 / slope:.4f} s (T'd0 = {gen.td0_t_s} s)")

    bus = GridConfig(kind="infinite-bus", x_line_pu=0.3, bus_voltage_pu=1.0)
    steady = initial_generator_state(gen, bus, airgap_power_pu=0.8, voltage_pu=1.0, turbine_rated_power_mw=225.0)
    unit = simulate_unit(gen, bus, t_end_s=15.0, dt_s=0.002, steady=steady, inertia_time_s=9.0,
                         torque_step=(0.5, 0.05))
    t, x = unit["time_s"], unit["speed_dev"]
    m = t > 1.0
    zc = t[m][np.where(np.diff(np.sign(x[m])) != 0)[0]]
    peaks = np.array([np.max(np.abs(x[(t > a) & (t < b)])) for a, b in zip(zc[:-1], zc[1:])])
    zeta = -np.polyfit(np.arange(peaks.size), np.log(peaks), 1)[0] / math.pi
    ks = transient_synchronizing_torque(gen, bus, steady)
    f_cl = math.sqrt(2 * math.pi * 50 * ks * steady.params[21] / 9.0) / (2 * math.pi)
    print(f"infinite bus (x_line 0.3, P 0.8, Ta 9 s): electromechanical mode {1 / (2 * np.mean(np.diff(zc))):.4f} Hz "
          f"(classical E'q-behind-X'd {f_cl:.4f} Hz), damping ratio {zeta:.4f}")

    island_state = initial_generator_state(gen, island, airgap_power_pu=0.8, voltage_pu=1.0)
    p, st, work = island_state.params, island_state.state.copy(), np.zeros(28)
    generator_step(p, st, 0.0, island_state.field_voltage_pu, 1.0, 1.0, 0.0, 0.01, work)  # compile
    n = 20000
    t0 = time.perf_counter()
    for _ in range(n):
        generator_step(p, st, 0.0, island_state.field_voltage_pu, 1.0, 1.0, 0.0, 0.01, work)
    per = (time.perf_counter() - t0) / n
    print(f"generator_step (dt 0.01 s, {int(math.ceil(0.01 / p[20]))} RK4 sub-steps, called from Python): "
          f"{1 / per:,.0f} steps/s ({per * 1e6:.1f} us per step incl. the Python call)")

    if args.figures:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out = Path(args.figures)
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.6))
        a1.plot(tau, current, lw=2, label="eq. (10), RK4")
        a1.plot(tau, classical, ls="--", label="classical envelope")
        a1.set_xlabel("time after the fault (s)")
        a1.set_ylabel("|i| (pu)")
        a1.set_title("three-phase terminal fault from open circuit")
        a1.legend()
        a1.grid(alpha=0.3)
        held = simulate_generator(gen, island, t_end_s=20.0, dt_s=0.01, steady=island_state, load_step=(1.0, 1.1))
        ctrl = simulate_generator(gen, island, t_end_s=20.0, dt_s=0.01, steady=island_state, load_step=(1.0, 1.1),
                                  excitation=exc)
        a2.plot(held["time_s"], held["terminal_voltage_pu"], label="field held")
        a2.plot(ctrl["time_s"], ctrl["terminal_voltage_pu"], label="PI voltage control (eqs. 11-13)")
        a2.set_xlabel("time (s)")
        a2.set_ylabel("terminal voltage (pu)")
        a2.set_title("island, +10 % load at 1 s (speed held)")
        a2.legend()
        a2.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(out / "generator.png", dpi=80)
        plt.close(fig)
        print(f"wrote {out / 'generator.png'}")


if __name__ == "__main__":
    main()
