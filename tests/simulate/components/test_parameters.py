"""Bad-input tests generated from the control components' declared parameters (simulate.components.parameters):
every bound of every declared key of [governor] is violated through the plant file, and the message must name the
key, the value and what is allowed; the value on the bound (or just inside an open one) beside it is not refused
for that reason."""

import dataclasses
import re

import pytest

from hillchart.errors import InputError
from simulate.components.control.backlash import BacklashConfig
from simulate.components.control.dead_time import DeadTimeConfig
from simulate.components.control.discrete_servo import DiscreteServoConfig
from simulate.components.control.governor import GovernorConfig
from simulate.components.control.two_stage import TwoStageConfig
from simulate.components.parameters import Parameter, declarations

#: (section, config class): the classes whose keys are declared as data
DECLARED = (("governor", GovernorConfig), ("servo", DiscreteServoConfig), ("servo", DeadTimeConfig),
            ("servo", BacklashConfig), ("servo", TwoStageConfig))


def _cases():
    for section, cls in DECLARED:
        for declared in declarations(cls):
            for bad in declared.parameter.violations():
                yield pytest.param(section, cls, declared, bad, id=f"{section}.{declared.name}={bad!r}")


def _governor_plant(overrides):
    from data_synthetic import PLANT_HLA339
    from simulate.config import load_plant

    return load_plant(PLANT_HLA339, {f"governor.{k}": v for k, v in overrides.items()})


def _make(section, cls, name, value):
    """The config with key ``name`` set to ``value``: [governor] through the plant file (the TOML path the users
    take), the servo's own config directly."""
    if section == "governor":
        return _governor_plant({name: value})
    others = {d.name: _inside(d.parameter)[0] for d in declarations(cls) if d.required and d.name != name}
    return cls(**others, **{name: value})


def _inside(spec: Parameter):
    """Values on each closed bound and just inside each open one: allowed by the declaration."""
    if spec.options():
        return list(spec.options())
    out = []
    for bound, is_open, sign in ((spec.low, spec.low_open, 1.0), (spec.high, spec.high_open, -1.0)):
        if bound is not None:
            out.append(bound + sign * 1e-6 * max(1.0, abs(bound)) if is_open else bound)
    return out


@pytest.mark.parametrize("section,cls,declared,bad", list(_cases()))
def test_every_declared_bound_is_enforced_with_a_message_naming_key_value_and_range(section, cls, declared, bad):
    spec = declared.parameter
    key = f"{section}.{declared.name}"
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


def test_every_key_of_the_governor_section_is_declared():
    names = [f.name for f in dataclasses.fields(GovernorConfig)]
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
