"""A component added from outside the package: one module and one registry line, after ``simulate.config`` is
imported. The module below is a rigid water column written in physical units (backward Euler of
H = H_up - K Q|Q| - (sum L / (g A)) dQ/dt); the loop runs it like the built-in ``rigid`` model, to the same numbers."""

import textwrap

import numpy as np
import pytest

import simulate.config  # noqa: F401  (imported before the component is registered: the order that must work)
from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from simulate.config import load_plant
from simulate.loop.engine import run_simulation

MODULE = textwrap.dedent('''
    """A user's penstock: a rigid column in physical units."""
    import numba
    import numpy as np

    from simulate.components.hydraulic import penstock
    from simulate.components.registry import CompiledPart, PartHooks


    @numba.njit(cache=True)
    def relation(p, s, upstream_head_m):
        # H = H_up - K Q_prev|Q_prev| - I (Q - Q_prev) / dt, I = sum L / (g A)
        friction, inertance_per_dt = p[0][0], p[0][1]
        q_prev = s[0][0]
        return upstream_head_m - friction * q_prev * abs(q_prev) + inertance_per_dt * q_prev, -inertance_per_dt


    @numba.njit(cache=True)
    def update(p, s, upstream_head_m, head_m, flow_m3_s):
        s[0][0] = flow_m3_s


    @numba.njit(cache=True)
    def inlet_flow(p, s):
        return s[0][0]


    def build(plant, steady, dt_s, upstream_head_m):
        pen = plant.penstock
        params = (np.array([pen.friction_coefficient_s2_m5, pen.inertance_s2_m2 / dt_s]),)
        return CompiledPart(kind="penstock", name="user_rigid",
                            functions={"relation": relation, "update": update, "inlet_flow": inlet_flow,
                                       "envelope": penstock.iir_envelope, "node_heads": penstock.iir_node_heads},
                            params=params, state=(np.array([steady.flow_m3_s]),), n_nodes=2,
                            node_x_m=np.array([0.0, pen.length_m]), hooks=PartHooks(summary={"user_model": True}))


    def time_scales(plant, schedules):
        return penstock.time_scales(plant, schedules)   # the water time, as the built-in rigid column
''')


@pytest.fixture
def user_penstock(register_penstock):
    return register_penstock("user_rigid", MODULE)  # one registry line, restored after


def test_a_penstock_registered_after_the_config_is_imported_runs_like_the_built_in_one(user_penstock):
    overrides = {"turbine.characteristics": "ideal", "scenario.t_end_s": 12.0}
    user = run_simulation(load_plant(PLANT_HLA339, overrides | {"penstock.model": user_penstock}))
    built_in = run_simulation(load_plant(PLANT_HLA339, overrides | {"penstock.model": "rigid"}))
    assert user.meta["user_model"] is True and user.meta["dt_s"] == built_in.meta["dt_s"]
    # 1e-9 relative: the same backward-Euler column written in physical instead of per-unit terms (another order of
    # the same operations, ~1e-16 each, over ~1000 steps)
    for name in ("head_m", "speed_rpm", "flow_m3_s"):
        a, b = getattr(user, name), getattr(built_in, name)
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b)), name
    # the check can fail: the elastic model of the same plant is another trajectory
    lumped = run_simulation(load_plant(PLANT_HLA339, overrides | {"penstock.model": "lumped"}))
    assert np.max(np.abs(lumped.head_m - built_in.head_m)) > 1e-3 * np.max(built_in.head_m)


def test_an_unregistered_penstock_is_refused_with_the_registered_names(user_penstock):
    with pytest.raises(InputError, match=r"penstock.model must be one of moc, zdomain, lumped, rigid, user_rigid; "
                                         r"got 'user_rigd'"):
        load_plant(PLANT_HLA339, {"penstock.model": "user_rigd"})
    import simulate.config as config

    assert "user_rigid" in config.PENSTOCK_MODELS  # the module attribute is read at call time too


def test_the_command_line_offers_a_registered_penstock(user_penstock, capsys):
    """The registry drives the CLI's --penstock-model choices (identify, linearize --plant)."""
    from hillsim.cli import build_parser

    for command in ("identify", "linearize"):
        with pytest.raises(SystemExit):
            build_parser().parse_args([command, "--help"])
        assert "user_rigid" in capsys.readouterr().out, command
