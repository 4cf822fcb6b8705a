"""Plant configuration: the reader that composes a TOML file's sections (:data:`SECTIONS`) into a :class:`PlantConfig`.

Each section's class lives in its component's package with every key declared as data (unit, bounds, default,
description: :mod:`simulate.components.parameters`; the plant-file reference page is generated from them). Every
section is read by one strict reader (:func:`simulate.components.parameters.read_section`: an unknown or missing key
is an error naming the key and the valid ones) and written by one writer
(:func:`simulate.components.parameters.section_dict`), so a key declared in a component is read, written and
overridden without a change here.
"""

from __future__ import annotations

import importlib
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from hillchart.errors import InputError
from simulate.components.control.governor import GovernorConfig
from simulate.components.electrical.generator import GridConfig
from simulate.components.hydraulic.conduit import (MAX_REACHES, WAVE_SPEED_MIN_M_S, PenstockConfig,  # noqa: F401
                                                   PenstockSegment)
from simulate.components.hydraulic.draft_tube import DRAFT_TUBE_MODELS, DraftTubeConfig  # noqa: F401
from simulate.components.hydraulic.surge_tank import SurgeTankConfig
from simulate.components.parameters import declarations, read_section, read_toml, section_dict
from simulate.components.registry import PENSTOCKS
from simulate.components.shaft.generator_config import SUBTRANSIENT_KEYS, GeneratorConfig  # noqa: F401
from simulate.components.solver import COURANT_TOLERANCE, PRESSURE_LOOPS, TOLERANCE_FLOOR, SolverConfig  # noqa: F401
from simulate.components.turbine.rated import COMBINATOR_HEAD_RANGE, TurbineConfig, check_combinator_head  # noqa: F401
from simulate.components.unit import UNIT_KEYS, UNIT_OVERRIDE_SECTIONS, UnitConfig, check_units
from simulate.scenarios.base import SCENARIO_KEYS, SCENARIO_KINDS, ScenarioConfig


@dataclass(frozen=True)
class PlantConfig:
    """The whole plant file. ``base_dir`` resolves a relative ``turbine.characteristics`` path."""

    turbine: TurbineConfig
    penstock: PenstockConfig
    generator: GeneratorConfig
    governor: GovernorConfig
    scenario: ScenarioConfig
    solver: SolverConfig = field(default_factory=SolverConfig)
    base_dir: Path = Path(".")
    surge_tank: SurgeTankConfig | None = None
    excitation: Any = None  # simulate.components.control.excitation.ExcitationConfig (generator.model = "subtransient")
    grid: Any = None  # simulate.components.electrical.generator.GridConfig (generator.model = "subtransient")
    units: tuple[UnitConfig, ...] = ()
    blade_servo: Any = None  # simulate.components.control.blade_servo.BladeServoConfig (double-regulated units)
    combinator: Any = None  # simulate.components.control.blade_servo.CombinatorConfig (double-regulated units)
    draft_tube: DraftTubeConfig | None = None

    def __post_init__(self):
        sc, gov = self.scenario, self.governor
        check_units(self)
        self.generator.electrical(self.excitation, self.grid)  # [excitation] and [grid] with the sub-transient model
        sc.check_plant(self)
        check_combinator_head(self.combinator, self.turbine, self.penstock)
        if sc.initial_opening is not None and not (gov.stroke_min <= sc.initial_opening <= gov.stroke_max):
            raise InputError(f"scenario.initial_opening must be in [governor.stroke_min, governor.stroke_max] = "
                             f"[{gov.stroke_min!r}, {gov.stroke_max!r}], got {sc.initial_opening!r}")
        if sc.initial_power_mw is not None and sc.initial_power_mw > 1.5 * self.turbine.rated_power_mw:
            raise InputError(f"scenario.initial_power_mw must be in [0, 1.5 * turbine.rated_power_mw] = "
                             f"[0, {1.5 * self.turbine.rated_power_mw!r}], got {sc.initial_power_mw!r}")

    def require_one_unit(self, what: str) -> None:
        """An :class:`InputError` when the plant has ``[[units]]``: ``what`` (a command or a study) models one unit."""
        if self.units:
            raise InputError(f"{what} models a plant with one unit; this plant has [[units]] "
                             f"({', '.join(u.name for u in self.units)}): give a plant file without [[units]] (one "
                             f"unit's [turbine], [generator], [governor] and its waterway as [[penstock.segments]])")

    @property
    def event_units(self) -> tuple[str, ...]:
        """Names of the units the scenario's event applies to (``scenario.units``, default all; empty without
        ``[[units]]``)."""
        if not self.units:
            return ()
        return tuple(self.scenario.units) if self.scenario.units is not None else tuple(u.name for u in self.units)

    def unit_plant(self, unit: UnitConfig) -> "PlantConfig":
        """The single-unit view of ``unit``: its turbine, generator and governor, its branch as the penstock (the
        builders of the control and shaft components read a plant); the scenario's initial point replaced by the
        unit's own when it has one."""
        sc = self.scenario
        if unit.initial_power_mw is not None:
            sc = replace(sc, initial_power_mw=unit.initial_power_mw, initial_opening=None, units=None)
        elif unit.initial_opening is not None:
            sc = replace(sc, initial_power_mw=None, initial_opening=unit.initial_opening, units=None)
        else:
            sc = replace(sc, units=None)
        return replace(self, turbine=unit.turbine, generator=unit.generator, governor=unit.governor,
                       penstock=unit.branch_penstock(self.penstock), scenario=sc, units=())

    @property
    def time_step_s(self) -> float:
        """The simulation step, s (:meth:`simulate.components.solver.SolverConfig.time_step_s`, checked against the
        Courant condition for MOC). With ``[[units]]``: the shortest travel time of every pipe (common conduit and
        branches) divided by ``penstock.reaches``."""
        moc_dt = min([self.penstock.moc_time_step_s]
                     + [u.branch_penstock(self.penstock).moc_time_step_s for u in self.units])
        return self.solver.time_step_s(moc_dt, PENSTOCKS.traits(self.penstock.model).grid_fixes_time_step,
                                       self.penstock.reaches)

    @property
    def electrical(self):
        """:class:`simulate.components.electrical.generator.ElectricalConfig` of ``[generator]``, ``[excitation]``,
        ``[grid]`` (model "subtransient"; None for the swing model)."""
        return self.generator.electrical(self.excitation, self.grid)

    def rotor_self_regulation(self, load_pu: float) -> float:
        """e_g of the rotor's load at a load of ``load_pu`` for the linear models
        (:meth:`simulate.components.shaft.generator_config.GeneratorConfig.rotor_self_regulation`)."""
        return self.generator.rotor_self_regulation(self.grid, load_pu)

    def with_overrides(self, overrides: dict[str, Any]) -> "PlantConfig":
        """A copy with ``{"section.key": value}`` replaced, validated like the file (see :func:`plant_from_dict`).

        A declared key of a section that holds a number, a string or a flag is replaced in place
        (:func:`dataclasses.replace`, which validates the section and the plant as the file does: a batch makes one
        variant per case, and the whole dictionary round trip costs ten times as much); anything else (an array, a
        table, a switch of scenario kind, an absent section, several units, an unknown key) takes the file's path
        (:func:`to_dict`, :func:`apply_overrides`, :func:`plant_from_dict`)."""
        replaced = self._replaced(overrides)
        if replaced is not None:
            return replaced
        raw = to_dict(self)
        apply_overrides(raw, overrides)
        return plant_from_dict(raw, base_dir=self.base_dir)

    def _replaced(self, overrides: dict[str, Any]) -> "PlantConfig | None":
        """:meth:`with_overrides` by :func:`dataclasses.replace`, or None where the file's path is needed."""
        if self.units or not isinstance(overrides, dict):
            return None
        changes: dict[str, dict[str, Any]] = {}
        for dotted, value in overrides.items():
            if not isinstance(dotted, str) or dotted.count(".") != 1 or isinstance(value, (list, tuple, dict)):
                return None
            section, key = dotted.split(".")
            config = getattr(self, section) if section in SECTIONS and section != "units" else None
            spec = {d.name: d for d in declarations(config)}.get(key) if config is not None else None
            if spec is None or spec.parameter.kind in ("array", "table") or (section, key) in _REBUILT_KEYS:
                return None
            if value is None:  # the file's path removes the key: its default, when it has one
                if spec.required:
                    return None
                value = spec.default
            changes.setdefault(section, {})[key] = value
        return replace(self, **{name: replace(getattr(self, name), **kv) for name, kv in changes.items()})


def __getattr__(name: str):
    """``PENSTOCK_MODELS``: the penstock registry's names at the time of the call (a component registered after this
    module was imported is included)."""
    if name == "PENSTOCK_MODELS":
        return PENSTOCKS.names()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: The sections of a plant file and their config classes (a ``"module:class"`` is imported when the section is
#: read); ``units`` is an array of tables.
SECTIONS = {
    "turbine": TurbineConfig, "penstock": PenstockConfig, "generator": GeneratorConfig, "governor": GovernorConfig,
    "scenario": ScenarioConfig, "solver": SolverConfig, "surge_tank": SurgeTankConfig,
    "excitation": "simulate.components.control.excitation:ExcitationConfig", "grid": GridConfig,
    "units": UnitConfig, "blade_servo": "simulate.components.control.blade_servo:BladeServoConfig",
    "combinator": "simulate.components.control.blade_servo:CombinatorConfig", "draft_tube": DraftTubeConfig,
}
#: Sections a plant file must have.
REQUIRED_SECTIONS = ("turbine", "penstock", "generator", "governor", "scenario")
#: Keys whose change rebuilds more than their own field: the scenario kind drops the keys the new kind does not use.
_REBUILT_KEYS = {("scenario", "kind")}


def _section_class(name: str):
    cls = SECTIONS[name]
    return getattr(importlib.import_module(cls.split(":")[0]), cls.split(":")[1]) if isinstance(cls, str) else cls


#: Sections of a guarantee study's plant file, which :mod:`simulate.studies.cases` reads; :func:`load_plant` skips
#: them (they are not part of the plant) and :func:`plant_from_dict` names them in its message.
STUDY_SECTIONS = ("limits", "load_cases")


def split_study_sections(raw: dict[str, Any]) -> dict[str, Any]:
    """Take the study sections (:data:`STUDY_SECTIONS`) out of a plant file's TOML document ``raw`` and return
    them, ``{name: value}`` for those present (``raw`` keeps the plant sections).

    Examples
    --------
    >>> raw = {"turbine": {}, "limits": {"max_speed_rise": 0.5}}
    >>> split_study_sections(raw), raw
    ({'limits': {'max_speed_rise': 0.5}}, {'turbine': {}})
    """
    return {name: raw.pop(name) for name in STUDY_SECTIONS if name in raw} if isinstance(raw, dict) else {}


def plant_from_dict(raw: dict[str, Any], *, base_dir: Path | str = ".") -> PlantConfig:
    """Build a :class:`PlantConfig` from the parsed TOML dictionary (strict keys), each section by
    :func:`simulate.components.parameters.read_section`.

    Examples
    --------
    >>> import tomllib
    >>> from data_synthetic import PLANT_HLA339
    >>> raw = tomllib.loads(PLANT_HLA339.read_text())
    >>> raw["penstock"]["reaches"] = 0
    >>> plant_from_dict(raw)
    Traceback (most recent call last):
    ...
    hillchart.errors.InputError: penstock.reaches must be an integer in [1, 10000], got 0
    """
    if not isinstance(raw, dict):
        raise InputError(f"plant file must be a table of sections, got {raw!r}")
    unknown = sorted(set(raw) - set(SECTIONS))
    if unknown:
        study = ("; [limits] and [[load_cases]] make a guarantee study: read the file with "
                 "simulate.config.load_plant (which skips them) or simulate.studies.cases.load_study (which reads "
                 "them)" if unknown[0] in STUDY_SECTIONS else "")
        raise InputError(f"unknown section [{unknown[0]}]; valid sections: {', '.join(SECTIONS)}{study}")
    for name in REQUIRED_SECTIONS:
        if name not in raw:
            raise InputError(f"missing section [{name}]; a plant file needs turbine, penstock, generator, governor, "
                             f"scenario ([solver], [surge_tank] and [draft_tube] are optional; [excitation] and "
                             f"[grid] go with generator.model = \"subtransient\"; [combinator] and [blade_servo] "
                             f"with three-input characteristics)")
    sections = {name: _units(raw[name], raw) if name == "units" else read_section(name, _section_class(name), raw[name])
                for name in SECTIONS if name in raw}
    return PlantConfig(base_dir=Path(base_dir), **sections)


def _units(raw_units: Any, raw: dict[str, Any]) -> tuple[UnitConfig, ...]:
    """The ``[[units]]`` array of tables, each unit's ``[units.turbine]`` ... read over the plant's section."""
    if not isinstance(raw_units, list) or not raw_units:
        raise InputError(f"units must be a non-empty array of tables [[units]], got {raw_units!r}")
    out = []
    for i, unit in enumerate(raw_units):
        if not isinstance(unit, dict):
            raise InputError(f"units[{i}] must be a table [[units]], got {unit!r}")
        unknown = sorted(set(unit) - set(UNIT_KEYS))
        if unknown:
            raise InputError(f"unknown key units.{unknown[0]} (unit {i}); valid keys of [[units]]: "
                             f"{', '.join(UNIT_KEYS)}")
        missing = [k for k in ("name", "branch") if k not in unit]
        if missing:
            raise InputError(f"missing required key units.{missing[0]} (unit {i}); a unit needs name and "
                             f"[[units.branch]]")
        where = f"unit {unit['name']!r}" if isinstance(unit["name"], str) else f"unit {i}"
        merged = dict(unit)
        for section in UNIT_OVERRIDE_SECTIONS:
            override = unit.get(section, {})
            if not isinstance(override, dict):
                raise InputError(f"units.{section} ({where}) must be a table [units.{section}] of the keys of "
                                 f"[{section}], got {override!r}")
            try:
                merged[section] = read_section(section, SECTIONS[section], dict(raw[section]) | override)
            except InputError as exc:
                raise InputError(f"{exc} (in [units.{section}] of {where})") from None
        try:
            out.append(read_section("units", UnitConfig, merged))
        except InputError as exc:
            raise InputError(str(exc) if where in str(exc) else f"{exc} ({where})") from None
    return tuple(out)


def to_dict(plant: PlantConfig) -> dict[str, Any]:
    """The TOML-shaped dictionary of ``plant``, every section by
    :func:`simulate.components.parameters.section_dict` (the scenario without the keys at their default)."""
    out: dict[str, Any] = {}
    for name in SECTIONS:
        config = getattr(plant, name)
        if name == "units" and config:
            out["units"] = [_unit_dict(unit, plant) for unit in config]
        elif name != "units" and config is not None:
            out[name] = section_dict(config, skip_defaults=name == "scenario")
    return out


def _unit_dict(unit: UnitConfig, plant: PlantConfig) -> dict[str, Any]:
    """One ``[[units]]`` table of ``unit``: its keys of turbine, generator and governor that differ from the plant's
    (so an override of the plant's section reaches every unit that does not set the key itself)."""
    out = section_dict(unit)
    for section in UNIT_OVERRIDE_SECTIONS:
        common = section_dict(getattr(plant, section))
        own = {key: value for key, value in out.pop(section).items() if common.get(key) != value}
        if own:
            out[section] = own
    return out


def parse_override(text: str) -> tuple[str, Any]:
    """``"section.key=value"`` -> ``("section.key", value)`` with the value parsed as TOML.

    Examples
    --------
    >>> parse_override("penstock.model=\\"rigid\\"")
    ('penstock.model', 'rigid')
    >>> parse_override("scenario.t_end_s=30")
    ('scenario.t_end_s', 30)
    >>> parse_override("solver.pressure_loop=newton")  # a bare word is taken as a string
    ('solver.pressure_loop', 'newton')
    """
    if "=" not in text:
        raise InputError(f"--set expects section.key=value, got {text!r}")
    key, value_text = (s.strip() for s in text.split("=", 1))
    if key.count(".") != 1 or not all(key.split(".")):
        raise InputError(f"--set key must be section.key (e.g. solver.dt_s), got {key!r}")
    try:
        value = tomllib.loads(f"v = {value_text}")["v"]
    except tomllib.TOMLDecodeError:
        if value_text and all(c.isalnum() or c in "-_./" for c in value_text):
            value = value_text  # a bare word: a string such as newton or ideal
        else:
            raise InputError(f"--set {key}: value {value_text!r} is not a TOML value") from None
    return key, value


def apply_overrides(raw: dict[str, Any], overrides: dict[str, Any]) -> None:
    """Set ``raw[section][key] = value`` for each ``"section.key"`` (a ``None`` value removes the key).

    Switching ``scenario.kind`` drops the scenario keys the new kind does not use.
    """
    new_kind = overrides.get("scenario.kind")
    if new_kind in SCENARIO_KEYS and isinstance(raw.get("scenario"), dict):
        keep = set(SCENARIO_KEYS[new_kind]) | {"kind", "t_end_s"}
        raw["scenario"] = {k: v for k, v in raw["scenario"].items() if k in keep}
    for dotted, value in overrides.items():
        if not isinstance(dotted, str) or dotted.count(".") != 1:
            raise InputError(f"override key must be section.key, got {dotted!r}")
        section, key = dotted.split(".", 1)
        if section == "units":
            raise InputError(f"override {dotted!r}: the units are changed in the plant file ([[units]]); an override "
                             f"of [turbine], [generator] or [governor] applies to every unit without its own key")
        if section not in SECTIONS:
            raise InputError(f"unknown section in override {dotted!r}; valid sections: {', '.join(SECTIONS)}")
        sec = raw.setdefault(section, {})
        if value is None:
            sec.pop(key, None)
        else:
            sec[key] = value


def load_plant(path: str | Path, overrides: dict[str, Any] | None = None, *,
               skipped: list[str] | None = None) -> PlantConfig:
    """Read a plant TOML file (strict keys), apply ``{"section.key": value}`` overrides, validate.

    A guarantee study's sections (``[limits]``, ``[[load_cases]]``: :data:`STUDY_SECTIONS`) are not part of the plant:
    they are skipped unread (:func:`simulate.studies.cases.load_study` reads and validates them), and their names
    appended to ``skipped`` when given, so a command can say so.

    Raises
    ------
    InputError
        Unknown or missing key, out-of-range value, unreadable file.
    """
    path = Path(path)
    raw, _ = read_plant_toml(path)
    study = split_study_sections(raw)
    if skipped is not None:
        skipped.extend(study)
    if overrides:
        apply_overrides(raw, overrides)
    return plant_from_dict(raw, base_dir=path.resolve().parent)


def read_plant_toml(path: Path) -> tuple[dict, bytes]:
    """The TOML document of a plant file and the file's bytes (:func:`simulate.components.parameters.read_toml`)."""
    return read_toml(path, "plant file")


from simulate.components.turbine.component import load_characteristics  # noqa: E402  (the turbine's own)


__all__ = [  # noqa: F822  (PENSTOCK_MODELS: served by the module's __getattr__)
    "PENSTOCK_MODELS", "PRESSURE_LOOPS", "SCENARIO_KINDS", "SCENARIO_KEYS", "SECTIONS", "TurbineConfig",
    "PenstockSegment", "PenstockConfig", "GeneratorConfig", "GovernorConfig", "ScenarioConfig", "SolverConfig",
    "SurgeTankConfig", "DraftTubeConfig", "UnitConfig", "PlantConfig", "plant_from_dict", "to_dict", "parse_override",
    "apply_overrides", "load_plant", "load_characteristics", "replace"]
