"""Start-up levers: the CLI imports only the command it runs, a run imports no
scipy.optimize. Each import check runs a fresh interpreter (``sys.modules`` of the test process holds whatever other
tests imported)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from hillsim import cli

ROOT = Path(__file__).resolve().parents[2]


def _modules_after(code: str, names, cwd) -> dict:
    script = code + "\nimport json, sys\nprint(json.dumps({m: m in sys.modules for m in " + repr(tuple(names)) + "}))\n"
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-c", script], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _help_texts(parser) -> dict:
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    return {name: p.format_help() for name, p in sub.choices.items()}


def test_one_command_parser_equals_the_full_parsers_command():
    """For every command, the parser ``main`` builds for it alone has the same options, metavars and help text as
    that command in the full parser (``hillsim --help``)."""
    full = _help_texts(cli.build_parser())
    assert len(full) == len(cli.COMMAND_MODULES)
    for name, text in full.items():
        module = cli._command_module([name, "--help"])
        assert module is not None, name
        alone = _help_texts(cli.build_parser(only=module))
        assert list(alone) == [name]
        assert alone[name] == text, name


@pytest.mark.parametrize("argv, expected", [
    (["run", "plant.toml", "--out", "D"], "hillsim.commands.run"),
    (["optimize-closure", "plant.toml"], "hillsim.commands.optimize_closure"),
    (["--version"], None),  # no command: the full parser
    (["-h"], None),
    ([], None),
    (["nope"], None),  # unknown: the full parser, whose error lists the commands
    (["--quiet", "run"], None),  # an option before the command: left to the full parser
    (["commands.run"], None),
])
def test_command_module_from_argv(argv, expected):
    assert cli._command_module(argv) == expected


def test_unknown_command_still_lists_every_command(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["nope"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'nope'" in err and "'optimize-closure'" in err and "'run'" in err


def test_run_help_imports_no_other_command_and_no_numpy(tmp_path):
    loaded = _modules_after(
        "import contextlib, io\nfrom hillsim import cli\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    try:\n        cli.main(['run', '--help'])\n    except SystemExit:\n        pass\n",
        ["hillsim.commands.run", "hillsim.commands.train", "hillsim.commands.linearize", "numpy"], tmp_path)
    assert loaded == {"hillsim.commands.run": True, "hillsim.commands.train": False,
                      "hillsim.commands.linearize": False, "numpy": False}
    # the check can fail: the full parser imports every command module
    loaded = _modules_after("from hillsim import cli\ncli.build_parser()\n", ["hillsim.commands.train"], tmp_path)
    assert loaded == {"hillsim.commands.train": True}


def test_a_run_imports_no_scipy_optimize(tmp_path):
    """The steady state uses simulate.loop.steady.brentq (scipy's algorithm, ported), not scipy.optimize, and
    reading nets with a silent-region model (the physical model's module) does not import it either: about a
    second of every run's start-up."""
    code = ("from data_synthetic import PLANT_HLA339\n"
            "from simulate.config import load_plant\nfrom simulate.loop.engine import run_simulation\n"
            "run_simulation(load_plant(PLANT_HLA339, {'scenario.t_end_s': 3.0})).summary()\n")
    assert _modules_after(code, ["scipy.optimize"], tmp_path) == {"scipy.optimize": False}
    assert _modules_after("import scipy.optimize\n", ["scipy.optimize"], tmp_path) == {"scipy.optimize": True}


def test_few_point_net_evaluation_is_the_compiled_kernel_to_the_bit():
    """``evaluate`` on up to ``_PYTHON_POINTS`` points runs the kernel's Python source; it gives the compiled
    kernel's values exactly (same operations in the same order, libm's exp either way)."""
    import numpy as np

    from hillchart.nets import weights as nets
    from hillchart.nets.hill_nets import load_nets

    flow = load_nets(ROOT / "data_synthetic" / "francis" / "nets.json").flow
    rng = np.random.default_rng(3)
    n11, a = rng.uniform(30.0, 110.0, nets._PYTHON_POINTS), rng.uniform(0.5, 30.0, nets._PYTHON_POINTS)
    few = flow.evaluate(n11, a)
    many = flow.evaluate(np.concatenate([n11, n11]), np.concatenate([a, a]))  # above the limit: compiled
    for small, large in zip(few, many):
        assert np.array_equal(small, large[:n11.size])


def test_linearizing_one_point_loads_nothing_compiled(tmp_path):
    """numba's first cache load initialises its compiler (it imports numba.np.arraymath, about half a second);
    ``hillsim linearize`` at one point does not need it."""
    code = ("from hillchart.nets.hill_nets import load_nets\nfrom hillchart.linearize import six_coefficients\n"
            f"nets = load_nets({str(ROOT / 'data_synthetic' / 'francis' / 'nets.json')!r})\n"
            "six_coefficients(nets, n11=67.8, opening=23.46)\n")
    assert _modules_after(code, ["numba.np.arraymath"], tmp_path) == {"numba.np.arraymath": False}
    # the check can fail: a map (many points) loads the compiled kernel
    code += "import numpy as np\nnets.flow.evaluate(np.linspace(40, 100, 500), np.full(500, 20.0))\n"
    assert _modules_after(code, ["numba.np.arraymath"], tmp_path) == {"numba.np.arraymath": True}


# ---------------------------------------------------------------------------------- figures in a forked process
@pytest.fixture(scope="module")
def short_result():
    from data_synthetic import PLANT_HLA339
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    return run_simulation(load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 4.0}))


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_figure_process_draws_the_same_pngs_as_this_process(tmp_path, short_result):
    from hillsim.commands.run import FigureProcess
    from simulate.results.envelope import plot_envelope

    figures = FigureProcess()
    assert figures.pid is not None
    child = figures.pid
    figures.draw(short_result, tmp_path / "t.png", tmp_path / "e.png")
    assert figures.failure == "" and figures.pid is None
    with pytest.raises(ChildProcessError):  # reaped: no zombie left
        os.waitpid(child, 0)
    short_result.plot(tmp_path / "t_here.png")
    plot_envelope(short_result, tmp_path / "e_here.png")
    # same code, same data, same matplotlib: the same bytes
    assert (tmp_path / "t.png").read_bytes() == (tmp_path / "t_here.png").read_bytes()
    assert (tmp_path / "e.png").read_bytes() == (tmp_path / "e_here.png").read_bytes()


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_figure_process_failure_falls_back_to_this_process_and_raises_the_real_error(tmp_path, short_result):
    from hillsim.commands.run import FigureProcess

    figures = FigureProcess()
    missing = tmp_path / "no" / "such" / "folder"
    with pytest.raises(FileNotFoundError):
        figures.draw(short_result, missing / "t.png", missing / "e.png")
    assert "FileNotFoundError" in figures.failure  # the child failed the same way, and said so
    assert not missing.exists()


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_figure_process_closed_before_drawing_is_stopped_and_reaped(tmp_path):
    from hillsim.commands.run import FigureProcess

    figures = FigureProcess()
    child = figures.pid
    figures.close()
    assert figures.pid is None
    with pytest.raises(ChildProcessError):
        os.waitpid(child, 0)
    assert list(tmp_path.iterdir()) == []
