"""``hillsim report plant.toml --out DIR [--closure DIR] [--sweep DIR]``: a self-contained regulating-guarantee
report (one HTML file) for the plant's load cases.

Runs the plant's scenario for every ``[[load_cases]]`` entry (or the plant's own scenario) exactly as
``hillsim run`` does and writes, in DIR: ``report.html`` (everything embedded), ``report.json`` (every number the page
shows; each number in the page carries its ``report.json`` key in ``data-key``), ``cases/<n>/timeseries.csv`` and
``cases/<n>/summary.json`` (the ``hillsim run`` files of each case), ``cases/<n>/member_<k>_timeseries.csv`` (the
ensemble member whose run decided a banded figure, :func:`simulate.studies.figure_origin.figure_origins`), and the
figures.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import sys
from pathlib import Path

import numpy as np

from hillchart.errors import HillsimError, InputError
from hillsim.report import Report, Value

#: Names under which the simulator's result may carry the head envelope along the penstock (core branch).

def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "report", help="regulating-guarantee report (self-contained HTML) for the plant's load cases",
        description="Run the plant's scenario for each [[load_cases]] entry (or the plant's scenario) and write a "
                    "self-contained report.html with the plant data sheet, the [limits] with PASS/FAIL per case, "
                    "transients, the head envelope (when the simulator provides it), the hill chart with the "
                    "operating range, what decided each figure (the run, operating point and chart region of its "
                    "conservative end, and the held-out evidence there), extrapolation warnings, version, date and "
                    "input hashes. Exit status: 0 when no limit FAILs (every limit PASS or not judged, or no "
                    "[limits]); 3 when a limit FAILs in some load case (the report is written all the same); 2 on "
                    "bad input.")
    parser.add_argument("plant", type=Path, help="plant TOML file (optional [limits] and [[load_cases]])")
    parser.add_argument("--out", type=Path, required=True, help="output directory (created if missing)")
    parser.add_argument("--closure", type=Path, default=None, metavar="DIR",
                        help="include the hillsim optimize-closure results in DIR (closure.json, pareto.png)")
    parser.add_argument("--sweep", type=Path, default=None, metavar="DIR",
                        help="include the hillsim sweep results in DIR (sweep.json, sweep.png)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a plant-file key (as in hillsim run)")
    parser.set_defaults(func=report_command)


class Verdict(Value):
    """A PASS / FAIL / n/a cell (coloured)."""

    def cell(self) -> str:
        colour = {"PASS": "#1a7f37", "FAIL": "#cf222e"}.get(self.value, "#777")
        key = f" data-key='{self.key}'" if self.key else ""
        return f"<td style='color:#fff;background:{colour};font-weight:600;text-align:center'{key}>{self.value}</td>"


def read_envelope(result) -> dict | None:
    """The head envelope of a run as ``{position_m, max_head_m, min_head_m[, min_pressure_head_m]}`` lists (from
    :func:`simulate.results.envelope.envelope_table`), or None when the run has no envelope (a lumped or rigid
    penstock)."""
    if getattr(result, "envelope_max_m", None) is None:
        return None
    from simulate.results.envelope import envelope_table

    table = envelope_table(result)
    out = {"position_m": [float(v) for v in table["x_m"]], "max_head_m": [float(v) for v in table["head_max_m"]],
           "min_head_m": [float(v) for v in table["head_min_m"]]}
    if "pressure_head_min_m" in table:
        out["min_pressure_head_m"] = [float(v) for v in table["pressure_head_min_m"]]
    return out


def _hash(path: Path) -> str:
    from simulate.studies.cases import file_sha256
    return file_sha256(path)


def plant_sheet(plant, chars_path: Path | None, chars) -> dict:
    t, p, g, gov, sc = plant.turbine, plant.penstock, plant.generator, plant.governor, plant.scenario
    if sc.kind == "closure-law":
        law = {"kind": "prescribed closure (no governor)", "closing_time_s": sc.closing_time_s,
               "break_opening": sc.break_opening, "break_time_s": sc.break_time_s}
    else:
        law = {"kind": "governor (PID) with servo rate limits", "closing_time_s": gov.closing_time_s,
               "opening_time_s": gov.opening_time_s}
    from simulate.components.turbine.kinds import kind_of

    source = {"kind": "nets.json" if chars_path is not None else kind_of(t.characteristics).label,
              "path": t.characteristics}
    if chars_path is not None:
        source["sha256"] = _hash(chars_path)
        from hillchart.nets.hill_nets import read_nets_json

        try:
            nets_doc = read_nets_json(chars_path)
            source["format"] = f"{nets_doc.get('format')} version {nets_doc.get('version')}"
        except (OSError, InputError):
            pass  # the turbine's kind has read and validated the same file just before
        training = getattr(chars, "training", None) or {}
        source["training"] = {k: v for k, v in training.items() if isinstance(v, (str, int, float, bool))}
        from simulate.components.turbine.step_up import step_up_of

        step_up = step_up_of(chars)
        if step_up is not None:  # the model chart converted to the prototype (IEC 60193): what was assumed
            source["step_up"] = step_up
        flow = getattr(chars, "flow", None)
        if flow is not None:
            source["n11_range_rpm"] = [float(flow.x_min[0]), float(flow.x_max[0])]
            source["opening_range"] = [float(flow.x_min[1]), float(flow.x_max[1])]
    return {
        "turbine": {"rated_head_m": t.rated_head_m, "rated_flow_m3_s": t.rated_flow_m3_s,
                    "rated_speed_rpm": t.rated_speed_rpm, "rated_power_mw": t.rated_power_mw,
                    "runner_diameter_m": t.runner_diameter_m, "opening_max": t.opening_max,
                    "rated_efficiency": t.rated_efficiency},
        "penstock": {"model": p.model, "static_head_m": p.static_head_m, "length_m": p.length_m,
                     "reaches": p.reaches, "water_time_s": p.water_time_s(t.rated_flow_m3_s, t.rated_head_m),
                     "two_l_over_a_s": 2.0 * p.travel_time_s, "time_step_s": plant.time_step_s,
                     "segments": [{"length_m": s.length_m, "diameter_m": s.diameter_m,
                                   "wave_speed_m_s": s.wave_speed_m_s, "darcy_friction": s.darcy_friction}
                                  for s in p.segments]},
        "generator": {"inertia_time_s": g.inertia_time_s, "self_regulation": g.self_regulation},
        "governor": {"kp": gov.kp, "ki": gov.ki, "kd": gov.kd, "derivative_filter_s": gov.derivative_filter_s,
                     "permanent_droop": gov.permanent_droop, "servo_time_s": gov.servo_time_s,
                     "closing_time_s": gov.closing_time_s, "opening_time_s": gov.opening_time_s},
        "scenario": {"kind": sc.kind, "t_end_s": sc.t_end_s, "event_time_s": sc.event_time_s},
        "closure_law": law,
        "characteristics": source,
    }


def plot_transient(result, case, plant, limits, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = result.time_s
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(9, 7.5))
    panels = ((result.speed_rpm, "speed (r/min)"), (result.head_m, "head at turbine (m)"),
              (result.opening, "guide-vane stroke"))
    for ax, (values, label) in zip(axes, panels):
        ax.plot(t, values, lw=1.2)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    n0, h0 = result.speed_rpm[0], result.head_m[0]
    t_end = float(t[-1]) if t.size else 1.0

    def note(ax, x, y, text, marker, below):
        right = x > 0.6 * t_end  # text to the left of late points, so it stays inside the axes
        ax.plot(x, y, marker)
        ax.annotate(text, (x, y), xytext=(-8 if right else 8, -14 if below else 4), textcoords="offset points",
                    fontsize=8, ha="right" if right else "left")

    shares = figure_shares(case.extrapolation)

    def outside(figure):  # the figure's extrapolation share, beside it
        return "" if shares[figure] is None else f"; {shares[figure]:.0%} of the run to it outside the chart"

    i = int(np.argmax(result.speed_rpm))
    note(axes[0], t[i], result.speed_rpm[i],
         f"max {result.speed_rpm[i]:.1f} r/min (+{100 * case.max_speed_rise:.1f} %) at {t[i]:.2f} s"
         + outside("max_speed_rise"), "rv", True)
    j, k = int(np.argmax(result.head_m)), int(np.argmin(result.head_m))
    note(axes[1], t[j], result.head_m[j],
         f"max {result.head_m[j]:.1f} m (+{100 * case.max_head_rise:.1f} %) at {t[j]:.2f} s"
         + outside("max_head_rise"), "rv", True)
    note(axes[1], t[k], result.head_m[k], f"min {result.head_m[k]:.1f} m at {t[k]:.2f} s" + outside("min_head_drop"),
         "b^", False)
    if limits is not None and limits.max_speed_rise is not None:
        axes[0].axhline(n0 * (1 + limits.max_speed_rise), color="tab:red", ls="--", lw=1,
                        label=f"limit +{100 * limits.max_speed_rise:g} %")
        axes[0].legend(fontsize=8, loc="upper right")
    if limits is not None and (limits.max_head_m is not None or limits.max_head_rise is not None):
        level = min(v for v in (limits.max_head_m, None if limits.max_head_rise is None
                                else h0 * (1 + limits.max_head_rise)) if v is not None)
        axes[1].axhline(level, color="tab:red", ls="--", lw=1, label=f"limit {level:.1f} m")
        axes[1].legend(fontsize=8, loc="upper right")
    events = plant.scenario.events()
    shut = np.nonzero((t > events[0][0]) & (result.opening <= 1e-6))[0] if events else np.array([], int)
    if shut.size:
        events = events + [(float(t[shut[0]]), "vanes shut")]
    for ax in axes:
        for time_s, name in events:
            ax.axvline(time_s, color="0.4", lw=0.8, ls=":")
    for time_s, name in events:
        axes[0].annotate(name, (time_s, axes[0].get_ylim()[1]), xytext=(3, -10), textcoords="offset points",
                         fontsize=8, color="0.3")
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_envelope(envelopes, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.5))
    for name, env in envelopes:
        line, = ax.plot(env["position_m"], env["max_head_m"], label=f"{name}: max head")
        ax.plot(env["position_m"], env["min_head_m"], "--", color=line.get_color(), label=f"{name}: min head")
    ax.set_xlabel("distance from the reservoir (m)")
    ax.set_ylabel("piezometric head (m)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


#: The guarantee figure a limit judges (its extrapolation share is printed beside the verdict).
LIMIT_FIGURES = {"max_speed_rise": "max_speed_rise", "max_head_rise": "max_head_rise", "max_head_m": "max_head_rise"}


def figure_shares(record) -> dict:
    """``{figure: share}`` of the guarantee figures: the share of the run up to each figure spent outside the
    digitized chart (outside the nets' training range when the digitized region is unknown), None where the run's
    extrapolation record does not have it (:func:`simulate.results.result.extrapolation_share`)."""
    from simulate.results.result import GUARANTEE_FIGURES, extrapolation_share

    out = {}
    for figure, *_ in GUARANTEE_FIGURES:
        share = extrapolation_share(record, figure)
        out[figure] = None if share is None else share[1]
    return out


def _finite(value):
    """``value``, None for NaN (a figure the run does not have, e.g. no flow reversal)."""
    return None if value is None or not math.isfinite(value) else value


def _case_json(case, lc, verdicts, folder: str) -> dict:
    from simulate.results.reversal import REVERSAL_FIGURES
    from simulate.studies.batch import extrapolation_kinds

    return {"name": lc.name, "overrides": lc.overrides, "status": case.status, "error": case.error,
            "max_speed_rise": case.max_speed_rise, "max_speed_rpm": case.max_speed_rpm,
            "t_max_speed_s": case.t_max_speed_s, "max_head_m": case.max_head_m, "max_head_rise": case.max_head_rise,
            "t_max_head_s": case.t_max_head_s, "min_head_m": case.min_head_m,
            "min_pressure_head_m": None if math.isnan(case.min_pressure_head_m) else case.min_pressure_head_m,
            "initial_power_mw": case.initial_power_mw, "initial_opening": case.initial_opening,
            "max_unit_speed_rpm": case.max_unit_speed_rpm, "min_unit_speed_rpm": case.min_unit_speed_rpm,
            "max_opening_chart": case.max_opening_chart, "beyond_nets_range": case.beyond_nets_range,
            "extrapolation": extrapolation_kinds(case.extrapolation), "verdicts": verdicts,
            "extrapolation_share": figure_shares(case.extrapolation),
            "four_quadrant": {name: _finite(case.components.get(name)) for name in REVERSAL_FIGURES}
            if any(name in case.components for name in REVERSAL_FIGURES) else None,
            "summary_file": f"{folder}/summary.json", "timeseries_file": f"{folder}/timeseries.csv"}


def build_report(args) -> tuple[dict, Path]:
    """Run the cases, write the per-case files and figures; return (report.json document, out dir)."""
    import hillsim
    from simulate.studies.batch import case_from_result, nets_domain, variant_overrides
    from hillsim.report_charts import plot_operating_chart
    from simulate.components.turbine.component import plant_turbine
    from simulate.components.turbine.kinds import kind_of
    from simulate.config import parse_override
    from simulate.loop.engine import plant_characteristics, run_simulation
    from simulate.studies.cases import load_study
    from simulate.studies.uncertainty import BAND_INFLATION, run_ensemble, uncalibrated_band_note

    out = args.outputs.folder("--out", args.out)  # checked and locked now, moved into place when complete
    study = load_study(args.plant, dict(parse_override(t) for t in args.overrides))
    closure_doc = sweep_doc = None
    if args.closure is not None:
        path = Path(args.closure) / "closure.json"
        try:
            closure_doc = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise InputError(f"--closure {str(args.closure)!r}: cannot read {path.name}: {exc}") from None
        if not isinstance(closure_doc, dict) or "law" not in closure_doc or "best_linear" not in closure_doc:
            raise InputError(f"--closure {str(args.closure)!r}: {path.name} is not a hillsim optimize-closure output")
    if args.sweep is not None:
        path = Path(args.sweep) / "sweep.json"
        try:
            sweep_doc = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise InputError(f"--sweep {str(args.sweep)!r}: cannot read {path.name}: {exc}") from None
        if not isinstance(sweep_doc, dict) or "cases" not in sweep_doc:
            raise InputError(f"--sweep {str(args.sweep)!r}: {path.name} is not a hillsim sweep output")
    plant = study.plant
    turbine = plant_turbine(plant)
    chars = turbine.characteristics
    chars_path = None if turbine.path is None else turbine.path.resolve()
    domain = nets_domain(chars, plant)
    # the ensemble's band: each limit is judged on its conservative side (the chart leaves that much open)
    with_band = bool(getattr(chars, "members", None) and chars.members()) and study.limits is not None
    out.mkdir(parents=True, exist_ok=True)
    inputs = [{"role": "plant file", "path": str(args.plant), "sha256": study.sha256}]
    if chars_path is not None:
        inputs.append({"role": "characteristics", "path": str(chars_path), "sha256": _hash(chars_path)})
    if closure_doc is not None:
        inputs.append({"role": "closure optimization", "path": str(Path(args.closure) / "closure.json"),
                       "sha256": _hash(Path(args.closure) / "closure.json")})
    if sweep_doc is not None:
        inputs.append({"role": "sweep", "path": str(Path(args.sweep) / "sweep.json"),
                       "sha256": _hash(Path(args.sweep) / "sweep.json")})
    cases, runs, envelopes, warnings = [], [], [], []
    if with_band and (note := uncalibrated_band_note(chars)) is not None:
        warnings.append(note)  # the limits are judged on a band that understates the error between lines
    for i, lc in enumerate(study.load_cases):
        folder = f"cases/{i}"
        (out / folder).mkdir(parents=True, exist_ok=True)
        case_plant = plant.with_overrides(variant_overrides(lc.overrides)) if lc.overrides else plant
        try:
            result = run_simulation(case_plant, characteristics=chars, raise_on_failure=False)
        except InputError as exc:  # e.g. an initial power the unit cannot give at this load case's head
            keys = ", ".join(sorted(lc.overrides)) or "no key"
            raise InputError(f"load case {lc.name!r} (setting {keys}): {exc}") from None
        result.to_csv(out / folder / "timeseries.csv")
        result.to_json(out / folder / "summary.json")
        case = case_from_result(i, lc.overrides, case_plant, result, domain)
        band = None
        if with_band and result.success:
            try:
                band, _ = run_ensemble(case_plant, chars)
            except HillsimError as exc:  # every member failed: judged on the point nets, and said so
                warnings.append(f"{lc.name}: no ensemble band (every member failed: {exc}); judged on the point "
                                f"nets only")
            else:
                for failure in band["failed"]:
                    warnings.append(f"{lc.name}: ensemble member {failure['member']} failed: {failure['message']}")
        verdicts = study.limits.check(case, band) if study.limits is not None else []
        warnings += [f"{lc.name}: limit {v['limit']} not judged: {v['why']}" for v in verdicts if "why" in v]
        doc = _case_json(case, lc, verdicts, folder)
        if band is not None:
            doc["band"] = {k: v for k, v in band.items() if k != "failed"}
        doc["decided"] = _decided(case_plant, chars, result, band, out, folder)
        cases.append(doc)
        runs.append((lc.name, result))
        plot_transient(result, case, case_plant, study.limits, out / f"transient_{i}.png",
                       f"{lc.name}: {case_plant.scenario.kind}")
        env = read_envelope(result)
        if env is not None:
            envelopes.append((lc.name, env))
            doc["envelope"] = env
        if not result.success:
            warnings.append(f"{lc.name}: the run failed: {result.message}")
        if case.beyond_nets_range:
            warnings.append(f"{lc.name}: the trajectory leaves the nets' training range (N11 "
                            f"{case.min_unit_speed_rpm:.1f}-{case.max_unit_speed_rpm:.1f} r/min, opening up to "
                            f"{case.max_opening_chart:.2f}; nets N11 {domain[0][0]:g}-{domain[1][0]:g}, opening "
                            f"{domain[0][1]:g}-{domain[1][1]:g}): figures there are extrapolated")
        for kind, fraction in (doc["extrapolation"] or {}).items():
            warnings.append(f"{lc.name}: extrapolation ({kind}) during {100 * fraction:.1f} % of the run "
                            f"(simulator record)")
    # the chart as the plant sees it: a double-regulated unit's on its cam, over (N11, guide-vane opening); the Suter
    # curves for characteristics over all four quadrants
    four_quadrant = turbine.kind is not None and kind_of(turbine.kind).four_quadrant
    chart_caption = plot_operating_chart(plant_characteristics(plant, chars), plant, runs, out / "hillchart.png",
                                         four_quadrant=four_quadrant)
    if envelopes:
        plot_envelope(envelopes, out / "envelope.png")
    verdict_list = [v["verdict"] for c in cases for v in c["verdicts"]]
    overall = ("FAIL" if "FAIL" in verdict_list else "PASS" if verdict_list and "n/a" not in verdict_list
               else "PASS (some limits not judged)" if "PASS" in verdict_list else "no limits")
    report = {
        "title": f"Regulating-guarantee report: {Path(args.plant).name}",
        "hillsim_version": hillsim.__version__,
        "date_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC"),
        "inputs": inputs, "overrides": list(args.overrides),
        "plant": plant_sheet(plant, chars_path, chars),
        "limits": None if study.limits is None else study.limits.as_dict(),
        "overall_verdict": overall, "cases": cases, "warnings": warnings,
        "judged_on": (f"the conservative side of the ensemble's 5-95 % band (widened x{BAND_INFLATION:g} about its "
                      f"median)" if with_band else "the point nets (no ensemble in the characteristics)")
        + _evidence_phrase(chars),
        "extrapolation_evidence": _extrapolation_evidence(chars),
        "envelope_available": bool(envelopes), "chart_caption": chart_caption,
        "chart_heading": ("Four-quadrant characteristics and operating range" if four_quadrant
                          else "Hill chart and operating range"),
        "closure": None if closure_doc is None else {
            k: closure_doc.get(k) for k in ("mode", "constraint", "law", "best_linear",
                                            "improvement_over_best_linear", "verification_max_abs_difference",
                                            "evaluations")},
        "sweep": None if sweep_doc is None else {k: sweep_doc.get(k) for k in ("keys", "cases", "ok", "failed",
                                                                                "error", "extrapolated_cases")},
    }
    return report, out


def _decided(plant, chars, result, band, out: Path, folder: str) -> dict:
    """Per banded figure, where its conservative end was decided and the evidence there
    (:func:`simulate.studies.figure_origin.figure_origins`); the time series of each deciding ensemble member is
    written beside the case's own. Empty for a failed run (its figures are not judged)."""
    from simulate.studies.figure_origin import figure_origins

    if not result.success:
        return {}
    origins, member_runs = figure_origins(plant, chars, result, band)
    for member, run in member_runs.items():
        run.to_csv(out / folder / f"member_{member}_timeseries.csv")
    for origin in origins.values():
        origin["timeseries_file"] = (f"{folder}/timeseries.csv" if origin["member"] is None
                                     else f"{folder}/member_{origin['member']}_timeseries.csv")
    return origins


def _extrapolation_evidence(chars) -> dict | None:
    """What the nets' training record says about the region below the lowest digitized line: the hypotheses'
    weights, their held-out errors and the band (:mod:`hillchart.extension.hypotheses`), or None."""
    record = (getattr(chars, "training", None) or {}).get("extrapolation")
    if not isinstance(record, dict):
        return None
    weights = record.get("weights", {}).get("q11", {})
    leading = max(weights, key=weights.get) if weights else None
    return {"summary": record.get("summary"), "leading_hypothesis_q11": leading,
            "weights": record.get("weights"), "rms_error": record.get("rms_error"),
            "held_out_points": record.get("held_out_points")}


def _evidence_phrase(chars) -> str:
    evidence = _extrapolation_evidence(chars)
    if evidence is None or not evidence.get("summary"):
        return ""
    return (f"; below the lowest digitized line the figures rest on hypotheses weighed by the chart's held-out "
            f"lines (leading: {evidence['leading_hypothesis_q11']}): {evidence['summary']}")


def _v(value, key, fmt="{:.4g}"):
    return Value(value, fmt, f"report.json:{key}")


def write_html(report: dict, out: Path, closure_dir: Path | None, sweep_dir: Path | None) -> Path:
    r = Report(report["title"])
    r.paragraph(f"hillsim {report['hillsim_version']}, generated {report['date_utc']}. Overall verdict: "
                f"{report['overall_verdict']}.")
    r.table(("input", "path", "SHA-256"), [(i["role"], i["path"], i["sha256"]) for i in report["inputs"]],
            caption="input files")
    p = report["plant"]
    r.heading("Plant data sheet")
    t = p["turbine"]
    r.table(("rated value", "value", "unit"), [
        ("head", _v(t["rated_head_m"], "plant.turbine.rated_head_m"), "m"),
        ("flow", _v(t["rated_flow_m3_s"], "plant.turbine.rated_flow_m3_s"), "m3/s"),
        ("speed", _v(t["rated_speed_rpm"], "plant.turbine.rated_speed_rpm"), "r/min"),
        ("power", _v(t["rated_power_mw"], "plant.turbine.rated_power_mw"), "MW"),
        ("runner diameter D1", _v(t["runner_diameter_m"], "plant.turbine.runner_diameter_m"), "m"),
        ("opening at full stroke", _v(t["opening_max"], "plant.turbine.opening_max"), "chart units"),
        ("rated efficiency P/(rho g Q H)", _v(t["rated_efficiency"], "plant.turbine.rated_efficiency"), "-")],
        caption="turbine")
    pen = p["penstock"]
    r.table(("penstock", "value", "unit"), [
        ("model", pen["model"], ""), ("static head", _v(pen["static_head_m"], "plant.penstock.static_head_m"), "m"),
        ("length", _v(pen["length_m"], "plant.penstock.length_m"), "m"),
        ("water inertia time Tw (rated)", _v(pen["water_time_s"], "plant.penstock.water_time_s"), "s"),
        ("wave reflection time 2L/a", _v(pen["two_l_over_a_s"], "plant.penstock.two_l_over_a_s"), "s"),
        ("MOC reaches / time step", f"{pen['reaches']} / {pen['time_step_s']:.5g} s", ""),
        ("rotor inertia time Ta", _v(p["generator"]["inertia_time_s"], "plant.generator.inertia_time_s"), "s"),
        ("load self-regulation e_g", _v(p["generator"]["self_regulation"], "plant.generator.self_regulation"),
         "pu")], caption="penstock and rotor")
    r.table(("segment", "length (m)", "diameter (m)", "wave speed (m/s)", "Darcy f"),
            [(i + 1, *(_v(s[k], f"plant.penstock.segments.{i}.{k}") for k in
                       ("length_m", "diameter_m", "wave_speed_m_s", "darcy_friction")))
             for i, s in enumerate(pen["segments"])], caption="penstock segments (upstream first)")
    gov = p["governor"]
    r.table(("governor", "value"), [(k, _v(v, f"plant.governor.{k}")) for k, v in gov.items()],
            caption="governor (parallel PID, permanent droop, servo)")
    law = p["closure_law"]
    r.table(("closure law", "value"), [(k, _v(v, f"plant.closure_law.{k}") if isinstance(v, (int, float)) else
                                        ("-" if v is None else v)) for k, v in law.items()],
            caption=f"scenario {p['scenario']['kind']}, event at {p['scenario']['event_time_s']:g} s, "
                    f"{p['scenario']['t_end_s']:g} s simulated")
    src = p["characteristics"]
    r.table(("characteristics", "value"), [(k, ", ".join(f"{x:g}" for x in v) if isinstance(v, list) else
                                            json.dumps(v) if isinstance(v, dict) else v) for k, v in src.items()],
            caption="turbine characteristics source")

    r.heading("Guarantee limits")
    cases = report["cases"]
    if report["limits"] is None:
        r.paragraph("The plant file has no [limits] section: nothing is judged.")
    else:
        r.table(("limit", "allowed"), [(k, "-" if v is None else _v(v, f"limits.{k}"))
                                       for k, v in report["limits"].items()], caption="[limits] of the plant file")
        rows = []
        for i, c in enumerate(cases):
            for j, v in enumerate(c["verdicts"]):
                banded = "band" in v  # a limit without a band (no ensemble, no figure) shows n/a there
                figure = LIMIT_FIGURES.get(v["limit"])
                share = (c.get("extrapolation_share") or {}).get(figure)
                rows.append((c["name"], v["limit"], _v(v["allowed"], f"cases.{i}.verdicts.{j}.allowed"),
                             _v(v["value"], f"cases.{i}.verdicts.{j}.value", "{:.5g}"),
                             *((_v(v["band"][k], f"cases.{i}.verdicts.{j}.band.{k}", "{:.5g}") for k in (0, 1))
                               if banded else (Value(None), Value(None))),
                             Value(None) if share is None else
                             _v(share, f"cases.{i}.extrapolation_share.{figure}", "{:.0%}"),
                             c["decided"][v["limit"]]["region_text"] if v["limit"] in c["decided"] else "-",
                             Verdict(v["verdict"], key=f"report.json:cases.{i}.verdicts.{j}.verdict")))
        r.table(("load case", "limit", "allowed", "point nets", "band low", "band high",
                 "run outside the chart up to it", "decided", "verdict"), rows,
                caption=f"PASS/FAIL per load case (overall: {report['overall_verdict']}), judged on "
                        f"{report['judged_on']}; n/a = the run gives no such figure (the warnings say what it "
                        f"needs: a penstock's profile, a draft tube, ...) or the run failed; 'run outside the chart "
                        f"up to it': the "
                        f"share of the run up to the figure spent outside the digitized chart (its extrapolation "
                        f"share: what the chart did not show of what decided it); 'decided': the region of the "
                        f"chart where the figure's conservative end was decided (next section)")

    def share(i, c, figure):
        value = (c.get("extrapolation_share") or {}).get(figure)
        return Value(None) if value is None else _v(value, f"cases.{i}.extrapolation_share.{figure}", "{:.0%}")

    r.heading("Load cases")
    r.table(("load case", "status", "initial power (MW)", "initial stroke", "max speed rise", "outside chart",
             "max speed (r/min)", "t (s)", "max head (m)", "max head rise", "outside chart", "t (s)", "min head (m)",
             "outside chart", "N11 range (r/min)"),
            [(c["name"], c["status"], _v(c["initial_power_mw"], f"cases.{i}.initial_power_mw"),
              _v(c["initial_opening"], f"cases.{i}.initial_opening"),
              _v(c["max_speed_rise"], f"cases.{i}.max_speed_rise", "{:.4f}"), share(i, c, "max_speed_rise"),
              _v(c["max_speed_rpm"], f"cases.{i}.max_speed_rpm", "{:.2f}"),
              _v(c["t_max_speed_s"], f"cases.{i}.t_max_speed_s", "{:.2f}"),
              _v(c["max_head_m"], f"cases.{i}.max_head_m", "{:.2f}"),
              _v(c["max_head_rise"], f"cases.{i}.max_head_rise", "{:.4f}"), share(i, c, "max_head_rise"),
              _v(c["t_max_head_s"], f"cases.{i}.t_max_head_s", "{:.2f}"),
              _v(c["min_head_m"], f"cases.{i}.min_head_m", "{:.2f}"), share(i, c, "min_head_drop"),
              f"{c['min_unit_speed_rpm']:.1f}-{c['max_unit_speed_rpm']:.1f}") for i, c in enumerate(cases)],
            caption="figures of each run (heads at the turbine inlet; rises relative to the initial value); "
                    "'outside chart' beside a figure: its extrapolation share, the share of the run up to it spent "
                    "outside the digitized chart; the hillsim run files of each case are in cases/<n>/")
    four = [(i, c) for i, c in enumerate(cases) if c.get("four_quadrant")]
    if four:
        from simulate.results.reversal import REVERSAL_FIGURES

        r.table(("load case", "max reverse speed (r/min)", "max reverse speed (% of rated)",
                 "max reverse flow (m3/s)", "first flow reversal (s)", "runaway: first speed peak (s)"),
                [(c["name"], *(Value(None) if c["four_quadrant"][k] is None else
                               _v(c["four_quadrant"][k], f"cases.{i}.four_quadrant.{k}", "{:.4g}")
                               for k in REVERSAL_FIGURES)) for i, c in four],
                caption="four-quadrant figures: against the initial rotation and flow (a turbine's reverse flow is "
                        "Q < 0, a pump's reverse rotation n > 0); n/a: the flow did not reverse, or the guide vanes "
                        "moved (no runaway)")
    _decided_section(r, cases)
    r.heading("Transients")
    for i, c in enumerate(cases):
        r.figure(out / f"transient_{i}.png", f"{c['name']}: speed, head and stroke with the maxima and the event")
    r.heading("Head envelope along the penstock")
    if report["envelope_available"]:
        r.figure(out / "envelope.png", "max and min piezometric head at every computing node")
    else:
        r.paragraph("Not available: this simulator version reports the head at the turbine inlet only. The report "
                    "draws the envelope when the run result carries it (SimulationResult.envelope with "
                    "position_m, max_head_m, min_head_m and optionally min_pressure_head_m).")
    r.heading(report["chart_heading"])
    r.figure(out / "hillchart.png", report["chart_caption"])
    r.heading("Extrapolation warnings")
    if report["warnings"]:
        r.parts.append("<ul>" + "".join(f"<li>{_esc(w)}</li>" for w in report["warnings"]) + "</ul>")
    else:
        r.paragraph("None: every run stayed inside the characteristics' training range"
                    + (" and the simulator recorded no extrapolation." if any(c["extrapolation"] is not None
                                                                             for c in cases)
                       else " (the simulator's own extrapolation record is not available in this version)."))
    if report["closure"] is not None:
        cl = report["closure"]
        r.heading("Closure-law optimization")
        rows = []
        for name in ("law", "best_linear"):
            d = cl[name]
            rows.append(({"law": "two-stage optimum", "best_linear": "best linear closure"}[name],
                         _v(d["closing_time_s"], f"closure.{name}.closing_time_s"),
                         "-" if d["break_opening"] is None else _v(d["break_opening"], f"closure.{name}.break_opening"),
                         "-" if d["break_time_s"] is None else _v(d["break_time_s"], f"closure.{name}.break_time_s"),
                         _v(d["max_speed_rise"], f"closure.{name}.max_speed_rise", "{:.4f}"),
                         _v(d["max_head_rise"], f"closure.{name}.max_head_rise", "{:.4f}")))
        r.table(("law", "T1 (s per full stroke)", "break stroke", "T2 (s per full stroke)", "worst max speed rise",
                 "worst max head rise"), rows,
                caption=f"{cl['constraint']}; improvement over the best linear closure "
                        f"{cl['improvement_over_best_linear']:.4f}; verification by hillsim run max |diff| "
                        f"{cl['verification_max_abs_difference']:.3g}")
        if closure_dir is not None and (closure_dir / "pareto.png").is_file():
            r.figure(closure_dir / "pareto.png", "Pareto front of the two-stage laws and the linear-closure family")
    if report["sweep"] is not None:
        sw = report["sweep"]
        r.heading("Sweep")
        r.paragraph(f"{sw['cases']} cases over {', '.join(sw['keys'] or [])}: {sw['ok']} ok, {sw['failed']} failed, "
                    f"{sw['error']} errors, {len(sw['extrapolated_cases'] or [])} extrapolated.")
        if sweep_dir is not None and (sweep_dir / "sweep.png").is_file():
            r.figure(sweep_dir / "sweep.png", "sweep: each maximum against the varied keys")
    return r.write(out / "report.html")


def _decided_section(r: Report, cases: list) -> None:
    """Per case and banded figure: the conservative end, the run it came from, the operating point of its extremum,
    the chart region there and the evidence the characteristics rest on (``cases.<i>.decided``)."""
    r.heading("What decided each figure")
    rows = []
    for i, c in enumerate(cases):
        for figure, d in c["decided"].items():
            key = f"cases.{i}.decided.{figure}"
            rows.append((c["name"], figure, _v(d["conservative_end"], f"{key}.conservative_end", "{:.5g}"), d["run"],
                         _v(d["time_s"], f"{key}.time_s", "{:.2f}"), _v(d["n11_rpm"], f"{key}.n11_rpm", "{:.2f}"),
                         _v(d["opening"], f"{key}.opening", "{:.3g}"), d["region_text"], d["decided_by"],
                         d["evidence"]["text"]))
    r.table(("load case", "figure", "conservative end", "run", "t (s)", "N11 (r/min)", "opening", "region",
             "decided by", "evidence"), rows,
            caption="the conservative end of each banded figure (the band's upper end, never milder than the point "
                    "nets' figure) came from the point nets, or else from the ensemble member with the largest "
                    "figure (its time series in cases/<n>/member_<k>_timeseries.csv); at its extremum, N11 = n D1 / "
                    "sqrt(H) and the opening (chart units) place it in the chart: inside the digitized chart the "
                    "measured chart decides (the nets' fit error stated), below the lowest digitized opening line "
                    "the weighed median of the extrapolation hypotheses (the hypothesis it takes there named) with "
                    "the held-out evidence that weighed them and the band there, beyond the last digitized N11 the "
                    "extension toward runaway with its held-out line ends")


def _esc(text: str) -> str:
    import html
    return html.escape(text)


def report_command(args: argparse.Namespace) -> int:
    from hillchart.io.tidy import tidy_floats

    report, out = build_report(args)
    report = tidy_floats(report)  # the same rounding as each run's summary.json, so the numbers match exactly
    (out / "report.json").write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    path = write_html(report, out, args.closure, args.sweep)
    print(f"report: {len(report['cases'])} load case(s), overall {report['overall_verdict']}, "
          f"{len(report['warnings'])} warning(s); wrote {Path(args.out) / Path(path).relative_to(out)}")
    failed = [f"{c['name']}: {v['limit']} {v['value']:.6g}"
              + (f" (band {v['band'][0]:.6g}-{v['band'][1]:.6g})" if v.get("judged") == "band" else "")
              + f" against the limit {v['allowed']:g}"
              for c in report["cases"] for v in c["verdicts"] if v["verdict"] == "FAIL"]
    if failed:
        from hillsim.cli import EXIT_LIMIT_FAIL

        args.outputs.commit()  # the report of a failed guarantee is the result: in place before the exit code
        print(f"hillsim report: FAIL: {'; '.join(failed)} (exit {EXIT_LIMIT_FAIL}; report written to {args.out})",
              file=sys.stderr)
        return EXIT_LIMIT_FAIL
    return 0
