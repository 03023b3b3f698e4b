"""The architecture holds: every module imports only from its own layer or the layers below,
and no modules import each other in a circle (docs/design.md §6).

Imports inside functions count too: a lazy import is still a dependency.
"""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "dgplate"

# lowest first; a module of layer i may import from layers 0..i
LAYERS = [
    {"compat", "errors", "interrupt", "schema", "values", "expressions", "mpi", "reference"},
    {"mesh"},
    {"dg"},
    {"solvers"},
    {"measure"},
    {"io"},
    {"coupling"},
    {"models"},
    {"problems"},
    {"cli", "demo", "__main__", "__init__"},
]


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer(module: str) -> int:
    parts = module.split(".")
    first = parts[1] if len(parts) > 1 else "__init__"
    for rank, names in enumerate(LAYERS):
        if first in names:
            return rank
    raise AssertionError(f"{module} belongs to no layer: add it to LAYERS")


def imports(path: Path, known: set[str]) -> set[str]:
    """The dgplate modules that ``path`` imports (``from dgplate import x`` → dgplate.x)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] != "dgplate":
                continue
            for alias in node.names:
                child = f"{node.module}.{alias.name}"
                found.add(child if child in known else node.module)
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "dgplate"}
    return found


def graph() -> dict[str, set[str]]:
    paths = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    known = set(paths)
    return {name: imports(path, known) - {name} for name, path in paths.items()}


def test_every_module_has_a_layer():
    for module in graph():
        layer(module)


def test_no_module_imports_from_a_layer_above_it():
    upward = [
        f"{module} (layer {layer(module)}) imports {target} (layer {layer(target)})"
        for module, targets in graph().items()
        for target in targets
        if target != "dgplate" and layer(target) > layer(module)
    ]
    assert not upward, "\n".join(upward)


def test_no_import_circles():
    edges = {m: {t for t in ts if t != "dgplate"} for m, ts in graph().items()}
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    circles = []

    def visit(module: str, path: list[str]) -> None:
        state[module] = 1
        for target in sorted(edges.get(module, ())):
            if state.get(target) == 1:
                circles.append(" → ".join([*path[path.index(target) :], target]))
            elif target not in state:
                visit(target, [*path, target])
        state[module] = 2

    for module in sorted(edges):
        if module not in state:
            visit(module, [module])
    assert not circles, "\n".join(circles)
