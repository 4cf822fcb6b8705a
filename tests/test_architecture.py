"""The architecture, kept by tests: layers import downward only, and no module imports itself back through others.

The import graph is grimp's (the engine of import-linter), built from the source with every import statement,
function-local ones included: an import moved into a function to dodge a cycle is still a cycle here.
"""

import grimp
import pytest

PACKAGES = ("hillsim", "simulate", "hillchart", "data_synthetic")

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
        ("hillchart.generalization", "hillchart.fccm"),
        ("hillchart.nets",),
        ("hillchart.extension",),
        ("hillchart.synthetic", "hillchart.io"),
        ("hillchart.linearize", "hillchart.characteristics", "hillchart.validation"),
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
