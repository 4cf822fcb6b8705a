"""The compiled loop runs without numba's reference counting (:func:`simulate.loop.assembly._header_lines`): it must
leave no reference behind, and a component that needs the runtime (its step allocates) runs in the counted twin."""

import gc
import textwrap

import numpy as np
import pytest
from numba.core.runtime import _nrt_python, rtsys

from data_synthetic import PLANT_HLA339
from simulate.config import load_plant
from simulate.loop import assembly, generator
from simulate.loop.engine import run_simulation


def unfreed_meminfos(action) -> int:
    """numba runtime objects (meminfos) made during ``action()`` and not freed after it."""
    enabled = _nrt_python.memsys_stats_enabled()
    _nrt_python.memsys_enable_stats()
    try:
        gc.collect()
        before = rtsys.get_allocation_stats()
        action()
        gc.collect()
        after = rtsys.get_allocation_stats()
    finally:
        if not enabled:
            _nrt_python.memsys_disable_stats()
    return (after.mi_alloc - before.mi_alloc) - (after.mi_free - before.mi_free)


@pytest.mark.parametrize("overrides", [{}, {"turbine.characteristics": "ideal", "scenario.t_end_s": 10.0}],
                         ids=["nets", "ideal"])
def test_a_run_leaves_no_reference_behind(overrides):
    plant = load_plant(PLANT_HLA339, overrides)
    run_simulation(plant)  # compiled (or loaded) before counting
    # every array handed to the compiled loop is wrapped in a meminfo for the call: a reference the loop kept would
    # keep its meminfo (and the array) alive
    assert unfreed_meminfos(lambda: run_simulation(plant)) == 0


def test_the_count_sees_a_reference_kept():
    """The failing case of the check above: a runtime object made and kept is counted."""
    kept = []
    assert unfreed_meminfos(lambda: kept.append(rtsys.meminfo_alloc(64))) == 1


ALLOCATING = textwrap.dedent('''
    """The built-in rigid column, with an update that allocates (a scratch array per step)."""
    import numba
    import numpy as np

    from simulate.components.hydraulic import penstock


    @numba.njit(cache=True)
    def update(p, s, upstream_head_m, head_m, flow_m3_s):
        scratch = np.empty(1)
        scratch[0] = flow_m3_s
        penstock.iir_update(p, s, upstream_head_m, head_m, scratch[0])


    def build(plant, steady, dt_s, upstream_head_m):
        part = penstock.build_rigid(plant, steady, dt_s, upstream_head_m)
        part.functions["update"] = update
        return part


    def time_scales(plant, schedules):
        return penstock.time_scales(plant, schedules)
''')


def test_a_component_that_allocates_runs_in_the_counted_loop(register_penstock):
    allocating_penstock = register_penstock("allocating_rigid", ALLOCATING)
    overrides = {"turbine.characteristics": "ideal", "scenario.t_end_s": 8.0}
    user = run_simulation(load_plant(PLANT_HLA339, overrides | {"penstock.model": allocating_penstock}))
    built_in = run_simulation(load_plant(PLANT_HLA339, overrides | {"penstock.model": "rigid"}))
    # the same operations in the same order: equal to the bit
    for name in ("head_m", "speed_rpm", "flow_m3_s"):
        np.testing.assert_array_equal(getattr(user, name), getattr(built_in, name))
    loops = {loop.counted for loop in generator._ASSEMBLED.values() if isinstance(loop, assembly.CompiledLoop)}
    assert loops == {False, True}  # the allocating one fell back, the built-in ones did not
