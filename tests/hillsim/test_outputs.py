"""hillsim.outputs and the CLI's handling of outputs, errors and signals."""

import argparse
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from hillchart.errors import InputError
from hillsim.cli import main, run_command
from hillsim.outputs import MANIFEST, OutputLockedError, OutputSet

REPO = Path(__file__).resolve().parents[2]
PLANT = REPO / "data_synthetic" / "plant_hla339.toml"
ENV = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _leftovers(folder: Path) -> list[str]:
    """Temporary or lock files hillsim would leave behind."""
    return sorted(p.name for p in folder.rglob("*") if ".hillsim-tmp-" in p.name or ".hillsim-lock" in p.name)


# ---------------------------------------------------------------------------------------------- checks up front


def test_file_output_with_missing_parent_names_option_and_path(tmp_path):
    with pytest.raises(InputError, match=r"--plot '.*missing/p.png': the folder '.*missing' does not exist"):
        OutputSet().file("--plot", tmp_path / "missing" / "p.png")


def test_file_output_that_is_a_folder_is_refused(tmp_path):
    with pytest.raises(InputError, match=r"--out '.*' is a folder; give a file name"):
        OutputSet().file("--out", tmp_path)


def test_file_output_below_a_file_is_refused(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match=r"is not a folder"):
        OutputSet().file("--out", tmp_path / "f" / "n.json")


def test_folder_output_that_is_a_file_is_refused(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match=r"--out '.*f' exists and is not a folder"):
        OutputSet().folder("--out", tmp_path / "f")
    with pytest.raises(InputError, match=r"is a file, not a folder"):
        OutputSet().folder("--out", tmp_path / "f" / "sub")


def test_read_only_folder_is_refused(tmp_path, monkeypatch):
    # the tests may run as root, which ignores permission bits: emulate a read-only folder through os.access
    real = os.access
    monkeypatch.setattr(os, "access",
                        lambda p, mode: False if Path(p) == tmp_path and mode & os.W_OK else real(p, mode))
    with pytest.raises(InputError, match=r"--out '.*x.csv': the folder '.*' is read-only"):
        OutputSet().file("--out", tmp_path / "x.csv")
    with pytest.raises(InputError, match=r"read-only"):
        OutputSet().folder("--out", tmp_path / "run")
    assert list(tmp_path.iterdir()) == []


def test_folder_output_needs_a_writable_parent(tmp_path, monkeypatch):
    # the temporary folder and the lock live beside the target: an existing, writable target is not enough
    (tmp_path / "run").mkdir()
    real = os.access
    monkeypatch.setattr(os, "access",
                        lambda p, mode: False if Path(p) == tmp_path and mode & os.W_OK else real(p, mode))
    with pytest.raises(InputError, match=r"--out '.*run': the folder '.*' is read-only"):
        OutputSet().folder("--out", tmp_path / "run")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_the_same_path_twice_is_refused(tmp_path):
    outputs = OutputSet()
    outputs.file("--out", tmp_path / "a.png")
    with pytest.raises(InputError, match="is also given as --out"):
        outputs.file("--plot", tmp_path / "a.png")
    outputs.discard()
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------------------------- atomic sets


def test_file_appears_only_at_commit(tmp_path):
    outputs = OutputSet()
    tmp = outputs.file("--out", tmp_path / "table.csv")
    assert tmp.suffix == ".csv" and tmp.parent == tmp_path  # same folder: the rename is atomic
    tmp.write_text("a,b\n")
    assert not (tmp_path / "table.csv").exists()
    outputs.commit()
    assert (tmp_path / "table.csv").read_text() == "a,b\n"
    assert _leftovers(tmp_path) == []


def test_failed_run_leaves_nothing_and_keeps_the_old_file(tmp_path):
    (tmp_path / "nets.json").write_text("old")
    with pytest.raises(RuntimeError):
        with OutputSet() as outputs:
            outputs.file("--out", tmp_path / "nets.json").write_text("half")
            raise RuntimeError("training failed")
    assert (tmp_path / "nets.json").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["nets.json"]


def test_failed_folder_run_removes_the_folders_it_created(tmp_path):
    with pytest.raises(RuntimeError):
        with OutputSet() as outputs:
            out = outputs.folder("--out", tmp_path / "a" / "b" / "run")
            (out / "timeseries.csv").write_text("t\n")
            raise RuntimeError
    assert list(tmp_path.iterdir()) == []


def test_new_set_replaces_an_earlier_set_and_keeps_foreign_files(tmp_path):
    run = tmp_path / "run"
    with OutputSet() as outputs:
        out = outputs.folder("--out", run)
        for name in ("timeseries.csv", "summary.json", "transient.png"):
            (out / name).write_text("first")
        (out / "sub").mkdir()
        (out / "sub" / "x.txt").write_text("first")
    (run / "my_notes.txt").write_text("mine")  # not hillsim's: must survive
    with OutputSet() as outputs:
        out = outputs.folder("--out", run)
        for name in ("timeseries.csv", "summary.json"):
            (out / name).write_text("second")
    names = sorted(p.relative_to(run).as_posix() for p in run.rglob("*") if p.is_file())
    # the first run's transient.png and sub/x.txt are gone: no new file beside an old run's
    assert names == [MANIFEST, "my_notes.txt", "summary.json", "timeseries.csv"]
    assert (run / "summary.json").read_text() == "second"
    assert _leftovers(tmp_path) == []


def test_stale_names_are_removed_from_folders_without_a_manifest(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "transient.png").write_text("from an old version")
    with OutputSet() as outputs:
        (outputs.folder("--out", run, stale=("transient.png",)) / "summary.json").write_text("{}")
    assert not (run / "transient.png").exists() and (run / "summary.json").exists()


# ----------------------------------------------------------------------------------------------------- locking

#: A hillsim command (through the CLI's run_command) that declares an output folder, writes into it, says so in the
#: ready file and then works for a while: the first of two concurrent writers, or the target of a signal.
HOLDER = textwrap.dedent("""
    import argparse, sys, time
    from pathlib import Path
    from hillsim.cli import run_command

    def work(args):
        out = args.outputs.folder("--out", sys.argv[1])
        (out / "timeseries.csv").write_text("time_s\\n0\\n")
        Path(sys.argv[2]).write_text("working")
        time.sleep(float(sys.argv[3]))
        return 0

    sys.exit(run_command(argparse.Namespace(command="hold", func=work, quiet=True)))
""")


def _start_holder(out: Path, ready: Path, seconds: float) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(out), str(ready), str(seconds)], env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for(ready, proc)
    return proc


def _wait_for(path: Path, proc: subprocess.Popen, timeout: float = 60) -> None:
    deadline = time.monotonic() + timeout
    while not path.exists():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.02)


def test_a_second_writer_is_refused_while_the_first_writes(tmp_path):
    """Two runs into the same --out: the second is refused rather than both corrupting it and exiting 0. Two
    processes: a writer holding the folder, and a hillsim command writing into the same folder."""
    out = tmp_path / "rejection"
    holder = _start_holder(out, tmp_path / "ready", 30)
    try:
        with pytest.raises(OutputLockedError, match=rf"--out '.*rejection' is being written by another hillsim "
                                                    rf"process \(pid {holder.pid}\)"):
            OutputSet().folder("--out", out)
        # the second writer is a real command (synth: the lightest to start; every command declares its outputs the
        # same way, and `run` declares --out before importing the simulator, see test_run_checks_out_before_...)
        second = subprocess.run([sys.executable, "-m", "hillsim.cli", "synth", str(out)],
                                env=ENV, capture_output=True, text=True, timeout=120)
        assert second.returncode == 2 and "Traceback" not in second.stderr
        assert ("hillsim synth: error: OUT_DIR" in second.stderr
                and "is being written by another hillsim" in second.stderr)
        assert not out.exists()  # the first writer's files are still private; nothing of the second's
    finally:
        holder.kill()
        holder.wait()
    # the kernel released the killed holder's lock: the folder is usable again, no stale lock to delete by hand
    with OutputSet() as outputs:
        (outputs.folder("--out", out) / "a.txt").write_text("ok")
    assert (out / "a.txt").read_text() == "ok"


def test_the_first_writer_finishes_intact_beside_a_refused_second(tmp_path):
    out = tmp_path / "run"
    holder = _start_holder(out, tmp_path / "ready", 1.0)
    with pytest.raises(OutputLockedError):
        OutputSet().folder("--out", out)
    assert holder.wait(timeout=60) == 0
    assert (out / "timeseries.csv").read_text() == "time_s\n0\n"
    assert _leftovers(tmp_path) == []


# ------------------------------------------------------------------------------------------ signals and errors


@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])
def test_signal_while_writing_exits_cleanly_and_leaves_nothing(tmp_path, sig, code, word):
    """SIGTERM/SIGINT while writing leaves no truncated timeseries.csv."""
    holder = _start_holder(tmp_path / "run", tmp_path / "ready", 30)
    holder.send_signal(sig)
    _, err = holder.communicate(timeout=60)
    assert holder.returncode == code
    assert err.strip() == f"hillsim hold: {word}; no outputs written"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ready"]  # no folder, no temporary, no lock


def test_ctrl_c_during_a_real_run_exits_130_and_writes_nothing(tmp_path):
    """`hillsim run` interrupted while it imports and compiles the loop (numba): one line, exit 130."""
    out = tmp_path / "rejection"
    proc = subprocess.Popen([sys.executable, "-m", "hillsim.cli", "run", str(PLANT), "--out", str(out)], env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for(tmp_path / ".rejection.hillsim-lock", proc)  # outputs declared: the work (imports, compile) runs
    time.sleep(0.3)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    # interrupted while importing, or in the loop (then the line says how far it got: "after N % of the run")
    assert re.search(r"hillsim run: interrupted( after \d+ % of the run)?; no outputs written", err), err
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def _args(func, command="fake") -> argparse.Namespace:
    return argparse.Namespace(command=command, func=func, quiet=True)


class _SwallowedInterrupt:
    """Raises SIGINT in a finalizer: Python prints 'Exception ignored in ...' and goes on (seen once during numba
    compilation, where the run then finished with exit 0)."""

    def __del__(self):
        signal.raise_signal(signal.SIGINT)


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_interrupt_swallowed_by_a_finalizer_still_exits_130(tmp_path, capsys):
    def func(args):
        out = args.outputs.folder("--out", tmp_path / "run")
        (out / "summary.json").write_text("{}")
        _SwallowedInterrupt()  # collected at once: the KeyboardInterrupt is raised inside __del__ and ignored
        return 0

    assert run_command(_args(func)) == 130
    assert "interrupted" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_write_error_names_the_option(tmp_path, capsys):
    def func(args):
        out = args.outputs.folder("--out", tmp_path / "run")
        raise OSError(28, "No space left on device", str(out / "timeseries.csv"))

    assert run_command(_args(func)) == 2
    err = capsys.readouterr().err
    assert "error: --out '" in err and "No space left on device" in err
    assert list(tmp_path.iterdir()) == []


def test_extend_with_a_bad_plot_path_writes_nothing(tmp_path, capsys):
    """`extend --out ext.csv --plot missing_parent/p.png` exits 2 and leaves no ext.csv."""
    code = main(["extend", str(REPO / "data_synthetic" / "francis"), "--out", str(tmp_path / "ext.csv"),
                 "--plot", str(tmp_path / "missing_parent" / "p.png")])
    assert code == 2
    assert "--plot" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_run_checks_out_before_simulating(tmp_path, capsys, monkeypatch):
    """`run` finds an unusable --out before the simulation, not after it."""
    import simulate.loop.engine

    def never(*args, **kwargs):
        raise AssertionError("the simulation ran before --out was checked")

    monkeypatch.setattr(simulate.loop.engine, "run_simulation", never)
    (tmp_path / "taken").write_text("a file")
    assert main(["run", str(PLANT), "--out", str(tmp_path / "taken")]) == 2
    assert "--out" in capsys.readouterr().err


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    from hillsim import __version__

    assert capsys.readouterr().out.strip() == f"hillsim {__version__}"


def test_an_unexpected_error_keeps_its_traceback_and_writes_nothing(tmp_path):
    """A command that crashes after writing (`train ... --out n.json`, QhullError) leaves nothing behind."""
    def func(args):
        args.outputs.file("--out", tmp_path / "n.json").write_text("{}")
        raise RuntimeError("QhullError: initial simplex is flat")  # a bug, not bad input: the traceback stays

    with pytest.raises(RuntimeError, match="simplex"):
        run_command(_args(func, "train"))
    assert list(tmp_path.iterdir()) == []


def test_an_interrupt_wrapped_into_another_error_still_exits_130(tmp_path, capsys):
    def func(args):
        args.outputs.folder("--out", tmp_path / "run")
        try:
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            raise RuntimeError("compilation failed") from None  # what a library catching everything might do

    assert run_command(_args(func)) == 130
    assert "interrupted" in capsys.readouterr().err and list(tmp_path.iterdir()) == []


def test_a_signal_inside_a_native_callback_is_delivered_again_after_it():
    """A Ctrl-C that lands in llvmlite's object-cache callback (numba compiling) cannot raise there (Python prints
    "Exception ignored" with a traceback and goes on): the handler sees such a frame and delivers the signal again
    once the callback has returned. The failing case beside it: an ordinary frame is not a callback."""
    from hillsim.cli import _in_native_callback

    namespace = {}
    exec(compile("import sys\ndef inner():\n    return sys._getframe()\n", "/site/llvmlite/binding/executionengine.py",
                 "exec"), namespace)

    def caller():  # an ordinary frame that calls into the callback's module: still inside the callback
        return namespace["inner"]()

    assert _in_native_callback(caller()) is True
    assert _in_native_callback(sys._getframe()) is False
