"""``hillsim demo [--out DIR]``: the whole pipeline on the shipped synthetic chart."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="run the pipeline end to end on the shipped synthetic chart",
        description="Load and extend the shipped synthetic chart and write the results into DIR.",
    )
    parser.add_argument("--out", default="hillsim_demo", help="output folder (default ./hillsim_demo)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from data_synthetic import FRANCIS_DIR
    from hillchart.extend import extend_samples
    from hillchart.samples import load_chart

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    chart = load_chart(FRANCIS_DIR)
    print(f"[1] chart {chart.info.name!r}: {chart.flow_n11.size} flow points on {chart.openings.size} opening lines, "
          f"{chart.eff_n11.size} efficiency points, {chart.runaway_n11.size} runaway points")
    extended = extend_samples(chart)
    extended.to_csv(out / "extended.csv")
    extended.plot(out / "extended.png")
    print(f"[2] extended to {extended.value.size} samples; K = {extended.k_zero_opening:.4g} N*m/(r/min)^2 "
          f"-> {out / 'extended.csv'}, {out / 'extended.png'}")
    print("This demo runs what exists so far (synth -> load -> extend -> plot); nets, simulation and "
          "identification follow in later releases.")
    return 0
