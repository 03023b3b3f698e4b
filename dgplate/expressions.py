"""Safe expressions of the reference coordinates, written in problem files.

A problem file may give a load, a spontaneous curvature or a heat source as a formula in
``x``, ``y`` (or ``x[0]``, ``x[1]``), the polar ``r`` = √(x² + y²) and ``theta`` = atan2(y, x)
(in [−π, π]: a formula in ``theta`` should be 2π-periodic, as theta jumps across the negative
x axis), ``t`` and named parameters, e.g. ``"0.1*sin(pi*x)"``. The
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
from typing import NamedTuple, NoReturn, TypeAlias

import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import compat, mpi
from dgplate.compat import Array, Mesh
from dgplate.errors import InputError
from dgplate.schema import is_number

#: What a formula evaluates to: a folded constant, a UFL expression, or NumPy values.
Value: TypeAlias = "float | Expr | Array"
#: Symbols of a formula besides x and y: UFL expressions, or numbers and arrays.
Names: TypeAlias = "Mapping[str, object]"


class _Function(NamedTuple):
    """A function allowed in formulas: its number of arguments, in UFL and in NumPy."""

    arity: int
    ufl: Callable[..., Value]
    numpy: Callable[..., Array]


_FUNCTIONS: dict[str, _Function] = {
    "sin": _Function(1, ufl.sin, np.sin),
    "cos": _Function(1, ufl.cos, np.cos),
    "tan": _Function(1, ufl.tan, np.tan),
    "exp": _Function(1, ufl.exp, np.exp),
    "ln": _Function(1, ufl.ln, np.log),
    "log": _Function(1, ufl.ln, np.log),
    "sqrt": _Function(1, ufl.sqrt, np.sqrt),
    "abs": _Function(1, abs, np.abs),
    "sinh": _Function(1, ufl.sinh, np.sinh),
    "cosh": _Function(1, ufl.cosh, np.cosh),
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
_COMPARE: dict[type[ast.cmpop], tuple[Callable[..., Value], Callable[..., Value]]] = {
    # (UFL, NumPy)
    ast.Lt: (ufl.lt, np.less),
    ast.LtE: (ufl.le, np.less_equal),
    ast.Gt: (ufl.gt, np.greater),
    ast.GtE: (ufl.ge, np.greater_equal),
}
_CONSTANTS = {"pi": math.pi, "e": math.e}


def _polar(x: Value, y: Value, numeric: bool) -> dict[str, Value]:
    """The polar coordinates ``r`` and ``theta`` of (x, y): NumPy values, or UFL expressions."""
    sqrt, atan2 = _FUNCTIONS["sqrt"], _FUNCTIONS["atan2"]
    if numeric:
        return {"r": sqrt.numpy(x * x + y * y), "theta": atan2.numpy(y, x)}
    return {"r": sqrt.ufl(x * x + y * y), "theta": atan2.ufl(y, x)}


def _shown(text: str) -> str:
    """A formula as quoted in messages (long ones shortened: messages are one line)."""
    return repr(text) if len(text) <= 80 else repr(text[:60]) + "…"


def _literal(text: object, key: str) -> float | str:
    """A finite number as float, or a formula string; anything else is an InputError."""
    if isinstance(text, str):
        return text
    if is_number(text):
        value = float(text)
        if not math.isfinite(value):
            raise InputError(f"{key} must be a finite number, got {text!r}")
        return value
    raise InputError(f"{key} must be a number or a formula string, got {text!r}")


def finite_number(value: object, key: str) -> float:
    """A finite number as float; anything else, a formula string too, is an InputError."""
    literal = _literal(value, key)
    if isinstance(literal, str):
        raise InputError(f"{key} must be a number, got {value!r}")
    return literal


def parse(text: object, mesh: Mesh, key: str, names: Names | None = None) -> float | Expr:
    """The UFL expression of ``text`` on ``mesh`` (a number passes through as a float).

    ``names`` adds symbols such as ``t``; ``key`` is the problem-file key, named in the error
    message when the text is not acceptable. A formula is first evaluated at
    :func:`sample_points` of the mesh and must be finite there; collective on ``mesh.comm``
    for formulas (every rank parses the same data).
    """
    value = _literal(text, key)
    return value if isinstance(value, float) else formula(value, mesh, key, names)


def formula(text: str, mesh: Mesh, key: str, names: Names | None = None) -> float | Expr:
    """The UFL expression of the formula ``text`` (:func:`parse` of a string).

    A constant formula such as ``"2*pi"`` is folded to a float.
    """
    check_finite_on_mesh(text, mesh, key, names)
    x = compat.spatial_coordinate(mesh)
    builder = _Builder(key, text, (x[0], x[1]), names or {}, numeric=False)
    try:
        built = builder.build()
    except InputError:
        raise
    except (ArithmeticError, ValueError, TypeError) as err:  # what UFL raises on odd input
        raise InputError(f"{key}: cannot build formula {_shown(text)}: {err}") from None
    assert not isinstance(built, np.ndarray)  # UFL coordinates give UFL expressions
    return built


def parse_vector(
    values: object, mesh: Mesh, key: str, size: int, names: Names | None = None
) -> Expr:
    """A UFL vector from a list of numbers/formulas (of ``size`` entries: a spec's list)."""
    assert isinstance(values, list | tuple) and len(values) == size
    return compat.as_vector([parse(v, mesh, f"{key}[{i}]", names) for i, v in enumerate(values)])


def check(value: object, key: str, names: Names | None = None) -> None:
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


def evaluate(text: str, points: Array, key: str, names: Names | None = None) -> Array | None:
    """The formula's values at ``points`` (shape (n, 2)); a scalar when it is a constant.

    None when a name has no numeric value (e.g. a UFL constant), so it cannot be evaluated.
    """
    numeric: dict[str, object] = {}
    for name, value in (names or {}).items():
        if isinstance(value, np.ndarray) or is_number(value):
            numeric[name] = value
        elif uses(text, name):
            return None
    coords = (points[:, 0], points[:, 1])
    with np.errstate(all="ignore"):
        return np.asarray(_Builder(key, text, coords, numeric, numeric=True).build())


def uses(text: str, name: str) -> bool:
    """True when the formula ``text`` uses the symbol ``name`` (False when it does not parse)."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        return False
    return any(isinstance(node, ast.Name) and node.id == name for node in ast.walk(tree))


def sample_points(mesh: Mesh) -> Array:
    """This rank's geometry nodes and cell midpoints (ghosts included), shape (n, 2)."""
    x = mesh.geometry.x
    midpoints = x[compat.geometry_dofmap(mesh)].mean(axis=1)
    return np.vstack([x, midpoints])[:, :2]


def agree(a: object, b: object, mesh: Mesh, key: str = "value") -> bool:
    """True when two numbers or formulas are equal at every sample point (collective).

    False when one cannot be evaluated numerically; an InputError when one is not valid.
    """
    points = sample_points(mesh)
    first, second = (_values_at(v, points, key) for v in (a, b))
    local = first is not None and second is not None and bool(np.array_equal(first, second))
    return mpi.global_all(mesh.comm, local)


def _values_at(value: object, points: Array, key: str) -> Array | None:
    """A number or formula at ``points``, one value per point; None: not evaluable."""
    text = _literal(value, key)
    values = text if isinstance(text, float) else evaluate(text, points, key)
    return None if values is None else np.broadcast_to(values, len(points))


def check_finite_on_mesh(text: str, mesh: Mesh, key: str, names: Names | None = None) -> None:
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

    def __init__(
        self, key: str, text: str, coords: tuple[Value, Value], names: Names, numeric: bool
    ):
        self.key, self.text, self.coords, self.numeric = key, text, coords, numeric
        self.shown = _shown(text)
        x, y = coords
        polar = _polar(x, y, numeric)
        self.symbols: dict[str, object] = {"x": x, "y": y, **polar, **_CONSTANTS, **names}

    def build(self) -> Value:
        """The formula's value: a UFL expression, NumPy values (``numeric``) or a constant."""
        try:
            tree = ast.parse(self.text.strip(), mode="eval")
        except (SyntaxError, ValueError) as err:
            reason = err.msg if isinstance(err, SyntaxError) else str(err).split(";")[0]
            raise InputError(f"{self.key}: cannot parse formula {self.shown}: {reason}") from None
        except (RecursionError, MemoryError):
            self.fail("nesting this deep")
        try:
            return self.value(tree.body)
        except RecursionError:
            self.fail("nesting this deep")

    def value(self, node: ast.expr) -> Value:
        """The value of a node of the syntax tree (``visit``, typed)."""
        result: Value = self.visit(node)
        return result

    def fail(self, what: str) -> NoReturn:
        """Refuse a construct of the formula: an InputError naming it."""
        raise InputError(f"{self.key}: {what} is not allowed in formula {self.shown}")

    def not_finite(self, what: str) -> NoReturn:
        """Refuse a constant part that is not a finite real number."""
        raise InputError(f"{self.key}: formula {self.shown} {what}")

    def generic_visit(self, node: ast.AST) -> NoReturn:
        """Every node without a ``visit_`` method is refused."""
        self.fail(type(node).__name__)

    def visit_Constant(self, node: ast.Constant) -> float:
        """A number (a bool, a string or anything else is refused)."""
        if isinstance(node.value, bool) or not isinstance(node.value, int | float):
            self.fail(f"the constant {node.value!r}")
        try:
            value = float(node.value)
        except OverflowError:
            self.not_finite("overflows: an integer constant beyond ±1.8e308")
        if not math.isfinite(value):
            self.not_finite(f"overflows: the number {value} is not finite")
        return value

    def visit_Name(self, node: ast.Name) -> object:
        """x, y, r, theta, pi, e or a named parameter."""
        if node.id not in self.symbols:
            known = ", ".join(sorted(self.symbols))
            raise InputError(
                f"{self.key}: unknown name '{node.id}' in {self.shown} (known: {known})"
            )
        return self.symbols[node.id]

    def visit_Attribute(self, node: ast.Attribute) -> NoReturn:
        """Attribute access is refused (no way out of the formula's names)."""
        self.fail(f"attribute access '{ast.unparse(node)}'")

    def visit_Subscript(self, node: ast.Subscript) -> Value:
        """x[0] or x[1]."""
        if not (isinstance(node.value, ast.Name) and node.value.id == "x"):
            self.fail("indexing anything but x")
        index = node.slice
        if not (isinstance(index, ast.Constant) and index.value in (0, 1)):
            self.fail("an index other than x[0] or x[1]")
        return self.coords[0] if index.value == 0 else self.coords[1]

    def visit_BinOp(self, node: ast.BinOp) -> Value:
        """+, −, *, / and ** (constants folded as Python floats)."""
        op = _BINARY.get(type(node.op))
        if op is None:
            self.fail(f"the operator {type(node.op).__name__}")
        left, right = self.value(node.left), self.value(node.right)
        if op is operator.truediv and isinstance(right, float) and right == 0.0:
            self.not_finite("divides by zero")
        if not (isinstance(left, float) and isinstance(right, float)):
            result: Value = op(left, right)
            return result
        return self._fold(op, left, right)

    def _fold(self, op: Callable[[float, float], object], left: float, right: float) -> float:
        """``op(left, right)`` of two constants, which must be a finite real number."""
        try:
            value = op(left, right)
        except OverflowError:
            self.not_finite("overflows (beyond ±1.8e308)")
        except ZeroDivisionError:
            self.not_finite("divides by zero")
        if isinstance(value, complex):
            self.not_finite(f"is not a real number ({left!r} ** {right!r})")
        assert isinstance(value, float)
        if not math.isfinite(value):
            self.not_finite("overflows (beyond ±1.8e308)")
        return value

    def visit_UnaryOp(self, node: ast.UnaryOp) -> Value:
        """Unary minus and plus."""
        if isinstance(node.op, ast.USub):
            return -self.value(node.operand)
        if isinstance(node.op, ast.UAdd):
            return self.value(node.operand)
        self.fail(f"the operator {type(node.op).__name__}")

    def visit_Compare(self, node: ast.Compare) -> NoReturn:
        """Comparisons are allowed only as the condition of ``where``."""
        self.fail("a comparison outside the condition of where(condition, a, b)")

    def condition(self, node: ast.expr) -> Value:
        """The first argument of ``where``: one comparison <, <=, > or >=."""
        if not isinstance(node, ast.Compare):
            self.fail("a condition that is not a comparison (<, <=, >, >=) in where()")
        if len(node.ops) != 1 or type(node.ops[0]) not in _COMPARE:
            self.fail("a chained or equality comparison")
        compare = _COMPARE[type(node.ops[0])][self.numeric]
        result: Value = compare(self.value(node.left), self.value(node.comparators[0]))
        return result

    def visit_Call(self, node: ast.Call) -> Value:
        """A call of one of the allowed functions, with positional arguments only."""
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
        values += [self.value(arg) for arg in args]
        if all(isinstance(v, float) for v in values):  # a constant: finite and real, or refused
            with np.errstate(all="ignore"):
                folded = function.numpy(*values)
            if np.iscomplexobj(folded) or not np.isfinite(folded):
                args_text = ", ".join(f"{v:g}" for v in values)
                self.not_finite(f"is not finite: {func.id}({args_text}) = {folded}")
        return (function.numpy if self.numeric else function.ufl)(*values)


def is_constant(values: object) -> bool:
    """True when no entry is a formula string."""
    if isinstance(values, list | tuple):
        return all(is_constant(v) for v in values)
    return not isinstance(values, str)
