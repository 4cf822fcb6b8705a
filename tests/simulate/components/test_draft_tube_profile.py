"""A ``moc`` draft tube with its profile (``[[draft_tube.segments]] elevation_start_m/elevation_end_m``, runner outlet
first): the lowest absolute pressure along it, where and when (``min_draft_tube_pressure_head_m``), the guarantee's
limit on it, and the refusals. The shipped bulb plant's 30 m draft tube, its runner outlet 4 m below the tailwater."""

import tomllib
from pathlib import Path

import numpy as np
import pytest

from data_synthetic import PLANT_BULB, PLANT_HLA339
from hillchart.errors import InputError
from simulate.config import load_plant, plant_from_dict
from simulate.loop.engine import run_simulation
from simulate.studies.case_results import case_from_result
from simulate.studies.cases import Limits

PIPE = {"diameter_m": 5.5, "wave_speed_m_s": 1000.0, "darcy_friction": 0.014}
ATMOSPHERE_M = 10.33  # the bulb plant's draft_tube.atmospheric_pressure_head_m


def bulb(segments, **draft_tube):
    raw = tomllib.loads(Path(PLANT_BULB).read_text(encoding="utf-8"))
    raw["draft_tube"].update(segments=segments, **draft_tube)
    return plant_from_dict(raw, base_dir=Path(PLANT_BULB).parent)


def hump(top_m: float):
    """Up 10 m from the runner outlet (-4 m) to ``top_m``, then 20 m down to the outlet at -6 m."""
    return [dict(PIPE, length_m=10.0, elevation_start_m=-4.0, elevation_end_m=top_m),
            dict(PIPE, length_m=20.0, elevation_start_m=top_m, elevation_end_m=-6.0)]


@pytest.fixture(scope="module")
def plain():
    return run_simulation(load_plant(PLANT_BULB))


@pytest.fixture(scope="module")
def over_a_hump():
    return run_simulation(bulb(hump(5.0)))


def test_a_level_profile_at_the_runner_is_the_run_without_one(plain):
    """Without a profile the cavity models take the axis at the runner outlet's level: the same profile given gives
    the same run (the same arithmetic: 1e-12 allows nothing but a reordering), and the guarantee's figure is the
    runner outlet's minimum either way."""
    level = run_simulation(bulb([dict(PIPE, length_m=30.0, elevation_start_m=-4.0, elevation_end_m=-4.0)]))
    for name in ("speed_rpm", "head_m", "flow_m3_s"):
        np.testing.assert_allclose(getattr(level, name), getattr(plain, name), rtol=1e-12, atol=0.0)
    for run in (plain, level):
        s = run.summary()
        assert s["min_draft_tube_pressure_head_m"] == pytest.approx(s["min_outlet_pressure_head_m"], rel=1e-12)
        assert s["min_draft_tube_pressure_x_m"] == 0.0
        assert s["t_min_draft_tube_pressure_s"] == s["t_min_outlet_pressure_s"]


def test_the_lowest_pressure_is_found_at_the_high_point_of_the_profile(plain, over_a_hump):
    """A hump 5 m above the tailwater 10 m from the runner: the lowest absolute pressure is there (1.21 m of water),
    not below the runner (8.23 m). Check by the rigid column: at the runner's lowest the draft tube's head falls
    by ``H_out`` along its whole 30 m, so 20 m from the tailwater by 20/30 of it, and the hump's absolute pressure
    head is ``(20/30) H_out - 5 + 10.33``. The elastic column, its friction and the hump's 20 m between the two
    estimates leave a few cm (measured 5 cm); 0.15 m would still tell the hump from the runner by 7 m."""
    s = over_a_hump.summary()
    assert s["min_draft_tube_pressure_x_m"] == pytest.approx(10.0)
    rigid = 20.0 / 30.0 * s["min_draft_tube_head_m"] - 5.0 + ATMOSPHERE_M
    assert s["min_draft_tube_pressure_head_m"] == pytest.approx(rigid, abs=0.15)
    assert s["min_draft_tube_pressure_head_m"] == pytest.approx(1.21, abs=0.01)
    assert s["min_draft_tube_pressure_head_m"] <= s["min_outlet_pressure_head_m"]  # the runner outlet is in the tube
    assert s["t_min_draft_tube_pressure_s"] == pytest.approx(s["t_min_outlet_pressure_s"], abs=0.05)
    # the runner outlet itself barely changes (the draft tube's column is the same length and section)
    assert s["min_outlet_pressure_head_m"] == pytest.approx(plain.summary()["min_outlet_pressure_head_m"], abs=0.01)
    warning = next(w for w in s["warnings"] if w.startswith("the absolute pressure head"))
    assert warning.startswith("the absolute pressure head in the draft tube 10 m from the runner outlet falls to "
                              "1.21 m, below the vapour pressure head plus margin (0.24 + 2 m)")


def test_the_guarantee_judges_the_draft_tube_s_lowest_pressure(plain, over_a_hump):
    """``[limits] min_draft_tube_pressure_head_m``: the bulb passes 2 m absolute with its plain draft tube (8.23 m
    below the runner) and fails it over the hump (1.21 m); a plant without a draft tube is not judged, and the row
    says what the figure needs."""
    limits = Limits(min_draft_tube_pressure_head_m=2.0)
    rows = {}
    for name, run in (("plain", plain), ("hump", over_a_hump)):
        case = case_from_result(0, {}, run.plant, run)
        (rows[name],) = limits.check(case)
    assert rows["plain"]["verdict"] == "PASS" and rows["plain"]["value"] == pytest.approx(8.23, abs=0.01)
    assert rows["hump"]["verdict"] == "FAIL" and rows["hump"]["value"] == pytest.approx(1.21, abs=0.01)
    francis = run_simulation(load_plant(PLANT_HLA339, {"scenario.t_end_s": 4.0}))
    (row,) = limits.check(case_from_result(0, {}, francis.plant, francis))
    assert row["verdict"] == "n/a" and "it needs a [draft_tube] section" in row["why"]


def test_a_cavity_at_a_high_point_that_stops_the_run_is_named():
    """The hump 7 m above the tailwater: a cavity opens there (not below the runner) and its collapse drives the
    turbine's net head toward zero; the run stops saying where the cavity was and what to change."""
    r = run_simulation(bulb(hump(7.0)), raise_on_failure=False)
    assert not r.success
    assert r.message.startswith("a cavity in the draft tube 10 m from the runner outlet (the discrete gas cavity "
                                "model) formed and collapsed")
    assert "lower the draft tube there ([[draft_tube.segments]] elevations)" in r.message


def test_the_profile_is_refused_where_it_would_not_hold():
    with pytest.raises(InputError, match=r"draft_tube.segments\[0\].elevation_start_m = -3 but "
                                         r"draft_tube.runner_elevation_m = -4: the profile starts at the runner"):
        bulb([dict(PIPE, length_m=30.0, elevation_start_m=-3.0, elevation_end_m=-6.0)])
    with pytest.raises(InputError, match=r"draft_tube.segments.elevation_start_m is read only by draft_tube.model = "
                                         r"\"moc\" .*; with model = 'rigid' it would be ignored"):
        bulb(hump(5.0), model="rigid", column_separation="off")
    with pytest.raises(InputError, match=r"draft_tube.segments: elevation_start_m/elevation_end_m must be given on "
                                         r"every segment or on none; segment 1 has none"):
        bulb([hump(5.0)[0], dict(PIPE, length_m=20.0)])
    # the water at a hump 15 m above the tailwater would boil in steady flow (10.33 - 15 m absolute)
    with pytest.raises(InputError, match=r"draft_tube.segments: the absolute pressure head in the draft tube 10 m "
                                         r"from the runner outlet in steady flow, -4.6\d m, is not above "
                                         r"draft_tube.vapour_pressure_head_m = 0.24"):
        run_simulation(bulb(hump(15.0)))
    # the third's passing twin: no segment with elevations is a draft tube without a profile
    assert bulb([dict(PIPE, length_m=30.0)]).draft_tube.has_profile is False
