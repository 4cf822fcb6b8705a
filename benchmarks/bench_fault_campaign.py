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
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the campaign's harness beside this script

from fault_campaign import (CHART, NETS, PLANT, RAN, REMOVE, SHORT, plant_text, run_campaign, table,  # noqa: E402
                            to_look_at)
# the suite reads these from this script (tests/hillsim/test_reliability.py)
from fault_campaign import COMMANDS, LIMIT_FAIL, tally  # noqa: E402, F401
from fault_campaign import new_case as _c  # noqa: E402
from fault_campaign_expected import expected_outcome_cases  # noqa: E402


# ------------------------------------------------------------------------------------------------ the cases


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
    "UTF-16 (Notepad)": [("write", "plant.toml", plant_text(PLANT).encode("utf-16"))],
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
