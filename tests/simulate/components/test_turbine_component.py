"""The turbine component: characteristic kinds behind one contract, a plant's characteristics loaded once (a nets.json
read once), an explicit characteristics object overriding the plant's, and the compiled forms the loop asks."""

import json
import os
import shutil
from importlib.resources import files

import numpy as np
import pytest

from data_synthetic import PLANT_HLA339
from hillchart.characteristics import IdealTurbine
from hillchart.errors import InputError
from simulate.components.registry import CHARACTERISTICS
from simulate.components.turbine import kinds
from simulate.components.turbine.component import characteristics_of, plant_turbine
from simulate.components.turbine.evaluation import (CompiledCharacteristics, ControlKernel, PythonKernel,
                                                    TwoInputKernel, compile_characteristics)
from simulate.config import load_plant
from simulate.loop.engine import initial_state, run_simulation

SHIPPED_NETS = files("data_synthetic.francis") / "nets.json"


@pytest.fixture
def reads(monkeypatch):
    """The nets.json files read (every read goes through hillchart.nets.hill_nets.read_nets_json)."""
    import hillchart.nets.hill_nets as hill_nets

    read = hill_nets.read_nets_json
    seen = []

    def counting(path):
        seen.append(str(path))
        return read(path)

    monkeypatch.setattr(hill_nets, "read_nets_json", counting)
    return seen


@pytest.fixture
def nets_copy(tmp_path):
    path = tmp_path / "nets.json"
    shutil.copyfile(SHIPPED_NETS, path)
    return path


def test_a_run_reads_the_nets_once_and_the_plant_keeps_them(reads, nets_copy):
    plant = load_plant(PLANT_HLA339, {"turbine.characteristics": str(nets_copy), "scenario.t_end_s": 3.0})
    result = run_simulation(plant)
    assert result.success and len(reads) == 1  # the resolver of before read the file twice a run
    # the steady state and a second run of the same plant object use the characteristics it owns
    initial_state(plant)
    assert run_simulation(plant).characteristics is result.characteristics and len(reads) == 1
    # the failing case beside: a new plant object loads its own (the counter counts every read)
    again = load_plant(PLANT_HLA339, {"turbine.characteristics": str(nets_copy), "scenario.t_end_s": 3.0})
    run_simulation(again)
    assert len(reads) == 2


def test_a_changed_nets_file_is_read_again(reads, nets_copy):
    plant = load_plant(PLANT_HLA339, {"turbine.characteristics": str(nets_copy)})
    first = characteristics_of(plant)
    assert characteristics_of(plant) is first and len(reads) == 1
    stat = os.stat(nets_copy)
    os.utime(nets_copy, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))  # the file rewritten
    assert characteristics_of(plant) is not first and len(reads) == 2
    nets_copy.unlink()
    with pytest.raises(InputError, match="does not exist"):  # a nets file gone is not served from memory
        characteristics_of(plant)


def test_an_explicit_object_overrides_the_plants(reads, nets_copy):
    plant = load_plant(PLANT_HLA339, {"turbine.characteristics": str(nets_copy), "scenario.t_end_s": 3.0})
    mine = IdealTurbine(q11_max_m3_s=0.7, opening_max=plant.turbine.opening_max, efficiency=0.9)
    assert plant_turbine(plant, mine).characteristics is mine and plant_turbine(plant, mine).kind is None
    assert run_simulation(plant, mine).characteristics is mine and reads == []
    turbine = plant_turbine(plant)
    assert turbine.kind == "nets" and turbine.path == nets_copy and len(reads) == 1


def _document(path=SHIPPED_NETS):
    return json.loads(path.read_text(encoding="utf-8"))


def test_each_file_kind_claims_its_own_documents():
    two = _document()
    three = json.loads(json.dumps(two))
    three["flow"]["inputs"] = ["n11", "opening", "blade_angle"]
    assert kinds.TWO_INPUT_NETS.owns(two) and not kinds.THREE_INPUT_NETS.owns(two)
    assert kinds.THREE_INPUT_NETS.owns(three) and not kinds.TWO_INPUT_NETS.owns(three)
    # a hillsim.nets file without inputs is the two-input kind's (its loader names what is missing)
    del two["flow"]["inputs"]
    assert kinds.TWO_INPUT_NETS.owns(two)
    for other in ([1, 2], {"format": "hillsim.suter"}, "text"):
        assert not any(kinds.kind_of(n).owns(other) for n in CHARACTERISTICS.names()), other
    assert kinds.word_kinds() == ("ideal", "synthetic", "synthetic-bulb", "synthetic-pump-turbine")
    # the four-quadrant kinds claim their own formats and nothing else
    suter = _document(SHIPPED_NETS.parents[1] / "pump_turbine" / "nets.json")
    assert [n for n in CHARACTERISTICS.names() if kinds.kind_of(n).owns(suter)] == ["suter-nets"]
    curves = {"format": "hillsim.suter_curves"}
    assert [n for n in CHARACTERISTICS.names() if kinds.kind_of(n).owns(curves)] == ["suter-curves"]


def test_a_file_no_kind_claims_is_refused_naming_the_kinds(tmp_path):
    path = tmp_path / "suter.json"
    path.write_text(json.dumps({"format": "hillsim.suter", "flow": {"inputs": ["theta"]}}), encoding="utf-8")
    with pytest.raises(InputError, match=r"turbine.characteristics = '.*suter.json': no registered kind of "
                                         r"characteristics reads .* \(format 'hillsim.suter', flow inputs "
                                         r"\['theta'\]\); the kinds read: nets: two-input nets .*; nets-3: "
                                         r"three-input nets"):
        kinds.resolve_characteristics(str(path))
    # the same file as a hillsim.nets two-input file is claimed and its loader says what is wrong
    path.write_text(json.dumps({"format": "hillsim.nets"}), encoding="utf-8")
    with pytest.raises(InputError, match=r"suter.json: key 'version' is missing"):
        kinds.resolve_characteristics(str(path))


def test_the_three_input_kind_reads_the_bulb_nets():
    plant = load_plant(files("data_synthetic") / "plant_bulb.toml")
    turbine = plant_turbine(plant)
    assert turbine.kind == "nets-3" and type(turbine.characteristics).__name__ == "DoubleRegulatedNets"


def test_a_word_kind_refuses_what_it_cannot_be():
    with pytest.raises(InputError, match="NETS = 'ideal' needs the plant's rated values"):
        kinds.resolve_characteristics("ideal", key="NETS")
    with pytest.raises(TypeError, match="chosen by its word; it defines no read"):
        kinds.IDEAL.read({}, None)
    with pytest.raises(TypeError, match="read from a nets.json; it defines no load"):
        kinds.TWO_INPUT_NETS.load(None)


class _PythonOnly:
    """The four methods of an ideal turbine, no numba kernel."""

    def __init__(self):
        self.inner = IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.9)

    def q11(self, n11, a):
        return self.inner.q11(n11, a)

    def m11(self, n11, a):
        return self.inner.m11(n11, a)

    def q11_grad(self, n11, a):
        return self.inner.q11_grad(n11, a)

    def m11_grad(self, n11, a):
        return self.inner.m11_grad(n11, a)


def test_the_compiled_form_follows_what_the_object_offers():
    ideal = IdealTurbine(q11_max_m3_s=0.6, opening_max=30.0, efficiency=0.9)
    two = compile_characteristics(ideal)
    python = compile_characteristics(_PythonOnly())
    assert type(two) is TwoInputKernel and two.jitted and type(python) is PythonKernel and not python.jitted
    controls = np.array([15.0])
    # both forms give the loop (q11, dq11/dn11, m11, dm11/dn11) of the same turbine: the same formulas in numpy and
    # in the numba kernel's Python function (1e-12 relative for the order of operations)
    assert np.allclose(two.python_kernel()(two.params, 70.0, controls),
                       python.python_kernel()(python.params, 70.0, controls), rtol=1e-12, atol=0.0)
    assert two.python_kernel()(two.params, 70.0, controls)[0] == pytest.approx(0.3, rel=1e-15)
    lines = two.loop_lines(lambda func, alias: f"from {func.__module__} import {func.__name__} as {alias}", set())
    assert "    out = _characteristics_kernel(params, n11, controls[0])" in lines
    assert python.loop_lines(None, set())[0].startswith("kernel = None")
    assert two.identity() != python.identity()


def test_the_double_regulated_view_compiles_on_the_control_vector():
    from simulate.loop.engine import plant_characteristics

    plant = load_plant(files("data_synthetic") / "plant_bulb.toml")
    assert type(compile_characteristics(plant_characteristics(plant, characteristics_of(plant)))) is ControlKernel


def test_an_object_may_bring_its_own_compiled_form():
    class Own(_PythonOnly):
        def compiled_characteristics(self):
            return self.form

    own = Own()
    own.form = PythonKernel(lambda params, n11, a: (0.0,) * 6, ())
    assert compile_characteristics(own) is own.form
    own.form = "two-input"  # the failing case: not a compiled form
    with pytest.raises(TypeError, match="compiled_characteristics\\(\\) must return a CompiledCharacteristics, got "
                                        "str"):
        compile_characteristics(own)
    with pytest.raises(NotImplementedError, match="must define loop_lines"):
        CompiledCharacteristics(None, ()).loop_lines(None, set())


def test_the_loop_template_names_no_turbine_function():
    """The template calls the turbine boundary by role (``u{i}_turbine_step``) and pastes no turbine function by
    name; the generated text of a plant binds the roles to the pressure loop's step (pasted) and signals (imported).
    The failing case: the call the template made before the boundary was a part is found by the same search."""
    import re

    from simulate.loop import generator

    bare = re.compile(r"(?<![\w}])turbine_(step|signals)\(")
    for template in (generator._HEAD, generator._STEP, generator._UNIT_SUBSTEP, generator._UNIT_TURBINE):
        assert not bare.search(template)
    assert bare.search("        status, it{i} = turbine_step(tb{i}, ch{i}, tb{i}_s, c_l{i} - c_m{i}, ...)")
    assert generator.UNIT_ROLES["turbine_step"] == ("turbine", "step")
    assert generator.UNIT_ROLES["turbine_signals"] == ("turbine", "signals")


def test_a_boundary_part_that_breaks_the_contract_is_refused():
    """check_boundary: a part of another kind, a part without ``signals``, a ``signals`` with three parameters; the
    pressure loop's own part passes."""
    from simulate.components.registry import CompiledPart
    from simulate.components.turbine.boundary import build_pressure_loop, turbine_signals
    from simulate.components.turbine.component import BoundaryInputs, check_boundary

    plant = load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal"})
    chars = characteristics_of(plant)
    good = build_pressure_loop(BoundaryInputs(turbine=plant.turbine, solver=plant.solver, characteristics=chars,
                                              compiled=compile_characteristics(chars), steady=initial_state(plant),
                                              n_controls=1, head_floor_m=0.0178, closed_stroke=1e-6))
    check_boundary(good, "kind 'ideal'")  # passes
    with pytest.raises(TypeError, match="kind 'x': its boundary builder must return a CompiledPart of kind "
                                        "'turbine', got a part of kind 'shaft'"):
        check_boundary(CompiledPart("shaft", "swing", {}, (), ()), "kind 'x'")
    with pytest.raises(TypeError, match=r"kind 'x': its boundary 'v' has no 'signals' function; the loop calls "
                                        r"signals\(p, s\)"):
        check_boundary(CompiledPart("turbine", "v", {"step": good.functions["step"]}, (), ()), "kind 'x'")

    def signals(p, s, extra):
        return turbine_signals(p, s)

    with pytest.raises(TypeError, match=r"kind 'x': its boundary 'v' 'signals' function .*signals\(p, s, extra\) "
                                        r"takes 3 parameter\(s\); the loop calls signals\(p, s\)"):
        check_boundary(CompiledPart("turbine", "v", {**good.functions, "signals": signals}, (), ()), "kind 'x'")
