"""The linearised isometry constraint and the isometry defect (DESIGN.md §2–§3).

The multiplier λ is a symmetric 2×2 matrix per cell (DG0, three values: λ₁₁, λ₁₂, λ₂₂), so the
linearised constraint ∇δyᵀ∇yⁿ + ∇yⁿᵀ∇δy = 0 holds for the integral mean over each cell.
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


__all__ = ["IsometryDefect", "linearised_isometry", "multiplier_element", "symmetric"]
