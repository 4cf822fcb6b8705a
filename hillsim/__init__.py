"""hillsim: Francis turbine hill chart -> BP nets -> nonlinear transient simulation -> linearization, identification.

The entry points a notebook needs, importable from here (each is imported on first use, so ``import hillsim`` is
fast and loads neither numpy, numba nor torch)::

    import hillsim
    chart = hillsim.load_chart("data_synthetic/francis")          # digitized chart folder -> ChartSamples
    extended = hillsim.extend_samples(chart)                      # torque from efficiency + boundary samples
    nets = hillsim.train_nets(extended, seed=0)                   # the two logsig nets (Levenberg-Marquardt)
    nets = hillsim.load_nets("data_synthetic/francis/nets.json")  # ... or the shipped ones
    plant = hillsim.load_plant("data_synthetic/plant_hla339.toml")
    result = hillsim.run_simulation(plant, characteristics=nets)  # SimulationResult: .summary(), .to_csv(), .plot()
    coeffs = hillsim.six_coefficients(nets, n11=67.8, opening=23.46)
    report = hillsim.compare_identification(plant)                # identification vs the nets' linear model
    series = hillsim.load_measured_series("series.csv", sample_time_s=0.2)
    report = hillsim.identify_measured(series, hillsim.ExperimentSettings(), plant=plant)
    summary = hillsim.run_demo("out/demo", fast=True)             # the whole pipeline, with report.html

The package itself is the command line (``hillsim --help``; one module per sub-command in :mod:`hillsim.commands`)
and the demo; :mod:`hillchart` and :mod:`simulate` never import it.
"""

from __future__ import annotations

from hillsim._stale import import_shadowed_packages

import_shadowed_packages()  # before hillchart: a folder an earlier installation left may shadow it

from hillchart.lazy import lazy_exports  # noqa: E402

__version__ = "0.1.0"

#: Public name -> module that defines it.
ENTRY_POINTS = {
    "load_chart": "hillchart.io.samples",
    "extend_samples": "hillchart.extension.extend",
    "train_nets": "hillchart.nets.training",
    "load_nets": "hillchart.nets.hill_nets",
    "six_coefficients": "hillchart.linearize",
    "load_plant": "simulate.config",
    "run_simulation": "simulate.loop.engine",
    "ExperimentSettings": "simulate.identification.experiment",
    "compare_identification": "simulate.identification.compare",
    "identify_measured": "simulate.identification.compare",
    "load_measured_series": "simulate.identification.measured",
    "run_demo": "hillsim.demo",
}

__all__ = ["__version__", *ENTRY_POINTS]


__getattr__, __dir__ = lazy_exports(__name__, ENTRY_POINTS)
