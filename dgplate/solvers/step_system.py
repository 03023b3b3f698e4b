"""The flow's step system: its forms, the step matrix K = A_const + B(yⁿ) and its solvers.

The block (1/τ)(·,·)_* + D²E_impl (A_const) does not depend on yⁿ: it is assembled only when
τ or an active set changes it, and each step adds b_n (cell integrals) to K in place
(docs/design.md §3). K is stored in DOLFINx's pattern of the step form without the constant
block's exact zeros (:mod:`dgplate.solvers.sparsity`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Protocol

import basix.ufl
import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from petsc4py import PETSc
from ufl.core.expr import Expr

from dgplate import compat, values
from dgplate.compat import Array, Function, FunctionSpace, Indices, Mesh
from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets, h2_metric
from dgplate.solvers import lagged, linear, ordering, sparsity, sqp
from dgplate.solvers.constraint import (
    EdgeConstraint,
    linearised_isometry,
    metric_measure,
    metric_tensor_defect,
    multiplier_element,
    symmetric,
)
from dgplate.solvers.lagged import StepSolver
from dgplate.solvers.linear import OptionValue, SolveStats

#: K follows yⁿ by increments B(yⁿ − y_K); it is assembled whole after this many, so that
#: their round-off (~10⁻¹⁶ of ‖B‖ each) cannot accumulate.
K_REASSEMBLY = 100


class StepSettings(Protocol):
    """The [flow] keys that the step system reads (:class:`dgplate.solvers.flow.FlowSpec`)."""

    multiplier_degree: int
    edge_constraint: bool
    solver: dict[str, OptionValue]
    linear_solver: str
    refactor_its: int

    @property
    def l2(self) -> bool | None:
        """Whether the metric has the L² product; None: decided by the model (clamped?)."""
        ...


@dataclass
class FlowCounts:
    """The flow's counters over all runs (``summary.json`` and checkpoints)."""

    fallbacks: int = 0  # solver fall-backs
    rejected_steps: int = 0  # steps redone with a smaller τ (flow.adaptive_tau)
    refactorisations: int = 0  # changes of τ in the step matrix (each reassembles A_const)
    newton_steps: int = 0  # accepted SQP steps (flow.newton_finish)
    newton_rejections: int = 0  # SQP steps redone as plain steps
    step_solves: int = 0  # solves with a step (or SQP) matrix: steps, redone steps, corrections
    active_set_changes: int = 0  # changes of an active set (each reassembles A_const)
    active_set_redos: int = 0  # steps redone because a point entered an active set


@dataclass
class Spaces:
    """The flow's mixed space W, the space V of y, y's dofs in W, and the state y."""

    W: FunctionSpace
    V: FunctionSpace
    vdofs: Indices
    y: Function


#: MUMPS's null-pivot detection, for the step systems of a continuous y: at a flat state its P1
#: moments (9 per cell) outnumber the in-plane unknowns (about 8 per cell for Q2) that alone
#: enter the linearised constraint there, so the systems are singular, and the factors without
#: it return garbage on two ranks (E_h 10³⁰ at the first step).
NULL_PIVOTS: dict[str, OptionValue] = {"mat_mumps_icntl_24": 1}


def mixed_space(
    mesh: Mesh, degree: int, settings: StepSettings, continuous: bool = False
) -> FunctionSpace:
    """W: y, the isometry multiplier, and the edge multipliers (if constrained).

    Args:
        mesh: the plate's mesh.
        degree: the degree k of y.
        settings: the [flow] keys of the constraint (multiplier degree, edge moments).
        continuous: y ∈ [Lagrange_k]³ (the C⁰ interior-penalty method, ``model.space = "c0"``;
            its first-moment multipliers are P1 on every cell) instead of [DG_k]³.

    Returns:
        The mixed space.
    """
    family = "Lagrange" if continuous else "DG"
    ve = basix.ufl.element(family, mesh.basix_cell(), degree, shape=(3,))
    elements = [ve, multiplier_element(mesh, settings.multiplier_degree, continuous)]
    if settings.edge_constraint:
        edge = basix.ufl.element("DG", mesh.basix_cell(), 0, shape=(EdgeConstraint.SIZE,))
        elements.append(edge)
    return dolfinx.fem.functionspace(mesh, basix.ufl.mixed_element(elements))


class StepSystem:
    """Assembles and solves the step system of the constrained flow (collective)."""

    def __init__(
        self,
        spaces: Spaces,
        facets: FacetSets,
        energy: Energy,
        settings: StepSettings,
        tau: float,
        counts: FlowCounts,
        metric: Expr | None = None,
    ):
        """The forms, K and the solvers at the state ``spaces.y``, with τ = ``tau``.

        ``metric``: the target metric G of the constraint ∇yᵀ∇y = G (None: I, an isometry);
        only the constraint's residual depends on it, not its linearisation.
        """
        self.settings, self.counts, self.energy = settings, counts, energy
        self.metric = metric
        self.W, self.V, self.vdofs, self.y = spaces.W, spaces.V, spaces.vdofs, spaces.y
        self.comm = facets.mesh.comm
        # factorisations of the runs this one resumes (the solvers count their own)
        self.earlier_factorisations = {"step": 0, "newton": 0}
        self._tau = values.constant(facets.mesh, tau)
        self._build_forms(facets, tau)
        self.K = self._compact_constant_block()
        self.solver: StepSolver | None = None  # made after the active sets and the scaling
        self.begin_active_sets()  # the pattern above has the couplings of the whole sets
        self._rhs_fn: Function = dolfinx.fem.Function(self.W)  # a ghosted vector in every version
        self.rhs = self._rhs_fn.x.petsc_vec
        # the constraint's residual at a step's start and at its end (the SQP steps' merit)
        self.start_residual, self.end_residual = self.rhs.duplicate(), self.rhs.duplicate()
        self.solution: Function = dolfinx.fem.Function(self.W)
        curvature = sqp.lagrangian_curvature(
            self.y, self.solution, energy.explicit, self._edge, self._scale, self._trial_test
        )
        self.newton = sqp.NewtonStep(self.comm, curvature, settings.solver)
        self._balance_constraint_rows()
        self.solver = self._make_solver()

    def _build_forms(self, facets: FacetSets, tau: float) -> None:
        """The step's forms, and the ufl of the stationarity measure's system."""
        y = self.y
        dy, multiplier, *edge_multiplier = ufl.TrialFunctions(self.W)
        v, q, *edge_q = ufl.TestFunctions(self.W)
        self._trial_test = (dy, v)
        # rigid motions, or a flap that can turn freely about a crease, leave the H² metric
        # singular: the L² product controls them
        rigid = not facets.has_clamped or facets.num_crease > 0
        l2 = rigid if self.settings.l2 is None else self.settings.l2
        hessian = ufl.derivative(ufl.derivative(self.energy.implicit, y, v), y, dy)
        metric = h2_metric(dy, v, facets, l2=l2)
        # the stationarity measure's metric must be definite by itself: a free plate's flow
        # may leave rigid motions to its implicit energy (an anchor spring) instead of L²
        stationarity_metric = h2_metric(dy, v, facets, l2=True) if rigid and not l2 else metric
        a_const = (1.0 / self._tau) * metric + hessian
        # The constraint rows are scaled by s (λ by 1/s, δy unchanged) so that they weigh like
        # the displacement rows: unscaled, ‖b_n‖ ~ 1 against ‖a‖ ~ h⁻³/τ, and a residual test
        # on the whole system would hardly see the constraint (see _balance_constraint_rows).
        s = self._scale = values.constant(facets.mesh, 1.0)
        b = linearised_isometry(v, y, multiplier) + linearised_isometry(dy, y, q)
        # residual of the nonlinear constraint in the multiplier rows: ∫ (∇yᵀ∇y − G) : q
        dx = metric_measure(y, self.metric)
        residual = -ufl.inner(metric_tensor_defect(y, self.metric), symmetric(q)) * dx
        self._edge = None
        if self.settings.edge_constraint:
            (edge_trial,), (edge_test,) = edge_multiplier, edge_q
            edge = self._edge = EdgeConstraint(facets)
            b += edge.linearised(v, y, edge_trial) + edge.linearised(dy, y, edge_test)
            residual -= edge.residual(y, edge_test)
            # cells without a free facet: their edge multipliers are pinned to zero
            pin = edge.interior * ufl.inner(edge_trial, edge_test) / facets.h * ufl.dx
            a_const += pin
            stationarity_metric += pin
        b, residual = s * b, s * residual
        # the projected-gradient system, its metric rows scaled by 1/τ⁰ so that they weigh
        # against the constraint rows as in K (a Constant: the form does not depend on τ⁰)
        scale = values.constant(facets.mesh, 1.0 / tau)
        self.stationarity_ufl = scale * stationarity_metric + b
        self._a_const = dolfinx.fem.form(a_const)
        self._b = dolfinx.fem.form(b)
        # b is linear in yⁿ, so B(yⁿ) = B(y_K) + B(yⁿ − y_K): K follows yⁿ by that increment
        # alone (see assemble), with the same compiled kernel (same signature)
        self._y_increment: Function = dolfinx.fem.Function(self.V)
        self._b_increment = dolfinx.fem.form(ufl.replace(b, {y: self._y_increment}))
        self._y_in_K = y.x.array.copy()  # the state whose B(y) K holds
        self._K_updates = 0  # increments added since K was last assembled whole
        self._K_whole = True  # K must be assembled whole at the next step
        explicit = self.energy.total
        if self.energy.step_shift is not None:
            explicit = explicit + self.energy.step_shift
        for term in self.energy.nonlocal_terms:
            explicit = explicit + term.linearisation
        self.rhs_form = dolfinx.fem.form(-ufl.derivative(explicit, y, v))
        self._constraint_residual = dolfinx.fem.form(residual)
        self._step_ufl = a_const + b

    def _make_solver(self) -> StepSolver:
        """The solver of the step systems K x = b (see :mod:`dgplate.solvers.linear`)."""
        settings = self.settings
        if settings.linear_solver == "direct":
            return linear.DirectStepSolver(self.comm, self.K, settings.solver, prefix=None)
        return lagged.LaggedStepSolver(
            self.comm,
            self.K,
            settings.solver,
            None,
            settings.refactor_its,
            ordering.cellwise_numbering(self.W),
            symmetric=True,
        )

    def _balance_constraint_rows(self) -> None:
        """Scale the constraint rows by s = ‖A_const‖_∞ / ‖B(y⁰)‖_∞, to weigh like the others.

        Only λ changes with s. The iterative solves stop on the residual of the whole system;
        with s = 1 its constraint part counts ~h³ less than the displacement part, and
        solutions that meet the tolerance drift off the constraint step by step (E_h to only
        ~1e-8 after a flow). Balanced, fewer iterations give E_h to ~1e-9.
        """
        # K holds A_const, then B alone, until the first step assembles it whole
        compat.assemble_matrix_into(self.K, self._a_const)
        norm_a = max_row_sum(self.K)
        compat.assemble_matrix_into(self.K, self._b)
        norm_b = max_row_sum(self.K)
        if norm_b > 0:
            self._scale.value = np.asarray(norm_a / norm_b)
        self._K_whole = True

    @functools.cached_property
    def step_form(self) -> compat.Form:
        """The whole step matrix as one form, compiled at its first use.

        The step assembles A_const and B apart; this form is for inspection, and compiling it
        up front would cost a second JIT compilation the size of a_const's.
        """
        form: compat.Form = dolfinx.fem.form(self._step_ufl)
        return form

    def _compact_constant_block(self) -> PETSc.Mat:
        """A_const in the pattern of the step form minus the constant block's exact zeros.

        The multiplier rows and columns keep DOLFINx's pattern (b_n fills them as yⁿ moves);
        in the displacement block only the couplings that the metric and the implicit energy
        actually have are stored (:mod:`dgplate.solvers.sparsity`). A_const and B are not
        stored apart (at 256² a matrix of this pattern is 1.6 GB).
        """
        # DOLFINx's pattern of a_const is that of the whole step form: b_n only couples the
        # dofs of one cell, which the cell integrals of a_const already do
        full: PETSc.Mat = dolfinx.fem.petsc.assemble_matrix(self._a_const)  # DOLFINx's pattern
        full.assemble()
        if not self.V.ufl_element().discontinuous:
            # a continuous y's row takes b_n's entries from cells of other ranks whose
            # multipliers are no ghosts here, so their columns cannot be kept by index
            return full
        imap, bs = self.W.dofmap.index_map, self.W.dofmap.index_map_bs
        is_multiplier = np.ones((imap.size_local + imap.num_ghosts) * bs, dtype=bool)
        is_multiplier[self.vdofs] = False
        multipliers = np.flatnonzero(is_multiplier)
        compact = sparsity.without_exact_zeros(
            full,
            keep_rows=is_multiplier[: imap.size_local * bs],
            keep_cols=np.sort(sparsity.global_indices(imap, bs, multipliers)),
        )
        full.destroy()
        return compact

    @property
    def tau(self) -> float:
        """The time step τ held in the step matrix."""
        return float(self._tau.value)

    def put_tau(self, value: float) -> None:
        """τ into the step matrix: A_const is reassembled at the next step; counted."""
        self.counts.refactorisations += 1
        self._tau.value = np.asarray(value)
        self._K_whole = True

    def begin_active_sets(self) -> None:
        """The active sets from the current state yⁿ; A_const follows them when they change."""
        if any([term.begin() for term in self.energy.active_sets]):
            self.active_sets_changed()

    def active_sets_changed(self) -> None:
        """An active set changed: reassemble A_const and refactorise at the next solve."""
        self.counts.active_set_changes += 1
        self._K_whole = True
        solver = self.solver  # None while the system is built
        if solver is not None and not isinstance(solver, linear.DirectStepSolver):
            solver.constant_changed()

    def assemble(self, newton: bool = False, residual: bool = False) -> StepSolver:
        """K = A_const + B(yⁿ) and the right-hand side −DE_h[yⁿ]; with ``newton`` also K_N.

        K is assembled whole after A_const changed, and every K_REASSEMBLY steps so that
        the round-off of the increments cannot accumulate; otherwise B(yⁿ − y_K) is added to K,
        which holds A_const + B(y_K).

        Args:
            newton: also assemble the SQP matrix K_N = K + H (:mod:`dgplate.solvers.sqp`).
            residual: the constraint rows' right-hand side is −(∇yⁿᵀ∇yⁿ − G) instead of 0, so
                that the step also solves the linearised constraint from yⁿ's defect (an SQP
                step from a state off the constraint); the residual is kept in
                :attr:`start_residual`.

        Returns:
            The solver of the step: the step solver, or K_N's for an SQP step.
        """
        y = self.y.x.array
        if self._K_whole or self._K_updates >= K_REASSEMBLY:
            compat.assemble_matrix_into(self.K, self._a_const)
            compat.add_matrix_form(self.K, self._b)
            self._K_whole, self._K_updates = False, 0
        else:
            self._y_increment.x.array[:] = y - self._y_in_K
            compat.add_matrix_form(self.K, self._b_increment)
            self._K_updates += 1
        self._y_in_K[:] = y
        for term in self.energy.nonlocal_terms:
            term.update()
        compat.assemble_vector_into(self.rhs, self.rhs_form)
        if residual:
            self.add_constraint_residual()
        assert self.solver is not None
        return self.newton.assemble(self.K) if newton else self.solver

    def add_constraint_residual(self) -> None:
        """The constraint rows' right-hand side −(∇yⁿᵀ∇yⁿ − G) added to :attr:`rhs`, and kept."""
        compat.assemble_vector_into(self.start_residual, self._constraint_residual)
        self.rhs.axpy(1.0, self.start_residual)

    def multiplier_term(self, at_start: bool = False) -> float:
        """Σ_T ∫_T λ : (∇yᵀ∇y − G) (edge moments included) with the last step's λ (collective).

        The Lagrangian's constraint term at the current y, or at the step's start yⁿ
        (``at_start``: the residual that :meth:`assemble` kept). The constraint rows are scaled
        by s and their residual is −s(∇yᵀ∇y − G) : q, the multiplier component of the solution
        is λ/s: the term is minus their dot product.

        Args:
            at_start: at yⁿ instead of the current y.

        Returns:
            The term.
        """
        if not at_start:
            compat.assemble_vector_into(self.end_residual, self._constraint_residual)
        residual = self.start_residual if at_start else self.end_residual
        return -float(residual.dot(self.solution.x.petsc_vec))

    def solve(self, solver: StepSolver) -> SolveStats:
        """Solve the assembled step with ``solver`` (that of :meth:`assemble`) into ``solution``."""
        stats = solver.solve(self.rhs, self.solution.x.petsc_vec)
        self.counts.step_solves += 1
        self.solution.x.scatter_forward()
        return stats

    def correct(self, stats: SolveStats, solver: StepSolver, refactor: bool = False) -> Array:
        """One correction towards ∫_T (∇yᵀ∇y − G) q = 0, reusing the step's factorisation.

        Args:
            stats: the step's figures; the correction's fall-backs are added to them.
            solver: the solver that holds the step's factors.
            refactor: factorise K first (K assembled at a new state, no step solved with it).

        Returns:
            The change of y's dofs (already added to y).
        """
        compat.assemble_vector_into(self.rhs, self._constraint_residual)
        correction: Function = dolfinx.fem.Function(self.W)
        more = solver.solve(self.rhs, correction.x.petsc_vec, refactor=refactor)
        self.counts.step_solves += 1
        stats.fallbacks += more.fallbacks
        correction.x.scatter_forward()
        c: Array = correction.x.array[self.vdofs]
        self.y.x.array[:] += c
        return c

    def factorisations(self) -> int | None:
        """Factorisations of the step solver over all runs (None: it does not count them)."""
        own = getattr(self.solver, "factorisations", None)
        return None if own is None else own + self.earlier_factorisations["step"]

    def newton_factorisations(self) -> int:
        """Factorisations of the SQP matrices over all runs."""
        return int(self.newton.factorisations) + self.earlier_factorisations["newton"]

    def destroy(self) -> None:
        """Free the solvers and the matrix."""
        if self.solver is not None:
            self.solver.destroy()
        self.newton.destroy()
        self.K.destroy()
        self.start_residual.destroy()
        self.end_residual.destroy()


def max_row_sum(matrix: PETSc.Mat) -> float:
    """‖A‖_∞, the largest absolute row sum.

    Args:
        matrix: the matrix.

    Returns:
        Its norm.
    """
    norm = matrix.norm(compat.NORM_INFINITY)
    assert isinstance(norm, float)  # a tuple only for NORM_1_AND_2
    return norm
