"""The Suter transform: round trips, the zones on both conventions' axes, the improved transform's bounds, bad input."""

import math

import numpy as np
import pytest

from hillchart.errors import InputError
from hillchart.four_quadrant.suter import (PLAIN, ZONES, SuterConstants, inverse_suter_transform, suter_angle,
                                           suter_transform, wylie_streeter_x_to_turbine, zone)

IMPROVED = SuterConstants(k1=6.5, k2=0.5, c_h=0.5, c_y=0.2)


def _points(n=2000, seed=0):
    rng = np.random.default_rng(seed)
    return (rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(0.05, 3, n), rng.uniform(-4, 4, n),
            rng.uniform(0, 1, n))


@pytest.mark.parametrize("constants", [PLAIN, IMPROVED])
@pytest.mark.parametrize("convention", ["turbine", "wylie-streeter"])
def test_round_trip_is_exact(constants, convention):
    """Forward then inverse returns h and m; 1e-12 relative: a few roundings of double precision (the inverse divides
    by (y + C_y)^2 - C_h WH, at least 0.04 here, so nothing is amplified by more than a factor of about 100)."""
    v, q, h, m, y = _points()
    x, wh, wm = suter_transform(v, q, h, m, y, constants=constants, convention=convention)
    assert np.all((x >= 0) & (x < 2 * math.pi))
    h2, m2 = inverse_suter_transform(wh, wm, v, q, y, constants=constants, convention=convention)
    assert np.max(np.abs(h2 - h) / np.maximum(np.abs(h), 1.0)) < 1e-12
    assert np.max(np.abs(m2 - m) / np.maximum(np.abs(m), 1.0)) < 1e-12
    # the failing case: the curves of another opening do not give back this point's head
    h3, _ = inverse_suter_transform(wh, wm, v, q, np.clip(y + 0.1, 0, 1), constants=constants, convention=convention)
    assert (np.max(np.abs(h3 - h)) > 1e-3) == (not constants.plain)


def test_plain_transform_matches_its_definition_and_wylie_streeter_axis():
    """x = pi + atan2(q, v), WH = h/(q^2 + v^2): the rated turbine point at 5 pi/4 with WH = WM = 1/2; Wylie and
    Streeter's rated pump point (alpha = v = h = beta = 1) at their x = 5 pi/4 too, and at pi/4 on the turbine axis."""
    x, wh, wm = suter_transform(1.0, 1.0, 1.0, 1.0)
    assert (float(x), float(wh), float(wm)) == pytest.approx((1.25 * math.pi, 0.5, 0.5), abs=1e-15)
    x_ws, wh_ws, _ = suter_transform(1.0, 1.0, 1.0, 1.0, convention="wylie-streeter")
    assert float(x_ws) == pytest.approx(1.25 * math.pi, abs=1e-15) and float(wh_ws) == 0.5
    # the same pump point in turbine-positive quantities: speed and flow change sign, head and torque do not
    x_t, wh_t, wm_t = suter_transform(-1.0, -1.0, 1.0, 1.0)
    assert float(x_t) == pytest.approx(0.25 * math.pi, abs=1e-15)
    assert float(wylie_streeter_x_to_turbine(x_ws)) == pytest.approx(float(x_t), abs=1e-15)
    assert (float(wh_t), float(wm_t)) == (0.5, 0.5)
    # Wylie-Streeter's x = pi + atan(v / alpha) where alpha > 0
    rng = np.random.default_rng(1)
    alpha, v = rng.uniform(0.1, 2, 100), rng.uniform(-2, 2, 100)
    x_ws = suter_angle(alpha, v, convention="wylie-streeter")
    assert np.max(np.abs(x_ws - (math.pi + np.arctan(v / alpha)))) < 1e-14


@pytest.mark.parametrize("z", ZONES, ids=lambda z: z.name)
def test_each_quadrant_maps_to_its_x_range(z):
    """Points strictly inside each quadrant land inside the zone's x-range on both axes and get its name."""
    rng = np.random.default_rng(2)
    v = z.speed_sign * rng.uniform(0.01, 2, 500)
    q = z.flow_sign * rng.uniform(0.01, 2, 500)
    x_t = suter_angle(v, q)
    x_ws = suter_angle(-v, -q, convention="wylie-streeter")
    assert np.all((x_t > z.x_turbine[0]) & (x_t < z.x_turbine[1]))
    assert np.all((x_ws > z.x_wylie_streeter[0]) & (x_ws < z.x_wylie_streeter[1]))
    assert set(zone(v, q)) == {z.name}
    # the failing case: the opposite quadrant is outside the range
    x_opposite = suter_angle(-v, -q)
    assert not np.any((x_opposite > z.x_turbine[0]) & (x_opposite < z.x_turbine[1]))


def test_turbine_brake_is_the_turbine_zone_with_negative_torque():
    names = zone([1.0, 1.0, 1.0, -1.0], [0.5, 0.5, -0.5, -0.5], [0.3, -0.3, -0.3, 0.3])
    assert names.tolist() == ["turbine", "turbine brake", "reverse pump", "pump"]
    assert zone(1.0, 0.0).tolist() == "turbine"  # zero flow at turbine speed starts the turbine zone (x = pi)
    with pytest.raises(InputError, match="standstill belongs to no zone"):
        zone(0.0, 0.0)


def test_improved_transform_bounds_the_small_openings_that_the_plain_one_blows_up():
    """On the synthetic pump-turbine's 4 mm line (y = 1/7) the plain WH reaches 9 (it grows as 1/y^2 toward the
    closed vane); the improved WH stays below (y + C_y)^2 / C_h. Numbers measured on the shipped table."""
    from data_synthetic import PUMP_TURBINE_DIR
    from hillchart.four_quadrant.table import load_complete_characteristics

    table = load_complete_characteristics(PUMP_TURBINE_DIR)
    small = table.opening == 4.0
    plain = table.suter(PLAIN)
    improved = table.suter(IMPROVED)
    y = 4.0 / 28.0
    assert plain["wh"][small].max() > 9.0
    assert improved["wh"][small].max() < (y + IMPROVED.c_y) ** 2 / IMPROVED.c_h
    # over the whole table WH spans a factor 112 plain and 24 improved (measured): the nets fit the smaller range
    assert improved["wh"].max() / improved["wh"].min() < plain["wh"].max() / plain["wh"].min() / 3


@pytest.mark.parametrize("call, message", [
    (lambda: suter_transform(0.0, 0.0, 1.0, 1.0), r"q\^2 \+ v\^2 \+ C_h h must be > 0 .*standstill"),
    (lambda: suter_transform(1.0, 0.5, -0.1, 1.0, 0.5, constants=IMPROVED),
     r"head must be >= 0 for the improved Suter transform .* got -0.1"),
    (lambda: suter_transform(1.0, np.nan, 1.0, 1.0), r"flow must be finite, got nan"),
    (lambda: suter_transform(1.0, 1.0, 1.0, 1.0, -0.2), r"opening must be >= 0 .* got -0.2"),
    (lambda: suter_transform(1.0, 1.0, 1.0, 1.0, convention="pump"),
     r"convention must be one of turbine, wylie-streeter, got 'pump'"),
    (lambda: suter_angle(1.0, 1.0, constants=IMPROVED), r"head is required when k2 > 0"),
    (lambda: inverse_suter_transform(2.0, 0.0, 1.0, 1.0, 0.0, constants=IMPROVED),
     r"wh must be < \(y \+ C_y\)\^2 / C_h = 0.08.* got 2.0"),
    (lambda: inverse_suter_transform(1.0, 1.0, 0.0, 0.0), r"must not both be 0"),
    (lambda: SuterConstants(c_h=float("inf")), r"SuterConstants.c_h must be a finite number >= 0, got inf"),
])
def test_bad_input_names_the_field_and_the_allowed_values(call, message):
    with pytest.raises(InputError, match=message):
        call()
