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
    assert plain.time_s[-1] < 5.0


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
