"""Full-gate load rejection of a plant built on the Sayano-Shushenskaya chart, default solver settings.

    PYTHONPATH=$PWD python benchmarks/bench_sayano_rejection.py [--nets NETS_JSON]

Trains nets on the real chart (``../shared/external``, ``hillsim train`` with its defaults, about a minute) unless
``--nets`` gives them, then rejects the load from 100, 80 and 60 % of the stroke on the shipped plant's waterway
scaled to the unit (penstock 7.5/7.0 m, H_r 194 m, n_r 142.86 r/min, D1 6.77 m, P_r 640 MW), with the point nets and
with each of the ensemble's members (``--uncertainty``). Prints, per run, success, the steps the pressure loop's
fallback (damping, then Newton) solved, and max speed rise / max head rise. Skips (exit 0 with a line) without the data.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from importlib import resources
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The unit (published rated values of the Sayano-Shushenskaya units).
UNIT = {"turbine.rated_head_m": 194.0, "turbine.rated_speed_rpm": 142.86, "turbine.runner_diameter_m": 6.77,
        "turbine.rated_power_mw": 640.0, "turbine.rated_flow_m3_s": 358.0, "turbine.opening_max": 58.0,
        "penstock.static_head_m": 198.0, "generator.inertia_time_s": 8.0,
        # a penstock of the unit's size (7.5 m, 8 m/s at rated flow; the shipped plant's 6.2/5.6 m would carry 14 m/s)
        "penstock.segments": [{"length_m": 220.0, "diameter_m": 7.5, "wave_speed_m_s": 1100.0, "darcy_friction": 0.012},
                              {"length_m": 100.0, "diameter_m": 7.0, "wave_speed_m_s": 1150.0,
                               "darcy_friction": 0.012}]}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nets", type=Path, help="nets.json trained on the chart (default: train them now)")
    parser.add_argument("--save-nets", type=Path, help="keep the nets trained now at this path")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    with tempfile.TemporaryDirectory() as tmp:
        nets = args.nets
        if nets is None:
            import tests.external_charts as external

            for folder in (external.EXTERNAL_DIR, ROOT.parent.parent / "shared" / "external"):
                if all((folder / n).is_file() for n in (external.SAYANO_LINES, external.SAYANO_CONTOURS)):
                    external.EXTERNAL_DIR = folder
                    break
            else:
                print(f"skipped: the Sayano-Shushenskaya chart is not in {external.EXTERNAL_DIR}")
                return 0
            from hillsim.cli import main as hillsim

            chart = external.write_sayano_chart(Path(tmp) / "sayano")
            nets = Path(tmp) / "nets.json"
            if hillsim(["train", str(chart), "--out", str(nets), "--quiet"]) != 0:
                print("training failed")
                return 1
            if args.save_nets is not None:
                import shutil

                shutil.copyfile(nets, args.save_nets)
        plant_file = resources.files("data_synthetic") / "plant_hla339.toml"
        print("| start | members | runs ok | fallback steps (total) | max speed rise (%) | max head rise (%) |")
        print("|---|---|---|---|---|---|")
        cases = [(f"{pct} % stroke", {"scenario.initial_power_mw": None, "scenario.initial_opening": pct / 100})
                 for pct in (100, 80, 60)]
        failures = 0
        for label, over in cases:
            plant = load_plant(plant_file, {**UNIT, "turbine.characteristics": str(nets), "scenario.t_end_s": 30.0,
                                            **over})
            run = run_simulation(plant, raise_on_failure=False)
            s = run.summary()
            ok = int(run.success)
            failures += 1 - ok
            print(f"| {label} | - | {ok}/1 | {run.meta['pressure_loop_fallback_steps']} | "
                  f"{100 * s['max_speed_rise']:.2f} | {100 * s['max_head_rise']:.2f} |")
            from simulate.studies.uncertainty import run_members

            band = run_members(plant)
            failures += len(band["failed"])
            print(f"| {label} | {band['members']} | {band['members'] - len(band['failed'])}/{band['members']} | - | "
                  f"{100 * band['max_speed_rise']['low']:.2f}-{100 * band['max_speed_rise']['high']:.2f} | "
                  f"{100 * band['max_head_rise']['low']:.2f}-{100 * band['max_head_rise']['high']:.2f} |")
        return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
