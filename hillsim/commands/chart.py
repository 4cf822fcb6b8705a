"""``hillsim chart nets.json --out chart.png [--samples CHART_DIR]``: hill chart, surfaces and errors of the nets."""

from __future__ import annotations

import argparse
import warnings

from hillsim import progress


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "chart",
        help="draw a manufacturer-style hill chart and the Q11/M11 surfaces from nets.json",
        description="Hill chart from the nets (N11 vs Q11, iso-efficiency contours, iso-opening lines, runaway "
                    "curve), filled contours of Q11(N11, a) and M11(N11, a) and, with --samples, the digitized "
                    "points and the net errors at every extended sample (Li et al. 2017, Figs. 5-8).",
    )
    parser.add_argument("nets", metavar="NETS_JSON", help="nets.json written by 'hillsim train'")
    parser.add_argument("--out", required=True, help="PNG to write")
    parser.add_argument("--samples", metavar="CHART_DIR", default=None,
                        help="chart folder whose samples are overlaid (and extended, as recorded in nets.json, "
                             "for the error plots)")
    parser.add_argument("--title", default=None, help="title of the hill-chart panel")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hillchart.nets.chartplot import chart_figure
    from hillchart.nets.hill_nets import load_nets

    from hillsim.outputs import check_picture_suffix

    check_picture_suffix("--out", args.out)
    out = args.outputs.file("--out", args.out)  # checked now, renamed into place at the end
    nets = load_nets(args.nets)
    chart = extended = None
    if args.samples is not None:
        from hillchart.extension.extend import extend_samples
        from hillchart.io.samples import load_chart

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            chart = load_chart(args.samples)
        for w in caught:
            print(f"warning: {w.message}")
        if chart.info.opening_unit != nets.opening_unit:
            from hillchart.errors import InputError

            raise InputError(f"--samples: the chart's opening_unit is {chart.info.opening_unit!r} but the nets "
                             f"were trained with {nets.opening_unit!r}")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            extended = extend_samples(chart, _recorded_options(nets))
        for w in caught:
            print(f"warning: {w.message}")
    title = args.title or (f"hill chart of {chart.info.name} from its nets" if chart is not None else None)
    progress.start("drawing the hill chart, surfaces and errors")
    chart_figure(nets, samples=chart, extended=extended, path=out, title=title)
    progress.done()
    print(f"wrote {args.out}")
    return 0


def _recorded_options(nets):
    """The extension options recorded by ``hillsim train`` (defaults when the record has none)."""
    from hillchart.extension.extend import ExtensionOptions

    if "extension" not in nets.training:
        return ExtensionOptions()
    rec = nets.training["extension"]
    keys = ("runaway", "zero_opening", "zero_speed", "extrapolation_degree", "zero_opening_k", "boundaries")
    options = {k: rec[k] for k in keys if k in rec}
    options.setdefault("boundaries", "polynomial")  # files trained before the model boundaries existed
    return ExtensionOptions(**options)
