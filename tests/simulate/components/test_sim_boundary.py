"""Turbine boundary (pressure loops, eqs. 27-32): agreement, guards at a = 0 / reverse flow / no head, failures."""

import math
from importlib import resources

import numba
import numpy as np
import pytest

from hillchart.errors import NumericalError
from simulate.components.turbine.boundary import (NO_POSITIVE_HEAD, NOT_CONVERGED, OK, quadratic_flow, solve_improved,
                               solve_newton,
                               solve_traditional)
from simulate.config import load_plant
from simulate.loop.engine import run_simulation

SOLVERS = {"improved": solve_improved, "traditional": solve_traditional, "newton": solve_newton}
D1 = 4.5


@numba.njit(cache=True)
def toy_francis(params, n11, a):
    """Q11 grows with opening and falls with unit speed (S-free Francis-like), M11 from a fixed efficiency shape."""
    q_per_mm, slope = params
    q = q_per_mm * a * (1.0 - slope * (n11 - 68.0))
    dq_dn = -q_per_mm * a * slope
    dq_da = q_per_mm * (1.0 - slope * (n11 - 68.0))
    m = 9000.0 * q * (1.4 - n11 / 120.0)
    return q, dq_dn, dq_da, m, 9000.0 * (dq_dn * (1.4 - n11 / 120.0) - q / 120.0), 9000.0 * dq_da * (
        1.4 - n11 / 120.0)


PARAMS = (0.53 / 28.0, 0.004)


def _residuals(head, flow, c_l, k, speed, opening, kernel=toy_francis, params=PARAMS):
    q11 = kernel(params, speed * D1 / math.sqrt(head), opening)[0]
    return abs(head - (c_l + k * flow)), abs(flow - q11 * D1 ** 2 * math.sqrt(head))


@pytest.mark.parametrize("k", [0.0, -0.5, -4.9, -95.0])  # no compliance, lumped-like, MOC-like, rigid-like
def test_three_loops_find_the_same_solution(k):
    c_l = 178.7 - k * 140.0  # H = 178.7 m near Q = 140 m3/s
    results = {}
    for name, solver in SOLVERS.items():
        relax = 1.0 if name != "traditional" else min(1.0, 1.0 / (1.0 + abs(k) * 0.4))
        head, flow, it, res, status = solver(toy_francis, PARAMS, c_l, k, 215.0, 27.0, 170.0, D1, 0.0176, 1e-9,
                                             500, relax)
        assert status == OK, name
        r_pen, r_turb = _residuals(head, flow, c_l, k, 215.0, 27.0)
        assert r_pen < 1e-9  # returned H satisfies the penstock relation exactly (rounding)
        assert r_turb < 1e-6  # turbine equation to the head tolerance (1e-9 m) times |dQ/dH| ~ 0.4 m2/s
        results[name] = (head, flow, it)
    heads = [v[0] for v in results.values()]
    assert max(heads) - min(heads) < 1e-8  # within a few head tolerances
    # the improved loop iterates only through N11: two evaluations without compliance (k = 0, H = C_L) and a
    # contraction of ~0.2-0.4 per iteration otherwise, with no tuning (alpha = 1). The traditional loop here has a
    # hand-tuned relaxation 1/(1 + 0.4|k|) and then needs about as many (measured improved/traditional/newton:
    # k=0: 2/2/2, k=-0.5: 9/9/4, k=-4.9: 16/14/4, k=-95: 20/19/5).
    if k == 0.0:
        assert results["improved"][2] == 2
    assert results["improved"][2] <= 25
    assert results["newton"][2] <= 6  # quadratic convergence with the analytic dQ11/dN11 (measured 2-5)


def test_traditional_without_relaxation_diverges_where_improved_converges():
    # MOC-like compliance: |k dQ/dH| = 4.9 * 0.39 ~ 1.9 > 1, so xi <- D_h(xi) diverges (the paper's point)
    k, c_l = -4.9, 178.7 + 4.9 * 140.0
    _, _, it, _, status = solve_traditional(toy_francis, PARAMS, c_l, k, 215.0, 27.0, 170.0, D1, 0.0176, 1e-9, 50,
                                            1.0)
    assert status in (NOT_CONVERGED, NO_POSITIVE_HEAD)
    _, _, it, _, status = solve_improved(toy_francis, PARAMS, c_l, k, 215.0, 27.0, 170.0, D1, 0.0176, 1e-9, 50, 1.0)
    assert status == OK and it <= 20  # contraction ~0.2 per iteration through N11 (measured 16)


@pytest.mark.parametrize("name", list(SOLVERS))
def test_closed_guide_vanes_give_zero_flow_and_no_nan(name):
    head, flow, it, res, status = SOLVERS[name](toy_francis, PARAMS, 250.0, -4.9, 200.0, 0.0, 178.0, D1, 0.0176,
                                                1e-10, 50, 1.0)
    assert status == OK and flow == 0.0 and head == 250.0 and it <= 2
    assert np.isfinite([head, flow, res]).all()


@numba.njit(cache=True)
def reverse_flow(params, n11, a):
    """Q11 < 0 (a turbine pushed into reverse flow), constant in N11."""
    return -0.1, 0.0, 0.0, -50.0, 0.0, 0.0


@pytest.mark.parametrize("name", list(SOLVERS))
def test_reverse_flow_is_solved_without_nan(name):
    c_l, k = 150.0, -2.0
    head, flow, it, res, status = SOLVERS[name](reverse_flow, (), c_l, k, 200.0, 10.0, 150.0, D1, 0.0176, 1e-10,
                                                200, 0.3 if name == "traditional" else 1.0)
    assert status == OK
    assert flow < 0 and head > c_l  # reverse flow through a k < 0 penstock raises the head
    r_pen, r_turb = _residuals(head, flow, c_l, k, 200.0, 10.0, reverse_flow, ())
    assert r_pen < 1e-9 and r_turb < 1e-8


@pytest.mark.parametrize("name", list(SOLVERS))
def test_no_positive_head_is_reported_not_nan(name):
    # C_L < 0 with forward flow at every N11 (ideal turbine): the head would have to be negative (column
    # separation) -> status 2 or 1, never NaN. (The toy kernel is not used: its Q11 turns negative at huge N11,
    # which is a genuine reverse-flow solution.)
    from hillchart.characteristics import IdealTurbine
    kernel, params = IdealTurbine(q11_max_m3_s=0.53, opening_max=32.0, efficiency=0.9).numba_kernel()
    head, flow, it, res, status = SOLVERS[name](kernel, params, -50.0, -4.9, 200.0, 20.0, 178.0, D1, 0.0176,
                                                1e-10, 50, 1.0)
    assert status in (NO_POSITIVE_HEAD, NOT_CONVERGED)
    assert np.isfinite([head, flow]).all()


def test_quadratic_flow_is_eq32_in_physical_units():
    # Q^2 - c k Q - c C_L = 0, c = Q11^2 D1^4: check both roots' conditions directly
    q11, c_l, k = 0.5, 180.0, -3.0
    flow, ok = quadratic_flow(q11, D1, c_l, k)
    assert ok and flow > 0
    assert flow == pytest.approx(q11 * D1 ** 2 * math.sqrt(c_l + k * flow), rel=1e-13)
    flow, ok = quadratic_flow(-q11, D1, c_l, k)
    assert ok and flow < 0 and flow == pytest.approx(-q11 * D1 ** 2 * math.sqrt(c_l + k * flow), rel=1e-13)
    assert quadratic_flow(q11, D1, -1.0, k)[1] is False


class _DroppingTurbine:
    """The ideal turbine with Q11 and M11 30 % lower above N11 = 70 r/min: once the speed pushes N11 across, the
    penstock line jumps over the turbine curve and no head solves the boundary (no loop can converge)."""

    def __init__(self, base):
        self.base = base

    def _factor(self, n11):
        return np.where(np.asarray(n11) > 70.0, 0.7, 1.0)

    def q11(self, n11, a):
        return self.base.q11(n11, a) * self._factor(n11)

    def m11(self, n11, a):
        return self.base.m11(n11, a) * self._factor(n11)

    def q11_grad(self, n11, a):
        g = self.base.q11_grad(n11, a)
        return g[0] * self._factor(n11), g[1] * self._factor(n11)

    def m11_grad(self, n11, a):
        g = self.base.m11_grad(n11, a)
        return g[0] * self._factor(n11), g[1] * self._factor(n11)


def test_engine_failure_raises_with_time_state_residual_and_what_to_change_or_returns_unsuccessful():
    from simulate.components.turbine.kinds import ideal_from_rated

    plant = load_plant(resources.files("data_synthetic") / "plant_hla339.toml",
                       {"turbine.characteristics": "ideal", "scenario.t_end_s": 5.0})
    chars = _DroppingTurbine(ideal_from_rated(plant.turbine))
    with pytest.raises(NumericalError, match=r"pressure loop 'improved' failed \(no convergence\) at t = "
                                             r"[0-9.]+ s \(step \d+\): speed .* r/min, opening .*residual .*retried "
                                             r"with relaxation 0\.5 and by Newton\): try solver\.pressure_loop = "
                                             r"\"newton\", a smaller solver\.relaxation"):
        run_simulation(plant, characteristics=chars)
    result = run_simulation(plant, characteristics=chars, raise_on_failure=False)
    assert not result.success and "no convergence" in result.message
    assert 1 < result.time_s.size < 5.0 / result.meta["dt_s"]  # stops at the failing step
    assert np.isfinite(result.head_m).all()


@pytest.mark.slow
def test_traditional_loop_at_its_default_relaxation_runs_through_its_fallback():
    # relaxation 1.0 diverges on the shipped plant (|k dQ/dH| ~ 1.9 on the MOC line); the damped retry and Newton
    # solve those steps, the run says so, and it agrees with Newton's run to the loops' tolerance (1e-10 of the
    # rated head per step; 1e-8 relative over the run)
    plant = load_plant(resources.files("data_synthetic") / "plant_hla339.toml",
                       {"turbine.characteristics": "ideal", "solver.pressure_loop": "traditional",
                        "scenario.t_end_s": 10.0})
    result = run_simulation(plant)
    assert result.meta["pressure_loop_fallback_steps"] > 0
    assert any("did not converge at" in w and "solver.pressure_loop = \"newton\"" in w
               for w in result.summary()["warnings"])
    newton = run_simulation(plant.with_overrides({"solver.pressure_loop": "newton"}))
    assert newton.meta["pressure_loop_fallback_steps"] == 0
    np.testing.assert_allclose(result.head_m, newton.head_m, rtol=1e-8)


