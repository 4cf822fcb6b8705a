"""``hillsim train CHART_DIR --out nets.json``: extend the chart's samples and train the flow and torque nets."""

from __future__ import annotations

import argparse
import sys
import time
import warnings

from hillsim.commands import SEED_RANGE, int_in
from hillsim.commands.extend import (add_extension_arguments, extension_options,
                                     load_chart_reporting_warnings)

#: Allowed ``--hidden`` values (the selection itself tries 5-10).
HIDDEN_RANGE = (1, 30)
#: Allowed ``--ensemble`` sizes.
ENSEMBLE_RANGE = (0, 100)
DEFAULT_ENSEMBLE = 10


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "train",
        help="train the Q11 and M11 nets (2-H-1 logsig, Levenberg-Marquardt) and write nets.json",
        description="Load a chart folder, check it, extend its samples (torque from efficiency; runaway, zero "
                    "opening, zero speed from a physical model fitted to the chart) and train the flow net "
                    "Q11(N11, a) and the torque net M11(N11, a) as in Li et al. 2017 (Levenberg-Marquardt). "
                    "The boundary samples' weight, the hidden size and the regularization are chosen by "
                    "cross-validation on the measured samples; an ensemble gives the uncertainty band. Every check "
                    "runs before anything is written.",
    )
    parser.add_argument("chart", metavar="CHART_DIR", help="chart folder (chart.toml, flow.csv, efficiency.csv, ...)")
    parser.add_argument("--out", required=True, help="nets.json to write")
    parser.add_argument("--hidden", default="auto",
                        help=f"hidden logsig neurons per net, an integer in [{HIDDEN_RANGE[0]}, {HIDDEN_RANGE[1]}] "
                             "(5 = the paper's 2-5-1 net), or 'auto' (default): chosen among 5-10 by cross-validation")
    parser.add_argument("--boundary-weight", default="auto",
                        help="weight of the derived boundary samples in (0, 1], or 'auto' (default: chosen by "
                             "cross-validation on the measured samples)")
    parser.add_argument("--regularization", default="auto",
                        help="weight decay lambda in [0, 1], or 'auto' (default: chosen by cross-validation)")
    parser.add_argument("--stops", default="auto",
                        help="the Levenberg-Marquardt stops: 'paper' (trainlm's goal 1e-5 on the normalized MSE, 6 "
                             "validation fails), 'longer' (goal 1e-7, 100 fails) or 'auto' (default: chosen between "
                             "them by cross-validation)")
    parser.add_argument("--ensemble", type=int, default=DEFAULT_ENSEMBLE,
                        help=f"ensemble members for the uncertainty band, {ENSEMBLE_RANGE[0]}-{ENSEMBLE_RANGE[1]} "
                             f"(default {DEFAULT_ENSEMBLE}; 0: a single net, no band)")
    parser.add_argument("--restarts", type=int, default=10,
                        help="random initialisations of the final net when --ensemble 0 (default 10)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the splits and initialisations (flow net: seed, torque net: seed + 1)")
    parser.add_argument("--allow-implausible", action="store_true",
                        help="report the efficiency plausibility check as a warning instead of an error (on a thin "
                             "chart, too few lines, points or contours, it is always a warning)")
    parser.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    parser.add_argument("--record-time", action="store_true",
                        help="store training times in nets.json (off by default: the file is then byte-for-byte "
                             "reproducible)")
    add_extension_arguments(parser)
    parser.set_defaults(func=run)


def _auto_float(option: str, value: str, low: float, high: float, *, open_low: bool):
    import math

    from hillchart.errors import InputError

    if value == "auto":
        return None
    bounds = f"{'(' if open_low else '['}{low}, {high}]"
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{option} must be a number in {bounds} or 'auto', got {value!r}") from None
    if not math.isfinite(number) or number > high or number < low or (open_low and number == low):
        raise InputError(f"{option} must be a number in {bounds} or 'auto', got {value!r}")
    return number


def _stops(value: str) -> dict:
    from hillchart.errors import InputError
    from hillchart.nets.training import LONGER_STOPS, PAPER_STOPS

    stops = {"auto": {}, "paper": dict(PAPER_STOPS), "longer": dict(LONGER_STOPS)}
    if value not in stops:
        raise InputError(f"--stops must be one of {', '.join(stops)}, got {value!r}")
    return stops[value]


def parse_options(args: argparse.Namespace) -> dict:
    """Validated training options (raises InputError naming the option)."""
    hidden = None if args.hidden == "auto" else int_in("--hidden", args.hidden, *HIDDEN_RANGE, auto=True)
    return {
        "stops": _stops(args.stops),
        "hidden": hidden,
        "boundary_weight": _auto_float("--boundary-weight", args.boundary_weight, 0.0, 1.0, open_low=True),
        "regularization": _auto_float("--regularization", args.regularization, 0.0, 1.0, open_low=False),
        "ensemble": int_in("--ensemble", args.ensemble, *ENSEMBLE_RANGE),
        "restarts": int_in("--restarts", args.restarts, 1, 1000),
        "seed": int_in("--seed", args.seed, *SEED_RANGE),
    }


def run(args: argparse.Namespace) -> int:
    from hillchart.errors import InputError
    from hillchart.extension.extend import extend_samples
    from hillchart.nets.training import train_nets
    from hillchart.extension.plausibility import efficiency_plausibility, thin_chart_notes

    options = parse_options(args)
    extension = extension_options(args)
    out = args.outputs.file("--out", args.out)  # checked now, renamed into place when everything succeeded
    chart = load_chart_reporting_warnings(args.chart, extension.boundaries)
    args.outputs.check_reads()  # --out one of the chart's files: refused before training, not after
    with warnings.catch_warnings(record=True) as caught:  # printed below as warning: lines, after the table
        warnings.simplefilter("always")
        extended = extend_samples(chart, extension)

    def progress(message: str) -> None:
        if not args.quiet:
            print(f"  [{time.perf_counter() - start:5.1f} s] {message}", file=sys.stderr, flush=True)

    start = time.perf_counter()
    nets = train_nets(extended, hidden=options["hidden"], boundary_weight=options["boundary_weight"],
                      regularization=options["regularization"], ensemble=options["ensemble"],
                      restarts=options["restarts"], seed=options["seed"], record_time=args.record_time,
                      progress=progress, **options["stops"])
    elapsed = time.perf_counter() - start
    nets.training["chart"] = chart.info.name
    nets.training["extension"] = {
        "runaway": extension.runaway, "zero_opening": extension.zero_opening, "zero_speed": extension.zero_speed,
        "extrapolation_degree": extension.extrapolation_degree, "zero_opening_k": extension.zero_opening_k,
        "boundaries": extension.boundaries, "k_zero_opening_used": extended.k_zero_opening,
    }
    if extended.boundary_model is not None:
        model = extended.boundary_model.to_dict()
        nets.training["extension"]["model_misfit_pct"] = model.pop("misfit_pct")
        nets.training["extension"].update(model)
    if args.record_time:
        nets.training["time_s"] = round(elapsed, 3)
    import numpy as np

    from simulate.loop.domain import convex_hull

    # the digitized region travels with the nets: a run judges its domain wherever the nets.json is kept
    hull = convex_hull(np.column_stack((chart.flow_n11, chart.flow_opening)))
    nets.digitized_region = hull if len(hull) >= 3 else None
    problem = efficiency_plausibility(nets, chart)  # checked before anything is written
    thin = thin_chart_notes(chart)
    if problem and not (args.allow_implausible or thin):
        raise InputError(f"{problem} (--allow-implausible writes the nets anyway)")
    nets.save(out)
    for note in thin:
        print(f"warning: thin chart: {note}")
    for w in caught:
        print(f"warning: {w.message}")
    if problem:
        print(f"warning: {problem}" + ("; on this thin chart digitize what the warnings above name" if thin else ""))
    hidden = "selected" if options["hidden"] is None else options["hidden"]
    print(f"chart {chart.info.name!r}: {len(extended.value)} extended samples ({extension.boundaries} boundaries); "
          f"2-H-1 logsig nets (H {hidden}), Levenberg-Marquardt, ensemble of {options['ensemble']} (seed "
          f"{options['seed']})")
    print(format_training_table(nets))
    if extended.boundary_model is not None:
        print(f"physical turbine model: {extended.boundary_model.describe()}")
    if extended.extrapolation is not None:
        print(f"extrapolation: {extended.extrapolation.summary()}")
    print(f"training time (both nets): {elapsed:.2f} s")
    print(f"wrote {args.out}")
    return 0


def format_training_table(nets) -> str:
    """Text table of the training record: one row per net, with what the selection chose."""
    header = (f"{'net':<7} {'H':>2} {'bnd w':>6} {'lambda':>7} {'CV MSE':>9} {'meas. RMS':>10} {'meas. max':>10} "
              f"{'unit':<6} {'members':>7} {'time s':>6}")
    lines = [header, "-" * len(header)]
    units = {"flow": "m^3/s", "torque": "N*m"}
    for key in ("flow", "torque"):
        rec = nets.training[key]
        sel = rec.get("selection", {})
        est = getattr(nets, "estimators", {}).get(key)
        seconds = f"{est.fit_time_s_:6.2f}" if est is not None else "     -"
        cv = sel.get("cv_mse_best")
        lines.append(f"{key:<7} {str(sel.get('hidden', '-')):>2} {str(sel.get('boundary_weight', '-')):>6} "
                     f"{str(sel.get('regularization', '-')):>7} {'-' if cv is None else format(cv, '.3g'):>9} "
                     f"{rec.get('measured_rms_error', float('nan')):>10.4g} "
                     f"{rec.get('measured_max_abs_error', float('nan')):>10.4g} {units[key]:<6} "
                     f"{len(nets.ensemble):>7} {seconds}")
    lines.append("(H, boundary weight, lambda: chosen by 5-fold CV on the measured samples unless given; CV MSE on "
                 "outputs mapped to [-1, 1]; errors of the point net at the measured samples in physical units)")
    for key in ("flow", "torque"):
        distilled = nets.training[key].get("distillation") or {"tried": []}
        if len(distilled["tried"]) > 1:
            first = distilled["tried"][0]
            lines.append(f"{key}: the point net has H = {distilled['hidden']}: with H = {first['hidden']} it "
                         f"followed the members' median only within {first['rms_from_median']:.3g} {units[key]} "
                         f"RMS (bound {distilled['bound']:.3g} {units[key]})")
    return "\n".join(lines)
