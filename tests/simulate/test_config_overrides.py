"""``PlantConfig.with_overrides`` replaces the sections a variant touches (``dataclasses.replace``, each section and
the plant validated by their ``__post_init__``) instead of rebuilding the plant from its dictionary: a batch makes
one variant per case. Both ways must give the same plant, or the same error."""

import dataclasses

import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.config import apply_overrides, load_plant, plant_from_dict, to_dict

BASE = load_plant(PLANT_HLA339)


def rebuilt(plant, overrides):
    """The plant as the file path builds it: its dictionary, the overrides applied, every section validated."""
    raw = to_dict(plant)
    apply_overrides(raw, overrides)
    return plant_from_dict(raw, base_dir=plant.base_dir)


def outcome(build):
    try:
        return build()
    except InputError as exc:
        return f"InputError: {exc}"


CASES = [
    {"governor.closing_time_s": 9.5},
    {"governor.kp": 3, "generator.inertia_time_s": 7.25},  # an int stays an int, as read from a file
    {"scenario.initial_power_mw": 160.0, "scenario.initial_opening": None},
    {"scenario.initial_opening": 0.6, "scenario.initial_power_mw": None},
    {"penstock.static_head_m": 170.0, "penstock.reaches": 12},
    {"penstock.model": "rigid", "solver.pressure_loop": "newton"},
    {"turbine.characteristics": "ideal", "solver.tolerance": 1e-9},
    {"solver.dt_s": 0.01},
    {"solver.dt_s": None},
    # refused, with the file path's message
    {"governor.closing_time_s": -1.0},
    {"governor.stroke_min": 0.9, "governor.stroke_max": 0.8},
    {"scenario.initial_power_mw": 400.0},  # above 1.5 x rated: the plant's own check
    {"governor.closing_tim_s": 9.5},  # unknown key
    {"turbine.rated_head_m": None},  # a required key removed
    {"scenario.kind": "frequency-step"},  # a switch of kind drops the keys the new kind does not use
    {"penstock.segments": [{"length_m": 100.0, "diameter_m": 2.0, "wave_speed_m_s": 1000.0,
                            "darcy_friction": 0.01}]},
]


@pytest.mark.parametrize("overrides", CASES, ids=[",".join(c) for c in CASES])
def test_a_variant_is_the_plant_the_file_path_builds(overrides):
    fast = outcome(lambda: BASE.with_overrides(overrides))
    slow = outcome(lambda: rebuilt(BASE, overrides))
    assert fast == slow
    if not isinstance(fast, str):
        for section in ("turbine", "penstock", "generator", "governor", "scenario", "solver"):
            for f in dataclasses.fields(getattr(fast, section)):
                a, b = getattr(getattr(fast, section), f.name), getattr(getattr(slow, section), f.name)
                assert type(a) is type(b), (section, f.name)


def test_the_comparison_can_fail():
    """The failing case beside the passing ones: two different variants are different plants."""
    assert BASE.with_overrides({"governor.closing_time_s": 9.5}) != rebuilt(BASE, {"governor.closing_time_s": 9.75})


def test_a_numeric_variant_does_not_rebuild_the_plant(monkeypatch):
    import simulate.config as config

    def refuse(*args, **kwargs):
        raise AssertionError("the plant was rebuilt from its dictionary")

    monkeypatch.setattr(config, "plant_from_dict", refuse)
    assert BASE.with_overrides({"governor.closing_time_s": 9.5}).governor.closing_time_s == 9.5
    with pytest.raises(AssertionError, match="rebuilt"):  # a switch of scenario kind takes the file's path
        BASE.with_overrides({"scenario.kind": "frequency-step"})
