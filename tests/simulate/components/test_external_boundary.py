"""A kind of characteristics that brings its own turbine boundary, added from outside the package: one module and one
registry line. The module below is a valve, Q = c s sqrt(H) (c = Cd A sqrt(2 g) at full stroke, from the plant's
rated flow and head; s the stroke), whose boundary is solved in closed form with the conduit's H = C_L + k Q instead
of the pressure loop. On a frictionless reservoir-pipe-valve plant shut at once (the Allievi case) the first head
rise is Joukowsky's a Q0 / (g A); a boundary with the wrong signature is refused before the run."""

import math
import sys
import textwrap

import numpy as np
import pytest

import simulate.config  # noqa: F401  (imported before the kind is registered: the order that must work)
from hillchart.constants import G_M_S2
from hillchart.errors import NumericalError
from simulate.config import (GeneratorConfig, GovernorConfig, PenstockConfig, PenstockSegment, PlantConfig,
                             ScenarioConfig, SolverConfig, TurbineConfig)
from simulate.loop.engine import run_simulation

MODULE = textwrap.dedent('''
    """A user's valve: Q = c s sqrt(H), c = Cd A sqrt(2 g) (m^2.5/s) at full stroke, s the stroke (fraction)."""
    import math

    import numba
    import numpy as np

    from hillchart.characteristics import KernelCharacteristics
    from simulate.components.registry import CompiledPart, PartHooks
    from simulate.components.turbine.kinds import CharacteristicKind

    NO_POSITIVE_HEAD, BELOW_MINIMUM_STROKE = 2, 4
    STATUS_TEXT = {NO_POSITIVE_HEAD: "found no positive head",
                   BELOW_MINIMUM_STROKE: "was driven below its minimum stroke"}


    @numba.njit(cache=True)
    def kernel(params, n11, opening):
        # Q11 = Q / (D1^2 sqrt(H)) = q11_full a / a_max whatever N11 (m^3/s); no torque
        q11_full, opening_max = params
        return q11_full * opening / opening_max, 0.0, q11_full / opening_max, 0.0, 0.0, 0.0


    class Valve(KernelCharacteristics):
        """The valve as characteristics (the steady state and the trusted domain read them)."""

        def __init__(self, q11_full, opening_max, flow_scale):
            self.q11_full = q11_full * flow_scale
            self.params = (self.q11_full, opening_max)

        def numba_kernel(self):
            return kernel, self.params


    @numba.njit(cache=True)
    def valve_step(p, s, c_l, k, speed_rpm, controls, diag):
        # Q = c s sqrt(H) with H = C_L + k Q: Q^2 - (c s)^2 k Q - (c s)^2 C_L = 0, the positive root (k <= 0) written
        # as 2 c^2 C_L / (root - c^2 k), where nothing cancels
        flow_per_stroke, minimum_stroke = p[0][0], p[0][1]
        c = flow_per_stroke * controls[0]
        state = s[0]
        status = 0
        if c_l <= 0.0:
            status = NO_POSITIVE_HEAD
        elif controls[0] < minimum_stroke:
            status = BELOW_MINIMUM_STROKE
        if status != 0:
            diag[1] = controls[0]
            diag[2] = minimum_stroke
            diag[4] = c_l
            diag[5] = k
            return status, 0
        flow = 0.0
        if c > 0.0:
            c2 = c * c
            flow = 2.0 * c2 * c_l / (math.sqrt(c2 * c2 * k * k + 4.0 * c2 * c_l) - c2 * k)
        state[0] = c_l + k * flow
        state[1] = flow
        state[2] = 0.0
        return 0, 0


    @numba.njit(cache=True)
    def valve_signals(p, s):
        return s[0][0], s[0][1], s[0][2]


    def step_failure(status, diag, conduit):
        return (f"the valve {STATUS_TEXT[status]}", f"stroke {diag[1]:.6g} (minimum {diag[2]:.6g}), {conduit} "
                f"relation H = {diag[4]:.6g} + ({diag[5]:.6g}) Q")


    def build_boundary(inputs, minimum_stroke=0.0):
        turbine, steady = inputs.turbine, inputs.steady
        flow_per_stroke = inputs.characteristics.q11_full * turbine.runner_diameter_m ** 2  # c, m^2.5/s
        return CompiledPart(kind="turbine", name="valve", functions={"step": valve_step, "signals": valve_signals},
                            params=(np.array([flow_per_stroke, minimum_stroke]),),
                            state=(np.array([steady.head_m, steady.flow_m3_s, 0.0]),),
                            hooks=PartHooks(step_failure=step_failure))


    @numba.njit(cache=True)
    def step_without_diag(p, s, c_l, k, speed_rpm, controls):
        return 0, 0


    def build_with_minimum(inputs):
        return build_boundary(inputs, minimum_stroke=0.1)


    def build_wrong(inputs):
        part = build_boundary(inputs)
        return CompiledPart(kind="turbine", name="valve", functions={**part.functions, "step": step_without_diag},
                            params=part.params, state=part.state)


    class ValveKind(CharacteristicKind):
        by_word = True
        description = "a valve from the plant's rated flow and head"
        boundary = "user_valve:build_boundary"

        def __init__(self, flow_scale=1.0, boundary=None):
            self.flow_scale = flow_scale
            if boundary is not None:
                self.boundary = boundary

        def load(self, turbine, *, key="turbine.characteristics"):
            q11_full = turbine.rated_flow_m3_s / (turbine.runner_diameter_m ** 2 * math.sqrt(turbine.rated_head_m))
            return Valve(q11_full, turbine.opening_max, self.flow_scale)


    KIND = ValveKind()
    KIND_MORE_FLOW = ValveKind(1.02)
    KIND_WRONG = ValveKind(boundary="user_valve:build_wrong")
    KIND_MINIMUM = ValveKind(boundary="user_valve:build_with_minimum")
''')

LENGTH_M, WAVE_SPEED_M_S, DIAMETER_M = 1000.0, 1000.0, 0.5


@pytest.fixture
def register_kind(tmp_path, monkeypatch):
    """``register_kind(name, attribute)``: :data:`MODULE` written in ``tmp_path`` and its kind ``attribute``
    registered under ``name`` as a user would (one registry line); undone after."""
    from simulate.components.registry import CHARACTERISTICS

    (tmp_path / "user_valve.py").write_text(MODULE, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))

    def register(name: str, attribute: str = "KIND") -> str:
        monkeypatch.setitem(CHARACTERISTICS._entries, name, f"user_valve:{attribute}")
        return name

    yield register
    sys.modules.pop("user_valve", None)


def valve_plant(characteristics: str, t_end_s: float = 4.2) -> PlantConfig:
    """A reservoir, a frictionless 1000 m pipe of 0.5 m (a = 1000 m/s, 20 reaches) and a valve at a quarter stroke
    (0.1 m^3/s) shut at once at 0.1 s."""
    turbine = TurbineConfig(rated_head_m=100.0, rated_flow_m3_s=0.4, rated_speed_rpm=1500.0, rated_power_mw=0.36,
                            runner_diameter_m=0.3, opening_max=1.0, characteristics=characteristics)
    seg = PenstockSegment(length_m=LENGTH_M, diameter_m=DIAMETER_M, wave_speed_m_s=WAVE_SPEED_M_S, darcy_friction=0.0)
    # Joukowsky's rise: the steady loss, and the DVCM (no cavity forms: the plain MOC; the default DGCM's free gas
    # would soften the front by a part in 1e4)
    penstock = PenstockConfig(model="moc", static_head_m=100.0, reaches=20, segments=(seg,),
                              friction_model="steady", column_separation="dvcm")
    governor = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0,
                              servo_time_s=0.2, closing_time_s=10.0, opening_time_s=20.0)
    scenario = ScenarioConfig(kind="closure-law", t_end_s=t_end_s, initial_opening=0.25, event_time_s=0.1,
                              closing_time_s=0.0)
    return PlantConfig(turbine=turbine, penstock=penstock, generator=GeneratorConfig(inertia_time_s=8.0),
                       governor=governor, scenario=scenario, solver=SolverConfig())


def first_rise_m(result) -> float:
    """The largest head rise at the valve above its head before the closure, in the first period 4 L / a, m."""
    t = result.time_s - 0.1
    return float(result.head_m[(t >= 0.0) & (t < 4.0 * LENGTH_M / WAVE_SPEED_M_S)].max() - result.head_m[0])


def joukowsky_rise_m(flow_m3_s: float) -> float:
    """a Q0 / (g A), m."""
    return WAVE_SPEED_M_S * flow_m3_s / (G_M_S2 * math.pi * DIAMETER_M ** 2 / 4.0)


def test_a_kind_with_its_own_boundary_gives_the_joukowsky_rise(register_kind):
    valve = run_simulation(valve_plant(register_kind("user-valve")))
    assert type(valve.characteristics).__name__ == "Valve" and valve.meta["compiled"]
    q0 = valve.flow_m3_s[0]
    assert q0 == pytest.approx(0.1, rel=1e-12)  # a quarter of the rated 0.4 m^3/s at the static head 100 m
    # without friction the C+ line reaching the shut valve carries H0 + B Q0 (B = a / (g A)) exactly: Joukowsky's
    # rise to the rounding of sums of 100 m heads over the 20 reaches (1e-12 relative; measured 2.2e-16)
    assert first_rise_m(valve) == pytest.approx(joukowsky_rise_m(q0), rel=1e-12)
    assert np.all(valve.flow_m3_s[valve.time_s > 0.1 + 1e-9] == 0.0)  # shut: no flow, the valve's own Q = 0
    # the built-in ideal turbine on the same plant is the same valve solved by the pressure loop: its Q11 does not
    # depend on N11, so the improved loop solves the same quadratic in closed form at its first iteration, and the
    # runs agree to rounding (1e-12 m and 1e-14 m^3/s; measured 1.4e-14 m and 1.4e-17 m^3/s), far inside the
    # loop's own head tolerance (1e-6 x 100 m)
    ideal = run_simulation(valve_plant("ideal"))
    assert valve.time_s.size == ideal.time_s.size
    assert np.max(np.abs(valve.head_m - ideal.head_m)) < 1e-12
    assert np.max(np.abs(valve.flow_m3_s - ideal.flow_m3_s)) < 1e-14


def test_the_joukowsky_check_can_fail(register_kind):
    """A valve 2 % wider carries 2 % more flow, and its rise is 2 % above Joukowsky's for 0.1 m^3/s: far outside
    the 1e-12 above."""
    wider = run_simulation(valve_plant(register_kind("user-valve-wider", "KIND_MORE_FLOW")))
    assert first_rise_m(wider) != pytest.approx(joukowsky_rise_m(0.1), rel=1e-12)
    assert abs(first_rise_m(wider) / joukowsky_rise_m(0.1) - 1.02) < 1e-12  # measured 2.2e-16


def test_a_boundary_with_the_wrong_signature_is_refused_before_the_run(register_kind):
    plant = valve_plant(register_kind("user-valve-wrong", "KIND_WRONG"))
    with pytest.raises(TypeError, match=r"turbine.characteristics kind 'user-valve-wrong': its boundary 'valve' "
                                        r"'step' function user_valve.step_without_diag\(p, s, c_l, k, speed_rpm, "
                                        r"controls\) takes 6 parameter\(s\); the loop calls step\(p, s, c_l_m, k, "
                                        r"speed_rpm, controls, diag\)"):
        run_simulation(plant)


def test_a_failed_step_of_its_own_boundary_is_told_in_its_own_words(register_kind):
    """A valve that may not close below 0.1 of its stroke stops the run at the closure (the controls at t = 0.1 s,
    step 2 on dt = 0.05 s), and the message is the part's, with the values the step left in ``diag``: the C+ line
    reaching the valve, H = (H0 + B Q0) - B Q with B = a / (g A) = 519.16 s/m^2 and H0 + B Q0 = 151.916 m."""
    plant = valve_plant(register_kind("user-valve-minimum", "KIND_MINIMUM"))
    with pytest.raises(NumericalError, match=r"^the valve was driven below its minimum stroke at t = 0\.1 s \(step "
                                             r"2\): stroke 0 \(minimum 0\.1\), penstock relation H = 151\.916 \+ "
                                             r"\(-519\.16\) Q$"):
        run_simulation(plant)
    failed = run_simulation(plant, raise_on_failure=False)
    assert not failed.success and failed.time_s[-1] == pytest.approx(0.05)  # the rows of the steps done
