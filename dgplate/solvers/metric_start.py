"""The metric start: a first state on the constraint ∇yᵀ∇y = G for a plate with a target metric.

The flat plate y = (x₁, x₂, 0) has ∇yᵀ∇y = I, so under a target metric G ≠ I the flow has no
admissible state to start from. Before its first step the flow (:class:`GradientFlow` with a
metric) makes one in two phases, as the preprocessing of Bonito, Guignard, Nochetto and Yang
(J. Comput. Phys. 2022, §4.2) does with a stretching energy; from a start of the user's
(``model.start``, ``initial``) it makes only the second, when that start's D_h exceeds
``DEFECT_TOL``:

1. *Stretching.* From the flat plate lifted by the paraboloid z = δ|x − c|²/d (c the centre
   and d the diameter of the plate's bounding box: a metric of positive Gauss curvature
   cannot be met in the plane, and δ > 0 chooses the side), Gauss–Newton steps on

       F(y) = ½∫|∇yᵀ∇y − G|² + ε E_h[y]

   (ε E_h, with E_h the flow's implicit energy, keeps y smooth across the cells): the matrix
   ∫ S(δy) : S(v) + ε D²E_h(δy, v) + σ∫δy·v with S(v) = ∇vᵀ∇y + ∇yᵀ∇v (σ takes the rigid
   motions), a step halved until F falls, at most ``STRETCH_STEPS`` steps, ended when F falls
   by less than ``STRETCH_RTOL`` of itself.
2. *Projection.* The flow's corrections (:meth:`StepSystem.correct`) with K assembled at each
   new state: Newton's method on the cell means ∫_T (∇yᵀ∇y − G) = 0, each the least change in
   the flow's metric, until D_h ≤ ``DEFECT_TOL`` (at most ``PROJECTION_STEPS``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Protocol

from mpi4py import MPI

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import compat, interrupt, mpi
from dgplate.compat import Array, Function
from dgplate.dg.energy import Energy
from dgplate.dg.forms import integral
from dgplate.errors import SolverError
from dgplate.solvers import linear
from dgplate.solvers.constraint import IsometryDefect, metric_measure, metric_tensor_defect
from dgplate.solvers.driver import Narrator
from dgplate.solvers.linear import SolveStats
from dgplate.solvers.step_system import StepSystem

#: δ of the paraboloid z = δ|x − c|²/d the stretching phase starts from
BUMP = 0.1
#: ε, the weight of the flow's energy in the stretching phase
EPSILON = 1e-3
#: σ, the L² weight that takes the rigid motions out of the Gauss–Newton matrix
SIGMA = 1e-6
#: at most this many Gauss–Newton steps
STRETCH_STEPS = 100
#: the stretching phase ends when a step lowers F by less than this fraction of F
STRETCH_RTOL = 1e-10
#: the projection phase ends when D_h is at most this
DEFECT_TOL = 1e-10
#: at most this many projections
PROJECTION_STEPS = 30
#: at most this many halvings of a Gauss–Newton step
HALVINGS = 30


class Stopped(Exception):
    """A signal stopped the metric start (:mod:`dgplate.interrupt`); ``signum`` names it."""

    def __init__(self, signum: int):
        super().__init__(interrupt.reason(signum))
        self.signum = signum


class StartFlow(Protocol):
    """What the metric start needs of the flow (:class:`~dgplate.solvers.flow.GradientFlow`)."""

    comm: MPI.Comm
    y: Function
    metric: Expr | None
    energy: Energy
    system: StepSystem
    defect: IsometryDefect


def run(
    flow: StartFlow, given: bool = False, say: Callable[[str], None] | None = None
) -> dict[str, Any]:
    """Move ``flow.y`` onto ∇yᵀ∇y = G (collective; module docstring).

    Args:
        flow: a gradient flow with a target metric, at its first state.
        given: the first state is the user's (``model.start``, ``initial``): only the
            projection phase, and only when its D_h exceeds ``DEFECT_TOL``.
        say: prints the phase's line (rank 0; the flow passes its progress printer's).

    Returns:
        The phase's figures for ``summary.json``: the steps of each part, the stretching
        ∫|∇yᵀ∇y − G|² after the first, the defect D_h at the end and the seconds taken. A
        state that meets the constraint already (D_h ≤ ``DEFECT_TOL``: G = I) stays.

    Raises:
        SolverError: D_h > ``DEFECT_TOL`` after the projections.
        Stopped: a signal arrived (checked between the steps of both phases).
    """
    assert flow.metric is not None
    t0 = time.perf_counter()
    steps, stretching, projections = 0, 0.0, 0
    if flow.defect() > DEFECT_TOL:  # else G = I: the flat plate is on the constraint already
        if not given:
            flow.y.interpolate(_lifted(flow.y))
            steps, stretching = _stretch(flow.y, flow.metric, flow.energy.implicit)
        projections = _project(flow)
    defect = flow.defect()
    figures = {
        "stretching_steps": steps,
        "stretching": stretching,
        "projection_steps": projections,
        "defect": defect,
        "seconds": time.perf_counter() - t0,
    }
    if say is not None:
        say(
            f"metric start: {steps} stretching steps (∫|∇yᵀ∇y − G|² = {stretching:.3e}), "
            f"{projections} projections, D_h = {defect:.3e} ({figures['seconds']:.1f} s)"
        )
    if not defect <= DEFECT_TOL:
        raise SolverError(
            f"the metric start left D_h = {defect:.3e} > {DEFECT_TOL:g} after "
            f"{projections} projections: no state on the constraint ∇yᵀ∇y = G"
        )
    return figures


class StartPhase:
    """The metric start as a phase of a flow: pending until it succeeded, its figures kept.

    The flow owns one; it runs the start before its first step (:meth:`run`), and its
    figures go into the flow's summary and checkpoint (:meth:`entries`), so that a resumed
    run does not start again (:meth:`restore`).
    """

    def __init__(self, metric: Expr | None, given: bool):
        """``metric``: the flow's target metric (None: no start); ``given``: a user's start."""
        self.has_metric = metric is not None
        self.pending = self.has_metric
        self.given = given
        #: the start's figures (None: no start, or not run yet)
        self.figures: dict[str, Any] | None = None

    def entries(self) -> dict[str, Any]:
        """``{"metric_start": figures}`` once the start ran, else nothing."""
        return {"metric_start": self.figures} if self.figures is not None else {}

    def restore(self, state: dict[str, Any]) -> None:
        """The figures of a checkpoint's ``state``; one written before the start ended starts anew."""
        self.figures = state.get("metric_start")
        self.pending = self.has_metric and self.figures is None
        self.given = False

    def run(self, flow: StartFlow, observers: list[Any]) -> tuple[str, int] | None:
        """Run the start (collective): None when it succeeded, else the run's (reason, signal).

        Args:
            flow: the flow, at its first state.
            observers: the flow's observers; the :class:`Narrator` ones print the start's lines.

        Returns:
            None, or why the run ends: the failure or the signal, and the signal's number.
        """
        notes = [obs.note for obs in observers if isinstance(obs, Narrator)]

        def say(line: str) -> None:
            for note in notes:
                note(line)

        try:
            self.figures = run(flow, self.given, say)
        except SolverError as exc:
            return f"metric start failed: {exc}", 0
        except Stopped as stop:
            return interrupt.reason(stop.signum), stop.signum
        self.pending = False
        return None


def _check_signal(comm: MPI.Comm) -> None:
    """Raise :class:`Stopped` when any rank received a signal (collective)."""
    signum = interrupt.requested(comm)
    if signum:
        raise Stopped(signum)


def _lifted(y: Function) -> Callable[[Array], Array]:
    """The flat plate lifted by the paraboloid z = δ|x − c|²/d, as a function of the points."""
    mesh = y.function_space.mesh
    low, high = mpi.bounding_box(mesh.comm, mesh.geometry.x[:, :2])
    centre, diameter = 0.5 * (low + high), float(np.linalg.norm(high - low))

    def lifted(points: Array) -> Array:
        z = BUMP * ((points[0] - centre[0]) ** 2 + (points[1] - centre[1]) ** 2) / diameter
        return np.vstack([points[0], points[1], z])

    return lifted


def _stretch(y: Function, metric: Expr, energy: ufl.Form) -> tuple[int, float]:
    """The Gauss–Newton steps of the stretching phase; (steps, ∫|∇yᵀ∇y − G|² at the end)."""
    space, comm = y.function_space, y.function_space.mesh.comm
    v, dy = ufl.TestFunction(space), ufl.TrialFunction(space)
    dx = metric_measure(y, metric)
    defect = metric_tensor_defect(y, metric)
    stretching = dolfinx.fem.form(ufl.inner(defect, defect) * dx)
    objective = 0.5 * ufl.inner(defect, defect) * dx + EPSILON * energy
    F = dolfinx.fem.form(objective)
    gradient = dolfinx.fem.form(-ufl.derivative(objective, y, v))
    Gy = ufl.grad(y)

    def strain(w: Expr) -> Expr:
        linearised: Expr = ufl.grad(w).T * Gy + Gy.T * ufl.grad(w)
        return linearised

    matrix = ufl.inner(strain(dy), strain(v)) * dx + SIGMA * ufl.inner(dy, v) * ufl.dx
    matrix += EPSILON * ufl.derivative(ufl.derivative(energy, y, v), y, dy)
    A_form = dolfinx.fem.form(matrix)
    A = dolfinx.fem.petsc.create_matrix(A_form)  # assembled at each step
    rhs, step = dolfinx.fem.Function(space), dolfinx.fem.Function(space)
    solver = linear.DirectStepSolver(comm, A, None, prefix=None)
    value = integral(F, comm)
    steps = 0
    try:
        while steps < STRETCH_STEPS:
            _check_signal(comm)
            steps += 1
            compat.assemble_matrix_into(A, A_form)
            compat.assemble_vector_into(rhs.x.petsc_vec, gradient)
            solver.solve(rhs.x.petsc_vec, step.x.petsc_vec)
            step.x.scatter_forward()
            previous = value
            value = _line_search(y, np.asarray(step.x.array, dtype=np.float64), F, previous)
            if previous - value <= STRETCH_RTOL * previous:
                break
    finally:
        solver.destroy()
        A.destroy()
    return steps, integral(stretching, comm)


def _line_search(y: Function, step: Array, F: compat.Form, value: float) -> float:
    """Move y by s·step, with the largest s = 2⁻ⁱ that lowers F below ``value``; F at the new y.

    When no s does, y stays and ``value`` is returned (the caller then stops).
    """
    comm = y.function_space.mesh.comm
    start = y.x.array.copy()
    scale = 1.0
    for _ in range(HALVINGS):
        y.x.array[:] = start + scale * step
        trial = integral(F, comm)
        if trial < value:
            return trial
        scale *= 0.5
    y.x.array[:] = start
    return value


def _project(flow: StartFlow) -> int:
    """Corrections at freshly assembled K until D_h ≤ DEFECT_TOL; the number made."""
    system, stats = flow.system, SolveStats(False, 0, 0.0, 0.0)
    for count in range(PROJECTION_STEPS + 1):
        if flow.defect() <= DEFECT_TOL:
            return count
        if count == PROJECTION_STEPS:
            break
        _check_signal(flow.comm)
        system.correct(stats, system.assemble(), refactor=True)
    return PROJECTION_STEPS
