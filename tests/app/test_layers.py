"""The architecture holds: every module imports only from its own layer or the layers below,
and no modules import each other in a circle (docs/design.md §6).

Imports inside functions count too: a lazy import is still a dependency.
"""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "dgplate"

# lowest first; a module of layer i may import from layers 0..i
LAYERS = [
    {
        "compat",
        "errors",
        "interrupt",
        "schema",
        "units",
        "values",
        "expressions",
        "mpi",
        "reference",
    },
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


def test_no_import_circles() -> None:
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


def design_table() -> dict[str, set[str]]:
    """docs/design.md §6's layer table: package folder ('' for the base and top) → modules."""
    text = (PACKAGE.parent / "docs" / "design.md").read_text()
    rows: dict[str, set[str]] = {}
    for line in text.split("### Layers", 1)[1].split("### ", 1)[0].splitlines():
        cells = line.split("|")
        if len(cells) < 4 or not cells[2].strip().startswith("`"):
            continue
        folder = cells[1].strip().strip("`")
        folder = folder.rstrip("/") if folder.endswith("/") else ""
        names = {n.strip().strip("`").removeprefix("dgplate/") for n in cells[2].split(",")}
        rows.setdefault(folder, set()).update(names)
    return rows


def test_design_lists_every_module_and_no_other() -> None:
    """The layer table of docs/design.md §6 names every module of the package, and only those."""
    listed = design_table()
    actual: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        if len(parts) == 1:
            actual.setdefault("", set()).add(parts[0])
        elif parts[0] == "reference":  # listed as a whole: `reference/`
            actual.setdefault("", set()).add("reference/")
        elif parts[-1] != "__init__":  # a module of a package below it: `fvk/spec`
            actual.setdefault(parts[0], set()).add("/".join(parts[1:]))
    assert listed == actual
