"""Which out-of-class change moves the guarantee figures: each switched off in turn.

The out-of-class family (:mod:`hillchart.synthetic.francis_variants`) differs from the model class the extension fits
by three changes acting where a chart is silent: a guide-vane throat with a foot, an asymmetric incidence loss and
leakage at closed vanes. For one turbine this script draws its chart (seed 0, reading noise 0.3 %, no runaway curve),
trains with ``hillsim train``'s defaults and rejects 100 % load with closures of 8 and 14 s (the guarantee
benchmark's plant, :mod:`simulate.studies.guarantee`), once with all three changes and once with each switched off,
and prints the max speed rise and max head rise errors (nets minus exact turbine, points).

Usage: ``PYTHONPATH=. python benchmarks/bench_out_of_class_ablation.py [--turbine slow-x]`` (about 1 min on 2 cores).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hillchart.synthetic import francis_variants  # noqa: E402
from simulate.studies.guarantee import evaluate_chart  # noqa: E402


def variants(member) -> dict:
    """The member's physics with all three changes, and with each switched off (the model class's value)."""
    physics = member.physics
    return {"all three changes": physics,
            "without the asymmetric incidence loss": dataclasses.replace(
                physics, k_incidence_negative=member.params.k_incidence),
            "without leakage": dataclasses.replace(physics, leakage_q11=0.0),
            "without the throat foot": dataclasses.replace(physics, throat_foot_mm=0.0)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--turbine", default="slow-x", choices=list(francis_variants.OUT_OF_CLASS_FAMILY))
    args = parser.parse_args(argv)
    family = francis_variants.OUT_OF_CLASS_FAMILY
    member = family[args.turbine]
    print(f"{args.turbine}, seed 0, noise 0.3 %, no runaway curve, 100 % load; errors nets - exact, points "
          "(closing 8 s / 14 s)\n")
    print("| physics | digitization | max speed rise error | max head rise error |")
    print("|---|---|---|---|")
    try:
        for label, physics in variants(member).items():
            family[args.turbine] = dataclasses.replace(member, physics=physics)
            for density in ("dense", "sparse"):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    chart = evaluate_chart(args.turbine, density=density, noise_pct=0.3, runaway=False, seed=0,
                                           closing_times_s=(8.0, 14.0), load_fractions=(1.0,), band=False)
                speed = " / ".join(f"{c.error_pt('max_speed_rise'):+.2f}" for c in chart.cases)
                head = " / ".join(f"{c.error_pt('max_head_rise'):+.2f}" for c in chart.cases)
                print(f"| {label} | {density} | {speed} | {head} |", flush=True)
    finally:
        family[args.turbine] = member
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
