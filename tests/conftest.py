"""Shared, session-scoped fixtures: expensive objects built once for the whole test run.

Each fixture returns an object the tests must not modify (frozen dataclasses, or read-only folders by convention).
"""

import importlib.util
import os

os.environ.setdefault("MPLBACKEND", "Agg")

# torch is a test dependency of two checks only; without it, --doctest-modules must not import the torch transcription
# (its users skip through the torch_autograd fixture)
collect_ignore = [] if importlib.util.find_spec("torch") else ["torch_reference.py"]

import pytest  # noqa: E402

#: Session fixtures expensive enough that their users should share one pytest-xdist worker (built once).
SHARED_SESSION_FIXTURES = ("demo_fast_run", "torch_autograd")


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the xdist_group marks
def pytest_collection_modifyitems(config, items):
    """Group the tests for ``--dist loadgroup`` (pyproject's addopts): by file, so a module-scoped fixture is built
    once, except that every user of a :data:`SHARED_SESSION_FIXTURES` fixture joins that fixture's group."""
    for item in items:
        shared = [name for name in SHARED_SESSION_FIXTURES if name in getattr(item, "fixturenames", ())]
        item.add_marker(pytest.mark.xdist_group(shared[0] if shared else item.nodeid.split("::")[0]))


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    """Tell the external-data helpers which test is being set up (they check its ``external`` marker)."""
    import tests.external_charts

    tests.external_charts.CURRENT_TEST = item


@pytest.fixture(scope="session")
def shipped_nets():
    """The shipped ``data_synthetic/francis/nets.json``, loaded once."""
    from data_synthetic import FRANCIS_DIR
    from hillchart.nets.hill_nets import load_nets

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
    from simulate.loop.engine import run_simulation

    return run_simulation(example_plant, characteristics=shipped_nets)


@pytest.fixture(scope="session")
def demo_fast_run(tmp_path_factory):
    """``hillsim demo --fast --quiet`` run once: (output folder, stdout, stderr). Tests only read the folder."""
    import contextlib
    import io

    from hillsim.cli import main

    out = tmp_path_factory.mktemp("demo") / "demo"
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        code = main(["demo", "--fast", "--quiet", "--out", str(out)])
    assert code == 0, stderr.getvalue()
    return out, stdout.getvalue(), stderr.getvalue()


@pytest.fixture(scope="session")
def demo_fast_dir(demo_fast_run):
    """The folder of :func:`demo_fast_run`."""
    return demo_fast_run[0]


@pytest.fixture(scope="session")
def torch_autograd():
    """``(torch, torch_forward)`` for the autograd checks of the compiled LM Jacobian. torch (a test dependency, about
    1.5 s to import) is imported here rather than at module level, so only the worker running these tests pays it."""
    import torch

    from tests.torch_reference import torch_forward

    return torch, torch_forward


@pytest.fixture
def register_penstock(tmp_path, monkeypatch):
    """``register_penstock(name, module_text)``: a penstock model written as a module in ``tmp_path`` and registered
    under ``name`` (builder ``build``) as a user would, after ``simulate.config`` is imported; both undone after."""
    import sys

    import simulate.config  # noqa: F401  (imported before the component is registered: the order that must work)
    from simulate.components.registry import PENSTOCKS

    modules = []

    def register(name: str, text: str, traits=None) -> str:
        module = f"{name}_model"
        (tmp_path / f"{module}.py").write_text(text, encoding="utf-8")
        monkeypatch.syspath_prepend(str(tmp_path))
        monkeypatch.setitem(PENSTOCKS._entries, name, f"{module}:build")
        # what the code asks of the model (its registry line's traits); the test columns are rigid ones
        monkeypatch.setitem(PENSTOCKS._traits, name, traits or PENSTOCKS.traits("rigid"))
        modules.append(module)
        return name

    yield register
    for module in modules:
        sys.modules.pop(module, None)
