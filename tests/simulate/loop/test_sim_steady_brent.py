"""simulate.loop.steady.brentq: scipy.optimize.brentq's algorithm without importing scipy.optimize
(start-up time).

The port must return scipy's root to the bit (the steady state, and so the stored reference run, depends on it),
take the same number of function calls, and fail where scipy fails.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq as scipy_brentq

from hillchart.errors import InputError, NumericalError
from simulate.loop.steady import brentq

CASES = [
    (lambda x: x * x - 2.0, 0.0, 2.0),
    (lambda x: math.cos(x) - x, 0.0, 1.0),
    (lambda x: x ** 3 - 2 * x - 5, 2.0, 3.0),
    (lambda x: math.exp(x) - 1e-3, -20.0, 5.0),
    (lambda x: math.atan(1e4 * (x - 0.3)), -1.0, 1.0),  # nearly a step: many bisections
    (lambda x: (x - 1.0) ** 3, 0.0, 3.5),  # triple root: slow interpolation
    (lambda x: x - 0.25, 0.25, 1.0),  # root at an end point
    (lambda x: math.tanh(x - 1e-9), -1e3, 1e3),
]


@pytest.mark.parametrize("case", range(len(CASES)))
@pytest.mark.parametrize("tols", [dict(xtol=2e-12, rtol=8.881784197001252e-16), dict(xtol=1e-15, rtol=1e-15),
                                  dict(xtol=1e-3, rtol=1e-6)])
def test_same_root_and_calls_as_scipy(case, tols):
    f, a, b = CASES[case]
    calls = {"ours": 0, "scipy": 0}

    def counted(key):
        def g(x):
            calls[key] += 1
            return f(x)
        return g

    ours = brentq(counted("ours"), a, b, maxiter=500, **tols)
    ref = scipy_brentq(counted("scipy"), a, b, maxiter=500, **tols)
    # bit-identical (not approximately equal): the port takes scipy's steps; one different rounding would show
    assert ours == ref, (ours, ref)
    assert calls["ours"] == calls["scipy"]


def test_random_cubics_match_scipy_bit_for_bit():
    rng = np.random.default_rng(10)
    for _ in range(200):
        c = rng.normal(size=4)
        a, b = -10.0, 10.0

        def f(x, c=c):
            return ((c[0] * x + c[1]) * x + c[2]) * x + c[3] * 50.0

        if f(a) * f(b) >= 0:
            continue
        assert brentq(f, a, b, xtol=1e-14, rtol=1e-15) == scipy_brentq(f, a, b, xtol=1e-14, rtol=1e-15)


def test_steady_state_of_the_shipped_plant_is_unchanged():
    """The shipped plant's steady state with the port equals the one scipy's brentq gives (same head and stroke)."""
    import importlib.resources as ir

    import simulate.loop.steady as steady
    from simulate.config import load_characteristics, load_plant
    from simulate.loop.engine import initial_state

    plant = load_plant(ir.files("data_synthetic") / "plant_hla339.toml")
    chars = load_characteristics(plant.turbine, plant.base_dir)
    ours = initial_state(plant, chars)
    original = steady.brentq
    try:
        steady.brentq = lambda f, a, b, **kw: scipy_brentq(f, a, b, **kw)
        ref = initial_state(plant, chars)
    finally:
        steady.brentq = original
    assert (ours.stroke, ours.head_m, ours.flow_m3_s, ours.torque_nm) == (ref.stroke, ref.head_m, ref.flow_m3_s,
                                                                          ref.torque_nm)


def test_errors():
    with pytest.raises(NumericalError, match="same sign"):
        brentq(lambda x: x * x + 1.0, -1.0, 1.0)
    with pytest.raises(NumericalError, match="NaN"):
        brentq(lambda x: math.nan if x > 0.5 else -1.0, 0.0, 1.0)
    with pytest.raises(NumericalError, match="no convergence in 3 iterations"):
        brentq(lambda x: math.atan(1e4 * (x - 0.3)), -1.0, 1.0, xtol=1e-15, maxiter=3)
    with pytest.raises(InputError, match="xtol"):
        brentq(lambda x: x, -1.0, 1.0, xtol=0.0)
    with pytest.raises(InputError, match="rtol"):
        brentq(lambda x: x, -1.0, 1.0, rtol=1e-17)
    # scipy agrees on what is an error
    with pytest.raises(ValueError):
        scipy_brentq(lambda x: x * x + 1.0, -1.0, 1.0)
    with pytest.raises(RuntimeError):
        scipy_brentq(lambda x: math.atan(1e4 * (x - 0.3)), -1.0, 1.0, xtol=1e-15, maxiter=3)
