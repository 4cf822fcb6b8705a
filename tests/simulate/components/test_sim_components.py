"""The component seams: a characteristics kernel on the control vector, a loop that names no
model, registries, threads (nogil)."""

import threading

import numba
import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.loop import assembly, generator
from simulate.components.registry import CHARACTERISTICS, CONTROLS, PENSTOCKS, SHAFTS, UPSTREAM
from simulate.config import load_characteristics, load_plant
from simulate.loop.engine import run_simulation


@numba.njit(cache=True)
def ideal_on_controls(params, n11, controls):
    """The ideal turbine written against the control vector: (q11, dq11/dn11, m11, dm11/dn11)."""
    q11_max, opening_max, torque_const = params
    q = q11_max / opening_max * controls[0]
    m = torque_const * q / n11
    return q, 0.0, m, -m / n11


class ControlVectorIdeal:
    """An IdealTurbine that offers ``numba_control_kernel`` (the seam a three-input turbine uses)."""

    def __init__(self, ideal):
        self.ideal = ideal

    def __getattr__(self, name):
        if name in ("q11", "m11", "q11_grad", "m11_grad"):
            return getattr(self.ideal, name)
        raise AttributeError(name)

    def numba_control_kernel(self):
        return ideal_on_controls, self.ideal.numba_kernel()[1]


def test_a_control_vector_kernel_runs_through_the_same_loop():
    plant = load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 10.0})
    ideal = load_characteristics(plant.turbine)
    ref = run_simulation(plant, ideal)
    alt = run_simulation(plant, ControlVectorIdeal(ideal))
    assert alt.meta["compiled"]
    # the same physics; the compiler may order the few multiplications differently (measured 6e-16 relative), so
    # 1e-12 relative: a wrong index into the control vector or a wrong output slot would be off by O(1)
    for name in ("speed_rpm", "head_m", "flow_m3_s", "opening", "torque_nm"):
        np.testing.assert_allclose(getattr(alt, name), getattr(ref, name), rtol=1e-12, atol=0)


def test_the_loop_template_names_no_model():
    text = " ".join([generator._HEAD, generator._STEP, generator._UNIT_SUBSTEP, generator._UNIT_TURBINE,
                     generator._UNIT_RECORDS, generator._JUNCTION, generator._JUNCTION_AFTER,
                     generator._JUNCTION_RECORDS, generator._SINGLE_AFTER]).lower()
    for word in ("moc", "zdomain", "lumped", "rigid", "governor", "prescribed", "rotor", "surge", "reservoir",
                 "nets", "ideal", "mode", "is_moc", "draft", "blade", "bulb"):
        assert word not in text, word
    # and the generated module imports each kind's functions under a role name
    plant = load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 3.0})
    r = run_simulation(plant)
    assert r.success


def test_registries_name_their_entries_and_reject_unknown_names():
    assert PENSTOCKS.names() == ("moc", "zdomain", "lumped", "rigid")
    assert UPSTREAM.names() == ("reservoir", "surge_tank")
    assert CONTROLS.names() == ("governor", "prescribed", "governor_blades", "prescribed_blades")
    assert SHAFTS.names() == ("swing", "subtransient")
    assert CHARACTERISTICS.names() == ("ideal", "synthetic", "synthetic-bulb", "nets", "nets-3", "suter-nets",
                                          "suter-curves", "synthetic-pump-turbine")
    with pytest.raises(InputError, match=r"penstock\.model must be one of moc, zdomain, lumped, rigid; got 'elastic'"):
        PENSTOCKS.builder("elastic")


def test_loop_runs_in_threads_without_the_gil():
    plant = load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 20.0})
    ref = run_simulation(plant)
    results = [None] * 3

    def work(i):
        results[i] = run_simulation(plant)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        np.testing.assert_array_equal(r.speed_rpm, ref.speed_rpm)
    loops = [m.time_loop for m in assembly._LOADED.values()]
    assert loops and all(loop.targetoptions.get("nogil") for loop in loops)


def test_result_carries_its_steady_state_and_plant():
    plant = load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 3.0})
    r = run_simulation(plant)
    assert r.plant is plant and r.steady.flow_m3_s == r.flow_m3_s[0] and r.steady.speed_rpm == r.speed_rpm[0]


def test_components_chosen_by_their_section_are_picked_without_naming_them():
    from types import SimpleNamespace

    from simulate.components.registry import Registry, section_component

    reg = Registry("shaft", "shaft", {"rotor": "simulate.components.shaft.rotor:build_rotor",
                                      "synchronous_generator": "somewhere:build"})
    assert section_component(reg, SimpleNamespace(), "rotor") == ("rotor", None)
    cfg = object()
    assert section_component(reg, SimpleNamespace(synchronous_generator=cfg), "rotor") == ("synchronous_generator", cfg)


@pytest.mark.slow
def test_a_kernel_without_a_source_file_runs_uncached():
    """A kernel from an interactive session (its module has no __file__) cannot be disk-cached: compiled in memory."""
    import sys
    import types

    mod = types.ModuleType("hillsim_interactive_kernel")
    sys.modules[mod.__name__] = mod
    try:
        src = ("import numba\n@numba.njit\ndef k(params, n11, controls):\n"
               "    q = params[0] / params[1] * controls[0]\n    m = params[2] * q / n11\n"
               "    return q, 0.0, m, -m / n11\n")
        exec(src, mod.__dict__)
        mod.k.__module__ = mod.__name__
        plant = load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 5.0})
        ideal = load_characteristics(plant.turbine)

        class Interactive(ControlVectorIdeal):
            def numba_control_kernel(self):
                return mod.k, self.ideal.numba_kernel()[1]

        r = run_simulation(plant, Interactive(ideal))
        ref = run_simulation(plant, ideal)
        np.testing.assert_allclose(r.speed_rpm, ref.speed_rpm, rtol=1e-12, atol=0)
    finally:
        del sys.modules[mod.__name__]
