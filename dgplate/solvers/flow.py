"""Discrete H² gradient flow with a linearised isometry constraint (docs/design.md §3).

One step from yⁿ: find δy ∈ [DG_k]³ and a cell-wise symmetric multiplier λ with

    (1/τ)(δy, v)_* + D²E_impl(δy, v) + b_n(v, λ) = −DE_h[yⁿ](v)   for all v,
    b_n(δy, q) = 0                                                for all q,

then yⁿ⁺¹ = yⁿ + δy. The matrix block (1/τ)(·,·)_* + D²E_impl does not depend on yⁿ: it is
assembled once, and each step reassembles only b_n (cell integrals) and adds the two matrices,
which share one sparsity pattern: DOLFINx's pattern of the step form without the constant
block's exact zeros (the components of y do not couple, :mod:`dgplate.solvers.sparsity`). Since that
sum changes only through b_n, the default
solver keeps one LU factorisation over many steps as the preconditioner of FGMRES
(:class:`dgplate.solvers.linear.LaggedStepSolver`) and refactorises only when the iteration count
grows. The flow is generic: it only sees an :class:`Energy`.
"""

from __future__ import annotations

import functools
import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

import basix.ufl
import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from petsc4py import PETSc

from dgplate import compat, interrupt, mpi, values
from dgplate.compat import Array, Function
from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets, h2_metric
from dgplate.dg.geometry import max_cell_diameter
from dgplate.errors import InputError, SolverError
from dgplate.schema import is_integer, is_number, option
from dgplate.solvers import linear as solvers
from dgplate.solvers import ordering, schur, sparsity, sqp
from dgplate.solvers.constraint import (
    EdgeConstraint,
    IsometryDefect,
    linearised_isometry,
    metric_tensor_defect,
    multiplier_element,
    symmetric,
)
from dgplate.solvers.driver import EnergyFlow, Observer
from dgplate.solvers.linear import OptionValue

_OPTION = re.compile(r"^[A-Za-z0-9_]+$")
#: How often a step that raised E_h is redone with τ/2 when only active sets ask for it.
HALVINGS = 10
#: At most this many corrections close the constraint after an SQP step (see _close_constraint).
SQP_CORRECTIONS = 20
#: D_h per unit area at which an SQP step's state counts as a discrete isometry.
SQP_DEFECT_TOL = 1e-12
#: The measure's Krylov tolerance: near a critical point ‖P DE_h‖ is a small part of ‖DE_h‖,
#: the right-hand side, and the step's 10⁻⁹ left it reproducible to only ~10⁻⁵ (2 ranks).
STATIONARITY_KRYLOV: dict[str, OptionValue] = {"ksp_rtol": 1e-13}
#: K follows yⁿ by increments B(yⁿ − y_K); it is assembled whole after this many, so that
#: their round-off (~10⁻¹⁶ of ‖B‖ each) cannot accumulate.
K_REASSEMBLY = 100
#: The stopping tests (``flow.stop``).
STOPS = ("rate", "stationarity")

#: The initial deformation: points x (shape (3, n)) to their images (shape (3, n)).
Initial = Callable[[Array], Array]


@dataclass
class FlowSpec:
    """The [flow] section: parameters of the gradient flow, validated once, here.

    D_h = O(τ). Cell moments of the constraint alone let the cells along a free edge curve in
    two directions (Gauss curvature ≠ 0), which lowers a bilayer's energy below the isometric
    minimum: ``edge_constraint`` also constrains two moments of the metric on free boundary
    facets (:class:`dgplate.solvers.constraint.EdgeConstraint`).
    """

    tau: float | str = option("h", "time step τ > 0, or 'h' for the largest cell diameter")
    tol: float = option(1e-6, "stop when the stopping test (flow.stop) falls below tol")
    max_steps: int = option(1000, "step budget; reaching it is reported as not converged")
    l2_metric: bool | str = option(
        "auto",
        "add the L² product to the metric; 'auto': when nothing is clamped or the plate has creases",
    )
    solver: dict[str, OptionValue] = option(
        {},
        "PETSc options for the step solve (default: MUMPS, LDLᵀ for the lagged solver, LU for 'direct')",
    )
    multiplier_degree: int = option(
        0,
        "degree of the isometry multiplier: 0 = cell means (published), 1 = also first moments (stronger)",
    )
    projection_steps: int = option(
        0,
        "corrections per step restoring the nonlinear discrete constraint (0: published method; 2 drives D_h to round-off)",
    )
    linear_solver: str = option(
        "lagged",
        "step solver: 'lagged' (one MUMPS LDLᵀ factorisation reused as FGMRES preconditioner, refactorised when needed), 'direct' (LU every step) or 'schur' (one Cholesky of the scalar constant block per run, CG on the multipliers' Schur complement; falls back to 'lagged' where the model couples the components of y)",
    )
    refactor_its: int = option(
        12, "lagged solver: refactorise after a solve that needed more FGMRES iterations"
    )
    edge_constraint: bool = option(
        False,
        "also constrain the metric on free boundary facets (edge length and normal stretch): keeps free edges of a bilayer from curving in two directions",
    )
    stop: str = option(
        "rate",
        "stopping test: 'rate' ((E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < tol, the published test) or 'stationarity' (‖P DE_h[yⁿ]‖_*' < tol, the dual norm of the projected gradient: does not depend on τ)",
    )
    adaptive_tau: bool = option(
        False,
        "adapt τ: grow it (tau_growth, tau_growth_max) after a step that lowered E_h with the isometry defect before projection below defect_bound, else halve it and redo the step",
    )
    defect_bound: float = option(
        1e-2,
        "adaptive τ: the largest isometry defect D_h of a step before its projection (the linearisation error)",
    )
    tau_growth: float = option(
        2.0, "adaptive τ: the factor by which τ grows after an accepted step"
    )
    tau_growth_max: float = option(
        8.0,
        "adaptive τ with newton_finish: until the run's first rejected step, τ grows by √(defect_bound/D)/2 (D: the step's isometry defect before projection), at least tau_growth and at most this factor, to reach the SQP steps sooner; tau_growth after a rejection and without newton_finish (tau_growth_max = tau_growth: always tau_growth)",
    )
    tau_max_ratio: float = option(
        1e3, "adaptive τ: the largest τ, as a multiple of the initial τ (flow.tau)"
    )
    refactor_factor: float = option(
        1.0,
        "adaptive τ: put a grown τ into the step matrix (reassemble and refactorise) only once it differs from the τ held there by more than this factor; until then the steps keep that τ (1: at every change)",
    )
    newton_finish: bool = option(
        True,
        "adaptive τ: once τ reaches newton_tau_ratio times the initial τ (or its cap), add the Lagrangian's curvature (the multipliers' term and D²E_expl) to the step matrix, a damped SQP (Newton) step; a step that does not lower E_h is redone as a plain step",
    )
    newton_tau_ratio: float = option(
        100.0,
        "adaptive τ with newton_finish: the τ, as a multiple of the initial τ, from which the steps are SQP steps (capped by tau_max_ratio)",
    )
    checkpoint_every: int = option(
        25,
        "write a checkpoint (for --resume) every n steps, and always at the end; 0: only at the end",
    )

    def __post_init__(self) -> None:
        self._check_tau()
        if not (isinstance(self.tol, int | float) and self.tol > 0):
            raise InputError(f"flow.tol must be > 0, got {self.tol!r}")
        for key, least in (
            ("max_steps", 1),
            ("projection_steps", 0),
            ("refactor_its", 1),
            ("checkpoint_every", 0),
        ):
            value = getattr(self, key)
            if not is_integer(value) or value < least:
                raise InputError(f"flow.{key} must be an integer >= {least}, got {value!r}")
        self._check_choices()
        self._check_adaptive()
        self._check_solver_options()

    def _check_choices(self) -> None:
        """The keys that take one of a few values."""
        if self.multiplier_degree not in (0, 1) or isinstance(self.multiplier_degree, bool):
            raise InputError(
                f"flow.multiplier_degree must be 0 or 1, got {self.multiplier_degree!r}"
            )
        if self.l2_metric not in (True, False, "auto"):
            raise InputError(
                f"flow.l2_metric must be true, false or 'auto', got {self.l2_metric!r}"
            )
        if self.linear_solver not in solvers.STEP_SOLVERS:
            raise InputError(
                f"flow.linear_solver must be one of {solvers.STEP_SOLVERS}, got {self.linear_solver!r}"
            )
        for key in ("adaptive_tau", "newton_finish"):
            if not isinstance(getattr(self, key), bool):
                raise InputError(f"flow.{key} must be true or false, got {getattr(self, key)!r}")
        if self.stop not in STOPS:
            raise InputError(f"flow.stop must be one of {STOPS}, got {self.stop!r}")
        if not isinstance(self.edge_constraint, bool):
            raise InputError(
                f"flow.edge_constraint must be true or false, got {self.edge_constraint!r}"
            )

    def _check_adaptive(self) -> None:
        """The numbers of the τ controller (flow.adaptive_tau)."""
        if not (is_number(self.defect_bound) and self.defect_bound > 0):
            raise InputError(f"flow.defect_bound must be > 0, got {self.defect_bound!r}")
        for key, strict in (
            ("tau_growth", True),
            ("tau_growth_max", False),
            ("tau_max_ratio", False),
            ("refactor_factor", False),
            ("newton_tau_ratio", False),
        ):
            value = getattr(self, key)
            finite = is_number(value) and math.isfinite(value)
            if not (finite and (value > 1 if strict else value >= 1)):
                relation = ">" if strict else ">="
                raise InputError(f"flow.{key} must be a number {relation} 1, got {value!r}")

    def _check_tau(self) -> None:
        """τ: a finite number > 0, or 'h'."""
        if isinstance(self.tau, str):
            if self.tau != "h":
                raise InputError(f"flow.tau must be a number > 0 or 'h', got {self.tau!r}")
        elif not (is_number(self.tau) and self.tau > 0 and math.isfinite(self.tau)):
            raise InputError(f"flow.tau must be > 0, got {self.tau!r}")

    def _check_solver_options(self) -> None:
        """PETSc option names (without '-') and values that PETSc can take."""
        for key, value in self.solver.items():
            if not _OPTION.match(key):
                raise InputError(
                    f"flow.solver.{key} is not a PETSc option name (letters, digits and _, "
                    "without the leading '-', e.g. ksp_type)"
                )
            if not isinstance(value, str | int | float):
                raise InputError(
                    f"flow.solver.{key} must be a string, a number or a boolean, got {value!r}"
                )

    @property
    def l2(self) -> bool | None:
        """Whether the metric has the L² product; None: decided by the model (clamped?)."""
        return None if self.l2_metric == "auto" else bool(self.l2_metric)


@dataclass
class StepInfo:
    """What one step did: the row of ``history.csv``."""

    step: int
    time: float
    tau: float
    energy: float
    defect: float
    increment: float  # max |δy| over the degrees of freedom
    rate: float  # (E_h[yⁿ⁻¹] − E_h[yⁿ]) / τ
    seconds: float
    assembly_s: float
    factor_s: float  # factorisation (0 when the lagged solver reused its factors)
    solve_s: float  # triangular solves and Krylov iterations
    iterations: int  # Krylov iterations of the step solve (1 for a direct solve)
    fallbacks: int = 0  # failed lagged solves redone (fresh factors, then direct LU)
    safety: dict[str, float] = field(default_factory=dict)  # nonlocal terms: min_distance, redone
    stationarity: float = math.nan  # ‖P DE_h[yⁿ]‖_*' (flow.stop = 'stationarity'; else nan)

    def line(self) -> str:
        """One line of progress output."""
        return (
            f"step {self.step:5d}  t = {self.time:9.4f}  τ = {self.tau:.3e}  "
            f"E_h = {self.energy:+.6e}  D_h = {self.defect:.3e}  "
            f"ΔE/τ = {self.rate:.2e}  {per_step(self.seconds)}"
        )


def per_step(seconds: float) -> str:
    """The time of a step for a progress line: ``1.23 s/step``, or ``4.2 ms/step``."""
    return f"{seconds:.2f} s/step" if seconds >= 0.1 else f"{1e3 * seconds:.3g} ms/step"


@dataclass
class FlowResult:
    """How a run of the flow ended, and the records of its steps."""

    converged: bool
    reason: str
    steps: int
    energy: float
    defect: float
    history: list[StepInfo]
    energy_increases: list[int]  # steps at which the energy went up
    interrupted: int = 0  # the signal (SIGINT, SIGTERM) that stopped the run; 0: none

    @classmethod
    def of(
        cls,
        outcome: tuple[bool, str, int],
        history: list[Any],
        increases: list[int],
        energy: float,
        defect: float,
    ) -> FlowResult:
        """The result of a run: (converged, reason, signal), its records and final figures."""
        converged, reason, signum = outcome
        return cls(converged, reason, len(history), energy, defect, history, increases, signum)


class GradientFlow(EnergyFlow):
    """The constrained H² gradient flow of an energy built by ``energy_fn(y)``."""

    def __init__(
        self,
        facets: FacetSets,
        degree: int,
        energy_fn: Callable[[Function], Energy],
        settings: FlowSpec,
        observers: Sequence[Observer] = (),
        initial: Initial | None = None,
    ):
        if degree < 2:
            raise InputError(f"model.degree must be >= 2 for the H² dG method, got {degree}")
        self.facets, self.settings, self.observers = facets, settings, list(observers)
        mesh = facets.mesh
        self.comm: MPI.Comm = mesh.comm
        ve = basix.ufl.element("DG", mesh.basix_cell(), degree, shape=(3,))
        elements = [ve, multiplier_element(mesh, settings.multiplier_degree)]
        if settings.edge_constraint:
            edge = basix.ufl.element("DG", mesh.basix_cell(), 0, shape=(EdgeConstraint.SIZE,))
            elements.append(edge)
        self.W = dolfinx.fem.functionspace(mesh, basix.ufl.mixed_element(elements))
        self.V, self._vdofs = compat.collapse(self.W.sub(0))
        self.y: Function = dolfinx.fem.Function(self.V, name="deformation")
        self.y.interpolate(initial or _flat)
        self.energy = energy_fn(self.y)
        self.defect = IsometryDefect(self.y)
        self.time, self.step_count = 0.0, 0
        self.energy_increases: list[int] = []  # steps at which E_h went up, over all runs
        self.fallbacks = 0  # solver fall-backs over all runs
        self._last_increment: Array = np.zeros(0)  # δy of the last step (for undo)
        tau = max_cell_diameter(mesh) if settings.tau == "h" else float(settings.tau)
        self._tau = values.constant(mesh, tau)
        self._initial_tau = tau
        # the τ controller's proposal (flow.adaptive_tau); the step matrix holds self.tau, which
        # follows it only when they differ by more than flow.refactor_factor
        self._target_tau = tau
        self._linear_defect = 0.0  # D_h after the last linearised step, before projection
        self.rejected_steps = 0  # steps redone with a smaller τ (flow.adaptive_tau)
        self.refactorisations = 0  # changes of τ in the step matrix (each reassembles A_const)
        self.newton_steps = 0  # accepted SQP steps (flow.newton_finish)
        self.newton_rejections = 0  # SQP steps redone as plain steps
        self.step_solves = 0  # solves with a step (or SQP) matrix: steps, redone steps, corrections
        self.active_set_changes = 0  # changes of an active set (each reassembles A_const)
        # factorisations of the runs this one resumes (the solvers count their own)
        self._earlier_factorisations = {"step": 0, "newton": 0}
        self.active_set_redos = 0  # steps redone because a point entered an active set
        self._build_forms()
        self._E_form = dolfinx.fem.form(self.energy.total)
        self._last_energy = self.evaluate_energy()

    @property
    def faces(self) -> FacetSets:
        """The old name of :attr:`facets`."""
        return self.facets

    # -- set-up -----------------------------------------------------------------------------
    def _build_forms(self) -> None:
        """The step's forms and matrices, and its solver."""
        y, facets = self.y, self.facets
        dy, multiplier, *edge_multiplier = ufl.TrialFunctions(self.W)
        v, q, *edge_q = ufl.TestFunctions(self.W)
        l2 = self.settings.l2
        # rigid motions, or a flap that can turn freely about a crease, leave the H² metric
        # singular: the L² product controls them
        rigid = not facets.has_clamped or facets.num_crease > 0
        l2 = rigid if l2 is None else l2
        hessian = ufl.derivative(ufl.derivative(self.energy.implicit, y, v), y, dy)
        metric = h2_metric(dy, v, facets, l2=l2)
        # the stationarity measure's metric must be definite by itself: a free plate's flow
        # may leave rigid motions to its implicit energy (an anchor spring) instead of L²
        stationarity_metric = h2_metric(dy, v, facets, l2=True) if rigid and not l2 else metric
        a_const = (1.0 / self._tau) * metric + hessian
        # The constraint rows are scaled by s (λ by 1/s, δy unchanged) so that they weigh like
        # the displacement rows: unscaled, ‖b_n‖ ~ 1 against ‖a‖ ~ h⁻³/τ, and a residual test
        # on the whole system would hardly see the constraint (see _balance_constraint_rows).
        s = self._constraint_scale = values.constant(facets.mesh, 1.0)
        b = linearised_isometry(v, y, multiplier) + linearised_isometry(dy, y, q)
        # residual of the nonlinear constraint in the multiplier rows: ∫ (∇yᵀ∇y − I) : q
        residual = -ufl.inner(metric_tensor_defect(y), symmetric(q)) * ufl.dx
        edge = None
        if self.settings.edge_constraint:
            (edge_trial,), (edge_test,) = edge_multiplier, edge_q
            edge = EdgeConstraint(facets)
            b += edge.linearised(v, y, edge_trial) + edge.linearised(dy, y, edge_test)
            residual -= edge.residual(y, edge_test)
            # cells without a free facet: their edge multipliers are pinned to zero
            pin = edge.interior * ufl.inner(edge_trial, edge_test) / facets.h * ufl.dx
            a_const += pin
            metric += pin
            stationarity_metric += pin
        b, residual = s * b, s * residual
        # the projected-gradient system (compiled at its first use: see stationarity()), its
        # metric rows scaled by 1/τ⁰ so that they weigh against the constraint rows as in K
        # (a Constant, so that the compiled form does not depend on τ⁰)
        scale = values.constant(facets.mesh, 1.0 / self._initial_tau)
        self._stationarity_ufl = scale * stationarity_metric + b
        self._stationarity: tuple[compat.Form, PETSc.Mat, schur.StepSolver] | None = None
        self._gradient: Function = dolfinx.fem.Function(self.W)  # g of stationarity()
        self._stationarity_fallbacks = 0  # of its solves, added to the step's record
        self._a_const = dolfinx.fem.form(a_const)
        self._b = dolfinx.fem.form(b)
        # b is linear in yⁿ, so B(yⁿ) = B(y_K) + B(yⁿ − y_K): K follows yⁿ by that increment
        # alone (see assemble_system), with the same compiled kernel (same signature)
        self._y_increment: Function = dolfinx.fem.Function(self.V)
        self._b_increment = dolfinx.fem.form(ufl.replace(b, {y: self._y_increment}))
        self._y_in_K = self.y.x.array.copy()  # the state whose B(y) K holds
        self._K_updates = 0  # increments added since K was last assembled whole
        self._K_whole = True  # K must be assembled whole at the next step
        explicit = self.energy.total
        if self.energy.step_shift is not None:
            explicit = explicit + self.energy.step_shift
        for term in self.energy.nonlocal_terms:
            explicit = explicit + term.linearisation
        self._rhs = dolfinx.fem.form(-ufl.derivative(explicit, y, v))
        self._constraint_residual = dolfinx.fem.form(residual)
        self._step_ufl = a_const + b
        # One matrix for the step: K = A_const + B(yⁿ), updated in place. A_const and B are not
        # stored apart (at 256² a matrix of this pattern is 1.6 GB), except A_const for the
        # Schur solver, which factorises its scalar block.
        self.K = self._compact_constant_block()
        self.A_const: PETSc.Mat | None = (
            self.K.duplicate(copy=False) if self.settings.linear_solver == "schur" else None
        )
        self._begin_active_sets()  # the pattern above has the couplings of the whole sets
        self._rhs_fn: Function = dolfinx.fem.Function(self.W)  # a ghosted vector in every version
        self.rhs = self._rhs_fn.x.petsc_vec
        self.solution: Function = dolfinx.fem.Function(self.W)
        curvature = sqp.lagrangian_curvature(
            y, self.solution, self.energy.explicit, edge, s, (dy, v)
        )
        self._newton = sqp.NewtonStep(self.comm, curvature, self.settings.solver)
        self._balance_constraint_rows()
        self.solver = self._make_solver()

    def _make_solver(self) -> schur.StepSolver:
        """The solver of the step systems K x = b (see :mod:`dgplate.solvers.linear`)."""
        settings = self.settings
        if settings.linear_solver == "direct":
            return solvers.DirectStepSolver(self.comm, self.K, settings.solver, prefix=None)
        numbering = ordering.cellwise_numbering(self.W)
        if settings.linear_solver == "schur":
            solver = self._schur_solver(numbering)
            if solver is not None:
                return solver
        return solvers.LaggedStepSolver(
            self.comm,
            self.K,
            settings.solver,
            None,
            settings.refactor_its,
            numbering,
            symmetric=True,
        )

    def _schur_solver(self, numbering: PETSc.IS | None) -> schur.SchurStepSolver | None:
        """The Schur-complement solver, or None (reason logged) where K lacks its structure."""
        if numbering is None:
            schur.fall_back(self.comm, "no cell-wise numbering of the unknowns")
            return None
        imap, bs = self.W.dofmap.index_map, self.W.dofmap.index_map_bs
        owned = imap.size_local * bs
        component = np.full(owned, -1, dtype=np.int32)
        kinds = np.arange(self._vdofs.size, dtype=np.int32) % 3
        mine = self._vdofs < owned
        component[self._vdofs[mine]] = kinds[mine]
        split = schur.split_unknowns(self.K, component, numbering)
        A_const = self._assembled_constant_block()
        reason = schur.unsupported(A_const, split)
        if reason:
            schur.fall_back(self.comm, reason)
            A_const.destroy()
            self.A_const = None
            return None
        nodes = self.V.dofmap.dof_layout.num_dofs
        solver = schur.SchurStepSolver(
            self.comm, self.K, A_const, split, nodes, self.settings.solver
        )
        if solver.wants_embedding:
            solver.use_embedding(schur.continuous_embedding(self.W, self.V, self._vdofs))
        return solver

    def _balance_constraint_rows(self) -> None:
        """Scale the constraint rows by s = ‖A_const‖_∞ / ‖B(y⁰)‖_∞, to weigh like the others.

        Only λ changes with s. The iterative solves stop on the residual of the whole system;
        with s = 1 its constraint part counts ~h³ less than the displacement part, and
        solutions that meet the tolerance drift off the constraint step by step (E_h to only
        ~1e-8 after a flow). Balanced, fewer iterations give E_h to ~1e-9.
        """
        # K holds A_const, then B alone, until the first step assembles it whole
        compat.assemble_matrix_into(self.K, self._a_const)
        norm_a = _max_row_sum(self.K)
        compat.assemble_matrix_into(self.K, self._b)
        norm_b = _max_row_sum(self.K)
        if norm_b > 0:
            self._constraint_scale.value = np.asarray(norm_a / norm_b)
        self._K_whole = True

    def _assembled_constant_block(self) -> PETSc.Mat:
        """A_const, assembled now (the Schur solver's copy; see :meth:`_constant_changed`)."""
        if self.A_const is None:
            self.A_const = self.K.duplicate(copy=False)
        compat.assemble_matrix_into(self.A_const, self._a_const)
        return self.A_const

    def _constant_changed(self) -> None:
        """A_const changed (τ, active sets): K is assembled whole at the next step."""
        self._K_whole = True
        if self.A_const is not None:
            compat.assemble_matrix_into(self.A_const, self._a_const)

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
        actually have are stored (:mod:`dgplate.solvers.sparsity`).
        """
        # DOLFINx's pattern of a_const is that of the whole step form: b_n only couples the
        # dofs of one cell, which the cell integrals of a_const already do
        full = dolfinx.fem.petsc.assemble_matrix(self._a_const)  # DOLFINx's pattern
        full.assemble()
        imap, bs = self.W.dofmap.index_map, self.W.dofmap.index_map_bs
        is_multiplier = np.ones((imap.size_local + imap.num_ghosts) * bs, dtype=bool)
        is_multiplier[self._vdofs] = False
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
        """The time step τ of the step matrix; setting it reassembles the constant block.

        Setting it also resets the adaptive controller's proposal to it, and counts one
        refactorisation (:attr:`refactorisations`).
        """
        return float(self._tau.value)

    @tau.setter
    def tau(self, value: float) -> None:
        if not value > 0:
            raise InputError(f"flow.tau must be > 0, got {value}")
        self._target_tau = value
        self._put_tau(value)

    def _put_tau(self, value: float) -> None:
        """τ into the step matrix: reassemble A_const, tell the solver, count it."""
        self.refactorisations += 1
        self._tau.value = np.asarray(value)
        self._constant_changed()
        if isinstance(self.solver, schur.SchurStepSolver):
            self.solver.constant_changed()

    def _begin_active_sets(self) -> None:
        """The active sets from the current state yⁿ; A_const follows them when they change."""
        if any([term.begin() for term in self.energy.active_sets]):
            self._active_sets_changed()

    def _active_sets_changed(self) -> None:
        """An active set changed: reassemble A_const and refactorise at the next solve."""
        self.active_set_changes += 1
        self._constant_changed()
        solver = getattr(self, "solver", None)  # None while the forms are built
        if solver is not None and not isinstance(solver, solvers.DirectStepSolver):
            solver.constant_changed()

    def _contact_step(self) -> StepInfo:
        """A step with active sets: taken from the sets of yⁿ, redone with larger sets when E_h rose.

        A step that lowers E_h is accepted as it is (points that entered a set join it at the
        next step, as in a semismooth Newton iteration). A step that raised E_h is taken back,
        the sets are enlarged by the points in them at the trial state, and the step is redone
        from yⁿ, at most ``max_redo`` times (counted in :attr:`active_set_redos`). With every
        entering point in the sets the step is energy stable (docs/obstacle.md); if the sets
        did not grow, the increase is left to the caller (:meth:`_safe_step` halves τ).
        """
        sets = self.energy.active_sets
        if not sets:
            return self.step()
        self._begin_active_sets()
        saved = (self.y.x.array.copy(), self._last_energy, self.time, self.step_count)
        info = self.step()
        for _ in range(max(term.max_redo for term in sets)):
            if not self._rose(info) or not any([term.enlarge() for term in sets]):
                break
            self.y.x.array[:], self._last_energy, self.time, self.step_count = (
                saved[0].copy(),
                *saved[1:],
            )
            self.active_set_redos += 1
            self._active_sets_changed()
            info = self.step()
        return info

    # -- one step ---------------------------------------------------------------------------
    def assemble_system(self) -> None:
        """K = A_const + B(yⁿ) and the right-hand side −DE_h[yⁿ].

        K is assembled whole after A_const changed, and every K_REASSEMBLY steps so that
        the round-off of the increments cannot accumulate; otherwise B(yⁿ − y_K) is added to K,
        which holds A_const + B(y_K).
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
        compat.assemble_vector_into(self.rhs, self._rhs)

    def _newton_system(self) -> solvers.DirectStepSolver:
        """K, K_N = K + H (:mod:`dgplate.solvers.sqp`) and −DE_h[yⁿ]; K_N's solver."""
        self.assemble_system()
        return self._newton.assemble(self.K)

    def step(self, newton: bool = False) -> StepInfo:
        """One step of the flow from yⁿ to yⁿ⁺¹ (collective).

        ``newton``: the SQP step (:mod:`dgplate.solvers.sqp`), its projections by its factors.
        """
        t0 = time.perf_counter()
        solver: schur.StepSolver | solvers.DirectStepSolver = self.solver
        if newton:
            solver = self._newton_system()
        else:
            self.assemble_system()
        t1 = time.perf_counter()
        stats = solver.solve(self.rhs, self.solution.x.petsc_vec)
        self.step_solves += 1
        self.solution.x.scatter_forward()
        t2 = time.perf_counter()
        dy = self.solution.x.array[self._vdofs].copy()
        self.y.x.array[:] += dy
        if self.settings.adaptive_tau:
            self._linear_defect = self.defect()
        for _ in range(self.settings.projection_steps):
            dy += self._project(stats, solver)
        if newton:
            dy += self._close_constraint(stats, solver)
        self._last_increment = dy
        owned = self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs
        increment = mpi.global_max(self.comm, float(np.max(np.abs(dy[:owned]), initial=0.0)))
        energy = self.evaluate_energy()
        rate = (self._last_energy - energy) / self.tau
        self._last_energy = energy
        self.step_count += 1
        self.time += self.tau
        info = StepInfo(
            step=self.step_count,
            time=self.time,
            tau=self.tau,
            energy=energy,
            defect=self.defect(),
            increment=increment,
            rate=rate,
            seconds=time.perf_counter() - t0,
            assembly_s=t1 - t0,
            factor_s=stats.factor_s,
            solve_s=t2 - t1 - stats.factor_s,
            iterations=stats.iterations,
            fallbacks=stats.fallbacks,
        )
        return info

    def _safe_step(self) -> StepInfo:
        """A step; with nonlocal terms or active sets one that is accepted and lowers E_h.

        A refused step is redone with τ/2 (at most :data:`HALVINGS` times with active sets
        alone).

        Nonlocal terms are explicit (self-avoidance): a step too long for them may bring parts
        of the plate through each other. A refused step is taken back and redone with half
        the step, at most ``max_redo`` times; τ is restored for the next step.
        """
        terms = self.energy.nonlocal_terms
        if not terms and not self.energy.active_sets:
            return self.step()
        tau, saved = self.tau, (self.y.x.array.copy(), self._last_energy, self.time)
        limit = max([term.max_redo for term in terms], default=HALVINGS)
        redone = 0
        info = self._contact_step()
        while not self._acceptable(info) and redone < limit:
            self.y.x.array[:], self._last_energy, self.time = saved[0], saved[1], saved[2]
            self.step_count -= 1
            self.tau, redone = self.tau / 2, redone + 1
            info = self._contact_step()
        if redone:
            self.tau = tau
        distance = min([term.min_distance for term in terms], default=math.inf)
        info.safety = {"min_distance": distance, "redone": float(redone)}
        return info

    def _acceptable(self, info: StepInfo) -> bool:
        """The nonlocal terms accept the new state and E_h did not go up (beyond round-off)."""
        accepted = all([term.accept() for term in self.energy.nonlocal_terms])
        return accepted and not self._rose(info)

    @staticmethod
    def _rose(info: StepInfo) -> bool:
        """Whether the step raised E_h beyond round-off."""
        return -info.rate * info.tau > 1e-12 * max(1.0, abs(info.energy))

    def _project(
        self, stats: solvers.SolveStats, solver: schur.StepSolver | solvers.DirectStepSolver
    ) -> Array:
        """One correction towards ∫_T (∇yᵀ∇y − I) q = 0, reusing the step's factorisation.

        Its fall-backs are added to the step's ``stats``; returns the change of y's dofs.
        """
        compat.assemble_vector_into(self.rhs, self._constraint_residual)
        correction: Function = dolfinx.fem.Function(self.W)
        more = solver.solve(self.rhs, correction.x.petsc_vec, refactor=False)
        self.step_solves += 1
        stats.fallbacks += more.fallbacks
        correction.x.scatter_forward()
        c = correction.x.array[self._vdofs]
        self.y.x.array[:] += c
        return c

    def _close_constraint(
        self, stats: solvers.SolveStats, solver: schur.StepSolver | solvers.DirectStepSolver
    ) -> Array:
        """Corrections after an SQP step until D_h is at round-off; returns the change of y.

        An SQP step lowers E_h partly along the constraint's curvature. Its corrections are
        chord iterations (b_n of the step's start, the SQP factors), which converge linearly,
        and a state left off the constraint by D_h lies below the constrained energy by about
        λ·D_h: the next steps, whose projections restore the constraint, would count that as a
        rise of E_h, and the controller would reject them down to the least τ (BNN 64²: D_h =
        7.9·10⁻⁷ after two corrections, and every following step "raised" E_h by 1.3·10⁻⁷).
        So at least two corrections are made, then more until D_h ≤ ``SQP_DEFECT_TOL``·|ω|,
        while each correction at least halves D_h, and at most ``SQP_CORRECTIONS``.
        """
        change: Array = np.zeros(self._vdofs.shape)
        tol = SQP_DEFECT_TOL * self.defect.area
        defect = math.inf
        for count in range(SQP_CORRECTIONS):
            change += self._project(stats, solver)
            previous, defect = defect, self.defect()
            if count >= 1 and (defect <= tol or defect > 0.5 * previous):
                break
        return change

    def stationarity(self) -> float:
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
        """
        if self._stationarity is None:
            form = dolfinx.fem.form(self._stationarity_ufl)
            matrix = dolfinx.fem.petsc.assemble_matrix(form)
            matrix.assemble()
            solver: schur.StepSolver = (
                solvers.DirectStepSolver(self.comm, matrix, self.settings.solver, prefix=None)
                if self.settings.linear_solver == "direct"
                else solvers.LaggedStepSolver(
                    self.comm,
                    matrix,
                    {**STATIONARITY_KRYLOV, **(self.settings.solver or {})},
                    None,
                    self.settings.refactor_its,
                    ordering.cellwise_numbering(self.W),
                    symmetric=True,
                )
            )
            self._stationarity = (form, matrix, solver)
        form, matrix, solver = self._stationarity
        compat.assemble_matrix_into(matrix, form)
        compat.assemble_vector_into(self.rhs, self._rhs)
        gradient = self._gradient.x.petsc_vec
        gradient.set(0.0)  # g can change much between calls (a heat step, new data)
        self._stationarity_fallbacks += solver.solve(self.rhs, gradient).fallbacks
        self._gradient.x.scatter_forward()
        # the solution is τ⁰ g (the metric rows carry 1/τ⁰)
        return math.sqrt(max(float(self.rhs.dot(gradient)) / self._initial_tau, 0.0))

    def rebase_energy(self) -> None:
        """Measure the energy decrease from the current state again.

        Call this when data of the energy changed between runs (a new temperature, a new Z):
        otherwise the first step would count that change as the flow's own decrease.
        """
        self._last_energy = self.evaluate_energy()

    def checkpoint_fields(self) -> dict[str, Function]:
        """The functions a checkpoint must hold to continue the flow exactly.

        The state and the last step's solution (the next step solve's initial guess).
        """
        return {"y": self.y, "step_solution": self.solution}

    def checkpoint_state(self) -> dict[str, Any]:
        """The counters a checkpoint must hold (with :meth:`checkpoint_fields`).

        With them τ (that of the step matrix and the adaptive controller's proposal), so that a
        resumed adaptive run goes on with the τ it had, not the initial one. K is not in it: a
        resumed run assembles K whole, where the uninterrupted one may carry it by increments,
        so the two can differ by round-off from there on (writing a checkpoint must not change
        the run, so it does not reassemble K).
        """
        return {
            **super().checkpoint_state(),
            "fallbacks": self.fallbacks,
            "tau": self.tau,
            "target_tau": self._target_tau,
            "rejected_steps": self.rejected_steps,
            "refactorisations": self.refactorisations,
            "newton_steps": self.newton_steps,
            "newton_rejections": self.newton_rejections,
            "step_solves": self.step_solves,
            "active_set_changes": self.active_set_changes,
            "active_set_redos": self.active_set_redos,
            "factorisations": self._factorisations(),
            "newton_factorisations": self._newton_factorisations(),
        }

    def _factorisations(self) -> int | None:
        """Factorisations of the step solver over all runs (None: it does not count them)."""
        own = getattr(self.solver, "factorisations", None)
        return None if own is None else own + self._earlier_factorisations["step"]

    def _newton_factorisations(self) -> int:
        """Factorisations of the SQP matrices over all runs."""
        return int(self._newton.factorisations) + self._earlier_factorisations["newton"]

    @property
    def checkpoint_every(self) -> int:
        """Steps between checkpoints: ``flow.checkpoint_every``."""
        return self.settings.checkpoint_every

    def remaining_steps(self) -> int:
        """Steps left of ``max_steps`` (the budget of a run and its resumed runs)."""
        return max(self.settings.max_steps - self.step_count, 0)

    @property
    def shape(self) -> Function:
        """The deformation y (the :class:`~dgplate.solvers.driver.Driver` protocol)."""
        return self.y

    def summary(self) -> dict[str, Any]:
        """The flow's numbers for ``summary.json`` (collective)."""
        return {
            "dofs": self.num_dofs,
            "energy": self.evaluate_energy(),
            "isometry_defect": self.defect(),
            "tau": self.tau,
            "energy_increases": list(self.energy_increases),
            "solver_fallbacks": self.fallbacks,
            "rejected_steps": self.rejected_steps,
            "refactorisations": self.refactorisations,
            "active_set_changes": self.active_set_changes,
            "active_set_redos": self.active_set_redos,
            "factorisations": self._factorisations(),
            "newton_steps": self.newton_steps,
            "newton_rejections": self.newton_rejections,
            "newton_factorisations": self._newton_factorisations(),
            "step_solves": self.step_solves,
        }

    def restore_state(self, state: dict[str, Any]) -> None:
        """Continue from a checkpoint's counters (after its fields were restored)."""
        super().restore_state(state)
        self.fallbacks = int(state.get("fallbacks", 0))
        tau = float(state.get("tau", self.tau))
        if tau != self.tau:
            self._put_tau(tau)
        self._target_tau = float(state.get("target_tau", tau))
        self.rejected_steps = int(state.get("rejected_steps", 0))
        self.refactorisations = int(state.get("refactorisations", 0))
        self.newton_steps = int(state.get("newton_steps", 0))
        self.newton_rejections = int(state.get("newton_rejections", 0))
        self.step_solves = int(state.get("step_solves", 0))
        self.active_set_changes = int(state.get("active_set_changes", 0))
        self.active_set_redos = int(state.get("active_set_redos", 0))
        self._earlier_factorisations = {
            "step": int(state.get("factorisations") or 0),
            "newton": int(state.get("newton_factorisations") or 0),
        }

    def undo(self) -> None:
        """Take back the last step (used when it produced a non-finite state)."""
        self.y.x.array[:] -= self._last_increment
        self.rebase_energy()

    # -- the loop ---------------------------------------------------------------------------
    def run(self, max_steps: int | None = None) -> FlowResult:
        """Step until the stopping rule holds or the step budget is spent."""
        budget = max_steps or self.remaining_steps()
        history: list[StepInfo] = []
        increases: list[int] = []
        test = (
            "‖P DE_h[yⁿ]‖_*'" if self.settings.stop == "stationarity" else "(E_h[yⁿ⁻¹] − E_h[yⁿ])/τ"
        )
        # the budget as the user set it (flow.max_steps counts the steps of resumed runs too)
        total = max_steps or self.settings.max_steps
        converged, reason = (
            False,
            f"step budget of {total} steps spent before {test} < {self.settings.tol:g}",
        )
        signum = 0
        for _ in range(budget):
            try:
                info = self._adaptive_step() if self.settings.adaptive_tau else self._safe_step()
            except SolverError as exc:
                reason = f"step {self.step_count + 1} failed: {exc}; the last good state is kept"
                break
            if not (math.isfinite(info.energy) and math.isfinite(info.defect)):
                self.undo()
                reason = f"diverged at step {info.step}: the energy became {info.energy}; the last finite state is kept"
                break
            self.fallbacks += info.fallbacks
            stop = self._stop_reason(info)  # first: it fills the record's stationarity
            self.record_step(info, history, increases)
            if stop:
                converged, reason = True, stop
                break
            signum = interrupt.requested(self.comm)  # collective: every rank stops together
            if signum:
                reason = interrupt.reason(signum)
                break
        last = history[-1] if history else None
        energy = last.energy if last else self.evaluate_energy()
        defect = last.defect if last else self.defect()
        result = FlowResult.of((converged, reason, signum), history, increases, energy, defect)
        for obs in self.observers:
            obs.finish(self, result)
        return result

    def _adaptive_step(self) -> StepInfo:
        """One accepted step with adaptive τ (``flow.adaptive_tau``).

        A step is accepted when E_h did not rise and the isometry defect after the linearised
        step (before projection) is at most ``flow.defect_bound`` and the nonlocal terms
        (self-avoidance) accept the new state; the controller's τ then grows
        (:meth:`_grow_tau`). Otherwise the step is taken back and redone with half the τ it
        was taken with (refactorised at once), down to 10⁻⁶ of the initial τ (below that the
        step is accepted as it is). Rejected steps are counted in :attr:`rejected_steps`.

        With ``flow.newton_finish``, once τ is at its cap the step is first tried as an SQP step
        (:mod:`dgplate.solvers.sqp`); if it fails the same test (or its matrix cannot be
        factorised) it is taken back and redone as a plain step with the same τ
        (:attr:`newton_rejections`).
        """
        y0 = self.y.x.array.copy()
        energy0, time0, count0 = self._last_energy, self.time, self.step_count
        tau_min = 1e-6 * self._initial_tau
        newton = self._newton_due()
        defect0 = self.defect() if newton else math.inf
        while True:
            info = self._attempt(newton)
            if info is not None and (
                self._accepted(info, energy0, defect0 if newton else math.inf)
                or (self.tau / 2 < tau_min and not newton)
            ):
                self.newton_steps += newton
                self._grow_tau()
                return info
            self.y.x.array[:] = y0
            self._last_energy, self.time, self.step_count = energy0, time0, count0
            if newton:  # redone as a plain step with the same τ
                self.newton_rejections += 1
                newton = False
                continue
            self.rejected_steps += 1
            self.tau = self.tau / 2

    def _attempt(self, newton: bool) -> StepInfo | None:
        """A step; an SQP step whose matrix cannot be factorised gives None (to redo it plain)."""
        if not newton:
            return self._contact_step()
        try:
            return self.step(newton=True)
        except SolverError:
            return None

    def _accepted(self, info: StepInfo, energy0: float, defect0: float = math.inf) -> bool:
        """The adaptive controller's test of a step from the energy ``energy0``.

        E_h did not rise, the linearisation error is at most ``flow.defect_bound`` and the
        nonlocal terms accept the state; a non-finite energy or defect fails. An SQP step
        (``defect0``: D_h of its start) must also end at most as far off the constraint as it
        started, or at round-off: when its corrections stall, the state lies below the
        constrained energy by about λ·D_h, and every later step, whose projections restore the
        constraint, would count that as a rise of E_h (BNN 64² with τ grown eightfold per step:
        D_h = 2.1·10⁻⁴ after an SQP step that started at 9.7·10⁻⁶, then 29 rejections).
        """
        lowered = info.energy <= energy0 + 1e-12 * max(1.0, abs(energy0))
        close = self._linear_defect <= self.settings.defect_bound
        on_constraint = info.defect <= max(defect0, SQP_DEFECT_TOL * self.defect.area)
        accepted = all([term.accept() for term in self.energy.nonlocal_terms])
        return lowered and close and on_constraint and accepted

    def _newton_due(self) -> bool:
        """Whether the next step is an SQP step: ``flow.newton_finish`` and τ large enough.

        τ (the held one) at least ``flow.newton_tau_ratio`` times the initial τ, or at its cap.
        """
        settings = self.settings
        ratio = min(settings.newton_tau_ratio, settings.tau_max_ratio)
        return settings.newton_finish and self.tau >= ratio * self._initial_tau * (1 - 1e-12)

    def _grow_tau(self) -> None:
        """After an accepted step: the proposal grows by :meth:`_growth`, up to its cap.

        The step matrix takes it only when it differs from the τ held there by more than
        ``flow.refactor_factor``; until then the steps are gradient-flow steps with the held τ.
        """
        settings = self.settings
        cap = settings.tau_max_ratio * self._initial_tau
        self._target_tau = min(self._growth() * self._target_tau, cap)
        ratio = max(self._target_tau / self.tau, self.tau / self._target_tau)
        if ratio > settings.refactor_factor * (1 + 1e-12):
            self._put_tau(self._target_tau)

    def _growth(self) -> float:
        """The factor of τ after an accepted step (``flow.tau_growth``, ``flow.tau_growth_max``).

        With the SQP finish and until the run's first rejection, √(defect_bound/D)/2 between
        the two, D the step's defect before projection: the factor that would bring a defect
        ∝ τ² to a quarter of the bound, as an error-based step-size controller does. It takes
        the run to the SQP steps sooner (box, second hold: 10 step solves against 14). Plain
        steps gain nothing from a τ grown fast (BNN 32², plain adaptive τ: 56 step solves
        against 38), and after a rejection a long step may leave the state off the constraint
        by more than the next projection restores: then, and without the finish, the fixed
        growth.
        """
        settings = self.settings
        fast = settings.newton_finish and not self.rejected_steps
        if not fast or settings.tau_growth_max <= settings.tau_growth:
            return settings.tau_growth
        defect = max(self._linear_defect, 1e-300)
        wanted = 0.5 * math.sqrt(settings.defect_bound / defect)
        return min(max(wanted, settings.tau_growth), settings.tau_growth_max)

    def _stop_reason(self, info: StepInfo) -> str:
        """Why the flow stops converged after this step ('' to go on): ``flow.stop``."""
        tol = self.settings.tol
        if self.settings.stop == "stationarity":
            before = self._stationarity_fallbacks
            info.stationarity = self.stationarity()
            more = self._stationarity_fallbacks - before  # in the record and in the total
            info.fallbacks += more
            self.fallbacks += more
            if info.stationarity < tol:
                return f"‖P DE_h[yⁿ]‖_*' = {info.stationarity:.3e} < {tol:g}"
            return ""
        if abs(info.rate) < tol:
            return f"(E_h[yⁿ⁻¹] − E_h[yⁿ])/τ = {info.rate:.3e} < {tol:g}"
        return ""

    def destroy(self) -> None:
        """Free the solver and the matrices."""
        self.solver.destroy()
        self._newton.destroy()
        if self._stationarity is not None:
            self._stationarity[2].destroy()
            self._stationarity[1].destroy()
        self.K.destroy()
        if self.A_const is not None:
            self.A_const.destroy()


def _flat(x: Array) -> Array:
    """The flat reference deformation y(x) = (x₁, x₂, 0), at points of shape (3, n)."""
    return np.vstack([x[0], x[1], np.zeros_like(x[0])])


def _max_row_sum(matrix: PETSc.Mat) -> float:
    """‖A‖_∞, the largest absolute row sum."""
    norm = matrix.norm(compat.NORM_INFINITY)
    assert isinstance(norm, float)  # a tuple only for NORM_1_AND_2
    return norm
