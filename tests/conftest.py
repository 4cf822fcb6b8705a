"""Shared, session-scoped fixtures: expensive objects built once for the whole test run.

Each fixture returns an object the tests must not modify (frozen dataclasses, or read-only folders by convention).
"""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import pytest  # noqa: E402


@pytest.fixture(scope="session")
def shipped_nets():
    """The shipped ``data_synthetic/francis/nets.json``, loaded once."""
    from data_synthetic import FRANCIS_DIR
    from hillchart.nets import load_nets

    return load_nets(FRANCIS_DIR / "nets.json")


@pytest.fixture(scope="session")
def example_plant():
    """The shipped example plant (``data_synthetic/plant_hla339.toml``), loaded once (a frozen PlantConfig)."""
    from data_synthetic import PLANT_HLA339
    from simulate.config import load_plant

    return load_plant(PLANT_HLA339)


@pytest.fixture(scope="session")
def shipped_rejection(example_plant, shipped_nets):
    """The example plant's scenario (100 % load rejection, MOC, governor) on the shipped nets: a SimulationResult."""
    from simulate.engine import run_simulation

    return run_simulation(example_plant, characteristics=shipped_nets)
