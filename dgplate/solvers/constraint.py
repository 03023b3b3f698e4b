"""The linearised isometry constraint and the isometry defect (docs/design.md §2–§3).

The multiplier λ is a symmetric 2×2 matrix per cell (DG0, three values: λ₁₁, λ₁₂, λ₂₂), so the
linearised constraint ∇δyᵀ∇yⁿ + ∇yⁿᵀ∇δy = 0 holds for the integral mean over each cell.
:class:`EdgeConstraint` adds (opt-in) moments of the metric on free boundary facets.
"""

from __future__ import annotations

from dataclasses import dataclass

import basix.ufl
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl
from ufl.algorithms import compute_form_data
from ufl.core.expr import Expr

from dgplate import mpi
from dgplate.compat import Array, Function, Mesh, entities_to_geometry
from dgplate.dg.forms import FREE, FacetSets, metric_quadrature
from dgplate.dg.geometry import cell_areas, oriented_normal
from dgplate.errors import InputError
from dgplate.mesh.tagged import local_entities


def multiplier_element(
    mesh: Mesh, degree: int = 0, total_degree: bool = False
) -> basix.ufl._ElementBase:
    """DG_degree with three components: the entries (11, 12, 22) of a symmetric 2×2 matrix.

    Degree 0 imposes the linearised constraint on cell means (the published method); degree 1
    imposes it on the first moments as well, a stronger discrete isometry.

    Args:
        mesh: the plate's mesh.
        degree: the multipliers' polynomial degree.
        total_degree: P_degree on quadrilaterals too (basix's DPC) instead of Q_degree. A
            continuous y has fewer unknowns per cell than a broken one (12 against 27 for
            Q2), and the four Q1 moments per entry leave its step system singular; the three
            P1 moments do not (docs/accuracy.md).

    Returns:
        The element.
    """
    quadrilateral = mesh.topology.cell_type == dolfinx.mesh.CellType.quadrilateral
    family = "DPC" if total_degree and degree > 0 and quadrilateral else "DG"
    return basix.ufl.element(family, mesh.basix_cell(), degree, shape=(3,))


def symmetric(q: Expr) -> Expr:
    """The symmetric matrix [[q₀, q₁], [q₁, q₂]] of a three-component multiplier."""
    matrix: Expr = ufl.as_matrix([[q[0], q[1]], [q[1], q[2]]])
    return matrix


def linearised_isometry(v: Expr, y: Expr, q: Expr) -> ufl.Form:
    """b_n(v, q) = ∫ (∇vᵀ∇yⁿ + ∇yⁿᵀ∇v) : q, the constraint linearised at y = yⁿ."""
    Gv, Gy = ufl.grad(v), ufl.grad(y)
    form: ufl.Form = ufl.inner(Gv.T * Gy + Gy.T * Gv, symmetric(q)) * ufl.dx
    return form


def refuse_edge_moments_with_metric(metric: Expr | None, edge_constraint: bool) -> None:
    """InputError when ``flow.edge_constraint`` meets a target metric G.

    Args:
        metric: the target metric (None: I).
        edge_constraint: whether the free edges' moments are constrained.
    """
    if metric is not None and edge_constraint:
        raise InputError(
            "flow.edge_constraint holds free edges to the metric I: not with model.metric "
            "or model.director"
        )


class EdgeConstraint:
    """Moments of the metric ∇yᵀ∇y − I on the free boundary: one free facet per cell that has one.

    Why: with cell moments only, a cell whose outer side is free has no neighbour to hold its
    metric there, and the energy ½|II − Z|² with Z = αI (which a sphere would make zero) pulls
    the free edges into a thin layer that is curved in both directions (Gauss curvature ≠ 0);
    the discrete energy then falls below the isometric minimum. The two moments below are
    the metric seen by the missing neighbour: on the chosen free facet e,

        ∫_e (|∂_t y|² − 1) p₀ ds = 0,      ∫_e (|∂_n y|² − 1) L₂(s) p₁ ds = 0,

    the mean of the tangential stretch and the second Legendre moment (s ∈ [−1, 1] along e) of
    the normal one. Both vanish for an isometry, so the constraint is consistent. At a flat
    state they are independent of the cell moments of a Q2 cell with DG0 or DG1 multipliers
    (the remaining metric mode of a Q2 cell is odd along the facet and has no mean Gauss
    curvature). One facet per cell: for a corner cell the moments of its second free facet
    follow from the first's and the cell moments (the step matrix would be singular). The
    facet is chosen by geometry (the longest, then the smallest midpoint), so the choice does
    not depend on the mesh partition, and is recognised on the facet by its outward normal,
    stored per cell, which no other facet of a convex cell shares.

    ``interior`` is 1 on the cells without a free facet, whose edge multipliers are pinned to
    zero, and 0 elsewhere. Collective on the mesh communicator.
    """

    #: number of moments (multiplier components) per cell
    SIZE = 2

    def __init__(self, facets: FacetSets):
        mesh = facets.mesh
        tdim, fdim = mesh.topology.dim, mesh.topology.dim - 1
        mesh.topology.create_connectivity(tdim, fdim)
        scalar = dolfinx.fem.functionspace(mesh, ("DG", 0))
        vector = dolfinx.fem.functionspace(mesh, ("DG", 0, (2,)))
        self.interior: Function = dolfinx.fem.Function(scalar, name="interior_cells")
        half_length: Function = dolfinx.fem.Function(scalar)
        normal: Function = dolfinx.fem.Function(vector)
        midpoint: Function = dolfinx.fem.Function(vector)
        half_length.x.array[:] = 1.0
        chosen = _chosen_free_facets(facets)
        for cell, facet in enumerate(chosen.facet):
            dof = scalar.dofmap.list[cell, 0]
            if facet < 0:
                self.interior.x.array[dof] = 1.0
                continue
            vdof = vector.dofmap.list[cell, 0]
            normal.x.array[2 * vdof : 2 * vdof + 2] = chosen.normal[cell]
            midpoint.x.array[2 * vdof : 2 * vdof + 2] = chosen.midpoint[cell]
            half_length.x.array[dof] = 0.5 * chosen.length[cell]
        n = facets.n
        self._chosen: Expr = ufl.conditional(ufl.gt(ufl.dot(n, normal), 0.5), 1.0, 0.0)
        self._ds = facets.ds(FREE)
        self._t: Expr = ufl.as_vector([-n[1], n[0]])
        self._n = n
        s = ufl.dot(ufl.SpatialCoordinate(mesh) - midpoint, self._t) / half_length
        self._legendre2: Expr = 1.5 * s**2 - 0.5

    def quantities(self, y: Expr) -> Expr:
        """(|∂_t y|² − 1, (|∂_n y|² − 1) L₂(s)) on boundary facets: zero for an isometry."""
        G = ufl.grad(y)
        Gt, Gn = G * self._t, G * self._n
        values: Expr = ufl.as_vector(
            [ufl.inner(Gt, Gt) - 1.0, (ufl.inner(Gn, Gn) - 1.0) * self._legendre2]
        )
        return values

    def residual(self, y: Expr, p: Expr) -> ufl.Form:
        """∫_e quantities(y) · p over the chosen facets: the nonlinear constraint."""
        form: ufl.Form = self._chosen * ufl.inner(self.quantities(y), p) * self._ds
        return form

    def linearised(self, v: Expr, y: Expr, p: Expr) -> ufl.Form:
        """Its derivative at y = yⁿ in the direction v: the rows of the step's constraint."""
        form: ufl.Form = ufl.derivative(self.residual(y, p), y, v)
        return form


@dataclass
class _ChosenFacets:
    """The free facet chosen for each local cell: index (−1: none), outward normal, midpoint, length."""

    facet: npt.NDArray[np.int32]
    normal: Array
    midpoint: Array
    length: Array


def _chosen_free_facets(facets: FacetSets) -> _ChosenFacets:
    """For each local cell, the free facet whose metric moments :class:`EdgeConstraint` takes.

    The longest free facet of the cell, then the one with the smallest midpoint (rounded):
    a choice by geometry, the same on any partition.
    """
    mesh = facets.mesh
    tdim, fdim = mesh.topology.dim, mesh.topology.dim - 1
    c2f = mesh.topology.connectivity(tdim, fdim)
    free = np.zeros(local_entities(mesh, fdim).size, dtype=bool)
    free[facets.tags.indices[facets.tags.values == FREE]] = True
    all_facets = np.arange(free.size, dtype=np.int32)
    facet_mid = dolfinx.mesh.compute_midpoints(mesh, fdim, all_facets)[:, :2]
    lengths = mesh.h(fdim, all_facets)
    rounded_lengths = lengths.round(12)
    facet_nodes = entities_to_geometry(mesh, fdim, all_facets)
    cells = local_entities(mesh, tdim)
    cell_mid = dolfinx.mesh.compute_midpoints(mesh, tdim, cells)[:, :2]
    x = mesh.geometry.x[:, :2]
    chosen = _ChosenFacets(
        np.full(cells.size, -1, dtype=np.int32),
        np.zeros((cells.size, 2)),
        np.zeros((cells.size, 2)),
        np.zeros(cells.size),
    )
    for cell in cells:
        candidates = [f for f in c2f.links(cell) if free[f]]
        if not candidates:
            continue
        f = min(candidates, key=lambda f: (-rounded_lengths[f], *facet_mid[f].round(12)))
        tangent = x[facet_nodes[f][-1]] - x[facet_nodes[f][0]]
        chosen.facet[cell] = f
        chosen.normal[cell] = oriented_normal(tangent, cell_mid[cell], facet_mid[f])
        chosen.midpoint[cell] = facet_mid[f]
        chosen.length[cell] = lengths[f]
    return chosen


def metric_tensor_defect(y: Expr, metric: Expr | None = None) -> Expr:
    """∇yᵀ∇y − G, zero when y realises the target metric G (None: G = I₂, an isometry).

    Args:
        y: the deformation.
        metric: the target metric G (first fundamental form), a UFL 2×2 expression.

    Returns:
        The 2×2 defect.
    """
    target = ufl.Identity(2) if metric is None else metric
    defect: Expr = ufl.grad(y).T * ufl.grad(y) - target
    return defect


def _estimated_degree(form: ufl.Form) -> int:
    """The quadrature degree FFCx gives the one integral of ``form``.

    UFL's estimate with the integral's scaling |det J| (degree 2 on second-order triangles).
    """
    data = compute_form_data(form, do_apply_integral_scaling=True)
    integral = data.integral_data[0].integrals[0]
    degree: int = integral.metadata()["estimated_polynomial_degree"]
    return degree


def metric_measure(y: Expr, metric: Expr | None) -> ufl.Measure:
    """The cell measure of the constraint's integrals: FFCx's degree for G = I, else the energy's.

    Args:
        y: the deformation (its degree sets the quadrature with a G).
        metric: the target metric G (None: I).

    Returns:
        ``dx``; with a G, of the energy's degree :func:`~dgplate.dg.forms.metric_quadrature`.
    """
    dx: ufl.Measure = ufl.dx
    if metric is not None:
        dx = dx(metadata={"quadrature_degree": metric_quadrature(y)})
    return dx


class IsometryDefect:
    """D_h[y] = Σ_T |∫_T (∇yᵀ∇y − G)| (Frobenius norm per cell), and its cell field.

    G is the target metric (I₂ without one: the isometry defect). The per-cell integrals are
    assembled once into a DG0 (2×2) vector; evaluating is one vector assembly and a
    reduction over owned cells.

    They take the quadrature of the constraint's residual ∫_T (∇yᵀ∇y − G) : q, which the
    step's corrections drive to zero. With G = I, q is a test function of the step's mixed
    space, so UFL gives that integral the degree of ∇yᵀ∇y − I plus y's degree, where the DG0
    test here alone would give y's degree less (with a metric, both take
    :func:`metric_measure`). On affine cells both rules are exact. On curved (second-order)
    cells ∇yᵀ∇y is rational and the lower rule left D_h a quadrature error the corrections
    cannot remove (curved fold, h = 0.4: 2·10⁻¹² against 10⁻¹⁵ with the residual's rule), at
    the trust region's "back on the constraint" threshold 10⁻¹²|ω|, where it refused every
    step (docs/performance.md).
    """

    def __init__(self, y: Function, metric: Expr | None = None):
        mesh = y.function_space.mesh
        element = basix.ufl.element("DG", mesh.basix_cell(), 0, shape=(2, 2))
        self.space = dolfinx.fem.functionspace(mesh, element)
        integrand = ufl.inner(metric_tensor_defect(y, metric), ufl.TestFunction(self.space))
        if metric is None:
            degree = _estimated_degree(integrand * ufl.dx)
            degree += y.function_space.ufl_element().embedded_superdegree
            dx = ufl.dx(metadata={"quadrature_degree": degree})
        else:
            dx = metric_measure(y, metric)
        self.form = dolfinx.fem.form(integrand * dx)
        self.comm = mesh.comm
        self.num_owned = mesh.topology.index_map(mesh.topology.dim).size_local
        self.volumes = cell_areas(dolfinx.fem.functionspace(mesh, ("DG", 0)))
        #: |ω|, the area of the reference domain (a scale for D_h)
        self.area = mpi.global_sum(self.comm, float(np.sum(self.volumes[: self.num_owned])))

    def cell_values(self) -> Array:
        """|∫_T (∇yᵀ∇y − I)| for each owned cell (in the order of the DG0 dofs)."""
        vec = dolfinx.fem.assemble_vector(self.form)
        per_cell = vec.array.reshape(-1, 4)[: self.num_owned]
        norms: Array = np.linalg.norm(per_cell, axis=1)
        return norms

    def __call__(self) -> float:
        """D_h[y] for the current y (collective)."""
        return mpi.global_sum(self.comm, float(np.sum(self.cell_values())))

    def density(self) -> Array:
        """Cell-wise defect per unit area, for plots (owned cells, in the order of the dofs)."""
        density: Array = self.cell_values() / self.volumes[: self.num_owned]
        return density


__all__ = [
    "EdgeConstraint",
    "IsometryDefect",
    "linearised_isometry",
    "metric_measure",
    "metric_tensor_defect",
    "multiplier_element",
    "symmetric",
]
