"""Numbers of a problem enter the forms as values, so that forms compile once per problem shape.

FFCx compiles a form into a C module named by the form's signature, and a literal number is
part of that signature: with numbers baked in, a load of 0.025 and one of 0.05 are two modules,
and every new value of a sweep paid tens of seconds of compilation. Numbers from problem files (loads,
Z, μ, the penalties γ₀ and γ₁, α, anchor stiffness, FvK data, …) therefore enter the forms as
:class:`dolfinx.fem.Constant` (scalars, vectors, 2×2 matrices) or as DG0 functions (tables per
cell group), whose values the generated code reads at assembly time.

The signature, and so the cache, still tells problem *shapes* apart: the model and its terms,
degrees, elements and cell types, the facet sets, the power p of h⁻ᵖ, and the text of formulas
in x, y. A formula such as ``"0.1*sin(pi*x)"`` stays symbolic, numbers in it included: it is a
piece of the form, not a value, so a sweep over its amplitude compiles once per amplitude.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeAlias, TypeVar

import dolfinx.fem
import numpy as np
import numpy.typing as npt
from petsc4py import PETSc
from ufl.core.expr import Expr

from dgplate import compat, expressions
from dgplate.compat import Constant, Mesh

T = TypeVar("T")
#: An entry of nested lists, or the nested lists of such entries.
Nested: TypeAlias = "T | list[Nested[T]]"


def constant(mesh: Mesh, value: npt.ArrayLike | Nested[float]) -> Constant:
    """``value`` (a number or an array of numbers) as a Constant of the DOLFINx ``mesh``.

    The Constant has PETSc's scalar type, like every form of dgplate.
    """
    return dolfinx.fem.Constant(mesh, np.asarray(value, dtype=PETSc.ScalarType))


def _map(values: object, key: str, leaf: Callable[[object, str], T]) -> Nested[T]:
    """``leaf(value, key[i][j])`` on every entry of nested lists."""
    if isinstance(values, list | tuple):
        return [_map(v, f"{key}[{i}]", leaf) for i, v in enumerate(values)]
    return leaf(values, key)


def array(
    values: object, mesh: Mesh, key: str, names: expressions.Names | None = None
) -> float | Expr:
    """A number, a formula, or nested lists of them (shape checked by the caller) as UFL.

    Numbers only: one Constant of their shape. With formulas: a UFL tensor whose numeric
    entries are scalar Constants. Entries are checked by :func:`dgplate.expressions.parse`;
    ``names`` adds symbols of the formulas (e.g. a Constant ``alpha``).
    """
    if expressions.is_constant(values):
        numbers: Nested[float] = _map(values, key, expressions.finite_number)
        return constant(mesh, numbers)

    def leaf(value: object, k: str) -> float | Expr:
        if isinstance(value, str):
            return expressions.formula(value, mesh, k, names)
        return constant(mesh, expressions.finite_number(value, k))

    entries = _map(values, key, leaf)
    return compat.as_tensor(entries) if isinstance(entries, list) else entries


def vector(
    values: object, mesh: Mesh, key: str, size: int, names: expressions.Names | None = None
) -> Expr:
    """:func:`dgplate.expressions.parse_vector`'s checks and messages, numbers as Constants."""
    expressions.parse_vector(values, mesh, key, size, names)  # checks only: `size` entries
    tensor = array(values, mesh, key, names)
    assert not isinstance(tensor, float)  # a list gives a vector
    return tensor
