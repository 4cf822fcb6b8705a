"""The ``hillsim`` command line.

Each sub-command lives in its own module under :mod:`hillsim.commands` and exposes ``register(subparsers)``,
which adds its parser and sets ``func`` (called with the parsed namespace, returns an exit code).
"""

from __future__ import annotations

import argparse
import importlib
import sys

from hillchart.errors import HillsimError

#: Sub-command modules, in the order ``hillsim --help`` lists them.
COMMAND_MODULES = (
    "hillsim.commands.synth",
    "hillsim.commands.extend",
    "hillsim.commands.train",
    "hillsim.commands.chart",
    "hillsim.commands.linearize",
    "hillsim.commands.run",
    "hillsim.commands.identify",
    "hillsim.commands.demo",
    "hillsim.commands.fccm",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hillsim",
        description="Francis turbine hill chart -> BP nets -> nonlinear transient simulation.",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (HillsimError, FileNotFoundError) as exc:
        print(f"hillsim {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
