"""A component's parameters declared as data, in the component's own module: name, unit, bounds, default and
description of each key of its plant-file section (as scikit-learn's ``_parameter_constraints`` and ANDES's model
parameters).

A config dataclass declares each key with :func:`parameter` (a :func:`dataclasses.field` that carries a
:class:`Parameter` in its metadata) and calls :func:`validate_parameters` first in ``__post_init__``. The same
declarations give the plant-file reference page its table (``docs/gen_reference.py``) and the bad-input tests
(``tests/simulate/components/test_parameters.py`` violates every bound of every declared key and checks the message
names the key, the value and what is allowed). Checks between keys (``stroke_min < stroke_max``) stay in
``__post_init__``, after the declared ones.

Examples
--------
>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Valve:
...     closing_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=1000.0,
...                                       description="time of a full stroke")
...     def __post_init__(self):
...         validate_parameters("valve", self)
>>> Valve(closing_time_s=-1.0)
Traceback (most recent call last):
...
hillchart.errors.InputError: valve.closing_time_s must be in (0.0, 1000.0], got -1.0
>>> [(d.name, d.parameter.allowed(), d.required) for d in declarations(Valve)]
[('closing_time_s', 'in (0.0, 1000.0]', True)]
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import MISSING, dataclass
from pathlib import Path
from typing import Any

from hillchart.errors import InputError
from hillchart.validation import check_choice, check_int, check_number, interval

#: The metadata key of a declared field.
METADATA_KEY = "parameter"
#: The metadata key that marks the field holding a section's component keys (:func:`component_store`).
STORE_MARK = "component_store"
#: What a declared value may be (:attr:`Parameter.kind`).
KINDS = ("number", "integer", "boolean", "text", "array", "table")


@dataclass(frozen=True)
class Parameter:
    """What a key means and what it may be: ``unit`` (``"s"``, ``"stroke fraction"``, ``"1"`` for a pure number),
    ``description`` (one line for the reference page), a number's bounds ``low``/``high`` (``None``: unbounded; a
    string: the value of that other key of the section; ``low_open``/``high_open``: the bound itself is refused), or
    a string's ``choices`` (a tuple, or a registry of components, :class:`simulate.components.registry.Registry`:
    its names at the time of the check, so a component registered later is accepted).

    ``kind``: what the value is, one of :data:`KINDS`: ``"number"`` (a real number, the default), ``"integer"``
    (an integer between the bounds, both given), ``"boolean"`` (true or false), ``"text"`` (a non-empty string, such
    as a path), ``"array"`` (a non-empty array; its entries are checked by the section, against other keys) or
    ``"table"`` (a sub-table, the config class ``table``, which validates its own keys); choices make it a choice.
    ``hint``: said after the message when the value is refused (how to give the value right); ``what``: the words
    for what a value of a kind other than a number is (``"a non-empty array of tables [[penstock.segments]]"``),
    instead of the kind's own."""

    unit: str
    description: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: Any = ()
    kind: str = "number"
    hint: str = ""
    table: Any = None
    what: str = ""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"Parameter.kind must be one of {', '.join(KINDS)}, got {self.kind!r}")
        if self.kind == "integer" and (self.low is None or self.high is None):
            raise ValueError("an integer Parameter needs both bounds")

    def options(self) -> tuple[str, ...]:
        """The allowed strings (none for a number)."""
        return tuple(self.choices.names()) if hasattr(self.choices, "names") else tuple(self.choices)

    def allowed(self) -> str:
        """What is allowed, worded as the error message words it (``in [0.0, 1.0)``, ``one of a, b``,
        ``an integer in [1, 10]``, ``true or false``)."""
        if self.options():
            return "one of " + ", ".join(self.options())
        if self.kind == "number":
            if isinstance(self.low, str) or isinstance(self.high, str):  # a bound named by another key
                low = "-inf" if self.low is None else self.low if isinstance(self.low, str) else repr(float(self.low))
                high = "inf" if self.high is None else self.high if isinstance(self.high, str) else repr(
                    float(self.high))
                return (f"in {'(' if self.low_open or self.low is None else '['}{low}, {high}"
                        f"{')' if self.high_open or self.high is None else ']'}")
            return "in " + interval(self.low, self.high, low_open=self.low_open, high_open=self.high_open)
        if self.what:
            return self.what
        return {"integer": f"an integer in [{self.low!r}, {self.high!r}]", "boolean": "true or false",
                "text": "a non-empty string", "array": "a non-empty array", "table": "a table"}[self.kind]

    def check(self, key: str, value: Any) -> None:
        """:class:`InputError` naming ``key``, ``value`` and :meth:`allowed` (then the hint) unless ``value`` is
        allowed."""
        try:
            if self.options():
                check_choice(key, value, self.options())
            elif self.kind == "number":
                check_number(key, value, low=self.low, high=self.high, low_open=self.low_open,
                             high_open=self.high_open)
            elif self.kind == "integer":
                check_int(key, value, self.low, self.high)
            elif not {"boolean": lambda v: isinstance(v, bool),
                      "text": lambda v: isinstance(v, str) and bool(v.strip()),
                      "array": lambda v: isinstance(v, (list, tuple)) and len(v) > 0,
                      "table": lambda v: isinstance(v, self.table)}[self.kind](value):
                raise InputError(f"{key} must be {self.allowed()}, got {value!r}")
        except InputError as exc:
            if not self.hint:
                raise
            raise InputError(f"{exc} {self.hint}") from None

    def resolved(self, config) -> "Parameter":
        """This declaration with each bound named by another key of the section (``high="t_end_s"``) replaced by
        that key's value in ``config`` (``None``, no bound, where the value is not a finite number: that key's own
        check reports it)."""
        def value(bound):
            if not isinstance(bound, str):
                return bound
            number = getattr(config, bound, None)
            ok = isinstance(number, (int, float)) and not isinstance(number, bool) and math.isfinite(number)
            return float(number) if ok else None

        return dataclasses.replace(self, low=value(self.low), high=value(self.high))

    def violations(self) -> list[Any]:
        """Values just outside each finite bound (the bound itself when it is open), and a wrong type: the bad
        inputs the generated tests feed."""
        if self.options():
            return ["no-such-" + self.options()[0], 1.0]
        if self.kind == "integer":
            return [self.low - 1, self.high + 1, float(self.low) + 0.5, True]
        if self.kind != "number":
            return {"boolean": ["yes", 1], "text": ["", 1.0], "array": [[], 1.0], "table": [1.0, True]}[self.kind]
        out = []
        if self.low is not None and not isinstance(self.low, str):
            out.append(self.low if self.low_open else self.low - max(1.0, abs(self.low)) * 1e-3)
        if self.high is not None and not isinstance(self.high, str):
            out.append(self.high if self.high_open else self.high + max(1.0, abs(self.high)) * 1e-3)
        return out + ["1.0", True]


def parameter(default: Any = MISSING, *, unit: str, description: str, low: float | None = None,
              high: float | None = None, low_open: bool = False, high_open: bool = False,
              choices: Any = (), kind: str = "number", hint: str = "", table: Any = None, what: str = "") -> Any:
    """A dataclass field declared as a :class:`Parameter` (``default`` left out: the key is required; ``None``: the
    key is optional and may be left out)."""
    declared = Parameter(unit=unit, description=description, low=low, high=high, low_open=low_open,
                         high_open=high_open, choices=choices if hasattr(choices, "names") else tuple(choices),
                         kind=kind, hint=hint, table=table, what=what)
    return dataclasses.field(default=default, metadata={METADATA_KEY: declared})


def borrowed(cls, name: str, *, description: str | None = None) -> Any:
    """An optional field (default ``None``) declared as key ``name`` of the config class ``cls``: a key another
    component owns and this section passes on (the discrete servo's coefficients in ``[governor]``)."""
    declared = next(d for d in declarations(cls) if d.name == name).parameter
    if description is not None:
        declared = dataclasses.replace(declared, description=description)
    return dataclasses.field(default=None, metadata={METADATA_KEY: declared})


@dataclass(frozen=True)
class Declared:
    """One declared key of a config class: its ``name``, ``default`` (``MISSING`` when required) and
    :class:`Parameter`."""

    name: str
    default: Any
    parameter: Parameter

    @property
    def required(self) -> bool:
        return self.default is MISSING


def declarations(cls) -> tuple[Declared, ...]:
    """The declared keys of the config class (or instance) ``cls``, in field order (fields without a declaration
    are left out), then the keys its components declare (:func:`component_declarations`)."""
    return tuple(Declared(f.name, f.default, f.metadata[METADATA_KEY]) for f in dataclasses.fields(cls)
                 if METADATA_KEY in f.metadata) + component_declarations(cls)


def own_keys(cls, *names: str, prefix: str = "") -> tuple[Declared, ...]:
    """The keys ``names`` (all by default) of the config class ``cls`` as the component that owns them declares them
    in a section another class reads (a governor mode's or a servo's own keys of ``[governor]``, its module's
    ``OWN_KEYS``): named ``prefix + name`` there, each optional (default ``None``: the component requires what it
    needs), with ``cls``'s unit, bounds and description.

    Examples
    --------
    >>> from simulate.components.control.dead_time import DeadTimeConfig
    >>> [(d.name, d.default, d.parameter.allowed()) for d in own_keys(DeadTimeConfig, prefix="servo_")]
    [('servo_dead_time_s', None, 'in (0.0, 10.0]')]
    """
    declared = {d.name: d.parameter for d in declarations(cls)}
    unknown = [name for name in names if name not in declared]
    if unknown:
        raise TypeError(f"{cls.__name__} declares no key {unknown[0]!r}; its keys: {', '.join(declared)}")
    return tuple(Declared(prefix + name, None, declared[name]) for name in names or declared)


def component_store() -> Any:
    """The field of a section's config class that holds the values of the keys its components declare
    (:func:`with_component_keys`): ``((key, value), ...)`` sorted by key, the keys left out absent. It is not a key of
    the section (:func:`section_fields` leaves it out)."""
    return dataclasses.field(default=(), metadata={STORE_MARK: True})


def component_declarations(cls) -> tuple[Declared, ...]:
    """The keys of ``cls``'s section that its components declare (its ``component_declarations()``, read at the
    time of the call, so a component registered later is included); none for a class without components."""
    method = getattr(cls, "component_declarations", None)
    return tuple(method()) if method is not None else ()


def section_fields(cls) -> tuple[dataclasses.Field, ...]:
    """The fields of the config class ``cls`` that are keys of its section (all but a :func:`component_store`)."""
    return tuple(f for f in dataclasses.fields(cls) if not f.metadata.get(STORE_MARK))


def section_keys(cls) -> tuple[str, ...]:
    """The keys of ``cls``'s section: its fields' (:func:`section_fields`), then its components'."""
    return tuple(f.name for f in section_fields(cls)) + tuple(d.name for d in component_declarations(cls))


def with_component_keys(cls):
    """Class decorator (over ``@dataclass``) for a section whose keys are in part declared by its components: the
    class method ``component_declarations()`` returns them (:class:`Declared`, default ``None``) and one field is
    the :func:`component_store`. Then ``cls(**keys)`` (so :func:`dataclasses.replace` and :func:`read_section`)
    accepts them beside the fields (``None``: left out), ``config.key`` reads one (``None`` when left out), and
    :func:`declarations` lists them, so :func:`validate_parameters`, :func:`read_section`, :func:`section_dict`, the
    reference page and the generated tests take them with no list kept by hand."""
    store = next(f.name for f in dataclasses.fields(cls) if f.metadata.get(STORE_MARK))
    fields = {f.name for f in dataclasses.fields(cls)}
    fields_init = cls.__init__

    def __init__(self, **keys):
        values = dict(keys.pop(store, ()))
        others = [k for k in keys if k not in fields]
        components = {d.name for d in cls.component_declarations()} if others else set()
        for name in others:
            if name not in components:
                raise TypeError(f"{cls.__name__}.__init__() got an unexpected keyword argument {name!r}")
            value = keys.pop(name)
            if value is None:
                values.pop(name, None)
            else:
                values[name] = value
        fields_init(self, **keys, **{store: tuple(sorted(values.items()))})

    def __getattr__(self, name: str):
        values = self.__dict__.get(store)
        if values is not None and not name.startswith("__"):
            for key, value in values:
                if key == name:
                    return value
            if any(d.name == name for d in cls.component_declarations()):
                return None
        raise AttributeError(f"{cls.__name__!r} object has no attribute {name!r}")

    __init__.__doc__ = fields_init.__doc__
    cls.__init__, cls.__getattr__ = __init__, __getattr__
    return cls


def validate_parameters(section: str, config) -> None:
    """Check every declared key of ``config`` against its declaration; an optional key left out (``None``) passes.
    The error names ``section.key``, the value and what is allowed."""
    for declared in declarations(config):
        value = getattr(config, declared.name)
        if value is None and declared.default is None:
            continue
        declared.parameter.resolved(config).check(f"{section}.{declared.name}", value)


def read_section(section: str, cls, raw: Any, *, ignore: tuple[str, ...] = ()):
    """The config ``cls`` of the TOML table ``raw`` of ``[section]``: the one strict reader of every section. An
    unknown key or a missing required key is an :class:`InputError` naming the key and the valid (required) ones;
    keys in ``ignore`` belong to another component and are passed over. An array becomes a tuple (a frozen config
    holds no list); the config's own ``__post_init__`` validates the values (sub-tables and arrays of tables
    included).

    Examples
    --------
    >>> from simulate.components.hydraulic.surge_tank import SurgeTankConfig
    >>> read_section("surge_tank", SurgeTankConfig, {"area_m2": 80.0})
    Traceback (most recent call last):
    ...
    hillchart.errors.InputError: missing required key surge_tank.throttle_loss_coefficient; [surge_tank] needs \
area_m2, throttle_loss_coefficient, tunnel_length_m, tunnel_diameter_m, tunnel_darcy_friction
    """
    if not isinstance(raw, dict):
        raise InputError(f"[{section}] must be a table of keys, got {raw!r}")
    names = list(section_keys(cls))
    unknown = sorted(set(raw) - set(names) - set(ignore))
    if unknown:
        raise InputError(f"unknown key {section}.{unknown[0]}; valid keys of [{section}]: {', '.join(names)}")
    required = [f.name for f in dataclasses.fields(cls) if f.default is MISSING and f.default_factory is MISSING]
    missing = [k for k in required if k not in raw]
    if missing:
        raise InputError(f"missing required key {section}.{missing[0]}; [{section}] needs {', '.join(required)}")
    return cls(**{k: tuple(raw[k]) if isinstance(raw[k], list) else raw[k] for k in names if k in raw})


def read_toml(path, what: str) -> tuple[dict, bytes]:
    """The TOML document of the ``what`` (``"plant file"``) at ``path`` and the file's bytes: the one TOML file
    reader. A UTF-8 byte-order mark (a Windows editor's) is accepted. Every :class:`InputError` names the file:
    unreadable, not UTF-8, not TOML, nested beyond reason."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read {what} {str(path)!r}: {exc.strerror}") from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        from hillchart.io.tabular import not_utf8_detail

        raise InputError(f"{what} {str(path)!r} is not UTF-8 text {not_utf8_detail(exc)}") from None
    try:
        return tomllib.loads(text), data
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{what} {str(path)!r} is not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"{what} {str(path)!r} is not a {what}: arrays or tables nested thousands of levels "
                         "deep") from None


def section_dict(config, *, skip_defaults: bool = False) -> dict[str, Any]:
    """The TOML table of the config ``config``: the one writer of every section, :func:`read_section`'s inverse.
    Every field is written (a key declared later is written without a change here), except a value of ``None`` (an
    optional key left out: TOML has no null) and, with ``skip_defaults``, a value equal to its default; a sub-table's
    config becomes its table, a tuple a list (of tables).

    Examples
    --------
    >>> from simulate.components.hydraulic.conduit import PenstockSegment
    >>> section_dict(PenstockSegment(length_m=400.0, diameter_m=2.0, wave_speed_m_s=1000.0, darcy_friction=0.01))
    {'length_m': 400.0, 'diameter_m': 2.0, 'wave_speed_m_s': 1000.0, 'darcy_friction': 0.01}
    """
    out = {}
    for f in (*section_fields(config), *component_declarations(config)):
        value = getattr(config, f.name)
        if value is None or (skip_defaults and f.default is not MISSING and value == f.default):
            continue
        out[f.name] = _toml_value(value)
    return out


def _toml_value(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return section_dict(value)
    if isinstance(value, (tuple, list)):
        return [_toml_value(v) for v in value]
    return value


__all__ = ["KINDS", "Parameter", "Declared", "parameter", "borrowed", "declarations", "own_keys", "component_store",
           "component_declarations", "section_fields", "section_keys", "with_component_keys", "validate_parameters",
           "read_section", "read_toml", "section_dict"]
