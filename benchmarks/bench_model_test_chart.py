"""A model test's measured characteristic, digitized as a hill chart: the lowest lines held out, and toward runaway,
against what the model test measured there.

The characteristic: the four-quadrant characteristic of a reversible Francis pump-turbine model (FR300T, "Torrao"), in
the text format of the SIMSEN software: a ``<list>`` of rows ``y N11 Q11 T11`` (relative opening ``a0 / a0max``,
r/min, m^3/s, N*m), ``a0max`` = 38 mm in its header. It is someone else's (github.com/mfranino/TCEditor,
``simsen_yn11q11t11_FR300T.txt``, commit 06bbf8439059cacfece7f5964c3f891761c880c4; sha256 of the file
70a2d65b643b4cac5682f03666b69595c699f271fa469ec7431ad3a4bfb0d2c7) and carries no licence: it is never copied into
this repository. Give its path with ``--characteristic``, or put it in ``../shared/external/``.

The chart a user would digitize from it (:func:`digitized_chart`):

* the 19 measured opening lines, a0 = 2 to 38 mm (the file's 1 mm and closed lines were constructed by its author
  from the 2 and 4 mm lines, its header says: left out), each read at :data:`POINTS_PER_LINE` N11 evenly spaced over
  the chart's frame, :data:`FRAME` times the N11 of best efficiency, where the line's torque is positive;
* the efficiency (eq. 5 of the BP hill-chart paper from T11) at those points where it is at least
  :data:`LOWEST_CONTOUR`, as contour readings;
* without the runaway curve, as hill charts are usually drawn, and with it (each line's T11 = 0 crossing).

Measured (``hold_out_lines`` of ``benchmarks/bench_extrapolation.py``, M11 against the measured T11):

1. below the lowest line, the k = 1, 2, 3 lowest lines held out, trained with ``hillsim train``'s defaults on the
   rest and read back as a run reads them;
2. toward runaway, trained on the whole chart: at the characteristic's own points beyond the frame up to each line's
   runaway, what a run reads against the measured Q11 and T11, by the relative N11 gap beyond the frame's end, and
   whether the members' 5-95 % band covers them; the extension's warnings, or its refusal.

Run (about 20 s on 2 cores)::

    PYTHONPATH=. python benchmarks/bench_model_test_chart.py [--characteristic PATH] [--write-docs]

``--write-docs`` puts the tables into ``docs/guarantee-benchmark.md`` between its markers.
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

FILE_NAME = "simsen_yn11q11t11_FR300T.txt"
#: a0max of the characteristic's header, mm.
OPENING_MAX_MM = 38.0
#: Lines its header says were constructed, not measured (mm).
CONSTRUCTED_MM = (0.0, 1.0)
#: The chart's N11 frame, as fractions of the N11 of best efficiency, and the points read on each line.
FRAME = (0.8, 1.2)
POINTS_PER_LINE = 7
#: The lowest efficiency contour read.
LOWEST_CONTOUR = 0.5
#: Gaps beyond the frame's end (relative N11) that the toward-runaway table bins by.
GAP_BINS = (0.0, 0.1, 0.25, 0.6)
MARKERS = ("<!-- bench_model_test_chart -->", "<!-- end bench_model_test_chart -->")
RHO_G = 1000.0 * 9.81  # the torque's efficiency, eq. (5) of the BP hill-chart paper, as the characteristic states T11


def read_simsen(path) -> np.ndarray:
    """Rows ``(y, N11, Q11, T11)`` of a SIMSEN characteristic's ``<list>`` block (comments ``;``, a header row)."""
    from hillchart.errors import InputError

    rows, inside = [], False
    for number, line in enumerate(Path(path).read_text(encoding="utf-8").splitlines(), start=1):
        text = line.strip()
        if text == "<list>":
            inside = True
        elif text == "</list>":
            break
        elif inside and text and not text.startswith(";"):
            try:
                rows.append([float(v) for v in text.split()])
            except ValueError:
                if rows:  # only the column header may be text
                    raise InputError(f"{path}: line {number} is not four numbers: {text!r}") from None
    data = np.array(rows, float)
    if data.ndim != 2 or data.shape[1] != 4 or len(data) < 10:
        raise InputError(f"{path}: expected a <list> of rows y N11 Q11 T11, got {data.shape}")
    return data


def _lines(data, turbine: bool = True):
    """Per measured opening (mm): the turbine quadrant's points (N11 > 0, Q11 > 0) ordered by N11, or with
    ``turbine=False`` every point of the line over the four quadrants in the file's order."""
    y, n, q, t = data.T
    a = np.round(y * OPENING_MAX_MM, 6)
    out = {}
    for op in np.unique(a):
        if op in CONSTRUCTED_MM:
            continue
        if not turbine:
            out[float(op)] = tuple(v[a == op] for v in (n, q, t))
            continue
        on = (a == op) & (n > 0) & (q > 0)
        order = np.argsort(n[on])
        out[float(op)] = tuple(v[on][order] for v in (n, q, t))
    return out


def best_point(data) -> tuple[float, float, float]:
    """``(N11, Q11, T11)`` of the turbine quadrant's measured point of best efficiency (positive torque)."""
    return max(((n[i], q[i], t[i]) for n, q, t in _lines(data).values() for i in range(n.size) if t[i] > 0),
               key=lambda p: efficiency(*p))


def efficiency(n11, q11, t11):
    """Efficiency from the unit torque, eq. (5) of the BP hill-chart paper: ``T11 omega11 / (rho g Q11)``."""
    return t11 * n11 * np.pi / 30.0 / (RHO_G * q11)


def digitized_chart(data, folder: Path, runaway: bool):
    """Write the chart folder (module docstring); return it, the measured T11 at its flow points and the frame."""
    lines = _lines(data)
    n_best = best_point(data)[0]
    frame = (FRAME[0] * n_best, FRAME[1] * n_best)
    folder.mkdir(parents=True)
    (folder / "chart.toml").write_text(f'name = "FR300T pump-turbine model, digitized from its characteristic"\n'
                                       f'opening_unit = "mm"\nopening_max = {OPENING_MAX_MM}\nq11_unit = "m3/s"\n'
                                       'efficiency_unit = "fraction"\n', encoding="utf-8")
    flow, eff, torque, run = ["opening,n11,q11"], ["efficiency,n11,q11"], [], ["opening,n11,q11"]
    for op, (n, q, t) in lines.items():
        for n11 in np.linspace(*frame, POINTS_PER_LINE):
            q11, t11 = float(np.interp(n11, n, q)), float(np.interp(n11, n, t))
            if t11 <= 0.0:
                continue
            flow.append(f"{op:g},{n11:.6g},{q11:.6g}")
            torque.append(t11)
            if (eta := efficiency(n11, q11, t11)) >= LOWEST_CONTOUR:
                eff.append(f"{eta:.6g},{n11:.6g},{q11:.6g}")
        cross = np.flatnonzero((t[:-1] > 0) & (t[1:] <= 0))
        if cross.size:
            i = int(cross[0])
            f = t[i] / (t[i] - t[i + 1])
            run.append(f"{op:g},{n[i] + f * (n[i + 1] - n[i]):.6g},{q[i] + f * (q[i + 1] - q[i]):.6g}")
    for name, rows in (("flow.csv", flow), ("efficiency.csv", eff)) + ((("runaway.csv", run),) if runaway else ()):
        (folder / name).write_text("\n".join(rows) + "\n", encoding="utf-8")
    return folder, np.array(torque), frame


def toward_runaway(data, folder: Path, runaway: bool) -> dict:
    """Train on the whole chart (defaults, ensemble 10, seed 0), read back, and compare with the characteristic
    beyond the frame up to each line's runaway; the extension's warnings, or its refusal."""
    from hillchart.errors import InputError
    from hillchart.extension.extend import extend_samples
    from hillchart.io.samples import load_chart
    from hillchart.nets.hill_nets import load_nets
    from hillchart.nets.training import train_nets
    from simulate.studies.uncertainty import figure_band

    path, _, frame = digitized_chart(data, folder, runaway)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        chart = load_chart(path)
        try:
            extended = extend_samples(chart)
        except InputError as exc:
            return {"refused": str(exc).replace(str(path), "the chart")}
        nets = train_nets(extended, ensemble=10, seed=0)
    nets = load_nets(nets.save(path / "nets.json"))
    n, a, q, t = [], [], [], []
    for op, (nn, qq, tt) in _lines(data).items():
        beyond = nn > frame[1]
        ends = np.flatnonzero(beyond & (tt <= 0))
        last = ends[0] if ends.size else nn.size - 1  # up to the line's first point at or past runaway
        keep = beyond & (np.arange(nn.size) <= last)
        n += nn[keep].tolist()
        q += qq[keep].tolist()
        t += tt[keep].tolist()
        a += [op] * int(keep.sum())
    n, a, q, t = (np.array(v, float) for v in (n, a, q, t))
    _, m11, origin = extended.select("m11")
    scale = float(np.ptp(m11[origin == "measured"]))
    q_run, m_run = np.asarray(nets.q11(n, a)), np.asarray(nets.m11(n, a))
    members = nets.members()
    q_lo, q_hi = figure_band(np.array([np.asarray(m.q11(n, a)) for m in members]), axis=0)
    m_lo, m_hi = figure_band(np.array([np.asarray(m.m11(n, a)) for m in members]), axis=0)
    gap = n / frame[1] - 1.0
    rows = []
    for lo, hi in zip(GAP_BINS[:-1], GAP_BINS[1:]):
        on = (gap > lo) & (gap <= hi)
        if not on.any():
            continue
        eq, em = q_run[on] / q[on] - 1.0, (m_run[on] - t[on]) / scale
        rows.append({"gap": (lo, hi), "points": int(on.sum()),
                     "q_mean": 100 * float(np.mean(np.abs(eq))), "q_worst": 100 * float(eq[np.argmax(np.abs(eq))]),
                     "m_mean": 100 * float(np.mean(np.abs(em))), "m_worst": 100 * float(em[np.argmax(np.abs(em))]),
                     "q_covered": int(np.sum((q_lo[on] <= q[on]) & (q[on] <= q_hi[on]))),
                     "m_covered": int(np.sum((m_lo[on] <= t[on]) & (t[on] <= m_hi[on])))})
    return {"rows": rows, "m11_scale": scale, "frame": frame,
            "warnings": [str(w.message) for w in caught if "toward runaway" in str(w.message)]}


def runaway_table(result: dict) -> str:
    if "refused" in result:
        return f"refused by `hillsim train`: {result['refused']}"
    out = ["| N11 beyond the frame's end | points | Q11 mean abs err % | Q11 worst % | M11 mean abs err (% of range) | "
           "M11 worst (% of range) | band covers Q11 | covers M11 |", "|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        out.append(f"| {100 * r['gap'][0]:.0f}-{100 * r['gap'][1]:.0f} % | {r['points']} | {r['q_mean']:.1f} | "
                   f"{r['q_worst']:+.1f} | {r['m_mean']:.1f} | {r['m_worst']:+.1f} | {r['q_covered']} of "
                   f"{r['points']} | {r['m_covered']} of {r['points']} |")
    out += [f"\nwarning: {w}" for w in result["warnings"]]
    return "\n".join(out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--characteristic", type=Path, help=f"the SIMSEN file ({FILE_NAME}; default: "
                                                            "../shared/external/ when it is there)")
    parser.add_argument("--write-docs", action="store_true", help="write the tables into docs/guarantee-benchmark.md")
    args = parser.parse_args(argv)
    from tests.external_charts import EXTERNAL_DIR

    source = args.characteristic or EXTERNAL_DIR / FILE_NAME
    if not source.is_file():
        print(f"the characteristic is absent ({source}); give its path with --characteristic")
        return 0
    from hillchart.io.samples import load_chart
    from tests.scripts import load_script

    bench_extrapolation = load_script("bench_extrapolation")  # its held-out comparison and table, shared

    data = read_simsen(source)
    with tempfile.TemporaryDirectory() as tmp:
        folder, torque, frame = digitized_chart(data, Path(tmp) / "chart", runaway=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            chart = load_chart(folder)
            below = [bench_extrapolation.hold_out_lines(chart, k, truth_torque=torque) for k in (1, 2, 3)]
        over = {runaway: toward_runaway(data, Path(tmp) / f"runaway-{runaway}", runaway) for runaway in (False, True)}
    parts = [f"FR300T pump-turbine model: {len(np.unique(chart.flow_opening))} opening lines, "
             f"{chart.flow_n11.size} points over N11 {frame[0]:.1f}-{frame[1]:.1f} r/min; the k lowest lines held out.",
             bench_extrapolation.table(below)]
    parts += [f"k = {r['k']}: {r['evidence']}" for r in below]
    for runaway, result in over.items():
        parts += [f"Toward runaway, the whole chart {'with' if runaway else 'without'} its runaway curve:",
                  runaway_table(result)]
    text = "\n\n".join(parts)
    print(text)
    if args.write_docs:
        from tests.scripts import write_between_markers

        page = REPO / "docs" / "guarantee-benchmark.md"
        write_between_markers(page, MARKERS, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
