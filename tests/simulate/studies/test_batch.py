"""simulate.studies.batch: identical to single runs, failing cases as records, structure/garbage refused."""

import math

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.studies.batch import (FIGURES, CaseResult, BatchResult, case_from_result, check_key,
                                    extrapolation_kinds, nets_domain, run_batch, run_case, variant_overrides)
from simulate.config import load_characteristics, load_plant
from simulate.loop.engine import run_simulation

# 5 s of the shipped plant (nets, MOC, 8 reaches): the load rejection at 2 s and the first 3 s of overspeed.
BASE = {"scenario.t_end_s": 5.0}


@pytest.fixture(scope="module")
def plant():
    return load_plant(PLANT_HLA339, BASE)


@pytest.fixture(scope="module")
def nets(plant):
    return load_characteristics(plant.turbine, plant.base_dir)


VARIANTS = [{"governor.closing_time_s": 8.0, "scenario.initial_power_mw": 160.0},
            {"governor.closing_time_s": 14.0, "scenario.initial_power_mw": 225.0},
            {"governor.kp": 3.5},
            {"penstock.static_head_m": 175.0}]


@pytest.mark.parametrize("mechanism", ["serial", "processes", "threads"])
def test_batch_equals_single_runs_exactly(plant, nets, mechanism):
    batch = run_batch(plant, VARIANTS, characteristics=nets, mechanism=mechanism, workers=2, chunk_size=1,
                      keep_series=True)
    assert batch.mechanism == mechanism and [c.index for c in batch.cases] == [0, 1, 2, 3]
    for variant, case in zip(VARIANTS, batch.cases):
        single = run_simulation(load_plant(PLANT_HLA339, {**BASE, **variant_overrides(variant)}),
                                characteristics=nets)
        s = single.summary()
        assert case.status == "ok", case.error
        # the same code path on the same inputs: bit-identical, whatever the mechanism
        assert case.max_speed_rise == s["max_speed_rise"] and case.max_head_m == s["max_head_m"]
        assert case.min_head_m == single.head_m.min() and case.steps == s["steps"]
        assert np.array_equal(case.series["speed_rpm"], single.speed_rpm)
        assert np.array_equal(case.series["head_m"], single.head_m)
        # every figure of the record: the one the single run gives (numbers to 1e-12 relative, the rest equal)
        alone = case_from_result(case.index, variant, single.plant, single, nets_domain(nets))
        for name in FIGURES:
            got, want = getattr(case, name), getattr(alone, name)
            if isinstance(want, float):
                assert got == pytest.approx(want, rel=1e-12, nan_ok=True), name
            else:
                assert got == want, name
    # the varied initial power really changed the run (the test would pass vacuously otherwise)
    assert batch.cases[0].initial_power_mw == pytest.approx(160.0, rel=1e-9)
    assert batch.cases[0].max_speed_rise < batch.cases[1].max_speed_rise


def test_failing_cases_are_records_and_the_batch_goes_on(plant, nets):
    variants = [{"governor.closing_time_s": -1.0},            # out of range: no run
                {"scenario.initial_power_mw": 1000.0},         # beyond 1.5 x rated: no run
                {"solver.relaxation": 1.0, "solver.max_iterations": 1},   # pressure loop cannot converge
                {"governor.closing_time_s": 10.0}]
    # the loop alone (solver.fallback = false): its damped and Newton retries would rescue the third case
    batch = run_batch(plant.with_overrides({"solver.fallback": False}), variants, characteristics=nets,
                      mechanism="serial")
    statuses = [c.status for c in batch.cases]
    assert statuses == ["error", "error", "failed", "ok"]
    assert "governor.closing_time_s must be in (0.0, 1000.0], got -1.0" in batch.cases[0].error
    assert "scenario.initial_power_mw" in batch.cases[1].error
    assert "failed (no convergence)" in batch.cases[2].error
    assert math.isnan(batch.cases[0].max_speed_rise) and batch.n_ok == 1


def test_a_start_beyond_the_chart_is_an_error_record_and_the_digitized_region_is_flagged(plant, nets):
    from simulate.studies.batch import extrapolation_kinds

    batch = run_batch(plant, [{"governor.stroke_max": 1.5, "scenario.initial_opening": 1.2}, {},
                              {"scenario.t_end_s": 8.0}], characteristics=nets, mechanism="serial")
    wide, base, longer = batch.cases
    # 38.4 mm on a 32 mm chart: the simulator refuses to start outside the characteristics; the batch goes on
    assert wide.status == "error" and "beyond full guide-vane stroke" in wide.error
    assert base.status == "ok" and base.beyond_nets_range is False
    # the first 5 s stay on the chart: the record's metadata (checked, intervals_s, training ranges) is no kind of
    # extrapolation, so nothing is flagged
    assert base.extrapolated is False and extrapolation_kinds(base.extrapolation) == {}
    # the shut vanes take the rejection below the lowest digitized opening from t = 5.45 s: flagged from the
    # simulator's record, and only that kind
    assert longer.extrapolated is True and set(extrapolation_kinds(longer.extrapolation)) == {"digitized_region"}


def test_envelope_and_extrapolation_fields_are_read_when_the_summary_has_them(plant, nets):
    def run_with_envelope(case_plant, characteristics, raise_on_failure):
        result = run_simulation(case_plant, characteristics=characteristics, raise_on_failure=raise_on_failure)
        meta = dict(result.meta, min_pressure_head_m=12.5, min_pressure_head_x_m=310.0,
                    extrapolation={"nets_range": {"fraction": 0.25, "n11_max": 130.0},
                                   "full_stroke": {"fraction": 0.0}})
        return type(result)(**{**result.__dict__, "meta": meta})

    case = run_case(plant, nets, 0, {}, run=run_with_envelope)
    assert case.min_pressure_head_m == 12.5 and case.min_pressure_head_at == "min_pressure_head_x_m=310.0"
    assert case.extrapolated is True
    batch = BatchResult(keys=(), cases=[case], mechanism="serial", workers=1, chunk_size=1, wall_time_s=0.0)
    row = batch.rows()[0]
    assert row["extrapolation"] == "nets_range:0.25" and row["min_pressure_head_m"] == 12.5


def test_extrapolation_record_shapes():
    assert extrapolation_kinds({"a": {"time_fraction": 0.0}, "b": 0.5, "c": {"extrapolated": True}}) == \
        {"b": 0.5, "c": 1.0}
    assert extrapolation_kinds({}) == {}
    assert CaseResult(index=0, values={}, status="ok", extrapolation={}).extrapolated is False
    assert CaseResult(index=0, values={}, status="ok").extrapolated is None


@pytest.mark.parametrize("variant,message", [
    ({"penstock.model": 1.0}, "value of varied key 'penstock.model' selects a model: a name"),
    ({"scenario.kind": "nope"}, "varied scenario.kind = 'nope': scenario.kind must be one of load-rejection"),
    ({"governor.kpp": 1.0}, "unknown key 'governor.kpp'; numeric keys of [governor]: governor.kp"),
    ({"rotor.inertia": 1.0}, "unknown section in varied key 'rotor.inertia'"),
    ({"kp": 1.0}, "varied key must be section.key"),
    ({"governor.kp": "fast"}, "value of varied key 'governor.kp' must be a number, got 'fast'"),
    ({"governor.kp": True}, "must be a number, got True"),
    ({"governor.kp": float("nan")}, "must be finite"),
    ({"scenario.break_opening": 0.2}, "is not used by scenario.kind = 'load-rejection'"),
    ({"scenario.initial_power_mw": 100.0, "scenario.initial_opening": 0.5}, "cannot both be varied"),
])
def test_bad_variants_are_refused_before_anything_runs(plant, variant, message):
    with pytest.raises(InputError) as info:
        run_batch(plant, [{}, variant])
    assert message in str(info.value)


@pytest.mark.parametrize("kwargs,message", [({"mechanism": "gpu"}, "mechanism must be one of"),
                                            ({"workers": 0}, "workers must be a positive integer"),
                                            ({"chunk_size": 0}, "chunk_size must be a positive integer")])
def test_bad_batch_options(plant, kwargs, message):
    with pytest.raises(InputError, match=message):
        run_batch(plant, [{}], **kwargs)


def test_check_key_accepts_numeric_keys_and_names_non_numeric_ones(plant):
    assert check_key(plant, "scenario.initial_power_mw") == "scenario.initial_power_mw"
    with pytest.raises(InputError, match="'turbine.characteristics' changes the plant structure"):
        check_key(plant, "turbine.characteristics")
    with pytest.raises(InputError, match="is not numeric"):
        check_key(plant, "scenario.speed_steps")


def test_processes_with_a_single_case_runs_it_in_this_process(plant, nets):
    batch = run_batch(plant, [{"governor.kp": 2.5}], characteristics=nets, mechanism="processes")
    assert [c.status for c in batch.cases] == ["ok"] and batch.case_steps == batch.cases[0].steps > 0


def test_batch_pool_reused_across_batches_equals_serial(plant, nets):
    from simulate.studies.batch import BatchPool

    serial = run_batch(plant, VARIANTS, characteristics=nets, mechanism="serial")
    with BatchPool(plant, [nets], workers=2) as pool:
        first = pool.run(VARIANTS[:2])
        second = pool.run(VARIANTS)
        with pytest.raises(InputError, match=r"member must be an index in \[0, 0\], got 1"):
            pool.run(VARIANTS, member=1)
    assert first.mechanism == "pool" and [c.index for c in second.cases] == [0, 1, 2, 3]
    for a, b in zip(serial.cases, second.cases):
        assert (a.max_speed_rise, a.max_head_m, a.min_head_m) == (b.max_speed_rise, b.max_head_m, b.min_head_m)
    assert first.cases[1].max_head_m == serial.cases[1].max_head_m


@pytest.mark.parametrize("workers", [1, 2])
def test_pool_members_equal_single_runs_of_each_member(plant, nets, workers):
    """Every member's figures of one ``run_members`` batch are those of a single run with that member (the same
    code on the same machine: identical); a variant the plant refuses is an error record for every member."""
    from simulate.studies.batch import BatchPool

    members = [nets] + nets.members()[:2]
    variants = VARIANTS[:2] + [{"governor.closing_time_s": -1.0}]
    with BatchPool(plant, members, workers=workers) as pool:
        batches = pool.run_members(variants)
    assert len(batches) == 3
    for member, batch in zip(members, batches):
        assert [c.index for c in batch.cases] == [0, 1, 2] and batch.cases[2].status == "error"
        assert "closing_time_s" in batch.cases[2].error
        for variant, case in zip(VARIANTS[:2], batch.cases):
            single = run_simulation(load_plant(PLANT_HLA339, {**BASE, **variant_overrides(variant)}),
                                    characteristics=member).summary()
            assert (case.max_speed_rise, case.max_head_m) == (single["max_speed_rise"], single["max_head_m"])
    # the failing case beside it: the members differ, so a mix-up of members would show
    assert batches[0].cases[0].max_speed_rise != batches[1].cases[0].max_speed_rise


def test_a_remembered_steady_state_is_the_computed_one(plant, nets):
    """The steady state a run finds again (same characteristics, same inputs) equals a fresh computation (exactly:
    the same code on the same inputs) and a changed input is not served from memory."""
    from simulate.loop import engine

    first = engine.initial_state(plant, nets)
    again = engine.initial_state(plant, nets)
    engine._MEMO.pop(nets, None)
    fresh = engine.initial_state(plant, nets)
    assert again is first and fresh == first
    other = engine.initial_state(plant.with_overrides({"scenario.initial_power_mw": 160.0}), nets)
    assert other.power_mw == pytest.approx(160.0, rel=1e-9) and other.stroke < first.stroke


def test_a_grid_convergence_batch_varies_the_reaches(plant, nets):
    """``penstock.reaches`` varies in a batch like any number (each case builds its own grid): every case equals
    its single run (identical), and the finer grid really ran a smaller step (more steps)."""
    variants = [{"penstock.reaches": r} for r in (8, 16, 32)]
    batch = run_batch(plant, variants, characteristics=nets, mechanism="serial")
    for variant, case in zip(variants, batch.cases):
        single = run_simulation(load_plant(PLANT_HLA339, {**BASE, **variant_overrides(variant)}),
                                characteristics=nets).summary()
        assert case.status == "ok" and (case.max_head_m, case.steps) == (single["max_head_m"], single["steps"])
    assert batch.cases[0].steps < batch.cases[1].steps < batch.cases[2].steps


# --- cases that differ in structure: grouped by the model's name -------------------------------------------------
MIXED = [{"penstock.model": "rigid", "governor.closing_time_s": 8.0},
         {"governor.closing_time_s": 14.0},  # the base plant's model (moc)
         {"penstock.model": "moc", "governor.closing_time_s": 8.0},
         {"penstock.model": "rigid", "solver.pressure_loop": "newton", "governor.kp": 3.5},
         {"penstock.model": "lumped", "governor.closing_time_s": -1.0}]  # a failing case inside a group


@pytest.mark.parametrize("mechanism", ["serial", "processes"])
def test_cases_of_other_structures_are_grouped_and_equal_their_single_runs(plant, nets, mechanism):
    batch = run_batch(plant, MIXED, characteristics=nets, mechanism=mechanism, workers=2, chunk_size=1)
    assert [c.index for c in batch.cases] == [0, 1, 2, 3, 4]
    assert batch.keys == ("penstock.model", "governor.closing_time_s", "solver.pressure_loop", "governor.kp")
    for variant, case in zip(MIXED[:4], batch.cases):
        assert case.status == "ok", case.error
        assert case.values == variant  # the record names the model it ran
        s = run_simulation(load_plant(PLANT_HLA339, {**BASE, **variant}), characteristics=nets).summary()
        # the same code path on the same inputs: bit-identical
        assert case.max_speed_rise == s["max_speed_rise"] and case.max_head_m == s["max_head_m"]
    # the groups really ran other models: a rigid column has no water hammer wave, so its head differs
    assert batch.cases[0].max_head_m != batch.cases[2].max_head_m
    assert batch.cases[4].status == "error" and "closing_time_s" in batch.cases[4].error
    assert list(batch.column("penstock.model")) == ["rigid", "", "moc", "rigid", "lumped"]


def test_varied_characteristics_run_each_nets(plant, nets, tmp_path):
    import shutil

    from data_synthetic import FRANCIS_DIR

    copy = shutil.copy(FRANCIS_DIR / "nets.json", tmp_path / "nets.json")
    variants = [{"turbine.characteristics": str(copy)}, {"turbine.characteristics": "synthetic"}]
    batch = run_batch(plant, variants, mechanism="serial")
    for variant, case in zip(variants, batch.cases):
        s = run_simulation(load_plant(PLANT_HLA339, {**BASE, **variant})).summary()
        assert case.status == "ok" and case.max_speed_rise == s["max_speed_rise"]
    assert batch.cases[0].max_speed_rise != batch.cases[1].max_speed_rise  # nets against the exact turbine


def test_studies_of_one_structure_refuse_a_model_choice(plant, nets):
    from simulate.studies.batch import BatchPool

    with BatchPool(plant, [nets], workers=1) as pool:
        with pytest.raises(InputError, match=r"'penstock.model' changes the plant structure .* run one study per "
                                             r"penstock.model \(a sweep groups its cases by it\)"):
            pool.run([{"penstock.model": "rigid"}])


def _uneven_units(tmp_path):
    """The shipped two-unit plant with both units rejecting, U2 at 120 MW closing in 6 s (U1: 225 MW, 12 s): U1
    gives the speed rise, U2 the head rise, and U2 runs the longer outside the digitized chart."""
    from pathlib import Path

    from data_synthetic import FRANCIS_DIR, PLANT_TWO_UNITS

    text = Path(PLANT_TWO_UNITS).read_text(encoding="utf-8")
    text = text.replace('[[units]]\nname = "U2"\n',
                        '[[units]]\nname = "U2"\ninitial_power_mw = 120.0\n[units.governor]\nclosing_time_s = 6.0\n')
    text = text.replace('units = ["U1"]', 'units = ["U1", "U2"]')
    text = text.replace('"francis/nets.json"', f'"{(Path(FRANCIS_DIR) / "nets.json").as_posix()}"')
    path = tmp_path / "uneven.toml"
    path.write_text(text, encoding="utf-8")
    return load_plant(path)


def test_a_case_of_a_plant_with_several_units_reads_every_unit(tmp_path):
    plant = _uneven_units(tmp_path)
    assert plant.scenario.units == ("U1", "U2") and plant.units[1].governor.closing_time_s == 6.0
    result = run_simulation(plant)
    summary = result.summary()
    case = run_batch(plant, [{}], mechanism="serial").cases[0]
    assert summary["max_speed_rise_unit"] == "U1" and summary["max_head_m_unit"] == "U2"
    # the figures are the single run's, worst over the units (the lead unit U1's series held the highest head 22 m
    # lower, and N11 more than 1 r/min higher at its lowest)
    for name in ("max_speed_rise", "max_head_m", "max_head_rise", "min_head_m", "min_head_drop"):
        assert getattr(case, name) == summary[name], name
    assert case.max_head_m > result.head_m.max() + 10.0
    n11 = {name: series["speed_rpm"] * plant.units[i].turbine.runner_diameter_m / np.sqrt(series["head_m"])
           for i, (name, series) in enumerate(result.units.items())}
    assert case.min_unit_speed_rpm == min(v.min() for v in n11.values()) < n11["U1"].min() - 1.0
    assert case.max_unit_speed_rpm == max(v.max() for v in n11.values())
    # the record: per kind the unit longest outside, per figure the unit that gives it
    units = {name: series["extrapolation"] for name, series in result.units.items()}
    kind = case.extrapolation["digitized_region"]
    assert kind["unit"] == "U2" and kind["fraction_of_time"] == units["U2"]["digitized_region"]["fraction_of_time"]
    assert kind["fraction_of_time"] > units["U1"]["digitized_region"]["fraction_of_time"]
    figures = case.extrapolation["figures"]
    assert figures["max_head_rise"] == units["U2"]["figures"]["max_head_rise"]
    assert figures["max_speed_rise"] == units["U1"]["figures"]["max_speed_rise"]
    assert figures["max_head_rise"] != units["U1"]["figures"]["max_head_rise"]


def test_a_double_regulated_case_is_judged_in_its_plant_openings():
    """The training box a bulb case is checked against is the nets' box as the plant sees it (the guide-vane angle
    above the closed vane, as the case's openings are), not the three-input nets' own (absolute angles 35-78 deg,
    against which every opening of the plant, 0-43 deg, looked outside)."""
    from data_synthetic import PLANT_BULB

    plant = load_plant(PLANT_BULB, {"scenario.t_end_s": 8.0})
    chars = load_characteristics(plant.turbine, plant.base_dir)
    own, seen = nets_domain(chars), nets_domain(chars, plant)
    assert own[0].size == 3 and own[0][1] == pytest.approx(35.0, abs=1e-5)  # the nets' vane angle: absolute
    np.testing.assert_allclose([seen[0][1], seen[1][1]], [0.0, 43.0], atol=1e-5)
    case = run_batch(plant, [{}], mechanism="serial").cases[0]
    assert 0.0 <= case.max_opening_chart <= 43.0 and case.beyond_nets_range is False
    # the simulator's own record agrees: nothing outside, so the case is not extrapolated
    assert case.extrapolated is False
    low, high = own
    assert case.max_opening_chart < low[1]  # what the three-input box alone would have flagged


def test_keys_of_the_plants_optional_sections_vary_like_any_other():
    """A surge tank's area (a classic design study) and a bulb's blade servo vary in a batch where the plant has the
    section: every case equals the single run of its plant to the bit, and the figures follow the key."""
    from data_synthetic import PLANT_BULB

    surge_plant = PLANT_HLA339.parent / "plant_hla339_surge_tank.toml"
    tank = load_plant(surge_plant, {"scenario.t_end_s": 20.0})
    areas = [{"surge_tank.area_m2": a} for a in (60.0, 400.0)]
    batch = run_batch(tank, areas, mechanism="serial")
    for case, variant in zip(batch.cases, areas):
        single = run_simulation(load_plant(surge_plant, {"scenario.t_end_s": 20.0, **variant})).summary()
        assert case.ok and case.max_head_m == single["max_head_m"] and case.min_head_m == single["min_head_m"]
    small, large = batch.cases
    assert small.max_head_m != large.max_head_m  # the tank's area reaches the turbine's head
    # the tank's own figures, what its design is judged on: a case's are its single run's, and a larger tank
    # surges less (measured on the 20 s run: 22.5 m against 3.7 m above the static level)
    single = run_simulation(load_plant(surge_plant, {"scenario.t_end_s": 20.0, **areas[0]}))
    assert small.components == single.component_figures and set(small.components) == {
        "surge_level_max_m", "t_surge_level_max_s", "surge_level_min_m", "t_surge_level_min_s",
        "max_cavity_volume_m3", "cavity_nodes", "t_envelope_min_head_s"}  # the last three: the MOC penstock's
    rise = batch.column("surge_level_max_m") - tank.penstock.static_head_m
    assert rise[0] > rise[1] > 0.0
    bulb = run_batch(load_plant(PLANT_BULB, {"scenario.t_end_s": 8.0}), [{"blade_servo.servo_time_s": 0.5},
                                                                        {"blade_servo.servo_time_s": 2.0}],
                     mechanism="serial")
    assert all(c.ok for c in bulb.cases) and bulb.cases[0].max_speed_rise != bulb.cases[1].max_speed_rise
    # a section the plant does not have: refused before anything runs, naming it
    with pytest.raises(InputError, match=r"varied key 'surge_tank.area_m2': the plant has no \[surge_tank\]; add "
                                         r"the section to the plant file"):
        run_batch(load_plant(PLANT_HLA339), [{"surge_tank.area_m2": 100.0}])
    with pytest.raises(InputError, match=r"unknown key 'blade_servo.servo_tim'; numeric keys of \[blade_servo\]: "
                                         r"blade_servo.servo_time_s"):
        check_key(bulb_plant := load_plant(PLANT_BULB), "blade_servo.servo_tim")
    assert check_key(bulb_plant, "combinator.opening_at_zero_stroke") == "combinator.opening_at_zero_stroke"


def test_the_components_figures_are_columns_of_results_csv(tmp_path):
    """A draft tube's lowest outlet pressure (cavitation, column separation) is a column of a bulb sweep; a case
    without a run leaves it empty."""
    import csv

    from data_synthetic import PLANT_BULB

    plant = load_plant(PLANT_BULB, {"scenario.t_end_s": 8.0})
    batch = run_batch(plant, [{"governor.closing_time_s": 6.0}, {"governor.closing_time_s": -1.0}],
                      mechanism="serial")
    assert [c.status for c in batch.cases] == ["ok", "error"]
    # the MOC penstock's figures (its cavities), then the draft tube's (its cavities too: none formed)
    assert batch.component_figures == ("max_cavity_volume_m3", "cavity_nodes", "t_envelope_min_head_s",
                                       "min_outlet_pressure_head_m", "t_min_outlet_pressure_s",
                                       "min_draft_tube_head_m", "min_draft_tube_pressure_head_m",
                                       "min_draft_tube_pressure_x_m", "t_min_draft_tube_pressure_s",
                                       "draft_tube_max_cavity_volume_m3", "draft_tube_cavity_nodes")
    batch.to_csv(tmp_path / "results.csv")
    rows = list(csv.DictReader((tmp_path / "results.csv").open()))
    single = run_simulation(plant.with_overrides({"governor.closing_time_s": 6.0})).summary()
    assert float(rows[0]["min_outlet_pressure_head_m"]) == single["min_outlet_pressure_head_m"]  # repr: exact
    assert rows[1]["min_outlet_pressure_head_m"] == ""
    assert list(rows[0])[-11:] == list(batch.component_figures)
