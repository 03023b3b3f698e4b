"""Corrections that bring a step's state back onto the nonlinear isometry constraint.

Each correction solves the step system with the constraint's residual ∫_T (∇yᵀ∇y − I) q as its
right-hand side, reusing the step's factors (:meth:`StepSystem.correct`): the least change in
the step's metric that solves the constraint linearised at the step's start (a chord step).
"""

from __future__ import annotations

import math

from dgplate.compat import Array
from dgplate.solvers.constraint import IsometryDefect
from dgplate.solvers.lagged import StepSolver
from dgplate.solvers.linear import SolveStats
from dgplate.solvers.step_system import StepSystem

#: At most this many corrections close the constraint after an SQP step (see close_constraint).
SQP_CORRECTIONS = 20
#: D_h per unit area at which an SQP step's state counts as a discrete isometry.
SQP_DEFECT_TOL = 1e-12


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
        while each correction at least halves D_h, and at most ``SQP_CORRECTIONS``.
        """
        tol = SQP_DEFECT_TOL * self.defect.area
        defect = math.inf
        for count in range(SQP_CORRECTIONS):
            change += self.system.correct(stats, solver)
            previous, defect = defect, self.defect()
            if count >= 1 and (defect <= tol or defect > 0.5 * previous):
                break
