"""A model is chosen by the registry, never by comparing its name: a comparison with a servo or penstock model's
or a kind of characteristics' or a governor mode's name (``plant.governor.servo_model == "discrete"``,
``plant.penstock.model == "moc"``, ``plant.turbine.characteristics == "ideal"``, ``plant.governor.mode == "power"``)
outside the model's own module and the registry fails here; what the code needs to know of a penstock model it asks
its registry entry (:meth:`simulate.components.registry.Registry.traits`). (The
control registry's names, "governor" and "prescribed", are also section and mode words elsewhere; its choice is
:func:`simulate.components.registry.control_name`.)"""

import ast
from pathlib import Path

import pytest

from simulate.components.registry import CHARACTERISTICS, FRICTION, GOVERNORS, PENSTOCKS, SERVOS

REPO = Path(__file__).resolve().parents[3]
#: the registries whose names may be compared only in their own modules
CHECKED = (SERVOS, PENSTOCKS, CHARACTERISTICS, GOVERNORS, FRICTION)


def _owner_files(registry) -> dict[str, set[str]]:
    """name -> the files allowed to name it: the module of its builder and the registry's module."""
    out = {}
    for name in registry.names():
        out[name] = {registry.module(name).replace(".", "/") + ".py", "simulate/components/registry.py"}
    return out


def _compared_strings(tree: ast.AST):
    """(line, string) of every string constant compared with == or != (alone or in a tuple, list or set on either
    side), or tested with in / not in against a literal tuple, list or set (``mode in ("speed", "power")``). A
    string looked up in a runtime container (``"opening" in measured_box``: a key, not a choice of model) is not a
    comparison."""
    def literals(operand):
        items = operand.elts if isinstance(operand, (ast.Tuple, ast.List, ast.Set)) else [operand]
        return [item.value for item in items if isinstance(item, ast.Constant) and isinstance(item.value, str)]

    for node in ast.walk(tree):
        if not isinstance(node, ast.Compare):
            continue
        operands = [node.left, *node.comparators]
        for left, op, right in zip(operands, node.ops, operands[1:]):
            if isinstance(op, (ast.Eq, ast.NotEq)):
                found = literals(left) + literals(right)
            elif isinstance(op, (ast.In, ast.NotIn)) and isinstance(right, (ast.Tuple, ast.List, ast.Set)):
                found = literals(left) + literals(right)
            else:
                found = []
            for value in found:
                yield node.lineno, value


def model_name_comparisons(root: Path = REPO, sources=None) -> list[str]:
    """``path:line compares "name"`` for each comparison with a checked model name outside its allowed files."""
    allowed = {}
    for registry in CHECKED:
        for name, files in _owner_files(registry).items():
            allowed.setdefault(name, set()).update(files)
    found = []
    if sources is None:
        sources = {str(p.relative_to(root)): p.read_text(encoding="utf-8")
                   for package in ("simulate", "hillsim") for p in sorted((root / package).rglob("*.py"))}
    for path, text in sources.items():
        for line, value in _compared_strings(ast.parse(text)):
            if value in allowed and path not in allowed[value]:
                found.append(f"{path}:{line} compares {value!r}")
    return found


def test_no_servo_penstock_characteristics_or_governor_mode_name_is_compared_outside_its_module_and_the_registry():
    assert model_name_comparisons() == []


@pytest.mark.parametrize("text,hits", [
    ('if plant.governor.servo_model == "discrete":\n    pass\n', 1),
    ('ok = model in ("first-order", "backlash")\n', 2),
    ('label = "discrete"\n', 0),  # a string that is not compared is not a choice of model
    ('if plant.penstock.model == "moc":\n    pass\n', 1),
    ('lumped = plant.penstock.model in ("rigid", "lumped")\n', 2),
    ('if plant.turbine.characteristics == "ideal":\n    pass\n', 1),
    ('chart_dir = None if spec in ("ideal", "synthetic") else path\n', 2),
    ('if plant.governor.mode == "dashpot":\n    pass\n', 1),
    ('pid = plant.governor.mode not in ["opening", "dashpot"]\n', 2),
    ('droop = "power" != mode\n', 1),
    ('known = "opening" in measured_box\n', 0),  # a key looked up in a mapping, not a choice of mode
])
def test_the_check_finds_a_comparison_in_another_module(text, hits):
    assert len(model_name_comparisons(sources={"simulate/loop/engine.py": text})) == hits
    # the servo's own module may compare its name
    assert model_name_comparisons(sources={"simulate/components/control/discrete_servo.py":
                                           'x = m == "discrete"\n'}) == []
    # and the module of the characteristics' kinds may compare theirs
    assert model_name_comparisons(sources={"simulate/components/turbine/kinds.py": 'x = m == "ideal"\n'}) == []


def test_a_penstock_model_is_asked_its_traits_not_its_name():
    """What the code needs of a penstock model is its registry entry's traits: the MOC grid fixes the step and
    computes branches; the rigid column carries no waves and is lumped; an unknown model is refused naming the
    choices; a model registered without traits says so (the failing case)."""
    from hillchart.errors import InputError
    from simulate.components.registry import ConduitTraits, Registry

    moc, rigid = PENSTOCKS.traits("moc"), PENSTOCKS.traits("rigid")
    assert moc.grid_fixes_time_step and moc.computes_branches and moc.carries_waves and not moc.lumped_column
    assert not rigid.grid_fixes_time_step and not rigid.carries_waves and rigid.lumped_column
    assert [PENSTOCKS.traits(n).lumped_column for n in PENSTOCKS.names()] == [False, False, True, True]
    with pytest.raises(InputError, match="penstock.model must be one of moc, zdomain, lumped, rigid; got 'pipe'"):
        PENSTOCKS.traits("pipe")
    mine = Registry("penstock", "penstock.model", {"moc": "simulate.components.hydraulic.penstock:build_moc"})
    with pytest.raises(TypeError, match="its registry entry declares no traits"):
        mine.traits("moc")
    mine.register("mine", "simulate.components.hydraulic.penstock:build_rigid",
                  ConduitTraits(grid_fixes_time_step=False, carries_waves=False, lumped_column=True,
                                computes_branches=False))
    assert mine.traits("mine").lumped_column
