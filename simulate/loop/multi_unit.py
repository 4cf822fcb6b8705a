"""The run of a plant with several units (``[[units]]``) on a common conduit that branches at a manifold.

The driver (:mod:`simulate.loop.driver`) runs a plant of one unit or of several with the same pre-run and post-run
work and the one loop template (:mod:`simulate.loop.generator`); :func:`run_units` is its name for a plant with
``[[units]]``, and the preparation of the units (their characteristics, the steady state of all units on the shared
conduit, their schedules) lives in :mod:`simulate.loop.prepare`.
"""

from __future__ import annotations

from simulate.config import PlantConfig
from simulate.loop.driver import run_plant
from simulate.loop.prepare import unit_characteristics, unit_schedules, units_initial_state  # noqa: F401
from simulate.results.result import SimulationResult


def run_units(plant: PlantConfig, characteristics=None, *, jit: bool = True, raise_on_failure: bool = True,
              progress=None) -> SimulationResult:
    """Simulate a plant with several units (its scenario); the arguments are those of
    :func:`simulate.loop.engine.run_simulation`.

    The result's plant-level series (``speed_rpm``, ``head_m``, ...) are those of the first unit the event applies
    to; ``result.units`` holds every unit's, ``signals`` the manifold head and the common flow and each unit's
    components' columns (``U1.blade_angle_deg``, ``U1.outlet_pressure_head_m``), and the summary the worst figures
    over the units (see :func:`simulate.results.result.worst_over_units`) and ``"units"``.
    """
    return run_plant(plant, characteristics, jit=jit, raise_on_failure=raise_on_failure, progress=progress)
