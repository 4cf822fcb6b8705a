"""The pump-turbine plant through the routes that hand the simulator a characteristics object (a sweep's cases, a
user's own Suter nets, the ensemble members of ``run --uncertainty``): each runs on the four-quadrant boundary its
kind brings, as the plant file's own run does, and gives the same figures."""

import numpy as np
import pytest

from data_synthetic import PUMP_TURBINE_DIR
from hillchart.four_quadrant.nets import load_suter_nets
from simulate.components.turbine.component import plant_turbine
from simulate.components.turbine.four_quadrant import SuterCharacteristics
from simulate.config import load_plant
from simulate.loop.engine import run_simulation
from simulate.studies.batch import run_batch

PLANT = PUMP_TURBINE_DIR.parent / "plant_pump_turbine.toml"
#: 12 s: past the first speed peak (4.9 s) and the first flow reversal, and past 4.28 s, where the Q11/N11 pressure
#: loop fails on these characteristics
SHORT = {"scenario.t_end_s": 12.0}


@pytest.fixture(scope="module")
def plant():
    return load_plant(PLANT, SHORT)


@pytest.fixture(scope="module")
def own_run(plant):
    result = run_simulation(plant)
    assert result.success and result.flow_m3_s.min() < 0  # through the S-zone into reverse flow
    return result


class NoKind:
    """The same characteristics behind an object no registered kind adopts: it runs on the default boundary."""

    def __init__(self, chars):
        self._chars = chars

    def numba_kernel(self):
        return self._chars.numba_kernel()

    def __getattr__(self, name):
        if name in ("q11", "m11", "q11_grad", "m11_grad"):
            return getattr(self._chars, name)
        raise AttributeError(name)


def test_a_caller_s_suter_nets_run_on_the_four_quadrant_boundary(plant, own_run):
    """A user's SuterNets object (hillchart's, as load_suter_nets returns it) is adopted by the suter-nets kind and
    runs to the end on its boundary with the plant file's figures to the bit (the same curves, the same
    boundary); the same characteristics behind an object no kind adopts get the pressure loop, which fails."""
    nets = load_suter_nets(PUMP_TURBINE_DIR / "nets.json")
    turbine = plant_turbine(plant, nets)
    assert turbine.kind == "suter-nets" and isinstance(turbine.characteristics, SuterCharacteristics)
    result = run_simulation(plant, characteristics=nets)
    assert result.success
    for name in ("speed_rpm", "head_m", "flow_m3_s", "torque_nm"):
        np.testing.assert_array_equal(getattr(result, name), getattr(own_run, name))
    # the failing case: the default boundary on the same characteristics stops where the S-zone begins
    plain = run_simulation(plant, characteristics=NoKind(turbine.characteristics), raise_on_failure=False)
    assert not plain.success and "pressure loop" in plain.message
    assert plain.time_s[-1] < 5.67  # before the first speed peak, where the path enters the S-zone


def test_a_table_is_adopted_by_the_curves_kind(plant):
    """The plant's own exact machine (a SuterCharacteristics of a table) given back as the caller's object keeps a
    four-quadrant kind; an object of another kind is adopted by none."""
    exact = load_plant(PLANT, {**SHORT, "turbine.characteristics": "synthetic-pump-turbine"})
    table = plant_turbine(exact).characteristics
    assert plant_turbine(plant, table).kind == "suter-curves"
    assert plant_turbine(plant, NoKind(table)).kind is None


def test_a_sweep_case_gives_the_run_s_figures(plant, own_run):
    """A sweep's case at the plant's own inertia is the plant's run to the bit (the sweep hands the loaded
    characteristics to every case: before, that object ran on the pressure loop and failed at 4.28 s); another
    inertia runs to the end too and moves the speed peak (larger Ta, smaller overspeed)."""
    batch = run_batch(plant, [{"generator.inertia_time_s": 6.0}, {"generator.inertia_time_s": 8.0}],
                      mechanism="serial")
    same, heavier = batch.cases
    assert same.ok and heavier.ok, (same.error, heavier.error)
    summary = own_run.summary()
    for name in ("max_speed_rise", "max_speed_rpm", "max_head_m", "min_head_m", "t_max_speed_s"):
        assert getattr(same, name) == summary[name], name
    assert heavier.max_speed_rise < same.max_speed_rise


def test_the_summary_gives_the_four_quadrant_figures(own_run):
    """The runaway through the S-zone: the flow reverses (about 10 m^3/s backwards), the speed never does, and the
    first speed peak comes 5.7 s into the run, before the largest one (the runaway oscillates and its second peak is
    higher). Against the exact machine through the same simulator each figure within 2 % (measured: reverse flow
    0.09 %, reversal and runaway times 1.0 %: the nets' S-zone is that close, docs/pump-turbines.md)."""
    nets = own_run.summary()
    exact = run_simulation(load_plant(PLANT, {**SHORT, "turbine.characteristics": "synthetic-pump-turbine"})).summary()
    assert nets["max_reverse_speed_rpm"] == 0.0 == nets["max_reverse_speed_pct"]
    assert nets["max_reverse_flow_m3_s"] == pytest.approx(-own_run.flow_m3_s.min(), abs=0)
    t = own_run.time_s
    first_negative = t[np.argmax(own_run.flow_m3_s < 0)]
    assert first_negative - (t[1] - t[0]) < nets["t_flow_reversal_s"] < first_negative
    peak = int(np.argmax(t >= nets["t_runaway_s"]))
    assert own_run.speed_rpm[peak] == own_run.speed_rpm[:peak + 40].max()  # the first peak: 1.1 s on either side
    for name in ("max_reverse_flow_m3_s", "t_flow_reversal_s", "t_runaway_s"):
        assert nets[name] == pytest.approx(exact[name], rel=0.02), name
    assert own_run.component_figures["t_runaway_s"] == nets["t_runaway_s"]  # a sweep's column too


def test_a_francis_turbine_gives_no_four_quadrant_figures():
    """The figures belong to kinds that can reverse (CharacteristicKind.four_quadrant): a Francis chart's run has
    none, even where its series would give numbers."""
    from data_synthetic import PLANT_HLA339

    summary = run_simulation(load_plant(PLANT_HLA339, {"scenario.t_end_s": 4.0})).summary()
    assert not any(name in summary for name in ("max_reverse_speed_rpm", "t_flow_reversal_s", "t_runaway_s"))


def test_uncertainty_runs_each_member_of_the_suter_nets(plant, own_run):
    """--uncertainty on the shipped Suter nets: one run per member (4; the first is the point nets, so its figures
    are the plant's run to the bit), and the band of each figure contains the central run's figure with a width
    > 0 (the members differ by their data splits: measured 0.4 points of speed rise, 1.4 points of head rise)."""
    from simulate.studies.uncertainty import run_ensemble

    band, traces = run_ensemble(plant)
    assert band["members"] == 4 and band["failed"] == [] and traces.members == 4
    summary = own_run.summary()
    for name in ("max_speed_rise", "max_head_rise", "min_head_drop", "max_reverse_flow_m3_s", "t_runaway_s"):
        low, high = band[name]["low"], band[name]["high"]
        assert band[name]["values"][0] == summary[name], name
        assert low <= summary[name] <= high and high - low > 0, name
    assert band["max_reverse_speed_pct"]["high"] == 0.0  # no member turns the runner backwards


def test_uncertainty_without_members_is_refused(tmp_path):
    """The same nets without their ensemble: the clear error, no run."""
    import json

    from hillchart.errors import InputError
    from simulate.studies.uncertainty import run_ensemble

    doc = json.loads((PUMP_TURBINE_DIR / "nets.json").read_text(encoding="utf-8"))
    assert doc["members"]
    doc["members"] = []
    (tmp_path / "nets.json").write_text(json.dumps(doc), encoding="utf-8")
    plant = load_plant(PLANT, {**SHORT, "turbine.characteristics": str(tmp_path / "nets.json")})
    with pytest.raises(InputError, match="needs nets with an ensemble"):
        run_ensemble(plant)
