"""The linearised isometry constraint and the isometry defect (docs/design.md §2–§3).

The multiplier λ is a symmetric 2×2 matrix per cell (DG0, three values: λ₁₁, λ₁₂, λ₂₂), so the
linearised constraint ∇δyᵀ∇yⁿ + ∇yⁿᵀ∇δy = 0 holds for the integral mean over each cell.
:class:`EdgeConstraint` adds (opt-in) moments of the metric on free boundary facets.
"""

from __future__ import annotations

from mpi4py import MPI

import basix.ufl
import dolfinx.fem
import numpy as np
import ufl


def multiplier_element(mesh, degree: int = 0):
    """DG_degree with three components: the entries (11, 12, 22) of a symmetric 2×2 matrix.

    Degree 0 imposes the linearised constraint on cell means (the published method); degree 1
    imposes it on the first moments as well, a stronger discrete isometry.
    """
    return basix.ufl.element("DG", mesh.basix_cell(), degree, shape=(3,))


def symmetric(q):
    """The symmetric matrix [[q₀, q₁], [q₁, q₂]] of a three-component multiplier."""
    return ufl.as_matrix([[q[0], q[1]], [q[1], q[2]]])


def linearised_isometry(v, y, q):
    """b_n(v, q) = ∫ (∇vᵀ∇yⁿ + ∇yⁿᵀ∇v) : q, the constraint linearised at y = yⁿ."""
    Gv, Gy = ufl.grad(v), ufl.grad(y)
    return ufl.inner(Gv.T * Gy + Gy.T * Gv, symmetric(q)) * ufl.dx


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

    def __init__(self, faces):
        from dgplate.dg.forms import FREE

        mesh = faces.mesh
        tdim, fdim = mesh.topology.dim, mesh.topology.dim - 1
        mesh.topology.create_connectivity(tdim, fdim)
        c2f = mesh.topology.connectivity(tdim, fdim)
        cmap, fmap = mesh.topology.index_map(tdim), mesh.topology.index_map(fdim)
        free = np.zeros(fmap.size_local + fmap.num_ghosts, dtype=bool)
        free[faces.tags.indices[faces.tags.values == FREE]] = True
        facets = np.arange(free.size, dtype=np.int32)
        facet_mid = dolfinx.mesh.compute_midpoints(mesh, fdim, facets)[:, :2]
        lengths = mesh.h(fdim, facets)
        facet_nodes = dolfinx.mesh.entities_to_geometry(mesh, fdim, facets)
        cells = np.arange(cmap.size_local + cmap.num_ghosts, dtype=np.int32)
        cell_mid = dolfinx.mesh.compute_midpoints(mesh, tdim, cells)[:, :2]
        x = mesh.geometry.x[:, :2]

        scalar = dolfinx.fem.functionspace(mesh, ("DG", 0))
        vector = dolfinx.fem.functionspace(mesh, ("DG", 0, (2,)))
        self.interior = dolfinx.fem.Function(scalar, name="interior_cells")
        half_length = dolfinx.fem.Function(scalar)
        normal, midpoint = dolfinx.fem.Function(vector), dolfinx.fem.Function(vector)
        half_length.x.array[:] = 1.0
        for cell in cells:
            dof = scalar.dofmap.list[cell, 0]
            candidates = [f for f in c2f.links(cell) if free[f]]
            if not candidates:
                self.interior.x.array[dof] = 1.0
                continue
            f = min(candidates, key=lambda f: (-round(lengths[f], 12), *facet_mid[f].round(12)))
            tangent = x[facet_nodes[f][-1]] - x[facet_nodes[f][0]]
            outward = np.array([tangent[1], -tangent[0]]) / np.linalg.norm(tangent)
            if np.dot(outward, facet_mid[f] - cell_mid[cell]) < 0:
                outward = -outward
            vdof = vector.dofmap.list[cell, 0]
            normal.x.array[2 * vdof : 2 * vdof + 2] = outward
            midpoint.x.array[2 * vdof : 2 * vdof + 2] = facet_mid[f]
            half_length.x.array[dof] = 0.5 * lengths[f]
        n = ufl.FacetNormal(mesh)
        self._chosen = ufl.conditional(ufl.gt(ufl.dot(n, normal), 0.5), 1.0, 0.0)
        self._ds = faces.ds(FREE)
        self._t, self._n = ufl.as_vector([-n[1], n[0]]), n
        s = ufl.dot(ufl.SpatialCoordinate(mesh) - midpoint, self._t) / half_length
        self._legendre2 = 1.5 * s**2 - 0.5

    def quantities(self, y):
        """(|∂_t y|² − 1, (|∂_n y|² − 1) L₂(s)) on boundary facets: zero for an isometry."""
        G = ufl.grad(y)
        Gt, Gn = G * self._t, G * self._n
        return ufl.as_vector([ufl.inner(Gt, Gt) - 1.0, (ufl.inner(Gn, Gn) - 1.0) * self._legendre2])

    def residual(self, y, p):
        """∫_e quantities(y) · p over the chosen facets: the nonlinear constraint."""
        return self._chosen * ufl.inner(self.quantities(y), p) * self._ds

    def linearised(self, v, y, p):
        """Its derivative at y = yⁿ in the direction v: the rows of the step's constraint."""
        return ufl.derivative(self.residual(y, p), y, v)


def metric_tensor_defect(y):
    """∇yᵀ∇y − I₂, zero for an isometry."""
    return ufl.grad(y).T * ufl.grad(y) - ufl.Identity(2)


class IsometryDefect:
    """D_h[y] = Σ_T |∫_T (∇yᵀ∇y − I₂)| (Frobenius norm per cell), and its cell field.

    The per-cell integrals are assembled once into a DG0 (2×2) vector; evaluating is one
    vector assembly and a reduction over owned cells.
    """

    def __init__(self, y: dolfinx.fem.Function):
        mesh = y.function_space.mesh
        element = basix.ufl.element("DG", mesh.basix_cell(), 0, shape=(2, 2))
        self.space = dolfinx.fem.functionspace(mesh, element)
        test = ufl.TestFunction(self.space)
        self.form = dolfinx.fem.form(ufl.inner(metric_tensor_defect(y), test) * ufl.dx)
        self.comm = mesh.comm
        self.num_owned = mesh.topology.index_map(mesh.topology.dim).size_local
        self.volumes = self._cell_volumes(mesh)

    @staticmethod
    def _cell_volumes(mesh) -> np.ndarray:
        space = dolfinx.fem.functionspace(mesh, ("DG", 0))
        form = dolfinx.fem.form(ufl.TestFunction(space) * ufl.dx)
        vec = dolfinx.fem.assemble_vector(form)
        return vec.array.copy()

    def cell_values(self) -> np.ndarray:
        """|∫_T (∇yᵀ∇y − I)| for each owned cell."""
        vec = dolfinx.fem.assemble_vector(self.form)
        per_cell = vec.array.reshape(-1, 4)[: self.num_owned]
        return np.linalg.norm(per_cell, axis=1)

    def __call__(self) -> float:
        local = float(np.sum(self.cell_values()))
        return float(self.comm.allreduce(local, op=MPI.SUM))

    def density(self) -> np.ndarray:
        """Cell-wise defect per unit area, for plots (owned cells)."""
        return self.cell_values() / self.volumes[: self.num_owned]


__all__ = [
    "EdgeConstraint",
    "IsometryDefect",
    "linearised_isometry",
    "multiplier_element",
    "symmetric",
]
