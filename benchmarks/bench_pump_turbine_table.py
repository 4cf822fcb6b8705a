"""A real pump-turbine's measured complete characteristics through the four-quadrant nets: opening lines held out.

The characteristic is the FR300T ("Torrao") reversible Francis pump-turbine model's, the SIMSEN file that
``benchmarks/bench_model_test_chart.py`` digitizes as a hill chart (someone else's, no licence, never copied into
this repository; its source and checksum are in that script): 19 measured opening lines, 2 to 38 mm, each over all
four quadrants (pump, pump brake, reverse pump, turbine and turbine brake), 1,447 points. The file's 1 mm and closed
lines were constructed by its author from the 2 and 4 mm lines (its header says so) and are left out.

What a user does with it: write it as a complete-characteristics folder (``table.toml``, ``table.csv``: opening,
N11, Q11, M11; the rated point the turbine-mode point of best efficiency), read it with
:func:`hillchart.four_quadrant.table.load_complete_characteristics`, and train the Suter nets as the shipped ones are
trained (:data:`hillchart.four_quadrant.nets.SHIPPED`, the improved transform
:data:`~hillchart.four_quadrant.nets.PUMP_TURBINE_CONSTANTS`). Measured, three ways of holding lines out:

* **every other line** (trained on 2, 6, ..., 38 mm; measured at 4, 8, ..., 36 mm): how the nets interpolate between
  measured lines, a table of half the density;
* **the lowest line**, then **the two lowest** (trained on the rest): how they extrapolate toward the closed vanes.

At the held-out lines, every other line held out, by zone (:func:`hillchart.four_quadrant.suter.zone`): the curves
WH and WM against the measured (RMS and worst, % of each curve's range over the table), and how many of the measured
curves' values the ensemble's 5-95 % band covers: the members' training spread (``calibrate=False``) and the band
calibrated on the kept lines' own halves (the default, :func:`hillchart.four_quadrant.nets.band_factor`).

In the turbine zone, every way, what a run reads: Q11 and M11 at unit head at each held-out point's measured N11 and
opening (:class:`simulate.components.turbine.four_quadrant.SuterCharacteristics` from the nets, on the normal
operating curve; below the nets' smallest opening on the closed-vane model), up to each line's runaway, within the
speeds a hill chart of this machine shows (``bench_model_test_chart.FRAME`` times the N11 of best efficiency, as
that script draws it) and beyond them by the N11 gap; beyond them also the torque of hill-chart nets
trained on that chart with every line (``hillsim train``'s defaults).

Run (about a minute on 2 cores)::

    PYTHONPATH=. python benchmarks/bench_pump_turbine_table.py [--characteristic PATH] [--write-docs]

``--write-docs`` puts the tables into ``docs/pump-turbines.md`` between its markers.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

MARKERS = ("<!-- bench_pump_turbine_table -->", "<!-- end bench_pump_turbine_table -->")
#: N11 gaps beyond the frame's end, as ``bench_model_test_chart`` bins them.
GAP_BINS = (0.0, 0.1, 0.25, 0.6)


def write_table(data, folder: Path, openings_mm) -> tuple[Path, dict]:
    """The complete-characteristics folder of the characteristic's measured lines; its rated point."""
    from bench_model_test_chart import OPENING_MAX_MM, _lines, best_point

    lines = _lines(data, turbine=False)
    rated = dict(zip(("n11_rpm", "q11_m3_s", "m11_nm"), (float(v) for v in best_point(data))))
    folder.mkdir(parents=True)
    (folder / "table.toml").write_text(
        f'name = "FR300T pump-turbine model (measured)"\nopening_unit = "mm"\nopening_max = {OPENING_MAX_MM}\n'
        f'q11_unit = "m3/s"\nrated_n11_rpm = {rated["n11_rpm"]!r}\nrated_q11 = {rated["q11_m3_s"]!r}\n'
        f'rated_m11_nm = {rated["m11_nm"]!r}\n', encoding="utf-8")
    rows = ["opening,n11,q11,m11"] + [f"{a:g},{nn:.10g},{qq:.10g},{tt:.10g}" for a in openings_mm
                                      for nn, qq, tt in zip(*lines[a])]
    (folder / "table.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    return folder, rated


def train(table, train_mm, calibrate: bool = False):
    """Suter nets of the lines ``train_mm`` of ``table``, trained as the shipped ones are, the band calibrated on
    those lines' own halves or not (``calibrate``; the point nets are the same)."""
    from hillchart.four_quadrant.nets import PUMP_TURBINE_CONSTANTS, SHIPPED, train_suter_nets

    samples = table.suter(PUMP_TURBINE_CONSTANTS)
    on = np.isin(table.opening, train_mm)
    return train_suter_nets({key: value[on] for key, value in samples.items()}, constants=PUMP_TURBINE_CONSTANTS,
                            calibrate=calibrate, **SHIPPED)


def curves_held_out(table, nets, test, calibrated=None) -> list[dict]:
    """The curves and the band at the points ``test`` (a mask), by zone and in all; with ``calibrated`` (the same
    nets with the band calibrated) its band's coverage too."""
    from hillchart.four_quadrant.nets import PUMP_TURBINE_CONSTANTS
    from hillchart.four_quadrant.suter import zone

    samples = table.suter(PUMP_TURBINE_CONSTANTS)
    rel = table.relative()
    x, y = samples["x"][test], samples["opening"][test]
    wh, wm = nets.curves(x, y)
    band = nets.band(x, y)
    zones = zone(rel["speed"][test], rel["flow"][test], rel["torque"][test])
    spans = {key: float(np.ptp(samples[key])) for key in ("wh", "wm")}
    errors = {"wh": (wh - samples["wh"][test]) / spans["wh"], "wm": (wm - samples["wm"][test]) / spans["wm"]}
    covered = {key: (band[key][0] <= samples[key][test]) & (samples[key][test] <= band[key][1]) for key in band}
    if calibrated is not None:
        wide = calibrated.band(x, y)
        covered.update({f"{key}_calibrated": (wide[key][0] <= samples[key][test]) & (samples[key][test] <= wide[key][1])
                        for key in wide})
    rows = []
    for name in [*dict.fromkeys(zones.tolist()), "all"]:
        on = np.ones(zones.size, bool) if name == "all" else zones == name
        row = {"zone": name, "points": int(on.sum())}
        for key, e in errors.items():
            row[key] = _rms_worst(100 * e[on])
        row["covered"] = {key: int(np.sum(c[on])) for key, c in covered.items()}
        rows.append(row)
    return rows


def _rms_worst(e) -> tuple[float, float]:
    e = np.asarray(e, float)
    e = e[np.isfinite(e)]
    return (float(np.sqrt(np.mean(e ** 2))), float(e[np.argmax(np.abs(e))])) if e.size else (np.nan, np.nan)


def _mean_worst(e) -> tuple[float, float]:
    e = np.asarray(e, float)
    e = e[np.isfinite(e)]
    return (float(np.mean(np.abs(e))), float(e[np.argmax(np.abs(e))])) if e.size else (np.nan, np.nan)


def turbine_points(table, test, frame) -> np.ndarray:
    """Indices of the ``test`` lines' points of positive flow and torque from the frame's start on: up to each
    line's runaway, on its normal operating curve (past runaway a pump-turbine's line folds back through the S-zone, and
    points there share their N11 with the normal operating curve's)."""
    n, q, m, a = table.n11, table.q11, table.m11, table.opening
    return np.flatnonzero(np.isin(a, np.unique(a[test])) & (q > 0) & (m > 0) & (n >= frame[0]))


def what_a_run_reads(table, nets, test, frame, label: str, hill=None) -> list[dict]:
    """Q11 and M11 at unit head as a run reads them at the ``test`` lines' turbine-zone points (module docstring),
    within the frame and by the N11 gap beyond it; with ``hill`` (hill-chart nets) their M11 too."""
    from simulate.components.turbine.four_quadrant import SuterCharacteristics

    run = SuterCharacteristics.from_nets(nets, rated=table.rated, opening_max=table.opening_max, name=label)
    at = turbine_points(table, test, frame)
    n, a, q, m = table.n11[at], table.opening[at], table.q11[at], table.m11[at]
    q_run, m_run = np.asarray(run.q11(n, a), float), np.asarray(run.m11(n, a), float)
    m_hill = None if hill is None else np.asarray(hill.m11(n, a), float)
    gap = n / frame[1] - 1.0
    rows = []
    for lo, hi in ((None, 0.0),) + tuple(zip(GAP_BINS[:-1], GAP_BINS[1:])):
        on = gap <= 0.0 if lo is None else (gap > lo) & (gap <= hi)
        if not on.any():
            continue
        row = {"label": label, "gap": (lo, hi), "points": int(on.sum()),
               "q11": _mean_worst(100 * (q_run[on] / q[on] - 1.0)),
               "m11": _mean_worst(100 * (m_run[on] - m[on]) / table.rated["m11_nm"]),
               "no_point": int(np.sum(~np.isfinite(q_run[on])))}
        if m_hill is not None and lo is not None:
            row["hill"] = _mean_worst(100 * (m_hill[on] - m[on]) / table.rated["m11_nm"])
        rows.append(row)
    return rows


def hill_chart_nets(data, folder: Path):
    """Hill-chart nets of the chart a user would digitize from the characteristic, every line, ``hillsim train``'s
    defaults (no runaway curve, as hill charts are usually drawn); read back as a run reads them; and the frame."""
    from bench_model_test_chart import digitized_chart

    from hillchart.extension.extend import extend_samples
    from hillchart.io.samples import load_chart
    from hillchart.nets.hill_nets import load_nets
    from hillchart.nets.training import train_nets

    path, _, frame = digitized_chart(data, folder, runaway=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nets = train_nets(extend_samples(load_chart(path)), ensemble=10, seed=0)
    return load_nets(nets.save(path / "nets.json")), frame


def tables(curve_rows: list, run_rows: list, rated: dict, factor: dict) -> str:
    out = [f"Rated point (turbine mode, best efficiency): N11 = {rated['n11_rpm']:.2f} r/min, Q11 = "
           f"{rated['q11_m3_s']:.4f} m^3/s, M11 = {rated['m11_nm']:.1f} N*m.", "",
           "Every other line held out, all four quadrants (the band calibrated on the kept lines' own halves: the "
           f"members moved {factor['wh']:.1f} (WH) and {factor['wm']:.1f} (WM) times as far from the point nets):", "",
           "| zone | points | WH RMS / worst (% of range) | WM RMS / worst (% of range) | 5-95 % band covers WH / WM | "
           "calibrated band covers WH / WM |", "|---|---|---|---|---|---|"]
    for row in curve_rows:
        cells = [f"{row[k][0]:.2f} / {row[k][1]:+.2f}" for k in ("wh", "wm")]
        zone = "**all**" if row["zone"] == "all" else row["zone"]
        out.append(f"| {zone} | {row['points']} | " + " | ".join(cells)
                   + f" | {row['covered']['wh']} / {row['covered']['wm']} of {row['points']} | "
                   f"{row['covered']['wh_calibrated']} / {row['covered']['wm_calibrated']} of {row['points']} |")
    out += ["", "What a run reads in the turbine zone at the held-out lines' measured N11, up to each line's runaway "
            "on its normal operating curve (unit head; Q11 error % of Q11, M11 error % of the rated torque; the "
            "hill-chart nets trained on every line):", "",
            "| held out | N11 | points | Q11 mean / worst % | M11 mean / worst (% of rated) | hill-chart nets' M11 "
            "mean / worst (% of rated) |", "|---|---|---|---|---|---|"]
    for row in run_rows:
        lo, hi = row["gap"]
        where = "inside the frame" if lo is None else f"{100 * lo:.0f}-{100 * hi:.0f} % beyond"
        hill = f"{row['hill'][0]:.1f} / {row['hill'][1]:+.1f}" if "hill" in row else "-"
        missing = f" ({row['no_point']} without a point)" if row["no_point"] else ""
        out.append(f"| {row['label']} | {where} | {row['points']}{missing} | {row['q11'][0]:.1f} / "
                   f"{row['q11'][1]:+.1f} | {row['m11'][0]:.1f} / {row['m11'][1]:+.1f} | {hill} |")
    return "\n".join(out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--characteristic", type=Path, help="the SIMSEN file (default: ../shared/external/ when it "
                                                            "is there)")
    parser.add_argument("--write-docs", action="store_true", help="write the tables into docs/pump-turbines.md")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_model_test_chart import FILE_NAME, _lines, read_simsen

    from hillchart.four_quadrant.table import load_complete_characteristics
    from tests.external_charts import EXTERNAL_DIR

    source = args.characteristic or EXTERNAL_DIR / FILE_NAME
    if not source.is_file():
        print(f"the characteristic is absent ({source}); give its path with --characteristic")
        return 0
    data = read_simsen(source)
    openings = sorted(_lines(data, turbine=False))
    with tempfile.TemporaryDirectory() as tmp:
        folder, rated = write_table(data, Path(tmp) / "table", openings)
        table = load_complete_characteristics(folder)
        hill, frame = hill_chart_nets(data, Path(tmp) / "chart")
        ways = {"every other line": openings[::2], "the lowest line": openings[1:],
                "the two lowest lines": openings[2:]}
        curve_rows, run_rows = [], []
        for label, kept in ways.items():
            nets = train(table, kept)
            test = ~np.isin(table.opening, kept)
            if label == "every other line":
                calibrated = train(table, kept, calibrate=True)
                factor = calibrated.training["band"]
                curve_rows = curves_held_out(table, nets, test, calibrated)
            run_rows += what_a_run_reads(table, nets, test, frame, label,
                                         hill if label == "every other line" else None)
    text = (f"FR300T pump-turbine model: {len(openings)} measured opening lines ({openings[0]:g}-{openings[-1]:g} mm), "
            f"{table.opening.size} points over the four quadrants; the hill chart's frame N11 {frame[0]:.1f}-"
            f"{frame[1]:.1f} r/min.\n\n" + tables(curve_rows, run_rows, rated, factor))
    print(text)
    if args.write_docs:
        from tests.scripts import write_between_markers

        write_between_markers(REPO / "docs" / "pump-turbines.md", MARKERS, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
