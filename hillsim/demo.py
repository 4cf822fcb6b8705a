"""The end-to-end demo: chart -> extension -> nets -> hill chart -> transients (and a double-regulated bulb unit)
-> linearization -> identification, written into one folder with a self-contained ``report.html``.

Each step writes its own files (figures, CSV, JSON); the report and the terminal summary read their numbers from
those JSON files, so what the report says is what the files say.

Examples
--------
A notebook user runs the same pipeline with::

    from hillsim.demo import run_demo
    summary = run_demo("demo_out", fast=True)
"""

from __future__ import annotations

import json
import warnings
from dataclasses import fields, is_dataclass, replace
from pathlib import Path

from hillsim.report import Report, Value

#: Steps, in order (the progress counter counts these).
STEPS = (
    "load and extend the chart",
    "nets",
    "hill chart",
    "load rejection (governor)",
    "load rejection (closure law)",
    "no-load frequency steps",
    "double-regulated bulb: load rejection",
    "linearize at the scenario's initial point",
    "identification vs nets",
    "report",
)


def _write_json(path: Path, data) -> Path:
    """JSON with tidy floats (:func:`hillchart.io.tidy.tidy_floats`: 12 significant digits, dust below 1e-30 -> 0)."""
    from hillchart.io.tidy import tidy_floats
    from simulate.results.result import json_default

    data = tidy_floats(json.loads(json.dumps(data, default=json_default)))
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return path


def _read_json(path: Path):
    return json.loads(path.read_text(encoding="utf-8"))


def _simulate(plant, nets, out_dir: Path) -> dict:
    from simulate.loop.engine import run_simulation

    result = run_simulation(plant, characteristics=nets)
    out_dir.mkdir(parents=True, exist_ok=True)
    result.to_csv(out_dir / "timeseries.csv")
    result.to_json(out_dir / "summary.json")
    result.plot(out_dir / "transient.png")
    return _read_json(out_dir / "summary.json")


def run_demo(out, *, fast: bool = False, progress: bool = False, restarts: int = 10, seed: int = 0,
             outputs=None) -> dict:
    """Run the whole pipeline on the shipped synthetic chart and plant; returns the key numbers.

    Parameters
    ----------
    out : path
        Output folder (created). The files are written into a private temporary folder and put in place when the
        demo has finished (:mod:`hillsim.outputs`): an interrupted or failed demo leaves nothing behind.
    fast : bool
        Reuse the shipped ``data_synthetic/francis/nets.json`` instead of training.
    progress : bool
        Print step progress on stderr (one line per step on a terminal, a start and a done line elsewhere).
    restarts, seed : int
        Training multi-start count and seed (ignored with ``fast``).
    outputs : hillsim.outputs.OutputSet or None
        Declare ``out`` on this set (the CLI's, committed by the CLI) instead of a set of the demo's own.

    Returns
    -------
    dict
        The numbers of ``demo_summary.json``.
    """
    from hillsim.outputs import OutputSet

    if outputs is not None:
        return _run_demo(outputs.folder("--out", out), fast=fast, progress=progress, restarts=restarts, seed=seed)
    with OutputSet("demo") as own:
        return _run_demo(own.folder("out", out), fast=fast, progress=progress, restarts=restarts, seed=seed)


def _run_demo(out: Path, *, fast: bool, progress: bool, restarts: int, seed: int) -> dict:
    """The demo, written into the (temporary) folder ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from data_synthetic import FRANCIS_DIR, PLANT_HLA339
    from hillchart.nets.chartplot import chart_figure
    from hillchart.extension.extend import extend_samples
    from hillchart.linearize import coefficient_maps, plot_coefficient_maps, six_coefficients
    from hillchart.nets.accuracy import read_truth_csv, truth_errors
    from hillchart.nets.hill_nets import load_nets
    from hillchart.nets.training import train_nets
    from hillchart.io.samples import measured_region_mask
    from hillchart.io.samples import load_chart
    from hillchart.synthetic.francis import SyntheticFrancis
    from simulate.config import ScenarioConfig, load_plant
    from simulate.identification.compare import compare_identification
    from simulate.identification.results import CoefficientSet, to_json_dict
    from simulate.identification.linear_reference import plant_linearization

    from hillsim.progress import Stages

    out = Path(out)
    bar = Stages(enabled=progress, total=len(STEPS))
    files: dict[str, Path] = {}

    bar.start(STEPS[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        chart = load_chart(FRANCIS_DIR)
    extended = extend_samples(chart)
    files["extended_csv"] = extended.to_csv(out / "extended.csv")
    extended.plot(out / "extended.png")
    plt.close("all")
    bar.done(f"{extended.value.size} samples")

    bar.start(STEPS[1] + (" (shipped, --fast)" if fast else " (training)"))
    if fast:
        nets = load_nets(FRANCIS_DIR / "nets.json")
    else:
        nets = train_nets(extended, restarts=restarts, seed=seed)
    nets.save(out / "nets.json")
    truth = read_truth_csv(FRANCIS_DIR / "truth.csv")
    inside = measured_region_mask(chart.flow_n11, chart.flow_opening, truth["n11"], truth["opening"])
    fit = {"truth_errors": truth_errors(nets, truth, inside), "training": nets.training, "trained": not fast}
    _write_json(out / "fit_errors.json", fit)
    bar.done()

    bar.start(STEPS[2])
    chart_figure(nets, samples=chart, extended=extended, path=out / "hillchart.png")
    plt.close("all")
    bar.done()

    plant = load_plant(PLANT_HLA339)
    scenario = plant.scenario

    bar.start(STEPS[3])
    rejection = _simulate(plant, nets, out / "load_rejection")
    plt.close("all")
    bar.done(f"max speed rise {100 * rejection['max_speed_rise']:.1f} %")

    bar.start(STEPS[4])
    closure = replace(
        plant,
        scenario=ScenarioConfig(kind="closure-law", t_end_s=scenario.t_end_s,
                                initial_power_mw=scenario.initial_power_mw, event_time_s=scenario.event_time_s,
                                closing_time_s=plant.governor.closing_time_s),
    )
    closure_summary = _simulate(closure, nets, out / "closure_law")
    plt.close("all")
    bar.done(f"max head rise {100 * closure_summary['max_head_rise']:.1f} %")

    bar.start(STEPS[5])
    freq = replace(plant, scenario=ScenarioConfig(kind="frequency-steps", t_end_s=100.0))
    _simulate(freq, nets, out / "frequency_steps")
    plt.close("all")
    bar.done()

    bar.start(STEPS[6])
    from data_synthetic import PLANT_BULB

    bulb = _simulate(load_plant(PLANT_BULB), None, out / "bulb_rejection")
    plt.close("all")
    bar.done(f"max speed rise {100 * bulb['max_speed_rise']:.1f} %, min outlet pressure "
             f"{bulb['min_outlet_pressure_head_m']:.2f} m")

    bar.start(STEPS[7])
    linear = plant_linearization(plant, nets)
    exact_turbine = SyntheticFrancis()
    op = linear.operating_point
    exact = six_coefficients(exact_turbine, n11=op.n11_rpm, opening=op.opening_chart)
    linear = replace(linear, coefficients_exact=CoefficientSet.of(exact))
    _write_json(out / "linearization.json", to_json_dict(linear))
    n11_grid = np.linspace(20.0, 120.0, 101)
    a_grid = np.linspace(2.0, chart.info.opening_max, 61)
    plot_coefficient_maps(coefficient_maps(nets, n11_grid, a_grid), out / "coefficient_maps.png",
                          operating_point=(op.n11_rpm, op.opening_chart), opening_unit=chart.info.opening_unit)
    plt.close("all")
    bar.done()

    bar.start(STEPS[8])
    # the lumped elastic penstock matches the elastic linear model (eqs. 24-30) exactly; `hillsim identify` runs moc too
    identification = compare_identification(plant, characteristics=nets, exact=exact_turbine, penstock_model="lumped")
    identification.write(out / "identification")
    plt.close("all")
    bar.done()

    bar.start(STEPS[9])
    for file in RESULT_FILES.values():  # the simulator's and identification's own JSON, tidied like the demo's
        _write_json(out / file, _read_json(out / file))
    results = _load_results(out)
    ide = _tidy_record(identification.summary)  # the numbers exactly as identification.json has them
    summary = _summary(results, ide)
    _write_json(out / "demo_summary.json", summary)
    build_report(out, results, summary, ide).write(out / "report.html")
    bar.done()
    return summary


#: The demo's JSON result files, by the name the report and summary use.
RESULT_FILES = {
    "fit": "fit_errors.json",
    "linearization": "linearization.json",
    "identification": "identification/identification.json",
    "load_rejection": "load_rejection/summary.json",
    "closure_law": "closure_law/summary.json",
    "frequency_steps": "frequency_steps/summary.json",
    "bulb_rejection": "bulb_rejection/summary.json",
}


def _load_results(out: Path) -> dict:
    """Every step's JSON file, read once (the summary and the report both take their numbers from these)."""
    return {name: _read_json(out / file) for name, file in RESULT_FILES.items()}


def _tidy_record(record):
    """A copy of a frozen record (:mod:`simulate.identification.results`) with every float tidied as
    :func:`_write_json` tidies the files (:func:`hillchart.io.tidy.tidy_float`), so that what the report reads from
    the record is what the JSON file says."""
    from hillchart.io.tidy import tidy_float

    if is_dataclass(record) and not isinstance(record, type):
        return replace(record, **{f.name: _tidy_record(getattr(record, f.name)) for f in fields(record) if f.init})
    if isinstance(record, tuple):
        return tuple(_tidy_record(v) for v in record)
    if isinstance(record, float):
        return tidy_float(float(record))
    return record


def _summary(results: dict, ide) -> dict:
    """The key numbers, each taken from a step's JSON file (``ide``: the identification summary as its file has
    it, see :func:`_tidy_record`)."""
    fit = results["fit"]["truth_errors"]
    rej, clo, fre = results["load_rejection"], results["closure_law"], results["frequency_steps"]
    lin = results["linearization"]
    six = ide.six_coefficients
    return {
        "q11_rms_measured_pct": fit["q11"]["rms_measured_pct"],
        "q11_max_measured_pct": fit["q11"]["max_measured_pct"],
        "m11_rms_measured_pct": fit["m11"]["rms_measured_pct"],
        "load_rejection_max_speed_rise": rej["max_speed_rise"],
        "load_rejection_max_head_rise": rej["max_head_rise"],
        "load_rejection_mean_iterations": rej["mean_iterations"],
        "closure_law_max_speed_rise": clo["max_speed_rise"],
        "closure_law_max_head_rise": clo["max_head_rise"],
        "frequency_steps_max_iterations": fre["max_iterations"],
        "bulb_max_speed_rise": results["bulb_rejection"]["max_speed_rise"],
        "bulb_min_outlet_pressure_head_m": results["bulb_rejection"]["min_outlet_pressure_head_m"],
        "operating_point_power_mw": lin["operating_point"]["power_mw"],
        "ey_nets": lin["coefficients"]["ey"],
        "ey_exact": lin["coefficients_exact"]["ey"],
        "six_max_abs_batch_ls_minus_nets": six.max_abs_batch_ls_minus_nets,
        "six_max_abs_nets_minus_exact": six.max_abs_nets_minus_exact,
        "rls_step_error_vs_nets": ide.arx.rls.step_error_vs_nets,
        "rls_simulation_mode_max_speed_error": ide.arx.rls.simulation_mode_final_theta.max_abs_error,
    }


def build_report(out: Path, results: dict, summary: dict, ide) -> Report:
    """``report.html``: every figure of the demo (PNGs under ``out``) and the tables of key numbers, taken from the
    JSON files (``results``, see :func:`_load_results`) and the identification summary as its file has it
    (``ide``, see :func:`_tidy_record`)."""
    fit, lin = results["fit"], results["linearization"]
    sims = {name: results[name] for name in ("load_rejection", "closure_law", "frequency_steps")}
    report = Report("hillsim demo: synthetic HLA339-like Francis unit")
    report.paragraph(
        "From the digitized hill chart of hillsim's synthetic Francis turbine: extended samples, the two 2-5-1 "
        "logsig nets, the hill chart they imply, the plant's load rejection (governor and closure law) and no-load "
        "frequency steps, the six linear coefficients, and recursive identification compared with the nets. Every "
        "number below is read from the JSON file named in its source column."
    )

    report.heading("1. Chart and extended samples")
    report.figure(out / "extended.png", "Extended Q11 and M11 samples coloured by origin (paper Figs. 2-3)")

    report.heading("2. Nets and their accuracy against the exact turbine")
    rows = []
    for target, unit in (("q11", "m3/s"), ("m11", "N*m")):
        e = fit["truth_errors"][target]
        rows.append([target, unit,
                     Value(e["rms_measured_pct"], "{:.3f} %",
                           f"fit_errors.json:truth_errors.{target}.rms_measured_pct"),
                     Value(e["max_measured_pct"], "{:.3f} %",
                           f"fit_errors.json:truth_errors.{target}.max_measured_pct"),
                     Value(e["rms_extended_pct"], "{:.3f} %",
                           f"fit_errors.json:truth_errors.{target}.rms_extended_pct"),
                     Value(e["max_extended_pct"], "{:.3f} %",
                           f"fit_errors.json:truth_errors.{target}.max_extended_pct")])
    report.table(["net", "unit", "RMS, measured region", "max, measured region", "RMS, extended region",
                  "max, extended region"], rows,
                 "Error against truth.csv as % of the truth range in the measured region "
                 "(bounds: Q11 RMS 0.5 %, max 2 %; M11 RMS 1 %)")
    report.figure(out / "hillchart.png", "Hill chart from the nets, Q11/M11 surfaces and errors (paper Figs. 5-8)")

    report.heading("3. Transients of the example plant (MOC penstock, improved pressure loop)")
    keys = [("max_speed_rise", "max speed rise", "{:.2%}"), ("t_max_speed_s", "time of max speed (s)", "{:.2f}"),
            ("max_head_rise", "max head rise", "{:.2%}"), ("min_head_drop", "min head drop", "{:.2%}"),
            ("final_speed_error", "final speed error", "{:.3%}"), ("mean_iterations", "mean iterations", "{:.2f}"),
            ("max_iterations", "max iterations", "{:d}")]
    rows = [[label] + [Value(sims[s][k], fmt, f"{s}/summary.json:{k}") for s in sims] for k, label, fmt in keys]
    report.table(["quantity", "load rejection (governor)", "load rejection (closure law)", "no-load frequency steps"],
                 rows, "Summary figures (fractions of the initial values)")
    for name, caption in (("load_rejection", "100 % load rejection with the governor (Li et al. 2017, Fig. 11b)"),
                          ("closure_law", "100 % load rejection with the prescribed closure law"),
                          ("frequency_steps", "No-load frequency steps +4 %, -8 %, +4 % (Li et al. 2017, Fig. 11a)")):
        report.figure(out / name / "transient.png", caption)

    report.heading("3b. A double-regulated unit: the bulb plant's load rejection")
    bulb = results["bulb_rejection"]
    keys = [("max_speed_rise", "max speed rise", "{:.2%}"), ("max_head_rise", "max net head rise", "{:.2%}"),
            ("min_outlet_pressure_head_m", "min runner-outlet pressure head (m, absolute)", "{:.2f}"),
            ("t_min_outlet_pressure_s", "time of that minimum (s)", "{:.2f}")]
    report.table(["quantity", "bulb load rejection"],
                 [[label, Value(bulb[k], fmt, f"bulb_rejection/summary.json:{k}")] for k, label, fmt in keys],
                 "The synthetic bulb (three-input nets), guide vanes by the governor, blades on the cam through their "
                 "servo, intake and draft tube by MOC")
    report.figure(out / "bulb_rejection" / "transient.png", "Bulb load rejection: speed, heads, vanes and blades")

    report.heading("4. Six coefficients: nets vs exact vs batch least squares")
    six = ide.six_coefficients
    names = ("ex", "ey", "eh", "eqx", "eqy", "eqh")
    rows = [[k,
             Value(lin["coefficients"][k], "{:.4f}", f"linearization.json:coefficients.{k}"),
             Value(lin["coefficients_exact"][k], "{:.4f}", f"linearization.json:coefficients_exact.{k}"),
             Value(getattr(six.nets, k), "{:.4f}", f"identification/identification.json:six_coefficients.nets.{k}"),
             Value(getattr(six.batch_ls, k), "{:.4f}",
                   f"identification/identification.json:six_coefficients.batch_ls.{k}")]
            for k in names]
    report.table(["coefficient", "nets, scenario point", "exact turbine, scenario point", "nets, identification point",
                  "batch LS (Wang et al. 2023, eqs. 69-70)"], rows,
                 "Relative coefficients at the scenario's initial point (the plant's initial load; not the chart's "
                 "design rated N11 of the README's linearize example) and at the identification point")
    report.figure(out / "coefficient_maps.png", "The six coefficients over the chart")

    report.heading("5. Identification against the nets")
    rows = []
    for name in ("rls", "dead_zone_rls", "rls_forgetting"):
        e = getattr(ide.arx, name)
        rows.append([name,
                     Value(e.step_error_vs_nets, "{:.4f}",
                           f"identification/identification.json:arx.{name}.step_error_vs_nets"),
                     Value(e.simulation_mode_final_theta.max_abs_error, "{:.3g}",
                           f"identification/identification.json:arx.{name}.simulation_mode_final_theta.max_abs_error")])
    report.table(["estimator", "step response error vs nets' ZOH model (fraction of peak)",
                  "simulation-mode max speed error (per unit)"], rows,
                 f"ARX identification with the {ide.penstock_model} penstock")
    for png, caption in (("six_coefficients.png", "Six coefficients: nets vs batch LS vs exact"),
                         ("step_response.png", "Step responses: identified vs nets' ZOH model"),
                         ("theta_convergence.png", "theta(k) convergence of RLS and dead-zone RLS"),
                         ("simulation_mode.png", "Simulation-mode speed output (Wang et al. 2023, eqs. 62-64)")):
        path = out / "identification" / png
        if path.is_file():
            report.figure(path, caption)

    report.heading("Key numbers")
    report.table(["key", "value"], [[k, Value(v, "{:.6g}", f"demo_summary.json:{k}")] for k, v in summary.items()],
                 "demo_summary.json")
    return report


def format_summary(summary: dict) -> str:
    """The short terminal table."""
    lines = [
        f"{'net fit (measured region)':<38} Q11 RMS {summary['q11_rms_measured_pct']:.3f} %, "
        f"max {summary['q11_max_measured_pct']:.3f} %; M11 RMS {summary['m11_rms_measured_pct']:.3f} %",
        f"{'load rejection (governor)':<38} max speed rise {summary['load_rejection_max_speed_rise']:.1%}, "
        f"max head rise {summary['load_rejection_max_head_rise']:.1%}, "
        f"{summary['load_rejection_mean_iterations']:.2f} iterations/step",
        f"{'load rejection (closure law)':<38} max speed rise {summary['closure_law_max_speed_rise']:.1%}, "
        f"max head rise {summary['closure_law_max_head_rise']:.1%}",
        f"{'bulb load rejection (double regulated)':<38} max speed rise {summary['bulb_max_speed_rise']:.1%}, "
        f"min outlet pressure {summary['bulb_min_outlet_pressure_head_m']:.2f} m",
        f"{'ey at the scenario point':<38} nets {summary['ey_nets']:.4f}, exact {summary['ey_exact']:.4f} "
        f"({summary['operating_point_power_mw']:.0f} MW)",
        f"{'six coefficients, batch LS vs nets':<38} max |diff| {summary['six_max_abs_batch_ls_minus_nets']:.4f}",
        f"{'RLS step response vs nets':<38} {summary['rls_step_error_vs_nets']:.3f} of peak; simulation-mode "
        f"speed error {summary['rls_simulation_mode_max_speed_error']:.2e} pu",
    ]
    return "\n".join(lines)
