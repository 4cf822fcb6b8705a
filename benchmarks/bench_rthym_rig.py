"""The Bergant-Simpson rig in RTHYM-MOC and in hillsim, in the same run (RTHYM-MOC optional: ``pip install
rthym-moc``): the pulses at the valve at 1.4 m/s against the measured trace.

    PYTHONPATH=$PWD python benchmarks/bench_rthym_rig.py

RTHYM-MOC (github.com/jlillywh/RTHYM-MOC, MIT licence; an open C++ MOC code with a Python API, US units) is run on
its own set-up of the rig, as its verification tests build it (``tests/bergant_adelaide_verification_utils.py``,
commit 200f1b8): a tank 22 m above the pipe's upstream end, the copper pipe of 37.23 m and 22.1 mm (Hazen-Williams
C = 130, wall 1.63 mm, E = 117 GPa, a computed by the code) rising 5.6 % to a valve node, a short stub to a downstream
tank that sets the steady velocity, the valve shut linearly in 9 ms, its discrete vapour cavity model at 1.7 kPa
absolute (15 degC) and its defaults otherwise (its unsteady friction on). It runs at dt = 2e-4, 1e-4 (its default
for the rig) and 5e-5 s. hillsim runs the rig of ``benchmarks/bench_column_separation.py`` with its defaults (the
convolution friction, the discrete gas cavity model) at that benchmark's dt and dt / 2. Both are read with that
benchmark's pulse figures (each pulse's top and the time it rises through 1000 kPa, :func:`window_peaks`) beside the
digitized measurement.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tests.scripts import load_script  # noqa: E402

#: RTHYM-MOC's set-up of the rig (its verification helper's constants, SI).
SLOPE = 0.056
WALL_MM = 1.63
COPPER_E_PA = 117.0e9
HAZEN_WILLIAMS_C = 130.0
VAPOUR_KPA_ABS = 1.7
ATMOSPHERIC_KPA = 101.325
#: RTHYM-MOC's steps, s (its default for the rig is 1e-4).
RTHYM_STEPS_S = (2e-4, 1e-4, 5e-5)
#: hillsim's runs: (friction, cavity model), its defaults.
HILLSIM_RUNS = (("convolution", "dgcm"),)


def rig():
    return load_script("bench_column_separation", folder="benchmarks")


def rthym_available() -> bool:
    try:
        import rthym_moc  # noqa: F401
    except ImportError:
        return False
    return True


def _downstream_head_m(upstream_m: float, velocity_m_s: float, length_m: float, diameter_m: float) -> float:
    """The downstream tank's head (m) that gives ``velocity_m_s`` with the Hazen-Williams loss (as RTHYM-MOC's
    helper inverts it, US units: h_f = 10.44 L Q^1.852 / (C^1.852 d^4.871), ft, gpm, in)."""
    import rthym_moc as m

    q_gpm = velocity_m_s * math.pi * diameter_m ** 2 / 4.0 * m.M3S_TO_GPM
    hf_ft = 10.44 * length_m * m.M_TO_FT * q_gpm ** 1.852 / (HAZEN_WILLIAMS_C ** 1.852
                                                              * (diameter_m * 1e3 * m.MM_TO_IN) ** 4.871)
    return upstream_m - hf_ft * m.FT_TO_M - SLOPE * length_m


def rthym_run(velocity_m_s: float, dt_s: float, t_end_s: float) -> tuple[np.ndarray, np.ndarray]:
    """RTHYM-MOC on the rig: time (s after the start of the closure) and absolute pressure at the valve (kPa)."""
    import rthym_moc as m

    b = rig()
    length, diameter = b.LENGTH_M, b.DIAMETER_M
    z_valve = SLOPE * length
    h_down = _downstream_head_m(b.TANK_HEAD_M, velocity_m_s, length, diameter)

    def node(name, kind, **values):
        n = m.NodeInput()
        n.id, n.type = name, kind
        for key, value in values.items():
            setattr(n, key, value)
        return n

    def pipe(name, start, end, length_ft, **values):
        p = m.PipeInput()
        p.id, p.from_node, p.to_node, p.length = name, start, end, length_ft
        for key, value in values.items():
            setattr(p, key, value)
        return p

    solver = m.MOCSolver()
    solver.add_node(node("T_UP", "Tank", elevation=0.0, head=b.TANK_HEAD_M * m.M_TO_FT))
    solver.add_node(node("V_DN", "Valve", elevation=z_valve * m.M_TO_FT, diameter=diameter * 1e3 * m.MM_TO_IN,
                         current_setting=100.0, head=h_down * m.M_TO_FT))
    solver.add_node(node("T_DN", "Tank", elevation=z_valve * m.M_TO_FT, head=h_down * m.M_TO_FT))
    common = dict(diameter=diameter * 1e3 * m.MM_TO_IN, wall_thickness=WALL_MM * m.MM_TO_IN,
                  youngs_modulus=COPPER_E_PA * m.PA_TO_PSI, poissons_ratio=0.34, roughness=HAZEN_WILLIAMS_C)
    q_gpm = velocity_m_s * math.pi * diameter ** 2 / 4.0 * m.M3S_TO_GPM
    solver.add_pipe(pipe("P_MAIN", "T_UP", "V_DN", length * m.M_TO_FT, flow_gpm=q_gpm, **common))
    stub_ft = max(b.WAVE_SPEED_M_S * 1e-4, 0.5) * m.M_TO_FT
    solver.add_pipe(pipe("P_STUB", "V_DN", "T_DN", stub_ft, flow_gpm=0.0, **common))
    closing = b.CLOSING_TIME_S
    steps = max(int(closing / dt_s) + 1, 2)
    schedule = [(0.0, 100.0)] + [(i * dt_s, max(0.0, 100.0 * (1.0 - i * dt_s / closing))) for i in range(1, steps + 1)]
    schedule.append((schedule[-1][0] + 10.0 * dt_s, 0.0))
    solver.set_valve_schedule("V_DN", schedule)
    vapour_psi = (VAPOUR_KPA_ABS - ATMOSPHERIC_KPA) * m.KPA_TO_PSI
    out = solver.run(total_time=t_end_s, dt=dt_s, p_vapor_psi=vapour_psi, cavitation_model=m.CavitationModel.DVCM)
    t = np.asarray(out["time"], float)
    head_ft = np.asarray(out["node_head"]["V_DN"], float)
    gauge_kpa = (head_ft - z_valve * m.M_TO_FT) / m.PSI_TO_FT * m.PSI_TO_KPA
    return t, gauge_kpa + ATMOSPHERIC_KPA


def rows() -> list[dict]:
    """The measured pulses, hillsim's (:data:`HILLSIM_RUNS` at dt and dt / 2) and RTHYM-MOC's
    (:data:`RTHYM_STEPS_S`, when installed), each as :func:`window_peaks` reads them, at 1.4 m/s."""
    b = rig()
    out = b.trace_table(runs=HILLSIM_RUNS, label="hillsim, ")
    if rthym_available():
        import rthym_moc

        for dt in RTHYM_STEPS_S:
            t, p = rthym_run(1.4, dt, b.TRACE_END_S)
            out.append({"run": f"RTHYM-MOC {rthym_moc.__version__}, DVCM, its defaults", "dt_s": dt,
                        "peaks": b.window_peaks(t, p)})
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.parse_args(argv)
    if not rthym_available():
        print("RTHYM-MOC is not installed (pip install rthym-moc): hillsim's rows only")
    print(rig().trace_markdown(rows()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
