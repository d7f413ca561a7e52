"""The package's layers hold: no import circle and no import of a higher layer, counting the imports
inside functions too (docs/developer.md, "Layers"); in ``dsmv/cel/`` a per-dimension file imports
no file of the other dimension."""

from __future__ import annotations

import ast
from pathlib import Path

import dsmv

PACKAGE = Path(dsmv.__file__).parent
#: the layers from the bottom up (docs/developer.md); a module's layer is its package's, or its own
#: name's for a top-level module
LAYERS = [
    {"dsmv", "errors", "registry", "results", "convergence", "numba_cache"},
    {"config"},
    {"soil_law"},
    {"analytic"},
    {"cel"},
    {"post", "safety"},
    {"tracking"},
    {"surrogate"},
    {"calibration"},
    {"app", "__main__"},
    {"verify"},
    {"testing"},
]


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def dsmv_imports(path: Path) -> set[str]:
    """The dsmv modules a file imports, anywhere in it (a name imported from a package counts as its
    module when it is one)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "dsmv"}
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "dsmv":
            found.add(node.module)
            found |= {f"{node.module}.{a.name}" for a in node.names}
    return found


def graph() -> dict[str, set[str]]:
    files = {module_name(p): p for p in PACKAGE.rglob("*.py") if "conf" not in p.relative_to(PACKAGE).parts}
    return {name: {m for m in dsmv_imports(path) if m in files and m != name} for name, path in files.items()}


def layer(module: str) -> int:
    parts = module.split(".")
    key = parts[1] if len(parts) > 1 else parts[0]
    return next(k for k, members in enumerate(LAYERS) if key in members)


def test_no_module_imports_a_higher_layer():
    upward = [f"{a} -> {b}" for a, targets in graph().items() for b in targets if layer(b) > layer(a)]
    assert not upward, upward


def test_no_import_circle():
    edges = graph()
    # a package's __init__ importing its own modules is how a package shows its face, not a circle
    edges = {a: {b for b in targets if not b.startswith(a + ".")} for a, targets in edges.items()}
    index, low, on_stack, stack, circles, counter = {}, {}, set(), [], [], [0]

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in edges:
        if v not in index:
            visit(v)
    assert not circles, circles


def test_a_cel_file_of_one_dimension_imports_none_of_the_other():
    edges = graph()
    for module, targets in edges.items():
        if not module.startswith("dsmv.cel"):
            continue
        for own, other in (("2d", "3d"), ("3d", "2d")):
            if module.endswith(own):
                assert not [t for t in targets if t.endswith(other)], (module, targets)
        if not module.endswith(("2d", "3d")) and module != "dsmv.cel.kernels":
            # a file that knows no dimension imports no per-dimension file (the factory excepted)
            assert not [t for t in targets if t.startswith("dsmv.cel") and t.endswith(("2d", "3d"))], (module, targets)


def test_the_checks_see_the_imports():
    """Not vacuous: the graph holds the imports every layer makes of the one below."""
    edges = graph()
    assert "dsmv.cel.solver" in edges["dsmv.cel.solver2d"]
    assert "dsmv.config.scene" in edges["dsmv.cel.solver"]
    assert "dsmv.cel.stepper" in edges["dsmv.cel.stepper3d"]
    assert sum(len(t) for t in edges.values()) > 150
