"""``hillsim identify plant.toml --out DIR``: identification on the simulated (or measured) transient vs the nets.

Runs the nonlinear simulator in open loop around the plant's operating point (opening steps and a seeded PRBS,
sampled at tau), identifies the six coefficients (batch least squares) and the ARX speed model (RLS, RLS with
forgetting, dead-zone RLS), and compares them with the nets' analytic coefficients and the zero-order hold of the
linear model they imply (:mod:`simulate.comparison`). Writes ``identification.json``, ``identified_series.csv`` and
figures into DIR, prints the tables. ``--data series.csv`` identifies from a measured series instead.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from hillchart.errors import InputError


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
    parser.add_argument("--penstock-model", choices=("moc", "zdomain", "lumped", "rigid"), default=None,
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
    est.add_argument("--p0", type=float, default=1e10, help="P(0) = p0 I of the recursive estimators (default 1e10)")
    est.add_argument("--forgetting", type=float, default=0.98, help="lambda of the RLS-with-forgetting (default 0.98)")
    est.add_argument("--eps0", type=float, default=None,
                     help="dead zone of the dead-zone RLS (default: (1 + sum|a|) x noise, or 1e-7 without noise)")
    est.add_argument("--delta", type=float, default=0.01, help="delta of the dead-zone RLS (default 0.01)")
    est.add_argument("--arx", choices=("zoh", "paper"), default="zoh",
                     help="ARX structure: exact zero-order hold (default) or paper 000 eq. (53) as printed")
    grid = parser.add_argument_group("paper 000 head model and closed loop (simulate.head_model)")
    grid.add_argument("--head-model", choices=("interval", "paper"), default=None,
                      help="also learn the head ARX (eqs. 60-61) and the speed/head/flow estimates (eqs. 62-68): "
                           "head_model.json, head_model.png")
    grid.add_argument("--closed-loop-kp", type=float, default=None, metavar="KP",
                      help="closed-loop identification with the governor PI, Kp relative (paper tests 5-6: 7.5): "
                           "closed_loop.json")
    grid.add_argument("--closed-loop-ti", type=float, nargs="+", default=[0.5, 0.15], metavar="TI_S",
                      help="integral times of the closed-loop runs, s (default 0.5 0.15)")
    parser.add_argument("--exact", choices=("auto", "synthetic", "none"), default="auto",
                        help="also report the exact synthetic turbine's coefficients (auto: when the plant uses the "
                             "shipped synthetic nets)")
    parser.set_defaults(func=run)


def _exact(choice: str, plant):
    if choice == "none":
        return None
    from hillchart.synthetic import SyntheticFrancis

    if choice == "synthetic":
        return SyntheticFrancis()
    chars = plant.turbine.characteristics
    if chars == "ideal":
        return None
    try:
        from importlib.resources import files

        shipped = Path(str(files("data_synthetic.francis") / "nets.json")).resolve()
    except (ModuleNotFoundError, FileNotFoundError):  # pragma: no cover - data package always ships
        return None
    return SyntheticFrancis() if (Path(plant.base_dir) / chars).resolve() == shipped else None


def run(args: argparse.Namespace) -> int:
    from simulate.comparison import (ExperimentSettings, compare_identification, identify_measured,
                                     load_measured_series, markdown_tables)
    from simulate.config import load_plant, parse_override

    from simulate.head_model import check_closed_loop_options

    check_closed_loop_options(args.closed_loop_kp, args.closed_loop_ti)  # before anything is written
    overrides = dict(parse_override(text) for text in args.set)
    plant = load_plant(args.plant, overrides)
    settings = ExperimentSettings(
        sample_time_s=args.tau, step_amplitude=args.amplitude, step_hold_s=args.step_hold_s,
        prbs_amplitude=args.prbs_amplitude, prbs_bit_s=args.prbs_bit_s, prbs_duration_s=args.prbs_duration_s,
        quiet_s=args.quiet_s, noise_level=args.noise, seed=args.seed, rls_p0=args.p0,
        forgetting_factor=args.forgetting, dead_zone_eps0=args.eps0, dead_zone_delta=args.delta,
        arx_structure=args.arx)
    exact = _exact(args.exact, plant)
    if args.data is not None:
        if args.penstock_model is not None or args.initial_opening is not None:
            raise InputError("--penstock-model and --initial-opening apply to the simulated experiment, not to --data")
        series = load_measured_series(args.data, sample_time_s=args.tau)
        arma_series = load_measured_series(args.data, sample_time_s=settings.arma_sample_time_s,
                                           operating_point=series.operating_point)
        report = identify_measured(series, settings, plant=plant, exact=exact, arma_series=arma_series)
    else:
        report = compare_identification(plant, settings=settings, exact=exact, penstock_model=args.penstock_model,
                                        initial_opening=args.initial_opening)
    paths = report.write(args.out)
    if args.head_model is not None or args.closed_loop_kp is not None:
        from simulate.head_model import write_head_and_closed_loop

        paths.update(write_head_and_closed_loop(report, plant, args.out, head_structure=args.head_model,
                                                closed_loop_kp=args.closed_loop_kp, closed_loop_ti=args.closed_loop_ti))
    summary = report.summary
    print(f"identification ({summary['source']}, penstock {summary.get('penstock_model', '-')}, tau = {args.tau} s, "
          f"{summary['samples']} samples)")
    print(markdown_tables(summary))
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0
