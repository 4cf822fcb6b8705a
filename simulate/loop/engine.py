"""Run a plant: the public entry :func:`run_simulation` (the driver, :mod:`simulate.loop.driver`, for a plant of one
unit or of several; the loop, :mod:`simulate.loop.generator`, assembled from compiled components, see
:mod:`simulate.components.registry`).

Per step k -> k+1 (t = k dt), for every unit (the steps in full: :mod:`simulate.loop.generator`):

1. control: the control vector at t_{k+1} from the named signals at t_k (:mod:`simulate.components.signals`: the
   governor's law + servo, or a prescribed law; with the runner blades of a double-regulated unit);
2. shaft: the speed at t_{k+1} from the turbine torque and the load at t_k (explicit Euler);
3. penstock (or branch): the linear relation H = C_L + k Q at the turbine, with the upstream (or manifold) head of
   this step, and the downstream part's H_out = C_M + B_M Q at the runner outlet;
4. turbine boundary: (H, Q) at n_{k+1} and the controls by the boundary the characteristics' kind chose (the
   chosen pressure loop for the shipped kinds); turbine torque M11 D1^3 H;
5. penstock, downstream and upstream (reservoir or surge tank) updates; the head envelope at every computing node.

The loop runs in chunks of about :data:`CHUNK_WALL_S` of work, so Ctrl-C is honoured between chunks (the compiled
code cannot be interrupted). With characteristics that offer no numba kernel, or ``jit=False``, the same generated
source runs as plain Python.
"""

from __future__ import annotations

from simulate.config import PlantConfig
from simulate.loop.driver import run_plant
from simulate.results.result import SimulationResult

from simulate.loop.common import (  # noqa: F401  (the loop's shared settings, re-exported here)
    CHUNK_WALL_S, CLOSED_STROKE, FAILURE_ADVICE, HEAD_FLOOR_FRACTION, SEPARATION_ADVICE, SEPARATION_FRACTION,
    _failure_advice, run_in_chunks, step_count, upstream_friction_s2_m5)
from simulate.loop.prepare import (  # noqa: F401  (what a run prepares, re-exported for its callers)
    MEMO_ENTRIES, _MEMO, _memo, build_parts, downstream_friction_s2_m5, initial_state, plant_characteristics,
    plant_schedules)


def run_simulation(plant: PlantConfig, characteristics=None, *, jit: bool = True,
                   raise_on_failure: bool = True, progress=None) -> SimulationResult:
    """Simulate ``plant`` (its scenario) and return the :class:`SimulationResult`.

    Parameters
    ----------
    plant : PlantConfig
    characteristics : object implementing :class:`hillchart.characteristics.Characteristics`, optional
        Overrides ``plant.turbine.characteristics`` (any object with q11, m11 and their gradients).
    jit : bool
        Run the compiled loop when the characteristics offer a numba kernel; False runs the same source as
        plain Python (slow; for checks).
    raise_on_failure : bool
        A pressure-loop failure raises :class:`NumericalError` (default) or, when False, returns the series up to
        the failure with ``success=False``.
    progress : callable, optional
        Called as ``progress(step, n_steps)`` between chunks of the loop.

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> from hillchart.characteristics import IdealTurbine
    >>> import importlib.resources as ir
    >>> plant = load_plant(ir.files("data_synthetic") / "plant_hla339.toml",
    ...                    {"turbine.characteristics": "ideal", "scenario.t_end_s": 5.0})
    >>> result = run_simulation(plant)
    >>> result.success, round(result.summary()["max_speed_rise"], 2) > 0
    (True, True)
    """
    return run_plant(plant, characteristics, jit=jit, raise_on_failure=raise_on_failure, progress=progress)
