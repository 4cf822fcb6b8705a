"""simulate: a hydropower plant (reservoir, penstock, turbine, governor, rotor) driven by hill-chart
characteristics, and the linear models and identification that are compared with them.

The subpackages follow the roles of the code: :mod:`simulate.components` (plant components: hydraulic, turbine,
control, shaft, electrical), :mod:`simulate.loop` (registries, the generated time loop, steady state, guards),
:mod:`simulate.scenarios`, :mod:`simulate.results`, :mod:`simulate.linear`, :mod:`simulate.identification` and
:mod:`simulate.studies` (batches, sweeps, closure optimization). The names most scripts need are importable from here
(each on first use, so ``import simulate`` stays cheap)::

    from simulate import load_plant, run_simulation
    result = run_simulation(load_plant("data_synthetic/plant_hla339.toml"))

``simulate`` imports :mod:`hillchart`; never the reverse.
"""

from __future__ import annotations

from hillchart.lazy import lazy_exports

#: Public name -> module that defines it.
PUBLIC = {
    "load_plant": "simulate.config",
    "PlantConfig": "simulate.config",
    "run_simulation": "simulate.loop.engine",
    "initial_state": "simulate.loop.engine",
    "SimulationResult": "simulate.results.result",
    "run_batch": "simulate.studies.batch",
    "LinearPlant": "simulate.linear.models",
    "ExperimentSettings": "simulate.identification.experiment",
    "compare_identification": "simulate.identification.compare",
    "identify_measured": "simulate.identification.compare",
    "load_measured_series": "simulate.identification.measured",
}

__all__ = list(PUBLIC)


__getattr__, __dir__ = lazy_exports(__name__, PUBLIC)
