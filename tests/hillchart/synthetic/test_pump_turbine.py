"""The synthetic pump-turbine: its S-shaped zone, plausible efficiencies in both modes, the affinity laws, the shipped
complete-characteristics table, bad input."""

import dataclasses

import numpy as np
import pytest

from hillchart.errors import InputError
from hillchart.synthetic.pump_turbine import (PumpTurbineParameters, SyntheticPumpTurbine,
                                              write_complete_characteristics)

TURBINE = SyntheticPumpTurbine()


def _positive_slope_branch(turbine, opening):
    """Points of the turbine-side opening line at unit head (N11 > 0, Q11 > 0) where dQ11/dN11 > 0: walking from zero
    flow toward zero speed, N11 and Q11 rise together. Returns their Q11 and M11."""
    theta = np.linspace(1e-4, np.pi / 2, 20001)
    n11, q11, m11 = turbine.unit_curve(opening, theta)
    rising = (np.diff(n11) > 0) & (np.diff(q11) > 0) & (n11[1:] > 0) & (q11[1:] > 0)
    return q11[1:][rising], m11[1:][rising]


@pytest.mark.parametrize("opening", [4.0, 8.0, 12.0, 16.0, 20.0, 28.0])
def test_every_opening_has_an_s_shaped_zone(opening):
    """Past its largest N11 the turbine-side line turns back: dQ11/dN11 > 0 on a stretch with Q11 > 0."""
    q11, _ = _positive_slope_branch(TURBINE, opening)
    assert q11.size > 0 and q11.max() > 0.02  # 0.02 m^3/s: 10 % of the rated Q11, not a rounding


@pytest.mark.parametrize("opening", [8.0, 12.0, 16.0, 20.0])
def test_runaway_lies_on_the_positive_slope_branch_at_small_and_medium_openings(opening):
    """The S-zone reaches M11 > 0, so the runaway point (M11 = 0) is on it (measured M11 up to 16-33 N*m there), as on
    low-specific-speed pump-turbines. The failing case: without the runner-inlet recirculation the positive slope
    exists only in the turbine brake zone (M11 < 0 everywhere on it, measured -15 to -20 N*m at most)."""
    _, m11 = _positive_slope_branch(TURBINE, opening)
    assert m11.max() > 10.0
    plain = SyntheticPumpTurbine(dataclasses.replace(TURBINE.params, recirculation_head=1e-9))
    _, m11_plain = _positive_slope_branch(plain, opening)
    assert m11_plain.max() < -10.0


def test_best_efficiencies_are_plausible():
    """Turbine mode 0.930 at N11 73.7 r/min, Q11 0.194 m^3/s (n_q = 32), pump mode 0.931; the band 0.88-0.94 is what
    large radial pump-turbines reach (hydraulic efficiency). The failing case: doubled friction and incidence
    coefficients fall below the band."""
    bep = TURBINE.best_efficiency_point("turbine")
    assert 0.88 <= bep["efficiency"] <= 0.94
    assert 25 <= bep["n11"] * np.sqrt(bep["q11"]) <= 45  # low specific speed: n_q 30-40
    pump = TURBINE.best_efficiency_point("pump")
    assert 0.85 <= pump["efficiency"] <= 0.94 and pump["n11"] < 0 and pump["q11"] < 0
    lossy = dataclasses.replace(TURBINE.params, k_guide_vane=0.3, k_runner=0.4, k_draft_tube=0.8)
    assert SyntheticPumpTurbine(lossy).best_efficiency_point("turbine")["efficiency"] < 0.88


def test_head_and_torque_follow_the_affinity_laws_exactly():
    """H and M are homogeneous of degree 2 in (n, Q): the Suter curves depend on the direction of (n, Q) alone. 1e-12
    relative: rounding of a few dozen operations."""
    rng = np.random.default_rng(0)
    n, q, a = rng.uniform(-150, 150, 500), rng.uniform(-0.5, 0.5, 500), rng.uniform(2, 28, 500)
    h1, m1 = TURBINE.head_torque(n, q, a)
    h2, m2 = TURBINE.head_torque(2.5 * n, 2.5 * q, a)
    assert np.max(np.abs(h2 - 6.25 * h1) / np.abs(6.25 * h1)) < 1e-12
    assert np.max(np.abs(m2 - 6.25 * m1) / np.maximum(np.abs(6.25 * m1), 1e-9)) < 1e-12
    # the failing case: the opening is not a scale, a different opening gives a different head
    h3, _ = TURBINE.head_torque(n, q, np.minimum(a + 1, 28))
    assert np.max(np.abs(h3 - h1) / np.abs(h1)) > 0.01


def test_the_four_quadrants_have_the_signs_of_a_pump_turbine():
    """Turbine: H, M > 0; pump (n, Q < 0): H > 0 and M > 0 (water power and shaft power both negative); a
    standing runner passes turbine flow with a positive head, and the water's torque on it starts it (M > 0)."""
    h, m = TURBINE.head_torque([73.7, -86.7, 0.0], [0.194, -0.209, 0.1], 20.0)
    assert np.all(h > 0) and m[0] > 0 and m[1] > 0 and m[2] > 0


def test_shipped_table_regenerates_bit_identically(tmp_path):
    from data_synthetic import PUMP_TURBINE_DIR

    out = write_complete_characteristics(tmp_path / "pt")
    for name in ("table.csv", "table.toml"):
        assert (out / name).read_bytes() == (PUMP_TURBINE_DIR / name).read_bytes(), name


@pytest.mark.parametrize("call, message", [
    (lambda: TURBINE.head_torque(70.0, 0.2, 0.0), r"opening_mm must be in \(0, 28.0\] .* got 0.0"),
    (lambda: TURBINE.head_torque(70.0, 0.2, 30.0), r"opening_mm must be in \(0, 28.0\] .* got 30.0"),
    (lambda: TURBINE.head_torque(np.inf, 0.2, 10.0), r"speed_rpm and flow_m3_s must be finite"),
    (lambda: PumpTurbineParameters(k_swirl=-1.0),
     r"PumpTurbineParameters.k_swirl must be a finite number > 0, got -1.0"),
    (lambda: PumpTurbineParameters(d2=1.2), r"PumpTurbineParameters.d2 must be in \(0, 1\), got 1.2"),
    (lambda: PumpTurbineParameters(opening_max_mm=70.0), r"opening_max_mm must be < guide_vane_pitch_mm = 60.0"),
    (lambda: TURBINE.best_efficiency_point("brake"), r"mode must be 'turbine' or 'pump', got 'brake'"),
])
def test_bad_input_is_refused_with_the_field_and_the_allowed_range(call, message):
    with pytest.raises(InputError, match=message):
        call()
