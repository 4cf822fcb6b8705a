"""A campaign of bad inputs and faults over all 12 ``hillsim`` commands: does each end cleanly, and is every input
intact afterwards?

Each case runs in a fresh folder holding copies of its inputs (the shipped synthetic chart, nets, plant files, a
measured series, a model-test table), mutated as the case says; the command runs in-process through
:func:`hillsim.cli.main` (signal cases as subprocesses). Before and after, every input file is hashed (SHA-256).
Each case is classified:

- ``clean error``: exit 2 and a one-line ``hillsim CMD: error: ...`` (or an argparse usage error), no traceback;
- ``warning``: exit 0 with a warning; ``ran``: exit 0 without one (absurd values a command may accept);
- ``clean signal end``: a signal case ending with 128 + the signal (130 for Ctrl-C), nothing left behind;
- ``traceback``: an exception escaped ``main`` or stderr holds a traceback;
- ``hang``: over the per-case time limit;
- ``lost or damaged input``: an input file missing or changed afterwards (counted on top of the above);
- ``left temporaries``: ``.hillsim-tmp-*`` or lock files left in the case folder;
- ``limit FAIL (exit 3)``: ``hillsim report`` judged a guarantee limit FAILed (its documented exit 3, report written);
- ``unexpected outcome``: a case that states what it expects (``expect``: clean error, warning or ran, with the text
  the message must hold, files that must be written, a time bound) ended otherwise: a silent acceptance of an absurd
  value or a false refusal of good input counts here, not only a traceback (counted on top of the above).

Run (prints a markdown table; about 2-4 minutes on 2 cores)::

    PYTHONPATH=. python benchmarks/bench_fault_campaign.py [--workers 2] [--only CATEGORY] [--sample] [--list]

The table in ``docs/reliability-campaign.md`` is this script's output.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from collections import Counter, defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

CHART = REPO / "data_synthetic" / "francis"
PLANT = REPO / "data_synthetic" / "plant_hla339.toml"
GUARANTEE = REPO / "data_synthetic" / "plant_hla339_guarantee.toml"
TWO_UNITS = REPO / "data_synthetic" / "plant_two_units.toml"
BULB_PLANT = REPO / "data_synthetic" / "plant_bulb.toml"
BULB_NETS = REPO / "data_synthetic" / "bulb" / "nets.json"
NETS = CHART / "nets.json"
CASE_TIMEOUT_S = 120
SHORT = ["--set", "scenario.t_end_s=2.5"]  # keeps every run that is accepted short (the event is at 2 s)

COMMANDS = ("synth", "extend", "train", "chart", "linearize", "run", "identify", "sweep", "optimize-closure",
            "report", "demo", "fccm")


# ------------------------------------------------------------------------------------------------ shared inputs


def _shared(cache: Path) -> dict:
    """Inputs made once per campaign: a measured series and a model-test table (as the tool writes them)."""
    from hillsim.cli import main

    series = cache / "series.csv"
    if not series.exists():
        run = cache / "steps"
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            main(["run", str(PLANT), "--out", str(run), "--quiet", "--set", 'scenario.kind="opening-steps"',
                  "--set", "scenario.initial_power_mw=180", "--set", "scenario.t_end_s=20"])
            main(["synth", str(cache / "bulb"), "--turbine", "bulb", "--quiet"])
            # the plant's own opening-steps test as the tool runs it by default (60 s)
            main(["run", str(PLANT), "--out", str(cache / "steps60"), "--quiet", "--set",
                  'scenario.kind="opening-steps"'])
        shutil.copy(run / "timeseries.csv", series)
    return {"series": series, "bulb": cache / "bulb", "series60": cache / "steps60" / "timeseries.csv"}


def _plant_text(source: Path) -> str:
    """A plant file that names its nets by absolute path (so it can be copied anywhere)."""
    return (source.read_text(encoding="utf-8").replace('"francis/nets.json"', json.dumps(str(NETS)))
            .replace('"bulb/nets.json"', json.dumps(str(BULB_NETS))))


def setup_case(folder: Path, case: dict, shared: dict) -> None:
    """Copy the inputs ``case["inputs"]`` into ``folder`` and apply ``case["mutate"]``."""
    for name in case.get("inputs", ()):
        if name == "plant":
            (folder / "plant.toml").write_text(_plant_text(PLANT), encoding="utf-8")
        elif name == "guarantee":
            (folder / "guarantee.toml").write_text(_plant_text(GUARANTEE), encoding="utf-8")
        elif name == "two units":
            (folder / "two.toml").write_text(_plant_text(TWO_UNITS), encoding="utf-8")
        elif name == "bulb plant":
            (folder / "bulb.toml").write_text(_plant_text(BULB_PLANT), encoding="utf-8")
        elif name == "chart":
            shutil.copytree(CHART, folder / "c")
        elif name == "nets":
            shutil.copy(NETS, folder / "nets.json")
        elif name == "series":
            shutil.copy(shared["series"], folder / "s.csv")
        elif name == "series60":
            shutil.copy(shared["series60"], folder / "s60.csv")
        elif name == "bulb":
            shutil.copytree(shared["bulb"], folder / "t")
        elif name == "earlier":  # a committed earlier run holding a file given as an input
            (folder / "r").mkdir()
            shutil.copy(shared["series"], folder / "r" / "timeseries.csv")
            for extra in ("closure.json", "sweep.json", "summary.json"):
                (folder / "r" / extra).write_text("{}\n")
            (folder / "r" / ".hillsim-outputs.json").write_text(json.dumps(
                {"files": ["timeseries.csv", "closure.json", "sweep.json", "summary.json"]}))
    for op in case.get("mutate", ()):
        apply_mutation(folder, op)


def apply_mutation(folder: Path, op: tuple) -> None:
    kind, rel = op[0], op[1]
    path = folder / rel
    if kind == "write":  # replace the whole file
        data = op[2]
        path.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
    elif kind == "prepend":
        path.write_bytes((op[2] if isinstance(op[2], bytes) else op[2].encode()) + path.read_bytes())
    elif kind == "append":
        path.write_bytes(path.read_bytes() + (op[2] if isinstance(op[2], bytes) else op[2].encode()))
    elif kind == "truncate":  # keep a fraction of the bytes
        data = path.read_bytes()
        path.write_bytes(data[:int(len(data) * op[2])])
    elif kind == "replace":  # text replacement (first occurrence, or every one with op[4])
        text = path.read_text(encoding="utf-8")
        path.write_text(text.replace(op[2], op[3]) if len(op) > 4 else text.replace(op[2], op[3], 1),
                        encoding="utf-8")
    elif kind == "line":  # replace line number op[2] (0 = header) by op[3]
        lines = path.read_text(encoding="utf-8").splitlines()
        lines[op[2]] = op[3]
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    elif kind == "cell":  # set column op[2] of data row op[3] to op[4] in a CSV
        lines = path.read_text(encoding="utf-8").splitlines()
        header = lines[0].split(",")
        cells = lines[op[3]].split(",")
        cells[header.index(op[2])] = op[4]
        lines[op[3]] = ",".join(cells)
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    elif kind == "shift":  # add op[4] to column op[2] of data row op[3] in a CSV
        lines = path.read_text(encoding="utf-8").splitlines()
        header = lines[0].split(",")
        cells = lines[op[3]].split(",")
        j = header.index(op[2])
        cells[j] = f"{float(cells[j]) + op[4]:.5f}"
        lines[op[3]] = ",".join(cells)
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    elif kind == "column":  # scale a numeric CSV column by op[3]
        lines = path.read_text(encoding="utf-8").splitlines()
        header = lines[0].split(",")
        j = header.index(op[2])
        out = [lines[0]]
        for line in lines[1:]:
            cells = line.split(",")
            cells[j] = repr(float(cells[j]) * op[3])
            out.append(",".join(cells))
        path.write_text("\n".join(out) + "\n", encoding="utf-8")
    elif kind == "noise":  # relative sensor noise op[2] (normal, seed op[3]) on every column but time and iterations
        import numpy as np

        rng = np.random.default_rng(op[3])
        lines = path.read_text(encoding="utf-8").splitlines()
        header = lines[0].split(",")
        noisy = [j for j, name in enumerate(header) if name not in ("time_s", "iterations")]
        out = [lines[0]]
        for line in lines[1:]:
            cells = line.split(",")
            for j in noisy:
                cells[j] = repr(float(cells[j]) * (1.0 + op[2] * rng.standard_normal()))
            out.append(",".join(cells))
        path.write_text("\n".join(out) + "\n", encoding="utf-8")
    elif kind == "rows":  # repeat the data rows of a CSV until it holds op[2] of them
        lines = path.read_text(encoding="utf-8").splitlines()
        rows = lines[1:]
        path.write_text("\n".join([lines[0]] + [rows[i % len(rows)] for i in range(op[2])]) + "\n", encoding="utf-8")
    elif kind == "json_scale":  # multiply every number of a (nested) list at a dotted key path by op[3]
        doc = json.loads(path.read_text(encoding="utf-8"))
        target = doc
        keys = op[2].split(".")
        for k in keys[:-1]:
            target = target[int(k)] if isinstance(target, list) else target[k]

        def scaled(value):
            return [scaled(v) for v in value] if isinstance(value, list) else value * op[3]

        target[keys[-1]] = scaled(target[keys[-1]])
        path.write_text(json.dumps(doc), encoding="utf-8")
    elif kind == "remove":
        if path.is_dir():
            shutil.rmtree(path)
        else:
            path.unlink()
    elif kind == "mkdir":
        path.mkdir(parents=True, exist_ok=True)
    elif kind == "json":  # set a key path (dotted) in a JSON file
        doc = json.loads(path.read_text(encoding="utf-8"))
        target = doc
        keys = op[2].split(".")
        for k in keys[:-1]:
            target = target[int(k)] if isinstance(target, list) else target[k]
        last = keys[-1]
        if op[3] is REMOVE:
            del target[last]
        elif isinstance(target, list):
            target[int(last)] = op[3]
        else:
            target[last] = op[3]
        path.write_text(json.dumps(doc), encoding="utf-8")
    elif kind == "symlink":
        path.symlink_to(op[2] if os.path.isabs(op[2]) else folder / op[2])
    else:  # pragma: no cover
        raise ValueError(kind)


REMOVE = "<remove>"

#: What a case may state it expects (``expect``): the outcomes that count as handled. An absurd value must be refused
#: (``CLEAN_ERROR``) or named in a warning (``WARNING``, with the text in ``expect_in``): running silently is a
#: failure. Good input must run: ``RAN`` (exit 0; a warning beside, such as a run leaving the digitized region, is no
#: refusal) or ``RAN_QUIET`` (exit 0 without any warning). ``LIMIT_FAIL``: ``hillsim report``'s documented exit 3.
#: Beside ``expect``: ``expect_in`` (texts the output must hold), ``expect_count`` (text -> times it appears),
#: ``expect_files`` (path in the case folder -> text it must hold, "" for any, None for "not written") and
#: ``max_s`` (a refusal that must come before the work, in seconds).
CLEAN_ERROR = ("clean error",)
WARNING = ("warning",)
RAN = ("ran", "warning")
RAN_QUIET = ("ran",)
LIMIT_FAIL = ("limit FAIL (exit 3)",)


# ------------------------------------------------------------------------------------------------ the cases


def _c(category, command, argv, inputs=(), mutate=(), **extra) -> dict:
    return {"category": category, "command": command, "argv": list(argv), "inputs": tuple(inputs),
            "mutate": tuple(mutate), **extra}


NUMERIC_PLANT_KEYS = (
    "turbine.rated_head_m", "turbine.rated_flow_m3_s", "turbine.rated_speed_rpm", "turbine.rated_power_mw",
    "turbine.runner_diameter_m", "turbine.opening_max", "penstock.static_head_m", "penstock.reaches",
    "generator.inertia_time_s", "generator.self_regulation", "governor.kp", "governor.ki", "governor.kd",
    "governor.derivative_filter_s", "governor.permanent_droop", "governor.servo_time_s", "governor.closing_time_s",
    "governor.opening_time_s", "governor.stroke_min", "governor.stroke_max", "scenario.t_end_s",
    "scenario.initial_power_mw", "scenario.event_time_s", "solver.tolerance", "solver.max_iterations",
    "solver.relaxation")
ABSURD_VALUES = ("-1", "0", "1e300", "nan", "inf", "-inf", '"text"', "[1, 2]", "true", "1e-300", "{a = 1}",
                 "1e5")


def plant_key_cases() -> list[dict]:
    cases = []
    for key in NUMERIC_PLANT_KEYS:
        for value in ABSURD_VALUES:
            if key == "scenario.t_end_s" and value == "1e5":
                continue  # a 28-hour run is allowed (the upper bound) and takes minutes: not a bad-input case
            argv = ["run", "{D}/plant.toml", "--out", "{D}/out", "--quiet", "--set", f"{key}={value}"]
            if key != "scenario.t_end_s":
                argv += SHORT
            cases.append(_c("plant key out of range (run --set)", "run", argv, ["plant"]))
    for key, values in {"penstock.model": ('"mocc"', "1", '""'), "scenario.kind": ('"rejection"', "2", '""'),
                        "solver.pressure_loop": ('"fast"', "[1]"),
                        "turbine.characteristics": ('"missing.json"', '"/"', "3", '"{D}/plant.toml"')}.items():
        for value in values:
            cases.append(_c("plant key out of range (run --set)", "run",
                            ["run", "{D}/plant.toml", "--out", "{D}/out", "--quiet", "--set", f"{key}={value}"]
                            + SHORT, ["plant"]))
    for text in ("penstock.wave_speed=1000", "turbine=1", "nosuchsection.key=1", "governor.Kp=2", "=1", "governor.kp",
                 "governor.kp=", "turbine.rated_head_m=1 2", "a.b.c.d=1"):
        cases.append(_c("plant key out of range (run --set)", "run",
                        ["run", "{D}/plant.toml", "--out", "{D}/out", "--quiet", "--set", text], ["plant"]))
    return cases


PLANT_MUTATIONS = {
    "empty file": [("write", "plant.toml", b"")],
    "UTF-16 (Notepad)": [("write", "plant.toml", _plant_text(PLANT).encode("utf-16"))],
    "Latin-1 comment": [("prepend", "plant.toml", b"# r\xe9servoir\n")],
    "binary": [("write", "plant.toml", bytes(range(256)) * 8)],
    "byte-order mark": [("prepend", "plant.toml", b"\xef\xbb\xbf")],
    "truncated 30 %": [("truncate", "plant.toml", 0.3)],
    "truncated 70 %": [("truncate", "plant.toml", 0.7)],
    "missing file": [("remove", "plant.toml")],
    "a folder": [("remove", "plant.toml"), ("mkdir", "plant.toml")],
    "duplicate key": [("append", "plant.toml", "\n[turbine]\nrated_head_m = 1.0\n")],
    "unknown section": [("append", "plant.toml", "\n[turbin]\nx = 1\n")],
    "1 MB line": [("append", "plant.toml", "\n# " + "x" * 1_000_000 + "\n")],
    "deeply nested": [("append", "plant.toml", "\nx = " + "[" * 5000 + "]" * 5000 + "\n")],
    "NUL bytes": [("append", "plant.toml", b"\x00\x00\x00")],
}


def plant_file_cases() -> list[dict]:
    commands = {
        "run": ["run", "{D}/plant.toml", "--out", "{D}/out", "--quiet"] + SHORT,
        "sweep": ["sweep", "{D}/plant.toml", "--vary", "governor.kp=1,2", "--out", "{D}/out", "--quiet",
                  "--workers", "1", "--no-plot"] + SHORT,
        "report": ["report", "{D}/plant.toml", "--out", "{D}/out", "--quiet"] + SHORT,
        "optimize-closure": ["optimize-closure", "{D}/plant.toml", "--out", "{D}/out", "--quiet", "--maxiter", "1",
                             "--popsize", "2", "--workers", "1", "--no-plot"] + SHORT,
        "identify": ["identify", "{D}/plant.toml", "--data", "{D}/s.csv", "--out", "{D}/out", "--quiet",
                     "--no-plot"],
        "linearize": ["linearize", "{D}/nets.json", "--plant", "{D}/plant.toml", "--quiet"],
    }
    cases = []
    for name, mutation in PLANT_MUTATIONS.items():
        for command, argv in commands.items():
            if name == "byte-order mark" and command in ("report", "optimize-closure"):
                continue  # accepted and then a full study: too long for a bad-input campaign
            inputs = ["plant", "series", "nets"]
            cases.append(_c("plant file corrupted", command, argv, inputs, mutation, label=name))
    return cases


def _chart_mutations() -> dict:
    m = {
        "chart.toml missing": [("remove", "c/chart.toml")],
        "chart.toml empty": [("write", "c/chart.toml", b"")],
        "chart.toml UTF-16": [("write", "c/chart.toml", (CHART / "chart.toml").read_text().encode("utf-16"))],
        "chart.toml Latin-1": [("prepend", "c/chart.toml", b"# \xe9\n")],
        "q11_unit as a list": [("replace", "c/chart.toml", 'q11_unit = "m3/s"', 'q11_unit = ["m3/s"]')],
        "q11_unit as a table": [("replace", "c/chart.toml", 'q11_unit = "m3/s"', 'q11_unit = {u = "m3/s"}')],
        "opening_unit unknown": [("replace", "c/chart.toml", 'opening_unit = "mm"', 'opening_unit = "inch"')],
        "opening_unit as a number": [("replace", "c/chart.toml", 'opening_unit = "mm"', "opening_unit = 3")],
        "efficiency_unit list": [("replace", "c/chart.toml", 'efficiency_unit = "fraction"', "efficiency_unit = []")],
        "opening_max 1e5": [("replace", "c/chart.toml", "opening_max = 32.0", "opening_max = 1e5")],
        "opening_max 0": [("replace", "c/chart.toml", "opening_max = 32.0", "opening_max = 0")],
        "opening_max nan": [("replace", "c/chart.toml", "opening_max = 32.0", "opening_max = nan")],
        "opening_max text": [("replace", "c/chart.toml", "opening_max = 32.0", 'opening_max = "32"')],
        "unknown key": [("append", "c/chart.toml", "\ncolour = 1\n")],
        "name missing": [("line", "c/chart.toml", 0, "# no name")],
        "runner diameter -1": [("append", "c/chart.toml", "\n"),
                               ("replace", "c/chart.toml", "runner_diameter_m = 0.35", "runner_diameter_m = -1")],
        "flow.csv missing": [("remove", "c/flow.csv")],
        "flow.csv empty": [("write", "c/flow.csv", b"")],
        "flow.csv header only": [("write", "c/flow.csv", b"opening,n11,q11\n")],
        "flow.csv wrong header": [("line", "c/flow.csv", 0, "a,b,c")],
        "flow.csv text cell": [("cell", "c/flow.csv", "q11", 3, "abc")],
        "flow.csv nan cell": [("cell", "c/flow.csv", "q11", 3, "nan")],
        "flow.csv inf cell": [("cell", "c/flow.csv", "n11", 3, "inf")],
        "flow.csv negative q11": [("cell", "c/flow.csv", "q11", 3, "-0.3")],
        "flow.csv N11 = 0": [("cell", "c/flow.csv", "n11", 3, "0")],
        "flow.csv 1e308": [("cell", "c/flow.csv", "q11", 3, "1e308")],
        "flow.csv missing cell": [("cell", "c/flow.csv", "q11", 3, "")],
        "flow.csv extra cell": [("append", "c/flow.csv", "10,60,0.3,7\n")],
        "flow.csv 200 kB cell": [("cell", "c/flow.csv", "q11", 3, "9" * 200_000)],
        "flow.csv BOM": [("prepend", "c/flow.csv", b"\xef\xbb\xbf")],
        "flow.csv semicolons": [("replace", "c/flow.csv", ",", ";", "all")],
        "flow.csv in l/s": [("column", "c/flow.csv", "q11", 1000.0)],
        "flow.csv binary": [("write", "c/flow.csv", bytes(range(256)) * 4)],
        "flow.csv a folder": [("remove", "c/flow.csv"), ("mkdir", "c/flow.csv")],
        "flow.csv one line": [("truncate", "c/flow.csv", 0.05)],
        "efficiency.csv missing": [("remove", "c/efficiency.csv")],
        "efficiency.csv empty": [("write", "c/efficiency.csv", b"")],
        "efficiency contour at 1.000": [("cell", "c/efficiency.csv", "efficiency", 2, "1.0")],
        "efficiency 1.5": [("cell", "c/efficiency.csv", "efficiency", 2, "1.5")],
        "efficiency in percent": [("column", "c/efficiency.csv", "efficiency", 100.0)],
        "efficiency text": [("cell", "c/efficiency.csv", "efficiency", 2, "high")],
        "efficiency point at N11 = 0": [("cell", "c/efficiency.csv", "n11", 2, "0")],
        "efficiency negative": [("cell", "c/efficiency.csv", "efficiency", 2, "-0.5")],
        "runaway.csv empty": [("write", "c/runaway.csv", b"")],
        "runaway.csv text": [("line", "c/runaway.csv", 1, "x,y")],
        "runaway.csv negative": [("line", "c/runaway.csv", 1, "10,-50")],
        "chart folder is a file": [("remove", "c"), ("write", "c", b"x")],
        "chart folder missing": [("remove", "c")],
    }
    return m


def chart_cases() -> list[dict]:
    cases = []
    for name, mutation in _chart_mutations().items():
        cases.append(_c("chart folder corrupted", "extend", ["extend", "{D}/c", "--out", "{D}/e.csv", "--quiet"],
                        ["chart"], mutation, label=name))
        cases.append(_c("chart folder corrupted", "chart", ["chart", "{D}/nets.json", "--samples", "{D}/c",
                                                            "--out", "{D}/chart.png", "--quiet"],
                        ["chart", "nets"], mutation, label=name))
        if name.startswith(("chart.toml", "q11_unit", "opening_unit", "efficiency_unit", "opening_max 0",
                            "opening_max nan", "opening_max text", "unknown key", "name missing", "flow.csv missing",
                            "flow.csv empty", "flow.csv header", "flow.csv wrong", "flow.csv text", "flow.csv nan",
                            "flow.csv 200", "flow.csv binary", "flow.csv a folder", "chart folder")):
            cases.append(_c("chart folder corrupted", "train", ["train", "{D}/c", "--out", "{D}/n.json", "--quiet",
                                                                "--restarts", "1", "--ensemble", "0"],
                            ["chart"], mutation, label=name))
    return cases


NETS_MUTATIONS = {
    "empty": [("write", "nets.json", b"")],
    "not JSON": [("write", "nets.json", b"{nets")],
    "truncated": [("truncate", "nets.json", 0.5)],
    "a list": [("write", "nets.json", b"[1, 2]")],
    "UTF-16": [("write", "nets.json", NETS.read_text().encode("utf-16"))],
    "binary": [("write", "nets.json", bytes(range(256)))],
    "format wrong": [("json", "nets.json", "format", "other")],
    "version 2": [("json", "nets.json", "version", 2)],
    "units.q11 l/s": [("json", "nets.json", "units.q11", "l/s")],
    "flow missing": [("json", "nets.json", "flow", REMOVE)],
    "flow weights short": [("json", "nets.json", "flow.IW", [[1.0]])],
    "flow x_max < x_min": [("json", "nets.json", "flow.x_max", [0.0, 0.0])],
    "torque a string": [("json", "nets.json", "torque", "x")],
    "ensemble not a list": [("json", "nets.json", "ensemble", 3)],
    "digitized_region bad": [("json", "nets.json", "digitized_region", [[1, 2]])],
    "digitized_region text": [("json", "nets.json", "digitized_region", "hull")],
    "NaN literal": [("replace", "nets.json", '"version": 1', '"version": NaN')],
    "deeply nested": [("write", "nets.json", ("[" * 100000 + "]" * 100000).encode())],
    "huge integer": [("replace", "nets.json", '"version": 1', '"version": 1' + "0" * 5000)],
    "a folder": [("remove", "nets.json"), ("mkdir", "nets.json")],
}


def nets_cases() -> list[dict]:
    cases = []
    for name, mutation in NETS_MUTATIONS.items():
        cases.append(_c("nets.json corrupted", "run", ["run", "{D}/plant.toml", "--out", "{D}/out", "--quiet",
                                                        "--set", 'turbine.characteristics="{D}/nets.json"'] + SHORT,
                        ["plant", "nets"], mutation, label=name))
        cases.append(_c("nets.json corrupted", "linearize", ["linearize", "{D}/nets.json", "--n11", "70",
                                                              "--opening", "20", "--quiet"],
                        ["nets"], mutation, label=name))
        cases.append(_c("nets.json corrupted", "chart", ["chart", "{D}/nets.json", "--out", "{D}/c.png", "--quiet"],
                        ["nets"], mutation, label=name))
    return cases


def series_cases() -> list[dict]:
    col = lambda c, f: [("column", "s.csv", c, f)]  # noqa: E731
    m = {
        "empty": [("write", "s.csv", b"")],
        "header only": [("line", "s.csv", 0, "time_s,speed_rpm,head_m,flow_m3_s,opening,opening_chart,torque_nm")],
        "missing column": [("replace", "s.csv", "torque_nm", "torque")],
        "text cell": [("cell", "s.csv", "speed_rpm", 5, "fast")],
        "nan cell": [("cell", "s.csv", "head_m", 5, "nan")],
        "1e308 spike": [("cell", "s.csv", "torque_nm", 50, "1e308")],
        "dropout to 0": [("cell", "s.csv", "speed_rpm", 50, "0")],
        "time not increasing": [("cell", "s.csv", "time_s", 5, "0")],
        "time in minutes": col("time_s", 1 / 60),
        "time in ms": col("time_s", 1000.0),
        "100 s hole": [("cell", "s.csv", "time_s", 300, "150")],
        "speed in rad/s": col("speed_rpm", 2 * 3.141592653589793 / 60),
        "another plant's speed": col("speed_rpm", 2.5),
        "head in bar": col("head_m", 9.81 * 1000 / 1e5),
        "flow in l/s": col("flow_m3_s", 1000.0),
        "torque in kN*m": col("torque_nm", 1e-3),
        "opening in percent": col("opening", 100.0),
        "negative head": [("cell", "s.csv", "head_m", 5, "-3")],
        "BOM": [("prepend", "s.csv", b"\xef\xbb\xbf")],
        "semicolons": [("replace", "s.csv", ",", ";", "all")],
        "UTF-16": [("write", "s.csv", b"\xff\xfet\x00i\x00m\x00e\x00")],
        "binary": [("write", "s.csv", bytes(range(256)) * 4)],
        "200 kB cell": [("cell", "s.csv", "time_s", 3, "1" * 200_000)],
        "a folder": [("remove", "s.csv"), ("mkdir", "s.csv")],
        "missing": [("remove", "s.csv")],
        "one row": [("truncate", "s.csv", 0.001)],
        "0.1 % noise (good input)": [("noise", "s.csv", 1e-3, 0)],
    }
    cases = []
    for name, mutation in m.items():
        expect = {"expect": RAN} if name == "0.1 % noise (good input)" else {}
        cases.append(_c("measured series corrupted", "identify", ["identify", "{D}/plant.toml", "--data", "{D}/s.csv",
                                                                   "--out", "{D}/out", "--quiet", "--no-plot"],
                        ["plant", "series"], mutation, label=name, **expect))
    return cases


def sweep_cases() -> list[dict]:
    base = ["sweep", "{D}/plant.toml", "--out", "{D}/out", "--quiet", "--no-plot", "--workers", "1"] + SHORT
    varies = ["governor.kp=1:2:0", "governor.kp=1:2", "governor.kp=a,b", "governor.kp=", "kp=1,2",
              "governor.kp=1:2:1e9", "governor.kp=nan,1", "governor.kp=1,inf", "turbine.characteristics=1,2",
              "governor.kp=1:2:-3", "governor.closing_time_s=-1,1", "=1,2", "governor.kp=1;2",
              "scenario.kind=1,2", "governor.kp=1:2:1000000", "governor.kp=1:2:100000,governor.ki=1:2:100000"]
    cases = [_c("sweep values and cases", "sweep", base + ["--vary", v], ["plant"], label=v) for v in varies]
    for name, text in {"empty": b"", "header only": b"governor.kp\n", "text": b"governor.kp\nabc\n",
                       "unknown key": b"governor.kq\n1\n", "BOM": b"\xef\xbb\xbfgovernor.kp\n1\n2\n",
                       "ragged": b"governor.kp,governor.ki\n1\n", "Latin-1": b"governor.kp\n1\n\xe9\n",
                       "UTF-16": "governor.kp\n1\n".encode("utf-16"), "nan": b"governor.kp\nnan\n",
                       "200 kB cell": b"governor.kp\n" + b"1" * 200_000 + b"\n",
                       "duplicate column": b"governor.kp,governor.kp\n1,2\n"}.items():
        cases.append(_c("sweep values and cases", "sweep", base + ["--cases", "{D}/cases.csv"], ["plant"],
                        [("write", "cases.csv", text)], label=name))
    for opt in (["--workers", "0"], ["--workers", "-3"], ["--workers", "x"], ["--chunk-size", "0"],
                ["--scheduler", "cloud"], ["--scheduler", "local", "x"], ["--cases", "{D}/missing.csv"],
                ["--cases", "{D}"]):
        cases.append(_c("sweep values and cases", "sweep", base + ["--vary", "governor.kp=1,2"] + opt, ["plant"],
                        label=" ".join(opt)))
    return cases


def fccm_cases() -> list[dict]:
    base = ["fccm", "{D}/t", "--inputs", "blade_angle_deg,guide_vane_deg", "--outputs", "efficiency",
            "--out", "{D}/out", "--quiet", "--no-plots"]
    m = {
        "table.csv missing": [("remove", "t/table.csv")],
        "table.toml missing": [("remove", "t/table.toml")],
        "table.csv empty": [("write", "t/table.csv", b"")],
        "table.csv text cell": [("cell", "t/table.csv", "efficiency", 3, "x")],
        "table.csv nan": [("cell", "t/table.csv", "efficiency", 3, "nan")],
        "table.csv Latin-1": [("append", "t/table.csv", b"# \xe9\n")],
        "table.csv UTF-16": [("write", "t/table.csv", "a,b\n1,2\n".encode("utf-16"))],
        "table.csv 200 kB cell": [("cell", "t/table.csv", "efficiency", 3, "1" * 200_000)],
        "table.csv header only": [("truncate", "t/table.csv", 0.001)],
        "table.csv ragged": [("append", "t/table.csv", "1,2\n")],
        "table.toml not TOML": [("write", "t/table.toml", b"name = ")],
        "table.toml UTF-16": [("write", "t/table.toml", 'name = "x"\n'.encode("utf-16"))],
        "table.toml unknown key": [("append", "t/table.toml", "\ncolour = 1\n")],
        "table.toml controls not a list": [("replace", "t/table.toml", 'controls = ["blade_angle_deg", '
                                            '"guide_vane_deg"]', 'controls = "blade_angle_deg"')],
        "table.toml speed -1": [("replace", "t/table.toml", "speed_rpm = 136.36", "speed_rpm = -1")],
    }
    cases = [_c("model-test table corrupted", "fccm", base, ["bulb"], mut, label=name) for name, mut in m.items()]
    for opt in (["--inputs", "nosuch"], ["--outputs", "nosuch"], ["--inputs", ""], ["--hidden", "0"],
                ["--hidden", "-1"], ["--seed", "-1"], ["--restarts", "0"], ["--split", "2"], ["--split", "a"],
                ["--truth", "{D}/missing.csv"], ["--outputs", "blade_angle_deg"]):
        argv = list(base)
        if opt[0] in argv:
            argv[argv.index(opt[0]) + 1] = opt[1]
        else:
            argv += opt
        cases.append(_c("model-test table corrupted", "fccm", argv, ["bulb"], label=" ".join(opt)))
    return cases


#: ``--out``-like argument of each command and the inputs it needs (``{D}`` is the case folder).
OUTPUT_OF = {
    "synth": (["synth", "{OUT}", "--quiet"], [], "folder"),
    "extend": (["extend", "{D}/c", "--out", "{OUT}", "--quiet"], ["chart"], "file"),
    "train": (["train", "{D}/c", "--out", "{OUT}", "--quiet", "--hidden", "0"], ["chart"], "file"),
    "chart": (["chart", "{D}/nets.json", "--out", "{OUT}", "--quiet", "--title", ""], ["nets"], "file"),
    "linearize": (["linearize", "{D}/nets.json", "--n11", "70", "--opening", "20", "--map", "{OUT}", "--quiet"],
                  ["nets"], "file"),
    "run": (["run", "{D}/plant.toml", "--out", "{OUT}", "--quiet"] + SHORT, ["plant"], "folder"),
    "identify": (["identify", "{D}/plant.toml", "--data", "{D}/s.csv", "--out", "{OUT}", "--quiet", "--tau", "-1"],
                 ["plant", "series"], "folder"),
    "sweep": (["sweep", "{D}/plant.toml", "--vary", "governor.kp=1,2", "--out", "{OUT}", "--quiet", "--workers", "0"],
              ["plant"], "folder"),
    "optimize-closure": (["optimize-closure", "{D}/plant.toml", "--out", "{OUT}", "--quiet", "--maxiter", "0"],
                         ["plant"], "folder"),
    "report": (["report", "{D}/plant.toml", "--out", "{OUT}", "--quiet", "--set", "governor.kp=-1"], ["plant"],
               "folder"),
    "demo": (["demo", "--out", "{OUT}", "--quiet", "--fast"], [], "folder"),
    "fccm": (["fccm", "{D}/t", "--inputs", "blade_angle_deg,guide_vane_deg", "--outputs", "efficiency", "--out",
              "{OUT}", "--quiet", "--hidden", "0"], ["bulb"], "folder"),
}


def output_cases() -> list[dict]:
    """Unusable or dangerous outputs for every command (each also carries a bad option where the command would
    otherwise run in full, so a case that is accepted ends quickly: the output check comes first)."""
    cases = []
    for command, (argv, inputs, kind) in OUTPUT_OF.items():
        inputs = list(inputs) + ["earlier", "plant", "nets", "series"]
        targets = {
            "empty": ("", []),
            "blank": ("   ", []),
            "trailing slash on a file": ("{D}/e.csv/", []),
            "missing parent": ("{D}/no/such/deep/out.png" if kind == "file" else "{D}/chart.toml/x", []),
            "a file where a folder is meant" if kind == "folder" else "a folder where a file is meant":
                ("{D}/plant.toml" if kind == "folder" else "{D}/r", []),
            "the input plant file": ("{D}/plant.toml", []),
            "the input nets file": ("{D}/nets.json", []),
            "the earlier run holding an input": ("{D}/r", []),
            "an input file inside it": ("{D}/r/timeseries.csv", []),
            "/dev/null": ("/dev/null", []),
            "a FIFO": ("{D}/fifo", [("fifo",)]),
            "a dangling symlink": ("{D}/dangling", [("symlink", "dangling", "{D}/nowhere/x")]),
            "a symlink loop": ("{D}/loop", [("symlink", "loop", "loop")]),
            "a name of 300 characters": ("{D}/" + "n" * 300, []),
            "a path through a file": ("{D}/plant.toml/out", []),
            "the root folder": ("/", []),
        }
        for label, (target, extra) in targets.items():
            a = [t.replace("{OUT}", target) for t in argv]
            if command == "identify" and target == "{D}/r/timeseries.csv":
                pass
            if command in ("identify",) and label == "the earlier run holding an input":
                a[a.index("--data") + 1] = "{D}/r/timeseries.csv"
            mutate = []
            for e in extra:
                if e[0] == "fifo":
                    mutate.append(("fifo", "fifo"))
                else:
                    mutate.append(("symlink", e[1], e[2]))
            cases.append(_c("unusable or dangerous output", command, a, inputs, (), label=label, pre=mutate))
    # report / sweep reading the folder they would write (the once-destructive cases)
    for option in ("--closure", "--sweep"):
        cases.append(_c("unusable or dangerous output", "report",
                        ["report", "{D}/plant.toml", option, "{D}/r", "--out", "{D}/r", "--quiet"],
                        ["plant", "earlier"], label=f"report {option} DIR --out DIR"))
    cases.append(_c("unusable or dangerous output", "extend", ["extend", "{D}/c", "--out", "{D}/c/flow.csv",
                                                               "--quiet"], ["chart"], label="extend onto flow.csv"))
    cases.append(_c("unusable or dangerous output", "extend", ["extend", "{D}/c", "--out", "{D}/c/efficiency.csv",
                                                               "--quiet"], ["chart"],
                    label="extend onto efficiency.csv"))
    cases.append(_c("unusable or dangerous output", "synth", ["synth", "{D}/c", "--quiet", "--seed", "3"], ["chart"],
                    label="synth over an existing chart (its own earlier output: replaced by design)"))
    return cases


def option_cases() -> list[dict]:
    """Absurd option values per command (each names the value or is an argparse usage error)."""
    cases = []
    per_command = {
        "synth": (["synth", "{D}/o", "--quiet"], [["--turbine", "huge"], ["--seed", "-1"], ["--noise", "-1"],
                                                  ["--noise", "nan"], ["--noise", "1e300"],
                                                  ["--points-per-line", "0"], ["--points-per-line", "-5"],
                                                  ["--points-per-line", "100000000"], ["--spacing", "nan"],
                                                  ["--opening-unit", "inch"], ["--q11-unit", "gal"],
                                                  ["--efficiency-unit", "x"], ["--opening-lines", "0"],
                                                  ["--opening-lines", "a"], ["--points", "0"],
                                                  ["--points", "-1"], ["--closure", "none"],
                                                  ["--seed", "99999999999999"]], []),
        "extend": (["extend", "{D}/c", "--out", "{D}/e.csv", "--quiet"],
                   [["--zero-opening-k", "1e300"], ["--zero-opening-k", "-1"], ["--zero-opening-k", "nan"],
                    ["--zero-opening-k", "inf"], ["--extrapolation-degree", "99"], ["--extrapolation-degree", "-1"],
                    ["--boundaries", "magic"], ["--plot", "{D}/missing/p.png"], ["--plot", "{D}/e.csv"]],
                   ["chart"]),
        "train": (["train", "{D}/c", "--out", "{D}/n.json", "--quiet"],
                  [["--hidden", "0"], ["--hidden", "1000"], ["--hidden", "x"], ["--restarts", "0"],
                   ["--ensemble", "-1"], ["--ensemble", "100000"], ["--seed", "-1"], ["--boundary-weight", "2"],
                   ["--boundary-weight", "nan"], ["--regularization", "-1"], ["--zero-opening-k", "1e300"]],
                  ["chart"]),
        "chart": (["chart", "{D}/nets.json", "--out", "{D}/c.png", "--quiet"],
                  [["--samples", "{D}/nosuch"], ["--samples", "{D}/nets.json"], ["--out", "{D}/c.xyz"]], ["nets"]),
        "linearize": (["linearize", "{D}/nets.json", "--quiet"],
                      [["--n11", "nan"], ["--n11", "-70", "--opening", "20"], ["--n11", "1e300", "--opening", "20"],
                       ["--n11", "70", "--opening", "-1"], ["--n11", "70", "--opening", "1e9"], ["--n11", "70"],
                       ["--plant", "{D}/plant.toml", "--stroke", "5"], ["--plant", "{D}/plant.toml", "--stroke", "nan"],
                       ["--plant", "{D}/plant.toml", "--tau", "0"], ["--plant", "{D}/plant.toml", "--tau", "-1"],
                       ["--n11", "70", "--opening", "20", "--speed-rpm", "200"],
                       ["--speed-rpm", "-200", "--head-m", "176", "--d1-m", "4.5", "--opening", "20"],
                       ["--speed-rpm", "200", "--head-m", "0", "--d1-m", "4.5", "--opening", "20"],
                       ["--n11", "70", "--opening", "20", "--map", "{D}/m.png", "--grid", "0"],
                       ["--n11", "70", "--opening", "20", "--map", "{D}/m.png", "--grid", "100000"],
                       ["--n11", "70", "--opening", "20", "--map", "{D}/m.png", "--n11-range", "90", "10"],
                       ["--n11", "70", "--opening", "20", "--map", "{D}/m.png", "--opening-range", "nan", "1"]],
                      ["nets", "plant"]),
        "run": (["run", "{D}/plant.toml", "--out", "{D}/out", "--quiet"] + SHORT,
                [["--set", "governor.closing_time_s=0.001"], ["--set", "turbine.rated_power_mw=1e6"],
                 ["--set", "scenario.initial_power_mw=1e6"], ["--set", "solver.dt_s=1e-9"],
                 ["--set", "scenario.t_end_s=1e9"], ["--set", "penstock.reaches=1000000"],
                 ["--set", "turbine.opening_max=1e5"], ["--ensemble"], ["--no-such-option"]], ["plant"]),
        "identify": (["identify", "{D}/plant.toml", "--out", "{D}/out", "--quiet", "--no-plot"],
                     [["--tau", "1e-6"], ["--tau", "0"], ["--tau", "-1"], ["--tau", "nan"], ["--tau", "1e9"],
                      ["--amplitude", "5"], ["--amplitude", "-1"], ["--noise", "-1"], ["--noise", "nan"],
                      ["--seed", "-1"], ["--step-hold-s", "1e9"], ["--prbs-duration-s", "1e12"],
                      ["--prbs-bit-s", "0"], ["--forgetting-factor", "2"], ["--forgetting-factor", "0"],
                      ["--p0", "-1"], ["--delta", "-1"], ["--initial-opening", "5"], ["--closed-loop-kp", "nan"],
                      ["--closed-loop-ti", "0"], ["--quiet-s", "-5"], ["--data", "{D}/s.csv", "--tau", "1e-6"]],
                     ["plant", "series"]),
        "optimize-closure": (["optimize-closure", "{D}/guarantee.toml", "--out", "{D}/out", "--quiet", "--no-plot"],
                             [["--seed", "-1"], ["--maxiter", "0"], ["--popsize", "0"], ["--workers", "0"],
                              ["--max-speed-rise", "0"], ["--max-speed-rise", "nan"], ["--max-head-rise", "99"],
                              ["--set", "governor.closing_time_s=-1"], ["--set", "nosuch.key=1"]], ["guarantee"]),
        "report": (["report", "{D}/guarantee.toml", "--out", "{D}/out", "--quiet"],
                   [["--closure", "{D}/nosuch"], ["--sweep", "{D}/nosuch"], ["--closure", "{D}/guarantee.toml"],
                    ["--set", "governor.kp=-1"], ["--set", "scenario.initial_power_mw=1e6"],
                    ["--set", "limits.max_speed_rise=-1"]], ["guarantee"]),
        "demo": (["demo", "--out", "{D}/demo", "--quiet"], [["--fast", "--no-such"], ["--out", ""]], []),
    }
    for command, (argv, variants, inputs) in per_command.items():
        for v in variants:
            cases.append(_c("absurd option value", command, argv + v, inputs, label=" ".join(v)))
    # load cases that fail (report names the load case and the key)
    for key, value in (("scenario.initial_power_mw", "1e6"), ("governor.closing_time_s", "-1"),
                       ("penstock.static_head_m", "0"), ("scenario.kind", '"nosuch"')):
        cases.append(_c("absurd option value", "report", ["report", "{D}/guarantee.toml", "--out", "{D}/out",
                                                           "--quiet"], ["guarantee"],
                        [("replace", "guarantee.toml", "name = \"70 % load\"",
                          f"name = \"70 % load\"\n{key} = {value}")], label=f"load case {key} = {value}"))
    return cases


def _run(plant: str, *more: str) -> list[str]:
    return ["run", "{D}/" + plant, "--out", "{D}/out", "--quiet", *SHORT, *more]


FCCM_FAST = ["--inputs", "blade_angle_deg,guide_vane_deg", "--outputs", "efficiency", "--out", "{D}/out", "--quiet",
             "--no-plots", "--hidden", "3", "--restarts", "1"]
NESTED_200000 = [("write", "nets.json", ("[" * 200_000 + "]" * 200_000).encode())]
MEMBER_W2_X10 = [("json_scale", "nets.json", "ensemble.3.flow.W2", 10.0)]
NOTE_ONCE = {"expect_count": {"note: ": 1}, "expect_in": ("[limits] and [[load_cases]]",)}


def expected_outcome_cases() -> list[dict]:
    """Inputs whose outcome is stated: former tracebacks, absurd values that must be refused or warned, good input
    that must run, messages that must name the cause, and a guarantee study's plant file given to every command."""
    cases = []
    add = lambda category, command, argv, inputs, mutate=(), **extra: cases.append(  # noqa: E731
        _c(category, command, argv, inputs, mutate, **extra))

    cat = "former traceback"
    add(cat, "run", _run("two.toml", "--set", 'turbine.characteristics="synthetic-bulb"'), ["two units"],
        label="three-input characteristics on a plant with [[units]]", expect=CLEAN_ERROR,
        expect_in=("turbine.characteristics = 'synthetic-bulb'",))
    add(cat, "run", _run("bulb.toml", "--set", 'turbine.step_up="iec60193"'), ["bulb plant"],
        label="a step-up of the bulb's three-input nets", expect=CLEAN_ERROR, expect_in=("turbine.step_up",))
    add(cat, "optimize-closure", ["optimize-closure", "{D}/guarantee.toml", "--out", "{D}/out", "--quiet", "--maxiter",
                                  "1", "--popsize", "1", "--workers", "1", "--no-plot", "--set",
                                  'turbine.step_up={method = "iec60193"}'], ["guarantee"],
        label="a plant with [turbine.step_up] written as the optimum", expect=RAN,
        expect_files={"out/closure.json": "", "out/optimum_plant.toml": "[turbine.step_up]"})
    add(cat, "run", _run("plant.toml", "--set", 'turbine.characteristics="{D}/nets.json"'), ["plant", "nets"],
        NESTED_200000, label="nets.json nested 200,000 deep", expect=CLEAN_ERROR, expect_in=("nested too deeply",))
    add(cat, "linearize", ["linearize", "{D}/nets.json", "--n11", "70", "--opening", "20", "--quiet"], ["nets"],
        NESTED_200000, label="nets.json nested 200,000 deep", expect=CLEAN_ERROR, expect_in=("nested too deeply",))

    cat = "absurd value refused or warned"
    fccm = ["fccm", "{D}/t", *FCCM_FAST]
    add(cat, "fccm", fccm, ["bulb"], [("column", "t/table.csv", "head_m", 9.81)], label="test table head in kPa",
        expect=WARNING, expect_in=("is the head in kPa",))
    add(cat, "fccm", fccm, ["bulb"], [("shift", "t/table.csv", "efficiency", 40, -0.4)],
        label="test table efficiency 0.4 off in row 41", expect=WARNING, expect_in=("row 41: efficiency",))
    add(cat, "run", _run("two.toml"), ["two units"], [("replace", "two.toml", "wave_speed_m_s = 1180.0",
                                                       "wave_speed_m_s = 1.0")],
        label="a branch wave speed of 1 m/s", expect=CLEAN_ERROR, expect_in=("units.branch.wave_speed_m_s",))
    add(cat, "run", _run("bulb.toml", "--set", "blade_servo.servo_time_s=0.001"), ["bulb plant"],
        label="blade servo time 1 ms", expect=WARNING, expect_in=("blade_servo.servo_time_s = 0.001 s",))
    add(cat, "run", _run("bulb.toml", "--set", "combinator.head_m=300"), ["bulb plant"],
        label="combinator head 300 m on the 12 m bulb plant", expect=CLEAN_ERROR,
        expect_in=("combinator.head_m = 300 m",))
    add(cat, "run", _run("bulb.toml", "--set", "blade_servo.law_start_s=1", "--set", "blade_servo.law_target_deg=-10"),
        ["bulb plant"], label="blade-law keys with the blades on the cam", expect=CLEAN_ERROR,
        expect_in=("the blade law's keys go with mode",))
    add(cat, "run", _run("plant.toml", "--set", "solver.tolerance=1e-300"), ["plant"], label="solver.tolerance 1e-300",
        expect=CLEAN_ERROR, expect_in=("solver.tolerance = 1e-300",))
    add(cat, "run", _run("plant.toml", "--set", 'penstock.model="rigid"', "--set", "solver.dt_s=0.05", "--set",
                         "scenario.event_time_s=1.234"), ["plant"],
        label="an event between the steps of solver.dt_s", expect=WARNING,
        expect_in=("scenario event(s) at 1.234 s fall between steps",))
    for command, argv in (("run", _run("plant.toml", "--set", 'turbine.characteristics="{D}/nets.json"')),
                          ("linearize", ["linearize", "{D}/nets.json", "--n11", "70", "--opening", "20", "--quiet"])):
        add(cat, command, argv, ["plant", "nets"], MEMBER_W2_X10, label="ensemble member 3 with W2 x 10",
            expect=CLEAN_ERROR, expect_in=("ensemble[3].flow departs",))
    add(cat, "identify", ["identify", "{D}/plant.toml", "--data", "{D}/s.csv", "--out", "{D}/out", "--quiet",
                          "--no-plot"], ["plant", "series"], [("column", "s.csv", "head_m", 2.0)],
        label="identify --data of another plant (head x 2)", expect=CLEAN_ERROR,
        expect_in=("column 'head_m' starts at",))
    underscore = [("replace", "c/flow.csv", ",44.02,", ",4_4.02,")]
    for command, argv in (("extend", ["extend", "{D}/c", "--out", "{D}/e.csv", "--quiet"]),
                          ("train", ["train", "{D}/c", "--out", "{D}/n.json", "--quiet", "--restarts", "1",
                                     "--ensemble", "0"]),
                          ("chart", ["chart", "{D}/nets.json", "--samples", "{D}/c", "--out", "{D}/c.png",
                                     "--quiet"])):
        add(cat, command, argv, ["chart", "nets"], underscore, label="chart cell 4_4.02", expect=CLEAN_ERROR,
            expect_in=("'4_4.02' (an underscore",))
    add(cat, "fccm", ["fccm", "{D}/t", "--simulator-nets", "--members", "1000", "--out", "{D}/out", "--quiet",
                      "--no-plots"], ["bulb"], label="fccm --simulator-nets --members 1000", expect=CLEAN_ERROR,
        expect_in=("--members must be an integer within 1-20",), max_s=30, expect_files={"out": None})
    add(cat, "fccm", ["fccm", "{D}/t", "--simulator-nets", "--out", "{D}/out", "--quiet", "--no-plots"], ["bulb"],
        [("rows", "t/table.csv", 20_001)], label="fccm --simulator-nets on a 20,001-row table", expect=CLEAN_ERROR,
        expect_in=("20001 rows",), max_s=30, expect_files={"out": None})
    add(cat, "run", ["run", "{D}/plant.toml", "--out", "{D}/out", "--quiet", "--check-step", "--set",
                     "penstock.reaches=10000"], ["plant"], label="run --check-step with penstock.reaches = 10000",
        expect=CLEAN_ERROR, expect_in=("--check-step reruns at half the step",), max_s=30,
        expect_files={"out": None})

    cat = "good input that must run"
    add(cat, "run", _run("plant.toml", "--set", "solver.dt_s=0.0190678"), ["plant"],
        label="solver.dt_s = the MOC step as hillsim prints it", expect=RAN_QUIET)
    add(cat, "identify", ["identify", "{D}/plant.toml", "--data", "{D}/s60.csv", "--out", "{D}/out", "--quiet",
                          "--no-plot"], ["plant", "series60"], [("noise", "s60.csv", 1e-3, 0)],
        label="the default opening-steps series with 0.1 % sensor noise", expect=RAN,
        expect_files={"out/identification.json": ""})
    add(cat, "sweep", ["sweep", "{D}/plant.toml", "--vary", "penstock.reaches=8,16", "--out", "{D}/out", "--quiet",
                       "--workers", "1", "--no-plot", *SHORT], ["plant"],
        label="sweep of penstock.reaches (integer key)", expect=RAN,
        expect_files={"out/results.csv": "\n0,8,ok,", "out/sweep.json": ""})

    cat = "message names the cause"
    add(cat, "sweep", ["sweep", "{D}/plant.toml", "--vary", "penstock.modle=moc,rigid", "--out", "{D}/out", "--quiet",
                       "--workers", "1", "--no-plot", *SHORT], ["plant"], label="misspelt --vary key with names",
        expect=CLEAN_ERROR, expect_in=("unknown key 'penstock.modle'",))
    add(cat, "train", ["train", "{D}/c", "--out", "{D}/c/flow.csv", "--quiet"], ["chart"],
        label="train CHART --out CHART/flow.csv", expect=CLEAN_ERROR,
        expect_in=("is the input", "nothing was written"), max_s=30)
    add(cat, "sweep", ["sweep", "{D}/plant.toml", "--vary", "penstock.reaches=3,4", "--out", "{D}/out", "--quiet",
                       "--workers", "1", "--no-plot", *SHORT], ["plant"], label="a sweep where every case fails",
        expect=CLEAN_ERROR, expect_in=("every one of the 2 cases failed",),
        expect_files={"out/results.csv": ",error,", "out/sweep.json": '"error": 2'})

    cat = "guarantee study file"
    add(cat, "run", _run("guarantee.toml"), ["guarantee"], label="run STUDY", expect=RAN, **NOTE_ONCE)
    add(cat, "sweep", ["sweep", "{D}/guarantee.toml", "--vary", "governor.kp=1,2", "--out", "{D}/out", "--quiet",
                       "--workers", "1", "--no-plot", *SHORT], ["guarantee"], label="sweep STUDY", expect=RAN,
        **NOTE_ONCE)
    add(cat, "identify", ["identify", "{D}/guarantee.toml", "--data", "{D}/s.csv", "--out", "{D}/out", "--quiet",
                          "--no-plot"], ["guarantee", "series"], label="identify STUDY --data", expect=RAN,
        **NOTE_ONCE)
    add(cat, "linearize", ["linearize", "{D}/nets.json", "--plant", "{D}/guarantee.toml", "--quiet"],
        ["guarantee", "nets"], label="linearize --plant STUDY", expect=RAN, **NOTE_ONCE)
    add(cat, "linearize", ["linearize", "{D}/nets.json", "--plant", "{D}/guarantee.toml", "--quiet", "--set",
                           "scenario.initial_power_mw=200"], ["guarantee", "nets"],
        label="linearize --plant STUDY --set scenario.initial_power_mw=200", expect=RAN, **NOTE_ONCE)
    add(cat, "report", ["report", "{D}/guarantee.toml", "--out", "{D}/out", "--quiet", "--set",
                        "scenario.t_end_s=5"], ["guarantee"],
        [("replace", "guarantee.toml", "max_speed_rise = 0.50", "max_speed_rise = 0.05")],
        label="report on a plant whose speed-rise limit FAILs", expect=LIMIT_FAIL,
        expect_in=("hillsim report: FAIL: rated load: max_speed_rise",),
        expect_files={"out/report.json": '"FAIL"', "out/report.html": ""})
    return cases


def signal_cases() -> list[dict]:
    """Ctrl-C, SIGTERM, SIGHUP (once, twice) during real runs, as subprocesses: ends with 128 + signal, nothing
    left behind, inputs intact."""
    runs = {
        "run": ["run", "{D}/plant.toml", "--out", "{D}/out", "--quiet"],
        "sweep": ["sweep", "{D}/plant.toml", "--vary", "governor.kp=1:3:8", "--out", "{D}/out", "--quiet",
                  "--workers", "2", "--set", "scenario.t_end_s=20"],
        "identify": ["identify", "{D}/plant.toml", "--data", "{D}/s.csv", "--out", "{D}/out", "--quiet"],
        "extend": ["extend", "{D}/c", "--out", "{D}/e.csv", "--plot", "{D}/e.png", "--quiet"],
    }
    cases = []
    for command, argv in runs.items():
        for sig in ("SIGINT", "SIGTERM", "SIGHUP"):
            for delay in (1.5, 4.0):  # after the interpreter has started (see the docs)
                for repeat in (1, 2):
                    cases.append(_c("signal during a run", command, argv, ["plant", "series", "chart"],
                                    label=f"{sig} x{repeat} at {delay} s", signal=(sig, delay, repeat)))
    return cases


def sample_cases(cases: list[dict], every: int = 8) -> list[dict]:
    """The suite's slow-tier sample: every case that states its expected outcome and every ``every``-th of the
    others (by case number). No signal case: where a signal lands against a run's start and end depends on the
    machine's load (see docs/reliability-campaign.md), so their outcome is not deterministic."""
    others = [c for c in cases if "expect" not in c and "signal" not in c]
    keep = {c["id"] for c in cases if "expect" in c} | {c["id"] for c in others[::every]}
    return [c for c in cases if c["id"] in keep]


def all_cases() -> list[dict]:
    cases = (plant_key_cases() + plant_file_cases() + chart_cases() + nets_cases() + series_cases() + sweep_cases()
             + fccm_cases() + output_cases() + option_cases() + expected_outcome_cases() + signal_cases())
    for i, case in enumerate(cases):
        case["id"] = i
    return cases


# ------------------------------------------------------------------------------------------------ running


class CaseTimeout(BaseException):
    pass


def _alarm(signum, frame):
    raise CaseTimeout()


def _hashes(folder: Path) -> dict:
    out = {}
    for p in folder.rglob("*"):
        try:
            if p.is_file() and not p.is_symlink():
                out[p.relative_to(folder).as_posix()] = hashlib.sha256(p.read_bytes()).hexdigest()
        except OSError:
            pass
    return out


def _output_target(argv: list[str], command: str) -> str | None:
    for option in ("--out", "--map"):
        if option in argv and argv.index(option) + 1 < len(argv):
            return argv[argv.index(option) + 1]
    return argv[1] if command == "synth" and len(argv) > 1 else None


def _replaced_by_design(argv: list[str], command: str, folder: Path) -> Path | None:
    """The output target when nothing else on the command line refers to it (or into it): a command replacing its
    own earlier output there is doing its job. An output that is, holds or lies in an input stays checked."""
    target = _output_target(argv, command)
    if not target or not target.strip():
        return None
    real = Path(os.path.realpath(target if os.path.isabs(target) else folder / target))
    index = argv.index(target) if target in argv else -1
    for i, token in enumerate(argv):
        if i == index or not token.startswith(str(folder)):
            continue
        other = Path(os.path.realpath(token))
        if other == real or real in other.parents or other in real.parents:
            return None
    return real if str(real).startswith(str(folder)) else None


def _under(path: Path, top: Path | None) -> bool:
    if top is None:
        return False
    path = Path(os.path.realpath(path))
    return path == top or top in path.parents


def _drain(fifo: Path):
    """A reader for a FIFO given as an output (as a shell's process substitution would be)."""
    import threading

    def read():
        with open(fifo, "rb") as handle:
            while handle.read(65536):
                pass

    thread = threading.Thread(target=read, daemon=True)
    thread.start()
    return thread


def _leftovers(folder: Path) -> list[str]:
    return [p.name for p in folder.rglob("*") if ".hillsim-tmp-" in p.name or ".hillsim-lock" in p.name]


def _restore_signals() -> None:
    signal.signal(signal.SIGINT, signal.default_int_handler)
    for name in ("SIGTERM", "SIGHUP", "SIGXCPU"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)


def run_case(case: dict, root: Path, shared: dict) -> dict:
    from hillsim.cli import main

    folder = Path(tempfile.mkdtemp(dir=root, prefix=f"case{case['id']:05d}-"))
    setup_case(folder, case, shared)
    for op in case.get("pre", ()):
        if op[0] == "fifo":
            os.mkfifo(folder / op[1])
        else:
            (folder / op[1]).symlink_to(op[2].replace("{D}", str(folder)))
    argv = [a.replace("{D}", str(folder)) for a in case["argv"]]
    skip = _replaced_by_design(argv, case["command"], folder)
    before = {k: v for k, v in _hashes(folder).items() if not _under(folder / k, skip)}
    readers = [_drain(folder / op[1]) for op in case.get("pre", ()) if op[0] == "fifo"]
    out, err = io.StringIO(), io.StringIO()
    result = {"id": case["id"], "category": case["category"], "command": case["command"],
              "label": case.get("label", ""), "argv": argv}
    start = time.perf_counter()
    if "signal" in case:
        code, text = _run_signal_case(argv, folder, case["signal"])
        err.write(text)
    else:
        old_cwd = os.getcwd()
        os.chdir(folder)  # relative outputs (``--out ''``) land in the case folder
        signal.signal(signal.SIGALRM, _alarm)
        signal.alarm(CASE_TIMEOUT_S)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                code = main(argv)
        except CaseTimeout:
            code = "hang"
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
        except BaseException:  # noqa: BLE001 - an escaped exception is what the campaign counts
            err.write(traceback.format_exc())
            code = "exception"
        finally:
            signal.alarm(0)
            os.chdir(old_cwd)
            _restore_signals()
    result["seconds"] = round(time.perf_counter() - start, 3)
    for reader in readers:
        reader.join(timeout=1.0)
    after = _hashes(folder)
    result["damaged"] = [name for name, digest in before.items() if after.get(name) != digest]
    result["leftovers"] = _leftovers(folder)
    stderr = err.getvalue()
    stdout = out.getvalue()
    result["code"] = code
    result["last_line"] = (stderr.strip().splitlines() or [""])[-1][:300]
    result["outcome"] = classify(code, stdout, stderr, case)
    result["unexpected"] = unexpected(case, result, stdout + stderr, folder)
    shutil.rmtree(folder, ignore_errors=True)
    return result


def unexpected(case: dict, result: dict, text: str, folder: Path) -> list[str]:
    """What a case that states its expected outcome (see :data:`CLEAN_ERROR`) did otherwise; empty when it did
    what it expects, or states nothing."""
    reasons = []
    if "expect" in case and result["outcome"] not in case["expect"]:
        reasons.append(f"expected {' or '.join(case['expect'])}, got {result['outcome']}")
    reasons += [f"the output lacks {needle!r}" for needle in case.get("expect_in", ()) if needle not in text]
    reasons += [f"{needle!r} appears {text.count(needle)} times, expected {count}"
                for needle, count in case.get("expect_count", {}).items() if text.count(needle) != count]
    for rel, needle in case.get("expect_files", {}).items():
        path = folder / rel
        if needle is None:
            if path.exists():
                reasons.append(f"{rel} written")
        elif not path.is_file():
            reasons.append(f"{rel} not written")
        elif needle not in path.read_text(encoding="utf-8", errors="replace"):
            reasons.append(f"{rel} lacks {needle!r}")
    if "max_s" in case and result["seconds"] > case["max_s"]:
        reasons.append(f"took {result['seconds']:.1f} s, expected at most {case['max_s']} s")
    return reasons


def _run_signal_case(argv, folder: Path, plan) -> tuple:
    name, delay, repeat = plan
    sig = getattr(signal, name)
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen([sys.executable, "-m", "hillsim.cli", *argv], cwd=folder, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(delay)
    for _ in range(repeat):
        if proc.poll() is None:
            proc.send_signal(sig)
            time.sleep(0.05)
    try:
        _, stderr = proc.communicate(timeout=CASE_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, stderr = proc.communicate()
        return "hang", stderr
    code = proc.returncode
    return (code if code >= 0 else f"killed by {-code}"), stderr


def classify(code, stdout: str, stderr: str, case: dict) -> str:
    if code == "hang":
        return "hang"
    if code == "exception" or "Traceback (most recent call last)" in stderr:
        return "traceback"
    lines = [line for line in stderr.splitlines() if line.strip()]
    if "signal" in case:
        sig = getattr(signal, case["signal"][0])
        expected = 130 if sig == signal.SIGINT else 128 + int(sig)
        if code == expected:
            return "clean signal end"
        if code == 0:  # the run finished before the signal
            return "ran"
        return "other exit"
    if code == 2:
        last = lines[-1] if lines else ""
        if last.startswith(f"hillsim {case['command']}: error:") or last.startswith("hillsim: error:"):
            return "clean error"
        return "other exit"
    if code == 0:
        return "warning" if "warning" in (stdout + stderr).lower() else "ran"
    if code == 3 and case["command"] == "report" and lines and lines[-1].startswith("hillsim report: FAIL: "):
        return "limit FAIL (exit 3)"  # a guarantee limit failed: the report is written and the exit says so
    return "other exit"


def _worker_init():
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run_one(args):
    case, root, shared = args
    try:
        return run_case(case, Path(root), shared)
    except BaseException as exc:  # noqa: BLE001 - a setup failure is reported, not hidden
        return {"id": case["id"], "category": case["category"], "command": case["command"],
                "label": case.get("label", ""), "argv": case["argv"], "code": "setup",
                "outcome": "campaign setup failure", "damaged": [], "leftovers": [], "unexpected": [],
                "seconds": 0.0,
                "last_line": f"{type(exc).__name__}: {exc}"}


OUTCOMES = ("clean error", "warning", "ran", "limit FAIL (exit 3)", "clean signal end", "traceback", "hang",
            "other exit", "campaign setup failure")
COLUMNS = ("cases", "clean error", "warning", "ran", "limit FAIL (exit 3)", "clean signal end", "traceback", "hang",
           "other exit", "lost or damaged input", "left temporaries", "unexpected outcome")


def tally(results: list[dict]) -> dict:
    """Category -> Counter of the table's columns (a case counts once per outcome, and once more for a damaged
    input, left temporaries or an unexpected outcome)."""
    by_cat = defaultdict(Counter)
    for r in results:
        by_cat[r["category"]][r["outcome"]] += 1
        by_cat[r["category"]]["cases"] += 1
        by_cat[r["category"]]["lost or damaged input"] += bool(r["damaged"])
        by_cat[r["category"]]["left temporaries"] += bool(r["leftovers"])
        by_cat[r["category"]]["unexpected outcome"] += bool(r.get("unexpected"))
    return by_cat


def to_look_at(results: list[dict]) -> list[dict]:
    """The cases that did not end as a campaign case must: a traceback, a hang, an undocumented exit, a setup
    failure, a damaged input, left temporaries or an outcome other than the one the case expects."""
    return [r for r in results if r["outcome"] in ("traceback", "hang", "other exit", "campaign setup failure")
            or r["damaged"] or r["leftovers"] or r.get("unexpected")]


def table(results: list[dict]) -> str:
    by_cat = tally(results)
    columns = COLUMNS
    lines = ["| category | " + " | ".join(columns) + " |", "|---|" + "---:|" * len(columns)]
    total = Counter()
    for cat in sorted(by_cat):
        total.update(by_cat[cat])
        lines.append(f"| {cat} | " + " | ".join(str(by_cat[cat][c]) for c in columns) + " |")
    lines.append("| **all** | " + " | ".join(f"**{total[c]}**" for c in columns) + " |")
    commands = Counter(r["command"] for r in results)
    lines.append("")
    lines.append("Cases per command: " + ", ".join(f"{c} {commands[c]}" for c in COMMANDS) + ".")
    return "\n".join(lines)


def run_campaign(cases: list[dict], workers: int = 2) -> tuple[list[dict], float]:
    """Run ``cases`` in ``workers`` processes, each in its own folder below a temporary root (removed after);
    return their results in case order and the wall time in seconds."""
    root = Path(tempfile.mkdtemp(prefix="hillsim-campaign-"))
    start = time.perf_counter()
    try:
        shared = _shared(root / "shared")
        ctx = multiprocessing.get_context("fork")
        with ctx.Pool(processes=max(1, workers), initializer=_worker_init, maxtasksperchild=200) as pool:
            results = list(pool.imap_unordered(_run_one, [(c, str(root), shared) for c in cases], chunksize=1))
    finally:
        shutil.rmtree(root, ignore_errors=True)
    results.sort(key=lambda r: r["id"])
    return results, time.perf_counter() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--only", default=None, help="run only the categories containing this text")
    parser.add_argument("--list", action="store_true", help="list the cases and exit")
    parser.add_argument("--sample", action="store_true",
                        help="only the slow-tier sample: the cases with an expected outcome and every 8th other "
                             "one (no signal case)")
    parser.add_argument("--json", default=None, help="write every case's result to this JSON file")
    args = parser.parse_args(argv)
    cases = all_cases()
    if args.sample:
        cases = sample_cases(cases)
    if args.only:
        cases = [c for c in cases if args.only in c["category"] or args.only == c["command"]]
    if args.list:
        for c in cases:
            print(c["id"], c["category"], "|", c.get("label", ""), "|", " ".join(c["argv"]))
        return 0
    results, wall = run_campaign(cases, args.workers)
    print(table(results))
    print()
    print(f"{len(results)} cases in {wall:.0f} s with {args.workers} worker processes.")
    bad = to_look_at(results)
    if bad:
        print()
        print("Cases to look at:")
        for r in bad:
            print(f"- [{r['category']}] {r['command']} {r['label']!r}: {r['outcome']}, exit {r['code']}, "
                  f"damaged {r['damaged']}, leftovers {r['leftovers']}, unexpected {r.get('unexpected', [])}: "
                  f"{r['last_line']}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1, default=str) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
