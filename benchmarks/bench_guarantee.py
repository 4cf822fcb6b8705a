"""Guarantee figures of load rejections with trained nets against the exact turbine, over the synthetic family.

Grid: turbines (slow, medium, fast; with ``--family out-of-class`` the out-of-class slow-x, medium-x, fast-x of
:mod:`hillchart.synthetic.francis_variants`, whose physics below the lowest line and in overspeed is not the chart
extension's model class; ``--family both``: all six) x digitization (dense: 8 lines of 6 uneven points; sparse: 4-6
lines of 3-5 points, cycling with the seed) x noise (0.15 %, 0.3 %) x {with, without runaway curve} x seeds. Each
chart is trained with ``hillsim train``'s defaults (ensemble of 10); then 100 % load rejections with closing times 8,
10, 14 s from 100 % and 60 % load are simulated (MOC penstock, 225 MW unit sized from each turbine, see
:mod:`simulate.studies.guarantee`) with the nets, with every ensemble member (the ``run --uncertainty`` 5-95 % band) and
with the exact turbine.

Printed per chart: worst error (nets - exact, points) of max speed rise, max head rise and min head, coverage of the
5-95 % band (max speed rise and max head rise), median band widths, whether ``hillsim train`` would refuse the chart;
then a markdown table per turbine x digitization and the totals against the acceptance bounds, one table and one
verdict per family (in class, out of class), never pooled.

Usage: ``PYTHONPATH=. python benchmarks/bench_guarantee.py [--seeds 3] [--family in-class|out-of-class|both]
[--turbines slow,medium,fast] [--density dense,sparse] [--noise 0.15,0.3] [--runaway both] [--quick]
[--stops GOAL,MAX_FAIL] [--markdown FILE]``; ``--stops`` trains with these Levenberg-Marquardt stops (``goal`` and
``max_fail`` of :class:`hillchart.nets.estimator.HillNet`) instead of the ones the selection chooses.
About 20 s per chart on 2 busy cores (72 charts for the full grid); ``--quick`` runs one seed, noise 0.3 %, with
the runaway curve, closing times 8 and 14 s (6 charts, about 2 min).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hillchart.synthetic.francis import FAMILY  # noqa: E402
from hillchart.synthetic.francis_variants import OUT_OF_CLASS_FAMILY  # noqa: E402
from simulate.studies.guarantee import (ACCEPTANCE, CLOSING_TIMES_S, LOAD_FRACTIONS, ChartGuarantee,  # noqa: E402
                                        evaluate_chart, is_out_of_class, summarize)

#: Families of ``--family``: their turbines, in table order.
FAMILIES = {"in-class": tuple(FAMILY), "out-of-class": tuple(OUT_OF_CLASS_FAMILY)}
#: Headings of the per-family tables.
HEADINGS = {"in-class": "In-class family (the model class the extension fits)",
            "out-of-class": "Out-of-class family (hyperbolic throat foot, asymmetric incidence loss, leakage at closed "
                            "vanes)"}


def _chart_line(g) -> str:
    s = summarize([g])
    return (f"{g.turbine:8} {g.density:6} noise {g.noise_pct:.2f} runaway {g.runaway!s:5} seed {g.seed}: "
            f"speed {s['max_speed_rise_worst_pt']:.2f} head {s['max_head_rise_worst_pt']:.2f} "
            f"min head {s['min_head_drop_worst_pt']:.2f} pt; coverage {s['coverage']:.0%}, band speed "
            f"{s['max_speed_rise_band_median_pt']:.1f} head {s['max_head_rise_band_median_pt']:.1f} pt; "
            f"train {g.train_s:.1f} s{'; REFUSED: ' + g.refused[:80] if g.refused else ''}")


def table(charts) -> str:
    """Markdown table: one row per turbine x digitization, then all charts."""
    lines = ["| turbine | digitization | charts | max speed rise error, worst (mean) pt | max head rise error, worst "
             "(mean) pt | min head error, worst pt | band coverage | band width speed / head, median pt | "
             "cases within 1 / 2 pt | refused by train |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    order = [*FAMILY, *OUT_OF_CLASS_FAMILY]
    groups = sorted({(g.turbine, g.density) for g in charts}, key=lambda k: (order.index(k[0]), k[1]))
    for turbine, density in groups + [("all", "all")]:
        sel = [g for g in charts if turbine == "all" or (g.turbine == turbine and g.density == density)]
        s = summarize(sel)
        lines.append(f"| {turbine} | {density} | {s['charts']} | {s['max_speed_rise_worst_pt']:.2f} "
                     f"({s['max_speed_rise_mean_abs_pt']:.2f}) | {s['max_head_rise_worst_pt']:.2f} "
                     f"({s['max_head_rise_mean_abs_pt']:.2f}) | {s['min_head_drop_worst_pt']:.2f} | "
                     f"{s['coverage']:.0%} | {s['max_speed_rise_band_median_pt']:.1f} / "
                     f"{s['max_head_rise_band_median_pt']:.1f} | {s['within_bounds']:.0%} | {s['refused']} |")
    return "\n".join(lines)


def calibration(charts) -> str:
    """Split calibration of :data:`simulate.studies.uncertainty.BAND_INFLATION`: the smallest factor (steps of 0.1)
    whose band covers >= 90 % of the max speed / max head rise cases on all seeds but the last; its coverage and median
    head band width on the held-out last seed."""
    from simulate.studies.guarantee import BAND_JUDGED
    from simulate.studies.uncertainty import figure_band

    last = max(g.seed for g in charts)
    fit = [c for g in charts if g.seed != last for c in g.cases]
    held = [c for g in charts if g.seed == last for c in g.cases]
    if not fit or not held:
        return "calibration needs at least two seeds"

    def coverage(cases, factor):
        hits = [low <= c.exact[f] <= high for c in cases for f in BAND_JUDGED
                for low, high in [figure_band(c.members[f], inflation=factor)]]
        return float(np.mean(hits))

    def head_width(cases, factor):
        return float(np.median([100 * np.diff(figure_band(c.members["max_head_rise"], inflation=factor))[0]
                                for c in cases]))

    for factor in np.arange(1.0, 6.01, 0.1):
        if coverage(fit, factor) >= ACCEPTANCE["coverage"]:
            return (f"band widening factor {factor:.1f}: coverage {coverage(fit, factor):.0%} on seeds < {last} "
                    f"({len(fit)} cases), {coverage(held, factor):.0%} on the held-out seed {last} ({len(held)} "
                    f"cases), median head band {head_width(held, factor):.1f} pt there")
    return "no widening factor up to 6 reaches the coverage"


def _family_of(turbine: str) -> str:
    """``"in-class"`` or ``"out-of-class"``: the family of a turbine name."""
    return "out-of-class" if is_out_of_class(turbine) else "in-class"


def _family_report(family: str, charts, failures, calibrate: bool, elapsed_s: float | None) -> str:
    """Heading, (calibration,) table, verdict and failures of one family's charts, as markdown text."""
    lines = [f"### {HEADINGS[family]}", ""]
    if not charts:
        return "\n".join(lines + ["no chart ran", ""] + [f"failure: {f}" for f in failures])
    calibrated = calibration(charts) if calibrate else ""
    s = summarize(charts)
    verdict = (f"acceptance: speed within {ACCEPTANCE['speed_pt']} pt and head within {ACCEPTANCE['head_pt']} pt in "
               f"{s['within_bounds']:.0%} of {s['cases']} cases (worst {s['max_speed_rise_worst_pt']:.2f} / "
               f"{s['max_head_rise_worst_pt']:.2f} pt); coverage {s['coverage']:.0%} (>= "
               f"{ACCEPTANCE['coverage']:.0%}); median head band {s['max_head_rise_band_median_pt']:.1f} pt (<= "
               f"{ACCEPTANCE['head_band_median_pt']}); {len(failures)} pipeline failures; "
               f"{s['refused']} charts refused by train; mean training {np.mean([g.train_s for g in charts]):.1f} s"
               + ("" if elapsed_s is None else f"; {elapsed_s / 60:.1f} min"))
    lines += [table(charts), "", verdict]
    if calibrated:
        lines += ["", calibrated]
    lines += [f"\nfailure: {f}" for f in failures]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="seeds 0..N-1 (default 3)")
    parser.add_argument("--family", choices=("in-class", "out-of-class", "both"), default="in-class",
                        help="which family's turbines run when --turbines is not given (default in-class)")
    parser.add_argument("--turbines", help="comma-separated members of either family (default: those of --family)")
    parser.add_argument("--density", default="dense,sparse")
    parser.add_argument("--noise", default="0.15,0.3")
    parser.add_argument("--runaway", choices=("both", "with", "without"), default="both")
    parser.add_argument("--closing", default=",".join(str(v) for v in CLOSING_TIMES_S),
                        help="closing times of a full stroke, s")
    parser.add_argument("--loads", default=",".join(str(v) for v in LOAD_FRACTIONS),
                        help="initial loads, fractions of rated power (default 1.0,0.6)")
    parser.add_argument("--quick", action="store_true",
                        help="one seed, noise 0.3 %%, with runaway curve, closing 8 and 14 s")
    parser.add_argument("--stops", help="GOAL,MAX_FAIL: train with these Levenberg-Marquardt stops (default: "
                                        "chosen by the selection's cross-validation)")
    parser.add_argument("--markdown", help="also write the table to this file")
    parser.add_argument("--json", help="also write every case (exact, nets, each member's value) to this file")
    parser.add_argument("--from-json", help="no runs: the tables of the cases stored by --json, with today's band")
    parser.add_argument("--calibrate", action="store_true",
                        help="also print the smallest band widening factor that covers >= 90 %% of the cases of "
                             "every seed but the last, and the coverage it gives on the last seed (held out)")
    args = parser.parse_args(argv)
    if args.quick:
        args.seeds, args.noise, args.runaway, args.closing = 1, "0.3", "with", "8,14"
    runaways = {"both": (True, False), "with": (True,), "without": (False,)}[args.runaway]
    train_kwargs = None
    if args.stops:
        try:
            goal, max_fail = args.stops.split(",")
            train_kwargs = {"goal": float(goal), "max_fail": int(max_fail)}
        except ValueError:
            parser.error(f"--stops must be GOAL,MAX_FAIL (a number > 0 and an integer >= 1, e.g. 1e-7,100), got "
                         f"{args.stops!r}")
        if not (train_kwargs["goal"] > 0 and train_kwargs["max_fail"] >= 1):
            parser.error(f"--stops must be GOAL,MAX_FAIL with GOAL > 0 and MAX_FAIL >= 1, got {args.stops!r}")
    closing = tuple(float(v) for v in args.closing.split(","))
    loads = tuple(float(v) for v in args.loads.split(","))
    turbines = (args.turbines.split(",") if args.turbines else
                [t for name, members in FAMILIES.items() if args.family in (name, "both") for t in members])
    unknown = [t for t in turbines if t not in (*FAMILY, *OUT_OF_CLASS_FAMILY)]
    if unknown:
        parser.error(f"unknown turbines {', '.join(unknown)}; allowed: {', '.join([*FAMILY, *OUT_OF_CLASS_FAMILY])}")
    warnings.simplefilter("ignore")
    charts, failures = [], []
    elapsed = {name: 0.0 for name in FAMILIES}
    if args.from_json:
        doc = json.loads(Path(args.from_json).read_text(encoding="utf-8"))
        charts = [ChartGuarantee.from_dict(c) for c in doc["charts"]]
        failures = doc["failures"]
    for turbine in ([] if args.from_json else turbines):
        start = time.perf_counter()
        for density in args.density.split(","):
            for noise in (float(v) for v in args.noise.split(",")):
                for runaway in runaways:
                    for seed in range(args.seeds):
                        try:
                            g = evaluate_chart(turbine, density=density, noise_pct=noise, runaway=runaway,
                                               seed=seed, closing_times_s=closing, load_fractions=loads,
                                               train_kwargs=train_kwargs)
                        except Exception as exc:  # reported as a failure of the pipeline, never swallowed
                            failures.append(f"{turbine} {density} noise {noise} runaway {runaway} seed {seed}: "
                                            f"{type(exc).__name__}: {str(exc)[:160]}")
                            print("FAILED", failures[-1], flush=True)
                            continue
                        charts.append(g)
                        print(_chart_line(g), flush=True)
        elapsed[_family_of(turbine)] += time.perf_counter() - start
    if args.json:
        Path(args.json).write_text(json.dumps({"charts": [g.to_dict() for g in charts], "failures": failures}),
                                   encoding="utf-8")
    if not charts:
        print("no chart ran")
        for f in failures:
            print("failure:", f)
        return 1
    command = ("PYTHONPATH=. python benchmarks/bench_guarantee.py "
               + " ".join(argv if argv is not None else sys.argv[1:]))
    sections = []
    for family in FAMILIES:  # one table and one verdict per family: in-class and out-of-class are never pooled
        own = [g for g in charts if _family_of(g.turbine) == family]
        own_failures = [f for f in failures if _family_of(f.split(" ", 1)[0]) == family]
        if not own and not own_failures:
            continue
        sections.append(_family_report(family, own, own_failures, args.calibrate,
                                       None if args.from_json else elapsed[family]))
    text = "\n\n".join(sections)
    print()
    print(text)
    if args.markdown:
        Path(args.markdown).write_text(f"`{command.strip()}`\n\n{text}\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
