"""Field helpers for output: cell fields, VTK-ready spaces and the gathered DG surface.

Plots and files index per-cell data by the *owned local cell* (0 .. num_owned − 1), while
DG0 functions and assembled DG0 vectors are indexed by *dof*. DOLFINx does not promise that
the two orders agree, so every conversion here goes through the DG0 dofmap.

``surface_grid`` builds the deformed surface from the DG dofs themselves: each owned cell
becomes a VTK Lagrange cell of the element degree whose points are the deformed positions at
that cell's nodes, so a picture shows the discrete surface (with its small jumps), not a
projection of it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import basix
import basix.ufl
import dolfinx.fem
import numpy as np
import numpy.typing as npt
from ufl.algorithms.apply_algebra_lowering import apply_algebra_lowering
from ufl.algorithms.apply_derivatives import apply_derivatives
from ufl.constantvalue import Zero
from ufl.core.expr import Expr

from dgplate import compat
from dgplate.compat import Array, Function, FunctionSpace, Mesh
from dgplate.dg import geometry
from dgplate.dg.forms import hessian_norm

if TYPE_CHECKING:
    import pyvista

#: Point-data name of the reference (undeformed) positions stored on every gathered grid.
REFERENCE = "reference position"
#: Name of the Gaussian-curvature cell field in time series.
GAUSS = "gauss_curvature"


def num_owned_cells(mesh: Mesh) -> int:
    """Number of cells this rank owns (ghost cells excluded)."""
    return int(mesh.topology.index_map(mesh.topology.dim).size_local)


def owned_cell_dofs(space: FunctionSpace) -> npt.NDArray[np.int64]:
    """The (block) dof of each owned cell of a DG0 space, in owned-cell order."""
    mesh = space.mesh
    cell_dofs = space.dofmap.list
    if cell_dofs.shape[1] != 1:
        raise ValueError("owned_cell_dofs needs a cell-wise constant (DG0) space")
    return np.asarray(cell_dofs[: num_owned_cells(mesh), 0], dtype=np.int64)


def dg0_dofs_to_cells(values: Array, space: FunctionSpace) -> Array:
    """Reorder per-DG0-dof values (first axis, owned dofs or all local dofs) to owned cells."""
    dofs = owned_cell_dofs(space)
    array = np.asarray(values)
    if dofs.size and dofs.max() >= array.shape[0]:
        raise ValueError("an owned cell has a ghost DG0 dof: pass the values of all local dofs")
    return array[dofs]


class CellField:
    """A scalar UFL expression at each cell's midpoint, as a DG0 function re-evaluated on demand.

    The expression is compiled once; :meth:`update` interpolates it into DG0 (one point per
    cell: the reference midpoint), e.g. before each write of a time series.
    """

    def __init__(self, expr: Expr, mesh: Mesh, name: str = "cell field"):
        space = dolfinx.fem.functionspace(mesh, ("DG", 0))
        points = compat.interpolation_points(space.element)
        # an expression that is zero once its derivatives are taken (the curvature of a
        # constant metric) has no cell to compile an Expression on: the field is zero
        lowered = apply_algebra_lowering(expr)  # type: ignore[no-untyped-call]
        zero = isinstance(apply_derivatives(lowered), Zero)  # type: ignore[no-untyped-call]
        self._expr: compat.Expression | None = (
            None if zero else dolfinx.fem.Expression(expr, points)
        )
        self.function: Function = dolfinx.fem.Function(space, name=name)

    def update(self) -> Function:
        """The DG0 function, set to the expression's current midpoint values."""
        if self._expr is None:
            self.function.x.array[:] = 0.0
        else:
            self.function.interpolate(self._expr)
        return self.function

    def values(self) -> Array:
        """The current midpoint values in owned-cell order (for ``cell_values``)."""
        field = self.update()
        values: Array = field.x.array[owned_cell_dofs(field.function_space)].real.copy()
        return values


def cell_field(expr: Expr, mesh: Mesh) -> Array:
    """A scalar UFL expression at each owned cell's midpoint, in owned-cell order.

    The expression is interpolated into DG0 and read back through the dofmap, so the result
    can be passed as ``cell_values``.
    """
    return CellField(expr, mesh).values()


def gauss_field(u: Function) -> CellField:
    """The Gaussian curvature K of the deformed surface of ``u`` as a DG0 ``CellField``.

    K = det(II)/det(∇yᵀ∇y) at each cell's midpoint (named ``gauss_curvature``), for a
    deformation y or a scalar deflection w (surface (x₁, x₂, w)).
    """
    K = geometry.gauss_curvature(geometry.surface(u))
    return CellField(K, u.function_space.mesh, name=GAUSS)


def gauss_density(u: Function) -> Array:
    """The Gaussian curvature K at the owned cells' midpoints (owned-cell order)."""
    return gauss_field(u).values()


def bending_density(y: Function) -> Array:
    """|D²y| (Frobenius norm of the broken Hessian) at the owned cells' midpoints.

    For a deformation y or a scalar deflection w alike.
    """
    return cell_field(hessian_norm(y), y.function_space.mesh)


def defect_density(y: Function, metric: Expr | None = None) -> Array:
    """Isometry-defect density |∫_T (∇yᵀ∇y − G)| / |T| per owned cell (owned-cell order).

    Args:
        y: the deformation.
        metric: the target metric G (None: I).

    Returns:
        One value per owned cell.
    """
    if y.ufl_shape != (3,):
        raise ValueError("the isometry defect needs a deformation y with three components")
    from dgplate.solvers.constraint import IsometryDefect

    defect = IsometryDefect(y, metric)
    # density() is indexed by the owned dofs of the defect's DG0 space, not by cell.
    return dg0_dofs_to_cells(defect.density(), defect.space)


def output_element(
    mesh: Mesh, degree: int, shape: tuple[int, ...] = (), discontinuous: bool = True
) -> basix.ufl._ElementBase:
    """A Lagrange element whose nodes VTK reads correctly (VTK Lagrange cells are equispaced).

    Basix's default variant (GLL-warped) has equispaced nodes up to degree 2, which is kept
    so that a DG2 deformation is written as is; from degree 3 on the equispaced variant is
    used, since VTK would draw a wavy surface through warped nodes.
    """
    variant = basix.LagrangeVariant.equispaced if degree >= 3 else basix.LagrangeVariant.gll_warped
    cell = mesh.basix_cell()
    return basix.ufl.element(
        "P", cell, degree, lagrange_variant=variant, shape=shape, discontinuous=discontinuous
    )


def to_output_space(
    f: Function, degree: int | None = None, discontinuous: bool | None = None
) -> Function:
    """``f`` in the ``output_element`` of the given degree (default: f's own degree).

    Returns ``f`` itself when it already lives there; otherwise interpolates, which is exact
    between the variants of one degree (same polynomial space).
    """
    element = compat.ufl_element(f.function_space)
    degree = element.embedded_superdegree if degree is None else degree
    discontinuous = element.discontinuous if discontinuous is None else discontinuous
    mesh = f.function_space.mesh
    target = output_element(mesh, degree, f.ufl_shape, discontinuous)
    if element == target:
        return f
    out: Function = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, target), name=f.name)
    out.interpolate(f)
    return out


def reference_coordinates(space: FunctionSpace) -> Array:
    """Reference positions x of the local (owned and ghost) dofs, shape (num_dofs, 3)."""
    return space.tabulate_dof_coordinates()


def surface_points(u: Function) -> Array:
    """Deformed positions at the local dofs, shape (num_dofs, 3).

    For a vector y with three components this is y itself; for a scalar deflection w it is
    (x₁, x₂, w).
    """
    space = u.function_space
    bs = space.dofmap.index_map_bs
    num_dofs = space.dofmap.index_map.size_local + space.dofmap.index_map.num_ghosts
    values = u.x.array.real[: num_dofs * bs].reshape(num_dofs, bs)
    if bs == 3:
        points: Array = values.copy()
        return points
    if bs == 1:
        embedded = reference_coordinates(space).copy()
        embedded[:, 2] = values[:, 0]
        return embedded
    raise ValueError(f"expected a deformation with 3 components or a scalar, got {bs}")


def dof_values(values: Array | Function, u: Function) -> Array:
    """Values at u's local dofs: an array indexed by local dof, or any Function.

    A Function is put on u's space by ``to_output_space``, so that a P1 temperature can be
    shown on a DG surface.
    """
    space = u.function_space
    num_dofs = space.dofmap.index_map.size_local + space.dofmap.index_map.num_ghosts
    if isinstance(values, dolfinx.fem.Function):
        element = compat.ufl_element(space)
        on_u = to_output_space(values, element.embedded_superdegree, element.discontinuous)
        # Same element layout, possibly other dof numbers: match them node by node per cell.
        same_node = np.empty(num_dofs, dtype=np.int64)
        same_node[space.dofmap.list.reshape(-1)] = on_u.function_space.dofmap.list.reshape(-1)
        bs = on_u.function_space.dofmap.index_map_bs
        matched: Array = on_u.x.array.real.reshape(-1, bs)[same_node]
        return matched[:, 0] if bs == 1 else matched
    array = np.asarray(values)
    if array.shape[0] != num_dofs:
        raise ValueError(f"point values need one entry per local dof ({num_dofs})")
    return array


def set_displacement(u: Function, y: Function, x: Array) -> None:
    """Set u ← y − x for the dof coordinates ``x`` (both functions in the same [DG_k]³ space)."""
    u.x.array[:] = y.x.array - x.reshape(-1)


def surface_grid(
    u: Function,
    cell_values: Mapping[str, Array] | None = None,
    point_values: Mapping[str, Array | Function] | None = None,
) -> pyvista.UnstructuredGrid | None:
    """The deformed surface of the owned cells of all ranks, as one grid on rank 0.

    ``u`` is a deformation y in [DG_k]³ or a scalar deflection w (surface (x₁, x₂, w)).
    ``cell_values`` are indexed by owned local cell, ``point_values`` by local dof of u's
    space. Collective; returns None on ranks other than 0. The reference positions are
    attached as point data ``REFERENCE``.
    """
    import pyvista

    u = to_output_space(u)
    space = u.function_space
    mesh = space.mesh
    owned = np.arange(num_owned_cells(mesh), dtype=np.int32)
    cells, types, _ = compat.vtk_mesh(space, owned)
    nodes = space.dofmap.dof_layout.num_dofs  # per cell; reshape works for 0 owned cells too
    topology = np.asarray(cells, dtype=np.int64).reshape(owned.size, nodes + 1)
    used, local = np.unique(topology[:, 1:], return_inverse=True)
    topology[:, 1:] = local.reshape(owned.size, nodes)
    points = surface_points(u)[used]
    reference = space.tabulate_dof_coordinates()[used]
    cvals = {name: np.asarray(v)[: owned.size] for name, v in (cell_values or {}).items()}
    for name, v in cvals.items():
        if v.shape[0] != owned.size:
            raise ValueError(f"cell values {name!r} need one entry per owned cell ({owned.size})")
    pvals = {name: dof_values(v, u)[used] for name, v in (point_values or {}).items()}
    pieces = mesh.comm.gather((topology, np.asarray(types), points, reference, cvals, pvals))
    if mesh.comm.rank != 0:
        return None
    offsets = np.cumsum([0] + [p[2].shape[0] for p in pieces])
    conn = [np.c_[t[:, :1], t[:, 1:] + off].reshape(-1) for (t, *_), off in zip(pieces, offsets)]
    types = np.concatenate([p[1] for p in pieces]).astype(np.uint8)
    grid = pyvista.UnstructuredGrid(np.concatenate(conn), types, np.vstack([p[2] for p in pieces]))
    grid.point_data[REFERENCE] = np.concatenate([p[3] for p in pieces])
    for name in cvals:
        grid.cell_data[name] = np.concatenate([p[4][name] for p in pieces])
    for name in pvals:
        grid.point_data[name] = np.concatenate([p[5][name] for p in pieces])
    return grid


__all__ = [
    "GAUSS",
    "REFERENCE",
    "CellField",
    "bending_density",
    "cell_field",
    "defect_density",
    "dg0_dofs_to_cells",
    "dof_values",
    "gauss_density",
    "gauss_field",
    "num_owned_cells",
    "output_element",
    "owned_cell_dofs",
    "reference_coordinates",
    "set_displacement",
    "surface_grid",
    "surface_points",
    "to_output_space",
]
