"""Generalization of the chart -> nets pipeline over the synthetic Francis family.

Grid: 3 turbines (slow, medium, fast) x 2 noise levels (0.15 %, 0.3 %) x 3 seeds x {with, without runaway curve};
each chart digitized as the issue's example (8 opening lines of 6 unevenly spaced points, Q11 in l/s, efficiency in
percent). For each chart two pipelines are trained:

* before: the paper's pipeline as hillsim had it before the physical-model boundaries and the cross-validated
  selection (polynomial boundaries, one 2-5-1 net, all samples weighted 1, best of 10 restarts);
* after: ``hillsim train``'s defaults (physical-model boundaries, boundary weight / hidden size / regularization by
  cross-validation on the measured samples, ensemble of 10 with a distilled point net);
* longer-fits (only when asked for with ``--pipelines``): the defaults with the Levenberg-Marquardt goal 1e-7 and
  100 validation fails always (the defaults choose between those and the paper's 1e-5 and 6 by cross-validation).

Printed per pipeline and turbine: measured- and extended-region errors (percent of the measured-region range, mean
and worst over the noise x seed x runaway grid), the worst six-coefficient error over the three operating points,
K of eq. (8) against the true disc friction, charts that fail the acceptance bounds, training failures, and (for the
after pipeline, with ``--coverage``) the fraction of truth-grid points inside the ensemble's 5-95 % band.

Usage: ``PYTHONPATH=. python benchmarks/bench_generalization.py [--seeds 3] [--turbines slow,medium,fast]
[--coverage] [--baseline]`` (about 20-40 min on 2 busy cores; ``--seeds 1`` for a quick look; ``--turbines
slow-x,medium-x,fast-x`` for the out-of-class family).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hillchart.extension.extend import ExtensionOptions  # noqa: E402
from hillchart.generalization import acceptance_failures, evaluate  # noqa: E402
from hillchart.synthetic.francis import FAMILY, DigitizationOptions  # noqa: E402

PIPELINES = {
    "before": (ExtensionOptions(boundaries="polynomial"),
               {"hidden": 5, "boundary_weight": 1.0, "regularization": 0.0, "ensemble": 0, "restarts": 10}),
    "after": (ExtensionOptions(), {"ensemble": 10}),
    # the defaults with the longer fits always (a Levenberg-Marquardt goal of 1e-7 and 100 validation fails; the
    # defaults choose between those and the paper's 1e-5 and 6: docs/guarantee-benchmark.md, step 14)
    "longer-fits": (ExtensionOptions(), {"ensemble": 10, "goal": 1e-7, "max_fail": 100}),
}


def coverage(nets, truth, inside, percentiles=(5.0, 95.0)) -> dict:
    """Fraction of truth-grid points whose exact Q11 / M11 lies inside the ensemble band, measured and extended."""
    out = {}
    for q in ("q11", "m11"):
        band = nets.band(q, truth["n11"], truth["opening"], percentiles=percentiles)
        ok = (truth[q] >= band["low"]) & (truth[q] <= band["high"])
        out[q] = (float(np.mean(ok[inside])), float(np.mean(ok[~inside])))
    return out


def _coverage_text(row) -> str:
    if "coverage" not in row:
        return ""
    c = row["coverage"]
    return f" cov Q {c['q11'][0]:.0%}/{c['q11'][1]:.0%} M {c['m11'][0]:.0%}/{c['m11'][1]:.0%}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--turbines", default=",".join(FAMILY))
    parser.add_argument("--noise", default="0.15,0.3")
    parser.add_argument("--pipelines", default="before,after")
    parser.add_argument("--coverage", action="store_true", help="ensemble band coverage of the truth grid")
    parser.add_argument("--baseline", action="store_true", help="also fit the measured samples alone (1.2 x rule)")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    rows = []
    for pipeline in args.pipelines.split(","):
        extension, train = PIPELINES[pipeline]
        for name in args.turbines.split(","):
            for noise in (float(v) for v in args.noise.split(",")):
                for seed in range(args.seeds):
                    for runaway in (True, False):
                        options = DigitizationOptions(points_per_line=6, spacing="uneven", noise_pct=noise,
                                                      q11_unit="l/s", efficiency_unit="percent", opening_lines=8,
                                                      runaway=runaway)
                        start = time.perf_counter()
                        try:
                            res = evaluate(name, seed=seed, options=options, extension=extension,
                                           train_kwargs=train, baseline=args.baseline)
                        except Exception as exc:  # reported as a failure of the pipeline, not swallowed
                            rows.append({"pipeline": pipeline, "turbine": name, "error": f"{type(exc).__name__}: "
                                                                                          f"{str(exc)[:80]}"})
                            print(f"{pipeline:6} {name:6} noise {noise} seed {seed} runaway {runaway}: FAILED {exc}",
                                  flush=True)
                            continue
                        row = {"pipeline": pipeline, "turbine": name, "noise": noise, "seed": seed,
                               "runaway": runaway, "k_ratio": res.k_ratio,
                               "coef": max(res.coefficient_errors.values()),
                               "fails": acceptance_failures(res), "seconds": time.perf_counter() - start}
                        for t in ("q11", "m11"):
                            for key in ("rms_measured_pct", "max_measured_pct", "rms_extended_pct"):
                                row[f"{t}_{key}"] = res.errors[t][key]
                        if args.coverage and res.nets.ensemble:
                            row["coverage"] = coverage(res.nets, res.truth, res.inside)
                        rows.append(row)
                        print(f"{pipeline:6} {name:6} noise {noise} seed {seed} runaway {runaway!s:5}: Q11 "
                              f"{row['q11_rms_measured_pct']:.2f}/{row['q11_max_measured_pct']:.2f} % M11 "
                              f"{row['m11_rms_measured_pct']:.2f} % ext {row['q11_rms_extended_pct']:.1f}/"
                              f"{row['m11_rms_extended_pct']:.1f} % K x{row['k_ratio']:.2f} coef {row['coef']:.3f}"
                              f"{_coverage_text(row)} "
                              f"{'FAIL ' + '; '.join(row['fails']) if row['fails'] else 'ok'} ({row['seconds']:.0f} s)",
                              flush=True)
    print()
    print("| pipeline | turbine | Q11 RMS meas. (mean / worst) | Q11 max meas. (worst) | M11 RMS meas. (mean / worst) "
          "| Q11 / M11 RMS extended (mean) | coefficients, worst | K / true (range) | charts failing | errors |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for pipeline in args.pipelines.split(","):
        for name in args.turbines.split(","):
            ok = [r for r in rows if r["pipeline"] == pipeline and r["turbine"] == name and "error" not in r]
            bad = [r for r in rows if r["pipeline"] == pipeline and r["turbine"] == name and "error" in r]
            if not ok:
                print(f"| {pipeline} | {name} | - | - | - | - | - | - | - | {len(bad)} |")
                continue

            def col(key):
                return np.array([r[key] for r in ok])

            k = col("k_ratio")
            print(f"| {pipeline} | {name} | {col('q11_rms_measured_pct').mean():.2f} / "
                  f"{col('q11_rms_measured_pct').max():.2f} % | {col('q11_max_measured_pct').max():.2f} % | "
                  f"{col('m11_rms_measured_pct').mean():.2f} / {col('m11_rms_measured_pct').max():.2f} % | "
                  f"{col('q11_rms_extended_pct').mean():.1f} / {col('m11_rms_extended_pct').mean():.1f} % | "
                  f"{col('coef').max():.3f} | {k.min():.2f}-{k.max():.2f} | "
                  f"{sum(bool(r['fails']) for r in ok)} of {len(ok)} | {len(bad)} |")
    if args.coverage:
        cov = [r["coverage"] for r in rows if "coverage" in r]
        if cov:
            for t in ("q11", "m11"):
                meas = np.mean([c[t][0] for c in cov])
                ext = np.mean([c[t][1] for c in cov])
                print(f"coverage of the 5-95 % band, {t.upper()}: measured region {meas:.0%}, extended region "
                      f"{ext:.0%} (mean over {len(cov)} charts)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
