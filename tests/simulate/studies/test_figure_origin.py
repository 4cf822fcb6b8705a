"""Where each banded guarantee figure was decided: the run of its conservative end, the operating point of the
extremum (checked by hand from the time series), the chart region there and the evidence read from nets.json."""

import json
import math

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR, PLANT_HLA339
from simulate.studies.figure_origin import classify, figure_origins, hull_span, region_evidence

NETS = json.loads((FRANCIS_DIR / "nets.json").read_text())
RECORD = NETS["training"]["extrapolation"]
HULL = np.array(NETS["digitized_region"])
D1 = 4.5  # runner diameter of the shipped plant, m


def _plant(**overrides):
    from simulate.config import load_plant

    return load_plant(PLANT_HLA339, overrides)


def _chars(plant):
    from simulate.config import load_characteristics

    return load_characteristics(plant.turbine, plant.base_dir)


def test_hull_span_and_regions_of_a_square_chart():
    """A trapezoid 'chart' (openings 10-30): its N11 edges by hand, each region, and the lowest line checked before
    the region (below it the table answers at any N11)."""
    hull = np.array([[40.0, 10.0], [90.0, 10.0], [80.0, 30.0], [45.0, 30.0]])
    assert hull_span(hull, 20.0) == (42.5, 85.0)  # halfway along both slanted edges
    assert hull_span(hull, 10.0) == (40.0, 90.0) and hull_span(hull, 9.99) is None
    assert classify(84.9, 20.0, hull, 10.0)[0] == "digitized"
    region, details = classify(85.1, 20.0, hull, 10.0)  # just past the edge: outside, toward runaway
    assert region == "toward_runaway" and details["gap"] == pytest.approx(0.1 / 85.0, rel=1e-12)
    assert classify(42.4, 20.0, hull, 10.0)[0] == "below_smallest_n11"
    assert classify(60.0, 31.0, hull, 10.0)[0] == "above_largest_line"
    assert classify(60.0, 10.0, hull, 10.0)[0] == "digitized"  # on the lowest line: measured
    region, details = classify(60.0, 9.0, hull, 10.0)
    assert region == "below_lowest_line" and details["distance"] == pytest.approx(0.1, rel=1e-12)
    assert classify(200.0, 9.0, hull, 10.0)[0] == "below_lowest_line"  # beyond the region's N11 too
    assert classify(60.0, 20.0, None, None)[0] == "unknown"


@pytest.fixture(scope="module")
def rejection():
    """The shipped plant's rated load rejection with the shipped nets' ensemble band."""
    from simulate.loop.engine import run_simulation
    from simulate.studies.uncertainty import run_ensemble

    plant = _plant(**{"scenario.t_end_s": 15.0})
    chars = _chars(plant)
    result = run_simulation(plant, characteristics=chars)
    band, _ = run_ensemble(plant, chars)
    origins, runs = figure_origins(plant, chars, result, band)
    return plant, chars, result, band, origins, runs


def test_a_load_rejection_max_speed_is_decided_below_the_lowest_line(rejection):
    """The conservative end of the max speed rise comes from the member with the largest figure; its maximum, by
    hand from that member's own run: N11 = n D1 / sqrt(H) and the opening there, below the lowest digitized line
    (10 mm in nets.json), where the weighed hypotheses answer with the weights and band of nets.json."""
    from simulate.loop.engine import run_simulation

    plant, chars, result, band, origins, runs = rejection
    origin = origins["max_speed_rise"]
    assert not band["failed"]
    k = int(np.argmax(band["max_speed_rise"]["values"]))
    assert origin["member"] == k and origin["run"] == f"ensemble member {k}"
    assert origin["conservative_end"] == band["max_speed_rise"]["high"] > origin["point_value"]
    member = run_simulation(plant, characteristics=chars.members()[k])  # a run of its own, not the module's
    i = int(np.argmax(member.speed_rpm))
    n11 = member.speed_rpm[i] * D1 / math.sqrt(member.head_m[i])
    # the same series and formula: equal to rounding
    assert origin["time_s"] == member.time_s[i] and origin["n11_rpm"] == pytest.approx(n11, rel=1e-12)
    assert origin["opening"] == member.opening_chart[i]
    assert 9.0 < origin["time_s"] < 11.0 and 80.0 < n11 < 90.0 and origin["opening"] < 2.0  # vanes nearly shut
    # failing case beside: the point nets reach their maximum elsewhere (another run), so the member's point is
    # what the test pins, not any run's
    j = int(np.argmax(result.speed_rpm))
    assert abs(result.speed_rpm[j] * D1 / math.sqrt(result.head_m[j]) - n11) > 0.01
    assert origin["opening"] < RECORD["lowest_opening"] == NETS["silent_model"]["blend_openings"][1] == 10.0
    assert origin["region"] == "below_lowest_line"
    evidence = origin["evidence"]
    assert evidence["kind"] == "held_out_lines" and evidence["weights"] == RECORD["weights"]
    assert evidence["rms_error"] == RECORD["rms_error"] and evidence["held_out_points"] == 21
    # the band's two sides there, by hand: d = 1 - a / a_low beyond twice the cap, where h levels off at 2 cap^2
    cap = NETS["silent_model"]["band"]["distance_cap"]
    d = 1.0 - origin["opening"] / 10.0
    assert d > 2 * cap
    low, high = NETS["silent_model"]["band"]["q11"]
    assert evidence["band_q11"] == pytest.approx([math.exp(-low * 2 * cap ** 2) - 1, math.exp(high * 2 * cap ** 2) - 1],
                                                 rel=1e-12)
    assert evidence["nets_weight"] == 0.0  # below half the lowest opening: the table alone
    # the member's own place in the band (0.76 with the shipped nets: its upper half, a Q11 above the median)
    assert chars.members()[k].silent_model.position == evidence["member_position"] > 0.0
    assert "other-form-model 0.41/0.43" in evidence["text"] and "anchored-model 0.10/0.13" in evidence["text"]
    # the hypothesis the weighed median takes there, by hand from the chart: each hypothesis' value at the point
    # and the weights (the median is one of them); the report names it for Q11 and M11
    from hillchart.extension.extend import extend_samples
    from hillchart.io.samples import load_chart

    extrapolation = extend_samples(load_chart(FRANCIS_DIR)).extrapolation
    answers = {h: extrapolation.hypotheses.predict(h, n11, origin["opening"]) for h in RECORD["hypotheses"]}
    for j, target in enumerate(("q11", "m11")):
        order = sorted(answers, key=lambda h: float(answers[h][j]))
        cumulative = np.cumsum([RECORD["weights"][target][h] for h in order])
        by_hand = order[int(np.argmax(cumulative >= 0.5 * cumulative[-1]))]
        assert by_hand in evidence["median_of"][target] and len(evidence["median_of"][target]) <= 2
        # failing case beside: the weighed mean stands where no hypothesis does here (Q11 4 % from the nearest,
        # M11 0.39 N*m, measured), so it could name none
        mean = sum(RECORD["weights"][target][h] * float(v[j]) for h, v in answers.items())
        nearest = min(abs(mean - float(v[j])) for v in answers.values())
        assert nearest > (0.01 * mean if target == "q11" else 0.1)
    assert origin["decided_by"].startswith("the weighed median of the extrapolation hypotheses")
    assert f"here the {' / '.join(evidence['median_of']['q11'])} (Q11)" in origin["decided_by"]


def test_a_deciding_member_that_does_not_repeat_its_figure_is_an_error(rejection):
    """The band keeps figures only, so the deciding member runs again; a band that does not belong to the run (its
    figure changed) is refused, never described with another run's point."""
    from hillchart.errors import NumericalError

    plant, chars, result, band, _, _ = rejection
    forged = json.loads(json.dumps(band))
    forged["max_speed_rise"]["values"][0] = 1.0  # member 0 now the largest, with a figure it never gave
    forged["max_speed_rise"]["high"] = 1.0
    with pytest.raises(NumericalError, match="max_speed_rise: ensemble member 0 gives 0.4"):
        figure_origins(plant, chars, result, forged)


def test_the_point_nets_decide_when_the_band_is_milder(rejection):
    """A band whose upper end is below the point nets' figure: the point nets' own run decides (no member runs)."""
    plant, chars, result, band, _, _ = rejection
    milder = json.loads(json.dumps(band))
    for figure in ("max_speed_rise", "max_head_rise", "min_head_drop", "max_head_m"):
        milder[figure]["high"] = milder[figure]["low"]
    origins, runs = figure_origins(plant, chars, result, milder)
    assert runs == {} and origins["max_speed_rise"]["member"] is None
    assert origins["max_speed_rise"]["run"] == "point nets"
    assert origins["max_speed_rise"]["conservative_end"] == result.summary()["max_speed_rise"]
    assert origins["max_speed_rise"]["time_s"] == result.time_s[int(np.argmax(result.speed_rpm))]


def test_a_load_step_max_speed_is_decided_in_the_measured_chart():
    """A 20 % load drop under the governor: the speed peaks with the vanes still open, between the digitized lines
    of 16 and 18 mm, inside both lines' N11 range (flow.csv): the measured chart decides, the nets' fit error
    stated (nets.json)."""
    from simulate.loop.engine import run_simulation
    from simulate.studies.uncertainty import run_ensemble

    plant = _plant(**{"scenario.kind": "load-step", "scenario.load_step": -0.2, "scenario.t_end_s": 10.0})
    chars = _chars(plant)
    result = run_simulation(plant, characteristics=chars)
    band, _ = run_ensemble(plant, chars)
    origin = figure_origins(plant, chars, result, band)[0]["max_speed_rise"]
    flow = np.loadtxt(FRANCIS_DIR / "flow.csv", delimiter=",", skiprows=1)
    assert 16.0 < origin["opening"] < 18.0
    for line in (16.0, 18.0):
        n11 = flow[flow[:, 0] == line, 1]
        assert n11.min() < origin["n11_rpm"] < n11.max()
    assert origin["region"] == "digitized" and origin["decided_by"] == "the measured chart"
    assert origin["evidence"]["q11_rms_m3_s"] == NETS["training"]["flow"]["measured_rms_error"]
    assert origin["evidence"]["m11_rms_nm"] == NETS["training"]["torque"]["measured_rms_error"]
    assert "held-out" not in origin["evidence"]["text"]


def test_a_slow_closure_decides_the_max_speed_toward_runaway():
    """A 70 s closure: the speed peaks with the vanes above the lowest line (at 11.1 mm), at an N11 beyond the
    digitized region's edge at that opening (by hand on the edge between the line ends (77.25, 10) and (81.54, 12));
    the evidence is the held-out line ends of nets.json, the torque band at the capped gap. (A 60 s closure peaks at
    9.85 mm, just below the lowest line, with the shipped nets.)"""
    from simulate.loop.engine import run_simulation

    plant = _plant(**{"governor.closing_time_s": 70.0, "scenario.t_end_s": 30.0})
    chars = _chars(plant)
    result = run_simulation(plant, characteristics=chars)
    origin = figure_origins(plant, chars, result)[0]["max_speed_rise"]
    assert origin["time_s"] < 29.0  # a maximum inside the run, not its end
    a = origin["opening"]
    assert 10.0 < a < 12.0 and origin["region"] == "toward_runaway"
    edge = 77.25 + (a - 10.0) * (81.54 - 77.25) / 2.0
    assert origin["details"]["edge_n11_rpm"] == pytest.approx(edge, rel=1e-12)
    assert origin["details"]["gap"] == pytest.approx(origin["n11_rpm"] / edge - 1.0, rel=1e-12)
    overspeed = RECORD["overspeed"]
    evidence = origin["evidence"]
    assert evidence["kind"] == "held_out_line_ends" and evidence["held_out_points"] == overspeed["held_out_points"]
    assert evidence["model_m11_rms"] == overspeed["model_m11_rms"]
    assert origin["details"]["gap"] > overspeed["gap_cap"]  # far beyond: the band at its cap
    band = overspeed["m11_band_per_gap"]
    assert evidence["band_m11_range"] == pytest.approx([-band["low"] * overspeed["gap_cap"],
                                                        band["high"] * overspeed["gap_cap"]], rel=1e-12)


def test_a_figure_decided_where_the_model_gave_no_runaway_says_the_nets_alone_answered(tmp_path):
    """The slow closure above, its maximum speed beyond the region's edge at 10-12 mm, with nets.json recording
    lines without a runaway speed from the fitted model (``training.lines_without_runaway``, what the extension warns
    of): from the 10 mm line up nothing constrained the nets there, and the report says so and what to give; lines
    from 20 mm up leave the point's evidence as it was (the held-out line ends)."""
    from simulate.loop.engine import run_simulation
    from simulate.studies.figure_origin import NETS_ALONE

    origins = {}
    for lines in ([10.0, 12.0, 14.0], [20.0, 22.0]):
        doc = json.loads(json.dumps(NETS))
        doc["training"]["lines_without_runaway"] = lines
        path = tmp_path / f"nets{lines[0]:g}.json"
        path.write_text(json.dumps(doc))
        plant = _plant(**{"turbine.characteristics": str(path), "governor.closing_time_s": 70.0,
                          "scenario.t_end_s": 30.0})
        chars = _chars(plant)
        origins[lines[0]] = figure_origins(plant, chars, run_simulation(plant, characteristics=chars))[0][
            "max_speed_rise"]
    bare, covered = origins[10.0], origins[20.0]
    assert bare["region"] == covered["region"] == "toward_runaway" and 10.0 < bare["opening"] < 12.0
    assert bare["details"]["gap"] > RECORD["overspeed"]["gap_cap"]  # beyond the lines' straight continuations
    assert bare["decided_by"].startswith(NETS_ALONE) and bare["evidence"]["kind"] == "none"
    assert "a = 10, 12, 14" in bare["evidence"]["text"] and "give the runaway curve" in bare["evidence"]["text"]
    assert covered["evidence"]["kind"] == "held_out_line_ends"
    # within the gap the held-out line ends tested twice over, the lines' straight continuations answer (the
    # extension samples them there: hillchart.extension.silent_samples.continued_line_points)
    from simulate.studies.figure_origin import region_evidence

    chars = _chars(_plant(**{"turbine.characteristics": str(tmp_path / "nets10.json")}))
    near = {"gap": 0.5 * RECORD["overspeed"]["gap_cap"], "edge_n11_rpm": 80.0}
    decided, evidence = region_evidence(chars, None, "toward_runaway", near, {"opening": 11.0, "n11_rpm": 81.0})
    assert decided == "the straight continuation of the lines toward runaway"
    assert evidence["line_m11_rms"] == RECORD["overspeed"]["line_m11_rms"] and "a = 10, 12, 14" in evidence["text"]


def test_nets_without_a_silent_model_say_there_is_no_held_out_evidence(tmp_path):
    """A nets.json without the silent_model block and its record (a legacy or --no-silent-regions file): the point
    below the lowest line (the digitized region's smallest opening) has no held-out evidence, and the report says
    so instead of weights; the shipped file beside it has them."""
    from simulate.loop.engine import run_simulation

    doc = json.loads(json.dumps(NETS))
    del doc["silent_model"], doc["training"]["extrapolation"]
    for member in doc["ensemble"]:
        member.pop("silent_model", None)
    (tmp_path / "nets.json").write_text(json.dumps(doc))
    origins, nets = {}, {}
    for name, path in (("stripped", tmp_path / "nets.json"), ("shipped", FRANCIS_DIR / "nets.json")):
        plant = _plant(**{"turbine.characteristics": str(path), "scenario.t_end_s": 12.0})
        nets[name] = chars = _chars(plant)
        origins[name] = figure_origins(plant, chars, run_simulation(plant, characteristics=chars))[0]["max_speed_rise"]
    stripped, shipped = origins["stripped"], origins["shipped"]
    assert stripped["region"] == shipped["region"] == "below_lowest_line"
    assert shipped["evidence"]["kind"] == "held_out_lines" and "weights" in shipped["evidence"]
    # without the table the lowest line is the digitized region's smallest opening
    assert stripped["details"]["lowest_opening"] == HULL[:, 1].min() == 10.0
    assert stripped["evidence"]["kind"] == "none" and "weights" not in stripped["evidence"]
    assert stripped["evidence"]["text"].startswith("no held-out evidence: this nets.json has no silent_model block")
    assert stripped["decided_by"] == "the nets alone, extrapolating the extension's samples"
    # toward runaway too: no overspeed samples of the model, no held-out line ends
    details = {"edge_n11_rpm": 80.0, "gap": 0.1}
    decided, evidence = region_evidence(nets["stripped"], None, "toward_runaway", details, stripped)
    assert decided == stripped["decided_by"] and evidence["kind"] == "none"
    decided, evidence = region_evidence(nets["shipped"], None, "toward_runaway", details, stripped)
    assert evidence["kind"] == "held_out_line_ends" and evidence["band_m11_range"] == pytest.approx(
        [-0.1 * RECORD["overspeed"]["m11_band_per_gap"]["low"], 0.1 * RECORD["overspeed"]["m11_band_per_gap"]["high"]],
        rel=1e-12)  # a gap of 10 %, under the cap: the summary's "10 % beyond a line's last point"


def test_an_extrapolation_of_another_kind_is_not_read_as_missing():
    """Characteristics whose silent model is not a single-regulated chart's table (a double-regulated table's) keep
    their evidence in another form: the report says it does not read it, never that there is none; the shipped
    nets beside it give their held-out lines."""
    from types import SimpleNamespace

    point = {"opening": 5.0, "q11_m3_s": 0.2, "n11_rpm": 80.0}
    details = {"lowest_opening": 10.0, "distance": 0.5}
    other = SimpleNamespace(silent_model=object(), training={"extrapolation": {"summary": "angles held out"}})
    decided, evidence = region_evidence(other, None, "below_lowest_line", details, point)
    assert evidence["kind"] == "not_read" and "does not read" in evidence["text"]
    decided, evidence = region_evidence(_chars(_plant()), None, "below_lowest_line", details, point)
    assert evidence["kind"] == "held_out_lines" and evidence["median_of"] is not None
    assert decided.startswith("the weighed median of the extrapolation hypotheses (weighed by the chart's held-out "
                              "lines): here the ")


def test_a_record_without_the_median_of_says_so_and_names_no_hypothesis():
    """A nets.json written before the record kept which hypothesis the weighed median takes: the evidence says it
    is not recorded and the figure is decided by the weighed median without a name; the shipped record names one."""
    import copy

    chars = _chars(_plant())
    old = copy.copy(chars)
    old.training = copy.deepcopy(chars.training)
    del old.training["extrapolation"]["median_of"]
    point = {"opening": 5.0, "q11_m3_s": 0.2, "n11_rpm": 80.0}
    details = {"lowest_opening": 10.0, "distance": 0.5}
    decided, evidence = region_evidence(old, None, "below_lowest_line", details, point)
    assert decided == "the weighed median of the extrapolation hypotheses (weighed by the chart's held-out lines)"
    assert evidence["median_of"] is None and "does not record (written by an earlier version" in evidence["text"]
    decided, evidence = region_evidence(chars, None, "below_lowest_line", details, point)
    assert "here the median is " in evidence["text"] and "does not record" not in evidence["text"]
