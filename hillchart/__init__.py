"""hillchart: from a digitized Francis hill chart to fast, differentiable Q11/M11 characteristics.

Data flows one way::

    chart folder -> hillchart.io (read, validate) -> hillchart.extension (torque, boundaries)
                 -> hillchart.nets (train, evaluate) -> hillchart.linearize (six coefficients)

:mod:`hillchart.fccm` characterises double-regulated (bulb, Kaplan) turbines from test tables;
:mod:`hillchart.synthetic` holds the physically based synthetic turbines. The names most scripts need are importable
from here (each on first use)::

    from hillchart import extend_samples, load_chart, train_nets
    nets = train_nets(extend_samples(load_chart("data_synthetic/francis")), seed=0)

``hillchart`` never imports ``simulate``.
"""

from __future__ import annotations

from hillchart.cache import configure_numba_cache
from hillchart.lazy import lazy_exports

__version__ = "0.1.0"

# before any module of hillchart or simulate imports numba: compiled code is cached in the user's cache folder,
# never beside the installed package (hillchart.cache says why)
configure_numba_cache(__version__)

#: Public name -> module that defines it.
PUBLIC = {
    "load_chart": "hillchart.io.samples",
    "extend_samples": "hillchart.extension.extend",
    "train_nets": "hillchart.nets.training",
    "load_nets": "hillchart.nets.hill_nets",
    "HillNets": "hillchart.nets.hill_nets",
    "six_coefficients": "hillchart.linearize",
    "SyntheticFrancis": "hillchart.synthetic.francis",
    "write_synthetic_chart": "hillchart.synthetic.francis",
    "SyntheticBulb": "hillchart.synthetic.bulb",
}

__all__ = ["__version__", *PUBLIC]


__getattr__, __dir__ = lazy_exports(__name__, PUBLIC)
