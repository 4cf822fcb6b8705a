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
  no traceback); 3 ``hillsim report`` found a limit FAILed (the report is written); 130 interrupted (Ctrl-C, also
  when the interrupt hit code that swallows exceptions, such as a finalizer during numba compilation); 143 terminated
  (SIGTERM).
"""

from __future__ import annotations

import argparse
import errno
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
    "hillsim.commands.four_quadrant",
)

#: One metavar per kind of argument, whichever command takes it (``dest`` -> metavar; a command's own metavar is
#: replaced so ``--help`` names the same thing the same way everywhere).
METAVARS = {"chart": "CHART_DIR", "samples": "CHART_DIR", "plant": "PLANT_TOML", "nets": "NETS_JSON",
            "data": "SERIES_CSV"}
#: ``--out`` of each command: a folder (DIR) or the file type it writes.
OUT_METAVARS = {"run": "DIR", "identify": "DIR", "demo": "DIR", "extend": "CSV", "train": "NETS_JSON",
                "chart": "PNG"}

EXIT_INPUT = 2
#: ``hillsim report``: a guarantee limit FAILs in some load case; the report is written all the same.
EXIT_LIMIT_FAIL = 3
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
    """SIGTERM, SIGHUP (terminal closed) or SIGXCPU (CPU time limit) arrived (raised from the signal handler so
    outputs are cleaned up on the way out); ``args[0]`` is the signal number when known."""


#: Signals that end a command like SIGTERM (exit code 128 + the signal number; SIGINT ends it with 130).
TERMINATING_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP", "SIGXCPU")
                            if hasattr(signal, name))


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
    for action in parser._actions:
        if action.dest in OUTPUT_DESTS:
            action.type = _non_empty(action.type)
    if "quiet" not in {a.dest for a in parser._actions}:
        parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


#: Destinations of output paths: an empty value is refused by the parser (``Path("")`` would silently be ".").
OUTPUT_DESTS = ("out", "out_dir", "plot", "map")


def _non_empty(convert):
    def parse(text: str):
        if not text.strip():
            raise argparse.ArgumentTypeError(f"is empty ({text!r}); give a path")
        return text if convert is None else convert(text)

    parse.__name__ = getattr(convert, "__name__", "path")  # argparse names the type in its messages
    return parse


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


#: Delay (s) before a signal that arrived inside a callback from native code is delivered again.
NATIVE_CALLBACK_RETRY_S = 0.02


def _in_native_callback(frame) -> bool:
    """True when ``frame`` runs inside a callback that native code made into Python: llvmlite's object cache while
    numba compiles (``llvmlite/binding``), where an exception raised by a signal handler cannot propagate."""
    while frame is not None:
        if "/llvmlite/binding/" in frame.f_code.co_filename.replace("\\", "/"):
            return True
        frame = frame.f_back
    return False


@contextmanager
def _signals(state: dict):
    """SIGINT -> KeyboardInterrupt, SIGTERM/SIGHUP/SIGXCPU -> :class:`Terminated`, each also recorded in
    ``state["signal"]`` (a KeyboardInterrupt raised inside a finalizer is swallowed by Python; the record still
    ends the command). While ``state["deferred"]`` is set (cleaning up, or putting the outputs in place) a signal is
    only recorded: a second Ctrl-C during the cleanup must not cut the cleanup short nor print a traceback."""

    def handler(signum, frame):
        if state.get("deferred"):
            if state["signal"] is None:
                state["signal"] = signum
            return
        state["signal"] = signum
        if _in_native_callback(frame):
            # an exception cannot leave a callback from native code (Python prints "Exception ignored" and a
            # traceback, and goes on): the same signal again once the callback has returned
            import threading

            timer = threading.Timer(NATIVE_CALLBACK_RETRY_S, os.kill, (os.getpid(), signum))
            timer.daemon = True
            timer.start()
            return
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        raise Terminated(signum)

    previous = {}
    try:
        for sig in (signal.SIGINT, *TERMINATING_SIGNALS):
            if sig == getattr(signal, "SIGHUP", None) and signal.getsignal(sig) is signal.SIG_IGN:
                continue  # nohup: the user asked the run to survive the terminal closing
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
        for root in (target.final, target.real, target.temporary):
            root = os.path.abspath(root)
            if path == root or path.startswith(root + os.sep):
                return f"{target.option} {str(target.final)!r}"
    return None


#: errno values of a failed write (full disk, quota, file too large, read-only file system).
_WRITE_ERRNOS = {getattr(errno, name) for name in ("ENOSPC", "EDQUOT", "EFBIG", "EROFS") if hasattr(errno, name)}

#: Namespace entries that are never paths.
_NOT_PATHS = {"func", "outputs", "command", "_options"}


def input_paths(args: argparse.Namespace) -> list[tuple[str, str]]:
    """``(option, path)`` for every argument value naming an existing file or folder (the command's inputs; an
    output option's own earlier result is skipped by :class:`~hillsim.outputs.OutputSet` by its option name)."""
    out = []
    for dest, value in vars(args).items():
        if dest in _NOT_PATHS:
            continue
        values = value if isinstance(value, (list, tuple)) else [value]
        for v in values:
            if isinstance(v, (str, os.PathLike)) and not isinstance(v, bool):
                text = os.fspath(v)
                try:
                    exists = text.strip() != "" and os.path.lexists(text)
                except (ValueError, OSError):  # a NUL byte, a name too long
                    exists = False
                if exists:
                    names = getattr(args, "_options", {})
                    out.append((names.get(dest) or "--" + dest.replace("_", "-"), text))
    return out


def _option_names(parser: argparse.ArgumentParser, args: argparse.Namespace) -> dict[str, str]:
    """``{dest: how --help names it}`` for the command ``args`` runs (``--data``, ``CHART_DIR``)."""
    sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
    command = sub.choices.get(args.command) if sub is not None else None
    names = {}
    for action in (command._actions if command is not None else []):
        names[action.dest] = (max(action.option_strings, key=len) if action.option_strings
                              else str(action.metavar or action.dest.upper()))
    return names


def run_command(args: argparse.Namespace) -> int:
    """Run ``args.func(args)`` with the shared output set, progress, error and signal handling; the exit code."""
    from hillsim import progress
    from hillsim.outputs import OutputSet

    command = args.command
    outputs = OutputSet(command, inputs=input_paths(args))
    args.outputs = outputs
    progress.configure(enabled=not getattr(args, "quiet", False))
    state = {"signal": None, "deferred": False}

    def fail(message: str, code: int) -> int:
        state["deferred"] = True  # a repeated signal during the cleanup is recorded, not raised
        outputs.discard()
        progress.current().abort()
        print(f"hillsim {command}: {message}", file=sys.stderr)
        return code

    def terminated_code() -> int:
        sig = state["signal"]
        return EXIT_TERMINATED if sig in (None, signal.SIGTERM) else 128 + int(sig)

    with _signals(state):
        try:
            code = int(args.func(args) or 0)
            if state["signal"] is not None:  # a signal swallowed on the way (e.g. in a finalizer)
                raise KeyboardInterrupt if state["signal"] == signal.SIGINT else Terminated(state["signal"])
            if code == 0:
                state["deferred"] = True  # putting the outputs in place is not cut in half by a signal
                outputs.commit()
                if state["signal"] is not None:
                    name = "interrupted" if state["signal"] == signal.SIGINT else "terminated"
                    print(f"hillsim {command}: {name} after the outputs were written", file=sys.stderr)
                    return EXIT_INTERRUPTED if state["signal"] == signal.SIGINT else terminated_code()
            else:
                outputs.discard()
            return code
        except BaseException as exc:
            state["deferred"] = True
            # a signal wins over whatever it turned into on the way (a library may wrap the KeyboardInterrupt)
            if isinstance(exc, Terminated) or state["signal"] in TERMINATING_SIGNALS:
                if state["signal"] is None and isinstance(exc, Terminated) and exc.args:
                    state["signal"] = exc.args[0]
                return fail("terminated; no outputs written", terminated_code())
            if isinstance(exc, KeyboardInterrupt) or state["signal"] is not None:
                where = f" {exc.args[0]}" if isinstance(exc, KeyboardInterrupt) and exc.args else ""
                return fail(f"interrupted{where}; no outputs written", EXIT_INTERRUPTED)
            if isinstance(exc, HillsimError):
                return fail(f"error: {exc}", EXIT_INPUT)
            if isinstance(exc, OSError):
                where = _output_option(outputs, exc)
                reason = exc.strerror or str(exc)
                if where is None and exc.errno in _WRITE_ERRNOS and outputs._targets:
                    # a write into an open file names no path: name the outputs being written
                    names = ", ".join(f"{t.option} {str(t.final)!r}" for t in outputs._targets)
                    return fail(f"error: {names}: cannot write: {reason}", EXIT_INPUT)
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
    args._options = _option_names(parser, args)
    return run_command(args)


def _starting_signals() -> None:
    def handler(signum, frame):
        word = "interrupted" if signum == signal.SIGINT else "terminated"
        os.write(2, f"hillsim: {word} while starting; nothing written\n".encode())
        os._exit(EXIT_INTERRUPTED if signum == signal.SIGINT else 128 + int(signum))

    try:
        for sig in (signal.SIGINT, *TERMINATING_SIGNALS):
            if signal.getsignal(sig) is not signal.SIG_IGN:  # ignored by the caller (nohup, a background job): kept
                signal.signal(sig, handler)
    except ValueError:  # pragma: no cover - not the main thread
        pass


def console_main() -> None:
    """The ``hillsim`` executable: :func:`main`, exiting with its code.

    After an interrupt the process ends through ``os._exit`` (streams flushed, outputs already discarded): CPython
    3.11 marks a KeyboardInterrupt that passed through code run by ``exec`` of a string (numba's generated wrappers
    are) as unhandled even when this module caught it, and then ends the process by SIGINT at exit instead of
    with the code 130 the CLI returned (seen about once in 15 interrupted runs).

    A signal that arrives while the command is still starting (importing numpy and the command's modules, before
    :func:`run_command` installs its handlers) ends the process at once with the same codes: nothing has been
    written yet."""
    _starting_signals()
    code = main()
    if code >= 128:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    console_main()
