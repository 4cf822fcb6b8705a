"""Every registered component declares its contract in its own module (:mod:`simulate.components.contract`): its
state arrays (``STATES``), its time scales (``time_scales`` or ``TIME_SCALES = ()``) and its linear counterpart
(``linear_counterpart`` or ``LINEAR_COUNTERPART = None``). Generated over the registries: each entry declares all
three; every shipped plant (data_synthetic/plant*.toml, the example's) and a variant for every component not in them
is built as the run builds it (the registries' builders, stopped before the loop is compiled), and each built part's
state arrays agree with its declared ``STATES`` (count, sizes by their shape rules); the failing cases beside: a
module that declares nothing, and ``STATES`` that omit an array or give a wrong size."""

import tomllib
import types
from pathlib import Path

import numpy as np
import pytest

from data_synthetic import PLANT_BULB, PLANT_HLA339
from simulate.components.contract import (ENTRIES, LEVELS_BY_NODE, SCALAR, UNDECLARED, StateArray, StatesOf,
                                          contract_of, state_mismatches)
from simulate.components.registry import (CONTROLS, DOWNSTREAM, FRICTION, GOVERNORS, PENSTOCKS, SERVOS, SHAFTS,
                                          UPSTREAM, Registry)
from simulate.config import apply_overrides, load_plant, plant_from_dict, read_plant_toml

REPO = Path(__file__).resolve().parents[3]
#: The registries of components with a compiled state (the turbine characteristics are the turbine's).
REGISTRIES = {r.kind: r for r in (PENSTOCKS, FRICTION, UPSTREAM, CONTROLS, DOWNSTREAM, GOVERNORS, SERVOS, SHAFTS)}
ENTRIES_ALL = [(kind, name) for kind, registry in REGISTRIES.items() for name in registry.names()]
SHIPPED = sorted((REPO / "data_synthetic").glob("plant*.toml"))
SHIPPED_SURGE_TANK = REPO / "data_synthetic" / "plant_hla339_surge_tank.toml"
PID = ("kp", "ki", "kd", "derivative_filter_s")
#: Variants of the reference plant that build the components the shipped plants leave out (ideal turbine: cheap).
RIGID = {"turbine.characteristics": "ideal", "penstock.model": "rigid", "solver.dt_s": 0.01}
VARIANTS = {
    "zdomain": ({"turbine.characteristics": "ideal", "penstock.model": "zdomain"}, ()),
    "lumped": ({"turbine.characteristics": "ideal", "penstock.model": "lumped"}, ()),
    "rigid": (RIGID, ()),
    "brunone": ({"turbine.characteristics": "ideal", "penstock.friction_model": "brunone"}, ()),
    "steady": ({"turbine.characteristics": "ideal", "penstock.friction_model": "steady"}, ()),
    "dgcm": ({"turbine.characteristics": "ideal", "penstock.column_separation": "dgcm"}, ()),
    "power": ({**RIGID, "governor.mode": "power"}, ()),
    "opening": ({**RIGID, "governor.mode": "opening"}, PID + ("permanent_droop",)),
    "dashpot": ({**RIGID, "governor.mode": "dashpot", "governor.transient_droop": 0.3, "governor.dashpot_time_s": 5.0,
                 "governor.pilot_servo_time_s": 0.05, "governor.gate_servo_time_s": 0.2}, PID),
    "discrete": ({**RIGID, "governor.servo_model": "discrete"}, ()),
    "dead-time": ({**RIGID, "governor.servo_model": "dead-time", "governor.servo_dead_time_s": 0.1}, ()),
    "backlash": ({**RIGID, "governor.servo_model": "backlash", "governor.servo_backlash": 0.01}, ()),
    "two-stage": ({**RIGID, "governor.servo_model": "two-stage", "governor.servo_break_stroke": 0.3,
                   "governor.servo_break_closing_time_s": 30.0}, ()),
    "rate-limit": ({**RIGID, "governor.servo_model": "rate-limit"}, ("servo_time_s",)),
    "prescribed": ({**RIGID, "scenario.kind": "closure-law", "scenario.closing_time_s": 12.0}, ()),
}
LEVEL = {**RIGID, "governor.mode": "level", "governor.level_kp": 1.0, "governor.level_ki": 0.2}
BULB_PRESCRIBED = {"scenario.kind": "closure-law", "scenario.closing_time_s": 12.0}


def _plant(path, overrides=None, drop=()):
    """The plant file with ``overrides`` and without the ``[governor]`` keys ``drop``."""
    if not drop:
        return load_plant(path, dict(overrides or {}))
    raw = tomllib.loads(read_plant_toml(path)[1].decode())
    apply_overrides(raw, dict(overrides or {}))
    for key in drop:
        raw["governor"].pop(key, None)
    return plant_from_dict(raw, base_dir=path.parent)


class _Built(Exception):
    """Raised in place of compiling the loop: every part is built by then."""


def built_parts(plant, monkeypatch) -> list:
    """``(kind, name, built object, builder arguments)`` of every component the run of ``plant`` builds, in order:
    the registries' builders wrapped, the run stopped where the loop would be assembled."""
    import simulate.loop.driver as driver
    from simulate.loop.engine import run_simulation

    found = []
    builder = Registry.builder

    def recording(registry, name):
        build = builder(registry, name)
        if registry.kind not in REGISTRIES:
            return build

        def wrapped(*args, **kwargs):
            out = build(*args, **kwargs)
            found.append((registry.kind, name, out, args))
            return out
        return wrapped

    def stop(*args, **kwargs):
        raise _Built

    with monkeypatch.context() as patch:
        patch.setattr(Registry, "builder", recording)
        patch.setattr(driver, "assemble", stop)
        with pytest.raises(_Built):
            run_simulation(plant)
    return found


def _contract(kind, name):
    return REGISTRIES[kind].contract(name)


def part_mismatches(plant, kind, name, built, args) -> list[str]:
    """How the built object's state differs from the STATES its component declares."""
    states = _contract(kind, name).state_arrays()
    where = f"{REGISTRIES[kind].key} = {name!r}"
    if kind == "servo":
        return state_mismatches(states, (built.state,), where=where, plant=plant, contract=_contract)
    if kind == "friction":
        arrays = built.arrays if isinstance(built.arrays, tuple) else (built.arrays,)
        grid = args[1]
        memory = arrays[len(arrays) - len(states):] if states else ()
        return state_mismatches(states, tuple(memory), where=where, plant=plant, contract=_contract,
                                n_nodes=sum(grid.reaches_per_segment) + 1)
    return state_mismatches(states, built.state, where=where, plant=plant, n_nodes=built.n_nodes or None,
                            n_controls=built.hooks.n_controls, contract=_contract)


# ---------------------------------------------------------------------------------------------------------------
# every entry declares its contract
# ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind, name", ENTRIES_ALL)
def test_every_registered_component_declares_states_time_scales_and_linear_counterpart(kind, name):
    contract = REGISTRIES[kind].contract(name)
    assert contract.missing() == ()
    states = contract.states
    assert isinstance(states, StatesOf) or (isinstance(states, tuple)
                                            and all(isinstance(s, StateArray) for s in states))
    assert contract.time_scales is None or callable(contract.time_scales)
    assert contract.linear_counterpart is None or callable(contract.linear_counterpart)


def test_a_module_that_declares_nothing_is_caught():
    """The failing case: a component module without the declarations; its time scales are asked for by the step
    planner, which refuses it (TypeError: the component's error), and the linear model refuses a component without
    a counterpart (InputError)."""
    from hillchart.errors import InputError

    bare = types.ModuleType("bare_component")
    contract = contract_of("penstock.model = 'bare'", bare, "build")
    assert contract.missing() == ("STATES", "time_scales (or TIME_SCALES = ())",
                                  "linear_counterpart (or LINEAR_COUNTERPART = None)")
    with pytest.raises(TypeError, match=r"penstock.model = 'bare': its module bare_component declares no "
                                        r"time_scales"):
        contract.scales(None, None)
    with pytest.raises(TypeError, match="declares no STATES"):
        contract.state_arrays()
    bare.TIME_SCALES, bare.LINEAR_COUNTERPART = (), None
    declared = contract_of("penstock.model = 'bare'", bare, "build")
    assert declared.scales(None, None) == [] and declared.linear_counterpart is None
    with pytest.raises(InputError, match="has no linear counterpart"):
        declared.linear(None, None)
    bare.TIME_SCALES = (1.0,)
    with pytest.raises(TypeError, match="TIME_SCALES of bare_component must be"):
        contract_of("penstock.model = 'bare'", bare, "build")


def test_a_registered_component_without_time_scales_is_refused_by_the_step_planner(register_penstock):
    """A user's penstock (one module, one registry line) that says nothing of its time scales: the run's step
    planner asks the registry and gets a TypeError naming the component and what to declare."""
    from simulate.components.schedules import GOVERNOR
    from simulate.loop.timestep import time_scales

    module = '''
def build(plant, steady, dt_s, upstream_head_m):
    raise AssertionError("not built")
'''
    name = register_penstock("silent", module)
    plant = _plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "penstock.model": name})
    with pytest.raises(TypeError, match=r"penstock.model = 'silent': its module silent_model declares no "
                                        r"time_scales \(or TIME_SCALES = \(\) for none\)"):
        time_scales(plant, types.SimpleNamespace(mode=GOVERNOR))  # the penstock is asked first


# ---------------------------------------------------------------------------------------------------------------
# the built parts agree with the declared STATES
# ---------------------------------------------------------------------------------------------------------------
#: What each case is there to build (beside what it builds anyway): together every registry entry.
COVERS = {
    "plant_hla339.toml": {("penstock", "moc"), ("friction", "convolution"), ("upstream", "reservoir"),
                          ("control", "governor"), ("governor", "speed"), ("servo", "first-order"), ("shaft", "swing"),
                          ("downstream", "tailwater")},
    "plant_hla339_grid.toml": {("shaft", "subtransient")},
    "plant_hla339_surge_tank.toml": {("upstream", "surge_tank")},
    "plant_bulb.toml": {("control", "governor_blades"), ("downstream", "draft_tube")},
    "hla339 zdomain": {("penstock", "zdomain")}, "hla339 lumped": {("penstock", "lumped")},
    "hla339 rigid": {("penstock", "rigid")}, "hla339 brunone": {("friction", "brunone")},
    "hla339 steady": {("friction", "steady")},
    "hla339 power": {("governor", "power")}, "hla339 opening": {("governor", "opening")},
    "hla339 dashpot": {("governor", "dashpot")}, "hla339 discrete": {("servo", "discrete")},
    "hla339 dead-time": {("servo", "dead-time")}, "hla339 backlash": {("servo", "backlash")},
    "hla339 two-stage": {("servo", "two-stage")}, "hla339 rate-limit": {("servo", "rate-limit")},
    "hla339 prescribed": {("control", "prescribed")}, "bulb prescribed": {("control", "prescribed_blades")},
    "surge tank level": {("governor", "level")},
}
CASES = ([(path.name, path, {}, ()) for path in SHIPPED]
         + [(f"hla339 {name}", PLANT_HLA339, overrides, drop) for name, (overrides, drop) in VARIANTS.items()]
         + [("bulb prescribed", PLANT_BULB, BULB_PRESCRIBED, ()),
            ("surge tank level", SHIPPED_SURGE_TANK, LEVEL, PID + ("permanent_droop",))])


@pytest.mark.parametrize("label, path, overrides, drop", CASES, ids=[c[0] for c in CASES])
def test_the_built_parts_hold_the_declared_states(label, path, overrides, drop, monkeypatch):
    plant = _plant(path, overrides, drop)
    parts = built_parts(plant, monkeypatch)
    built = {(kind, name) for kind, name, *_ in parts}
    assert built >= {("penstock", plant.penstock.model)} and COVERS.get(label, set()) <= built
    problems = [p for kind, name, part, args in parts for p in part_mismatches(plant, kind, name, part, args)]
    assert problems == []


def test_the_cases_build_every_registered_component():
    """The cases above are there for every registry entry (each case checks that it builds what it is there for):
    a component registered later needs a case."""
    assert sorted(set(ENTRIES_ALL) - set().union(*COVERS.values())) == []
    assert set(COVERS) <= {c[0] for c in CASES}


def test_the_example_builds_the_reference_plant():
    """examples/quickstart.py runs the reference plant (the shipped data_synthetic/plant_hla339.toml, a case above)
    and its rigid variant (the case 'rigid')."""
    text = (REPO / "examples" / "quickstart.py").read_text(encoding="utf-8")
    assert "load_plant(PLANT_HLA339)" in text and 'model="rigid"' in text


def test_states_that_omit_an_array_or_misstate_a_size_are_caught(monkeypatch):
    """The failing cases: the MOC penstock's STATES without its ``current`` index, with the heads as one row per node
    instead of two levels, and the surge tank's vector with an entry too few."""
    plant = _plant(PLANT_HLA339, {"turbine.characteristics": "ideal"})
    moc = next(built for kind, name, built, _ in built_parts(plant, monkeypatch) if kind == "penstock")
    declared = _contract("penstock", "moc").state_arrays()
    assert state_mismatches(declared, moc.state, where="moc", plant=plant, n_nodes=moc.n_nodes,
                            contract=_contract) == []
    short = state_mismatches(declared[:2], moc.state, where="moc", plant=plant, contract=_contract)
    assert short == ["moc: the state has 6 arrays, STATES declares 2 (heads, flows)"]
    per_node = (StateArray("heads", "m", "", "per node"),) + declared[1:]
    wrong = state_mismatches(per_node, moc.state, where="moc", plant=plant, n_nodes=moc.n_nodes, contract=_contract)
    assert wrong == [f"moc: state array 'heads' has shape (2, {moc.n_nodes}), its rule 'per node' asks (n,)"]
    other_grid = state_mismatches(declared, moc.state, where="moc", plant=plant, n_nodes=moc.n_nodes + 1,
                                  contract=_contract)
    assert len(other_grid) == 4 and "asks" in other_grid[0]  # heads, flows, inflows, track
    tank = (StateArray("tank", "m; m^3/s", "", ENTRIES, entries=("level_m", "tunnel_flow_m3_s")),)
    assert state_mismatches(tank, (np.zeros(3),), where="tank", plant=plant, contract=_contract) == [
        "tank: state array 'tank' has shape (3,), its rule 'entries' asks (2,)"]


def test_a_state_record_is_refused_with_a_shape_it_cannot_have():
    with pytest.raises(TypeError, match="shape must be one of"):
        StateArray("x", "m", "", "per reach")
    with pytest.raises(TypeError, match="entries go with the shape"):
        StateArray("x", "m", "", SCALAR, entries=("a",))
    with pytest.raises(TypeError, match="needs kind and component or chosen_by"):
        StateArray("x", "", "", "part", kind="servo")
    assert StateArray("x", "m", "", LEVELS_BY_NODE).shape == LEVELS_BY_NODE
    assert UNDECLARED == "undeclared"
