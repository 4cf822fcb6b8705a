"""``hillsim train CHART_DIR --out nets.json``: extend the chart's samples and train the flow and torque nets."""

from __future__ import annotations

import argparse
import time

from hillsim import progress

from hillsim.commands.extend import add_extension_arguments, extension_options, load_chart_reporting_warnings


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "train",
        help="train the Q11 and M11 nets (2-H-1 logsig, Levenberg-Marquardt) and write nets.json",
        description="Load a chart folder, extend its samples (torque from efficiency, runaway, zero opening, zero "
                    "speed) and train the flow net Q11(N11, a) and the torque net M11(N11, a) as in the BP "
                    "hill-chart paper (Levenberg-Marquardt, 80/20 split stratified by origin, best of N restarts).",
    )
    parser.add_argument("chart", metavar="CHART_DIR", help="chart folder (chart.toml, flow.csv, efficiency.csv, ...)")
    parser.add_argument("--out", required=True, help="nets.json to write")
    parser.add_argument("--hidden", type=int, default=5, help="hidden logsig neurons per net (default 5)")
    parser.add_argument("--restarts", type=int, default=10,
                        help="random initialisations per net; the best validation error is kept (default 10)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the split and initialisations (flow net: seed, torque net: seed + 1)")
    parser.add_argument("--record-time", action="store_true",
                        help="store training times in nets.json (off by default: the file is then byte-for-byte "
                             "reproducible)")
    add_extension_arguments(parser)
    parser.set_defaults(func=run)


def _check_int(option: str, value: int, low: int) -> None:
    from hillchart.errors import InputError

    if value < low:
        raise InputError(f"{option} must be an integer >= {low}, got {value}")


def run(args: argparse.Namespace) -> int:
    from hillchart.extend import extend_samples
    from hillchart.nets import train_nets

    _check_int("--hidden", args.hidden, 1)
    _check_int("--restarts", args.restarts, 1)
    _check_int("--seed", args.seed, 0)
    out = args.outputs.file("--out", args.out)  # checked now, renamed into place when everything succeeded
    options = extension_options(args)
    chart = load_chart_reporting_warnings(args.chart)
    extended = extend_samples(chart, options)
    start = time.perf_counter()
    progress.start(f"training both nets ({args.restarts} restarts each)")
    nets = train_nets(extended, hidden=args.hidden, restarts=args.restarts, seed=args.seed,
                      record_time=args.record_time)
    elapsed = time.perf_counter() - start
    progress.done()
    nets.training["chart"] = chart.info.name
    nets.training["extension"] = {
        "runaway": options.runaway, "zero_opening": options.zero_opening, "zero_speed": options.zero_speed,
        "extrapolation_degree": options.extrapolation_degree, "zero_opening_k": options.zero_opening_k,
        "k_zero_opening_used": extended.k_zero_opening,
    }
    if args.record_time:
        nets.training["time_s"] = round(elapsed, 3)
    nets.save(out)
    warning = efficiency_plausibility_warning(nets, chart)
    if warning:
        print(f"warning: {warning}")
    print(f"chart {chart.info.name!r}: {len(extended.value)} extended samples; 2-{args.hidden}-1 logsig nets, "
          f"best of {args.restarts} Levenberg-Marquardt runs each (seed {args.seed})")
    print(format_training_table(nets))
    print(f"training time (both nets): {elapsed:.2f} s")
    print(f"wrote {args.out}")
    return 0


def format_training_table(nets) -> str:
    """Text table of the training record: one row per net."""
    header = (f"{'net':<7} {'n_train':>7} {'n_val':>5} {'train MSE':>10} {'val MSE':>10} {'train max|e|':>13} "
              f"{'val max|e|':>12} {'unit':<6} {'epochs':>6} {'stop':<10} {'time s':>6}")
    lines = [header, "-" * len(header)]
    units = {"flow": "m^3/s", "torque": "N*m"}
    for key in ("flow", "torque"):
        rec = nets.training[key]
        est = getattr(nets, "estimators", {}).get(key)
        seconds = f"{est.fit_time_s_:6.2f}" if est is not None else "     -"
        lines.append(f"{key:<7} {rec['n_train']:>7} {rec['n_validation']:>5} {rec['train_mse_normalized']:>10.3g} "
                     f"{rec['validation_mse_normalized']:>10.3g} {rec['train_max_abs_error']:>13.4g} "
                     f"{rec['validation_max_abs_error']:>12.4g} {units[key]:<6} {rec['epochs']:>6} "
                     f"{rec['stop_reason']:<10} {seconds}")
    lines.append("(MSE on outputs mapped to [-1, 1], as trainlm's goal; max |e| in physical units)")
    return "\n".join(lines)


def efficiency_plausibility_warning(nets, chart, *, margin: float = 0.03) -> str | None:
    """A warning when the nets' efficiency inside the digitized region exceeds the chart's best contour by more
    than ``margin`` (the flow and torque nets then disagree: usually a poor boundary extrapolation), else None."""
    import numpy as np

    from hillchart.chartplot import efficiency_from_characteristics
    from hillchart.nets import measured_region_mask

    n11, opening = np.meshgrid(np.linspace(chart.flow_n11.min(), chart.flow_n11.max(), 60),
                               np.linspace(chart.flow_opening.min(), chart.flow_opening.max(), 60))
    inside = measured_region_mask(chart.flow_n11, chart.flow_opening, n11, opening)
    eta = efficiency_from_characteristics(nets, n11[inside], opening[inside])
    best_net, best_chart = float(np.nanmax(eta)), float(chart.eff_efficiency.max())
    if best_net <= best_chart + margin:
        return None
    return (f"the nets' efficiency reaches {best_net:.3f} inside the digitized region, the chart's best contour is "
            f"{best_chart:.3f}: the flow and torque nets disagree there; check the extended samples "
            "(hillsim extend --plot), e.g. train with --no-zero-speed when the opening lines start far from N11 = 0")
