"""Closure-law optimization, [limits]/[[load_cases]] parsing, ensemble nets, hillsim optimize-closure."""

import hashlib
import json
import tomllib
from dataclasses import replace

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR, PLANT_HLA339, PLANT_HLA339_GUARANTEE
from hillchart.errors import InputError
from hillsim.cli import main
from simulate.studies.batch import CaseResult
from simulate.studies.closure_opt import ClosureEvaluator, ClosureLaw, best_linear, closure_plant, optimize_closure
from simulate.config import load_plant
from simulate.components.control.governor import closure_law
from simulate.studies.cases import Limits, LoadCase, load_ensemble, load_study


@pytest.fixture(scope="module")
def study():
    return load_study(PLANT_HLA339_GUARANTEE)


@pytest.fixture(scope="module")
def optimum(study):
    # small search (5 x 3 laws, 6 generations, seed 0): enough to beat the linear family clearly
    return optimize_closure(study.plant, study.load_cases, limit=0.50, seed=0, maxiter=6, popsize=5)


def test_guarantee_plant_is_the_shipped_plant_plus_study_sections(study):
    assert study.plant == load_plant(PLANT_HLA339)  # same plant sections (no drift between the two files)
    assert study.limits == Limits(max_speed_rise=0.5, max_head_m=240.0, min_pressure_head_m=5.0)
    assert [lc.name for lc in study.load_cases] == ["rated load", "70 % load", "rated load, low reservoir"]
    assert study.load_cases[2].overrides == {"scenario.initial_power_mw": 200.0, "penstock.static_head_m": 170.0}


def test_closure_law_duration_matches_the_scenario_law():
    for law in (ClosureLaw(12.0), ClosureLaw(10.0, 0.3, 25.0), ClosureLaw(10.0, 0.9, 25.0)):
        t, _ = closure_law(0.68, 2.0, law.closing_time_s, law.break_opening, law.break_time_s)
        assert law.duration_s(0.68) == pytest.approx(t[-1] - 2.0, rel=1e-12)  # same law, two formulas


@pytest.mark.parametrize("kwargs,message", [
    ({"closing_time_s": 0.0}, "closing_time_s must be in (0, 1000]"),
    ({"closing_time_s": 10.0, "break_opening": 0.3}, "go together"),
    ({"closing_time_s": 10.0, "break_opening": -0.1, "break_time_s": 5.0}, "break_opening must be in (0, 1.5)"),
])
def test_bad_closure_laws(kwargs, message):
    with pytest.raises(InputError) as info:
        ClosureLaw(**kwargs)
    assert message in str(info.value)


def test_two_stage_optimum_beats_the_best_linear_closure(optimum):
    law, linear = optimum.law, optimum.best_linear
    assert law.law.break_opening is not None and law.feasible_runs and linear.feasible_runs
    # both meet the limit; the linear one sits on it (brentq to 1e-6 s in T1)
    assert law.max_speed_rise <= 0.50 and linear.max_speed_rise == pytest.approx(0.50, abs=1e-6)
    # acceptance: lower worst max head rise at (no more than) the same worst max speed rise; 0.03 is well below
    # the 0.05 found here and well above what search noise moves (a few 1e-3 between seeds)
    assert law.max_head_rise < linear.max_head_rise - 0.03
    # the Pareto front is non-dominated and contains the optimum's point or a better one at its speed rise
    front = np.array([[f.max_speed_rise, f.max_head_rise] for f in optimum.pareto_two_stage])
    assert np.all(np.diff(front[:, 0]) >= 0) and np.all(np.diff(front[:, 1]) < 0)
    below = front[front[:, 0] <= law.max_speed_rise]
    assert below[:, 1].min() <= law.max_head_rise


def test_the_best_linear_closure_meets_the_limit_when_the_root_lands_past_it(study, monkeypatch):
    """brentq's root lies within its xtol (1e-6 s) of the crossing, on either side; one just past it gives a speed
    rise above the limit by about 1e-8, and was dropped for the best grid point (T1 = 15 s, 0.9 points below the
    limit, a higher head rise). Its neighbour 2 xtol toward the feasible end is taken instead: the closure sits on
    the limit within 1e-7 (the slope there is 0.014 per second of T1). The failing case: the root itself, just past."""
    import simulate.studies.closure_opt as closure_opt

    found = {}

    def past(f, a, b, xtol):
        root = closure_opt_brentq(f, a, b, xtol=1e-9)
        found["root"] = root + 0.5 * xtol * (1.0 if f(a) < 0 else -1.0)  # on the infeasible side
        return found["root"]

    closure_opt_brentq = closure_opt.brentq
    monkeypatch.setattr(closure_opt, "brentq", past)
    evaluator = ClosureEvaluator(study.plant, study.load_cases[:1])
    grid = evaluator.evaluate([ClosureLaw(float(t)) for t in np.linspace(3.0, 30.0, 10)], record=False)
    linear = best_linear(evaluator, "head", 0.50, grid)
    assert linear.max_speed_rise <= 0.50 and linear.max_speed_rise == pytest.approx(0.50, abs=1e-7)
    beyond = evaluator.evaluate([ClosureLaw(closing_time_s=found["root"])], record=False)[0]
    assert beyond.max_speed_rise > 0.50


def test_a_poor_two_stage_law_does_not_beat_the_linear_family(study):
    # the failing side of the acceptance check: slow first stage, fast second stage
    evaluator = ClosureEvaluator(study.plant, study.load_cases)
    poor = evaluator.evaluate([ClosureLaw(18.0, 0.4, 8.0)])[0]
    grid = evaluator.evaluate([ClosureLaw(float(t)) for t in np.linspace(3.0, 30.0, 28)], record=False)
    linear = best_linear(evaluator, "head", poor.max_speed_rise, grid)
    assert poor.feasible_runs and linear.max_speed_rise <= poor.max_speed_rise * (1 + 1e-9)
    assert not poor.max_head_rise < linear.max_head_rise  # the check fails for this law


def test_reverse_mode_minimizes_speed_under_a_head_limit(study):
    plant = load_plant(PLANT_HLA339)
    opt = optimize_closure(plant, (LoadCase("rated", {"scenario.initial_power_mw": 225.0}),), mode="speed",
                           limit=0.25, seed=1, maxiter=5, popsize=5)
    assert opt.law.max_head_rise <= 0.25 and opt.best_linear.max_head_rise <= 0.25 * (1 + 1e-9)
    assert opt.law.max_speed_rise <= opt.best_linear.max_speed_rise  # at least as good as linear


def test_bad_optimize_arguments(study):
    with pytest.raises(InputError, match="mode must be one of head, speed"):
        optimize_closure(study.plant, study.load_cases, mode="power", limit=0.5)
    with pytest.raises(InputError, match="the limit must be a fraction in"):
        optimize_closure(study.plant, study.load_cases, limit=-0.5)
    with pytest.raises(InputError, match="bounds must be three"):
        optimize_closure(study.plant, study.load_cases, limit=0.5, bounds=((3, 30), (0.9, 0.1), (3, 60)))
    with pytest.raises(InputError, match="no linear closure with T1 in"):
        optimize_closure(study.plant, study.load_cases, limit=0.01, maxiter=1, popsize=1)
    freq = load_plant(PLANT_HLA339, {"scenario.kind": "frequency-steps"})
    with pytest.raises(InputError, match="needs a load-rejection or closure-law scenario"):
        closure_plant(freq)


# ---------------------------------------------------------------------------------------------------------------
# ensemble
# ---------------------------------------------------------------------------------------------------------------
def _ensemble_file(tmp_path, scale):
    doc = json.loads((FRANCIS_DIR / "nets.json").read_text())
    member = {"flow": dict(doc["flow"]), "torque": dict(doc["torque"])}
    member["torque"]["b2"] = doc["torque"]["b2"] + scale  # a member with a little more torque everywhere
    doc["ensemble"] = [{"flow": doc["flow"], "torque": doc["torque"]}, member]
    path = tmp_path / "nets.json"
    path.write_text(json.dumps(doc))
    return path


def test_ensemble_worst_case_is_the_worst_member(tmp_path, study):
    members = load_ensemble(_ensemble_file(tmp_path, 0.02))
    assert len(members) == 2
    law = [ClosureLaw(14.0, 0.38, 21.0)]
    single = ClosureEvaluator(study.plant, study.load_cases).evaluate(law)[0]
    both = ClosureEvaluator(study.plant, study.load_cases, members).evaluate(law)[0]
    strong = ClosureEvaluator(study.plant, study.load_cases, members[1:]).evaluate(law)[0]
    assert len(both.cases) == 6
    # member 0 is the base nets: worst case = max over members, exactly
    assert both.max_speed_rise == max(single.max_speed_rise, strong.max_speed_rise)
    assert strong.max_speed_rise != single.max_speed_rise  # the perturbed member really differs


@pytest.mark.parametrize("ensemble,message", [
    ("x", "ensemble must be a list of"),
    ([{"flow": {}}], "ensemble[0] must be an object with the keys flow and torque"),
    ([{"flow": {"inputs": ["n11", "opening"]}, "torque": {}}], "ensemble[0].flow."),
])
def test_bad_ensembles(tmp_path, ensemble, message):
    doc = json.loads((FRANCIS_DIR / "nets.json").read_text())
    doc["ensemble"] = ensemble
    path = tmp_path / "nets.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError) as info:
        load_ensemble(path)
    assert message in str(info.value)


def test_nets_without_ensemble_give_no_members(tmp_path):
    doc = json.loads((FRANCIS_DIR / "nets.json").read_text())
    assert len(load_ensemble(FRANCIS_DIR / "nets.json")) == len(doc["ensemble"]) == 10  # the shipped nets have one
    del doc["ensemble"]
    path = tmp_path / "nets.json"
    path.write_text(json.dumps(doc))
    assert load_ensemble(path) == []


# ---------------------------------------------------------------------------------------------------------------
# [limits] and [[load_cases]] garbage
# ---------------------------------------------------------------------------------------------------------------
def _study_with(tmp_path, extra: str):
    text = PLANT_HLA339.read_text().replace('characteristics = "francis/nets.json"', 'characteristics = "ideal"')
    path = tmp_path / "plant.toml"
    path.write_text(extra + "\n" + text)  # first, so that top-level keys stay top-level
    return path


@pytest.mark.parametrize("extra,message", [
    ("[limits]\nmax_speed_rize = 0.5\n", "unknown key limits.max_speed_rize; valid keys of [limits]"),
    ("[limits]\nmax_speed_rise = -0.5\n", "limits.max_speed_rise must be in (0.0, 5.0], got -0.5"),
    ("[limits]\nmax_head_m = true\n", "limits.max_head_m must be a number"),
    ("[limits]\nmax_head_rise = \"big\"\n", "limits.max_head_rise must be a number"),
    ("[limits]\nmin_pressure_head_m = -20.0\n", "limits.min_pressure_head_m must be in (-10.4"),
    ("limits = 3\n", "[limits] must be a table"),
    ("load_cases = 3\n", "load_cases must be a non-empty array of tables"),
    ("[[load_cases]]\nscenario.initial_power_mw = 100.0\n", "load_cases[0].name must be a non-empty string"),
    ("[[load_cases]]\nname = \"a\"\nscenario.initial_power_mw = 100.0\n[[load_cases]]\nname = \"a\"\n"
     "scenario.initial_power_mw = 120.0\n", "load_cases[1].name 'a' is used twice"),
    ("[[load_cases]]\nname = \"a\"\n", "sets no plant key"),
    ("[[load_cases]]\nname = \"a\"\npower = 100.0\n", "must be written section.key = number"),
    ("[[load_cases]]\nname = \"a\"\nscenario.initial_power = 100.0\n", "unknown key 'scenario.initial_power'"),
    ("[[load_cases]]\nname = \"a\"\nscenario.initial_power_mw = \"full\"\n", "must be a number, got 'full'"),
    ("[[load_cases]]\nname = \"a\"\npenstock.model = 1.0\n", "changes the plant structure"),
    ("[[load_cases]]\nname = \"a\"\nscenario.break_opening = 0.2\n", "is not used by scenario.kind"),
    ("[nonsense]\nx = 1\n", "unknown section [nonsense]"),
])
def test_bad_study_sections(tmp_path, extra, message):
    with pytest.raises(InputError) as info:
        load_study(_study_with(tmp_path, extra))
    assert message in str(info.value)


def test_bad_study_files(tmp_path):
    with pytest.raises(InputError, match="cannot read plant file"):
        load_study(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_bytes(b"[turbine]\nname = \"\xe9\"\n")
    with pytest.raises(InputError, match="is not UTF-8 text"):
        load_study(bad)
    bad.write_text("[turbine\n")
    with pytest.raises(InputError, match="is not valid TOML"):
        load_study(bad)


def test_a_study_file_saved_with_a_byte_order_mark_reads_as_hillsim_run_reads_it(tmp_path):
    """A Windows editor's UTF-8 byte-order mark: the study (limits, load cases) reads as without it, as the plant
    file of hillsim run does (it was 'not valid TOML' here at line 1, column 1)."""
    plain = load_study(PLANT_HLA339_GUARANTEE)
    marked = tmp_path / "guarantee.toml"
    text = PLANT_HLA339_GUARANTEE.read_text(encoding="utf-8").replace(
        '"francis/nets.json"', json.dumps(str(PLANT_HLA339_GUARANTEE.parent / "francis" / "nets.json")))
    marked.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    study = load_study(marked)
    assert study.limits == plain.limits and study.load_cases == plain.load_cases
    assert study.plant.turbine.rated_power_mw == plain.plant.turbine.rated_power_mw
    assert study.sha256 == hashlib.sha256(marked.read_bytes()).hexdigest()  # the file as it is, mark included
    # a mark in the middle of the file is no mark: still an error naming the file
    marked.write_bytes(text.encode("utf-8") + b"\xef\xbb\xbf")
    with pytest.raises(InputError, match="guarantee.toml' is not valid TOML"):
        load_study(marked)


STUDY_NOTE = (f"note: {PLANT_HLA339_GUARANTEE}: [limits] and [[load_cases]] are read by hillsim report and "
              f"optimize-closure; ignored here")


def test_hillsim_run_reads_a_study_file_as_its_plant_with_one_note(tmp_path, capsys):
    """hillsim run reads the guarantee study's file (it refused it: "unknown section [limits]") as the plain plant:
    the same run as plant_hla339.toml, no load case applied, and one note naming the sections it ignores."""
    short = ["--no-plot", "--set", "scenario.t_end_s=3"]
    assert main(["run", str(PLANT_HLA339_GUARANTEE), "--out", str(tmp_path / "study"), *short]) == 0
    err = capsys.readouterr().err
    assert err.splitlines()[0] == f"hillsim run: {STUDY_NOTE}" and err.count("note:") == 1
    assert main(["run", str(PLANT_HLA339), "--out", str(tmp_path / "plain"), *short]) == 0
    assert "note:" not in capsys.readouterr().err
    study, plain = (json.loads((tmp_path / name / "summary.json").read_text()) for name in ("study", "plain"))
    assert study == plain and study["max_speed_rise"] > 0.05  # the plant's own 225 MW, not a load case's
    # the study sections are still validated where they are read
    bad = _study_with(tmp_path, "[limits]\nmax_speed_rize = 0.5\n")
    assert main(["report", str(bad), "--out", str(tmp_path / "rep")]) == 2
    assert "unknown key limits.max_speed_rize" in capsys.readouterr().err and not (tmp_path / "rep").exists()
    # another unknown section is refused, with no word of studies
    with pytest.raises(InputError) as info:
        load_plant(_study_with(tmp_path, "[nonsense]\nx = 1\n"))
    assert "unknown section [nonsense]" in str(info.value) and "load_study" not in str(info.value)


def test_sweep_identify_and_linearize_read_a_study_file_with_one_note(tmp_path, capsys):
    assert main(["sweep", str(PLANT_HLA339_GUARANTEE), "--vary", "governor.kp=2,3", "--out", str(tmp_path / "sw"),
                 "--no-plot", "--set", "scenario.t_end_s=3"]) == 0
    assert capsys.readouterr().err.count(f"hillsim sweep: {STUDY_NOTE}") == 1
    assert main(["identify", str(PLANT_HLA339_GUARANTEE), "--out", str(tmp_path / "id"), "--no-plot",
                 "--penstock-model", "rigid"]) == 0
    assert capsys.readouterr().err.count(f"hillsim identify: {STUDY_NOTE}") == 1
    nets = str(FRANCIS_DIR / "nets.json")
    assert main(["linearize", nets, "--plant", str(PLANT_HLA339_GUARANTEE)]) == 0
    study = capsys.readouterr()
    assert study.err.count(f"hillsim linearize: {STUDY_NOTE}") == 1
    assert main(["linearize", nets, "--plant", str(PLANT_HLA339)]) == 0
    plain = json.loads(capsys.readouterr().out)
    assert json.loads(study.out)["operating_point"] == plain["operating_point"]
    # the plant's scenario, not the last load case's 200 MW
    assert plain["operating_point"]["power_mw"] == pytest.approx(225.0, rel=1e-12)


def test_limits_verdicts():
    limits = Limits(max_speed_rise=0.5, max_head_m=200.0, min_pressure_head_m=5.0)
    case = CaseResult(index=0, values={}, status="ok", max_speed_rise=0.45, max_head_m=210.0)
    rows = {r["limit"]: r["verdict"] for r in limits.check(case)}
    assert rows == {"max_speed_rise": "PASS", "max_head_m": "FAIL", "min_pressure_head_m": "n/a"}
    failed = CaseResult(index=0, values={}, status="error")
    assert {r["verdict"] for r in limits.check(failed)} == {"n/a"}


def test_limits_are_judged_on_the_conservative_side_of_the_band():
    """A maximum is judged at the band's upper end, a minimum at its lower end: a point figure inside its limit
    whose band reaches past it FAILs (the chart does not exclude it); a band well inside PASSes."""
    limits = Limits(max_speed_rise=0.5, min_pressure_head_m=5.0)
    case = CaseResult(index=0, values={}, status="ok", max_speed_rise=0.48, min_pressure_head_m=6.0)
    point = {r["limit"]: r["verdict"] for r in limits.check(case)}
    assert point == {"max_speed_rise": "PASS", "min_pressure_head_m": "PASS"}
    wide = {"max_speed_rise": {"low": 0.46, "high": 0.51}, "min_pressure_head_m": {"low": 4.5, "high": 7.0}}
    rows = {r["limit"]: r for r in limits.check(case, wide)}
    assert {k: r["verdict"] for k, r in rows.items()} == {"max_speed_rise": "FAIL", "min_pressure_head_m": "FAIL"}
    assert rows["max_speed_rise"]["band"] == [0.46, 0.51] and rows["max_speed_rise"]["judged"] == "band"
    narrow = {"max_speed_rise": {"low": 0.47, "high": 0.49}, "min_pressure_head_m": {"low": 5.5, "high": 6.5}}
    assert {r["verdict"] for r in limits.check(case, narrow)} == {"PASS"}
    # a band that does not contain the point figure never makes the verdict milder than the point nets'
    below = {"max_speed_rise": {"low": 0.40, "high": 0.45}}
    assert limits.check(case, below)[0]["verdict"] == "PASS"
    assert Limits(max_speed_rise=0.47).check(case, below)[0]["verdict"] == "FAIL"  # 0.48 > 0.47 at the point


# ---------------------------------------------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------------------------------------------
def test_optimize_closure_cli_writes_law_front_and_a_verification_that_agrees(tmp_path, capsys):
    out = tmp_path / "opt"
    code = main(["optimize-closure", str(PLANT_HLA339_GUARANTEE), "--out", str(out), "--maxiter", "3",
                 "--popsize", "3"])
    assert code == 0
    doc = json.loads((out / "closure.json").read_text())
    assert doc["mode"] == "head" and doc["limit"] == 0.5  # from [limits] of the file
    assert doc["law"]["max_speed_rise"] <= 0.5 and len(doc["verification"]) == 3
    assert doc["verification_max_abs_difference"] <= 1e-9  # hillsim run == batch (promised: 1e-9)
    # every case leaves the digitized region once the vanes close below the lowest digitized opening (the
    # simulator's extrapolation record says so, and the optimizer passes it on); none leaves the nets' training range
    assert len(doc["extrapolated_cases"]) == 3 and all(c["beyond_nets_range"] is False for c in doc["cases"])
    # ... and the warning says so in one phrase instead of listing the three runs
    assert "trusted domain in every run (3 load case(s) x 1 characteristics)" in capsys.readouterr().out
    worst = max(c["max_head_rise"] for c in doc["cases"])
    assert doc["law"]["max_head_rise"] == worst
    run_summary = json.loads((out / "verification" / "0" / "summary.json").read_text())
    assert run_summary["scenario"] == "closure-law"
    assert run_summary["max_speed_rise"] == doc["verification"][0]["max_speed_rise_batch"]
    plant = tomllib.loads((out / "optimum_plant.toml").read_text())
    # optimum_plant.toml holds the law exactly; closure.json rounds to 12 significant digits like summary.json
    assert plant["scenario"]["break_opening"] == pytest.approx(doc["law"]["break_opening"], rel=1e-11)
    for name in ("pareto.png", "law.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_optimize_closure_writes_a_plant_with_a_step_up_table(tmp_path, capsys):
    """The plant writer refused the nested table [turbine.step_up] ("cannot write {...} as TOML") after the whole
    optimization, so nothing was written; the verification runs read the written plant, so their agreement with the
    batch (1e-9) shows the step-up reached them."""
    out = tmp_path / "opt"
    code = main(["optimize-closure", str(PLANT_HLA339_GUARANTEE), "--out", str(out), "--maxiter", "1", "--popsize",
                 "1", "--workers", "1", "--no-plot", "--quiet", "--set",
                 "turbine.step_up={method = \"iec60193\", model_head_m = 25.0}"])
    assert code == 0, capsys.readouterr().err
    doc = json.loads((out / "closure.json").read_text())
    assert doc["verification_max_abs_difference"] <= 1e-9
    plant = tomllib.loads((out / "optimum_plant.toml").read_text())
    assert plant["turbine"]["step_up"] == {"method": "iec60193", "model_diameter_m": 0.35, "model_head_m": 25.0,
                                           "kinematic_viscosity_m2_s": 1e-6, "scalable_loss_share": 0.7,
                                           "reynolds_reference": 7e6}
    assert tomllib.loads((out / "verification" / "0" / "plant.toml").read_text())["turbine"]["step_up"] \
        == plant["turbine"]["step_up"]


def test_plant_writer_writes_nested_tables_at_any_depth():
    """[turbine.step_up] of the plant and [units.turbine.step_up] of one unit read back equal (None keys left out)."""
    from data_synthetic import PLANT_TWO_UNITS
    from simulate.config import plant_from_dict
    from simulate.studies.cases import plant_toml

    raw = tomllib.loads(PLANT_TWO_UNITS.read_text(encoding="utf-8"))
    raw["turbine"]["step_up"] = {"method": "iec60193"}
    raw["units"][1]["turbine"] = {"step_up": {"method": "iec60193", "model_diameter_m": 0.5}}
    plant = plant_from_dict(raw, base_dir=PLANT_TWO_UNITS.parent)
    text = plant_toml(plant)
    assert "\n[turbine.step_up]\nmethod = \"iec60193\"\n" in text
    assert "\n[units.turbine.step_up]\nmethod = \"iec60193\"\nmodel_diameter_m = 0.5\n" in text
    again = plant_from_dict(tomllib.loads(text), base_dir=plant.base_dir)
    assert again.turbine.step_up == plant.turbine.step_up and again.turbine.step_up.model_diameter_m == 0.35
    assert [u.turbine.step_up for u in again.units] == [u.turbine.step_up for u in plant.units]
    assert again.units[1].turbine.step_up.model_diameter_m == 0.5


def test_optimum_plant_is_a_study_file_that_report_and_run_read_back(tmp_path, capsys):
    """optimum_plant.toml keeps [limits] and [[load_cases]] and names the nets relative to itself (it lost the limits
    and held an absolute path): hillsim report runs every load case under the law, with the figures of closure.json,
    and hillsim run the worst case, with the figures of its verification run."""
    import os

    out = tmp_path / "opt"
    assert main(["optimize-closure", str(PLANT_HLA339_GUARANTEE), "--out", str(out), "--maxiter", "2",
                 "--popsize", "2", "--no-plot", "--quiet"]) == 0
    doc = json.loads((out / "closure.json").read_text())
    raw = tomllib.loads((out / "optimum_plant.toml").read_text())
    nets = raw["turbine"]["characteristics"]
    assert not os.path.isabs(nets) and nets == os.path.relpath(FRANCIS_DIR / "nets.json", out).replace(os.sep, "/")
    assert raw["limits"] == {"max_speed_rise": 0.5, "max_head_m": 240.0, "min_pressure_head_m": 5.0}
    written = load_study(out / "optimum_plant.toml")
    original = load_study(PLANT_HLA339_GUARANTEE)
    assert written.limits == original.limits
    assert [lc.name for lc in written.load_cases] == [lc.name for lc in original.load_cases]
    for lc, was in zip(written.load_cases, original.load_cases):  # each case's own keys, as in the study
        assert {k: lc.overrides[k] for k in was.overrides} == was.overrides
    # report: every load case under the optimum law, the figures closure.json has for them
    code = main(["report", str(out / "optimum_plant.toml"), "--out", str(tmp_path / "rep"), "--quiet"])
    report = json.loads((tmp_path / "rep" / "report.json").read_text())
    assert code == (3 if report["overall_verdict"] == "FAIL" else 0)
    assert [c["name"] for c in report["cases"]] == [c["load_case"] for c in doc["cases"]]
    for case, expected in zip(report["cases"], doc["cases"]):
        for key in ("max_speed_rise", "max_head_rise", "max_head_m"):
            assert case[key] == pytest.approx(expected[key], rel=1e-10), (case["name"], key)
    assert len({c["max_head_m"] for c in report["cases"]}) == 3  # three different cases, not one three times
    # run: the worst load case, as its verification run gave it; the study sections ignored with one note
    capsys.readouterr()
    assert main(["run", str(out / "optimum_plant.toml"), "--out", str(tmp_path / "run"), "--no-plot"]) == 0
    assert "[limits] and [[load_cases]] are read by hillsim report" in capsys.readouterr().err
    worst = max(range(3), key=lambda i: doc["cases"][i]["max_head_rise"])
    run = json.loads((tmp_path / "run" / "summary.json").read_text())
    verified = json.loads((out / "verification" / str(worst) / "summary.json").read_text())
    assert {k: run[k] for k in ("max_speed_rise", "max_head_rise", "max_head_m", "initial_power_mw")} == \
        {k: verified[k] for k in ("max_speed_rise", "max_head_rise", "max_head_m", "initial_power_mw")}
    # the verification plant files name the nets relative to themselves too
    case_file = tomllib.loads((out / "verification" / "0" / "plant.toml").read_text())
    assert not os.path.isabs(case_file["turbine"]["characteristics"])


def test_explicit_load_cases_give_each_case_on_a_plant_carrying_another(study, tmp_path):
    """The plant of optimum_plant.toml carries the worst case's keys: written as in the study, the low-reservoir case's
    170 m would leak into the rated-load case, which does not set the static head. Explicit, each case gives its own
    plant whichever case the plant carries, also when one case gives an initial opening instead of a power."""
    from simulate.studies.batch import variant_overrides
    from simulate.studies.cases import explicit_load_cases, study_toml

    cases = (*study.load_cases, LoadCase("opening", {"scenario.initial_opening": 0.5}))
    plant = study.plant

    def of(base, lc):
        return base.with_overrides(variant_overrides(lc.overrides))

    explicit = explicit_load_cases(cases, plant)
    assert explicit[0].overrides == {"scenario.initial_power_mw": 225.0, "penstock.static_head_m": 180.0}
    assert explicit[3].overrides == {"scenario.initial_opening": 0.5, "penstock.static_head_m": 180.0}
    for carried in range(len(cases)):
        base = of(plant, explicit[carried])
        for lc, exp in zip(cases, explicit):
            assert of(base, exp) == of(plant, lc), (carried, lc.name)
    # without: the rated-load case on the low-reservoir plant keeps 170 m
    assert of(of(plant, cases[2]), cases[0]).penstock.static_head_m == 170.0
    # written after the plant and read back: the same plant, limits and cases (a name TOML must escape too)
    from simulate.studies.cases import plant_toml

    named = (*explicit[:3], LoadCase('opening "half" \u00e9\U0001f600', explicit[3].overrides))
    path = tmp_path / "study.toml"
    path.write_text(plant_toml(plant, relative_to=tmp_path) + "\n" + study_toml(study.limits, named),
                    encoding="utf-8")
    again = load_study(path)
    chars = again.plant.turbine.characteristics
    assert not chars.startswith("/") and (tmp_path / chars).resolve() == (FRANCIS_DIR / "nets.json").resolve()
    assert again.plant == replace(plant, base_dir=tmp_path.resolve(),
                                  turbine=replace(plant.turbine, characteristics=chars))
    assert again.limits == study.limits and again.load_cases == named


@pytest.mark.parametrize("args,message", [
    (["--max-speed-rise", "-0.5"], "--max-speed-rise must be a fraction in (0, 5]"),
    (["--max-head-rise", "nan"], "--max-head-rise must be a fraction in (0, 5]"),
    (["--max-speed-rise", "0.5", "--maxiter", "0"], "--maxiter must be an integer >= 1"),
    (["--max-speed-rise", "0.5", "--set", "scenario.kind=frequency-steps"],
     "load_cases[0] ('rated load'): varied key 'scenario.initial_power_mw' is not used by scenario.kind"),
])
def test_optimize_closure_cli_garbage(tmp_path, capsys, args, message):
    out = tmp_path / "never"
    code = main(["optimize-closure", str(PLANT_HLA339_GUARANTEE), "--out", str(out), *args])
    assert code == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_optimize_closure_cli_needs_a_limit(tmp_path, capsys):
    assert main(["optimize-closure", str(PLANT_HLA339), "--out", str(tmp_path / "x")]) == 2
    assert "give --max-speed-rise or --max-head-rise" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # argparse: not both
        main(["optimize-closure", str(PLANT_HLA339), "--out", str(tmp_path / "x"), "--max-speed-rise", "0.5",
              "--max-head-rise", "0.3"])
