"""Bad-input tests generated from the components' declared parameters (simulate.components.parameters): every bound
of every declared key of every plant-file section is violated (and a wrong type given), and the message must name
the key, the value and what is allowed; the value on the bound (or just inside an open one) beside it is not refused
for that reason. [governor] goes through the plant file; the other sections through ``dataclasses.replace`` of the
section as a shipped example plant has it (which validates like the file: the reader calls the same class)."""

import dataclasses
import re

import pytest

from hillchart.errors import InputError
from simulate.components.control.backlash import BacklashConfig
from simulate.components.control.dead_time import DeadTimeConfig
from simulate.components.control.discrete_servo import DiscreteServoConfig
from simulate.components.control.governor import GovernorConfig
from simulate.components.control.two_stage import TwoStageConfig
from simulate.components.parameters import Parameter, declarations, section_keys

#: (section, config class): the classes whose keys are declared as data
DECLARED = (("governor", GovernorConfig), ("servo", DiscreteServoConfig), ("servo", DeadTimeConfig),
            ("servo", BacklashConfig), ("servo", TwoStageConfig))


def _shipped():
    """{section: (config class, a valid instance from a shipped example plant)} of every plant-file section."""
    from data_synthetic import PLANT_BULB, PLANT_HLA339, PLANT_HLA339_GRID, PLANT_TWO_UNITS
    from simulate.components.electrical.generator import SubtransientGeneratorConfig
    from simulate.components.turbine.step_up import StepUpConfig
    from simulate.config import load_plant
    from simulate.studies.cases import Limits

    base, grid, bulb, units = (load_plant(p) for p in (PLANT_HLA339, PLANT_HLA339_GRID, PLANT_BULB, PLANT_TWO_UNITS))
    surge = load_plant(PLANT_HLA339.parent / "plant_hla339_surge_tank.toml")
    configs = {"turbine": base.turbine, "turbine.step_up": StepUpConfig(), "penstock": base.penstock,
               "penstock.segments": base.penstock.segments[0], "generator": grid.generator,
               "generator (machine)": grid.generator.subtransient, "scenario": base.scenario,
               "scenario (closure-law)": load_plant(PLANT_HLA339, {"scenario.kind": "closure-law",
                                                                   "scenario.closing_time_s": 8.0}).scenario,
               "solver": base.solver, "surge_tank": surge.surge_tank, "draft_tube": bulb.draft_tube,
               "blade_servo": bulb.blade_servo, "combinator": bulb.combinator, "excitation": grid.excitation,
               "grid": grid.grid, "units": units.units[0], "limits": Limits(max_speed_rise=0.5)}
    assert isinstance(configs["generator (machine)"], SubtransientGeneratorConfig)
    return {name: (type(config), config) for name, config in configs.items()}


SHIPPED = _shipped()
#: The key prefix of each entry of SHIPPED (its section in the plant file).
PREFIX = {name: name.split(" ")[0] for name in SHIPPED}


def _cases():
    for section, cls in DECLARED:
        for declared in declarations(cls):
            for bad in declared.parameter.violations():
                yield pytest.param(section, cls, declared, bad, id=f"{section}.{declared.name}={bad!r}")
    for name, (cls, _) in SHIPPED.items():
        for declared in declarations(cls):
            for bad in declared.parameter.violations():
                yield pytest.param(name, cls, declared, bad, id=f"{name}.{declared.name}={bad!r}")


def _governor_plant(overrides):
    from data_synthetic import PLANT_HLA339
    from simulate.config import load_plant

    return load_plant(PLANT_HLA339, {f"governor.{k}": v for k, v in overrides.items()})


def _make(section, cls, name, value):
    """The config with key ``name`` set to ``value``: [governor] through the plant file (the TOML path the users
    take), the servo's own config directly."""
    if section == "governor":
        return _governor_plant({name: value})
    if section in SHIPPED:
        return dataclasses.replace(SHIPPED[section][1], **{name: value})
    others = {d.name: _inside(d.parameter)[0] for d in declarations(cls) if d.required and d.name != name}
    return cls(**others, **{name: value})


def _inside(spec: Parameter):
    """Values on each closed bound and just inside each open one: allowed by the declaration."""
    if spec.options():
        return list(spec.options())
    if spec.kind not in ("number", "integer"):
        return []  # a text, an array or a table: its good values are the shipped plants'
    out = []
    for bound, is_open, sign in ((spec.low, spec.low_open, 1.0), (spec.high, spec.high_open, -1.0)):
        if bound is not None:
            out.append(bound + sign * 1e-6 * max(1.0, abs(bound)) if is_open else bound)
    return out


@pytest.mark.parametrize("section,cls,declared,bad", list(_cases()))
def test_every_declared_bound_is_enforced_with_a_message_naming_key_value_and_range(section, cls, declared, bad):
    key = f"{PREFIX.get(section, section)}.{declared.name}"
    spec = declared.parameter.resolved(SHIPPED[section][1]) if section in SHIPPED else declared.parameter
    with pytest.raises(InputError) as err:
        _make(section, cls, declared.name, bad)
    message = str(err.value)
    assert message.startswith(f"{key} must be"), message
    assert spec.allowed().split(" ", 1)[1] in message, message
    assert repr(float(bad) if isinstance(bad, float) else bad) in message, message
    # beside it, the values the declaration allows are not refused for this key's range (another check, such as
    # stroke_min < stroke_max or the discrete servo's DC gain, may still refuse the combination, naming itself)
    for good in _inside(spec):
        try:
            _make(section, cls, declared.name, good)
        except InputError as exc:
            assert not re.match(rf"{re.escape(key)} must be (a number )?(in|one of) ", str(exc)), (good, str(exc))


def test_the_violations_straddle_each_bound():
    """The generator of bad values can fail: a bound moved inwards by the declaration would let the old bound's
    violation through (checked on permanent_droop, allowed in [0, 1))."""
    spec = next(d for d in declarations(GovernorConfig) if d.name == "permanent_droop").parameter
    assert spec.violations()[:2] == [-0.001, 1.0]  # 1e-3 below the closed bound 0; the open bound 1 itself
    narrower = dataclasses.replace(spec, high=0.5)
    with pytest.raises(InputError, match=r"governor\.permanent_droop must be in \[0\.0, 0\.5\), got 0\.7"):
        narrower.check("governor.permanent_droop", 0.7)
    spec.check("governor.permanent_droop", 0.7)  # the declared range allows it


@pytest.mark.parametrize("name", list(SHIPPED))
def test_every_key_of_every_section_is_declared(name):
    cls = SHIPPED[name][0]
    assert [f.name for f in dataclasses.fields(cls)] == [d.name for d in declarations(cls)]
    assert declarations(cls), name


def test_an_undeclared_key_is_found():
    """The check above can fail: a field added without ``parameter(...)`` is not among the declarations."""
    from simulate.components.solver import SolverConfig

    extended = dataclasses.make_dataclass("SolverConfig", [("new_key_s", float, dataclasses.field(default=1.0))],
                                          bases=(SolverConfig,), frozen=True)
    assert [f.name for f in dataclasses.fields(extended)] != [d.name for d in declarations(extended)]


def test_a_bound_named_by_another_key_takes_its_value():
    """scenario.event_time_s lies in [0, t_end_s): the message states the plant's t_end_s, the page the key."""
    sc = SHIPPED["scenario"][1]
    spec = next(d for d in declarations(type(sc)) if d.name == "event_time_s").parameter
    assert spec.allowed() == "in [0.0, t_end_s)" and spec.resolved(sc).allowed() == "in [0.0, 60.0)"
    with pytest.raises(InputError, match=r"scenario\.event_time_s must be in \[0\.0, 60\.0\), got -1\.0"):
        dataclasses.replace(sc, event_time_s=-1.0)
    assert dataclasses.replace(sc, event_time_s=59.0).event_time_s == 59.0


def test_every_key_of_the_governor_section_is_declared():
    names = list(section_keys(GovernorConfig))  # its fields but the store of the component keys, then those keys
    assert names == [d.name for d in declarations(GovernorConfig)]
    assert [f.name for f in dataclasses.fields(DiscreteServoConfig)] == [d.name
                                                                         for d in declarations(DiscreteServoConfig)]


def test_the_governor_defaults_and_required_keys_are_the_declared_ones():
    """The section requires the rate limits; the PID's keys are required by the modes that read them
    (``REQUIRED_KEYS`` of the mode's module) and ``servo_time_s`` by every servo with a lag: leaving one out names
    the mode or servo that needs it."""
    by_name = {d.name: d for d in declarations(GovernorConfig)}
    assert [n for n, d in by_name.items() if d.required] == ["closing_time_s", "opening_time_s"]
    assert (by_name["stroke_max"].default, by_name["servo_model"].default, by_name["mode"].default) == (
        1.0, "first-order", "speed")
    from data_synthetic import PLANT_HLA339
    from simulate.config import plant_from_dict, read_plant_toml
    import tomllib

    for key, message in (("kp", r"governor\.mode = \"speed\" needs governor\.kp$"),
                         ("servo_time_s", r"governor\.servo_model = \"first-order\" needs governor\.servo_time_s")):
        raw = tomllib.loads(read_plant_toml(PLANT_HLA339)[1].decode())
        plant_from_dict(raw, base_dir=PLANT_HLA339.parent)  # the file as shipped passes
        del raw["governor"][key]
        with pytest.raises(InputError, match=message):
            plant_from_dict(raw, base_dir=PLANT_HLA339.parent)
