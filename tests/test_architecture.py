"""The architecture, kept by tests: layers import downward only, no module imports itself back through others, and
no module grows past :data:`MAX_MODULE_LINES`.

The import graph is grimp's (the engine of import-linter), built from the source with every import statement,
function-local ones included: an import moved into a function to dodge a cycle is still a cycle here.
"""

from pathlib import Path

import grimp
import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("hillsim", "simulate", "hillchart", "data_synthetic")

#: The most lines a module of the packages or of benchmarks/ may have: past about 600 a module usually holds two
#: ideas (STYLE.md), and past this many it is split along the seam between them.
MAX_MODULE_LINES = 700
#: Modules over the limit for now, with their reason (none: a module that grows past the limit is split, or named
#: here with why it cannot be).
LONG_MODULES_ALLOWED: dict[str, str] = {}

#: Layers, top to bottom: a module may import from its own layer's package or from layers below, never above.
#: Names on one line are independent siblings of one layer (they may not import each other).
LAYERS = {
    "top": [("hillsim",), ("simulate",), ("hillchart", "data_synthetic")],
    "simulate": [
        ("simulate.studies",),
        ("simulate.identification",),
        ("simulate.loop",),
        ("simulate.config",),
        ("simulate.scenarios",),
        ("simulate.components", "simulate.results", "simulate.linear"),
    ],
    "hillchart": [
        ("hillchart.four_quadrant",),
        ("hillchart.generalization", "hillchart.fccm"),
        ("hillchart.nets",),
        ("hillchart.extension",),
        ("hillchart.synthetic", "hillchart.io"),
        ("hillchart.linearize", "hillchart.validation"),
        ("hillchart.characteristics",),  # the model law and the characteristics protocol, read by the linearization
        ("hillchart.errors", "hillchart.constants", "hillchart.lazy", "hillchart.cache"),
    ],
}


@pytest.fixture(scope="module")
def graph():
    return grimp.build_graph(*PACKAGES, cache_dir=None)


def import_cycles(graph) -> list[list[str]]:
    """Every strongly connected set of two or more modules (Tarjan's algorithm, iterative)."""
    adjacency = {m: sorted(graph.find_modules_directly_imported_by(m)) for m in sorted(graph.modules)}
    index, low, on_stack, stack, cycles, counter = {}, {}, set(), [], [], 0
    for root in adjacency:
        if root in index:
            continue
        work = [(root, iter(adjacency[root]))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(adjacency.get(child, ()))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    cycles.append(sorted(component))
    return cycles


def _layer_of(module: str, layers) -> tuple[int, str] | None:
    for depth, siblings in enumerate(layers):
        for name in siblings:
            if module == name or module.startswith(name + "."):
                return depth, name
    return None


def layer_violations(graph, layers) -> list[str]:
    """Imports that go up a layer or sideways between siblings, as 'importer -> imported'."""
    out = []
    for importer in sorted(graph.modules):
        upper = _layer_of(importer, layers)
        if upper is None:
            continue
        for imported in sorted(graph.find_modules_directly_imported_by(importer)):
            lower = _layer_of(imported, layers)
            if lower is not None and lower[1] != upper[1] and lower[0] <= upper[0]:
                out.append(f"{importer} -> {imported}")
    return out


def test_no_import_cycles(graph):
    assert import_cycles(graph) == []


@pytest.mark.parametrize("name", LAYERS)
def test_layers_import_downward_only(graph, name):
    assert layer_violations(graph, LAYERS[name]) == []


def test_every_subpackage_has_a_layer(graph):
    """A new subpackage must be placed in :data:`LAYERS` (else nothing would check its imports)."""
    for package, layers in LAYERS.items():
        if package == "top":
            continue
        children = {".".join(m.split(".")[:2]) for m in graph.modules if m.startswith(package + ".")}
        unplaced = [c for c in sorted(children) if _layer_of(c, layers) is None]
        assert unplaced == [], f"place these in LAYERS[{package!r}]"


def test_the_checks_catch_an_injected_cycle_and_an_upward_import(graph):
    """The failing case: one added import from the base layer back up makes both a cycle and a layer violation."""
    graph.add_import(importer="hillchart.errors", imported="simulate.config")
    try:
        assert any({"hillchart.errors", "simulate.config"} <= set(c) for c in import_cycles(graph))
        assert "hillchart.errors -> simulate.config" in layer_violations(graph, LAYERS["top"])
        graph.add_import(importer="simulate.components.registry", imported="simulate.loop.engine")
        assert "simulate.components.registry -> simulate.loop.engine" in layer_violations(graph, LAYERS["simulate"])
    finally:
        graph.remove_import(importer="hillchart.errors", imported="simulate.config")
        graph.remove_import(importer="simulate.components.registry", imported="simulate.loop.engine")


def long_modules(root: Path, folders, limit: int = MAX_MODULE_LINES) -> dict[str, int]:
    """``{path relative to root: lines}`` of the .py files below ``root/folder`` (each of ``folders``) that have more
    than ``limit`` lines."""
    out = {}
    for folder in folders:
        for path in sorted((root / folder).rglob("*.py")):
            lines = len(path.read_text(encoding="utf-8").splitlines())
            if lines > limit:
                out[path.relative_to(root).as_posix()] = lines
    return out


def test_no_module_is_longer_than_the_limit():
    """Every module of the packages and of benchmarks/ has at most :data:`MAX_MODULE_LINES` lines, but those of
    :data:`LONG_MODULES_ALLOWED`; an allowed one that has come under the limit leaves that list."""
    long = long_modules(REPO, (*PACKAGES, "benchmarks"))
    assert {path: n for path, n in long.items() if path not in LONG_MODULES_ALLOWED} == {}
    assert [path for path in LONG_MODULES_ALLOWED if path not in long] == [], "under the limit now: remove it"


def test_the_line_limit_catches_a_long_module(tmp_path):
    """The failing case: a fake package with a module one line over the limit beside one at the limit."""
    folder = tmp_path / "hillchart" / "sub"
    folder.mkdir(parents=True)
    (folder / "long.py").write_text("x = 1\n" * (MAX_MODULE_LINES + 1), encoding="utf-8")
    (folder / "at_the_limit.py").write_text("x = 1\n" * MAX_MODULE_LINES, encoding="utf-8")
    (tmp_path / "benchmarks").mkdir()
    (tmp_path / "benchmarks" / "bench_long.py").write_text("x = 1\n" * 2000, encoding="utf-8")
    assert long_modules(tmp_path, ("hillchart", "benchmarks")) == {"hillchart/sub/long.py": MAX_MODULE_LINES + 1,
                                                                   "benchmarks/bench_long.py": 2000}
    assert long_modules(tmp_path, ("hillchart",)) == {"hillchart/sub/long.py": MAX_MODULE_LINES + 1}


#: The plant-file reader composes the sections its components declare (simulate/components/*); past this many lines
#: it is becoming a home for components again.
MAX_CONFIG_LINES = 400


def test_the_plant_file_reader_stays_a_reader():
    lines = len((REPO / "simulate" / "config.py").read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_CONFIG_LINES, f"simulate/config.py has {lines} lines: move a section's logic to its component"
