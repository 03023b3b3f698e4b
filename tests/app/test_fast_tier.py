"""The fast tier's list (tests/slow_tests.txt) names tests that exist."""

import ast
from pathlib import Path

import pytest
from conftest import SLOW_TESTS, slow_test_ids

ROOT = SLOW_TESTS.parent.parent


def defined_tests(path: Path) -> set[str]:
    """The test functions of a module."""
    tree = ast.parse(path.read_text())
    return {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}


@pytest.mark.parametrize("node", sorted(slow_test_ids()))
def test_listed_slow_test_exists(node):
    path, name = node.split("::", 1)
    assert (ROOT / path).is_file(), f"slow_tests.txt: {path} does not exist"
    assert name.split("[", 1)[0] in defined_tests(ROOT / path), f"slow_tests.txt: {node}"
