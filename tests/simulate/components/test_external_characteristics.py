"""A kind of characteristics added from outside the package: one module and one registry line, after
``simulate.config`` is imported. The module below is the ideal turbine written in the plant's rated terms
(Q11 = Q_r / (D1^2 sqrt(H_r)) a / a_max, M11 = P_r / (Q_r H_r) Q11 / omega11); the loop runs it like the built-in
``ideal`` kind, to the same numbers."""

import sys
import textwrap

import numpy as np
import pytest

import simulate.config  # noqa: F401  (imported before the kind is registered: the order that must work)
from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.config import load_plant
from simulate.loop.engine import run_simulation

MODULE = textwrap.dedent('''
    """A user's turbine: the ideal turbine in the plant's rated terms."""
    import math

    import numba
    import numpy as np

    from simulate.components.turbine.kinds import CharacteristicKind


    @numba.njit(cache=True)
    def kernel(params, n11, opening):
        # Q11 = q11_r a / a_max; M11 = (P_r / (Q_r H_r)) Q11 / omega11 with omega11 = 2 pi N11 / 60 (rad/s)
        q11_rated, opening_max, power_per_flow_head = params
        q = q11_rated * opening / opening_max
        omega = n11 * (2.0 * math.pi / 60.0)
        m = power_per_flow_head * q / omega
        return q, 0.0, q11_rated / opening_max, m, -m / n11, power_per_flow_head * q11_rated / opening_max / omega


    class RatedTurbine:
        """Q11 (m^3/s) and M11 (N*m) of (N11 r/min, a chart units) from a turbine section's rated values."""

        def __init__(self, turbine, flow_scale):
            self.params = (flow_scale * turbine.rated_flow_m3_s
                           / (turbine.runner_diameter_m ** 2 * math.sqrt(turbine.rated_head_m)),
                           turbine.opening_max,
                           turbine.rated_power_mw * 1e6 / (turbine.rated_flow_m3_s * turbine.rated_head_m))

        def _values(self, n11, opening):
            n11, opening = np.broadcast_arrays(np.asarray(n11, float), np.asarray(opening, float))
            return kernel.py_func(self.params, n11, opening)

        def q11(self, n11, opening):
            return self._values(n11, opening)[0]

        def m11(self, n11, opening):
            return self._values(n11, opening)[3]

        def q11_grad(self, n11, opening):
            q, dq_dn, dq_da = self._values(n11, opening)[:3]
            return np.zeros_like(q) + dq_dn, np.zeros_like(q) + dq_da

        def m11_grad(self, n11, opening):
            m, dm_dn, dm_da = self._values(n11, opening)[3:]
            return dm_dn, np.zeros_like(m) + dm_da

        def numba_kernel(self):
            return kernel, self.params


    class RatedKind(CharacteristicKind):
        by_word = True
        description = "the ideal turbine in the plant's rated terms"

        def __init__(self, flow_scale):
            self.flow_scale = flow_scale

        def load(self, turbine, *, key="turbine.characteristics"):
            return RatedTurbine(turbine, self.flow_scale)


    KIND = RatedKind(1.0)
    KIND_MORE_FLOW = RatedKind(1.02)
''')


@pytest.fixture
def register_kind(tmp_path, monkeypatch):
    """``register_kind(name, attribute)``: :data:`MODULE` written in ``tmp_path`` and its kind object ``attribute``
    registered under ``name`` as a user would (one registry line); undone after."""
    from simulate.components.registry import CHARACTERISTICS

    (tmp_path / "user_turbine.py").write_text(MODULE, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))

    def register(name: str, attribute: str = "KIND") -> str:
        monkeypatch.setitem(CHARACTERISTICS._entries, name, f"user_turbine:{attribute}")
        return name

    yield register
    sys.modules.pop("user_turbine", None)


OVERRIDES = {"scenario.t_end_s": 12.0}


def test_a_kind_registered_after_the_config_is_imported_runs_like_the_built_in_one(register_kind):
    user = run_simulation(load_plant(PLANT_HLA339, OVERRIDES | {"turbine.characteristics": register_kind("rated")}))
    built_in = run_simulation(load_plant(PLANT_HLA339, OVERRIDES | {"turbine.characteristics": "ideal"}))
    assert type(user.characteristics).__name__ == "RatedTurbine" and user.meta["compiled"]
    assert user.meta["dt_s"] == built_in.meta["dt_s"] and user.time_s.size == built_in.time_s.size
    # 1e-9 relative: the same ideal turbine written with rho g eta = P_r / (Q_r H_r) instead of the efficiency
    # (another order of the same operations, ~1e-16 each, over ~600 steps)
    for name in ("head_m", "speed_rpm", "flow_m3_s", "torque_nm"):
        a, b = getattr(user, name), getattr(built_in, name)
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b)), name


def test_the_comparison_can_fail(register_kind):
    """The same kind with 2 % more flow at every opening is another trajectory, far outside the tolerance above."""
    more = run_simulation(load_plant(PLANT_HLA339, OVERRIDES | {
        "turbine.characteristics": register_kind("rated-more-flow", "KIND_MORE_FLOW")}))
    built_in = run_simulation(load_plant(PLANT_HLA339, OVERRIDES | {"turbine.characteristics": "ideal"}))
    assert np.max(np.abs(more.flow_m3_s - built_in.flow_m3_s)) > 1e-3 * np.max(built_in.flow_m3_s)


def test_a_misspelt_word_names_the_registered_ones(register_kind):
    register_kind("rated")
    plant = load_plant(PLANT_HLA339, OVERRIDES | {"turbine.characteristics": "ratd"})
    with pytest.raises(InputError, match=r"nets file .*ratd' does not exist; give \"ideal\", \"synthetic\", "
                                         r"\"synthetic-bulb\", \"synthetic-pump-turbine\", \"rated\" or the path of "
                                         r"a nets.json"):
        run_simulation(plant)
