"""The variants of a batch: which plant keys may vary, the checks of their keys and values, and the overrides a
variant applies to the base plant (:mod:`simulate.studies.batch` runs them).

A *variant* is a dictionary ``{"section.key": number}`` applied to a base plant with
:meth:`simulate.config.PlantConfig.with_overrides`. Numeric keys vary within one structure (:func:`check_key`,
:func:`check_value`); keys that choose a model (penstock model, scenario kind, pressure loop, characteristics:
:data:`STRUCTURE_CHOICE_KEYS`) take a name (:func:`check_choice_value`) and group the cases, each group's plant built
by :func:`structure_variant`. ``penstock.reaches`` may vary (a grid-convergence study): each case builds its own
grid.
"""

from __future__ import annotations

import functools
import math
from dataclasses import fields
from typing import Any, Iterable

import numpy as np

from hillchart.errors import InputError
from simulate.components.parameters import component_declarations, section_fields
from simulate.config import (GeneratorConfig, GovernorConfig, PenstockConfig, PlantConfig, SCENARIO_KEYS,
                             ScenarioConfig, SolverConfig, TurbineConfig, load_characteristics)

#: Keys that are numbers but change the structure the cases share (none today: ``penstock.reaches`` sizes the MOC
#: grid's arrays, and every case builds its own, so a grid-convergence sweep over it is a batch like any other).
STRUCTURE_KEYS: dict[str, str] = {}
#: Keys whose value is a name that selects a model. :func:`simulate.studies.batch.run_batch` (so ``hillsim sweep``)
#: groups the cases by them and runs one batch of numbers per group (each with its own compiled loop, characteristics
#: and pool); studies that share one structure among their cases (:class:`simulate.studies.batch.BatchPool`, closure
#: optimization) refuse them.
STRUCTURE_CHOICE_KEYS = ("penstock.model", "scenario.kind", "solver.pressure_loop", "turbine.characteristics")
#: The two scenario keys of which exactly one is set; varying one removes the other.
_EXCLUSIVE = {"scenario.initial_power_mw": "scenario.initial_opening",
              "scenario.initial_opening": "scenario.initial_power_mw"}
_SECTION_CLASSES = {"turbine": TurbineConfig, "penstock": PenstockConfig, "generator": GeneratorConfig,
                    "governor": GovernorConfig, "scenario": ScenarioConfig, "solver": SolverConfig}
#: Sections a plant file may have (a surge tank, a draft tube, a double-regulated unit's blades, the generator's
#: voltage control and grid): their numeric keys vary like any other where the plant has the section.
OPTIONAL_SECTIONS = ("surge_tank", "draft_tube", "blade_servo", "combinator", "excitation", "grid")


def _section_keys(section: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(numeric keys as ``section.key``, every key name) of a plant section: its fields' and the numeric keys its
    components declare (a governor mode's or a servo's own keys, read from the registries at the time of the call)."""
    cls, numeric, names = _field_keys(section)
    declared = component_declarations(cls)
    numeric += tuple(f"{section}.{d.name}" for d in declared
                     if d.parameter.kind in ("number", "integer") and not d.parameter.options())
    return numeric, names + tuple(d.name for d in declared)


@functools.cache
def _field_keys(section: str) -> tuple[type, tuple[str, ...], tuple[str, ...]]:
    """(config class, numeric fields as ``section.key``, every field's name) of a plant section; an optional
    section's class is imported here, when a key of it is first varied (some cost a quarter of a second of
    start-up)."""
    from simulate.config import _section_class

    cls = _SECTION_CLASSES.get(section) or _section_class(section)
    numeric = tuple(f"{section}.{f.name}" for f in section_fields(cls)
                    if str(f.type).replace(" ", "") in ("float", "int", "float|None", "int|None"))
    return cls, numeric, tuple(f.name for f in section_fields(cls))


def numeric_keys() -> dict[str, tuple[str, ...]]:
    """Numeric keys of every plant section (what :func:`check_key` accepts before the scenario-kind check and, for
    an optional section, the check that the plant has it).

    Examples
    --------
    >>> "governor.closing_time_s" in numeric_keys()["governor"], "surge_tank.area_m2" in numeric_keys()["surge_tank"]
    (True, True)
    """
    return {section: _section_keys(section)[0] for section in (*_SECTION_CLASSES, *OPTIONAL_SECTIONS)}


def check_key(plant: PlantConfig, key: Any, *, choices: bool = False) -> str:
    """Validate a varied key against ``plant``: a numeric ``section.key`` that keeps the structure, or with
    ``choices`` also a key of :data:`STRUCTURE_CHOICE_KEYS` (a model's name; the batch groups the cases by it).

    Raises
    ------
    InputError
        Not ``section.key``; unknown section or key; a non-numeric key; a structure key; a scenario key the plant's
        scenario kind does not use. The message names the key and the allowed ones.

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> from data_synthetic import PLANT_HLA339
    >>> check_key(load_plant(PLANT_HLA339), "governor.kp")
    'governor.kp'
    """
    if not isinstance(key, str) or key.count(".") != 1 or not all(key.split(".")):
        raise InputError(f"varied key must be section.key (e.g. governor.closing_time_s), got {key!r}")
    section, name = key.split(".")
    sections = (*_SECTION_CLASSES, *OPTIONAL_SECTIONS)
    if section not in sections:
        raise InputError(f"unknown section in varied key {key!r}; valid sections: {', '.join(sections)}")
    numeric, names = _section_keys(section)
    if key in STRUCTURE_CHOICE_KEYS and choices:
        return key
    if key in STRUCTURE_KEYS or key in STRUCTURE_CHOICE_KEYS:
        why = STRUCTURE_KEYS.get(key, "it selects a model every case shares")
        raise InputError(f"varied key {key!r} changes the plant structure ({why}); this study's cases share one "
                         f"structure: run one study per {key} (a sweep groups its cases by it)")
    if name not in names:
        named = [k for k in STRUCTURE_CHOICE_KEYS if k.startswith(f"{section}.")] if choices else []
        raise InputError(f"unknown key {key!r}; numeric keys of [{section}]: {', '.join(numeric)}"
                         + (f"; keys of [{section}] that take a name: {', '.join(named)}" if named else ""))
    if section in OPTIONAL_SECTIONS and getattr(plant, section, None) is None:
        raise InputError(f"varied key {key!r}: the plant has no [{section}]; add the section to the plant file to "
                         f"vary its keys")
    if key not in numeric:
        names_note = (f"; of the keys that take a name only {', '.join(STRUCTURE_CHOICE_KEYS)} can be varied (a "
                      f"sweep groups its cases by them)") if choices else ""
        raise InputError(f"varied key {key!r} is not numeric (it takes a name or a table, not a number){names_note}; "
                         f"numeric keys of [{section}]: {', '.join(numeric)}")
    if section == "scenario" and name != "t_end_s" and name not in SCENARIO_KEYS[plant.scenario.kind]:
        raise InputError(f"varied key {key!r} is not used by scenario.kind = {plant.scenario.kind!r}; scenario "
                         f"keys of that kind: t_end_s, {', '.join(SCENARIO_KEYS[plant.scenario.kind])}")
    return key


def integer_keys(section: str) -> tuple[str, ...]:
    """The keys of a plant section that take an integer (``penstock.reaches``, ``solver.max_iterations``, ...)."""
    cls, numeric, _ = _field_keys(section)
    hints = {f.name: str(f.type).replace(" ", "") for f in fields(cls)}
    return tuple(key for key in numeric if hints[key.split(".")[1]] in ("int", "int|None")) + tuple(
        f"{section}.{d.name}" for d in component_declarations(cls) if d.parameter.kind == "integer")


def check_value(key: str, value: Any) -> float:
    """A varied value must be a finite real number (bool refused); ints stay ints, and a key that takes an integer
    (:func:`integer_keys`, e.g. ``penstock.reaches``) gets one: a whole float (``8.0`` from a ``--vary`` list or
    range, or a ``cases.csv`` cell) becomes ``8``, a fraction is refused.

    Examples
    --------
    >>> check_value("penstock.reaches", 8.0), check_value("governor.kp", 2)
    (8, 2)
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"value of varied key {key!r} must be a number, got {value!r}")
    if not math.isfinite(float(value)):
        raise InputError(f"value of varied key {key!r} must be finite, got {value!r}")
    section = key.split(".")[0] if isinstance(key, str) and key.count(".") == 1 else None
    if section in (*_SECTION_CLASSES, *OPTIONAL_SECTIONS) and key in integer_keys(section):
        if float(value) != int(value):
            raise InputError(f"value of varied key {key!r} must be an integer (the key counts), got {value!r}")
        return int(value)
    return int(value) if isinstance(value, (int, np.integer)) else float(value)


def variant_overrides(variant: dict[str, float]) -> dict[str, Any]:
    """The override dictionary of a variant (adds the removal of the exclusive partner of an initial-point key)."""
    out: dict[str, Any] = dict(variant)
    for key in variant:
        partner = _EXCLUSIVE.get(key)
        if partner is not None and partner not in variant:
            out[partner] = None
    return out


def check_choice_value(key: str, value: Any) -> str:
    """The value of a :data:`STRUCTURE_CHOICE_KEYS` key: a non-empty name (what the plant file would hold)."""
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"value of varied key {key!r} selects a model: a name (e.g. penstock.model = \"rigid\"), "
                         f"got {value!r}")
    return value.strip()


def validate_variants(plant: PlantConfig, variants: Iterable[dict], *,
                      choices: bool = False) -> tuple[tuple[str, ...], list[dict]]:
    """Check every variant's keys (:func:`check_key`) and values (:func:`check_value`, or
    :func:`check_choice_value` for a model's name with ``choices``); returns (keys, variants)."""
    out, keys = [], []
    for i, variant in enumerate(variants):
        if not isinstance(variant, dict):
            raise InputError(f"variant {i} must be a dictionary {{section.key: number}}, got {variant!r}")
        clean = {}
        for key, value in variant.items():
            check_key(plant, key, choices=choices)
            clean[key] = check_choice_value(key, value) if key in STRUCTURE_CHOICE_KEYS else check_value(key, value)
            if key not in keys:
                keys.append(key)
        out.append(clean)
    both = [k for k in _EXCLUSIVE if k in keys]
    if len(both) == 2:
        raise InputError("scenario.initial_power_mw and scenario.initial_opening cannot both be varied: a case "
                         "starts from exactly one of them")
    return tuple(keys), out


def structure_variant(plant: PlantConfig, names: dict[str, str]) -> tuple[PlantConfig, Any]:
    """``plant`` with the model names ``names`` (:data:`STRUCTURE_CHOICE_KEYS` -> name), and its characteristics
    when ``turbine.characteristics`` is among them (None otherwise: the base plant's serve).

    Raises
    ------
    InputError
        A name the plant file would refuse, or characteristics that cannot be read; the message names the varied
        key and value.
    """
    try:
        varied = plant.with_overrides(names) if names else plant
        chars = (load_characteristics(varied.turbine, varied.base_dir) if "turbine.characteristics" in names
                 else None)
    except InputError as exc:
        raise InputError(f"varied {', '.join(f'{k} = {v!r}' for k, v in names.items())}: {exc}") from None
    return varied, chars
