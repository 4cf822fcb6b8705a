"""The upstream end of the penstock when there is no surge tank: a reservoir at constant level.

Registry kind "upstream" (see :mod:`simulate.components.registry`); an upstream component offers

``head(p, s) -> H``                      piezometric head at the penstock inlet for this step, m above tailwater
``step(p, s, inlet_flow_m3_s, dt_s)``   advance with the penstock's inlet flow of this step
``level(p, s) -> z``                     (optional) the upstream water level, m above tailwater: the named signal
                                         ``upstream_level_m`` (:mod:`simulate.components.signals`)
"""

from __future__ import annotations

import numba
import numpy as np

from simulate.components.contract import SCALAR, LinearBlock, StateArray

#: None of its own (one unused value): the level is constant.
STATES = (StateArray("unused", "", "none: a constant level (one unused value)", SCALAR),)
#: None: a constant level has no dynamics.
TIME_SCALES = ()


@numba.njit(cache=True)
def reservoir_head(p, s):
    return p[0][0]


@numba.njit(cache=True)
def reservoir_level(p, s):
    """The reservoir's level, m above tailwater: the static head."""
    return p[0][0]


@numba.njit(cache=True)
def reservoir_step(p, s, inlet_flow_m3_s, dt_s):
    return None


def build_reservoir(plant, steady, dt_s: float):
    """Constant level ``penstock.static_head_m``."""
    from simulate.components.registry import CompiledPart

    return CompiledPart(kind="upstream", name="reservoir", functions={"head": reservoir_head, "step": reservoir_step,
                                                                    "level": reservoir_level},
                        params=(np.array([plant.penstock.static_head_m]),), state=(np.zeros(1),))


def reservoir_initial(plant, flow_m3_s: float) -> dict:
    """Steady values at the penstock inlet: head = static head (no upstream losses)."""
    return {"upstream_head_m": plant.penstock.static_head_m, "upstream_friction_s2_m5": 0.0}


def linear_counterpart(plant, steady) -> LinearBlock:
    """h_up = 0: the constant level the linear model of the plant assumes (paper 000's reservoir)."""
    return LinearBlock("h_up = 0 (a constant level)")
