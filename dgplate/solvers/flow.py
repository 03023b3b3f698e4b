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
(:class:`dgplate.solvers.lagged.LaggedStepSolver`) and refactorises only when the iteration count
grows. The flow is generic: it only sees an :class:`Energy`.

:class:`GradientFlow` is the driver; it composes the step system
(:class:`dgplate.solvers.step_system.StepSystem`: assembly and solves), the τ controller
(:class:`dgplate.solvers.tau.TauController`: fixed or adaptive τ, the SQP switch), the
safeguards (:mod:`dgplate.solvers.safeguard`: nonlocal terms, active sets), the corrections
(:class:`dgplate.solvers.projection.Projection`) and the stopping measure
(:class:`dgplate.solvers.stationarity.Stationarity`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any, Literal

from mpi4py import MPI

import dolfinx.fem
import numpy as np
from ufl.core.expr import Expr

from dgplate import compat, interrupt, mpi
from dgplate.compat import Array, Function
from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets
from dgplate.dg.geometry import max_cell_diameter
from dgplate.errors import SolverError
from dgplate.schema import option
from dgplate.solvers import linear, metric_start, transfer
from dgplate.solvers.constraint import IsometryDefect, refuse_edge_moments_with_metric
from dgplate.solvers.driver import EnergyFlow, Observer
from dgplate.solvers.linear import OptionValue
from dgplate.solvers.projection import Merit, Projection
from dgplate.solvers.stationarity import Stationarity
from dgplate.solvers.step_system import FlowCounts, Spaces, StepSystem, mixed_space
from dgplate.solvers.steps import FlowResult, StepInfo, stopping_value
from dgplate.solvers.tau import TauController

#: The stopping tests (``flow.stop``).
STOPS = ("rate", "stationarity")

#: ``flow.method``: "accurate" takes the model's defaults (a plate's: :data:`ACCURATE`),
#: "bnn" the published gradient flow of Bartels, Bonito and Nochetto: the option defaults of
#: :class:`FlowSpec` (fixed τ, no projection, the rate stop).
METHODS = ("accurate", "bnn")

#: The plate models' defaults of [flow] keys, under a problem's own (``flow.method =
#: "accurate"``): adaptive τ with the SQP finish, two corrections per step restoring the
#: discrete constraint, and the τ-independent stop, so that a run ends at a discrete minimiser
#: (docs/accuracy.md) and ``dgplate converge`` extrapolates minimisers, not stopped flows.
ACCURATE: dict[str, Any] = {"adaptive_tau": True, "projection_steps": 2, "stop": "stationarity"}

#: The adaptive step controls (``flow.step_control``).
STEP_CONTROLS = ("trust_region", "defect_bound")

#: The initial deformation: points x (shape (3, n)) to their images (shape (3, n)).
Initial = Callable[[Array], Array]


@dataclass
class FlowSpec:
    """The [flow] section: parameters of the gradient flow, validated once, here.

    D_h = O(τ). Cell moments alone let a free edge's cells curve two ways (K ≠ 0), below the
    isometric minimum: ``edge_constraint`` also constrains two moments of the metric on free
    boundary facets (:class:`dgplate.solvers.constraint.EdgeConstraint`).
    """

    method: str = option(
        "accurate",
        "'accurate': the model's defaults of the keys below (a plate's: adaptive τ, SQP finish, projection_steps = 2, stop = 'stationarity'; a run ends at a discrete minimiser); 'bnn': the published method of Bartels, Bonito and Nochetto (fixed τ, no projection, the rate stop: what the defaults shown here are). Keys given in the file override either",
        choices=METHODS,
    )
    tau: float | Literal["h"] = option(
        "h", "time step τ > 0, or 'h' for the largest cell diameter", gt=0
    )
    tol: float = option(1e-6, "stop when the stopping test (flow.stop) falls below tol", gt=0)
    max_steps: int = option(1000, "step budget; reaching it is reported as not converged", ge=1)
    l2_metric: bool | Literal["auto"] = option(
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
        choices=(0, 1),
    )
    projection_steps: int = option(
        0,
        "corrections per step restoring the nonlinear discrete constraint (0: published method; 2 drives D_h to round-off)",
        ge=0,
    )
    linear_solver: str = option(
        "lagged",
        "step solver: 'lagged' (one MUMPS LDLᵀ factorisation reused as FGMRES preconditioner, refactorised when needed) or 'direct' (LU every step)",
        choices=linear.STEP_SOLVERS,
        retired=("schur",),
        note="the Schur solver was removed: docs/performance.md",
    )
    refactor_its: int = option(
        12, "lagged solver: refactorise after a solve that needed more FGMRES iterations", ge=1
    )
    edge_constraint: bool = option(
        False,
        "also constrain the metric on free boundary facets (edge length and normal stretch): keeps free edges of a bilayer from curving in two directions",
    )
    stop: str = option(
        "rate",
        "stopping test: 'rate' ((E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < tol, the published test; with adaptive_tau, whose growing τ lowers the rate whatever the state, its limit τ → 0, ‖P DE_h[yⁿ]‖_*'² < tol) or 'stationarity' (‖P DE_h[yⁿ]‖_*' < tol, the dual norm of the projected gradient: does not depend on τ)",
        choices=STOPS,
    )
    adaptive_tau: bool = option(
        False,
        "adapt τ: grow it after an accepted step, halve it and redo a refused one; which steps are accepted: a plate's step control below, a rod's in docs/rods.md",
    )
    defect_bound: float = option(
        1e-2,
        "adaptive τ: the largest isometry defect D_h of a step before its projection (the linearisation error): the acceptance test of a rod's steps, and of a plate's under its defect-bound control (and the trust region's plain steps: with active sets, or with the SQP steps off)",
        gt=0,
    )
    tau_growth: float = option(
        2.0,
        "adaptive τ: the factor by which τ grows after an accepted step (under the trust region, one whose D_h used at most half of its bound)",
        gt=1,
    )
    tau_growth_max: float = option(
        8.0,
        "adaptive τ with newton_finish and step_control = 'defect_bound': until the run's first rejected step, τ grows by √(defect_bound/D)/2 (D: the step's isometry defect before projection), at least tau_growth and at most this factor, to reach the SQP steps sooner; tau_growth after a rejection and without newton_finish (tau_growth_max = tau_growth: always tau_growth)",
        ge=1,
    )
    tau_max_ratio: float = option(
        1e3, "adaptive τ: the largest τ, as a multiple of the initial τ (flow.tau)", ge=1
    )
    refactor_factor: float = option(
        1.0,
        "adaptive τ: put a grown τ into the step matrix (reassemble and refactorise) only once it differs from the τ held there by more than this factor; until then the steps keep that τ (1: at every change)",
        ge=1,
    )
    step_control: str = option(
        "trust_region",
        "adaptive τ with newton_finish: 'trust_region' (every step an SQP step that also solves the constraint linearised from its start's defect, so the states between may be off the constraint; accepted when the merit E_h + λ·c did not rise and D_h stayed below 0.01·|ω| or its start's; τ, the trust radius: retried smaller when refused (halved, or by (D_h/bound)^(−½) down to a tenth when D_h overshot), grown by tau_growth when accepted with D_h at most half its bound, else held; a converged run ends on the constraint; not with active sets) or 'defect_bound' (plain steps accepted below defect_bound, SQP steps from newton_tau_ratio on, closed onto the constraint, a refused SQP step redone plain)",
        choices=STEP_CONTROLS,
    )
    newton_finish: bool = option(
        True,
        "adaptive τ: SQP (Newton) steps, with the Lagrangian's curvature (the multipliers' term and D²E_expl) in the step matrix: every step under step_control = 'trust_region'; under 'defect_bound' once τ reaches newton_tau_ratio times the initial τ (or its cap), a step that does not lower E_h redone as a plain step",
    )
    newton_tau_ratio: float = option(
        100.0,
        "adaptive τ with newton_finish and step_control = 'defect_bound': the τ, as a multiple of the initial τ, from which the steps are SQP steps (capped by tau_max_ratio)",
        ge=1,
    )
    checkpoint_every: int = option(
        25,
        "write a checkpoint (for --resume) every n steps, and always at the end; 0: only at the end",
        ge=0,
    )

    def __post_init__(self) -> None:
        linear.check_option_names(self.solver, "flow.solver")

    @property
    def l2(self) -> bool | None:
        """Whether the metric has the L² product; None: decided by the model (clamped?)."""
        return None if self.l2_metric == "auto" else bool(self.l2_metric)


class GradientFlow(EnergyFlow):
    """The constrained H² gradient flow of an energy built by ``energy_fn(y)`` (a Driver)."""

    #: The step system's class (a benchmark replaces it by a naive one).
    system_type: type[StepSystem] = StepSystem
    settings: FlowSpec

    def __init__(
        self,
        facets: FacetSets,
        degree: int,
        energy_fn: Callable[[Function], Energy],
        settings: FlowSpec,
        observers: Sequence[Observer] = (),
        initial: Initial | None = None,
        metric: Expr | None = None,
        continuous: bool = False,
    ):
        """The flow from ``initial`` (default: the flat plate) of ``energy_fn(y)``.

        Args:
            facets: the mesh and its facet sets (clamped, free, creases).
            degree: the degree k ≥ 2 of y ∈ [DG_k]³.
            energy_fn: the energy of a deformation y.
            settings: the [flow] section.
            observers: told of every step and of the end of each run.
            initial: the initial deformation; None: y(x) = (x₁, x₂, 0).
            metric: the target metric G of the constraint ∇yᵀ∇y = G (None: I, isometries).
                With a G the first run begins with the metric start
                (:mod:`dgplate.solvers.metric_start`; from an ``initial``, its projections
                only): the flat plate violates the constraint.
            continuous: y continuous (C⁰ interior penalty: step_system.mixed_space).
        """
        refuse_edge_moments_with_metric(metric, settings.edge_constraint)
        self.facets, self.settings, self.observers = facets, settings, list(observers)
        mesh = facets.mesh
        self.comm: MPI.Comm = mesh.comm
        self.W = mixed_space(mesh, degree, settings, continuous)
        self.V, self._vdofs = compat.collapse(self.W.sub(0))
        self.y: Function = dolfinx.fem.Function(self.V, name="deformation")
        transfer.interpolate(self.y, initial or flat)
        self.energy = energy_fn(self.y)
        self.defect = IsometryDefect(self.y, metric)
        self.metric = metric
        self.start_phase = metric_start.StartPhase(metric, initial is not None)
        self.time, self.step_count = 0.0, 0
        self.energy_increases: list[int] = []  # steps at which E_h went up, over all runs
        self.counts = FlowCounts()
        self._last_increment: Array = np.zeros(0)  # δy of the last step (for undo)
        self.merit: Merit | None = None  # of the last step, if an SQP step off the constraint
        tau = max_cell_diameter(mesh) if settings.tau == "h" else float(settings.tau)
        spaces = Spaces(self.W, self.V, self._vdofs, self.y)
        self.system = self.system_type(
            spaces, facets, self.energy, settings, tau, self.counts, metric
        )
        self.control = TauController(self, self.system, settings, tau)
        self.projection = Projection(self.system, self.defect, settings.projection_steps)
        self.measure = Stationarity(self.system, settings, tau)
        self._E_form = dolfinx.fem.form(self.energy.total)
        self._last_energy = self.evaluate_energy()

    @property
    def tau(self) -> float:
        """The time step τ of the step matrix; setting it reassembles the constant block.

        Setting it also resets the adaptive controller's proposal to it, and counts one
        refactorisation (``refactorisations``).
        """
        return self.system.tau

    @tau.setter
    def tau(self, value: float) -> None:
        self.control.set_tau(value)

    @property
    def shape(self) -> Function:
        """The deformation y (the :class:`~dgplate.solvers.driver.Driver` protocol)."""
        return self.y

    def options_prefixes(self) -> list[str]:
        """The options prefixes of the step solver's KSPs (none while it is being built)."""
        solver = self.system.solver
        return solver.prefixes() if solver is not None else []

    def save(self) -> tuple[Array, float, float, int]:
        """The state a redone step starts from: y, the last energy, the time, the step count."""
        return self.y.x.array.copy(), self._last_energy, self.time, self.step_count

    def restore(self, saved: tuple[Array, float, float, int]) -> None:
        """Take back the state of :meth:`save`."""
        self.y.x.array[:] = saved[0]
        self._last_energy, self.time, self.step_count = saved[1:]

    def rebase_energy(self) -> None:
        """Measure the energy decrease from the current state again.

        Call this when data of the energy changed between runs (a new temperature, a new Z):
        otherwise the first step would count that change as the flow's own decrease.
        """
        self._last_energy = self.evaluate_energy()

    def undo(self) -> None:
        """Take back the last step (used when it produced a non-finite state)."""
        self.y.x.array[:] -= self._last_increment
        self.rebase_energy()

    def stationarity(self) -> float:
        """‖P DE_h[y]‖_*' at the current y (collective; :class:`Stationarity`)."""
        return self.measure()

    def checkpoint_fields(self) -> dict[str, Function]:
        """The state and the last step's solution (the next step solve's initial guess)."""
        return {"y": self.y, "step_solution": self.system.solution}

    def checkpoint_state(self) -> dict[str, Any]:
        """The counters a checkpoint must hold (with :meth:`checkpoint_fields`).

        With them τ (the step matrix's and the proposal: a resumed adaptive run goes on with the
        τ it had) and the metric start's figures. Not K: a resumed run assembles it whole, the
        uninterrupted one may carry it by increments (the two differ by round-off from there).
        """
        return {
            **super().checkpoint_state(),
            "tau": self.tau,
            "target_tau": self.control.target,
            **asdict(self.counts),
            "factorisations": self.system.factorisations(),
            "newton_factorisations": self.system.newton_factorisations(),
            **self.start_phase.entries(),
        }

    def restore_state(self, state: dict[str, Any]) -> None:
        """Continue from a checkpoint's counters (after its fields were restored)."""
        super().restore_state(state)
        self.start_phase.restore(state)
        tau = float(state.get("tau", self.tau))
        if tau != self.tau:
            self.system.put_tau(tau)
        self.control.target = float(state.get("target_tau", tau))
        for key in asdict(self.counts):
            setattr(self.counts, key, int(state.get(key, 0)))
        self.system.earlier_factorisations = {
            "step": int(state.get("factorisations") or 0),
            "newton": int(state.get("newton_factorisations") or 0),
        }

    def summary(self) -> dict[str, Any]:
        """The flow's numbers for ``summary.json`` (collective)."""
        counts = self.counts
        return {
            "dofs": self.num_dofs,
            "energy": self.evaluate_energy(),
            "isometry_defect": self.defect(),
            "tau": self.tau,
            "energy_increases": list(self.energy_increases),
            "solver_fallbacks": counts.fallbacks,
            "rejected_steps": counts.rejected_steps,
            "refactorisations": counts.refactorisations,
            "active_set_changes": counts.active_set_changes,
            "active_set_redos": counts.active_set_redos,
            "factorisations": self.system.factorisations(),
            "newton_steps": counts.newton_steps,
            "newton_rejections": counts.newton_rejections,
            "newton_factorisations": self.system.newton_factorisations(),
            "step_solves": counts.step_solves,
            **self.start_phase.entries(),
        }

    # -- the loop ---------------------------------------------------------------------------
    def run(self, max_steps: int | None = None, test_last: bool = True) -> FlowResult:
        """Step until the stopping rule holds or the step budget is spent.

        Args:
            max_steps: the budget of this run; None: what is left of ``flow.max_steps``.
            test_last: False: the step that spends the budget ends the run untested (the
                stopping test's solve costs about as much as a step: a caller that tracks a
                path with a step or two per load increment does not need it).

        Returns:
            How the run ended, with its records.
        """
        if self.start_phase.pending:
            ended = self.start_phase.run(self, self.observers)
            if ended is not None:
                return self._finish(False, *ended, [], [])
            self.rebase_energy()
        budget = max_steps or self.remaining_steps()
        history: list[StepInfo] = []
        increases: list[int] = []
        test = stopping_value(self.settings, math.nan, math.nan)[1]
        # the budget as the user set it (flow.max_steps counts the steps of resumed runs too)
        total = max_steps or self.settings.max_steps
        untested = "" if test_last else " (the last step not tested)"
        reason = (
            f"step budget of {total} steps spent before {test} < {self.settings.tol:g}{untested}"
        )
        converged, signum = False, 0
        for k in range(budget):
            try:
                info = self.control.step()
            except SolverError as exc:
                reason = f"step {self.step_count + 1} failed: {exc}; the last good state is kept"
                break
            if not (math.isfinite(info.energy) and math.isfinite(info.defect)):
                self.undo()
                reason = f"diverged at step {info.step}: the energy became {info.energy}; the last finite state is kept"
                break
            self.counts.fallbacks += info.fallbacks
            tested = test_last or k < budget - 1
            # first: it fills the record's stationarity
            stop = self.measure.stop_reason(info) if tested else ""
            if stop and self._land(info):  # measured again on the constraint
                stop = self.measure.stop_reason(info)
            self.record_step(info, history, increases)
            if stop:
                converged, reason = True, stop
                break
            signum = interrupt.requested(self.comm)  # collective: every rank stops together
            if signum:
                reason = interrupt.reason(signum)
                break
        return self._finish(converged, reason, signum, history, increases)

    def _land(self, info: StepInfo) -> bool:
        """Land a converged run on the constraint (:meth:`Projection.land`), update ``info``."""
        if self.merit is None or not self.projection.land(self._last_increment):
            return False
        energy = self.evaluate_energy()
        info.rate += (info.energy + self.merit.end - energy) / info.tau
        info.energy, info.defect, self._last_energy = energy, self.defect(), energy
        return True

    def _finish(
        self,
        converged: bool,
        reason: str,
        signum: int,
        history: list[StepInfo],
        increases: list[int],
    ) -> FlowResult:
        """The run's result, told to the observers."""
        last = history[-1] if history else None
        energy = last.energy if last else self.evaluate_energy()
        defect = last.defect if last else self.defect()
        result = FlowResult.of((converged, reason, signum), history, increases, energy, defect)
        for obs in self.observers:
            obs.finish(self, result)
        return result

    # -- one step ---------------------------------------------------------------------------
    def step(self, newton: bool = False) -> StepInfo:
        """One step of the flow from yⁿ to yⁿ⁺¹ (collective).

        Args:
            newton: the SQP step (:mod:`dgplate.solvers.sqp`), its projections by its factors.

        Returns:
            The step's record.
        """
        t0 = time.perf_counter()
        sqp_path = newton and self.control.trust_region()
        solver = self.system.assemble(newton, residual=sqp_path)
        t1 = time.perf_counter()
        stats = self.system.solve(solver)
        t2 = time.perf_counter()
        dy = self.system.solution.x.array[self._vdofs].copy()
        self.y.x.array[:] += dy
        if self.settings.adaptive_tau:
            self.control.linear_defect = self.defect()
        self.merit = self.projection.after_step(stats, solver, dy, newton, sqp_path)
        self._last_increment = dy
        owned = self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs
        increment = mpi.global_max(self.comm, float(np.max(np.abs(dy[:owned]), initial=0.0)))
        energy = self.evaluate_energy()
        # off the constraint, the decrease of the merit E_h + λ·c (Merit)
        change = self.merit.start - self.merit.end if self.merit else 0.0
        rate = (self._last_energy - energy + change) / self.tau
        self._last_energy = energy
        self.step_count += 1
        self.time += self.tau
        return StepInfo(
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

    def destroy(self) -> None:
        """Free the solvers and the matrices."""
        self.system.destroy()
        self.measure.destroy()


def flat(x: Array) -> Array:
    """The flat reference deformation y(x) = (x₁, x₂, 0).

    Args:
        x: points, of shape (3, n).

    Returns:
        y at the points, of shape (3, n).
    """
    return np.vstack([x[0], x[1], np.zeros_like(x[0])])
