"""No class over 300 lines and no module over 500 lines in dgplate/ (docs/design.md §6).

A module that may not be split at once would be listed in LARGER_MODULES with its size: it
may only shrink, and its entry goes once it is within the limit. None is listed today.
"""

import ast
from pathlib import Path
from typing import cast

PACKAGE = Path(__file__).resolve().parents[2] / "dgplate"
MODULE_LINES, CLASS_LINES = 500, 300

#: Larger modules allowed for now (path below dgplate/: lines): none.
LARGER_MODULES: dict[str, int] = {}


def module_sizes(root: Path) -> dict[str, int]:
    return {
        path.relative_to(root).as_posix(): len(path.read_text().splitlines())
        for path in sorted(root.rglob("*.py"))
    }


def oversized(root: Path, larger: dict[str, int]) -> list[str]:
    """Modules over their limit and classes over theirs, one line each."""
    found = [
        f"{path}: {lines} lines, at most {larger.get(path, MODULE_LINES)}"
        for path, lines in module_sizes(root).items()
        if lines > larger.get(path, MODULE_LINES)
    ]
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.ClassDef):
                continue
            lines = cast(int, node.end_lineno) - node.lineno + 1  # ast.parse sets end_lineno
            if lines > CLASS_LINES:
                found.append(f"{path.relative_to(root).as_posix()}::{node.name}: {lines} lines")
    return found


def test_no_module_or_class_over_its_limit():
    over = oversized(PACKAGE, LARGER_MODULES)
    assert not over, "\n".join(over)


def stale(sizes: dict[str, int], larger: dict[str, int]) -> list[str]:
    """The listed modules that are within the limit now, or gone."""
    return [path for path in larger if sizes.get(path, 0) <= MODULE_LINES]


def test_the_larger_modules_are_still_larger():
    found = stale(module_sizes(PACKAGE), LARGER_MODULES)
    assert not found, f"within {MODULE_LINES} lines now, remove from LARGER_MODULES: {found}"


def test_a_shrunk_or_removed_module_is_stale():
    sizes = {"big.py": 600, "shrunk.py": 500}
    larger = {"big.py": 600, "shrunk.py": 510, "gone.py": 700}
    assert stale(sizes, larger) == ["shrunk.py", "gone.py"]
    assert stale(sizes, {}) == []


def test_a_grown_module_and_a_large_class_are_caught(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "big.py").write_text("x = 1\n" * (MODULE_LINES + 1))
    (tmp_path / "listed.py").write_text("x = 1\n" * 600)
    body = "class Large:\n" + "    x = 1\n" * CLASS_LINES
    (tmp_path / "classes.py").write_text(body + "\n\nclass Small:\n    x = 1\n")
    assert oversized(tmp_path, {"listed.py": 600}) == [
        "sub/big.py: 501 lines, at most 500",
        "classes.py::Large: 301 lines",
    ]
    assert oversized(tmp_path, {"listed.py": 599})[0] == "listed.py: 600 lines, at most 599"
