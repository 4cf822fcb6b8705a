"""What a registered component declares of itself besides its parameters, as data in its own module: the arrays of
its compiled state (``STATES``), its time scales (``time_scales(plant, schedules)``, or ``TIME_SCALES = ()`` for none)
and its linear counterpart (``linear_counterpart(plant, steady) -> LinearBlock``, or ``LINEAR_COUNTERPART = None``
for none). :meth:`simulate.components.registry.Registry.contract` reads them into one :class:`Contract`, so no caller
imports a model's module by hand.

A module that holds several registered components (the penstock models, the governor and the prescribed law) may
give ``STATES`` and ``LINEAR_COUNTERPART`` as a dictionary by the name of each component's builder function (the part
of its registry target after the colon).

The shape rule of a state array (:attr:`StateArray.shape`):

================= ================================================================================================
rule              shape of the array
================= ================================================================================================
``scalar``        ``(1,)``: one value
``entries``       ``(len(entries),)``: one value per named entry (:attr:`StateArray.entries`)
``per node``      ``(n,)``: one value per computing node of the part's grid
``levels x node`` ``(2, n)``: the current and the next time level, one value per computing node
``entries x node`` ``(len(entries), n)``: the named entries, one row each, one value per computing node
``rows x node``   ``(m, n)``, m >= 1: m rows (m set at build time, e.g. a friction model's terms), one value per
                  computing node
``per control``   ``(n_controls,)``: one value per control of the control vector (1: the guide vanes; 2 with the
                  runner blades)
``delay line``    ``(len(entries) + m,)``, m >= 1: the named entries, then one value per step of a delay (m set at
                  build time from the delay and the step)
``part``          the state of another registered component (:attr:`StateArray.kind` and its name, fixed by
                  :attr:`StateArray.component` or chosen by the plant key :attr:`StateArray.chosen_by`), checked
                  against that component's own ``STATES``
================= ================================================================================================

A servo's state is one array (its ``STATES`` has one record); a friction model's state is the trailing arrays of its
``arrays`` tuple (after its parameters); every other component's state is the tuple of its :class:`CompiledPart`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from hillchart.errors import InputError

SCALAR, ENTRIES, PER_NODE, LEVELS_BY_NODE, ENTRIES_BY_NODE, ROWS_BY_NODE, PER_CONTROL, DELAY_LINE, PART = (
    "scalar", "entries", "per node", "levels x node", "entries x node", "rows x node", "per control", "delay line",
    "part")
#: The shape rules (module docstring).
SHAPES = (SCALAR, ENTRIES, PER_NODE, LEVELS_BY_NODE, ENTRIES_BY_NODE, ROWS_BY_NODE, PER_CONTROL, DELAY_LINE, PART)
#: Registry kinds whose components' state is one array, not a tuple.
ARRAY_KINDS = ("servo",)


@dataclass(frozen=True)
class StateArray:
    """One array of a component's compiled ``state`` tuple.

    ``name`` and ``description`` say what it holds, ``unit`` its unit (of each entry, ``"; "``-separated in the
    order of ``entries`` where they differ), ``shape`` its rule (module docstring); ``entries`` the names of its
    values (rules ``entries``, ``delay line``); ``kind`` with ``component`` or ``chosen_by`` the component whose
    state it is (rule ``part``: a registry kind, and that component's name or the dotted plant key that names it).
    """

    name: str
    unit: str
    description: str
    shape: str = SCALAR
    entries: tuple[str, ...] = ()
    kind: str = ""
    component: str = ""
    chosen_by: str = ""

    def __post_init__(self):
        if self.shape not in SHAPES:
            raise TypeError(f"state array {self.name!r}: shape must be one of {', '.join(SHAPES)}, got {self.shape!r}")
        if (self.shape in (ENTRIES, ENTRIES_BY_NODE)) != bool(self.entries) and self.shape != DELAY_LINE:
            raise TypeError(f"state array {self.name!r}: entries go with the shapes {ENTRIES!r} and "
                            f"{ENTRIES_BY_NODE!r} (and {DELAY_LINE!r})")
        if (self.shape == PART) != bool(self.kind) or (self.shape == PART) == (not (self.component or self.chosen_by)):
            raise TypeError(f"state array {self.name!r}: the shape {PART!r} needs kind and component or chosen_by")


@dataclass(frozen=True)
class StatesOf:
    """A component whose compiled part is another component's (the ``governor`` control is its mode's part): its
    state is that of the component of registry ``kind`` the plant key ``chosen_by`` names."""

    kind: str
    chosen_by: str


@dataclass(frozen=True)
class LinearBlock:
    """A component's linear counterpart at an operating point: ``equation`` (the block, with the equation number of
    its source), ``values`` (name -> value) and ``units`` (name -> unit). A penstock's and a shaft's values are
    keyword arguments of :meth:`simulate.linear.models.LinearPlant.from_coefficients`."""

    equation: str
    values: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)

    def __post_init__(self):
        if set(self.values) != set(self.units):
            raise TypeError(f"linear block {self.equation!r}: every value needs a unit (values {sorted(self.values)}, "
                            f"units {sorted(self.units)})")


#: What a module has not declared (:class:`Contract` fields).
UNDECLARED = "undeclared"


@dataclass(frozen=True)
class Contract:
    """What component ``component`` (``"penstock.model = 'rigid'"``) declares in module ``module``: its ``states``
    (a tuple of :class:`StateArray` or a :class:`StatesOf`), its ``time_scales`` function (None: it declares none)
    and its ``linear_counterpart`` function (None: it has none); :data:`UNDECLARED` where the module says nothing."""

    component: str
    module: str
    states: Any = UNDECLARED
    time_scales: Callable | None | str = UNDECLARED
    linear_counterpart: Callable | None | str = UNDECLARED

    def missing(self) -> tuple[str, ...]:
        """The declarations the module lacks (names as a module writes them)."""
        out = []
        if isinstance(self.states, str):
            out.append("STATES")
        if isinstance(self.time_scales, str):
            out.append("time_scales (or TIME_SCALES = ())")
        if isinstance(self.linear_counterpart, str):
            out.append("linear_counterpart (or LINEAR_COUNTERPART = None)")
        return tuple(out)

    def _require(self, what: str, value):
        if isinstance(value, str):
            raise TypeError(f"{self.component}: its module {self.module} declares no {what} (see "
                            f"simulate.components.contract)")
        return value

    def state_arrays(self):
        """The declared ``STATES``; :class:`TypeError` when the module has none."""
        return self._require("STATES", self.states)

    def scales(self, plant, schedules) -> list:
        """The component's :class:`simulate.components.timescale.TimeScale` list for ``plant`` and its scenario's
        ``schedules``; :class:`TypeError` when the module declares neither ``time_scales`` nor ``TIME_SCALES``."""
        func = self._require("time_scales (or TIME_SCALES = () for none)", self.time_scales)
        return [] if func is None else list(func(plant, schedules))

    def linear(self, plant, steady) -> LinearBlock:
        """The component's :class:`LinearBlock` at the verified steady state ``steady``; :class:`InputError` when it
        has none, :class:`TypeError` when its module does not say."""
        func = self._require("linear_counterpart (or LINEAR_COUNTERPART = None for none)", self.linear_counterpart)
        if func is None:
            raise InputError(f"{self.component} has no linear counterpart (its module {self.module} declares none)")
        return func(plant, steady)


def declared(module, attr: str, builder: str):
    """Module ``module``'s ``attr`` for the component built by ``builder``: the attribute itself, or its entry for
    ``builder`` where it is a dictionary by builder name; :data:`UNDECLARED` where there is none."""
    value = getattr(module, attr, UNDECLARED)
    if isinstance(value, dict):
        value = value.get(builder, UNDECLARED)
    return value


def contract_of(component: str, module, builder: str) -> Contract:
    """The :class:`Contract` module ``module`` declares for the component built by its function ``builder``."""
    scales = declared(module, "time_scales", builder)
    if scales is UNDECLARED:
        scales = declared(module, "TIME_SCALES", builder)
        if scales is not UNDECLARED:
            if tuple(scales) != ():
                raise TypeError(f"{component}: TIME_SCALES of {module.__name__} must be () (no time scales); a "
                                f"component with time scales declares time_scales(plant, schedules)")
            scales = None
    linear = declared(module, "linear_counterpart", builder)
    if linear is UNDECLARED:
        linear = declared(module, "LINEAR_COUNTERPART", builder)
    states = declared(module, "STATES", builder)
    return Contract(component, module.__name__, states, scales, linear)


def _chosen(plant, key: str) -> str:
    value = plant
    for attr in key.split("."):
        value = getattr(value, attr)
    return value


def state_mismatches(states, state, *, where: str, plant, n_nodes: int | None = None, n_controls: int = 1,
                     contract: Callable[[str, str], Contract]) -> list[str]:
    """How the compiled ``state`` (a tuple of arrays, nested for a ``part``) differs from the declared ``states``
    (a tuple of :class:`StateArray` or a :class:`StatesOf`): one line per difference, naming ``where`` and the array.

    ``n_nodes``: the computing nodes of the part's grid (None: unknown, the ``per node`` arrays need only agree with
    each other); ``n_controls``: the length of the control vector; ``contract(kind, name)``: the :class:`Contract` of
    a registered component (:meth:`simulate.components.registry.Registry.contract` by kind).

    Examples
    --------
    >>> declared = (StateArray("speed", "r/min", "the shaft speed"),)
    >>> state_mismatches(declared, (np.zeros(1),), where="rotor", plant=None, contract=None)
    []
    >>> state_mismatches(declared, (np.zeros(1), np.zeros(3)), where="rotor", plant=None, contract=None)
    ['rotor: the state has 2 arrays, STATES declares 1 (speed)']
    """
    if isinstance(states, StatesOf):
        name = _chosen(plant, states.chosen_by)
        inner = contract(states.kind, name)
        return state_mismatches(inner.state_arrays(), state, where=f"{where} ({inner.component})", plant=plant,
                                n_nodes=n_nodes, n_controls=n_controls, contract=contract)
    if not isinstance(state, tuple) or len(state) != len(states):
        count = len(state) if isinstance(state, tuple) else "no tuple of"
        return [f"{where}: the state has {count} arrays, STATES declares {len(states)} "
                f"({', '.join(s.name for s in states)})"]
    out, nodes = [], {"n": n_nodes}
    for declared_array, value in zip(states, state):
        name = f"{where}: state array {declared_array.name!r}"
        if declared_array.shape == PART:
            kind = declared_array.kind
            component = declared_array.component or _chosen(plant, declared_array.chosen_by)
            inner = contract(kind, component)
            nested = (value,) if kind in ARRAY_KINDS else value
            out += state_mismatches(inner.state_arrays(), nested, where=f"{name} ({inner.component})", plant=plant,
                                    n_controls=n_controls, contract=contract)
            continue
        problem = _shape_problem(declared_array, np.shape(value), nodes, n_controls)
        if problem:
            out.append(f"{name} has shape {np.shape(value)}, {problem}")
    return out


def _shape_problem(array: StateArray, shape: tuple, nodes: dict, n_controls: int) -> str:
    """"" when ``shape`` follows the array's rule, else what the rule asks; ``nodes["n"]``: the node count (set by
    the first ``per node`` array when unknown)."""
    if array.shape == SCALAR:
        return "" if shape == (1,) else "its rule 'scalar' asks (1,)"
    if array.shape == ENTRIES:
        return "" if shape == (len(array.entries),) else f"its rule 'entries' asks ({len(array.entries)},)"
    if array.shape == PER_CONTROL:
        return "" if shape == (n_controls,) else f"its rule 'per control' asks ({n_controls},)"
    if array.shape == DELAY_LINE:
        ok = len(shape) == 1 and shape[0] >= len(array.entries) + 1
        return "" if ok else f"its rule 'delay line' asks ({len(array.entries)} + m,) with m >= 1"
    want_dims = 1 if array.shape == PER_NODE else 2
    if array.shape == ROWS_BY_NODE:
        if len(shape) != 2 or shape[0] < 1:
            return f"its rule {array.shape!r} asks (m, n) with m >= 1"
    else:
        rows = len(array.entries) if array.shape == ENTRIES_BY_NODE else 2
        if len(shape) != want_dims or (want_dims == 2 and shape[0] != rows):
            return f"its rule {array.shape!r} asks {'(n,)' if want_dims == 1 else f'({rows}, n)'}"
    if nodes["n"] is None:
        nodes["n"] = shape[-1]
    return "" if shape[-1] == nodes["n"] else f"its rule {array.shape!r} asks {nodes['n']} nodes"


__all__ = ["SCALAR", "ENTRIES", "PER_NODE", "LEVELS_BY_NODE", "ENTRIES_BY_NODE", "ROWS_BY_NODE", "PER_CONTROL",
           "DELAY_LINE", "PART", "SHAPES", "ARRAY_KINDS", "StateArray", "StatesOf", "LinearBlock", "UNDECLARED",
           "Contract", "declared", "contract_of", "state_mismatches"]
