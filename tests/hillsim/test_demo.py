"""``hillsim demo --fast`` end to end: every promised file, and the report says what the JSON files say."""

import html
import json
import re

import pytest

pytestmark = pytest.mark.slow


PROMISED = [
    "extended.csv", "extended.png", "nets.json", "fit_errors.json", "hillchart.png", "coefficient_maps.png",
    "linearization.json", "demo_summary.json", "report.html",
    *(f"{run}/{name}" for run in ("load_rejection", "closure_law", "frequency_steps")
      for name in ("timeseries.csv", "summary.json", "transient.png")),
    "bulb_rejection/timeseries.csv", "bulb_rejection/summary.json", "bulb_rejection/transient.png",
    "identification/identification.json", "identification/step_response.png",
    "identification/theta_convergence.png", "identification/six_coefficients.png",
]


@pytest.fixture(scope="module")
def demo_dir(demo_fast_dir):
    return demo_fast_dir  # one shared `hillsim demo --fast --quiet` run (tests/conftest.py)


def test_every_promised_file_exists(demo_dir):
    missing = [name for name in PROMISED if not (demo_dir / name).is_file()]
    assert not missing
    for name in PROMISED:
        assert (demo_dir / name).stat().st_size > 100, name


def _lookup(doc, dotted):
    for part in dotted.split("."):
        doc = doc[part]
    return doc


def test_report_numbers_equal_the_json_files(demo_dir):
    text = (demo_dir / "report.html").read_text(encoding="utf-8")
    cells = re.findall(r'data-value="([^"]*)" data-key="([^"]*)"', text)
    assert len(cells) >= 50  # fit errors, three transient summaries, six coefficients x 4, identification, key numbers
    for value, key in cells:
        file, dotted = html.unescape(key).split(":", 1)
        expected = _lookup(json.loads((demo_dir / file).read_text()), dotted)
        assert html.unescape(value) == repr(expected), key


def test_report_embeds_every_figure(demo_dir):
    text = (demo_dir / "report.html").read_text(encoding="utf-8")
    pngs = [p for p in PROMISED if p.endswith(".png")]
    assert text.count("data:image/png;base64,") >= len(pngs)
    assert "src='http" not in text and 'src="http' not in text  # self-contained


def test_summary_matches_step_files(demo_dir):
    summary = json.loads((demo_dir / "demo_summary.json").read_text())
    rejection = json.loads((demo_dir / "load_rejection" / "summary.json").read_text())
    assert summary["load_rejection_max_speed_rise"] == rejection["max_speed_rise"]
    # the shipped nets meet the accuracy bounds the product promises (RMS 0.5 % of the Q11 range in the measured region)
    assert summary["q11_rms_measured_pct"] < 0.5 and summary["m11_rms_measured_pct"] < 1.0
    # a 100 % load rejection must overspeed the unit and raise the head (water hammer of the closing vanes)
    assert 0.05 < rejection["max_speed_rise"] < 0.8 and rejection["max_head_rise"] > 0.02
    # the bulb: overspeeds, and the draft tube's pressure falls below its steady value (reverse water hammer)
    bulb = json.loads((demo_dir / "bulb_rejection" / "summary.json").read_text())
    assert summary["bulb_min_outlet_pressure_head_m"] == bulb["min_outlet_pressure_head_m"]
    assert 0.1 < bulb["max_speed_rise"] < 1.0 and bulb["min_outlet_pressure_head_m"] < bulb["initial_head_m"]


def test_quiet_prints_nothing(demo_fast_run):
    _, out, err = demo_fast_run  # the shared run is the --quiet one: its stdout and stderr were captured
    assert out == "" and err == ""
