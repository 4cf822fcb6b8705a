"""The pump-turbine plant through hillsim run, sweep, report and run --uncertainty: every command runs on the
four-quadrant boundary of its characteristics' kind and gives the same figures, and the report judges and draws
the four-quadrant figures."""

import csv
import json

import pytest

from data_synthetic import PUMP_TURBINE_DIR
from hillchart.errors import InputError
from hillsim.cli import main
from simulate.studies.batch import CaseResult
from simulate.studies.cases import Limits

PLANT = PUMP_TURBINE_DIR.parent / "plant_pump_turbine.toml"
#: 12 s: past the first speed peak and flow reversal (5.7 s) and past 4.28 s, where the pressure loop fails
SHORT = ["--set", "scenario.t_end_s=12.0"]


def study_file(tmp_path, name: str, limits: str):
    """The shipped plant (12 s) with its nets by absolute path and a [limits] section."""
    text = PLANT.read_text(encoding="utf-8").replace('"pump_turbine/nets.json"',
                                                       json.dumps(str(PUMP_TURBINE_DIR / "nets.json")))
    path = tmp_path / name
    path.write_text(text.replace("t_end_s = 40.0", "t_end_s = 12.0") + "\n[limits]\n" + limits, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("pump_turbine")
    assert main(["run", str(PLANT), "--out", str(base / "run"), "--no-plot", "--uncertainty", *SHORT]) == 0
    assert main(["sweep", str(PLANT), "--vary", "generator.inertia_time_s=6,7", "--out", str(base / "sw"),
                 "--no-plot", *SHORT]) == 0
    failing = study_file(base, "failing.toml", "max_speed_rise = 0.6\nmax_reverse_speed_pct = 10.0\n"
                                               "max_reverse_flow_m3_s = 8.0\n")
    assert main(["report", str(failing), "--out", str(base / "rep")]) == 3  # a limit FAILs
    passing = study_file(base, "passing.toml", "max_reverse_flow_m3_s = 12.0\n")
    assert main(["report", str(passing), "--out", str(base / "rep_pass")]) == 0
    read = lambda *p: json.loads(base.joinpath(*p).read_text(encoding="utf-8"))  # noqa: E731
    with open(base / "sw" / "results.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    return {"summary": read("run", "summary.json"), "rows": rows, "report": read("rep", "report.json"),
            "passing": read("rep_pass", "report.json"), "html": (base / "rep" / "report.html").read_text()}


def test_sweep_and_report_give_the_run_s_figures(runs):
    """Sweep and report run to the end (before, both failed at 4.28 s in the pressure loop) and give hillsim run's
    figures to the digit the files carry (each file's floats are the same tidy rounding of the same run)."""
    run, case = runs["summary"], runs["report"]["cases"][0]
    same = next(r for r in runs["rows"] if float(r["generator.inertia_time_s"]) == 6.0)
    assert all(r["status"] == "ok" for r in runs["rows"]) and case["status"] == "ok"
    for name in ("max_speed_rise", "max_head_m", "max_speed_rpm"):
        assert case[name] == run[name], name
        assert float(same[name]) == pytest.approx(run[name], rel=1e-11), name  # csv: repr, summary: 12 digits
    assert float(same["t_runaway_s"]) == pytest.approx(run["t_runaway_s"], rel=1e-11)  # the sweep's column
    assert case["four_quadrant"]["t_runaway_s"] == run["t_runaway_s"]


def test_run_gives_the_four_quadrant_figures_and_their_band(runs, capsys):
    """summary.json has the figures; --uncertainty bands them over the four members of the shipped nets, each
    band holding the central run's figure with a width > 0 (the reverse speed stays 0 in every member)."""
    s = runs["summary"]
    assert s["max_reverse_speed_rpm"] == 0.0 and 9.0 < s["max_reverse_flow_m3_s"] < 11.0
    assert 5.0 < s["t_runaway_s"] < s["t_flow_reversal_s"] < 6.0  # the peak where the torque turns, then Q < 0
    band = s["uncertainty"]
    assert band["members"] == 4 and band["failed"] == []
    for name in ("max_speed_rise", "max_reverse_flow_m3_s", "t_runaway_s"):
        assert band[name]["low"] <= s[name] <= band[name]["high"] and band[name]["high"] > band[name]["low"]


def test_report_judges_the_four_quadrant_limits(runs):
    """max_reverse_flow_m3_s = 8 FAILs (10.05 m^3/s backwards, the band's upper end 10.13), 12 PASSes; no reverse
    rotation PASSes a 10 % limit; the table and the Suter chart replace the hill chart's contours."""
    verdicts = {v["limit"]: v for v in runs["report"]["cases"][0]["verdicts"]}
    assert verdicts["max_reverse_flow_m3_s"]["verdict"] == "FAIL" and verdicts["max_reverse_flow_m3_s"]["judged"] \
        == "band"
    assert verdicts["max_reverse_speed_pct"]["verdict"] == "PASS" and verdicts["max_speed_rise"]["verdict"] == "PASS"
    assert [v["verdict"] for v in runs["passing"]["cases"][0]["verdicts"]] == ["PASS"]
    assert runs["report"]["chart_heading"] == "Four-quadrant characteristics and operating range"
    assert "Four-quadrant characteristics and operating range" in runs["html"]
    assert "iso-efficiency" not in runs["report"]["chart_caption"]
    assert "max reverse flow (m3/s)" in runs["html"]


def test_a_four_quadrant_limit_on_a_plant_that_cannot_give_it_says_so():
    """A Francis run has no reverse figures: the limit is not judged (n/a) and the row says what it needs; the
    same case with the figure is judged."""
    limits = Limits.from_dict({"max_reverse_speed_pct": 5.0})
    francis = CaseResult(index=0, values={}, status="ok", max_speed_rise=0.3)
    (row,) = limits.check(francis)
    assert row["verdict"] == "n/a" and "four quadrants" in row["why"]
    pump = CaseResult(index=0, values={}, status="ok", components={"max_reverse_speed_pct": 6.0})
    assert limits.check(pump)[0]["verdict"] == "FAIL"
    assert Limits.from_dict({"max_reverse_speed_pct": 7.0}).check(pump)[0]["verdict"] == "PASS"


def test_an_unknown_or_bad_limit_is_refused():
    with pytest.raises(InputError, match="max_reverse_speed_pct"):  # the valid keys are named
        Limits.from_dict({"max_reverse_speed": 5.0})
    with pytest.raises(InputError, match="limits.max_reverse_flow_m3_s"):
        Limits.from_dict({"max_reverse_flow_m3_s": -1.0})


def test_a_band_not_calibrated_on_the_table_is_said(runs, tmp_path, capsys):
    """Four-quadrant nets whose band is the members' training spread (a nets.json written before its calibration,
    or trained with calibrate=False) are run with a warning naming the command that calibrates them; the shipped
    nets, calibrated, without one (the summary of the module's run holds no warning)."""
    from hillchart.four_quadrant.nets import load_suter_nets
    from simulate.components.turbine.four_quadrant import SuterCharacteristics
    from simulate.studies.uncertainty import uncalibrated_band_note

    assert "warnings" not in runs["summary"]["uncertainty"]
    doc = json.loads((PUMP_TURBINE_DIR / "nets.json").read_text(encoding="utf-8"))
    del doc["training"]["band"]
    folder = tmp_path / "pump_turbine"
    folder.mkdir()
    (folder / "nets.json").write_text(json.dumps(doc), encoding="utf-8")
    nets = load_suter_nets(folder / "nets.json")
    chars = SuterCharacteristics.from_nets(nets, rated=nets.training["rated"], opening_max=28.0, name="old")
    assert "not calibrated on the table's lines" in uncalibrated_band_note(chars)
    plant = tmp_path / "plant.toml"
    plant.write_text(PLANT.read_text(encoding="utf-8"), encoding="utf-8")  # its nets: pump_turbine/nets.json beside
    assert main(["run", str(plant), "--out", str(tmp_path / "run"), "--no-plot", "--uncertainty", *SHORT]) == 0
    err = capsys.readouterr().err
    assert "warning: the band of these four-quadrant nets is their members' training spread" in err
    assert "hillsim four-quadrant TABLE_DIR" in err
    summary = json.loads((tmp_path / "run" / "summary.json").read_text(encoding="utf-8"))
    assert len(summary["uncertainty"]["warnings"]) == 1
    # the report judges its limits on that band, and says so once; the shipped nets' report does not
    study = tmp_path / "study.toml"
    study.write_text(plant.read_text(encoding="utf-8").replace("t_end_s = 40.0", "t_end_s = 12.0")
                     + "\n[limits]\nmax_reverse_flow_m3_s = 12.0\n", encoding="utf-8")
    assert main(["report", str(study), "--out", str(tmp_path / "rep")]) == 0
    said = json.loads((tmp_path / "rep" / "report.json").read_text(encoding="utf-8"))["warnings"]
    assert sum("training spread" in w for w in said) == 1
    assert not any("training spread" in w for w in runs["passing"]["warnings"])
