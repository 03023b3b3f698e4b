"""Safe expressions of the reference coordinates, written in problem files.

A problem file may give a load, a spontaneous curvature or a heat source as a formula in
``x``, ``y`` (or ``x[0]``, ``x[1]``), ``t`` and named parameters, e.g. ``"0.1*sin(pi*x)"``. The
text is parsed with :mod:`ast` and only numbers, the names above, arithmetic, comparisons (as
the condition of ``where``) and a fixed set of functions are accepted; nothing is ever passed to
``eval``. The result is a UFL expression, so it enters the forms exactly.

The same walk of the syntax tree also evaluates a formula with NumPy: :func:`check` does so
without a mesh when a problem file is validated (syntax, allowed calls, constant overflow,
division by zero), and :func:`parse` at the mesh's vertices and cell midpoints before it builds
the UFL expression, so that a formula that is not finite on the plate (``sqrt(-1-x)``) is an
``InputError`` naming its key instead of NaNs in the forms or a compiler error.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

from mpi4py import MPI

import numpy as np
import ufl

from dgplate import compat
from dgplate.errors import InputError


class _Function(NamedTuple):
    arity: int
    ufl: Callable[..., Any]
    numpy: Callable[..., Any]


_FUNCTIONS: dict[str, _Function] = {
    "sin": _Function(1, ufl.sin, np.sin),
    "cos": _Function(1, ufl.cos, np.cos),
    "tan": _Function(1, ufl.tan, np.tan),
    "exp": _Function(1, ufl.exp, np.exp),
    "ln": _Function(1, ufl.ln, np.log),
    "log": _Function(1, ufl.ln, np.log),
    "sqrt": _Function(1, ufl.sqrt, np.sqrt),
    "abs": _Function(1, abs, np.abs),
    "tanh": _Function(1, ufl.tanh, np.tanh),
    "atan": _Function(1, ufl.atan, np.arctan),
    "atan2": _Function(2, ufl.atan2, np.arctan2),
    "min": _Function(2, ufl.min_value, np.minimum),
    "max": _Function(2, ufl.max_value, np.maximum),
    "where": _Function(3, ufl.conditional, np.where),
}
_ALLOWED = ", ".join(sorted(_FUNCTIONS))
_BINARY = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_COMPARE = {  # (UFL, NumPy)
    ast.Lt: (ufl.lt, np.less),
    ast.LtE: (ufl.le, np.less_equal),
    ast.Gt: (ufl.gt, np.greater),
    ast.GtE: (ufl.ge, np.greater_equal),
}
_CONSTANTS = {"pi": math.pi, "e": math.e}


def _shown(text: str) -> str:
    """A formula as quoted in messages (long ones shortened: messages are one line)."""
    return repr(text) if len(text) <= 80 else repr(text[:60]) + "…"


def _literal(text: Any, key: str) -> float | str:
    """A finite number as float, or a formula string; anything else is an InputError."""
    if isinstance(text, str):
        return text
    if isinstance(text, int | float) and not isinstance(text, bool):
        value = float(text)
        if not math.isfinite(value):
            raise InputError(f"{key} must be a finite number, got {text!r}")
        return value
    raise InputError(f"{key} must be a number or a formula string, got {text!r}")


def parse(text: str | float | int, mesh, key: str, names: Mapping[str, Any] | None = None):
    """The UFL expression of ``text`` on ``mesh`` (a number passes through as a float).

    ``names`` adds symbols such as ``t``; ``key`` is the problem-file key, named in the error
    message when the text is not acceptable. A formula is first evaluated at
    :func:`sample_points` of the mesh and must be finite there; collective on ``mesh.comm``
    for formulas (every rank parses the same data).
    """
    value = _literal(text, key)
    if isinstance(value, float):
        return value
    _check_finite_on_mesh(value, mesh, key, names)
    x = ufl.SpatialCoordinate(mesh)
    builder = _Builder(key, value, (x[0], x[1]), names or {}, numeric=False)
    try:
        return builder.build()
    except InputError:
        raise
    except (ArithmeticError, ValueError, TypeError) as err:  # what UFL raises on odd input
        raise InputError(f"{key}: cannot build formula {_shown(value)}: {err}") from None


def parse_vector(values, mesh, key: str, size: int, names: Mapping[str, Any] | None = None):
    """A UFL vector from a list of numbers/formulas of the given size."""
    if not isinstance(values, list | tuple) or len(values) != size:
        raise InputError(f"{key} must be a list of {size} numbers or formulas, got {values!r}")
    return ufl.as_vector([parse(v, mesh, f"{key}[{i}]", names) for i, v in enumerate(values)])


def check(value: Any, key: str, names: Mapping[str, Any] | None = None) -> None:
    """Validate a number, a formula, or (nested) lists of them, without a mesh.

    Catches what does not depend on the domain: syntax, disallowed names and calls, constant
    overflow, division by zero, constant parts that are not finite (``sqrt(-1)``). Nested
    entries are named ``key[i]``.
    """
    if isinstance(value, list | tuple):
        for i, entry in enumerate(value):
            check(entry, f"{key}[{i}]", names)
        return
    text = _literal(value, key)
    if isinstance(text, str):
        placeholders = dict.fromkeys(names or {}, np.empty(0))
        evaluate(text, np.empty((0, 2)), key, placeholders)


def evaluate(
    text: str, points: np.ndarray, key: str, names: Mapping[str, Any] | None = None
) -> np.ndarray | None:
    """The formula's values at ``points`` (shape (n, 2)); a scalar when it is a constant.

    None when a name has no numeric value (e.g. a UFL constant), so it cannot be evaluated.
    """
    numeric: dict[str, Any] = {}
    for name, value in (names or {}).items():
        if isinstance(value, np.ndarray) or (
            isinstance(value, int | float) and not isinstance(value, bool)
        ):
            numeric[name] = value
        else:
            return None
    coords = (points[:, 0], points[:, 1])
    with np.errstate(all="ignore"):
        return np.asarray(_Builder(key, text, coords, numeric, numeric=True).build())


def sample_points(mesh) -> np.ndarray:
    """This rank's geometry nodes and cell midpoints (ghosts included), shape (n, 2)."""
    x = mesh.geometry.x
    midpoints = x[compat.geometry_dofmap(mesh)].mean(axis=1)
    return np.vstack([x, midpoints])[:, :2]


def agree(a: Any, b: Any, mesh, key: str = "value") -> bool:
    """True when two numbers or formulas are equal at every sample point (collective).

    False when one cannot be evaluated numerically; an InputError when one is not valid.
    """
    points = sample_points(mesh)
    first, second = (_values_at(v, points, key) for v in (a, b))
    local = first is not None and second is not None and bool(np.array_equal(first, second))
    return bool(mesh.comm.allreduce(local, op=MPI.LAND))


def _values_at(value: Any, points: np.ndarray, key: str) -> np.ndarray | None:
    text = _literal(value, key)
    values = text if isinstance(text, float) else evaluate(text, points, key)
    return None if values is None else np.broadcast_to(values, len(points))


def _check_finite_on_mesh(text: str, mesh, key: str, names: Mapping[str, Any] | None) -> None:
    """InputError (on every rank) when the formula is not finite at some sample point."""
    points = sample_points(mesh)
    values = evaluate(text, points, key, names)
    bad = None
    if values is not None:
        values = np.broadcast_to(values, len(points))
        where = np.flatnonzero(~np.isfinite(values))
        if where.size:
            i = where[0]
            bad = (float(values[i]), float(points[i, 0]), float(points[i, 1]))
    found = [b for b in mesh.comm.allgather(bad) if b is not None]
    if found:
        value, px, py = found[0]
        raise InputError(
            f"{key}: formula {_shown(text)} is not finite on the plate: {value} at "
            f"(x, y) = ({px:.6g}, {py:.6g})"
        )


class _Builder(ast.NodeVisitor):
    """One walk of a formula's syntax tree: UFL operators, or NumPy ones (``numeric``).

    Constants are folded as Python floats in both cases, so a constant that overflows,
    divides by zero or is not real fails the same way with or without a mesh.
    """

    def __init__(self, key: str, text: str, coords: tuple, names: Mapping[str, Any], numeric: bool):
        self.key, self.text, self.coords, self.numeric = key, text, coords, numeric
        self.shown = _shown(text)
        self.symbols: dict[str, Any] = {"x": coords[0], "y": coords[1], **_CONSTANTS, **names}

    def build(self):
        try:
            tree = ast.parse(self.text.strip(), mode="eval")
        except (SyntaxError, ValueError) as err:
            reason = err.msg if isinstance(err, SyntaxError) else str(err).split(";")[0]
            raise InputError(f"{self.key}: cannot parse formula {self.shown}: {reason}") from None
        except (RecursionError, MemoryError):
            self.fail("nesting this deep")
        try:
            return self.visit(tree.body)
        except RecursionError:
            self.fail("nesting this deep")

    def fail(self, what: str):
        raise InputError(f"{self.key}: {what} is not allowed in formula {self.shown}")

    def not_finite(self, what: str):
        raise InputError(f"{self.key}: formula {self.shown} {what}")

    def generic_visit(self, node):
        self.fail(type(node).__name__)

    def visit_Constant(self, node: ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, int | float):
            self.fail(f"the constant {node.value!r}")
        try:
            value = float(node.value)
        except OverflowError:
            self.not_finite("overflows: an integer constant beyond ±1.8e308")
        if not math.isfinite(value):
            self.not_finite(f"overflows: the number {value} is not finite")
        return value

    def visit_Name(self, node: ast.Name):
        if node.id not in self.symbols:
            known = ", ".join(sorted(self.symbols))
            raise InputError(
                f"{self.key}: unknown name '{node.id}' in {self.shown} (known: {known})"
            )
        return self.symbols[node.id]

    def visit_Attribute(self, node: ast.Attribute):
        self.fail(f"attribute access '{ast.unparse(node)}'")

    def visit_Subscript(self, node: ast.Subscript):
        if not (isinstance(node.value, ast.Name) and node.value.id == "x"):
            self.fail("indexing anything but x")
        index = node.slice
        if not (isinstance(index, ast.Constant) and index.value in (0, 1)):
            self.fail("an index other than x[0] or x[1]")
        return self.coords[index.value]

    def visit_BinOp(self, node: ast.BinOp):
        op = _BINARY.get(type(node.op))
        if op is None:
            self.fail(f"the operator {type(node.op).__name__}")
        left, right = self.visit(node.left), self.visit(node.right)
        if op is operator.truediv and isinstance(right, float) and right == 0.0:
            self.not_finite("divides by zero")
        if not (isinstance(left, float) and isinstance(right, float)):
            return op(left, right)
        try:  # constant folding, as Python floats
            value = op(left, right)
        except OverflowError:
            self.not_finite("overflows (beyond ±1.8e308)")
        except ZeroDivisionError:
            self.not_finite("divides by zero")
        if isinstance(value, complex):
            self.not_finite(f"is not a real number ({left!r} ** {right!r})")
        if not math.isfinite(value):
            self.not_finite("overflows (beyond ±1.8e308)")
        return value

    def visit_UnaryOp(self, node: ast.UnaryOp):
        if isinstance(node.op, ast.USub):
            return -self.visit(node.operand)
        if isinstance(node.op, ast.UAdd):
            return self.visit(node.operand)
        self.fail(f"the operator {type(node.op).__name__}")

    def visit_Compare(self, node: ast.Compare):
        self.fail("a comparison outside the condition of where(condition, a, b)")

    def condition(self, node: ast.expr):
        """The first argument of ``where``: one comparison <, <=, > or >=."""
        if not isinstance(node, ast.Compare):
            self.fail("a condition that is not a comparison (<, <=, >, >=) in where()")
        if len(node.ops) != 1 or type(node.ops[0]) not in _COMPARE:
            self.fail("a chained or equality comparison")
        compare = _COMPARE[type(node.ops[0])][self.numeric]
        return compare(self.visit(node.left), self.visit(node.comparators[0]))

    def visit_Call(self, node: ast.Call):
        func = node.func
        if not (isinstance(func, ast.Name) and func.id in _FUNCTIONS):
            what = "a lambda" if isinstance(func, ast.Lambda) else f"'{ast.unparse(func)[:40]}'"
            raise InputError(
                f"{self.key}: calling {what} is not allowed in formula {self.shown} "
                f"(allowed functions: {_ALLOWED})"
            )
        if node.keywords or any(isinstance(arg, ast.Starred) for arg in node.args):
            self.fail("a keyword or starred argument")
        function = _FUNCTIONS[func.id]
        if len(node.args) != function.arity:
            self.fail(f"{func.id}() with {len(node.args)} argument(s) (it takes {function.arity})")
        args = list(node.args)
        values = [self.condition(args.pop(0))] if func.id == "where" else []
        values += [self.visit(arg) for arg in args]
        if all(isinstance(v, float) for v in values):  # a constant: finite and real, or refused
            with np.errstate(all="ignore"):
                folded = function.numpy(*values)
            if np.iscomplexobj(folded) or not np.isfinite(folded):
                args_text = ", ".join(f"{float(v):g}" for v in values)
                self.not_finite(f"is not finite: {func.id}({args_text}) = {folded}")
        return (function.numpy if self.numeric else function.ufl)(*values)


def is_constant(values) -> bool:
    """True when no entry is a formula string."""
    if isinstance(values, list | tuple):
        return all(is_constant(v) for v in values)
    return not isinstance(values, str)
