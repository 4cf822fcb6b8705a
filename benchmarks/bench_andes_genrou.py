"""Cross-check of the sub-transient generator against ANDES's GENROU on a single machine on an infinite bus.

Run: ``pip install 'hillsim[andes]'`` (ANDES >= 2.0, optional), then ``python benchmarks/bench_andes_genrou.py``
(about 10 s). Without ANDES it says so and exits 0.

The same machine (Table 1 of paper 001, 100 MVA here, M = 2H = 8.1 s, no damping coefficient, no exciter, no
governor) feeds a 1.0 pu infinite bus through x = 0.3 pu at P = 0.8 pu and V = 1.0 pu. What differs between the
models: GENROU is a round-rotor model with a q-axis transient circuit (E'd, X'q, T'q0) and one sub-transient
reactance (X''d = X''q), a leakage reactance and saturation; paper 001's eq. (10) has no q-axis transient circuit.
GENROU's q-axis transient circuit is made inert (X'q = 0.5 ~ Xq = 0.512, T'q0 = 1 s), X''q = X''d = 0.187 (Table 1:
0.189), saturation off. Compared: the initial state, the electromechanical mode (ANDES eigenvalues vs our time
response to a small torque step), and a 100 ms three-phase fault at the machine terminals (current at the fault
instant, peak speed deviation, the speed trajectory).
"""

from __future__ import annotations

import math
from importlib import resources

import numpy as np

from simulate.components.electrical.generator import GridConfig, initial_generator_state, load_electrical
from simulate.components.electrical.standalone import simulate_unit

P_PU, X_LINE, M_S, T_END = 0.8, 0.3, 8.1, 8.0


def andes_case(fault: bool):
    import andes

    andes.config_logger(stream_level=40)
    ss = andes.System()
    ss.add("Bus", {"idx": 1, "name": "gen", "Vn": 110.0, "v0": 1.0})
    ss.add("Bus", {"idx": 2, "name": "inf", "Vn": 110.0, "v0": 1.0})
    ss.add("PV", {"idx": "PV_1", "bus": 1, "Sn": 100.0, "Vn": 110.0, "p0": P_PU, "v0": 1.0})
    ss.add("Slack", {"idx": "SL_1", "bus": 2, "Sn": 100.0, "Vn": 110.0, "v0": 1.0, "a0": 0.0})
    ss.add("Line", {"idx": "L1", "bus1": 1, "bus2": 2, "r": 0.0, "x": X_LINE, "Vn1": 110.0, "Vn2": 110.0,
                    "fn": 50.0})
    ss.add("GENROU", {"idx": "G1", "bus": 1, "gen": "PV_1", "Sn": 100.0, "Vn": 110.0, "fn": 50.0, "M": M_S, "D": 0.0,
                      "ra": 0.0, "xl": 0.15, "xd": 0.768, "xq": 0.512, "xd1": 0.249, "xq1": 0.5, "xd2": 0.187,
                      "xq2": 0.187, "Td10": 7.88, "Td20": 0.049, "Tq10": 1.0, "Tq20": 0.0283, "S10": 0.0,
                      "S12": 0.0})
    if fault:
        ss.add("Fault", {"idx": "F1", "bus": 1, "tf": 1.0, "tc": 1.1, "xf": 1e-4, "rf": 0.0})
    ss.setup()
    ss.PFlow.run()
    return ss


def main() -> None:
    try:
        import andes  # noqa: F401
    except ImportError:
        print("ANDES is not installed (optional: pip install 'hillsim[andes]'); nothing to compare")
        return
    gen = load_electrical(resources.files("data_synthetic") / "generator_table1.toml").generator
    bus = GridConfig(kind="infinite-bus", x_line_pu=X_LINE, bus_voltage_pu=1.0)
    ours0 = initial_generator_state(gen, bus, airgap_power_pu=P_PU, voltage_pu=1.0,
                                    turbine_rated_power_mw=gen.rated_mva)

    ss = andes_case(fault=False)
    ss.TDS.init()
    g = ss.GENROU
    rows = [("load angle delta (rad)", g.delta.v[0], ours0.state[3]),
            ("field voltage (pu)", g.vf.v[0], ours0.field_voltage_pu),
            ("Id (pu)", g.Id.v[0], ours0.outputs["id_pu"]), ("Iq (pu)", g.Iq.v[0], ours0.outputs["iq_pu"])]
    ss.EIG.run()
    mu = ss.EIG.mu
    mode = mu[np.argmax(mu.imag)]
    unit = simulate_unit(gen, bus, t_end_s=15.0, dt_s=0.002, steady=ours0, inertia_time_s=M_S,
                         torque_step=(0.5, 0.01))
    t, x = unit["time_s"], unit["speed_dev"]
    m = t > 1.0
    zc = t[m][np.where(np.diff(np.sign(x[m])) != 0)[0]]
    peaks = np.array([np.max(np.abs(x[(t > a) & (t < b)])) for a, b in zip(zc[:-1], zc[1:])])
    zeta = -np.polyfit(np.arange(peaks.size), np.log(peaks), 1)[0] / math.pi
    rows += [("electromechanical mode (Hz)", abs(mode.imag) / (2 * math.pi), 1.0 / (2 * np.mean(np.diff(zc)))),
             ("its damping ratio", -mode.real / abs(mode), zeta)]

    sf = andes_case(fault=True)
    sf.TDS.config.tf = T_END
    sf.TDS.config.tstep = 0.002
    sf.TDS.config.no_tqdm = 1
    sf.TDS.run()
    ts = sf.dae.ts
    ta = ts.t
    ia = np.hypot(ts.y[:, sf.GENROU.Id.a[0]], ts.y[:, sf.GENROU.Iq.a[0]])
    xa = ts.x[:, sf.GENROU.omega.a[0]] - 1.0
    run = simulate_unit(gen, bus, t_end_s=T_END, dt_s=0.002, steady=ours0, inertia_time_s=M_S,
                        fault_window=(1.0, 1.1))
    t, x = run["time_s"], run["speed_dev"]
    i = np.hypot(run["current_d_pu"], run["current_q_pu"])
    k = int(np.searchsorted(ta, 1.0 + 1e-6))
    rows += [("terminal fault: |i| just after (pu)", ia[k], float(np.interp(ta[k], t, i))),
             ("|i| 50 ms into the fault (pu)", float(np.interp(1.05, ta, ia)), float(np.interp(1.05, t, i))),
             ("peak speed deviation (pu)", float(np.max(np.abs(xa))), float(np.max(np.abs(x)))),
             ("time of the peak (s)", float(ta[np.argmax(np.abs(xa))]), float(t[np.argmax(np.abs(x))]))]
    diff = float(np.max(np.abs(np.interp(t, ta, xa) - x)) / np.max(np.abs(x)))
    print("| quantity | ANDES GENROU | hillsim eq. (10) | difference |")
    print("|---|---|---|---|")
    for name, a, b in rows:
        print(f"| {name} | {a:.5g} | {b:.5g} | {abs(b - a) / abs(a):.2%} |")
    print(f"\nspeed after the fault, max difference over {T_END:g} s: {diff:.1%} of the peak (the 1 % frequency "
          "difference accumulates as phase)")


if __name__ == "__main__":
    main()
