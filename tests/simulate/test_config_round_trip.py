"""A key declared in a component's section is read, written, overridden and passed on without a change in the reader
(simulate.config): the writer (``to_dict``, ``plant_toml``) and the override paths work from the declarations. The
failing cases beside: a writer that lists the keys by hand, and the hand rebuild of a branch's penstock that the
reader had, drop the new key."""

import dataclasses
import tomllib

import pytest

import simulate.config as config
from data_synthetic import PLANT_HLA339, PLANT_TWO_UNITS
from simulate.components.parameters import parameter
from simulate.components.solver import SolverConfig

#: The keys [solver] had before the new one, as a hand-written writer would list them.
HAND_WRITTEN_SOLVER_KEYS = ("dt_s", "pressure_loop", "tolerance", "max_iterations", "relaxation", "output_dt_s",
                            "max_node_steps", "max_output_mb", "fallback", "substeps")


def _with_new_key(monkeypatch, section, base):
    """``base`` with a new declared key ``new_key_s`` (default 2.0), registered as the class of ``section``."""
    extended = dataclasses.make_dataclass(
        base.__name__, [("new_key_s", float, parameter(2.0, unit="s", low=0.0, high=10.0, description="a new key"))],
        bases=(base,), frozen=True)
    monkeypatch.setitem(config.SECTIONS, section, extended)
    return extended


def test_a_new_solver_key_round_trips_through_write_read_and_overrides(monkeypatch):
    _with_new_key(monkeypatch, "solver", SolverConfig)
    raw = tomllib.loads(PLANT_HLA339.read_text(encoding="utf-8"))
    raw["solver"]["new_key_s"] = 3.0
    plant = config.plant_from_dict(raw, base_dir=PLANT_HLA339.parent)
    assert plant.solver.new_key_s == 3.0
    written = config.to_dict(plant)
    assert written["solver"]["new_key_s"] == 3.0
    assert config.plant_from_dict(written, base_dir=plant.base_dir) == plant
    from simulate.studies.cases import plant_toml

    assert config.plant_from_dict(tomllib.loads(plant_toml(plant)), base_dir=plant.base_dir).solver.new_key_s == 3.0
    # both override paths: in place (a scalar) and through the file (with a list beside it)
    assert plant.with_overrides({"solver.new_key_s": 4.0}).solver.new_key_s == 4.0
    segments = [dataclasses.asdict(s) for s in plant.penstock.segments]
    through_file = plant.with_overrides({"solver.new_key_s": 5.0, "penstock.segments": segments})
    assert through_file.solver.new_key_s == 5.0 and through_file.penstock == plant.penstock
    assert plant.with_overrides({"penstock.segments": segments}).solver.new_key_s == 3.0  # kept, not reset
    with pytest.raises(config.InputError, match=r"solver\.new_key_s must be in \[0\.0, 10\.0\], got 11\.0"):
        plant.with_overrides({"solver.new_key_s": 11.0})
    # the failing case: a writer that lists [solver]'s keys by hand writes the plant without it, and the plant
    # read back has the default (2.0), not the plant's 3.0
    hand = dict(written, solver={k: v for k, v in written["solver"].items() if k in HAND_WRITTEN_SOLVER_KEYS})
    assert config.plant_from_dict(hand, base_dir=plant.base_dir).solver.new_key_s == 2.0


def test_a_new_penstock_key_reaches_each_units_branch(monkeypatch):
    from simulate.components.hydraulic.conduit import PenstockConfig

    _with_new_key(monkeypatch, "penstock", PenstockConfig)
    raw = tomllib.loads(PLANT_TWO_UNITS.read_text(encoding="utf-8"))
    raw["penstock"]["new_key_s"] = 3.0
    plant = config.plant_from_dict(raw, base_dir=PLANT_TWO_UNITS.parent)
    branch = plant.units[0].branch_penstock(plant.penstock)
    assert branch.new_key_s == 3.0 and branch.segments == plant.units[0].branch
    assert plant.unit_plant(plant.units[1]).penstock.new_key_s == 3.0
    assert config.plant_from_dict(config.to_dict(plant), base_dir=plant.base_dir) == plant
    # the failing case: the hand rebuild the reader had (model, static head, reaches and segments) drops it
    hand = type(plant.penstock)(model="moc", static_head_m=plant.penstock.static_head_m,
                                reaches=plant.penstock.reaches, segments=plant.units[0].branch)
    assert hand.new_key_s == 2.0
