"""The cases of ``benchmarks/bench_fault_campaign.py`` that state their expected outcome (``expect``, see
:data:`fault_campaign.CLEAN_ERROR`): former tracebacks, absurd values that must be refused or warned, good input that
must run, messages that must name the cause, and a guarantee study's plant file given to every command. The slow
tier runs every one of them (:func:`bench_fault_campaign.sample_cases`).
"""

from __future__ import annotations

from fault_campaign import CLEAN_ERROR, LIMIT_FAIL, RAN, RAN_QUIET, SHORT, WARNING
from fault_campaign import new_case as _c


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
