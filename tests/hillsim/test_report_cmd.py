"""hillsim report: every number on the page equals report.json, which equals the hillsim run files; sections,
PASS/FAIL, warnings, envelope, garbage."""

import json
import re
from html.parser import HTMLParser

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR, PLANT_HLA339, PLANT_HLA339_GUARANTEE
from hillsim.cli import main

SECTIONS = ("Plant data sheet", "Guarantee limits", "Load cases", "What decided each figure", "Transients",
            "Head envelope along the penstock", "Hill chart and operating range", "Extrapolation warnings",
            "Closure-law optimization", "Sweep")


class Cells(HTMLParser):
    def __init__(self):
        super().__init__()
        self.cells, self.headings, self.images, self._in_h2 = [], [], [], False

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "td" and "data-key" in attrs:
            self.cells.append((attrs["data-key"], attrs.get("data-value")))
        if tag == "h2":
            self._in_h2 = True
        if tag == "img":
            self.images.append(attrs.get("src", ""))

    def handle_endtag(self, tag):
        if tag == "h2":
            self._in_h2 = False

    def handle_data(self, data):
        if self._in_h2:
            self.headings.append(data)


def resolve(doc, dotted):
    for part in dotted.split("."):
        doc = doc[int(part)] if isinstance(doc, list) else doc[part]
    return doc


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    base = tmp_path_factory.mktemp("report")
    assert main(["optimize-closure", str(PLANT_HLA339_GUARANTEE), "--out", str(base / "opt"), "--maxiter", "2",
                 "--popsize", "2"]) == 0
    assert main(["sweep", str(PLANT_HLA339), "--vary", "governor.closing_time_s=8,12", "--out", str(base / "sw"),
                 "--set", "scenario.t_end_s=6"]) == 0
    out = base / "rep"
    assert main(["report", str(PLANT_HLA339_GUARANTEE), "--out", str(out), "--closure", str(base / "opt"),
                 "--sweep", str(base / "sw")]) == 0
    html = (out / "report.html").read_text()
    parser = Cells()
    parser.feed(html)
    return out, html, json.loads((out / "report.json").read_text()), parser


def test_every_number_on_the_page_equals_report_json(made):
    out, html, doc, cells = made
    assert len(cells.cells) > 60
    for key, value in cells.cells:
        file, dotted = key.split(":", 1)
        assert file == "report.json"
        expected = resolve(doc, dotted)
        if isinstance(expected, str):  # a verdict cell
            assert re.search(rf"data-key='report.json:{re.escape(dotted)}'>{expected}<", html)
        else:
            assert value == repr(expected), key  # the exact float, not a rounded display


def test_report_json_equals_the_hillsim_run_files_of_each_case(made):
    out, html, doc, cells = made
    assert [c["name"] for c in doc["cases"]] == ["rated load", "70 % load", "rated load, low reservoir"]
    for case in doc["cases"]:
        summary = json.loads((out / case["summary_file"]).read_text())
        series = np.loadtxt(out / case["timeseries_file"], delimiter=",", skiprows=1)
        for key in ("max_speed_rise", "max_head_rise", "max_head_m", "t_max_speed_s", "initial_power_mw"):
            assert case[key] == summary[key]
        assert case["min_head_m"] == pytest.approx(series[:, 2].min(), rel=1e-9)  # csv has 10 digits
    # the plant data sheet: Tw and 2L/a of the shipped penstock by hand (two segments)
    g = 9.81  # hillchart.constants.G_M_S2 (the papers' value)
    tw = (320 / (g * np.pi * 6.2 ** 2 / 4) + 180 / (g * np.pi * 5.6 ** 2 / 4)) * 142.5 / 176.0
    # report.json is rounded to 12 significant digits, as every summary.json is
    assert doc["plant"]["penstock"]["water_time_s"] == pytest.approx(tw, rel=1e-11)
    assert doc["plant"]["penstock"]["two_l_over_a_s"] == pytest.approx(2 * (320 / 1120 + 180 / 1180), rel=1e-11)
    assert doc["closure"]["law"] == json.loads((out.parent / "opt" / "closure.json").read_text())["law"]


def test_each_figure_carries_its_extrapolation_share_from_the_run(made):
    """Beside each guarantee figure (load-case table) and each judged limit (verdict table): the share of the run up
    to the figure outside the digitized chart, the same number as the case's summary.json."""
    out, html, doc, cells = made
    keys = {key for key, _ in cells.cells}
    for i, case in enumerate(doc["cases"]):
        record = json.loads((out / case["summary_file"]).read_text())["extrapolation"]["figures"]
        for figure in ("max_speed_rise", "max_head_rise", "min_head_drop"):
            assert case["extrapolation_share"][figure] == record[figure]["digitized_region"]
            assert f"report.json:cases.{i}.extrapolation_share.{figure}" in keys
        # a load rejection's shut vanes are below the lowest digitized line: the maxima are partly extrapolated
        assert 0.0 < case["extrapolation_share"]["max_head_rise"] < 1.0
    share = doc["cases"][0]["extrapolation_share"]["max_speed_rise"]
    assert re.search(rf'data-key="report.json:cases.0.extrapolation_share.max_speed_rise">{share:.0%}<', html)
    assert "run outside the chart up to it" in html


def test_page_has_every_section_self_contained(made):
    out, html, doc, cells = made
    assert all(s in cells.headings for s in SECTIONS)
    assert len(cells.images) == 3 + 1 + 1 + 1 + 1  # transients, envelope, hill chart, pareto, sweep
    assert all(src.startswith("data:image/png;base64,") for src in cells.images)
    assert doc["hillsim_version"] and re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d UTC", doc["date_utc"])
    roles = {i["role"]: i["sha256"] for i in doc["inputs"]}
    import hashlib
    assert roles["plant file"] == hashlib.sha256(PLANT_HLA339_GUARANTEE.read_bytes()).hexdigest()
    assert roles["characteristics"] == hashlib.sha256((FRANCIS_DIR / "nets.json").read_bytes()).hexdigest()
    # the shipped limits: speed and head PASS, min pressure head not judged without the envelope
    verdicts = {(c["name"], v["limit"]): v["verdict"] for c in doc["cases"] for v in c["verdicts"]}
    assert verdicts[("rated load", "max_speed_rise")] == "PASS"
    assert verdicts[("rated load", "min_pressure_head_m")] == "n/a"
    assert doc["overall_verdict"] == "PASS (some limits not judged)"
    # the shipped nets carry an ensemble: each banded limit is judged on the conservative side of the band
    assert doc["judged_on"].startswith("the conservative side of the ensemble's 5-95 % band")
    # ... and says what decides the figures below the lowest digitized line: the weighed hypotheses and their
    # held-out evidence, from the nets' training record (the in-class shipped chart leads with the model, in its
    # form with the throat foot, 0.64 likely given the chart)
    evidence = doc["extrapolation_evidence"]
    assert evidence["leading_hypothesis_q11"] == "other-form-model" and evidence["held_out_points"] == 21
    assert "held-out lines (leading: other-form-model)" in doc["judged_on"]
    assert "within 0.4 % (Q11)" in doc["judged_on"]
    speed = next(v for v in doc["cases"][0]["verdicts"] if v["limit"] == "max_speed_rise")
    low, high = speed["band"]
    assert speed["judged"] == "band" and low < speed["value"] < high


def test_the_report_says_what_decided_the_max_speed_rise(made):
    """Rated load: the conservative end of the max speed rise came from the member with the largest figure; its
    maximum, by hand from that member's time series in the report folder (N11 = n D1 / sqrt(H)), lies below the
    lowest digitized line, and the page names the region and the hypotheses' weights of nets.json."""
    out, html, doc, cells = made
    case = doc["cases"][0]
    decided = case["decided"]["max_speed_rise"]
    values = case["band"]["max_speed_rise"]["values"]
    k = int(np.argmax(values))
    assert decided["member"] == k and decided["member_value"] == values[k]
    assert decided["conservative_end"] == case["band"]["max_speed_rise"]["high"]
    series = np.genfromtxt(out / decided["timeseries_file"], delimiter=",", names=True)
    assert decided["timeseries_file"] == f"cases/0/member_{k}_timeseries.csv"
    i = int(np.argmax(series["speed_rpm"]))
    # the csv holds 10 significant digits, report.json 12
    assert decided["time_s"] == pytest.approx(series["time_s"][i], rel=1e-9)
    assert decided["n11_rpm"] == pytest.approx(series["speed_rpm"][i] * 4.5 / np.sqrt(series["head_m"][i]), rel=2e-9)
    assert decided["opening"] == pytest.approx(series["opening_chart"][i], rel=1e-9)
    assert series["speed_rpm"][i] / series["speed_rpm"][0] - 1 == pytest.approx(values[k], rel=1e-9)
    # failing case beside: the point nets' own series peaks at another speed (the member's file is the one read)
    point = np.genfromtxt(out / case["timeseries_file"], delimiter=",", names=True)
    assert abs(point["speed_rpm"].max() - series["speed_rpm"][i]) > 0.1
    nets = json.loads((FRANCIS_DIR / "nets.json").read_text())
    record = nets["training"]["extrapolation"]
    assert decided["opening"] < record["lowest_opening"] and decided["region"] == "below_lowest_line"
    weights = record["weights"]
    for target in ("q11", "m11"):  # report.json holds 12 significant digits
        assert decided["evidence"]["weights"][target] == pytest.approx(weights[target], rel=1e-11)
    for hypothesis in ("model", "anchored-model", "quadratic"):
        assert f"{hypothesis} {weights['q11'][hypothesis]:.2f}/{weights['m11'][hypothesis]:.2f}" in html
    assert "What decided each figure" in cells.headings
    assert html.count("below the lowest digitized opening line") >= 3  # the section and the verdict table
    assert "report.json:cases.0.decided.max_speed_rise.n11_rpm" in {key for key, _ in cells.cells}


def _plant(tmp_path, extra):
    text = PLANT_HLA339.read_text().replace('"francis/nets.json"', json.dumps(str(FRANCIS_DIR / "nets.json")))
    path = tmp_path / "plant.toml"
    path.write_text(extra + "\n" + text)
    return path


def test_fail_verdict_and_extrapolation_warning(tmp_path, capsys):
    plant = _plant(tmp_path, "[limits]\nmax_speed_rise = 0.30\n"
                             "[[load_cases]]\nname = \"rated\"\nscenario.initial_power_mw = 225.0\n"
                             "[[load_cases]]\nname = \"low\"\nscenario.initial_power_mw = 100.0\n"
                             )
    out = tmp_path / "rep"
    # a FAIL is exit 3 (not 0: a script or CI job must see it), with the report written all the same
    assert main(["report", str(plant), "--out", str(out), "--set", "scenario.t_end_s=10"]) == 3
    doc = json.loads((out / "report.json").read_text())
    verdicts = [c["verdicts"][0]["verdict"] for c in doc["cases"]]
    assert verdicts[:2] == ["FAIL", "PASS"]  # 44 % > 30 % at rated load; about 8 % from 100 MW
    assert doc["overall_verdict"] == "FAIL"
    # the shut vanes take every case below the lowest digitized opening: the simulator's record says so
    assert any(w.startswith("rated: extrapolation (digitized_region)") for w in doc["warnings"])
    assert "extrapolation (digitized_region)" in (out / "report.html").read_text()
    assert sorted(p.name for p in out.iterdir()) == sorted(  # committed: the manifest, no temporaries beside it
        [".hillsim-outputs.json", "report.html", "report.json", "cases", "hillchart.png", "envelope.png",
         "transient_0.png", "transient_1.png"])
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
    captured = capsys.readouterr()
    assert "overall FAIL" in captured.out
    row = doc["cases"][0]["verdicts"][0]  # judged on the shipped nets' ensemble band
    assert row["judged"] == "band" and 0.3 < row["value"] < row["band"][1]
    assert captured.err.splitlines()[-1] == (
        f"hillsim report: FAIL: rated: max_speed_rise {row['value']:.6g} (band {row['band'][0]:.6g}-"
        f"{row['band'][1]:.6g}) against the limit 0.3 (exit 3; report written to {out})")
    # the same plant with a limit both cases meet: PASS, exit 0
    plant.write_text(plant.read_text().replace("max_speed_rise = 0.30", "max_speed_rise = 0.50"))
    assert main(["report", str(plant), "--out", str(out), "--set", "scenario.t_end_s=10"]) == 0
    assert json.loads((out / "report.json").read_text())["overall_verdict"] == "PASS"
    assert "FAIL" not in capsys.readouterr().err


def test_nets_without_held_out_evidence_are_reported_as_such(tmp_path):
    """A nets.json without the silent_model block (a legacy or --no-silent-regions file): the report says there is
    no held-out evidence below the lowest line, with no weights, where the shipped file names them."""
    doc = json.loads((FRANCIS_DIR / "nets.json").read_text())
    del doc["silent_model"], doc["training"]["extrapolation"]
    for member in doc["ensemble"]:
        member.pop("silent_model", None)
    (tmp_path / "nets.json").write_text(json.dumps(doc))
    text = PLANT_HLA339.read_text().replace('"francis/nets.json"', json.dumps(str(tmp_path / "nets.json")))
    plant = tmp_path / "plant.toml"
    plant.write_text("[limits]\nmax_speed_rise = 0.6\n[[load_cases]]\nname = \"rated\"\n"
                     "scenario.initial_power_mw = 225.0\n" + text)
    out = tmp_path / "rep"
    assert main(["report", str(plant), "--out", str(out), "--set", "scenario.t_end_s=12"]) == 0
    report = json.loads((out / "report.json").read_text())
    decided = report["cases"][0]["decided"]["max_speed_rise"]
    assert decided["region"] == "below_lowest_line" and decided["evidence"]["kind"] == "none"
    assert "weights" not in decided["evidence"] and report["extrapolation_evidence"] is None
    html = (out / "report.html").read_text()
    assert "no held-out evidence: this nets.json has no silent_model block" in html
    assert "anchored-model" not in html


def test_envelope_along_the_penstock_matches_the_turbine_head(tmp_path):
    out = tmp_path / "rep"
    assert main(["report", str(PLANT_HLA339), "--out", str(out), "--set", "scenario.t_end_s=6"]) == 0
    doc = json.loads((out / "report.json").read_text())
    env = doc["cases"][0]["envelope"]
    summary = json.loads((out / doc["cases"][0]["summary_file"]).read_text())
    # the last node is the turbine: its envelope is the turbine head's max/min (same numbers, 12 digits)
    assert doc["envelope_available"] and env["position_m"][0] == 0.0 and env["position_m"][-1] == 500.0
    assert env["max_head_m"][-1] == pytest.approx(summary["max_head_m"], rel=1e-11)
    assert env["min_head_m"][-1] == pytest.approx(summary["min_head_m"], rel=1e-11)
    assert (out / "envelope.png").is_file()
    assert "max and min piezometric head at every computing node" in (out / "report.html").read_text()


@pytest.mark.parametrize("args,message", [
    (["--closure", "/nonexistent"], "--closure '/nonexistent': cannot read closure.json"),
    (["--sweep", "/nonexistent"], "--sweep '/nonexistent': cannot read sweep.json"),
    (["--set", "governor.kp=-1"], "governor.kp must be in [0.0, 1000.0], got -1.0"),
])
def test_report_garbage(tmp_path, capsys, args, message):
    out = tmp_path / "never"
    assert main(["report", str(PLANT_HLA339), "--out", str(out), *args]) == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_report_refuses_foreign_json(tmp_path, capsys):
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "closure.json").write_text("{\"x\": 1}")
    assert main(["report", str(PLANT_HLA339), "--out", str(tmp_path / "o"), "--closure", str(tmp_path / "c")]) == 2
    assert "is not a hillsim optimize-closure output" in capsys.readouterr().err
    plant = _plant(tmp_path, "[limits]\nmax_speed_rise = 9.0\n")
    assert main(["report", str(plant), "--out", str(tmp_path / "o")]) == 2
    assert "limits.max_speed_rise must be in (0.0, 5.0], got 9.0" in capsys.readouterr().err


def test_a_stepped_up_plant_reports_its_step_up(tmp_path):
    """[turbine.step_up]: the data sheet and every case's summary.json say what was assumed (the same record)."""
    plant = _plant(tmp_path, "[[load_cases]]\nname = \"rated\"\nscenario.initial_power_mw = 225.0\n")
    out = tmp_path / "rep"
    assert main(["report", str(plant), "--out", str(out), "--set", "scenario.t_end_s=6",
                 "--set", "turbine.step_up=iec60193"]) == 0
    doc = json.loads((out / "report.json").read_text())
    record = doc["plant"]["characteristics"]["step_up"]
    summary = json.loads((out / doc["cases"][0]["summary_file"]).read_text())
    assert record == summary["step_up"] and record["method"] == "iec60193"
    assert 1.01 < record["torque_factor"] < 1.05  # a 0.35 m model against the 4.5 m unit: about 2 points
    assert "torque_factor" in (out / "report.html").read_text()


def test_a_double_regulated_plant_reports_on_its_cam(tmp_path):
    """The report's hill chart of a bulb unit is its chart on the cam, over (N11, guide-vane opening) (the chart of
    the three-input nets alone has no such plane: the report stopped with a TypeError)."""
    from data_synthetic import PLANT_BULB
    from simulate.config import load_characteristics, load_plant
    from simulate.loop.engine import plant_characteristics

    out = tmp_path / "rep"
    assert main(["report", str(PLANT_BULB), "--out", str(out), "--set", "scenario.t_end_s=4"]) == 0
    doc = json.loads((out / "report.json").read_text())
    assert (out / "hillchart.png").stat().st_size > 10_000 and doc["cases"][0]["status"] == "ok"
    # the bulb's nets record no digitized region: its figures are not placed on the chart, and the page says so
    decided = doc["cases"][0]["decided"]["max_speed_rise"]
    assert decided["region"] == "unknown" and decided["evidence"]["kind"] == "not_placed"
    plant = load_plant(PLANT_BULB)
    view = plant_characteristics(plant, load_characteristics(plant.turbine, plant.base_dir))
    assert view.opening_unit == "deg above the closed vane"
    with pytest.raises(TypeError):  # what the chart was drawn from before: the nets need the blade angle too
        view.inner.q11(np.array([150.0]), np.array([45.0]))


def test_the_draft_tube_s_lowest_pressure_is_judged_and_a_missing_profile_is_named(tmp_path, capsys):
    """The bulb plant with limits on both minimum pressures: the draft tube's (absolute, below the runner: 8.23 m)
    passes 8 m and fails 9 m; the penstock's needs its profile, which the plant does not give: not judged, and the
    warning says what it needs."""
    from data_synthetic import PLANT_BULB

    nets = (PLANT_BULB.parent / "bulb" / "nets.json").as_posix()
    text = PLANT_BULB.read_text(encoding="utf-8").replace('characteristics = "bulb/nets.json"',
                                                          f'characteristics = "{nets}"')
    verdicts = {}
    for allowed in (8.0, 9.0):
        plant = tmp_path / f"plant_{allowed:g}.toml"
        limits = f"\n[limits]\nmin_draft_tube_pressure_head_m = {allowed}\nmin_pressure_head_m = 2.0\n"
        plant.write_text(text + limits, encoding="utf-8")
        out = tmp_path / f"rep_{allowed:g}"
        code = main(["report", str(plant), "--out", str(out), "--set", "scenario.t_end_s=8"])
        doc = json.loads((out / "report.json").read_text())
        rows = {v["limit"]: v for v in doc["cases"][0]["verdicts"]}
        verdicts[allowed] = (code, rows["min_draft_tube_pressure_head_m"]["verdict"])
        assert rows["min_draft_tube_pressure_head_m"]["value"] == pytest.approx(8.23, abs=0.01)
        assert rows["min_pressure_head_m"]["verdict"] == "n/a"
        assert any("limit min_pressure_head_m not judged" in w and "a penstock with its profile" in w
                   for w in doc["warnings"])
    assert verdicts == {8.0: (0, "PASS"), 9.0: (3, "FAIL")}  # exit 3: a limit failed
    assert re.search(r"FAIL: plant scenario: min_draft_tube_pressure_head_m 8\.22\d* against the limit 9",
                     capsys.readouterr().err)


@pytest.mark.slow
def test_the_hill_chart_of_a_plant_with_several_units_draws_every_unit():
    from data_synthetic import PLANT_TWO_UNITS
    from hillsim.report_charts import trajectories
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation

    plant = load_plant(PLANT_TWO_UNITS, {"scenario.t_end_s": 4.0})
    result = run_simulation(plant)
    lines = trajectories(plant, [("rated", result)])
    assert [label for label, _, _ in lines] == ["rated, U1", "rated, U2"]
    # U1 rejects its load (its N11 rises), U2 stays on its load (its own series, not the plant-level one)
    u2 = result.units["U2"]
    d1 = plant.units[1].turbine.runner_diameter_m
    np.testing.assert_array_equal(lines[1][1], u2["speed_rpm"] * d1 / np.sqrt(u2["head_m"]))
    assert lines[0][1].max() > lines[1][1].max() + 1.0
    single = load_plant(PLANT_HLA339, {"scenario.t_end_s": 4.0})
    assert [label for label, _, _ in trajectories(single, [("rated", run_simulation(single))])] == ["rated"]
