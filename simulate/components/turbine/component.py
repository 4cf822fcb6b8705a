"""The turbine as a component: the plant's turbine section and the characteristics it owns.

The characteristics are loaded by their kind (:mod:`simulate.components.turbine.kinds`) once per plant: every
function that takes a plant and an optional characteristics object asks :func:`characteristics_of`, which returns
the caller's object when one is given (an ensemble member, a user's own turbine: it overrides the plant's; the
registered kind that adopts it gives its form and its boundary, :func:`simulate.components.turbine.kinds.
adopt_characteristics`) and otherwise the plant's own, loaded at the first call and kept for that plant object
while its nets.json is unchanged (a run reads the file once, and a steady state, a run and a step check of one
plant read it once together).

The component also builds each unit's turbine boundary, the part of kind ``"turbine"`` the loop calls by role
(:func:`build_turbine_part`), with the builder the characteristics' kind names
(:attr:`simulate.components.turbine.kinds.CharacteristicKind.boundary`).
"""

from __future__ import annotations

import importlib
import inspect
import threading
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from simulate.components.registry import Bound, CompiledPart, LoopTemplate
from simulate.components.turbine.kinds import (CharacteristicKind, adopt_characteristics, file_stamp, kind_of,
                                              load_kind)


@dataclass(frozen=True)
class Turbine:
    """A turbine section with its characteristics.

    Attributes
    ----------
    config : simulate.config.TurbineConfig
        The plant's turbine section.
    characteristics : object
        Its characteristics (q11, m11 and their gradients), as the kind loaded them (stepped up with
        ``turbine.step_up``) or as the caller gave them.
    kind : str or None
        The registry entry that loaded them (:data:`simulate.components.registry.CHARACTERISTICS`) or adopted the
        caller's object (:func:`~simulate.components.turbine.kinds.adopt_characteristics`); None for a caller's
        object no kind adopts.
    path : Path or None
        The nets.json they were read from (None for a registry word or the caller's object).
    stamp : tuple or None
        That file's :func:`~simulate.components.turbine.kinds.file_stamp` when it was read.
    """

    config: Any
    characteristics: Any
    kind: str | None = None
    path: Path | None = None
    stamp: tuple | None = None

    def is_current(self) -> bool:
        """False when the nets.json the characteristics came from has changed (or gone) since it was read."""
        if self.path is None:
            return True
        try:
            return file_stamp(self.path) == self.stamp
        except OSError:
            return False


def load_turbine(turbine, base_dir: Path | str = ".") -> Turbine:
    """The :class:`Turbine` of the section ``turbine`` (a :class:`simulate.config.TurbineConfig`), its
    characteristics loaded by their kind (a nets.json read once)."""
    kind, characteristics, path, stamp = load_kind(turbine.characteristics, turbine=turbine, base_dir=base_dir)
    return Turbine(turbine, characteristics, kind, path, stamp)


def load_characteristics(turbine, base_dir: Path | str = "."):
    """The characteristics object named by ``turbine.characteristics``.

    One resolver for every command (:func:`simulate.components.turbine.kinds.resolve_characteristics`): ``"ideal"``
    gives :class:`hillchart.characteristics.IdealTurbine` from the rated values: q11_max = Q_r / (D1^2 sqrt(H_r)) at
    full stroke (opening_max), efficiency P_r / (rho g Q_r H_r). ``"synthetic"`` the exact synthetic Francis
    turbine, ``"synthetic-bulb"`` the exact synthetic bulb; anything else is a nets.json path (relative to
    ``base_dir``) read by the registered kind that owns its content (two- or three-input nets). With
    ``turbine.step_up`` the model chart is converted to the prototype here
    (:func:`simulate.components.turbine.step_up.apply_step_up`), so every command runs on the same stepped-up
    characteristics.

    Examples
    --------
    >>> from simulate.config import TurbineConfig
    >>> t = TurbineConfig(rated_head_m=100.0, rated_flow_m3_s=10.0, rated_speed_rpm=300.0, rated_power_mw=9.0,
    ...                   runner_diameter_m=2.0, opening_max=1.0, characteristics="ideal")
    >>> ideal = load_characteristics(t)
    >>> round(ideal.q11_max_m3_s, 6), round(ideal.efficiency, 6)
    (0.25, 0.917431)
    """
    return load_turbine(turbine, base_dir).characteristics


#: The turbine of each plant object (by ``id``, with a weak reference that removes the entry with the plant).
_OWN: dict[int, tuple] = {}
_OWN_LOCK = threading.Lock()


def plant_turbine(plant, characteristics=None) -> Turbine:
    """The :class:`Turbine` of ``plant``: with ``characteristics`` given, that object (it overrides the plant's) in
    the form and with the kind of the registered kind that adopts it (:func:`~simulate.components.turbine.kinds.
    adopt_characteristics`); else the plant's own, loaded once per plant object (again only when its nets.json has
    changed)."""
    if characteristics is not None:
        kind, adopted = adopt_characteristics(characteristics)
        return Turbine(plant.turbine, adopted, kind)
    key = id(plant)
    with _OWN_LOCK:
        found = _OWN.get(key)
    if found is not None and found[0]() is plant and found[1].is_current():
        return found[1]
    turbine = load_turbine(plant.turbine, plant.base_dir)
    try:
        ref = weakref.ref(plant, lambda _, key=key: _OWN.pop(key, None))
    except TypeError:  # a plant that cannot be weakly referenced: nothing remembered
        return turbine
    with _OWN_LOCK:
        _OWN[key] = (ref, turbine)
    return turbine


def characteristics_of(plant, characteristics=None):
    """The characteristics a run of ``plant`` uses: ``characteristics`` when given, else the plant's own
    (:func:`plant_turbine`)."""
    return plant_turbine(plant, characteristics).characteristics


#: A turbine boundary's functions by role and the arguments the loop passes them, in order (k: m per m^3/s).
BOUNDARY_ROLES = {"step": ("p", "s", "c_l_m", "k", "speed_rpm", "controls", "diag"), "signals": ("p", "s")}


@dataclass(frozen=True)
class BoundaryInputs:
    """What a turbine boundary's builder (:attr:`simulate.components.turbine.kinds.CharacteristicKind.boundary`) is
    given for one unit.

    Attributes
    ----------
    turbine : simulate.config.TurbineConfig
        The unit's turbine section (rated values, runner diameter D1 m, ``opening_max``).
    solver : simulate.config.SolverConfig
        The plant's solver section (the pressure loop, its tolerance, iterations, relaxation, fallback).
    characteristics : object
        The characteristics as the unit uses them.
    compiled : simulate.components.turbine.evaluation.CompiledCharacteristics
        Their compiled form (``compiled.params``: the kernels' parameters).
    steady : simulate.loop.steady.SteadyState
        The unit's verified steady state (head m, flow m^3/s, torque N*m, stroke at t = 0).
    n_controls : int
        The length of the unit's control vector (1: the guide vanes; 2 with the runner blades).
    head_floor_m : float
        The lowest head the boundary may accept, m.
    closed_stroke : float
        The stroke (fraction) at or below which the guide vanes are shut.
    """

    turbine: Any
    solver: Any
    characteristics: Any
    compiled: Any
    steady: Any
    n_controls: int
    head_floor_m: float
    closed_stroke: float


def _boundary_builder(kind: str | None):
    """The boundary builder of the registered kind ``kind`` (the pressure loop for a caller's object no kind adopts,
    ``kind=None``)."""
    target = CharacteristicKind.boundary if kind is None else kind_of(kind).boundary
    module, _, name = str(target).partition(":")
    builder = getattr(importlib.import_module(module), name, None) if name else None
    if not callable(builder):
        raise TypeError(f"turbine.characteristics kind {kind!r}: its boundary {target!r} names no function; give "
                        f"\"module:function\" of a builder build(inputs) -> CompiledPart")
    return builder


def check_boundary(part, who: str) -> None:
    """Refuse, before anything is compiled, a turbine boundary ``part`` that is not a :class:`CompiledPart` of kind
    ``"turbine"`` or whose functions do not take the loop's arguments (:data:`BOUNDARY_ROLES`); ``who`` names it in
    the message."""
    if not isinstance(part, CompiledPart) or part.kind != "turbine":
        got = f"a part of kind {part.kind!r}" if isinstance(part, CompiledPart) else type(part).__name__
        raise TypeError(f"{who}: its boundary builder must return a CompiledPart of kind 'turbine', got {got}")
    for role, arguments in BOUNDARY_ROLES.items():
        wanted = f"{role}({', '.join(arguments)})"
        func = part.functions.get(role)
        if func is None:
            raise TypeError(f"{who}: its boundary {part.name!r} has no {role!r} function; the loop calls {wanted}")
        plain = func.func if isinstance(func, (Bound, LoopTemplate)) else func
        plain = getattr(plain, "py_func", plain)
        try:
            parameters = list(inspect.signature(plain).parameters.values())
        except (TypeError, ValueError):
            raise TypeError(f"{who}: its boundary {part.name!r} {role!r} function {plain!r} is not a Python "
                            f"function; the loop calls {wanted}") from None
        positional = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
        if len(parameters) != len(arguments) or any(p.kind not in positional for p in parameters):
            name = f"{getattr(plain, '__module__', '?')}.{getattr(plain, '__qualname__', plain)}"
            raise TypeError(f"{who}: its boundary {part.name!r} {role!r} function {name}"
                            f"({', '.join(str(p) for p in parameters)}) takes {len(parameters)} parameter(s); the "
                            f"loop calls {wanted}")


def build_turbine_part(kind: str | None, inputs: BoundaryInputs) -> CompiledPart:
    """A unit's turbine boundary, the part of kind ``"turbine"`` the loop calls by role (``step``, ``signals``),
    built by the boundary the characteristics' kind ``kind`` names (the registry word; None for a caller's object no
    kind adopts: the pressure loop) and checked (:func:`check_boundary`)."""
    part = _boundary_builder(kind)(inputs)
    check_boundary(part, "the caller's characteristics" if kind is None else f"turbine.characteristics kind {kind!r}")
    return part
