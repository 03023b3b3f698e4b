"""The flow's stopping tests (``flow.stop``): the rate, or ‖P DE_h[y]‖_*', which is free of τ."""

from __future__ import annotations

import math
from typing import Protocol

import dolfinx.fem
import dolfinx.fem.petsc
from petsc4py import PETSc

from dgplate import compat
from dgplate.compat import Function
from dgplate.solvers import lagged, linear, ordering
from dgplate.solvers.lagged import StepSolver
from dgplate.solvers.linear import OptionValue
from dgplate.solvers.step_system import StepSettings, StepSystem
from dgplate.solvers.steps import StepInfo, StopRule, measured, stop_reason

#: The measure's Krylov tolerance: near a critical point ‖P DE_h‖ is a small part of ‖DE_h‖,
#: the right-hand side, and the step's 10⁻⁹ left it reproducible to only ~10⁻⁵ (2 ranks).
STATIONARITY_KRYLOV: dict[str, OptionValue] = {"ksp_rtol": 1e-13}


class StopSettings(StepSettings, StopRule, Protocol):
    """The [flow] keys of the stopping tests, besides the step system's."""


class Stationarity:
    """The projected-gradient system of a flow and its solver, built at the first call."""

    def __init__(self, system: StepSystem, settings: StopSettings, initial_tau: float):
        """The measure of ``system``'s state; its metric rows carry 1/``initial_tau``."""
        self.system, self.settings, self.initial_tau = system, settings, initial_tau
        self._built: tuple[compat.Form, PETSc.Mat, StepSolver] | None = None
        self._gradient: Function = dolfinx.fem.Function(system.W)  # g of __call__
        self._tangent: Function = dolfinx.fem.Function(system.W)  # g without its multipliers
        self.fallbacks = 0  # of its solves, added to the step's record

    def _build(self) -> tuple[compat.Form, PETSc.Mat, StepSolver]:
        """The compiled form, its matrix and its solver (at the first call: the JIT costs)."""
        comm, settings = self.system.comm, self.settings
        form = dolfinx.fem.form(self.system.stationarity_ufl)
        matrix = dolfinx.fem.petsc.assemble_matrix(form)
        matrix.assemble()
        solver: StepSolver = (
            linear.DirectStepSolver(comm, matrix, settings.solver, prefix=None)
            if settings.linear_solver == "direct"
            else lagged.LaggedStepSolver(
                comm,
                matrix,
                {**STATIONARITY_KRYLOV, **(settings.solver or {})},
                None,
                settings.refactor_its,
                ordering.cellwise_numbering(self.system.W),
                symmetric=True,
            )
        )
        return form, matrix, solver

    def __call__(self) -> float:
        """‖P DE_h[y]‖_*', the dual norm of the projected gradient at the current y (collective).

        The KKT residual of the constrained problem in the flow's metric M = (·,·)_*: with
        M g + b(·, μ) = −DE_h[y], b(g, q) = 0 (g: the steepest descent in the tangent space of
        the linearised constraint), it is ‖g‖_M = (−DE_h[y](g))^½. It vanishes exactly at the
        discrete constrained critical points, and unlike the rate (E_h[yⁿ⁻¹] − E_h[yⁿ])/τ it does
        not depend on τ. One assembly and one solve per call: the matrix changes from call to
        call only through b_n(y), as the step matrix does, so it is solved like the step, by
        FGMRES preconditioned with lagged LU factors of its own (refactorised when the
        iterations grow; a fresh LU with ``flow.linear_solver = 'direct'``; freed at
        destroy()); its metric rows carry 1/τ⁰ (the initial τ), so that the rows weigh as in
        the step matrix and the iterative solve's residual test sees both parts (unscaled, the
        measure of one state varied by 10⁻⁶ between solves). Where rigid motions or a free
        flap about a crease leave the H² metric singular, M has the L² part, also where the
        flow's metric has not (flow.l2_metric = false with an anchor).

        Returns:
            The measure; its solves' fall-backs are added to :attr:`fallbacks`.
        """
        if self._built is None:
            self._built = self._build()
        form, matrix, solver = self._built
        rhs = self.system.rhs
        compat.assemble_matrix_into(matrix, form)
        compat.assemble_vector_into(rhs, self.system.rhs_form)
        gradient = self._gradient.x.petsc_vec
        gradient.set(0.0)  # g can change much between calls (a heat step, new data)
        self.fallbacks += solver.solve(rhs, gradient).fallbacks
        self._gradient.x.scatter_forward()
        return self._metric_norm(matrix)

    def _metric_norm(self, matrix: PETSc.Mat) -> float:
        """‖g‖_M from the solution (τ⁰ g, μ): (τ⁰g, 0)ᵀ K (τ⁰g, 0) = τ⁰ gᵀMg (collective).

        The solution's multiplier part set to zero leaves only the metric block of the
        system K, whose rows carry 1/τ⁰: a sum of non-negative terms. The equal −DE_h[y](g)
        is a difference of large terms near a critical point, where DE_h[y] is balanced by
        the multipliers' forces: it came out at round-off or negative (read as 0) there.
        """
        tangent = self._tangent
        tangent.x.array[:] = 0.0
        tangent.x.array[self.system.vdofs] = self._gradient.x.array[self.system.vdofs]
        vector = tangent.x.petsc_vec
        image = vector.duplicate()
        matrix.mult(vector, image)
        value = float(vector.dot(image)) / self.initial_tau
        image.destroy()
        return math.sqrt(max(value, 0.0))

    def stop_reason(self, info: StepInfo) -> str:
        """Why the flow stops converged after the step ``info`` ('' to go on): ``flow.stop``.

        The rule is :func:`dgplate.solvers.steps.stop_reason`. When it needs the measure, it
        is stored in the record, and its solves' fall-backs are added to the record's and the
        flow's counts.
        """
        if measured(self.settings):
            before = self.fallbacks
            info.stationarity = self()
            more = self.fallbacks - before  # in the record and in the total
            info.fallbacks += more
            self.system.counts.fallbacks += more
        return stop_reason(self.settings, info.rate, info.stationarity)

    def destroy(self) -> None:
        """Free the solver and the matrix (if built)."""
        if self._built is not None:
            self._built[2].destroy()
            self._built[1].destroy()
