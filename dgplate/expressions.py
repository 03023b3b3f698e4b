"""Safe expressions of the reference coordinates, written in problem files.

A problem file may give a load, a spontaneous curvature or a heat source as a formula in
``x``, ``y`` (or ``x[0]``, ``x[1]``), ``t`` and named parameters, e.g. ``"0.1*sin(pi*x)"``. The
text is parsed with :mod:`ast` and only numbers, the names above, arithmetic, comparisons and
a fixed set of functions are accepted; nothing is ever passed to ``eval``. The result is a UFL
expression, so it enters the forms exactly.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Mapping
from typing import Any

import ufl

from dgplate.errors import InputError

_FUNCTIONS: dict[str, Callable[..., Any]] = {
    "sin": ufl.sin,
    "cos": ufl.cos,
    "tan": ufl.tan,
    "exp": ufl.exp,
    "ln": ufl.ln,
    "log": ufl.ln,
    "sqrt": ufl.sqrt,
    "abs": abs,
    "tanh": ufl.tanh,
    "atan": ufl.atan,
    "atan2": ufl.atan2,
    "min": ufl.min_value,
    "max": ufl.max_value,
    "where": ufl.conditional,
}
_BINARY = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_COMPARE = {
    ast.Lt: ufl.lt,
    ast.LtE: ufl.le,
    ast.Gt: ufl.gt,
    ast.GtE: ufl.ge,
}
_CONSTANTS = {"pi": math.pi, "e": math.e}


def parse(
    text: str | float | int,
    x,
    key: str,
    names: Mapping[str, Any] | None = None,
):
    """The UFL expression of ``text`` (a number passes through).

    ``x`` is ``ufl.SpatialCoordinate(mesh)``; ``names`` adds symbols such as ``t``; ``key`` is
    the problem-file key, named in the error message when the text is not acceptable.
    """
    if isinstance(text, bool):
        raise InputError(f"{key} must be a number or a formula string, got {text!r}")
    if isinstance(text, int | float):
        return float(text)
    if not isinstance(text, str):
        raise InputError(f"{key} must be a number or a formula string, got {text!r}")
    symbols: dict[str, Any] = {"x": x[0], "y": x[1], **_CONSTANTS, **(names or {})}
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as err:
        raise InputError(f"{key}: cannot parse formula {text!r}: {err.msg}") from None
    return _Builder(symbols, x, key, text).visit(tree.body)


class _Builder(ast.NodeVisitor):
    def __init__(self, symbols: dict[str, Any], x, key: str, text: str):
        self.symbols, self.x, self.key, self.text = symbols, x, key, text

    def fail(self, what: str):
        raise InputError(f"{self.key}: {what} is not allowed in formula {self.text!r}")

    def generic_visit(self, node):
        self.fail(type(node).__name__)

    def visit_Constant(self, node: ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, int | float):
            self.fail(f"the constant {node.value!r}")
        return float(node.value)

    def visit_Name(self, node: ast.Name):
        if node.id not in self.symbols:
            known = ", ".join(sorted(self.symbols))
            raise InputError(
                f"{self.key}: unknown name '{node.id}' in {self.text!r} (known: {known})"
            )
        return self.symbols[node.id]

    def visit_Subscript(self, node: ast.Subscript):
        if not (isinstance(node.value, ast.Name) and node.value.id == "x"):
            self.fail("indexing anything but x")
        index = node.slice
        if not (isinstance(index, ast.Constant) and index.value in (0, 1)):
            self.fail("an index other than x[0] or x[1]")
        return self.x[index.value]

    def visit_BinOp(self, node: ast.BinOp):
        op = _BINARY.get(type(node.op))
        if op is None:
            self.fail(f"the operator {type(node.op).__name__}")
        return op(self.visit(node.left), self.visit(node.right))

    def visit_UnaryOp(self, node: ast.UnaryOp):
        if isinstance(node.op, ast.USub):
            return -self.visit(node.operand)
        if isinstance(node.op, ast.UAdd):
            return self.visit(node.operand)
        self.fail(f"the operator {type(node.op).__name__}")

    def visit_Compare(self, node: ast.Compare):
        if len(node.ops) != 1 or type(node.ops[0]) not in _COMPARE:
            self.fail("a chained or equality comparison")
        return _COMPARE[type(node.ops[0])](self.visit(node.left), self.visit(node.comparators[0]))

    def visit_Call(self, node: ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in _FUNCTIONS:
            known = ", ".join(sorted(_FUNCTIONS))
            name = getattr(node.func, "id", "this call")
            raise InputError(
                f"{self.key}: unknown function '{name}' in {self.text!r} (known: {known})"
            )
        if node.keywords:
            self.fail("a keyword argument")
        return _FUNCTIONS[node.func.id](*(self.visit(arg) for arg in node.args))


def parse_vector(values, x, key: str, size: int, names: Mapping[str, Any] | None = None):
    """A UFL vector from a list of numbers/formulas of the given size."""
    if not isinstance(values, list | tuple) or len(values) != size:
        raise InputError(f"{key} must be a list of {size} numbers or formulas, got {values!r}")
    return ufl.as_vector([parse(v, x, f"{key}[{i}]", names) for i, v in enumerate(values)])


def is_constant(values) -> bool:
    """True when no entry is a formula string."""
    if isinstance(values, list | tuple):
        return all(is_constant(v) for v in values)
    return not isinstance(values, str)
