"""Design-study sections of a plant file: ``[limits]`` (guarantees) and ``[[load_cases]]``; ensemble nets.

The plant reader (:func:`simulate.config.plant_from_dict`) takes the plant sections only, so :func:`load_study`
reads the TOML, takes ``limits`` and ``load_cases`` out, and builds the plant from the rest with the public
:func:`simulate.config.plant_from_dict` (:func:`simulate.config.load_plant` skips them unread). Format (units in the
names)::

    [limits]                        # every key optional
    max_speed_rise = 0.50           # max|n|/|n0| - 1, fraction
    max_head_rise = 0.45            # max(H)/H0 - 1 at the turbine, fraction
    max_head_m = 260.0              # head at the turbine inlet, m
    min_pressure_head_m = 5.0       # along the penstock (needs the simulator's head envelope)
    min_draft_tube_pressure_head_m = 2.0  # absolute, below the runner and along the draft tube (needs [draft_tube])
    max_reverse_speed_pct = 30.0    # against the initial rotation, % of n_r (four-quadrant characteristics)
    max_reverse_flow_m3_s = 12.0    # against the initial flow, m^3/s (four-quadrant characteristics)

    [[load_cases]]                  # optional; default: the plant's own scenario as one case
    name = "rated load, normal level"
    scenario.initial_power_mw = 225.0      # any numeric plant key that keeps the structure (simulate.studies.batch)
    penstock.static_head_m = 180.0

:func:`load_ensemble` reads the optional top-level ``"ensemble"`` list of ``{"flow": NET, "torque": NET}`` of a
nets.json (members share the base nets' units).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from hillchart.errors import InputError
from simulate.components.parameters import parameter, read_section, validate_parameters
from simulate.studies.batch import _EXCLUSIVE, CaseResult, check_key, check_value, variant_overrides
from simulate.studies.case_results import worst_over_units
from simulate.config import (STUDY_SECTIONS, PlantConfig, apply_overrides, plant_from_dict, read_plant_toml,
                             split_study_sections, to_dict)


@dataclass(frozen=True)
class Limits:
    """Guarantee limits; None = not guaranteed. Fractions of the initial value, heads in m."""

    max_speed_rise: float | None = parameter(None, unit="fraction of the initial speed", low=0.0, low_open=True,
                                             high=5.0, description="largest speed rise")
    max_head_rise: float | None = parameter(None, unit="fraction of the initial head", low=0.0, low_open=True,
                                            high=10.0, description="largest head rise at the turbine inlet")
    max_head_m: float | None = parameter(None, unit="m", low=0.0, low_open=True, high=1e4,
                                         description="largest head at the turbine inlet")
    # -10.4 m: vacuum, water
    min_pressure_head_m: float | None = parameter(None, unit="m", low=-10.4, low_open=True, high=1e4,
                                                  description="smallest pressure head along the penstock")
    min_draft_tube_pressure_head_m: float | None = parameter(
        None, unit="m of water, absolute", low=0.0, high=1e4,
        description="smallest absolute pressure head below the runner and, with the draft tube's profile, along it")
    max_reverse_speed_pct: float | None = parameter(
        None, unit="% of the rated speed", low=0.0, high=500.0,
        description="largest speed against the initial rotation (characteristics over all four quadrants)")
    max_reverse_flow_m3_s: float | None = parameter(
        None, unit="m^3/s", low=0.0, high=1e5,
        description="largest flow against the initial flow (characteristics over all four quadrants)")

    #: Each limit: its figure, whether it bounds a maximum, and what the run needs to give the figure (said when a
    #: case has none: the limit is then not judged).
    JUDGED = (("max_speed_rise", True, "a run"), ("max_head_rise", True, "a run"), ("max_head_m", True, "a run"),
              ("min_pressure_head_m", False, "the head envelope along a penstock with its profile (an MOC "
                                             "penstock, [[penstock.segments]] elevation_start_m/elevation_end_m)"),
              ("min_draft_tube_pressure_head_m", False, "a [draft_tube] section (the runner outlet's absolute "
                                                        "pressure; along the draft tube with draft_tube.model = "
                                                        "\"moc\" and [[draft_tube.segments]] elevation_start_m/"
                                                        "elevation_end_m)"),
              ("max_reverse_speed_pct", True, "characteristics over all four quadrants (a pump-turbine's)"),
              ("max_reverse_flow_m3_s", True, "characteristics over all four quadrants (a pump-turbine's)"))

    def __post_init__(self):
        validate_parameters("limits", self)

    @classmethod
    def from_dict(cls, raw: Any) -> "Limits":
        return read_section("limits", cls, raw)

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def check(self, case: CaseResult, band: dict | None = None) -> list[dict]:
        """One row per set limit: ``{"limit", "allowed", "value", "verdict"}`` with verdict ``PASS``, ``FAIL`` or
        ``n/a`` (the case did not run, or the figure is not computed, e.g. no envelope).

        With ``band`` (the ensemble band of :func:`simulate.studies.uncertainty.run_ensemble`), a limit whose figure
        has a band is judged on its conservative side: the band's upper end for a maximum, its lower end for a
        minimum; the row then also has ``"band": [low, high]`` and ``"judged": "band"`` (else ``"point"``). A
        figure inside its limit at the point nets but outside it at the band's end FAILs: the chart does not
        exclude it. A row not judged has ``"why"``: the run failed, or the plant's run gives no such figure (what
        it would need, :data:`JUDGED`)."""
        rows = []
        for figure, upper, needs in self.JUDGED:
            allowed = getattr(self, figure)
            if allowed is None:
                continue
            value = getattr(case, figure) if hasattr(case, figure) else worst_over_units(case.components, figure)
            row = {"limit": figure, "allowed": allowed, "value": value, "judged": "point"}
            judged = value
            if band is not None and isinstance(band.get(figure), dict) and value is not None:
                low, high = float(band[figure]["low"]), float(band[figure]["high"])
                # the conservative side, never milder than the point nets' own figure
                judged = max(high, value) if upper else min(low, value)
                row.update(band=[low, high], judged="band")
            if not case.ok or judged is None or not math.isfinite(judged):
                verdict = "n/a"
                row["why"] = ("the run failed" if not case.ok else f"this plant's run gives no {figure}: it needs "
                              f"{needs}")
            else:
                verdict = "PASS" if (judged <= allowed if upper else judged >= allowed) else "FAIL"
            row["verdict"] = verdict
            rows.append(row)
        return rows


@dataclass(frozen=True)
class LoadCase:
    """A named set of numeric overrides of the plant (``{"section.key": number}``)."""

    name: str
    overrides: dict


def parse_load_cases(raw: Any, plant: PlantConfig) -> tuple[LoadCase, ...]:
    """Validate ``[[load_cases]]`` (a list of tables with ``name`` and ``section.key = number`` entries)."""
    if not isinstance(raw, list) or not raw:
        raise InputError(f"load_cases must be a non-empty array of tables [[load_cases]], got {raw!r}")
    out, names = [], set()
    for i, table in enumerate(raw):
        where = f"load_cases[{i}]"
        if not isinstance(table, dict):
            raise InputError(f"{where} must be a table, got {table!r}")
        name = table.get("name")
        if not isinstance(name, str) or not name.strip():
            raise InputError(f"{where}.name must be a non-empty string, got {name!r}")
        if name in names:
            raise InputError(f"{where}.name {name!r} is used twice; names must be unique")
        names.add(name)
        overrides = {}
        for section, body in table.items():
            if section == "name":
                continue
            if not isinstance(body, dict):
                raise InputError(f"{where}.{section} must be written section.key = number (e.g. "
                                 f"scenario.initial_power_mw = 225.0), got {section} = {body!r}")
            for key, value in body.items():
                dotted = f"{section}.{key}"
                try:
                    check_key(plant, dotted)
                    overrides[dotted] = check_value(dotted, value)
                except InputError as exc:
                    raise InputError(f"{where} ({name!r}): {exc}") from None
        if not overrides:
            raise InputError(f"{where} ({name!r}) sets no plant key; give e.g. scenario.initial_power_mw = 225.0")
        try:  # each key's range, and the plant it makes, checked now: the error names the load case
            plant.with_overrides(variant_overrides(overrides))
        except InputError as exc:
            keys = ", ".join(sorted(overrides))
            raise InputError(f"{where} ({name!r}, setting {keys}): {exc}") from None
        out.append(LoadCase(name=name, overrides=overrides))
    return tuple(out)


@dataclass(frozen=True)
class Study:
    """A plant with its optional limits and load cases, and the SHA-256 of the file it came from."""

    plant: PlantConfig
    limits: Limits | None
    load_cases: tuple[LoadCase, ...]
    path: Path
    sha256: str


def load_study(path: str | Path, overrides: dict[str, Any] | None = None) -> Study:
    """Read a plant file that may carry ``[limits]`` and ``[[load_cases]]`` (see the module docstring).

    Raises
    ------
    InputError
        Unreadable file, invalid TOML, anything :func:`simulate.config.plant_from_dict` rejects, a bad limit or
        load case (the message names the key and the value).
    """
    path = Path(path)
    raw, data = read_plant_toml(path)
    study_raw = split_study_sections(raw)
    if overrides:
        apply_overrides(raw, overrides)
    plant = plant_from_dict(raw, base_dir=path.resolve().parent)
    limits = Limits.from_dict(study_raw["limits"]) if "limits" in study_raw else None
    cases = (parse_load_cases(study_raw["load_cases"], plant) if "load_cases" in study_raw
             else (LoadCase(name="plant scenario", overrides={}),))
    return Study(plant=plant, limits=limits, load_cases=cases, path=path, sha256=hashlib.sha256(data).hexdigest())


def file_sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


# ---------------------------------------------------------------------------------------------------------------
# a plant file for hillsim run
# ---------------------------------------------------------------------------------------------------------------
def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {value!r} as TOML")


def _characteristics_path(spec: str, base_dir: Path, relative_to: Path | None) -> str:
    """A nets.json path of the plant (relative to ``base_dir``) for a file written into the folder ``relative_to``:
    relative to that folder (absolute where there is no relative path, e.g. another drive), or absolute without it.
    A registry word (:data:`simulate.components.registry.CHARACTERISTICS`) stays as it is."""
    from simulate.components.turbine.kinds import word_kinds

    if spec in word_kinds():
        return spec
    target = (Path(base_dir) / spec).resolve()
    if relative_to is None:
        return str(target)
    try:
        return Path(os.path.relpath(target, Path(relative_to).resolve())).as_posix()
    except ValueError:  # no relative path between two drives
        return str(target)


def plant_toml(plant: PlantConfig, *, relative_to: Path | str | None = None) -> str:
    """The plant as a TOML file :func:`simulate.config.load_plant` reads back to an equal plant: the characteristics
    path relative to the folder ``relative_to`` the file is written into (so the file travels with its folder and
    the chart), or without it absolute (so the file works from any folder).

    Examples
    --------
    >>> import tomllib
    >>> from dataclasses import replace
    >>> from simulate.config import load_plant
    >>> from data_synthetic import PLANT_HLA339
    >>> plant = load_plant(PLANT_HLA339)
    >>> again = plant_from_dict(tomllib.loads(plant_toml(plant)), base_dir=plant.base_dir)
    >>> again.turbine.characteristics == str(plant.base_dir / "francis" / "nets.json")
    True
    >>> replace(again, turbine=plant.turbine) == plant
    True
    """
    raw = to_dict(plant)
    for turbine in [raw["turbine"]] + [unit.get("turbine", {}) for unit in raw.get("units", [])]:
        if turbine.get("characteristics") is not None:
            turbine["characteristics"] = _characteristics_path(turbine["characteristics"], plant.base_dir,
                                                               relative_to)
    lines = []
    for section, body in raw.items():
        if isinstance(body, list):  # an array of tables ([[units]])
            for item in body:
                lines.extend(_toml_table(section, item, array=True))
        else:
            lines.extend(_toml_table(section, body))
    return "\n".join(lines)


def _is_table_array(value) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _toml_table(name: str, body: dict, *, array: bool = False) -> list[str]:
    """The lines of the table ``[name]`` (``[[name]]`` with ``array``): its plain keys (None left out: TOML has no
    null, an absent key takes its default), then its sub-tables (``[name.key]``, such as ``[turbine.step_up]``) and
    arrays of tables (``[[name.key]]``, such as ``[[penstock.segments]]``), at any depth."""
    lines = [f"[[{name}]]" if array else f"[{name}]"]
    lines.extend(f"{key} = {_toml_value(value)}" for key, value in body.items()
                 if value is not None and not isinstance(value, dict) and not _is_table_array(value))
    lines.append("")
    for key, value in body.items():
        if isinstance(value, dict):
            lines.extend(_toml_table(f"{name}.{key}", value))
        elif _is_table_array(value):
            for item in value:
                lines.extend(_toml_table(f"{name}.{key}", item, array=True))
    return lines


def _toml_string(text: str) -> str:
    """A TOML basic string (JSON's escapes are TOML's; characters outside the BMP written as they are, since JSON's
    surrogate-pair escapes are not TOML)."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def study_toml(limits: Limits | None, load_cases: tuple[LoadCase, ...]) -> str:
    """``[limits]`` and ``[[load_cases]]`` as TOML, to follow :func:`plant_toml` in one study file that
    :func:`load_study` reads back to the same limits and load cases (empty for no limits and only the default case).

    Examples
    --------
    >>> import tomllib
    >>> text = study_toml(Limits(max_speed_rise=0.5), (LoadCase("70 % load", {"scenario.initial_power_mw": 160.0}),))
    >>> print(text)
    [limits]
    max_speed_rise = 0.5
    <BLANKLINE>
    [[load_cases]]
    name = "70 % load"
    scenario.initial_power_mw = 160.0
    <BLANKLINE>
    >>> tomllib.loads(text)["load_cases"]
    [{'name': '70 % load', 'scenario': {'initial_power_mw': 160.0}}]
    """
    lines = []
    if limits is not None:
        lines.append("[limits]")
        lines.extend(f"{k} = {_toml_value(v)}" for k, v in limits.as_dict().items() if v is not None)
        lines.append("")
    for lc in load_cases:
        if not lc.overrides:  # the default case (the plant's own scenario) is no [[load_cases]] entry
            continue
        lines.append("[[load_cases]]")
        lines.append(f"name = {_toml_string(lc.name)}")
        lines.extend(f"{key} = {_toml_value(value)}" for key, value in lc.overrides.items())
        lines.append("")
    return "\n".join(lines)


def explicit_load_cases(load_cases: tuple[LoadCase, ...], plant: PlantConfig) -> tuple[LoadCase, ...]:
    """``load_cases`` with every key that any of them sets (and the exclusive partner of an initial-point key) given
    explicitly in each, from the plant the case gives on ``plant`` where the case does not set it.

    On a plant that carries one case's keys already (the worst case in the plant file ``hillsim optimize-closure``
    writes), each explicit case then gives the same plant as the case on ``plant``: a key one case sets does not leak
    into another that leaves it at the plant's value.
    """
    keys = set().union(*(lc.overrides for lc in load_cases))
    keys |= {_EXCLUSIVE[k] for k in keys if k in _EXCLUSIVE}
    out = []
    for lc in load_cases:
        if not lc.overrides:
            out.append(lc)
            continue
        case_plant = plant.with_overrides(variant_overrides(lc.overrides))
        given = dict(lc.overrides)
        for key in sorted(keys - set(given)):
            section, name = key.split(".")
            value = getattr(getattr(case_plant, section), name)
            if value is not None:  # None: the exclusive partner of a key the case sets, removed by the case
                given[key] = value
        out.append(LoadCase(name=lc.name, overrides=given))
    return tuple(out)


# ---------------------------------------------------------------------------------------------------------------
# ensemble nets
# ---------------------------------------------------------------------------------------------------------------
def load_ensemble(path: str | Path) -> list:
    """The members of the optional top-level ``"ensemble"`` list of a nets.json as HillNets (empty list when
    the file has none). Each member is ``{"flow": NET, "torque": NET}`` in the base file's units.

    Raises
    ------
    InputError
        ``ensemble`` not a non-empty list, a member not an object or without flow/torque, a malformed NET (the
        message names ``ensemble[i].flow.KEY``).
    """
    from hillchart.nets.hill_nets import load_nets

    path = Path(path)
    base = load_nets(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"cannot read nets file {str(path)!r}: {exc}") from None
    if "ensemble" not in doc:
        return []
    if not doc["ensemble"]:  # load_nets checked it is a list of members
        raise InputError(f"{str(path)!r}: ensemble must be a non-empty list of {{\"flow\": NET, \"torque\": NET}}, "
                         f"got an empty list")
    return base.members()  # each with its own draw of the silent-region model, when the file has them


__all__ = ["STUDY_SECTIONS", "Limits", "LoadCase", "Study", "parse_load_cases", "load_study", "plant_toml",
           "study_toml", "explicit_load_cases", "file_sha256", "load_ensemble"]
