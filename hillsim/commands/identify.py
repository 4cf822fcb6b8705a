"""``hillsim identify plant.toml --out DIR``: identification on the simulated (or measured) transient vs the nets.

Runs the nonlinear simulator in open loop around the plant's operating point (opening steps and a seeded PRBS,
sampled at tau), identifies the six coefficients (batch least squares) and the ARX speed model (RLS, RLS with
forgetting, dead-zone RLS), and compares them with the nets' analytic coefficients and the zero-order hold of the
linear model they imply (:mod:`simulate.identification.compare`). Writes ``identification.json``,
``identified_series.csv`` and figures into DIR, prints the tables. ``--data series.csv`` identifies from a measured
series instead.
"""

from __future__ import annotations

import argparse
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from hillchart.errors import InputError
from hillsim import progress

#: The exact turbine the shipped synthetic nets were trained on (``--exact auto``).
EXACT_OF_SHIPPED_NETS = "synthetic"


def _penstock_models() -> tuple[str, ...]:
    """The penstock models of the registry (the built-in ones and any registered before the parser is built)."""
    from simulate.components.registry import PENSTOCKS

    return PENSTOCKS.names()

def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "identify",
        help="identify the linear turbine model from the simulated (or measured) transient and compare with the nets",
        description="Open-loop opening steps + PRBS on the nonlinear simulator (or a measured series), batch LS of "
                    "the six coefficients, RLS / dead-zone RLS of the ARX speed model, compared with the nets.",
    )
    parser.add_argument("plant", metavar="PLANT", help="plant TOML file")
    parser.add_argument("--out", required=True, help="output folder (created)")
    parser.add_argument("--data", default=None, metavar="CSV",
                        help="measured series: header time_s,speed_rpm,head_m,opening,torque_nm,flow_m3_s "
                             "(opening as stroke fraction); resampled to tau by interpolation")
    parser.add_argument("--penstock-model", choices=_penstock_models(), default=None,
                        help="override the plant's penstock model (rigid/lumped match the linear models)")
    parser.add_argument("--initial-opening", type=float, default=None, metavar="STROKE",
                        help="operating point as a stroke fraction (default: the scenario's initial power/opening)")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a plant value (repeatable), as in hillsim run")
    exp = parser.add_argument_group("experiment")
    exp.add_argument("--tau", type=float, default=0.2, help="sampling time tau, s (default 0.2)")
    exp.add_argument("--amplitude", type=float, default=0.01,
                     help="opening steps +-A, relative to the operating opening (default 0.01)")
    exp.add_argument("--step-hold-s", type=float, default=40.0, help="hold of each step, s (default 40)")
    exp.add_argument("--prbs-amplitude", type=float, default=0.01, help="PRBS level, relative (default 0.01)")
    exp.add_argument("--prbs-bit-s", type=float, default=1.0, help="PRBS bit length, s (default 1)")
    exp.add_argument("--prbs-duration-s", type=float, default=160.0, help="PRBS duration, s (default 160)")
    exp.add_argument("--quiet-s", type=float, default=100.0, help="constant opening at the end, s (default 100)")
    exp.add_argument("--noise", type=float, default=0.0,
                     help="half-width of uniform measurement noise on x, h, m, q (relative; default 0)")
    exp.add_argument("--seed", type=int, default=0, help="seed of the PRBS and the noise (default 0)")
    est = parser.add_argument_group("estimators")
    est.add_argument("--p0", type=float, default=1e10,
                     help="P(0) = p0 I of the recursive estimators (default 1e10, as ExperimentSettings.rls_p0; the "
                          "estimators' own default 1.0 is the paper's P(0) = I, which leaves theta far from least "
                          "squares on per-unit data)")
    est.add_argument("--forgetting-factor", "--forgetting", dest="forgetting", type=float, default=0.98,
                     help="lambda of the RLS-with-forgetting variant (default 0.98, as "
                          "ExperimentSettings.forgetting_factor; RecursiveLeastSquares' own default 1.0 is plain RLS)")
    est.add_argument("--eps0", type=float, default=None,
                     help="dead zone of the dead-zone RLS (default: (1 + sum|a|) x noise, or 1e-7 without noise)")
    est.add_argument("--delta", type=float, default=0.01, help="delta of the dead-zone RLS (default 0.01)")
    est.add_argument("--arx", choices=("zoh", "paper"), default="zoh",
                     help="ARX structure: exact zero-order hold (default) or eq. (53) of Wang et al. 2023 as printed")
    grid = parser.add_argument_group(
        "head model and closed loop of Wang et al. 2023 (simulate.identification.head_model)")
    grid.add_argument("--head-model", choices=("interval", "paper"), default=None,
                      help="also learn the head ARX (eqs. 60-61) and the speed/head/flow estimates (eqs. 62-68): "
                           "head_model.json, head_model.png")
    grid.add_argument("--closed-loop-kp", type=float, default=None, metavar="KP",
                      help="closed-loop identification with the governor PI, Kp relative (paper tests 5-6: 7.5): "
                           "closed_loop.json")
    grid.add_argument("--closed-loop-ti", type=float, nargs="+", default=None, metavar="TI_S",
                      help="integral times of the closed-loop runs, s (default 0.5 0.15; needs --closed-loop-kp)")
    parser.add_argument("--no-plot", action="store_true", help="do not write the PNG figures")
    parser.add_argument("--exact", choices=("auto", EXACT_OF_SHIPPED_NETS, "none"), default="auto",
                        help="also report the exact synthetic turbine's coefficients (auto: when the plant uses the "
                             "shipped synthetic nets)")
    parser.set_defaults(func=run)


def _exact(choice: str, plant):
    """The exact turbine reported next to the nets (``--exact``), from the one resolver of characteristics: the
    word of the exact turbine ``--exact`` names, or with ``auto`` the synthetic Francis turbine when the plant runs on
    the shipped synthetic nets (stepped up like the nets when the plant has [turbine.step_up])."""
    if choice == "none":
        return None
    from simulate.components.turbine.kinds import nets_path, resolve_characteristics

    if choice == "auto":
        path = nets_path(plant.turbine.characteristics, plant.base_dir)
        if path is None:
            return None
        try:
            from importlib.resources import files

            shipped = Path(str(files("data_synthetic.francis") / "nets.json")).resolve()
        except (ModuleNotFoundError, FileNotFoundError):  # pragma: no cover - data package always ships
            return None
        if path.resolve() != shipped:
            return None
        choice = EXACT_OF_SHIPPED_NETS
    return resolve_characteristics(choice, turbine=plant.turbine)


def run(args: argparse.Namespace) -> int:
    from hillsim.commands import load_command_plant
    from simulate.identification.experiment import ExperimentSettings
    from simulate.identification.compare import compare_identification, identify_measured
    from simulate.identification.tables import markdown_tables
    from simulate.identification.measured import load_measured_series

    from simulate.identification.head_model import check_closed_loop_options

    check_closed_loop_options(args.closed_loop_kp, args.closed_loop_ti)  # before anything is written
    out = args.outputs.folder("--out", args.out)  # checked now, put in place when everything succeeded
    plant = load_command_plant("identify", args.plant, args.set)
    plant.require_one_unit("hillsim identify")
    settings = ExperimentSettings(
        sample_time_s=args.tau, step_amplitude=args.amplitude, step_hold_s=args.step_hold_s,
        prbs_amplitude=args.prbs_amplitude, prbs_bit_s=args.prbs_bit_s, prbs_duration_s=args.prbs_duration_s,
        quiet_s=args.quiet_s, noise_level=args.noise, seed=args.seed, rls_p0=args.p0,
        forgetting_factor=args.forgetting, dead_zone_eps0=args.eps0, dead_zone_delta=args.delta,
        arx_structure=args.arx)
    exact = _exact(args.exact, plant)
    notes: list[str] = []
    if args.data is not None:
        if args.penstock_model is not None or args.initial_opening is not None:
            raise InputError("--penstock-model and --initial-opening apply to the simulated experiment, not to --data")
        from simulate.identification.series_checks import check_against_plant, check_duration_against_plant

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            series = load_measured_series(args.data, sample_time_s=args.tau)
        for w in caught:
            print(f"warning: {w.message}")
        check_against_plant(args.data, series.operating_point, plant)
        check_duration_against_plant(args.data, series.time_s, plant)
        try:
            with warnings.catch_warnings():  # the same file again: its notes were printed above
                warnings.simplefilter("ignore")
                arma_series = load_measured_series(args.data, sample_time_s=settings.arma_sample_time_s,
                                                   operating_point=series.operating_point)
        except InputError as exc:  # e.g. sampled too coarsely for paper 002's 0.04 s: the rest stands
            arma_series = None
            notes.append(f"the ARMA fit of Wei et al. 2016 uses the series at {settings.arma_sample_time_s} s: {exc}")
        progress.start("identifying from the measured series")
        report = identify_measured(series, settings, plant=plant, exact=exact, arma_series=arma_series)
    else:
        progress.start(f"simulating the experiment ({settings.duration_s:g} s) and identifying")
        report = compare_identification(plant, settings=settings, exact=exact, penstock_model=args.penstock_model,
                                        initial_opening=args.initial_opening)
    summary, review_notes = review_summary(report.summary, report.series, settings)
    notes += review_notes
    if notes:
        summary = replace(summary, warnings=tuple(notes))
    report = replace(report, summary=summary)
    progress.done()
    progress.start("writing identification.json, the series" + ("" if args.no_plot else " and the figures"))
    paths = report.write(out, plot=not args.no_plot)
    if args.head_model is not None or args.closed_loop_kp is not None:
        from simulate.identification.head_model import DEFAULT_CLOSED_LOOP_TI, write_head_and_closed_loop

        paths.update(write_head_and_closed_loop(report, plant, out, head_structure=args.head_model,
                                                closed_loop_kp=args.closed_loop_kp,
                                                closed_loop_ti=args.closed_loop_ti or DEFAULT_CLOSED_LOOP_TI))
    progress.done()
    print(f"identification ({summary.source}, penstock {summary.penstock_model or '-'}, tau = {args.tau} s, "
          f"{summary.samples} samples)")
    print(markdown_tables(summary))
    for note in notes:
        print(f"warning: {note}")
    print("wrote " + ", ".join(str(Path(args.out) / p.relative_to(out)) for p in paths.values()))
    return 0


#: A measured opening moving less than this (relative to the operating opening) over the last ``quiet_s`` counts as
#: a quiet tail (position sensors resolve about 0.1 % of the stroke).
QUIET_TAIL_TOLERANCE = 1e-3


def has_quiet_tail(series, settings) -> bool:
    """Whether the last ``settings.quiet_s`` of the series hold the opening constant (the part where only noise
    drives the estimators); False when the series is shorter than that or the opening moves."""
    n = int(round(settings.quiet_s / series.sample_time_s))
    if n < 2 or n >= series.y.size:
        return False
    return float(np.ptp(series.y[-n:])) <= QUIET_TAIL_TOLERANCE


def review_summary(summary, series, settings):
    """``(reviewed summary, warnings)``: each identified ARX model gets ``max_pole_modulus`` and ``stable``; without
    a quiet tail the quiet-tail spread is None and the recorded ``experiment.quiet_s`` 0 (nothing to shade in the
    convergence plot). Warnings: unstable models, no quiet tail, outside the small-signal range; the caller records
    them in ``summary.warnings``.

    Parameters
    ----------
    summary : simulate.identification.results.IdentificationSummary
    series : simulate.identification.measured.RelativeSeries
    settings : simulate.identification.experiment.ExperimentSettings
    """
    from simulate.identification.series_checks import small_signal_warning

    notes = []
    signal = small_signal_warning(series)
    if signal:
        notes.append(signal)
    quiet = has_quiet_tail(series, settings)
    reviewed = {}
    for name, estimate in summary.arx.estimates().items():
        modulus = estimate.pole_modulus()
        changes = {"max_pole_modulus": modulus, "stable": bool(modulus < 1.0)}
        if not changes["stable"]:
            notes.append(f"the ARX model identified by {name} is unstable (largest pole |z| = {modulus:.6f} >= 1): "
                         "its step response and simulation-mode output diverge, so their errors are not shown")
        if not quiet:
            changes["theta_spread_quiet_tail"] = None
        reviewed[name] = replace(estimate, **changes)
    summary = replace(summary, arx=replace(summary.arx, **reviewed))
    if not quiet:
        summary = replace(summary, experiment=replace(summary.experiment, quiet_s=0.0))
        notes.append(f"no quiet tail (the opening moves within the last {settings.quiet_s:g} s, or the series is "
                     "shorter): the theta spread in the quiet tail is not reported")
    return summary, notes
