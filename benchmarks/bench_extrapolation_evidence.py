"""Below the lowest line, on a real chart: what the inner evidence saw against what was asked.

For each k of ``benchmarks/bench_extrapolation.py`` (the k lowest opening lines of the Sayano-Shushenskaya chart held
out), the extension of the kept lines weighs its hypotheses by its *inner* hold-outs (its own lowest line, then its
two lowest, :func:`hillchart.extension.hypotheses.chart_evidence`). This script prints, per held-out line, the
distance ``d = 1 - a / a_low`` below the lowest kept line and every hypothesis' mean signed Q11 error there (log-ratio,
%), for the inner folds (what the weights saw) and for the outer held-out lines (what was asked), with the weights
and the weighed blend; and how far the lowest kept line, as the hypotheses read it (:class:`LowestLine`), is from its
own digitized points (0 when it passes through them).

No nets are trained (the blend is what a run reads below the lowest line, within 0.1 % on this chart); about 15 s.

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


def _line_rows(label, opening, distance, q11, predictions, blend=None):
    """One row per line: label, opening, distance, points and every hypothesis' mean signed log-ratio error (%)."""
    from hillchart.extension.hypotheses import HYPOTHESES

    rows = []
    for a in np.unique(opening):
        on = opening == a
        errors = [100 * float(np.mean(np.log(predictions[h][0][on] / q11[on]))) for h in HYPOTHESES]
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
    from hillchart.extension.extend import extend_samples
    from hillchart.extension.hypotheses import HYPOTHESES, sub_chart
    from hillchart.extension.turbine_model import fit_turbine_model

    rest, held = reduced_chart(chart, k)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        extended = extend_samples(rest)
    x = extended.extrapolation
    ev, hyp = x.evidence, x.hypotheses
    weights = ev.weights["q11"]
    out = [f"#### k = {k}: lowest kept line {hyp.lowest.opening:g}", "",
           "| held out | line | d | points | " + " | ".join(HYPOTHESES) + " | weighed blend |",
           "|---|---|---|---|" + "---|" * (len(HYPOTHESES) + 1),
           "| weights Q11 | | | | " + " | ".join(f"{weights[h]:.2f}" for h in HYPOTHESES) + " | |"]
    for fold in ev.folds + ev.band_folds:
        blend = sum(weights[h] * fold.predictions[h][0] for h in HYPOTHESES)
        tag = f"inner, {fold.lines} line{'s' if fold.lines > 1 else ''}" + (
            "" if fold in ev.folds else " (band only)")
        out += _line_rows(tag, fold.opening, fold.distance, fold.q11, fold.predictions, blend)
    n, a, q = chart.flow_n11[held], chart.flow_opening[held], chart.flow_q11[held]
    predictions = {h: hyp.predict(h, n, a) for h in HYPOTHESES}
    out += _line_rows("**outer** (asked)", a, 1.0 - a / hyp.lowest.opening, q, predictions, x.values(n, a)[0])
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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
