"""Nothing in a plant file is accepted and ignored: for every shipped example plant and every declared key of each
of its sections, a valid value different from the plant's either changes a short run's result (its summary
figures, warnings included), or is refused with an InputError naming the key and why, or (where refusing would
break a legitimate plant file) the run warns naming the key. Generated from the declarations
(:mod:`simulate.components.parameters`), so a key declared later is checked without a change here.

A key whose effect is a guard (a budget, a threshold of a warning, the retry of an unsolved step) acts only where
the run reaches it: its candidates run from a modest change to the values just inside its bounds, which reach it.
The whole matrix is the slow tier; the fast tier runs one plant's [solver], [penstock] and [[penstock.segments]]."""

from __future__ import annotations

import json
import math
import sys
import warnings

import pytest

from data_synthetic import PLANT_BULB, PLANT_HLA339, PLANT_HLA339_GRID, PLANT_TWO_UNITS
from hillchart.errors import InputError
from simulate.components.parameters import declarations
from simulate.config import _section_class, load_plant, plant_from_dict, to_dict

PLANTS = {"hla339": PLANT_HLA339, "grid": PLANT_HLA339_GRID, "bulb": PLANT_BULB, "two_units": PLANT_TWO_UNITS,
          "surge_tank": PLANT_HLA339.parent / "plant_hla339_surge_tank.toml",
          "guarantee": PLANT_HLA339.parent / "plant_hla339_guarantee.toml",
          "pump_turbine": PLANT_HLA339.parent / "plant_pump_turbine.toml"}
#: A short run: the event at 1 s, the end 3 s later (every shipped scenario has an event time).
SHORT = {"scenario.event_time_s": 1.0, "scenario.t_end_s": 4.0}
#: Sections whose keys are checked (a table of keys each); ``penstock.segments`` is the first segment's keys.
TABLES = ("turbine", "penstock", "penstock.segments", "generator", "governor", "scenario", "solver", "surge_tank",
          "draft_tube", "blade_servo", "combinator", "excitation", "grid")


def _base(plant_name: str, section: str):
    """The short run's plant; the francis plants run the ideal turbine for keys that are not the turbine's (the
    bulb needs its blades' characteristics, the pump-turbine its four-quadrant ones and their boundary)."""
    overrides = dict(SHORT)
    if section != "turbine" and plant_name not in ("bulb", "pump_turbine"):
        overrides["turbine.characteristics"] = "ideal"
    return load_plant(PLANTS[plant_name], overrides)


def _table(raw: dict, section: str, key: str) -> dict | None:
    """The table holding ``key``: a segment's keys on the first segment, its end elevation on the last (the ends
    of a continuous profile that no other segment shares)."""
    if section == "penstock.segments":
        return raw["penstock"]["segments"][-1 if key == "elevation_end_m" else 0]
    return raw.get(section)


#: Keys that act only where the run reaches them, and the overrides of both runs that make it reach them (tried when
#: the plant's own short run does not reach the key): the
#: retry of an unsolved step (a loop of one iteration leaves steps unsolved); the elevations (a profile on every
#: segment, which the pressure-head envelope reads).
CONDITIONS = {("solver", "fallback"): {"solver.max_iterations": 1},
              # the load's self-regulation acts while the breaker is closed: a load step, not a rejection
              ("generator", "self_regulation"): {"scenario.kind": "load-step"},
              # the derivative filter filters the derivative term: a governor with one
              ("governor", "derivative_filter_s"): {"governor.kd": 0.5},
              # the blades open on a load increase
              ("blade_servo", "opening_time_s"): {"scenario.kind": "load-step", "scenario.load_step": 0.5,
                                                  "scenario.initial_power_mw": 3.0},
              # the rated flow sizes the ideal turbine (a chart's flow is its own)
              ("turbine", "rated_flow_m3_s"): {"turbine.characteristics": "ideal"},
              # the overflow crest lies above the static level, which the tank's level passes after tens of seconds
              ("surge_tank", "level_max_m"): {"scenario.t_end_s": 150.0}}
#: Keys the run does not read, not fixed here: (plant, section, key) -> why.
KNOWN: dict = {}
PROFILE_KEYS = ("elevation_start_m", "elevation_end_m")


def _with_profile(raw: dict) -> None:
    """A continuous pipe profile on every segment: the inlet 5 m below the reservoir level, 1 m lower per segment
    (a pipe above its reservoir would boil in steady flow, which the cavity models refuse)."""
    top = raw["penstock"]["static_head_m"] - 5.0
    for i, segment in enumerate(raw["penstock"]["segments"]):
        segment["elevation_start_m"], segment["elevation_end_m"] = top - i, top - i - 1.0


def _class(section: str):
    if section == "penstock.segments":
        from simulate.components.hydraulic.conduit import PenstockSegment

        return PenstockSegment
    return _section_class(section)


def _candidates(spec, current, default, config):
    """Valid values other than ``current``, a modest change first, then each bound (just inside an open one)."""
    spec = spec.resolved(config)
    if spec.options():
        return [o for o in spec.options() if o != current]
    if spec.kind == "boolean":
        return [not current]
    if spec.kind == "text":
        return [v for v in ("ideal", "synthetic") if v != current]
    if spec.kind not in ("number", "integer"):
        return []  # arrays and tables: their entries are keys of their own (segments) or lists (scenario steps)
    value = current if current is not None else default if default is not None else None
    out = []
    if value is not None:
        out += [value * 1.25, value * 0.75, value + 1.0, value - 1.0] if value else [0.1, -0.1, 1.0]
    for bound, is_open, sign in ((spec.low, spec.low_open, 1.0), (spec.high, spec.high_open, -1.0)):
        if bound is not None:
            out.append(bound + sign * 1e-3 * max(1.0, abs(bound)) if is_open else bound)
    if spec.kind == "integer":
        out = [int(round(v)) for v in out]
    low_ok = lambda v: spec.low is None or (v > spec.low if spec.low_open else v >= spec.low)  # noqa: E731
    high_ok = lambda v: spec.high is None or (v < spec.high if spec.high_open else v <= spec.high)  # noqa: E731
    seen = []
    for v in out:
        if v != current and math.isfinite(v) and low_ok(v) and high_ok(v) and v not in seen:
            seen.append(v)
    return seen


def _fingerprint(plant) -> str:
    from simulate.loop.engine import run_simulation

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run_simulation(plant, raise_on_failure=False)
    summary = result.summary()
    summary["python_warnings"] = sorted(str(w.message) for w in caught)
    return json.dumps(summary, sort_keys=True, default=repr)


def _keys(plant_name: str, sections=TABLES):
    raw = to_dict(load_plant(PLANTS[plant_name]))
    for section in sections:
        if section == "penstock.segments" or section in raw:
            for declared in declarations(_class(section)):
                if declared.parameter.kind not in ("array", "table"):  # entries checked as keys of their own
                    yield plant_name, section, declared.name


def _verdict(plant_name: str, section: str, key: str, condition: dict | None = None) -> str:
    """How the key acts: "changes", "refused: ..." or "warns: ..."; "ignored" when no candidate acts."""
    base = _base(plant_name, section)
    if condition:
        base = base.with_overrides(condition)
    raw = to_dict(base)
    if section == "penstock.segments" and key in PROFILE_KEYS:
        _with_profile(raw)
        base = plant_from_dict(json.loads(json.dumps(raw)), base_dir=base.base_dir)
    table = _table(raw, section, key)
    config = _class(section)(**table) if section == "penstock.segments" else getattr(base, section)
    declared = next(d for d in declarations(config) if d.name == key)
    default = None if declared.required else declared.default
    reference = _fingerprint(base)
    tried = []
    for value in _candidates(declared.parameter, table.get(key), default, config):
        table[key] = value
        dotted = f"{section}.{key}"
        try:
            changed = plant_from_dict(json.loads(json.dumps(raw)), base_dir=base.base_dir)
            fingerprint = _fingerprint(changed)
        except InputError as exc:
            if dotted in str(exc) or f"{section.split('.')[0]}.{key}" in str(exc):
                return f"refused: {exc}"
            tried.append(f"{value!r}: {exc}")  # refused for another key's sake: try the next value
            continue
        if fingerprint != reference:
            return "changes"
        tried.append(f"{value!r}: same result")
    return "ignored (" + "; ".join(tried) + ")"


def _check(plant_name, section, key):
    verdict = _verdict(plant_name, section, key)
    if (plant_name, section, key) in KNOWN:  # stays listed only while it is so
        assert verdict.startswith("ignored"), f"{section}.{key} now acts ({verdict}): remove it from KNOWN"
        return
    if verdict.startswith("ignored") and (section, key) in CONDITIONS:  # a guard: run where it is reached
        verdict = _verdict(plant_name, section, key, CONDITIONS[section, key])
    assert not verdict.startswith("ignored"), f"{plant_name}: {section}.{key} {verdict}"


FAST = list(_keys("hla339", ("solver", "penstock", "penstock.segments")))


@pytest.mark.parametrize("plant_name,section,key", FAST, ids=[f"{p}-{s}.{k}" for p, s, k in FAST])
def test_a_key_of_the_reference_plants_solver_and_penstock_acts(plant_name, section, key):
    _check(plant_name, section, key)


SLOW = [case for name in PLANTS for case in _keys(name) if case not in FAST]


@pytest.mark.slow
@pytest.mark.parametrize("plant_name,section,key", SLOW, ids=[f"{p}-{s}.{k}" for p, s, k in SLOW])
def test_every_key_of_every_shipped_plant_acts(plant_name, section, key):
    _check(plant_name, section, key)


def test_the_check_can_fail_a_key_that_changes_nothing_is_found(monkeypatch):
    """A key whose value the run never reads is reported as ignored: the run's fingerprint stripped of everything
    makes every key look ignored."""
    monkeypatch.setattr(sys.modules[__name__], "_fingerprint", lambda plant: "same")
    assert _verdict("hla339", "governor", "kp").startswith("ignored")
