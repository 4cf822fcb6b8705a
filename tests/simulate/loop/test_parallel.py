"""simulate.loop.parallel: several whole runs on threads give the single runs' results, failures in place."""

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError, NumericalError
from simulate.config import load_characteristics, load_plant
from simulate.loop.engine import run_simulation
from simulate.loop.parallel import run_all

# 6 s of the shipped plant (nets, MOC): the rejection at 2 s and the overspeed's first 4 s
BASE = {"scenario.t_end_s": 6.0}


@pytest.fixture(scope="module")
def plant():
    return load_plant(PLANT_HLA339, BASE)


def test_runs_on_threads_are_the_single_runs(plant):
    """Each member's run on two threads equals its run alone (the same code on the same machine: identical
    series), in the order given; a failing job is returned in its place and the others run."""
    nets = load_characteristics(plant.turbine, plant.base_dir)
    members = nets.members()[:4]
    bad = plant.with_overrides({"solver.max_iterations": 1, "solver.fallback": False})
    results = run_all([(plant, m) for m in members] + [(bad, members[0])], workers=2)
    assert isinstance(results[-1], NumericalError) and "pressure loop" in str(results[-1])
    for member, result in zip(members, results):
        single = run_simulation(plant, characteristics=member)
        assert np.array_equal(result.speed_rpm, single.speed_rpm) and np.array_equal(result.head_m, single.head_m)
    # the failing case beside it: the members' runs differ, so results returned out of order would show
    assert results[0].summary()["max_head_m"] != results[1].summary()["max_head_m"]


@pytest.mark.parametrize("workers", [0, -1, 1.5, True])
def test_bad_worker_counts_are_refused(plant, workers):
    with pytest.raises(InputError, match="workers must be a positive integer"):
        run_all([(plant, None)], workers=workers)
