"""The shipped pump-turbine plant's two transients through its S-zone, nets against the exact machine, at the plant's
step and at half of it; and the figure of the pump-turbine docs page (``--figures OUT`` writes
``OUT/pump_turbine_transients.png``).

* **Turbine-mode rejection, vanes blocked** (``data_synthetic/plant_pump_turbine.toml`` as shipped): the unit runs
  away through the S-zone into reverse flow and the runaway oscillates.
* **Pump trip, vanes blocked** (the same plant with ``turbine.operating_mode = "pump"``): the motor's torque is lost
  at 0.5 s, the pump runs down, the flow reverses, the runner turns back and runs away in the turbine direction.

Each is run on the shipped Suter nets and on the exact synthetic machine (``turbine.characteristics =
"synthetic-pump-turbine"``), through the same simulator; and on the nets again with twice the MOC reaches (half the
step). The figures (``simulate.results.reversal`` for the four-quadrant ones) and their differences are printed;
the test ``tests/simulate/studies/test_pump_turbine_transients.py`` asserts the issue's bounds on them.

    PYTHONPATH=. python benchmarks/bench_pump_turbine_transients.py [--figures OUT]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
PLANT = REPO / "data_synthetic" / "plant_pump_turbine.toml"
#: The two transients: name -> overrides of the shipped plant. 40 s holds three runaway periods of the rejection;
#: 30 s holds the pump trip's reverse runaway peak (about 18 s).
CASES = {
    "turbine-mode rejection": {"scenario.t_end_s": 40.0},
    "pump trip": {"turbine.operating_mode": "pump", "scenario.t_end_s": 30.0},
}
EXACT = {"turbine.characteristics": "synthetic-pump-turbine"}


def run(case: str, extra: dict | None = None):
    """The simulation result of ``case`` with ``extra`` overrides (the plant as loaded, and the result)."""
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    plant = load_plant(PLANT, {**CASES[case], **(extra or {})})
    result = run_simulation(plant)
    if not result.success:
        raise RuntimeError(f"{case} {extra or ''}: {result.message}")
    return plant, result


def runaway_period_s(time_s, speed_rpm, after_s: float) -> float:
    """Mean spacing of the speed's local maxima after ``after_s`` (s; nan with fewer than two)."""
    late = time_s > after_s
    t, n = time_s[late], np.abs(speed_rpm[late])
    peaks = np.flatnonzero((n[1:-1] > n[:-2]) & (n[1:-1] >= n[2:])) + 1
    return float(np.mean(np.diff(t[peaks]))) if peaks.size > 1 else math.nan


def figures(plant, result) -> dict:
    """The figures compared: extreme speed (% of n_r, signed as the turbine-positive speed), extreme heads (% of the
    rated head), the four-quadrant figures and the runaway's period."""
    from simulate.results.reversal import reversal_figures

    rated = plant.turbine.rated_speed_rpm
    head_r = plant.turbine.rated_head_m
    out = {"max speed (% n_r)": 100 * result.speed_rpm.max() / rated,
           "min speed (% n_r)": 100 * result.speed_rpm.min() / rated,
           "max head (% H_r)": 100 * result.head_m.max() / head_r,
           "min head (% H_r)": 100 * result.head_m.min() / head_r}
    four = reversal_figures(result.time_s, result.speed_rpm, result.flow_m3_s, result.opening, rated)
    out["max reverse flow (m^3/s)"] = four["max_reverse_flow_m3_s"]
    out["flow reversal (s)"] = four["t_flow_reversal_s"]
    out["first speed peak (s)"] = four["t_runaway_s"]
    out["runaway period (s)"] = runaway_period_s(result.time_s, result.speed_rpm, 10.0)
    return out


def measure() -> dict:
    """case -> {"nets", "exact", "half step"} -> (plant, result, figures)."""
    out = {}
    for case in CASES:
        out[case] = {}
        for label, extra in (("nets", None), ("exact", EXACT), ("half step", {"penstock.reaches": 80})):
            plant, result = run(case, extra)
            out[case][label] = (plant, result, figures(plant, result))
    return out


def table(measured: dict) -> str:
    lines = []
    for case, runs in measured.items():
        lines += [f"#### {case}", "", "| figure | nets | exact machine | nets, half step |", "|---|---|---|---|"]
        for name in runs["nets"][2]:
            values = [runs[label][2][name] for label in ("nets", "exact", "half step")]
            lines.append(f"| {name} | " + " | ".join("-" if v is None or not math.isfinite(v) else f"{v:.2f}"
                                                    for v in values) + " |")
        lines.append("")
    return "\n".join(lines)


def unit_path(plant, result):
    """(N11 r/min, Q11 m^3/s) of a run (the net head at the runner, D1 of the plant)."""
    d1 = plant.turbine.runner_diameter_m
    root = np.sqrt(np.maximum(result.head_m, 1e-9))
    return result.speed_rpm * d1 / root, result.flow_m3_s / (d1 * d1 * root)


def draw(measured: dict, out_dir) -> Path:
    """Left: the two runs' paths in (N11, Q11) over the exact machine's opening line at the held opening. Middle and
    right: speed, flow and head of the rejection and of the pump trip, relative to their rated values, nets (lines)
    and exact machine (dashed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hillchart.four_quadrant.plots import opening_line
    from hillchart.synthetic.pump_turbine import SyntheticPumpTurbine

    turbine = SyntheticPumpTurbine()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8))
    plant = measured["turbine-mode rejection"]["nets"][0]
    held_mm = plant.scenario.initial_opening * plant.turbine.opening_max
    n11, q11, _ = opening_line(turbine, held_mm)
    axes[0].plot(n11, q11, color="0.6", lw=3, label=f"opening line {held_mm:g} mm (exact)")
    for (case, runs), color, width in zip(measured.items(), ("C0", "C3"), (2.0, 0.8)):
        p, result, _ = runs["nets"]
        n, q = unit_path(p, result)
        axes[0].plot(n, q, color=color, lw=width, label=case)
        axes[0].plot(n[:1], q[:1], "o", color=color, ms=5)
    axes[0].axhline(0, color="0.6", lw=0.6)
    axes[0].axvline(0, color="0.6", lw=0.6)
    axes[0].set(xlabel="N11 (r/min)", ylabel="Q11 (m$^3$/s)", title="Paths over the opening line (dot: start)")
    axes[0].legend(fontsize=7, loc="lower right")
    for ax, (case, runs) in zip(axes[1:], measured.items()):
        for label, style in (("nets", "-"), ("exact", "--")):
            p, result, _ = runs[label]
            t = result.time_s
            for series, base, name, color in ((result.speed_rpm, p.turbine.rated_speed_rpm, "speed / n_r", "C0"),
                                              (result.flow_m3_s, p.turbine.rated_flow_m3_s, "flow / Q_r", "C2"),
                                              (result.head_m, p.turbine.rated_head_m, "head / H_r", "C3")):
                ax.plot(t, series / base, style, color=color, lw=1.0 if label == "nets" else 0.8,
                        label=name if label == "nets" else None)
        ax.axhline(0, color="0.6", lw=0.6)
        ax.set(xlabel="time (s)", ylabel="relative to rated", title=f"{case}: nets, exact machine dashed")
        ax.legend(fontsize=7)
    fig.tight_layout()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "pump_turbine_transients.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--figures", type=Path, help="write pump_turbine_transients.png into this folder")
    args = parser.parse_args(argv)
    measured = measure()
    print(table(measured))
    if args.figures is not None:
        print(f"wrote {draw(measured, args.figures)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
