"""Corrections that bring a step's state back onto the nonlinear isometry constraint.

Each correction solves the step system with the constraint's residual ∫_T (∇yᵀ∇y − I) q as its
right-hand side, reusing the step's factors (:meth:`StepSystem.correct`): the least change in
the step's metric that solves the constraint linearised at the step's start (a chord step).
The corrections that close an SQP step are Anderson-mixed (:class:`AndersonMixing`). The
trust region's SQP steps are not closed: they take their start's defect into their own
right-hand side, get one correction, and are judged by a merit function (:class:`Merit`); a
converged run lands on the constraint (:meth:`Projection.land`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np

from dgplate.compat import Array
from dgplate.solvers.constraint import IsometryDefect
from dgplate.solvers.lagged import StepSolver
from dgplate.solvers.linear import SolveStats
from dgplate.solvers.step_system import StepSystem
from dgplate.solvers.steps import not_raised

#: At most this many corrections close the constraint after an SQP step (see close_constraint).
SQP_CORRECTIONS = 20
#: D_h per unit area at which an SQP step's state counts as a discrete isometry.
SQP_DEFECT_TOL = 1e-12
#: Chord corrections after an SQP step that goes off the constraint (Projection.correct_sqp_step).
SQP_STEP_CORRECTIONS = 1
#: D_h per unit area that an SQP step off the constraint may leave (more only if its start had
#: more): its merit E_h + λ·c is the energy of the state brought back onto the constraint only
#: to first order in the defect, and λ·c is unbounded below (see Merit). With 0.02 and more the
#: I-shaped plate at its paper mesh ended at another minimiser than the closed steps' (E_h −1.9 %,
#: its axis 8.5° off; docs/performance.md).
SQP_STEP_DEFECT = 0.01
#: The corrections' differences the closing's Anderson mixing combines (at most).
ANDERSON_DEPTH = 5


class AndersonMixing:
    """Anderson acceleration of the fixed-point iteration y ← y + c(y) (type II).

    After each correction c_k (already added: y = y_k + c_k) the next state is
    y_k + c_k − (ΔY + ΔC) γ, with ΔY, ΔC the differences of the last states and corrections
    and γ the least-squares fit of c_k by ΔC (H. F. Walker and P. Ni, SIAM J. Numer. Anal. 49,
    2011). The chord corrections converge linearly at a rate that grows with the step's
    rotation; mixed, the SQP steps of a strip rolling through a full turn (96×8 cells), when
    each was closed, took 226 solves instead of 426 (docs/performance.md). They now close the
    defect-bound control's SQP steps and land a converged trust-region run.
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


@dataclass(frozen=True)
class Merit:
    """The Lagrangian's constraint term Σ_T ∫_T λ : (∇yᵀ∇y − G) of an SQP step, with its λ.

    At the step's start yⁿ and at its end: E_h + this term is the merit function of the SQP
    steps that go off the constraint (:meth:`Projection.correct_sqp_step`). To first order it is
    the energy of the state brought back onto the constraint: that moves y by −B⁺c, which
    changes E_h by −DE_h B⁺c = λ·c at a KKT point.
    """

    start: float
    end: float

    def lowered(self, energy_start: float, energy_end: float) -> bool:
        """Whether the step lowered E_h + λ·c (to a relative 10⁻¹²).

        Args:
            energy_start: E_h[yⁿ].
            energy_end: E_h at the step's end.

        Returns:
            True when the merit did not rise.
        """
        return not_raised(energy_start + self.start, energy_end + self.end)


class Projection:
    """The corrections after a step: ``flow.projection_steps``, and closing an SQP step."""

    def __init__(self, system: StepSystem, defect: IsometryDefect, steps: int):
        """``steps``: corrections after every step (``flow.projection_steps``)."""
        self.system, self.defect, self.steps = system, defect, steps
        # the factors of the last SQP step that left the state off the constraint (None: on it)
        self._off: tuple[SolveStats, StepSolver] | None = None

    def after_step(
        self, stats: SolveStats, solver: StepSolver, change: Array, sqp: bool, off: bool
    ) -> Merit | None:
        """The corrections of a step: :meth:`correct_sqp_step`, or :meth:`project` (and more).

        After :meth:`project`, an SQP step is closed by :meth:`close_constraint`.

        Args:
            stats: the step's figures (the corrections' fall-backs are added).
            solver: the solver that holds the step's factors.
            change: the step's change of y's dofs; each correction is added to it.
            sqp: whether the step was an SQP step.
            off: whether it may stay off the constraint (an SQP step from its start's defect).

        Returns:
            The step's merit terms when it stays off the constraint, else None.
        """
        if off:
            return self.correct_sqp_step(stats, solver, change)
        self.project(stats, solver, change)
        if sqp:
            self.close_constraint(stats, solver, change)
        return None

    def correct_sqp_step(self, stats: SolveStats, solver: StepSolver, change: Array) -> Merit:
        """The corrections of an SQP step that may leave the state off the constraint.

        The step solved the linearised constraint from its start's defect (:meth:`StepSystem.
        assemble` with ``residual``), so its end is off the constraint by the quadratic term
        (∇δyᵀ∇δy) only, and the next step takes that defect back: closing it at every step cost
        most of the solves of a roll-up (226 of them for a full turn of a 96 × 8 strip, 22 step
        factorisations). One chord correction with the step's factors (a second-order
        correction, as in Fletcher's SQP) leaves a defect of third order, ‖δy‖³; the state is
        brought onto the constraint by :meth:`land` when a run ends.

        Args:
            stats: the step's figures (the correction's fall-backs are added).
            solver: the solver that holds the SQP step's factors.
            change: the step's change of y's dofs; the correction is added to it.

        Returns:
            The step's merit terms.
        """
        for _ in range(SQP_STEP_CORRECTIONS):
            change += self.system.correct(stats, solver)
        self._off = (stats, solver)
        return Merit(self.system.multiplier_term(at_start=True), self.system.multiplier_term())

    def land(self, change: Array) -> bool:
        """Bring a state that SQP steps left off the constraint back onto it (collective).

        By :meth:`close_constraint` with the last SQP step's factors, when D_h is above
        ``SQP_DEFECT_TOL``·|ω|.

        Args:
            change: the last step's change of y's dofs; the corrections are added to it.

        Returns:
            Whether the state moved.
        """
        off, self._off = self._off, None
        if off is None or self.defect() <= SQP_DEFECT_TOL * self.defect.area:
            return False
        self.close_constraint(*off, change)
        return True

    def project(self, stats: SolveStats, solver: StepSolver, change: Array) -> None:
        """The ``flow.projection_steps`` corrections of a step.

        Args:
            stats: the step's figures (the corrections' fall-backs are added).
            solver: the solver that holds the step's factors.
            change: the step's change of y's dofs; each correction is added to it.
        """
        self._off = None
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
