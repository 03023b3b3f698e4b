"""The one model shape: what a registered model builds from its spec and the mesh.

A model is an energy written once in UFL plus what its driver needs. :class:`Model` is the
protocol the runner sees; :class:`PlateModel` is the shape of every isometry-constrained plate
(Kirchhoff, bilayer, foundation, …): facets, degree and the energy of the deformation, run by the
constrained gradient flow. Models with another state or driver (FvK: Newton over a load
schedule; thermal: heat steps coupled to the flow) implement :class:`Model` themselves.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import ufl
from ufl.core.expr import Expr

from dgplate import values
from dgplate.compat import Array, Function, Mesh
from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets
from dgplate.errors import InputError
from dgplate.measure.creases import crease_polylines, fold_angle_summary
from dgplate.mesh.tagged import TaggedMesh
from dgplate.schema import is_matrix, is_number
from dgplate.solvers.driver import Driver, Observer
from dgplate.solvers.flow import FlowSpec, GradientFlow, Initial

__all__ = ["Initial", "Model", "PlateModel", "clamped_data", "flat_identity", "piecewise_constant"]


class Model(Protocol):
    """What the runner needs of a model (all methods collective).

    ``figures`` and ``lines`` take the driver that :meth:`driver` returned, whose type each
    model knows (a protocol cannot say "the type of my driver"): hence ``Any``.
    """

    def driver(
        self, flow: FlowSpec, observers: Sequence[Observer], initial: Initial | None
    ) -> Driver:
        """The driver that solves this model; ``flow`` is the problem's [flow] section."""
        ...

    def figures(self, driver: Any) -> dict[str, Any]:
        """Model-specific numbers for ``summary.json`` (e.g. fold angles)."""
        ...

    def lines(self, driver: Any) -> list[Array]:
        """Polylines drawn on the picture of the final shape (e.g. deformed creases)."""
        ...


@dataclass
class PlateModel:
    """An isometry-constrained plate: the energy of y ∈ [DG_k]³, run by the gradient flow.

    ``measures`` add numbers of the final deformation to ``summary.json``; fold angles of
    crease facets are always reported.
    """

    facets: FacetSets
    degree: int
    energy: Callable[[Function], Energy]
    measures: Sequence[Callable[[Function], dict[str, Any]]] = field(default_factory=tuple)

    def driver(
        self, flow: FlowSpec, observers: Sequence[Observer], initial: Initial | None
    ) -> GradientFlow:
        """The constrained gradient flow of :attr:`energy`."""
        return GradientFlow(self.facets, self.degree, self.energy, flow, observers, initial)

    def figures(self, driver: GradientFlow) -> dict[str, Any]:
        """Fold angles along creases and the numbers of :attr:`measures`."""
        out: dict[str, Any] = {}
        if self.facets.num_crease:
            out.update(fold_angle_summary(driver.y, self.facets))
        for measure in self.measures:
            out.update(measure(driver.y))
        return out

    def lines(self, driver: GradientFlow) -> list[Array]:
        """The deformed crease lines."""
        return crease_polylines(driver.y, self.facets) if self.facets.num_crease else []


def flat_identity(mesh: Mesh) -> tuple[Expr, Expr]:
    """The flat reference deformation y⁰(x) = (x₁, x₂, 0) and its gradient [I₂; 0]."""
    x = ufl.SpatialCoordinate(mesh)
    g: Expr = ufl.as_vector([x[0], x[1], 0.0])
    Phi: Expr = ufl.as_matrix([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    return g, Phi


def piecewise_constant(tagged: TaggedMesh, data: object, key: str) -> Expr:
    """μ-like data: a number (a Constant), or {cell group name: number} as a DG0 function.

    Either way a value of the forms, not part of their code (:mod:`dgplate.values`).
    """
    if is_number(data):
        if not data > 0:
            raise InputError(f"{key} must be > 0, got {data}")
        return values.constant(tagged.mesh, data)
    if not isinstance(data, dict) or not data:
        raise InputError(f"{key} must be a number or a table {{group = value}}, got {data!r}")
    for name, value in data.items():
        if not (is_number(value) and value > 0):
            raise InputError(f"{key}.{name} must be a number > 0, got {value!r}")
    return tagged.group_function(data, key=key)


def clamped_data(value: object, mesh: Mesh, key: str = "model.boundary_data") -> tuple[Expr, Expr]:
    """Nitsche data (g, Φ) on clamped facets from a problem file.

    ``"flat"``: g = (x, y, 0), Φ = [I₂; 0]. A table ``{g = [3 formulas], Phi = [[2], [2], [2]]}``
    gives any data, e.g. a folded sheet; Φ defaults to ∇g. Numbers in the table are Constants
    (:mod:`dgplate.values`).
    """
    if value == "flat":
        return flat_identity(mesh)
    if not isinstance(value, dict) or "g" not in value or set(value) - {"g", "Phi"}:
        raise InputError(
            f"{key} must be 'flat' or a table {{g = [..3..], Phi = [[..2..] x3]}}, got {value!r}"
        )
    g = values.vector(value["g"], mesh, f"{key}.g", 3)
    if "Phi" not in value:
        gradient: Expr = ufl.grad(g)
        return g, gradient
    rows = value["Phi"]
    if not is_matrix(rows, 3, 2):
        raise InputError(f"{key}.Phi must be a 3×2 matrix [[..], [..], [..]], got {rows!r}")
    Phi = values.array(rows, mesh, f"{key}.Phi")
    assert not isinstance(Phi, float)  # a matrix gives a tensor
    return g, Phi
