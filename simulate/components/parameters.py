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
from dataclasses import MISSING, dataclass
from typing import Any

from hillchart.validation import check_choice, check_number, interval

#: The metadata key of a declared field.
METADATA_KEY = "parameter"


@dataclass(frozen=True)
class Parameter:
    """What a key means and what it may be: ``unit`` (``"s"``, ``"stroke fraction"``, ``"1"`` for a pure number),
    ``description`` (one line for the reference page), a number's bounds ``low``/``high`` (``None``: unbounded;
    ``low_open``/``high_open``: the bound itself is refused), or a string's ``choices`` (a tuple, or a registry of
    components, :class:`simulate.components.registry.Registry`: its names at the time of the check, so a component
    registered later is accepted)."""

    unit: str
    description: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: Any = ()

    def options(self) -> tuple[str, ...]:
        """The allowed strings (none for a number)."""
        return tuple(self.choices.names()) if hasattr(self.choices, "names") else tuple(self.choices)

    def allowed(self) -> str:
        """What is allowed, worded as the error message words it (``in [0.0, 1.0)``, ``one of a, b``)."""
        if self.options():
            return "one of " + ", ".join(self.options())
        return "in " + interval(self.low, self.high, low_open=self.low_open, high_open=self.high_open)

    def check(self, key: str, value: Any) -> None:
        """:class:`InputError` naming ``key``, ``value`` and :meth:`allowed` unless ``value`` is allowed."""
        if self.options():
            check_choice(key, value, self.options())
        else:
            check_number(key, value, low=self.low, high=self.high, low_open=self.low_open, high_open=self.high_open)

    def violations(self) -> list[Any]:
        """Values just outside each finite bound (the bound itself when it is open), and a wrong type: the bad
        inputs the generated tests feed."""
        if self.options():
            return ["no-such-" + self.options()[0], 1.0]
        out = []
        if self.low is not None:
            out.append(self.low if self.low_open else self.low - max(1.0, abs(self.low)) * 1e-3)
        if self.high is not None:
            out.append(self.high if self.high_open else self.high + max(1.0, abs(self.high)) * 1e-3)
        return out + ["1.0", True]


def parameter(default: Any = MISSING, *, unit: str, description: str, low: float | None = None,
              high: float | None = None, low_open: bool = False, high_open: bool = False,
              choices: Any = ()) -> Any:
    """A dataclass field declared as a :class:`Parameter` (``default`` left out: the key is required; ``None``: the
    key is optional and may be left out)."""
    declared = Parameter(unit=unit, description=description, low=low, high=high, low_open=low_open,
                         high_open=high_open,
                         choices=choices if hasattr(choices, "names") else tuple(choices))
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
    are left out)."""
    return tuple(Declared(f.name, f.default, f.metadata[METADATA_KEY]) for f in dataclasses.fields(cls)
                 if METADATA_KEY in f.metadata)


def validate_parameters(section: str, config) -> None:
    """Check every declared key of ``config`` against its declaration; an optional key left out (``None``) passes.
    The error names ``section.key``, the value and what is allowed."""
    for declared in declarations(config):
        value = getattr(config, declared.name)
        if value is None and declared.default is None:
            continue
        declared.parameter.check(f"{section}.{declared.name}", value)


__all__ = ["Parameter", "Declared", "parameter", "borrowed", "declarations", "validate_parameters"]
