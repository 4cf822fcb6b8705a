"""``hillsim demo [--out DIR] [--fast] [--quiet]``: the whole pipeline on the shipped synthetic chart."""

from __future__ import annotations

import argparse


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="run the whole pipeline on the shipped synthetic chart and write report.html",
        description="Extend the shipped synthetic chart, train the nets (or reuse the shipped ones with --fast), "
        "draw the hill chart, simulate load rejection and frequency steps, linearize and identify; write every "
        "result and a self-contained report.html into DIR.",
    )
    parser.add_argument("--out", default="hillsim_demo", help="output folder (default ./hillsim_demo)")
    parser.add_argument("--fast", action="store_true", help="reuse the shipped nets.json instead of training")
    parser.add_argument("--quiet", action="store_true", help="no progress and no summary table")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hillsim.demo import format_summary, run_demo

    summary = run_demo(args.out, fast=args.fast, progress=not args.quiet, outputs=args.outputs)
    if not args.quiet:
        print(format_summary(summary))
        print(f"wrote {args.out}/report.html")
    return 0
