"""Headrace tunnel + surge tank as a pluggable component: analytic mass oscillation, friction decay,
the example plant through the CLI, and garbage in the [surge_tank] section."""

import csv
import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.constants import G_M_S2
from hillchart.errors import InputError, NumericalError
from simulate.config import load_plant, plant_from_dict, to_dict
from simulate.loop.engine import run_simulation

SURGE_PLANT = Path(PLANT_HLA339).parent / "plant_hla339_surge_tank.toml"
#: the [surge_tank] section, spelled as in the documented file layout
TANK = {"surge_tank.area_m2": 100.0, "surge_tank.throttle_loss_coefficient": 0.0,
        "surge_tank.tunnel_length_m": 1000.0, "surge_tank.tunnel_diameter_m": 3.5,
        "surge_tank.tunnel_darcy_friction": 0.0}


def _instant_stop(t_end_s=450.0, **extra):
    """Ideal turbine on a frictionless rigid penstock; the vanes shut within one step at t = 2 s: the penstock flow
    stops instantaneously, as the analytic solution assumes."""
    plant = load_plant(PLANT_HLA339, {**TANK, **extra, "penstock.model": "rigid", "turbine.characteristics": "ideal",
                                      "scenario.kind": "closure-law", "scenario.closing_time_s": 0.0,
                                      "scenario.t_end_s": t_end_s})
    pen = dataclasses.replace(plant.penstock, segments=tuple(
        dataclasses.replace(s, darcy_friction=0.0) for s in plant.penstock.segments))
    return run_simulation(dataclasses.replace(plant, penstock=pen))


def _crossings(t, y):
    """Times where y changes sign (linear interpolation) and the direction (+1 up, -1 down)."""
    s = np.sign(y)
    idx = np.flatnonzero(s[:-1] * s[1:] < 0)
    times = t[idx] - y[idx] * (t[idx + 1] - t[idx]) / (y[idx + 1] - y[idx])
    return times, np.sign(y[idx + 1] - y[idx])


def test_frictionless_mass_oscillation_matches_the_analytic_amplitude_and_period():
    r = _instant_stop()
    tank = r.plant.surge_tank
    z, q_t, t = r.signals["surge_level_m"], r.signals["tunnel_flow_m3_s"], r.time_s
    a_t = tank.tunnel_area_m2
    v0 = q_t[0] / a_t
    amplitude = v0 * math.sqrt(tank.tunnel_length_m * a_t / (G_M_S2 * tank.area_m2))  # z = V0 sqrt(L A_t/(g A_s))
    period = 2.0 * math.pi * math.sqrt(tank.tunnel_length_m * tank.area_m2 / (G_M_S2 * a_t))  # T
    z0 = z[0]
    assert z0 == r.plant.penstock.static_head_m  # no tunnel friction: the tank stands at the reservoir level
    after = t > 2.0 + 1e-9
    rise, fall = z[after].max() - z0, z0 - z[after].min()
    times, direction = _crossings(t[after], z[after] - z0)
    downs = times[direction < 0]
    measured_period = downs[1] - downs[0]
    errors = {"rise": rise / amplitude - 1, "fall": fall / amplitude - 1, "period": measured_period / period - 1}
    # 0.5 %: the promised accuracy; symplectic Euler at omega dt = 6e-4 is good to ~1e-4 (measured: 3e-8)
    assert max(abs(e) for e in errors.values()) < 5e-3, errors
    print("surge tank errors vs analytic:", errors)


def test_the_analytic_check_fails_for_a_throttled_tank():
    """The check can fail: a throttle (R = 0.02 s^2/m^5, about 20 m of loss at the initial flow) damps the first
    swing far beyond 0.5 %."""
    r = _instant_stop(t_end_s=120.0, **{"surge_tank.throttle_loss_coefficient": 0.002})
    tank = r.plant.surge_tank
    z, q_t = r.signals["surge_level_m"], r.signals["tunnel_flow_m3_s"]
    amplitude = q_t[0] / tank.tunnel_area_m2 * math.sqrt(tank.tunnel_length_m * tank.tunnel_area_m2
                                                         / (G_M_S2 * tank.area_m2))
    assert abs((z.max() - z[0]) / amplitude - 1) > 5e-3


def test_tunnel_friction_makes_the_oscillation_decay():
    r = _instant_stop(**{"surge_tank.tunnel_darcy_friction": 0.015, "surge_tank.tunnel_diameter_m": 6.0})
    z = r.signals["surge_level_m"]
    z0 = z[0]
    # the steady level is below the reservoir by the tunnel loss K_t Q0^2
    k_t = r.plant.surge_tank.steady_loss_coefficient_s2_m5
    assert z0 == pytest.approx(r.plant.penstock.static_head_m - k_t * r.flow_m3_s[0] ** 2, rel=1e-12)
    zr = z - r.plant.penstock.static_head_m  # oscillates about the reservoir level once the flow has stopped
    peaks = [i for i in range(1, z.size - 1) if zr[i] > 0 and zr[i] >= zr[i - 1] and zr[i] > zr[i + 1]]
    troughs = [i for i in range(1, z.size - 1) if zr[i] < 0 and zr[i] <= zr[i - 1] and zr[i] < zr[i + 1]]
    assert len(peaks) >= 2 and len(troughs) >= 1
    assert zr[peaks[1]] < 0.8 * zr[peaks[0]]  # each swing loses energy to friction
    assert abs(zr[troughs[0]]) < zr[peaks[0]]
    frictionless = _instant_stop(t_end_s=150.0, **{"surge_tank.tunnel_diameter_m": 6.0})
    assert zr[peaks[0]] < frictionless.signals["surge_level_m"].max() - frictionless.plant.penstock.static_head_m


@pytest.mark.slow
def test_example_plant_with_a_surge_tank_through_the_cli(tmp_path, capsys):
    from hillsim.cli import main

    out = tmp_path / "surge"
    assert main(["run", str(SURGE_PLANT), "--out", str(out), "--no-plot", "--set", "scenario.t_end_s=150"]) == 0
    with open(out / "timeseries.csv", encoding="utf-8") as fh:
        header = next(csv.reader(fh))
    # the tank's columns, then the MOC penstock's cavity volumes
    assert header[-4:] == ["surge_level_m", "tunnel_flow_m3_s", "cavity_volume_m3", "outlet_cavity_volume_m3"]
    data = np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1)
    z, q_t = data[:, -4], data[:, -3]
    assert np.all(data[:, -2:] == 0.0)  # no cavity on this plant
    assert q_t[0] == pytest.approx(data[0, 3], rel=1e-9)  # tunnel flow = turbine flow at the steady start
    assert z.max() - z[0] > 5.0  # the load rejection drives an up-surge
    summary = json.loads((out / "summary.json").read_text())
    assert summary["surge_tank_period_s"] == pytest.approx(
        2 * math.pi * math.sqrt(1000.0 * 200.0 / (G_M_S2 * math.pi * 8.0 ** 2 / 4)), rel=1e-12)
    # the tank is upstream of the penstock: the penstock's inlet node now follows the tank, not a constant level
    assert summary["envelope_max_head_x_m"] == 500.0


def test_tank_running_dry_is_an_error_and_overflow_a_warning():
    with pytest.raises(NumericalError, match=r"surge tank level fell to .* below the tank bottom "
                                             r"\(surge_tank\.level_min_m = -10\.0 m"):
        _instant_stop(t_end_s=250.0, **{"surge_tank.level_min_m": -10.0})
    r = _instant_stop(t_end_s=100.0, **{"surge_tank.level_max_m": 10.0})
    assert any("overflow crest" in w for w in r.summary()["warnings"])
    r = _instant_stop(t_end_s=100.0, **{"surge_tank.level_max_m": 60.0, "surge_tank.level_min_m": -60.0})
    assert r.success and not any("surge tank" in w for w in r.summary()["warnings"])


@pytest.mark.parametrize("key,value,message", [
    ("area_m2", 0.0, r"surge_tank\.area_m2 must be in \(0\.0, 100000\.0\], got 0\.0"),
    ("throttle_loss_coefficient", -1.0, r"surge_tank\.throttle_loss_coefficient must be in \[0\.0, 10000\.0\]"),
    ("tunnel_length_m", "long", r"surge_tank\.tunnel_length_m must be a number"),
    ("tunnel_diameter_m", 50.0, r"surge_tank\.tunnel_diameter_m must be in \(0\.0, 30\.0\]"),
    ("tunnel_darcy_friction", 0.5, r"surge_tank\.tunnel_darcy_friction must be in \[0\.0, 0\.2\]"),
    ("level_max_m", -5.0, r"surge_tank\.level_max_m must be in \(0\.0, 10000\.0\]"),
    ("level_min_m", 5.0, r"surge_tank\.level_min_m must be in \[-10000\.0, 0\.0\)"),
    ("volume_m3", 5.0, r"unknown key surge_tank\.volume_m3; valid keys of \[surge_tank\]: area_m2"),
])
def test_surge_tank_garbage(key, value, message):
    raw = to_dict(load_plant(SURGE_PLANT))
    raw["surge_tank"][key] = value
    with pytest.raises(InputError, match=message):
        plant_from_dict(raw)


def test_missing_surge_tank_key_and_round_trip():
    raw = to_dict(load_plant(SURGE_PLANT))
    assert plant_from_dict(raw, base_dir=SURGE_PLANT.parent) == load_plant(SURGE_PLANT)
    del raw["surge_tank"]["tunnel_length_m"]
    with pytest.raises(InputError, match=r"missing required key surge_tank\.tunnel_length_m"):
        plant_from_dict(raw)
    assert "surge_tank" not in to_dict(load_plant(PLANT_HLA339))  # absent section stays absent
