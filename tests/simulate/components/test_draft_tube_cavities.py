"""Water-column separation in the ``moc`` draft tube (``draft_tube.column_separation``, the penstock's cavity models
run on the mirrored conduit, :mod:`simulate.components.hydraulic.draft_tube`): the shipped bulb's rejection with its
runner set higher, so that the pressure below the runner reaches the vapour pressure."""

import numpy as np
import pytest

from data_synthetic import PLANT_BULB
from hillchart.errors import InputError
from simulate.config import load_plant
from simulate.loop.engine import run_simulation


def bulb(runner_elevation_m: float, model: str | None = None):
    keys = {"draft_tube.runner_elevation_m": runner_elevation_m}
    if model is not None:
        keys["draft_tube.column_separation"] = model
    return run_simulation(load_plant(PLANT_BULB, keys), raise_on_failure=False)


def test_a_cavity_below_the_runner_is_modelled_and_reported():
    """The runner outlet 4 m above the tailwater: without column separation the pressure below the runner falls to
    0.228 m of water (absolute), 0.012 m below the vapour pressure (0.24 m), which the warning says is not modelled;
    the DVCM opens a cavity there instead (one node, the runner outlet, 30 m from the draft tube's outlet), holds the
    pressure at the vapour pressure (the cavity decided at the boundary flow foreseen: decided at the last step's it
    dipped to 0.228 m for a step) and says so, and the run's other figures stay those of the run without it (the
    largest head within 1e-3 of it: the cavity is small, 63 cm^3, and opens for a few steps)."""
    off, vapour = bulb(4.0, "off"), bulb(4.0, "dvcm")
    assert off.success and vapour.success
    s_off, s = off.summary(), vapour.summary()
    assert s_off["min_outlet_pressure_head_m"] == pytest.approx(0.228, abs=1e-3)
    assert any("(not modelled)" in w for w in s_off["warnings"])
    assert "draft_tube_cavity_volume_m3" not in off.signals
    assert s["draft_tube_column_separation"] == "dvcm" and s["draft_tube_cavity_nodes"] == 1
    assert s["draft_tube_max_cavity_x_m"] == pytest.approx(30.0)
    assert s["draft_tube_max_cavity_volume_m3"] == pytest.approx(6.32e-5, rel=0.05)
    # the plant's vapour pressure head (draft_tube.vapour_pressure_head_m = 0.24 m), to the mm: the cavity holds it
    assert s["min_outlet_pressure_head_m"] == pytest.approx(0.24, abs=1e-3)
    assert np.max(vapour.signals["runner_outlet_cavity_volume_m3"]) == pytest.approx(
        s["draft_tube_max_cavity_volume_m3"], rel=1e-12)
    warning = next(w for w in s["warnings"] if w.startswith("water-column separation in the draft tube"))
    assert "a vapour cavity formed at x = 30 m from the draft tube's outlet (node 3 of 3)" in warning
    assert not any("(not modelled)" in w for w in s["warnings"])
    assert vapour.head_m.max() == pytest.approx(off.head_m.max(), rel=1e-3)
    # the default, the gas cavity model: its gas expands below the runner to a partial pressure of 0.07 m (below
    # 0.1 m: a cavity, 6e-4 m^3 of gas), the pressure held above the vapour pressure
    gas = bulb(4.0)
    s_gas = gas.summary()
    assert gas.success and s_gas["draft_tube_column_separation"] == "dgcm"
    assert s_gas["draft_tube_cavity_nodes"] == 1
    assert s_gas["draft_tube_max_cavity_volume_m3"] == pytest.approx(6.05e-4, rel=0.05)
    assert s_gas["min_outlet_pressure_head_m"] == pytest.approx(0.308, abs=2e-3)


def test_a_collapse_below_the_runner_that_reverses_the_net_head_stops_the_run_saying_so():
    """The runner 6 m above the tailwater: a cavity of about 0.9 m^3 opens below the runner and its collapse drives
    the draft tube's head above the turbine inlet's; the turbine's characteristics do not cover a net head of zero
    or below, and the run stops saying why and what to change (without column separation it runs on, with the
    absolute pressure below the runner at -1.8 m of water, below zero: the failing case of the old model)."""
    for model in ("dgcm", "dvcm"):
        r = bulb(6.0, model)
        assert not r.success
        assert r.message.startswith("a cavity below the runner")
        assert "set the runner deeper (draft_tube.runner_elevation_m)" in r.message
    off = bulb(6.0, "off")
    assert off.success and off.summary()["min_outlet_pressure_head_m"] < 0.0


def test_the_keys_are_refused_where_they_would_not_hold():
    with pytest.raises(InputError, match=r"draft_tube.column_separation = 'dvcm' is read only by draft_tube.model = "
                                         r"moc; with model = 'rigid' it would be ignored"):
        load_plant(PLANT_BULB, {"draft_tube.model": "rigid", "draft_tube.column_separation": "dvcm"})
    with pytest.raises(InputError, match=r"draft_tube.vapour_pressure_head_m = 0.0: with "
                                         r"draft_tube.column_separation = 'dgcm' it must be water's vapour pressure"):
        load_plant(PLANT_BULB, {"draft_tube.vapour_pressure_head_m": 0.0})
    load_plant(PLANT_BULB, {"draft_tube.vapour_pressure_head_m": 0.0, "draft_tube.column_separation": "off"})
    # a runner so high that the water below it would boil in steady flow
    with pytest.raises(InputError, match=r"draft_tube.runner_elevation_m = 15: the absolute pressure head below the "
                                         r"runner in steady flow, -4.66 m, is not above "
                                         r"draft_tube.vapour_pressure_head_m = 0.24"):
        run_simulation(load_plant(PLANT_BULB, {"draft_tube.runner_elevation_m": 15.0}))
