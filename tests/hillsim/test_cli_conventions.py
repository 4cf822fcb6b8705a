"""CLI conventions: --version, the same names for the same things in --help, defaults shown, progress lines."""

import argparse
import io
import re
from pathlib import Path


from hillsim.cli import build_parser, main
from hillsim.progress import Stages

REPO = Path(__file__).resolve().parents[2]
NETS = REPO / "data_synthetic" / "francis" / "nets.json"


def _subparsers():
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices


def test_same_thing_same_name_in_every_command():
    seen: dict[str, set] = {}
    for name, sub in _subparsers().items():
        for action in sub._actions:
            if action.dest in ("chart", "samples", "plant", "nets", "data"):
                seen.setdefault(action.dest.replace("samples", "chart"), set()).add(action.metavar)
            if action.dest == "out":
                # help text and metavar agree (`demo --help` once said "into DIR" while the option read `--out OUT`)
                assert action.metavar not in (None, "OUT"), name
                description = sub.description or ""
                if "DIR" in description:
                    assert action.metavar == "DIR", name
    assert seen == {"chart": {"CHART_DIR"}, "plant": {"PLANT_TOML"}, "nets": {"NETS_JSON"}, "data": {"SERIES_CSV"}}


def test_every_default_is_shown_and_every_command_has_quiet():
    for name, sub in _subparsers().items():
        text = sub.format_help()
        assert "--quiet" in text, name
        for action in sub._actions:
            if action.option_strings and action.default not in (None, False, argparse.SUPPRESS) \
                    and action.dest != "help":
                assert "default" in (action.help or "").lower() or "(default: " in text, (name, action.dest)
    # every option shows its default (`train --seed` once showed none)
    train_help = " ".join(_subparsers()["train"].format_help().split())
    assert "torque net: seed + 1) (default: 0)" in train_help


def test_stages_on_a_pipe_print_a_start_and_a_done_line():
    stream = io.StringIO()
    stages = Stages(stream=stream, total=2, terminal=False)
    stages.start("load")
    stages.done("12 samples")
    stages.start("fit")
    stages.done()
    lines = stream.getvalue().splitlines()
    assert lines[0] == "[1/2] load ..." and re.fullmatch(r"\[1/2\] load: done \(\d+\.\d s, 12 samples\)", lines[1])
    assert lines[2] == "[2/2] fit ..." and re.fullmatch(r"\[2/2\] fit: done \(\d+\.\d s\)", lines[3])


def test_stages_on_a_terminal_share_one_line():
    stream = io.StringIO()
    stages = Stages(stream=stream, terminal=True)
    stages.start("load")
    stages.done()
    assert re.fullmatch(r"load \.\.\. done \(\d+\.\d s\)\n", stream.getvalue())


def test_disabled_stages_print_nothing():
    stream = io.StringIO()
    stages = Stages(enabled=False, stream=stream)
    stages.start("load")
    assert stages.done() >= 0 and stream.getvalue() == ""


def test_a_piped_command_shows_its_stages(tmp_path, capsys):
    # --quiet silencing them: tests/hillsim/test_demo.py::test_quiet_prints_nothing (the shared demo run is --quiet)
    args = ["linearize", str(NETS), "--n11", "67.8", "--opening", "23.46", "--map", str(tmp_path / "m.png"),
            "--grid", "4"]
    assert main(args) == 0
    err = capsys.readouterr().err
    # pytest's capture is not a terminal: a start line and a done line with the time
    assert "coefficient maps on a 4 x 4 grid ...\n" in err
    assert re.search(r"coefficient maps on a 4 x 4 grid: done \(\d+\.\d s\)", err)
