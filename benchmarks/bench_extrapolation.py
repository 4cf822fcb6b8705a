"""Below the lowest line, on a real chart: hold out its k lowest opening lines, train with hillsim train's defaults on
the rest, and compare what a run reads there with the held-out points.

The real chart is the Sayano-Shushenskaya Francis runner in ``../shared/external/`` (12 opening lines of 3-5 points,
digitized by someone else; never shipped). For k = 1, 2, 3:

* the k lowest opening lines are removed, and the efficiency-contour points below the new lowest line (Q11 below
  that line's Q11 at the same N11), as a chart digitized only down to that line would be;
* the rest is extended and trained exactly as ``hillsim train`` does (ensemble of 10, seed 0), saved and read back
  with :func:`hillchart.nets.hill_nets.load_nets`, so the answer is what a run reads;
* at the held-out points: Q11 against the digitized Q11; M11 against the torque of the whole chart's efficiency
  surface (eq. 5 of the BP hill-chart paper; the held-out lines' own contours are in it); the 5-95 % band of the
  ensemble members (widened as the report widens it, :func:`simulate.studies.uncertainty.figure_band`) and whether
  it covers each point;
* every hypothesis of :mod:`hillchart.extension.hypotheses`, refitted on the kept lines, at the same points (the
  ``line`` hypothesis is the straight-line baseline: Q11 = 0 at a = 0 to the lowest kept line at the same N11).

Run (about 1 minute on 2 cores)::

    PYTHONPATH=. python benchmarks/bench_extrapolation.py [--json out.json] [--chart FOLDER or WORKBOOK.xlsx]

``--chart`` measures another chart folder the same way (a chart of 4 opening lines or more), or a Kaplan combined
hill chart's workbook digitized as the ZZ680 runner's is (a ``.xlsx`` file;
:func:`tests.external_charts.write_kaplan_workbook_chart` makes the folder, with openpyxl).

The tables of the docs page "Guarantee figures" (section "Below the lowest line, on a real chart") are this script's
output.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

HOLD_OUTS = (1, 2, 3)


def reduced_chart(chart, k: int):
    """``chart`` without its ``k`` lowest opening lines and the contour points below the new lowest line; the
    held-out mask of the flow points."""
    from hillchart.extension.hypotheses import sub_chart

    openings = np.unique(chart.flow_opening)
    held = np.isin(chart.flow_opening, openings[:k])
    on = chart.flow_opening == openings[k]
    order = np.argsort(chart.flow_n11[on])
    q_line = np.interp(chart.eff_n11, chart.flow_n11[on][order], chart.flow_q11[on][order])
    keep = chart.eff_q11 >= q_line
    rest = replace(sub_chart(chart, ~held), eff_n11=chart.eff_n11[keep], eff_q11=chart.eff_q11[keep],
                   eff_efficiency=chart.eff_efficiency[keep])
    return rest, held


def chart_torque(chart):
    """M11 (N*m) at the chart's flow points from its efficiency surface (eq. 5)."""
    from hillchart.characteristics import unit_torque_from_efficiency
    from hillchart.extension.extend import fit_efficiency_surface

    surface = fit_efficiency_surface(chart.eff_n11, chart.eff_q11, chart.eff_efficiency)
    return unit_torque_from_efficiency(chart.flow_q11, chart.flow_n11, surface(chart.flow_n11, chart.flow_q11))


def hold_out_lines(chart, k: int, *, seed: int = 0, ensemble: int = 10, truth_torque=None) -> dict:
    """The held-out comparison of one ``k`` (module docstring) as a dict of per-point arrays and summary numbers;
    ``truth_torque``: M11 (N*m) at the chart's flow points where the chart's source measured it (default: from the
    chart's efficiency surface, :func:`chart_torque`)."""
    from hillchart.extension.extend import extend_samples
    from hillchart.nets.hill_nets import load_nets
    from hillchart.nets.training import train_nets
    from simulate.studies.uncertainty import figure_band

    truth_torque = chart_torque(chart) if truth_torque is None else np.asarray(truth_torque, float)
    rest, held = reduced_chart(chart, k)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        extended = extend_samples(rest)
        nets = train_nets(extended, ensemble=ensemble, seed=seed)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "nets.json"
        nets.save(path)
        nets = load_nets(path)
    n, a = chart.flow_n11[held], chart.flow_opening[held]
    q, m = chart.flow_q11[held], truth_torque[held]
    m_scale = float(np.ptp(chart_torque(rest)))
    q_run, m_run = np.asarray(nets.q11(n, a)), np.asarray(nets.m11(n, a))
    members = nets.members()
    q_members = np.array([np.asarray(mb.q11(n, a)) for mb in members])
    m_members = np.array([np.asarray(mb.m11(n, a)) for mb in members])
    q_lo, q_hi = figure_band(q_members, axis=0)
    m_lo, m_hi = figure_band(m_members, axis=0)
    extrapolation = extended.extrapolation
    candidates = {h: extrapolation.hypotheses.predict(h, n, a) for h in extrapolation.hypotheses.names}
    candidates["blend"] = extrapolation.values(n, a)
    rows = {}
    for name, (qq, mm) in {**candidates, "run": (q_run, m_run)}.items():
        eq, em = (qq - q) / q, (mm - m) / m_scale
        rows[name] = {"q11_mean_abs_pct": 100 * float(np.mean(np.abs(eq))),
                      "q11_worst_pct": 100 * float(eq[np.argmax(np.abs(eq))]),
                      "m11_mean_abs_pct_range": 100 * float(np.mean(np.abs(em))),
                      "m11_worst_pct_range": 100 * float(em[np.argmax(np.abs(em))])}
    covered_q = (q_lo <= q) & (q <= q_hi)
    covered_m = (m_lo <= m) & (m <= m_hi)
    return {"k": k, "points": int(held.sum()), "lowest_kept": float(np.unique(rest.flow_opening)[0]),
            "rows": rows, "q11_covered": int(covered_q.sum()), "m11_covered": int(covered_m.sum()),
            "q11_band_median_pct": 100 * float(np.median((q_hi - q_lo) / q_run)),
            # how far the point nearest a band's edge lies inside it (negative: outside), % of Q11 / of the M11 range
            "q11_margin_pct": 100 * float(np.min(np.minimum(q - q_lo, q_hi - q) / q)),
            "m11_margin_pct_range": 100 * float(np.min(np.minimum(m - m_lo, m_hi - m) / m_scale)),
            "weights": extrapolation.evidence.weights, "evidence": extrapolation.summary()}


def sayano_chart(folder):
    from hillchart.io.samples import load_chart
    from tests.external_charts import write_sayano_chart

    return load_chart(write_sayano_chart(Path(folder) / "sayano"))


def table(results: list) -> str:
    names = list(dict.fromkeys(name for r in results for name in r["rows"]))  # a chart of 3 lines has no other form
    lines = ["| k held out | points | lowest kept | candidate | Q11 mean abs err % | Q11 worst % | M11 mean abs err "
             "(% of range) | M11 worst (% of range) |", "|---|---|---|---|---|---|---|---|"]
    for r in results:
        for name in (n for n in names if n in r["rows"]):
            row = r["rows"][name]
            label = {"run": "**what a run reads** (nets + table)", "blend": "weighed blend",
                     "line": "line (straight-line baseline)"}.get(name, name)
            lines.append(f"| {r['k']} | {r['points']} | {r['lowest_kept']:g} | {label} | "
                         f"{row['q11_mean_abs_pct']:.1f} | {row['q11_worst_pct']:+.1f} | "
                         f"{row['m11_mean_abs_pct_range']:.1f} | {row['m11_worst_pct_range']:+.1f} |")
    lines += ["", "| k held out | 5-95 % band covers Q11 | covers M11 | median Q11 band width % |", "|---|---|---|---|"]
    for r in results:
        lines.append(f"| {r['k']} | {r['q11_covered']} of {r['points']} | {r['m11_covered']} of {r['points']} | "
                     f"{r['q11_band_median_pct']:.1f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path, help="also write the results as JSON")
    parser.add_argument("--chart", type=Path, help="measure this chart folder (chart.toml, flow.csv, efficiency.csv), "
                                                   "or a Kaplan chart's .xlsx workbook, instead of the Sayano chart")
    args = parser.parse_args(argv)
    from tests.external_charts import EXTERNAL_DIR, SAYANO_CONTOURS, SAYANO_LINES

    if args.chart is None and not all((EXTERNAL_DIR / name).is_file() for name in (SAYANO_LINES, SAYANO_CONTOURS)):
        print(f"the real chart is absent ({EXTERNAL_DIR}); nothing to measure")
        return 0
    with tempfile.TemporaryDirectory() as folder:
        if args.chart is None:
            chart = sayano_chart(folder)
        else:
            from hillchart.io.samples import load_chart
            from tests.external_charts import write_kaplan_workbook_chart

            path = args.chart
            if path.suffix.lower() == ".xlsx":
                path = write_kaplan_workbook_chart(path, Path(folder) / path.stem)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                chart = load_chart(path)
        results = [hold_out_lines(chart, k) for k in HOLD_OUTS]
    name = "Sayano-Shushenskaya Francis" if args.chart is None else chart.info.name
    print(f"{name}, the k lowest opening lines held out\n")
    print(table(results))
    for r in results:
        print(f"\nk = {r['k']}: {r['evidence']}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
