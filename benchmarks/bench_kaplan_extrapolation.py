"""Below the lowest blade-angle line of an on-cam Kaplan chart: hold out its k lowest lines, train with
``hillsim fccm --simulator-nets``'s defaults on the rest, and compare what a run reads there with the held-out points.

The chart: the Kaplan hill chart of Liszka et al. in ``../shared/external/`` (65 digitized points on 5 blade-angle
lines, 8-38 deg, with the efficiency; someone else's data, never shipped). It has no guide-vane angle: every point
lies on the combinator's cam, and the simulator runs it as two-input nets over the cam position
(:mod:`hillchart.fccm.on_cam`).

For k = 1, 2, 3 (the k lowest lines held out; the closed cam placed from the two lowest lines kept):

* the rest is extended and trained exactly as ``hillsim fccm --simulator-nets`` does (2-8-1, 5 restarts, the point
  nets and 5 members, seed 0), saved and read back, so the answer is what a run reads;
* candidates refitted on the kept lines, at the held-out points: ``line`` (the straight-line baseline: Q11 and
  M11 linear in the cam from the lowest kept line, at the same N11, down to zero at the closed cam, i.e. the
  efficiency held at the lowest line's), ``line, efficiency linear to zero`` (Q11 the same, the efficiency linear
  in the cam down to zero), the ``weighed blend`` of the two efficiencies (the weights the reduced chart's own
  held-out lines give: what the extension samples) and ``quadratic`` (Q11 and the efficiency quadratic in the blade
  angle through the three lowest kept lines at the same N11; with three lines kept or more). Outside a kept line's
  N11 range it is held at its end value;
* toward overspeed, the highest-N11 point of every line held out, the nets trained without them against a straight
  continuation of each line through its two last kept points;
* Q11 relative error, M11 error as % of the chart's M11 range (M11 from the efficiency, eq. (5) of the BP hill-chart
  paper), the members' 5-95 % band and whether it covers each held-out point, and the chart's own evidence below
  its lowest line as ``hillsim fccm`` prints it (:func:`hillchart.fccm.on_cam.on_cam_evidence`).

Run (about 15 s on 2 cores)::

    PYTHONPATH=. python benchmarks/bench_kaplan_extrapolation.py [--write-docs]

``--write-docs`` puts the tables into ``docs/bulb-extrapolation.md`` between its markers.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

HOLD_OUTS = (1, 2, 3)
#: The bounds of the issue, as for the bulb table (benchmarks/bench_bulb_extrapolation.py).
WORST_BOUND = 0.08
COVERAGE_BOUND = 0.80
#: As ``hillsim fccm --simulator-nets`` trains an on-cam chart by default.
HIDDEN, MEMBERS, RESTARTS, SEED = 8, 5, 5, 0
MARKERS = ("<!-- bench_kaplan_extrapolation -->", "<!-- end bench_kaplan_extrapolation -->")


def _read(table: Path) -> dict:
    with (table / "table.csv").open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def _write(folder: Path, source: Path, chart: dict, keep) -> Path:
    folder.mkdir(parents=True)
    (folder / "table.toml").write_text((source / "table.toml").read_text(encoding="utf-8"), encoding="utf-8")
    with (folder / "table.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(list(chart))
        writer.writerows(zip(*(v[keep] for v in chart.values())))
    return folder


def _at_lines(chart: dict, keep, lines, n11):
    """Q11 and the efficiency of each of ``lines`` (blade angles, deg) of the kept chart, interpolated at ``n11``
    (held at a line's ends outside its N11 range): arrays of shape (lines, points)."""
    q, eta = [], []
    for line in lines:
        on = keep & (chart["blade_angle_deg"] == line)
        order = np.argsort(chart["n11_rpm"][on])
        n_line = chart["n11_rpm"][on][order]
        q.append(np.interp(n11, n_line, chart["q11_m3_s"][on][order]))
        eta.append(np.interp(n11, n_line, chart["efficiency"][on][order]))
    return np.array(q), np.array(eta)


def candidates(chart: dict, keep, closed: float, blade, n11, held: float) -> dict:
    """``{name: (q11, efficiency)}`` of the candidates at the held-out (``blade``, ``n11``); ``held``: the weight
    the reduced chart's evidence gives the efficiency held (:func:`hillchart.fccm.on_cam.silent_efficiency`)."""
    from hillchart.fccm.on_cam import silent_efficiency

    lines = np.unique(chart["blade_angle_deg"][keep])
    q, eta = _at_lines(chart, keep, lines[:3], n11)
    t = (blade - closed) / (lines[0] - closed)
    out = {"line": (q[0] * t, eta[0]), "line, efficiency linear to zero": (q[0] * t, eta[0] * t),
           "weighed blend": (q[0] * t, silent_efficiency(eta[0], t, held))}
    if lines.size >= 3:
        fit = [np.array([np.polyval(np.polyfit(lines[:3], y[:, i], 2), blade[i]) for i in range(blade.size)])
               for y in (q, eta)]
        out["quadratic"] = tuple(fit)
    return out


def measure(source: Path, folder: Path) -> dict:
    from hillchart.characteristics import unit_torque_from_efficiency
    from hillchart.extension.band import continuation
    from hillchart.fccm.on_cam import on_cam_unit_samples, train_on_cam_nets
    from hillchart.fccm.table import load_test_table
    from hillchart.nets.hill_nets import load_nets

    chart = _read(source)
    blade, n11, q11 = chart["blade_angle_deg"], chart["n11_rpm"], chart["q11_m3_s"]
    m11 = np.asarray(unit_torque_from_efficiency(q11, n11, chart["efficiency"]), float)  # eq. (5) of paper 004
    scale = float(np.ptp(m11))
    lines = np.unique(blade)
    folds = []
    for k in HOLD_OUTS:
        held = blade < lines[k]
        table = load_test_table(_write(folder / f"k{k}", source, chart, ~held))
        samples, _, closed = on_cam_unit_samples(table, seed=SEED)
        nets, _ = train_on_cam_nets(samples, hidden=HIDDEN, restarts=RESTARTS, seed=SEED, members=MEMBERS)
        nets = load_nets(nets.save(folder / f"k{k}" / "nets.json"))
        b, n, q, m = blade[held], n11[held], q11[held], m11[held]
        c = b - closed
        rows = {name: (qq, np.asarray(unit_torque_from_efficiency(qq, n, ee), float))
                for name, (qq, ee) in candidates(chart, ~held, closed, b, n,
                                                 samples["evidence"].efficiency_held).items()}
        rows["run"] = (nets.q11(n, c), nets.m11(n, c))
        errors = {name: {"q": qq / q - 1.0, "m": (mm - m) / scale} for name, (qq, mm) in rows.items()}
        qs = np.array([x.q11(n, c) for x in nets.members()])
        ms = np.array([x.m11(n, c) for x in nets.members()])
        q_lo, q_hi = np.percentile(qs, [5.0, 95.0], axis=0)
        m_lo, m_hi = np.percentile(ms, [5.0, 95.0], axis=0)
        folds.append({"k": k, "points": int(held.sum()), "lowest_kept": float(lines[k]), "closed": closed,
                      "errors": errors, "q_covered": int(np.sum((q >= q_lo) & (q <= q_hi))),
                      "m_covered": int(np.sum((m >= m_lo) & (m <= m_hi))),
                      "q_band_median": float(np.median((q_hi - q_lo) / q)),
                      "summary": samples["evidence"].summary()})
    # toward overspeed: the highest-N11 point of every line held out, the rest trained on, and the nets (what a run
    # reads) against a straight continuation of each line through its two last kept points
    ends = np.array([np.flatnonzero(blade == line)[np.argmax(n11[blade == line])] for line in lines])
    held = np.zeros(blade.size, bool)
    held[ends] = True
    table = load_test_table(_write(folder / "overspeed", source, chart, ~held))
    samples, _, closed = on_cam_unit_samples(table, seed=SEED)
    nets, _ = train_on_cam_nets(samples, hidden=HIDDEN, restarts=RESTARTS, seed=SEED, members=MEMBERS)
    nets = load_nets(nets.save(folder / "overspeed" / "nets.json"))
    b, n, q, m = blade[held], n11[held], q11[held], m11[held]
    c = b - closed
    straight = {"q": [], "m": []}
    for line, n_end in zip(b, n):
        on = ~held & (blade == line)
        straight["q"].append(continuation(n11[on], q11[on], n_end))
        straight["m"].append(continuation(n11[on], m11[on], n_end))
    members_q = np.array([x.q11(n, c) for x in nets.members()])
    members_m = np.array([x.m11(n, c) for x in nets.members()])
    q_lo, q_hi = np.percentile(members_q, [5.0, 95.0], axis=0)
    m_lo, m_hi = np.percentile(members_m, [5.0, 95.0], axis=0)
    overspeed = {"points": int(held.sum()), "n11": [float(n.min()), float(n.max())],
                 "errors": {"straight continuation": {"q": np.array(straight["q"]) / q - 1.0,
                                                      "m": (np.array(straight["m"]) - m) / scale},
                            "run": {"q": nets.q11(n, c) / q - 1.0, "m": (nets.m11(n, c) - m) / scale}},
                 "q_covered": int(np.sum((q >= q_lo) & (q <= q_hi))),
                 "m_covered": int(np.sum((m >= m_lo) & (m <= m_hi)))}
    return {"folds": folds, "m11_range": scale, "points": int(blade.size), "lines": lines.tolist(),
            "overspeed": overspeed}


LABELS = {"line": "line (straight-line baseline)", "weighed blend": "weighed blend (what the extension samples)",
          "run": "**what a run reads** (nets)"}


def tables(result: dict) -> str:
    out = [f"Lines {', '.join(f'{v:g}' for v in result['lines'])} deg ({result['points']} points); M11 range "
           f"{result['m11_range']:.4g} (unit torque, N*m).", "",
           "| k held out | points | lowest kept (deg) | closed cam (deg) | candidate | Q11 mean abs err % | "
           "Q11 worst % | M11 mean abs err (% of range) | M11 worst (% of range) |",
           "|---|---|---|---|---|---|---|---|---|"]
    for f in result["folds"]:
        for name, e in f["errors"].items():
            out.append(f"| {f['k']} | {f['points']} | {f['lowest_kept']:g} | {f['closed']:.2f} | "
                       f"{LABELS.get(name, name)} | {100 * np.mean(np.abs(e['q'])):.1f} | "
                       f"{100 * e['q'][np.argmax(np.abs(e['q']))]:+.1f} | {100 * np.mean(np.abs(e['m'])):.1f} | "
                       f"{100 * e['m'][np.argmax(np.abs(e['m']))]:+.1f} |")
    out += ["", "| k held out | 5-95 % band covers Q11 | covers M11 | median Q11 band width % | bounds Q11: mean <= "
                "line's, worst <= 8 % (k = 1, 2), covered >= 80 % | bounds M11 (% of range): the same |",
            "|---|---|---|---|---|---|"]
    for f in result["folds"]:
        verdicts = []
        for t, covered in (("q", f["q_covered"]), ("m", f["m_covered"])):
            run, line = f["errors"]["run"][t], f["errors"]["line"][t]
            marks = [np.mean(np.abs(run)) <= np.mean(np.abs(line)),
                     np.max(np.abs(run)) <= WORST_BOUND if f["k"] <= 2 else None,
                     covered >= COVERAGE_BOUND * f["points"]]
            verdicts.append(" / ".join("-" if v is None else ("yes" if v else "**no**") for v in marks))
        out.append(f"| {f['k']} | {f['q_covered']} of {f['points']} | {f['m_covered']} of {f['points']} | "
                   f"{100 * f['q_band_median']:.1f} | {verdicts[0]} | {verdicts[1]} |")
    o = result["overspeed"]
    out += ["", f"Toward overspeed ({o['points']} points, the highest N11 of each line, {o['n11'][0]:.0f}-"
                f"{o['n11'][1]:.0f} r/min; the members' 5-95 % band covers {o['q_covered']} of Q11 and "
                f"{o['m_covered']} of M11):", "",
            "| candidate | Q11 mean abs err % | Q11 worst % | M11 mean abs err (% of range) | M11 worst (% of range) |",
            "|---|---|---|---|---|"]
    for name, e in o["errors"].items():
        out.append(f"| {LABELS.get(name, name)} | {100 * np.mean(np.abs(e['q'])):.1f} | "
                   f"{100 * e['q'][np.argmax(np.abs(e['q']))]:+.1f} | {100 * np.mean(np.abs(e['m'])):.1f} | "
                   f"{100 * e['m'][np.argmax(np.abs(e['m']))]:+.1f} |")
    out += ["", "What `hillsim fccm --simulator-nets` prints of each reduced chart's own evidence:", ""]
    out += [f"* k = {f['k']}: {f['summary']}" for f in result["folds"]]
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write-docs", action="store_true", help="write the tables into docs/bulb-extrapolation.md")
    args = parser.parse_args(argv)
    from tests.external_charts import EXTERNAL_DIR
    from tests.fccm_external import KAPLAN_LISZKA, write_kaplan_table

    if not (EXTERNAL_DIR / KAPLAN_LISZKA).is_file():
        print(f"the Kaplan chart is absent ({EXTERNAL_DIR / KAPLAN_LISZKA}): nothing to measure")
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        text = tables(measure(write_kaplan_table(folder / "kaplan"), folder))
    print(text)
    if args.write_docs:
        from tests.scripts import write_between_markers

        page = REPO / "docs" / "bulb-extrapolation.md"
        write_between_markers(page, MARKERS, text.removesuffix(chr(10)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
