"""Below the lowest line, on the real charts: what the inner evidence saw against what was asked.

For each k of ``benchmarks/bench_extrapolation.py`` (the k lowest opening lines of the Sayano-Shushenskaya chart held
out), the extension of the kept lines weighs its hypotheses by its *inner* hold-outs (its own lowest line, then its
two lowest, :func:`hillchart.extension.hypotheses.chart_evidence`). This script prints, per held-out line, the
distance ``d = 1 - a / a_low`` below the lowest kept line and every hypothesis' mean signed Q11 error there (log-ratio,
%), for the inner folds (what the weights saw) and for the outer held-out lines (what was asked), with the weights
and the weighed median; and how far the lowest kept line, as the hypotheses read it (:class:`LowestLine`), is from its
own digitized points (0 when it passes through them).

The same for the EGAT 137 kW bulb table of ``benchmarks/bench_bulb_extrapolation.py`` (the k lowest guide-vane
angles of every sweep held out; :mod:`hillchart.fccm.evidence`), per held-out angle.

No nets are trained (the blend is what a run reads below the lowest line, within 0.1 % on the Francis chart);
about 30 s.

Run::

    PYTHONPATH=. python benchmarks/bench_extrapolation_evidence.py
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

HOLD_OUTS = (1, 2, 3)


def _line_rows(label, opening, distance, q11, predictions, names, blend=None):
    """One row per line: label, opening, distance, points and the mean signed log-ratio error (%) of every hypothesis
    of ``names``."""
    rows = []
    for a in np.unique(opening):
        on = opening == a
        errors = [100 * float(np.mean(np.log(predictions[h][0][on] / q11[on]))) for h in names]
        if blend is not None:
            errors.append(100 * float(np.mean(np.log(blend[on] / q11[on]))))
        rows.append(f"| {label} | {a:g} | {float(distance[on][0]):.3f} | {int(on.sum())} | "
                    + " | ".join(f"{e:+.1f}" for e in errors) + " |")
    return rows


def lowest_line_miss(chart, torque, fit_model) -> float:
    """Largest relative Q11 miss of the lowest line, as the hypotheses read it, at its own digitized points."""
    from hillchart.extension.hypotheses import fit_hypotheses

    model = fit_model(chart, torque)
    hyp = fit_hypotheses(chart, torque, model, model.k_zero_opening)
    on = chart.flow_opening == hyp.lowest.opening
    q, _ = hyp.lowest.values(model, chart.flow_n11[on])
    return float(np.max(np.abs(q / chart.flow_q11[on] - 1.0)))


def diagnose(chart, k: int) -> str:
    """The tables of one k (module docstring)."""
    from benchmarks.bench_extrapolation import reduced_chart
    from hillchart.extension.band import weighed_median
    from hillchart.extension.extend import extend_samples
    from hillchart.extension.hypotheses import sub_chart
    from hillchart.extension.turbine_model import fit_turbine_model

    rest, held = reduced_chart(chart, k)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        extended = extend_samples(rest)
    x = extended.extrapolation
    ev, hyp = x.evidence, x.hypotheses
    weights, names = ev.weights["q11"], ev.names
    out = [f"#### k = {k}: lowest kept line {hyp.lowest.opening:g}", "",
           "| held out | line | d | points | " + " | ".join(names) + " | weighed median |",
           "|---|---|---|---|" + "---|" * (len(names) + 1),
           "| weights Q11 | | | | " + " | ".join(f"{weights[h]:.2f}" for h in names) + " | |"]
    for fold in ev.folds + ev.band_folds:
        blend = weighed_median([fold.predictions[h][0] for h in names], [weights[h] for h in names])
        tag = f"inner, {fold.lines} line{'s' if fold.lines > 1 else ''}" + (
            "" if fold in ev.folds else " (band only)")
        out += _line_rows(tag, fold.opening, fold.distance, fold.q11, fold.predictions, names, blend)
    n, a, q = chart.flow_n11[held], chart.flow_opening[held], chart.flow_q11[held]
    predictions = {h: hyp.predict(h, n, a) for h in names}
    out += _line_rows("**outer** (asked)", a, 1.0 - a / hyp.lowest.opening, q, predictions, names,
                      x.values(n, a)[0])
    inner_d = max(float(f.distance.max()) for f in ev.folds + ev.band_folds)
    outer_d = float((1.0 - a / hyp.lowest.opening).max())
    torque = extended.value[(extended.target == "m11") & (extended.origin == "measured")]
    openings = np.unique(rest.flow_opening)
    misses = []
    for lines in (1, 2):
        keep = ~np.isin(rest.flow_opening, openings[:lines])
        misses.append(lowest_line_miss(sub_chart(rest, keep), torque[keep], fit_turbine_model))
    out += ["", f"The inner folds reach d = {inner_d:.3f}; the question reaches d = {outer_d:.3f} (the silent-region "
                f"samples reach 0.9). The lowest kept line of the inner folds, as the hypotheses read it, misses its "
                f"own digitized points by up to {100 * misses[0]:.1f} % (1 line held out) and {100 * misses[1]:.1f} % "
                "(2 lines held out).", ""]
    return "\n".join(out)


def diagnose_bulb(samples, k: int) -> str:
    """The table of one k of the bulb table (module docstring)."""
    from benchmarks.bench_bulb_extrapolation import SEED, _subset
    from hillchart.extension.band import weighed_median
    from hillchart.fccm.double_regulated import extend_unit_samples
    from hillchart.fccm.evidence import HYPOTHESES, held_out_mask, hold_out_angles, table_evidence

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        closed = extend_unit_samples(samples, seed=SEED)[2].opening_closed
        n, a, b = (np.asarray(samples[key], float) for key in ("n11", "opening", "blade_angle"))
        outer = hold_out_angles(samples, k, opening_closed=closed, seed=SEED)
        kept = _subset(samples, ~held_out_mask(n, a, b, k)[0])
        evidence = table_evidence(kept, extend_unit_samples(kept, opening_closed=closed, seed=SEED)[2], seed=SEED)
    weights = evidence.weights["q11"]
    out = [f"#### bulb, k = {k}", "",
           "| held out | angle | mean d | points | " + " | ".join(HYPOTHESES) + " | weighed median |",
           "|---|---|---|---|" + "---|" * (len(HYPOTHESES) + 1),
           "| weights Q11 | | | | " + " | ".join(f"{weights[h]:.2f}" for h in HYPOTHESES) + " | |"]
    for label, folds in (("inner", evidence.folds), ("**outer** (asked)", [outer])):
        for fold in folds:
            blend = weighed_median([fold.predictions[h][0] for h in HYPOTHESES], [weights[h] for h in HYPOTHESES])
            for angle in np.unique(fold.opening):
                on = fold.opening == angle
                errors = [np.mean(np.log(fold.predictions[h][0][on] / fold.q11[on])) for h in HYPOTHESES]
                errors.append(np.mean(np.log(blend[on] / fold.q11[on])))
                tag = label if folds is not evidence.folds else f"inner, {fold.angles} angle{'s' * (fold.angles > 1)}"
                out.append(f"| {tag} | {angle:g} | {float(np.mean(fold.distance[on])):.3f} | {int(on.sum())} | "
                           + " | ".join(f"{100 * e:+.1f}" for e in errors) + " |")
    return "\n".join(out + [""])


def main() -> int:
    from benchmarks.bench_extrapolation import sayano_chart
    from tests.external_charts import EXTERNAL_DIR, SAYANO_CONTOURS, SAYANO_LINES

    if not all((EXTERNAL_DIR / name).is_file() for name in (SAYANO_LINES, SAYANO_CONTOURS)):
        print(f"the real chart is absent ({EXTERNAL_DIR}); nothing to measure")
        return 0
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        chart = sayano_chart(folder)
    print("Sayano-Shushenskaya Francis: mean signed Q11 error (log-ratio, %) per held-out line\n")
    for k in HOLD_OUTS:
        print(diagnose(chart, k))
    from benchmarks.bench_bulb_extrapolation import real_samples
    from tests.fccm_external import BULB_137KW

    if not (EXTERNAL_DIR / BULB_137KW).is_file():
        print(f"the real bulb table is absent ({EXTERNAL_DIR / BULB_137KW})")
        return 0
    with tempfile.TemporaryDirectory() as folder:
        samples = real_samples(Path(folder))
    print("EGAT 137 kW bulb: mean signed Q11 error (log-ratio, %) per held-out guide-vane angle\n")
    for k in HOLD_OUTS:
        print(diagnose_bulb(samples, k))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
