"""Wall friction in the method of characteristics: the one implementation of the friction head loss of a reach, and
its models (registry kind "friction", key ``penstock.friction_model``: :data:`simulate.components.registry.FRICTION`).

Along the characteristics of reach r (nodes r and r+1, length dx = a dt) the compatibility equations of the MOC
(Wylie and Streeter, *Fluid Transients in Systems*, eqs. (3-18), (3-19)) are written with the friction head loss
Delta h_f of the reach, taken explicitly at the foot of the characteristic (node j = r for C+, j = r+1 for C-)::

    C+:  H_P = C_P - B Q_P,   C_P = H_r + B Q_r - Delta h_f(r, r)
    C-:  H_P = C_M + B Q_P,   C_M = H_{r+1} - B Q_{r+1} + Delta h_f(r, r+1)

Delta h_f = a dt J is the head lost to friction over the reach (J the friction slope, head per length, signed with
the flow). A friction model is two module-level numba functions, which the MOC penstock
(:mod:`simulate.components.hydraulic.penstock`) calls by these names (a model other than the default is bound in
their place, :func:`with_friction`):

``reach_friction_loss(friction, flows, reach, node) -> Delta h_f``   (m; ``flows`` the node flows of the current
                                                                     level, m^3/s)
``reach_friction_advance(friction, flows, new_flows)``               after each MOC step (its memory, if any)

``friction`` is the model's arrays: its parameters and, for a model with memory, its state (a tuple, or one array).
The default, ``steady``, is the quasi-steady Darcy-Weisbach loss Delta h_f = R Q|Q| with R = f dx / (2 g D A^2)
(:func:`simulate.components.hydraulic.penstock.build_moc_grid`), ``friction`` the array R per reach.

A friction model's builder ``build(penstock, grid, flow_m3_s) -> CompiledFriction`` (``penstock`` the
:class:`simulate.components.hydraulic.conduit.PenstockConfig`, ``grid`` its
:class:`simulate.components.hydraulic.penstock.MocGrid`, ``flow_m3_s`` the steady flow); its module may name its
``[penstock]`` keys in ``PENSTOCK_KEYS`` (refused under another friction model). A plant with ``[[units]]`` runs the
model in every pipe: the common conduit and each branch are MOC penstocks, and a branch's C- line at the manifold
(:func:`simulate.components.hydraulic.penstock.moc_inlet_relation`) is bound like the other lines.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numba

from simulate.components.registry import Bound

#: The steady loss has no memory; its time scales are the MOC grid's, on which it is exact; its linearization is the
#: penstock's friction slope r_f = 2 K Q0^2 / H0 (the penstock's linear block), not a block of its own.
STATES: tuple = ()
TIME_SCALES = ()
LINEAR_COUNTERPART = None
#: The names by which the MOC functions call the friction model.
SEAM = ("reach_friction_loss", "reach_friction_advance")


#: Kinematic viscosity of water at 20 C, m^2/s: the unsteady models' default.
WATER_VISCOSITY_M2_S = 1.0e-6


def segment_reynolds(penstock, flow_m3_s: float, viscosity_m2_s: float | None) -> list[float]:
    """The steady Reynolds number |Q| D / (A nu) of every segment of ``penstock`` (``nu`` the given viscosity, or
    :data:`WATER_VISCOSITY_M2_S` when None).

    >>> from types import SimpleNamespace
    >>> seg = SimpleNamespace(diameter_m=0.5, area_m2=0.25)
    >>> [round(re) for re in segment_reynolds(SimpleNamespace(segments=(seg,)), -0.1, None)]
    [200000]
    """
    nu = WATER_VISCOSITY_M2_S if viscosity_m2_s is None else viscosity_m2_s
    return [abs(flow_m3_s) * s.diameter_m / (s.area_m2 * nu) for s in penstock.segments]


@numba.njit(cache=True)
def steady_reach_loss(friction, flows, reach, node):
    """Delta h_f = R Q|Q| (m) of reach ``reach`` at the flow of node ``node`` (the foot of the characteristic),
    R = ``friction[reach]`` = f dx / (2 g D A^2) (s^2/m^5): the Darcy-Weisbach loss over dx = a dt
    (Wylie and Streeter, eq. (3-18))."""
    q = flows[node]
    return friction[reach] * q * abs(q)


@numba.njit(cache=True)
def steady_advance(friction, flows, new_flows):
    """The steady loss has no memory."""
    return


@dataclass(frozen=True)
class CompiledFriction:
    """A friction model compiled for one MOC grid: its two functions (``loss``: ``reach_friction_loss``, ``advance``:
    ``reach_friction_advance``), its arrays (the ``friction`` argument of both) and figures for the run's summary."""

    name: str
    loss: Callable
    advance: Callable
    arrays: Any
    summary: dict = field(default_factory=dict)

    def bind(self, func: Callable) -> Callable:
        """``func`` (a MOC function) calling this model (:func:`with_friction`)."""
        return with_friction(func, {"reach_friction_loss": self.loss, "reach_friction_advance": self.advance})


def build_steady_friction(penstock, grid, flow_m3_s: float) -> CompiledFriction:
    """The quasi-steady Darcy-Weisbach loss R Q|Q| per reach (the default model)."""
    return CompiledFriction("steady", steady_reach_loss, steady_advance, grid.friction_s2_m5)


def with_friction(func: Callable, functions: dict[str, Callable]) -> Callable:
    """``func`` with its calls of the friction seam (:data:`SEAM`, the names in ``functions``) going to
    ``functions``, through every function of its own module that it calls and that reaches the seam: a
    :class:`simulate.components.registry.Bound` (nested), or ``func`` itself where every name already refers to
    the given function (the default model: the loop's text is then the same as without a friction model). Compiled
    or not (``NUMBA_DISABLE_JIT``)."""
    names = []
    py_func = getattr(func, "py_func", func)
    for name in py_func.__code__.co_names:
        target = py_func.__globals__.get(name)
        if name in functions:
            if target is not functions[name]:
                names.append((name, functions[name]))
        elif _same_module_function(target, func) and _reaches_seam(target, {func}):
            bound = with_friction(target, functions)
            if bound is not target:
                names.append((name, bound))
    return Bound(func, tuple(names)) if names else func


def _same_module_function(target, func) -> bool:
    return callable(target) and hasattr(getattr(target, "py_func", target), "__code__") \
        and getattr(target, "__module__", None) == func.__module__


def _reaches_seam(func, seen: set) -> bool:
    """Whether ``func`` calls the friction seam, itself or through functions of its module that it calls."""
    py_func = getattr(func, "py_func", func)
    for name in py_func.__code__.co_names:
        if name in SEAM:
            return True
        target = py_func.__globals__.get(name)
        if _same_module_function(target, func) and target not in seen and _reaches_seam(target, seen | {func}):
            return True
    return False


__all__ = ["SEAM", "WATER_VISCOSITY_M2_S", "segment_reynolds", "CompiledFriction", "steady_reach_loss",
           "steady_advance", "build_steady_friction", "with_friction"]
