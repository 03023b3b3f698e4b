"""The LDG reconstructed Hessian of a broken deformation (``model.hessian = "ldg"``).

Bonito, Guignard, Nochetto and Yang (prestrained plates, IMA J. Numer. Anal. 2023) replace the
broken Hessian D²_h y of the bending energy by the reconstructed Hessian

    H_h(y) = D²_h y − R_h([∇y]) + B_h([y]) ∈ [V_l]^{3×2×2},

with the lifting operators onto the broken polynomials V_l of degree l: for a facet e,
∫ r_e(φ) : τ = ∫_e {τ} : φ ⊗ n and ∫ b_e(v) : τ = ∫_e {div τ} n · v for all τ ∈ [V_l]^{3×2×2},
R_h = Σ_e r_e, B_h = Σ_e b_e (on clamped facets the jumps against the Nitsche data, with
one-sided τ). Here l = k, the degree of y: then D²_h y ∈ V_l (on triangles and on
quadrilaterals), so that H_h(y) is the L² projection onto V_l of the distributional Hessian
⟨D²y, τ⟩ of :func:`dgplate.dg.forms.distributional_hessian`, a cell-local (block-diagonal)
solve. The energy is

    E_h[y] = ½∫μ|H_h(y)|² + ½Σ_e γ₁h⁻ᵖ{μ}|[∇y]|² + ½Σ_e γ₀h⁻³{μ}|[y]|²,

whose penalties need only be positive (the lifting terms carry the stability that the
interior-penalty method asks of large γ).

How it enters the flow. ½∫μ|H_h(y)|² couples the facets of each cell, which a UFL form cannot
express, and its matrix Bᵀ M⁻¹ B has a wider stencil than DOLFINx's dG pattern. It is split
into a quadratic upper bound and a concave rest: expanding the square,

    ½∫μ|H_h(y)|² = a_SIPG(y) + ½∫μ|R_h − B_h|²,

with a_SIPG the symmetric interior-penalty energy without penalties (:func:`bending_energy`
with γ = 0), and ½∫μ|R_h − B_h|² ≤ ½Σ_e c{μ}(h⁻¹|[∇y]|² + h⁻³|[y]|²) (trace and inverse
inequalities, c = :func:`lifting_bound`). The implicit energy is a_SIPG with the penalties
c and the user's γ, a quadratic form whose Hessian is the flow's constant matrix; the rest,
½∫μ|R_h − B_h|² − ½Σ_e c{μ}(…), is concave and enters as an explicit, nonlocal term
(:class:`LiftedHessian`, the :class:`~dgplate.dg.energy.Nonlocal` protocol) that computes
H_h(yⁿ) by the cell-local projection before each assembly. An explicit concave part keeps the
flow energy-decreasing, and its derivative at yⁿ, ∫μ H_h(yⁿ) : H_h(v) = ⟨D²v, μ H_h(yⁿ)⟩
minus that of the bound, is exact: the stationary points, and so the discrete minimisers, are
those of the LDG energy. The matrix is stiffer than the LDG Hessian on jump modes, by at most
(γ + c)/γ: small γ costs steps.
"""

from __future__ import annotations

import math
from typing import Unpack

import dolfinx.fem
import dolfinx.fem.petsc
import ufl
from petsc4py import PETSc
from ufl.core.expr import Expr

from dgplate import compat
from dgplate.compat import Function
from dgplate.dg.energy import Energy
from dgplate.dg.forms import (
    BendingData,
    FacetSets,
    Penalty,
    bending_energy,
    distributional_hessian,
    integral,
    jump_penalty,
)

#: The Hessians of the bending energy (``model.hessian``), the default first.
HESSIANS = ("broken", "ldg")
#: The help text of ``model.hessian`` in the plate models' schemas.
HESSIAN_HELP = (
    "Hessian of the bending energy: 'broken' (interior penalty, D²_h y with consistency terms) "
    "or 'ldg' (the reconstructed Hessian D²_h y − R_h[∇y] + B_h[y] with lifting operators of "
    "degree k, docs/design.md; any penalties > 0)"
)


def lifting_bound(degree: int) -> Penalty:
    """Penalties c₀, c₁ with ½∫|R_h − B_h|² ≤ ½Σ_e (c₁h⁻¹|[∇y]|² + c₀h⁻³|[y]|²) (h: diameter).

    c₁ = 11(k + 1)², c₀ = 37(k + 1)⁴: for k = 2 (99, 2997) against the largest ratio measured
    on 4 × 4 meshes clamped on one side (c₀ = 30c₁): 43, 60 and 78 for c₁ on uniform
    quadrilaterals, perturbed quadrilaterals and right triangles (tests/dg/test_lifting.py).

    Args:
        degree: the polynomial degree k of y (and of the liftings).

    Returns:
        The bound as a :class:`Penalty` (p = 1).
    """
    return Penalty(gamma0=37.0 * (degree + 1) ** 4, gamma1=11.0 * (degree + 1) ** 2)


class LiftedHessian:
    """½∫μ|H_h(y)|² − a_SIPG,c(y), the concave rest of the LDG energy (module docstring).

    A :class:`~dgplate.dg.energy.Nonlocal` term without a safety net (``max_redo = 0``):
    :meth:`update` projects the distributional Hessian of the current y onto [V_k]^{3×2×2}
    (:attr:`H`, a cell-local solve with the mass matrix factorised once) and returns the
    term's value; :attr:`linearisation` has the term's derivative at y.
    """

    max_redo = 0
    min_distance = math.inf

    def __init__(self, y: Function, facets: FacetSets, degree: int, **data: Unpack[BendingData]):
        """The term of the deformation ``y`` (in [DG_k]³, k = ``degree``) on ``facets``.

        ``data``: the rigidity ``mu`` and the clamped data ``g``, ``Phi`` (as for
        :func:`~dgplate.dg.forms.bending_energy`).
        """
        mesh = facets.mesh
        self.comm = mesh.comm
        space = dolfinx.fem.functionspace(mesh, ("DG", degree, (3, 2, 2)))
        self.H: Function = dolfinx.fem.Function(space, name="H_h")
        test, trial = ufl.TestFunction(space), ufl.TrialFunction(space)
        g, Phi = data.get("g"), data.get("Phi")
        self._rhs = dolfinx.fem.form(distributional_hessian(y, test, facets, g, Phi))
        self._mass = dolfinx.fem.petsc.assemble_matrix(
            dolfinx.fem.form(ufl.inner(trial, test) * ufl.dx)
        )
        self._mass.assemble()
        self._ksp = _block_solver(self._mass)
        self._rhs_fn: Function = dolfinx.fem.Function(space)  # a ghosted vector in every version
        self._b = self._rhs_fn.x.petsc_vec
        mu = data.get("mu")
        mu = 1.0 if mu is None else mu
        bound = bending_energy(y, facets, lifting_bound(degree), **data)
        self.linearisation: ufl.Form = (
            distributional_hessian(y, mu * self.H, facets, g, Phi) - bound
        )
        self._value = dolfinx.fem.form(0.5 * mu * ufl.inner(self.H, self.H) * ufl.dx - bound)

    def project(self) -> Function:
        """H_h(y) at the current y, into :attr:`H` (collective)."""
        compat.assemble_vector_into(self._b, self._rhs)
        self._ksp.solve(self._b, self.H.x.petsc_vec)
        self.H.x.scatter_forward()
        return self.H

    def update(self) -> float:
        """The term's value at the current y; refreshes :attr:`H` (collective)."""
        self.project()
        return integral(self._value, self.comm)

    def accept(self) -> bool:
        """Always: the term has no safety net."""
        return True


#: The options prefix of the cell-wise mass solves.
_PREFIX = "dgplate_lifting_"


def _block_solver(mass: PETSc.Mat) -> PETSc.KSP:
    """A direct solver of the block-diagonal (cell-wise) mass matrix of a dG space.

    Block Jacobi over the ranks with ILU(0) in each block: the cell blocks are dense, so the
    incomplete factorisation has no fill to drop and is exact.
    """
    ksp = PETSc.KSP().create(mass.getComm())
    ksp.setOperators(mass)
    ksp.setOptionsPrefix(_PREFIX)
    ksp.setType("preonly")
    ksp.getPC().setType("bjacobi")
    # the blocks' solvers through the options database: petsc4py < 3.23 (Debian 13's 3.22)
    # has no PC.getBJacobiSubKSP
    options = PETSc.Options(_PREFIX)
    options.setValue("sub_ksp_type", "preonly")
    options.setValue("sub_pc_type", "ilu")
    ksp.setFromOptions()
    ksp.setUp()
    return ksp


def ldg_energy(
    y: Function,
    facets: FacetSets,
    penalty: Penalty,
    degree: int,
    load: Expr | None = None,
    **data: Unpack[BendingData],
) -> Energy:
    """The LDG bending energy (module docstring) less ∫f·y: the implicit bound, the rest nonlocal.

    ``data``: the rigidity ``mu`` and the clamped data ``g``, ``Phi``.
    """
    implicit = bending_energy(y, facets, lifting_bound(degree), **data)
    implicit += jump_penalty(y, facets, penalty, **data)
    if load is not None:
        implicit -= ufl.inner(load, y) * facets.dx
    return Energy(implicit=implicit, nonlocal_terms=[LiftedHessian(y, facets, degree, **data)])
