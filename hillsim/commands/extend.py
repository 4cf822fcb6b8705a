"""``hillsim extend CHART --out extended.csv [--plot ext.png]``: torque from efficiency and boundary extension."""

from __future__ import annotations

import argparse
import warnings


def add_extension_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of :class:`hillchart.extension.extend.ExtensionOptions` (shared by ``extend`` and ``train``)."""
    group = parser.add_argument_group("extension (Li et al. 2017, sections 2.1 and 2.6)")
    group.add_argument("--no-runaway", action="store_true", help="do not add the runaway boundary")
    group.add_argument("--no-zero-opening", action="store_true", help="do not add the zero-opening boundary")
    group.add_argument("--no-zero-speed", action="store_true", help="do not add the zero-speed boundary")
    group.add_argument("--boundaries", choices=("model", "polynomial"), default="model",
                       help="where the zero-opening / zero-speed (and missing runaway) samples come from: a physical "
                            "turbine model fitted to the chart (default) or the paper's polynomial extrapolations")
    group.add_argument("--no-silent-regions", action="store_true",
                       help="leave the fitted model out where the chart is silent: no samples there (small openings "
                            "below the lowest line, overspeed up to runaway) and, for train, no hand-over of the nets "
                            "to the model below the lowest line (only with --boundaries model)")
    group.add_argument("--degree", type=int, default=2,
                       help="degree of the polynomial boundary extrapolations, 1-4 (default 2)")
    group.add_argument(
        "--zero-opening-k", type=float, default=None,
        help="K of M11 = -K N11^2 at zero opening, N*m/(r/min)^2 (default: fitted from the data)",
    )


def extension_options(args: argparse.Namespace):
    from hillchart.extension.extend import ExtensionOptions

    return ExtensionOptions(
        runaway=not args.no_runaway,
        zero_opening=not args.no_zero_opening,
        zero_speed=not args.no_zero_speed,
        extrapolation_degree=args.degree,
        zero_opening_k=args.zero_opening_k,
        boundaries=args.boundaries,
        silent_regions=not args.no_silent_regions,
    )


def load_chart_reporting_warnings(folder, boundaries: str = "polynomial"):
    """:func:`hillchart.io.samples.load_chart`, printing its warnings (e.g. no runaway.csv) as ``warning: ...``.

    With ``boundaries="model"`` a missing runaway.csv is no warning: the fitted turbine model gives the runaway
    samples (a note says so)."""
    from hillchart.io.samples import load_chart

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        chart = load_chart(folder)
    for w in caught:
        if boundaries == "model" and "runaway.csv is absent" in str(w.message):
            print("note: no runaway.csv: the runaway samples come from the turbine model fitted to the chart")
        else:
            print(f"warning: {w.message}")
    return chart


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "extend",
        help="compute torque samples and extend them to runaway, zero opening and zero speed",
        description="Load a chart folder, compute M11 from efficiency and add the boundary samples.",
    )
    parser.add_argument("chart", metavar="CHART", help="chart folder (chart.toml, flow.csv, efficiency.csv, ...)")
    parser.add_argument("--out", required=True, help="CSV to write: target,origin,n11,opening,value")
    parser.add_argument("--plot", default=None, help="PNG of the samples coloured by origin")
    add_extension_arguments(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hillchart.extension.extend import extend_samples

    from hillsim.outputs import check_picture_suffix

    check_picture_suffix("--plot", args.plot)
    out, plot = args.outputs.file("--out", args.out), args.outputs.file("--plot", args.plot)  # checked first
    options = extension_options(args)
    chart = load_chart_reporting_warnings(args.chart, options.boundaries)
    with warnings.catch_warnings(record=True) as caught:  # printed below as warning: lines
        warnings.simplefilter("always")
        extended = extend_samples(chart, options)
    extended.to_csv(out)
    print(f"wrote {args.out}: {len(extended.value)} samples")
    for target, per_origin in extended.counts().items():
        print(f"  {target}: " + ", ".join(f"{o} {n}" for o, n in per_origin.items()))
    if extended.k_zero_opening is not None:
        print(f"  zero opening: M11 = -K N11^2 with K = {extended.k_zero_opening:.6g} N*m/(r/min)^2")
    if extended.boundary_model is not None:
        model = extended.boundary_model
        print(f"  boundaries from the physical turbine model fitted to the chart: {model.describe()}")
    print(f"  efficiency surface: polynomial of degree {extended.efficiency_surface.degree}, "
          f"cross-validated RMSE {extended.efficiency_surface.cv_rmse:.4f}")
    for w in caught:
        print(f"warning: {w.message}")
    if args.plot:
        extended.plot(plot)
        print(f"wrote {args.plot}")
    return 0
