"""Corrections that bring a step's state back onto the nonlinear isometry constraint.

Each correction solves the step system with the constraint's residual ∫_T (∇yᵀ∇y − I) q as its
right-hand side, reusing the step's factors (:meth:`StepSystem.correct`): the least change in
the step's metric that solves the constraint linearised at the step's start (a chord step).
The corrections that close an SQP step are Anderson-mixed (:class:`AndersonMixing`).
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np

from dgplate.compat import Array
from dgplate.solvers.constraint import IsometryDefect
from dgplate.solvers.lagged import StepSolver
from dgplate.solvers.linear import SolveStats
from dgplate.solvers.step_system import StepSystem

#: At most this many corrections close the constraint after an SQP step (see close_constraint).
SQP_CORRECTIONS = 20
#: D_h per unit area at which an SQP step's state counts as a discrete isometry.
SQP_DEFECT_TOL = 1e-12
#: The corrections' differences the closing's Anderson mixing combines (at most).
ANDERSON_DEPTH = 5


class AndersonMixing:
    """Anderson acceleration of the fixed-point iteration y ← y + c(y) (type II).

    After each correction c_k (already added: y = y_k + c_k) the next state is
    y_k + c_k − (ΔY + ΔC) γ, with ΔY, ΔC the differences of the last states and corrections
    and γ the least-squares fit of c_k by ΔC (H. F. Walker and P. Ni, SIAM J. Numer. Anal. 49,
    2011). The chord corrections converge linearly at a rate that grows with the step's
    rotation; mixed, the SQP steps of a strip rolling through a full turn (96×8 cells) close
    in 226 solves instead of 426, and fewer of them are refused (docs/performance.md).
    scipy.optimize.anderson owns its loop and is serial: the fit here is a global reduction.
    """

    def __init__(self, comm: MPI.Comm, owned: int, depth: int = ANDERSON_DEPTH):
        """``owned``: the number of the local entries of y that this rank owns (first)."""
        self.comm, self.owned, self.depth = comm, owned, depth
        self.states: list[Array] = []
        self.corrections: list[Array] = []

    def mix(self, state: Array, correction: Array) -> Array:
        """The change to subtract from y = ``state`` + ``correction`` (zero at the first call).

        Args:
            state: y before the correction (every local entry, ghosts included).
            correction: the correction added to it.

        Returns:
            (ΔY + ΔC) γ, consistent on the ghosts as the inputs are.
        """
        self.states = [*self.states[-self.depth :], state.copy()]
        self.corrections = [*self.corrections[-self.depth :], correction.copy()]
        if len(self.states) < 2:
            return np.zeros_like(correction)
        dC = np.diff(np.array(self.corrections), axis=0).T
        dY = np.diff(np.array(self.states), axis=0).T
        own = dC[: self.owned]
        gram = self.comm.allreduce(own.T @ own, op=MPI.SUM)
        rhs = self.comm.allreduce(own.T @ correction[: self.owned], op=MPI.SUM)
        if not (np.all(np.isfinite(gram)) and np.all(np.isfinite(rhs))):
            # a diverged closing (its step is refused): the plain correction, history cleared
            self.states, self.corrections = [], []
            return np.zeros_like(correction)
        gamma = np.linalg.lstsq(gram, rhs, rcond=1e-12)[0]
        change: Array = (dY + dC) @ gamma
        return change


class Projection:
    """The corrections after a step: ``flow.projection_steps``, and closing an SQP step."""

    def __init__(self, system: StepSystem, defect: IsometryDefect, steps: int):
        """``steps``: corrections after every step (``flow.projection_steps``)."""
        self.system, self.defect, self.steps = system, defect, steps

    def project(self, stats: SolveStats, solver: StepSolver, change: Array) -> None:
        """The ``flow.projection_steps`` corrections of a step.

        Args:
            stats: the step's figures (the corrections' fall-backs are added).
            solver: the solver that holds the step's factors.
            change: the step's change of y's dofs; each correction is added to it.
        """
        for _ in range(self.steps):
            change += self.system.correct(stats, solver)

    def close_constraint(self, stats: SolveStats, solver: StepSolver, change: Array) -> None:
        """Corrections after an SQP step until D_h is at round-off (arguments: :meth:`project`).

        An SQP step lowers E_h partly along the constraint's curvature. Its corrections are
        chord iterations (b_n of the step's start, the SQP factors), which converge linearly,
        and a state left off the constraint by D_h lies below the constrained energy by about
        λ·D_h: the next steps, whose projections restore the constraint, would count that as a
        rise of E_h, and the controller would reject them down to the least τ (BNN 64²: D_h =
        7.9·10⁻⁷ after two corrections, and every following step "raised" E_h by 1.3·10⁻⁷).
        So at least two corrections are made, then more until D_h ≤ ``SQP_DEFECT_TOL``·|ω|,
        while each correction at least halves D_h, and at most ``SQP_CORRECTIONS``; they are
        Anderson-mixed.
        """
        tol = SQP_DEFECT_TOL * self.defect.area
        y = self.system.y
        owned = y.function_space.dofmap.index_map.size_local * y.function_space.dofmap.index_map_bs
        mixing = AndersonMixing(y.function_space.mesh.comm, owned)
        defect = math.inf
        for count in range(SQP_CORRECTIONS):
            state = y.x.array.copy()
            correction = self.system.correct(stats, solver)
            adjust = mixing.mix(state, correction)
            y.x.array[:] -= adjust
            change += correction - adjust
            previous, defect = defect, self.defect()
            if not math.isfinite(defect):  # diverged: the step is refused by its energy
                break
            if count >= 1 and (defect <= tol or defect > 0.5 * previous):
                break
