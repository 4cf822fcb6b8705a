"""The ``hillsim`` command line.

Each sub-command lives in its own module under :mod:`hillsim.commands` and exposes ``register(subparsers)``,
which adds its parser and sets ``func`` (called with the parsed namespace, returns an exit code).

What every command gets from here:

- ``args.outputs``, an :class:`hillsim.outputs.OutputSet`: a command declares its output files and folders with it
  before working (checked, locked, written under temporary names); they are put in place when the command returns 0
  and removed on any error, interrupt or termination, so nothing partial is left behind;
- ``--quiet`` (added when the command does not define it) and progress lines on stderr (:mod:`hillsim.progress`);
- the same conventions in ``--help``: defaults shown, the same metavar for the same thing (:data:`METAVARS`);
- exit codes: 0 success; 2 bad input, unusable output or numerical failure (one line ``hillsim CMD: error: ...``,
  no traceback); 130 interrupted (Ctrl-C, also when the interrupt hit code that swallows exceptions, such as a
  finalizer during numba compilation); 143 terminated (SIGTERM).
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from contextlib import contextmanager

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
    "hillsim.commands.sweep",
    "hillsim.commands.optimize_closure",
    "hillsim.commands.report",
    "hillsim.commands.demo",
    "hillsim.commands.fccm",
)

#: One metavar per kind of argument, whichever command takes it (``dest`` -> metavar; a command's own metavar is
#: replaced so ``--help`` names the same thing the same way everywhere).
METAVARS = {"chart": "CHART_DIR", "samples": "CHART_DIR", "plant": "PLANT_TOML", "nets": "NETS_JSON",
            "data": "SERIES_CSV"}
#: ``--out`` of each command: a folder (DIR) or the file type it writes.
OUT_METAVARS = {"run": "DIR", "identify": "DIR", "demo": "DIR", "extend": "CSV", "train": "NETS_JSON",
                "chart": "PNG"}

EXIT_INPUT = 2
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143


class HelpFormatter(argparse.HelpFormatter):
    """Shows ``(default: X)`` after an option's help unless the help already states its default, the default is
    None/False (nothing to say) or the argument is a required positional."""

    def _get_help_string(self, action):
        text = action.help or ""
        if ("default" in text.lower() or any(action.default is v for v in (None, False, argparse.SUPPRESS))
                or action.required or not action.option_strings):
            return text
        return text + " (default: %(default)s)"


class Terminated(BaseException):
    """SIGTERM arrived (raised from the signal handler so outputs are cleaned up on the way out)."""


def _version() -> str:
    from hillsim import __version__

    return __version__


def _command_module(argv: list[str]) -> str | None:
    """The module of the sub-command ``argv`` names (its first word not starting with ``-``), when it is one of
    :data:`COMMAND_MODULES` (``optimize-closure`` -> ``hillsim.commands.optimize_closure``); else None."""
    word = next((a for a in argv if not a.startswith("-")), None)
    if word is None or argv.index(word) != 0:  # only ``hillsim COMMAND ...``; anything else parses in full
        return None
    module = "hillsim.commands." + word.replace("-", "_")
    return module if module in COMMAND_MODULES else None


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The ``hillsim`` parser with every command, or with the one command module ``only`` (what ``main`` uses when
    the command line names a command: importing every command module and its dependencies costs a third of a
    second of start-up)."""
    parser = argparse.ArgumentParser(
        prog="hillsim",
        description="Francis turbine hill chart -> BP nets -> nonlinear transient simulation.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"hillsim {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES if only is None else (only,):
        importlib.import_module(name).register(subparsers)
    for name, sub in subparsers.choices.items():
        _harmonize(name, sub)
    return parser


def _harmonize(name: str, parser: argparse.ArgumentParser) -> None:
    """Help conventions shared by every command (see the module docstring)."""
    parser.formatter_class = HelpFormatter
    for action in parser._actions:
        if action.dest in METAVARS and isinstance(action.metavar, (str, type(None))):
            action.metavar = METAVARS[action.dest]
        elif action.dest == "out" and action.option_strings and (name in OUT_METAVARS or action.metavar is None):
            action.metavar = OUT_METAVARS.get(name) or _out_metavar(action.help or "")
    if "quiet" not in {a.dest for a in parser._actions}:
        parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


def _out_metavar(help_text: str) -> str:
    """``--out``'s metavar for a command not in :data:`OUT_METAVARS`: DIR for a folder, else the file type its help
    names, else PATH."""
    text = help_text.lower()
    if "folder" in text or "director" in text:
        return "DIR"
    for kind in ("png", "csv", "json", "html", "toml"):
        if kind in text:
            return kind.upper()
    return "PATH"


@contextmanager
def _signals(state: dict):
    """SIGINT -> KeyboardInterrupt, SIGTERM -> :class:`Terminated`, each also recorded in ``state["signal"]`` (a
    KeyboardInterrupt raised inside a finalizer is swallowed by Python; the record still ends the command)."""

    def handler(signum, frame):
        state["signal"] = signum
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        raise Terminated(signum)

    previous = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, handler)
    except ValueError:  # not the main thread: leave the handlers alone
        pass
    try:
        yield state
    finally:
        for sig, old in previous.items():
            # once a signal has ended the command, a repeat of it (or one still pending) must not turn the exit
            # code 130/143 into a death by signal on the way out: ignore it from here on
            signal.signal(sig, signal.SIG_IGN if state["signal"] is not None else old)


def _output_option(outputs, exc: OSError) -> str | None:
    """The option whose output the failing path belongs to (temporary or final), if any."""
    name = getattr(exc, "filename", None)
    if not name:
        return None
    path = os.path.abspath(str(name))
    for target in outputs._targets:
        for root in (target.final, target.temporary):
            root = os.path.abspath(root)
            if path == root or path.startswith(root + os.sep):
                return f"{target.option} {str(target.final)!r}"
    return None


def run_command(args: argparse.Namespace) -> int:
    """Run ``args.func(args)`` with the shared output set, progress, error and signal handling; the exit code."""
    from hillsim import progress
    from hillsim.outputs import OutputSet

    command = args.command
    outputs = OutputSet(command)
    args.outputs = outputs
    progress.configure(enabled=not getattr(args, "quiet", False))
    state = {"signal": None}

    def fail(message: str, code: int) -> int:
        outputs.discard()
        progress.current().abort()
        print(f"hillsim {command}: {message}", file=sys.stderr)
        return code

    with _signals(state):
        try:
            code = int(args.func(args) or 0)
            if state["signal"] is not None:  # a signal swallowed on the way (e.g. in a finalizer)
                raise Terminated() if state["signal"] == signal.SIGTERM else KeyboardInterrupt
            if code == 0:
                outputs.commit()
            else:
                outputs.discard()
            return code
        except BaseException as exc:
            # a signal wins over whatever it turned into on the way (a library may wrap the KeyboardInterrupt)
            if isinstance(exc, Terminated) or state["signal"] == signal.SIGTERM:
                return fail("terminated; no outputs written", EXIT_TERMINATED)
            if isinstance(exc, KeyboardInterrupt) or state["signal"] is not None:
                where = f" {exc.args[0]}" if isinstance(exc, KeyboardInterrupt) and exc.args else ""
                return fail(f"interrupted{where}; no outputs written", EXIT_INTERRUPTED)
            if isinstance(exc, HillsimError):
                return fail(f"error: {exc}", EXIT_INPUT)
            if isinstance(exc, OSError):
                where = _output_option(outputs, exc)
                reason = exc.strerror or str(exc)
                if where:
                    return fail(f"error: {where}: cannot write {exc.filename!s}: {reason}", EXIT_INPUT)
                target = f"{exc.filename}: " if exc.filename else ""
                return fail(f"error: {target}{reason}", EXIT_INPUT)
            outputs.discard()
            raise


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(only=_command_module(argv))
    args = parser.parse_args(argv)
    return run_command(args)


def console_main() -> None:
    """The ``hillsim`` executable: :func:`main`, exiting with its code.

    After an interrupt the process ends through ``os._exit`` (streams flushed, outputs already discarded): CPython
    3.11 marks a KeyboardInterrupt that passed through code run by ``exec`` of a string (numba's generated wrappers
    are) as unhandled even when this module caught it, and then ends the process by SIGINT at exit instead of
    with the code 130 the CLI returned (seen about once in 15 interrupted runs)."""
    code = main()
    if code in (EXIT_INTERRUPTED, EXIT_TERMINATED):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    console_main()
