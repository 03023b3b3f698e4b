"""Gradient flow of an inextensible bending–torsion rod (docs/rods.md, docs/design.md §1).

The state is a pair (u, b): the centreline u ∈ [P_k]³ (C⁰ interior penalty, k ≥ 2) and the
frame director b ∈ [P₁]³ on a 1D mesh of (0, L). One step from (uⁿ, bⁿ) finds increments
(δu, δb) and multipliers (λ₁, λ₂, λ₃) with

    (1/τ) m((δu, δb), (v, c)) + D²E_impl((δu, δb), (v, c)) + B_n((v, c), λ) = −DE[uⁿ, bⁿ](v, c),
    B_n((δu, δb), q) = 0,

where B_n holds the three constraints |u′|² = 1, u′·b = 0 and |b|² = 1 linearised at
(uⁿ, bⁿ): the first two as two moments per cell (DG₁ multipliers), the third at the nodes
(P₁ multiplier, vertex quadrature). The metric m is the H² product of u (C⁰-IP) plus the H¹
product of b plus the L² products of both, so that free ends need no special case.

Why not :class:`dgplate.solvers.flow.GradientFlow`: that flow is written for a single
deformation y ∈ [DG_k]³ of a 2D plate with the isometry constraint ∇yᵀ∇y = I; the rod has two
unknown fields, three other constraints and strong end conditions. Only the step system is
different: the records, the stopping rule, the safeguard and the checkpoints are the same. The
1D system is small, so it is reassembled and factorised by MUMPS at every step.

``flow.projection_steps = m`` adds after each step m Newton corrections towards the nonlinear
constraints (the same moments and nodes): the step system assembled at the current state, with
the constraints' residual as its right-hand side, i.e. the least correction in the step's
metric that solves the constraints linearised at the current state.

Nonlocal terms of the energy (self-avoidance ρ·TP[u], :class:`dgplate.dg.energy.Nonlocal`)
are explicit: their derivative at uⁿ is one more load. A step that they refuse (the least
distance of non-neighbouring points fell too fast) or that raised the energy is taken back
and redone with τ/2, at most ``max_redo`` times, by the plate flow's
:class:`dgplate.solvers.safeguard.Safeguard`.

``flow.adaptive_tau`` (:class:`RodTau`): a step is accepted when the energy did not rise, the
largest constraint defect after the linearised step (before the projection) is at most
``flow.defect_bound`` and the nonlocal terms accept the state; τ then grows by
``flow.tau_growth`` up to ``flow.tau_max_ratio`` times the initial τ, else the step is redone
with τ/2. With a τ that changes, the rate (E[xⁿ⁻¹] − E[xⁿ])/τ measures τ rather than the state
(it falls as τ grows), so the rate stop then compares the rate's limit τ → 0 with ``flow.tol``:
the square of the τ-independent measure ‖P DE[xⁿ]‖_*' (:class:`RodStationarity`), which
``flow.stop = 'stationarity'`` compares itself.
"""

from __future__ import annotations

import math
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
from ufl.core.expr import Expr

from dgplate import compat, interrupt, mpi, values
from dgplate.compat import Array, Function, FunctionSpace, Mesh
from dgplate.dg.energy import Energy
from dgplate.dg.forms import integral
from dgplate.errors import SolverError
from dgplate.solvers import linear, steps
from dgplate.solvers.driver import EnergyFlow, Observer
from dgplate.solvers.flow import FlowSpec
from dgplate.solvers.rod_forms import (
    Defects,
    RodStationarity,
    ip_jumps,
    ip_product,
    metric,
    nitsche_slope,
    nodal,
    tangent,
)
from dgplate.solvers.safeguard import Safeguard, passes, safety
from dgplate.solvers.steps import FlowResult, measured, per_step, stop_reason, stopping_value

__all__ = [
    "DEFAULTS",
    "RodFlow",
    "RodState",
    "RodStep",
    "RodTau",
    "ip_jumps",
    "ip_product",
    "nitsche_slope",
    "tangent",
]

#: The rod flow's own defaults of [flow] keys (a problem file's keys override them): adaptive
#: τ, two corrections per step, the τ-independent stop. The clamped rod with κ = π (32 cells,
#: from τ = h = 1/32) reaches the half circle in 76 steps with defects ≤ 3·10⁻¹⁴; with the
#: plates' defaults (fixed τ, no projection, rate stop) it spent 1000 steps at defects of 2–5 %
#: and E_h = −0.035 (the discrete minimum: +0.0059) (docs/rods.md).
DEFAULTS: dict[str, Any] = {"adaptive_tau": True, "projection_steps": 2, "stop": "stationarity"}

#: (u, b) ↦ the rod energy.
RodEnergy = Callable[[Function, Function], Energy]


@dataclass
class RodState:
    """The start of a rod flow: u⁰ and b⁰ as callables of points (3, n) → (3, n)."""

    centreline: Callable[[Array], Array]
    frame: Callable[[Array], Array]
    clamped: tuple[float, ...]  # s of the ends where b is kept (u′ is the energy's datum)
    pinned: tuple[float, ...]  # s of the ends where u is kept


@dataclass
class RodStep:
    """What one step did: the row of ``history.csv``."""

    step: int
    time: float
    tau: float
    energy: float
    defect: float  # the largest of the three constraint defects
    increment: float  # max |δu|, |δb| over the degrees of freedom
    rate: float  # (E[xⁿ⁻¹] − E[xⁿ]) / τ
    seconds: float
    safety: dict[str, float] = field(default_factory=dict)  # nonlocal terms: min_distance, redone
    figures: dict[str, float] = field(default_factory=dict)  # the model's per-step measures
    projection: dict[str, float] = field(default_factory=dict)  # E after − E before projection
    stationarity: float = math.nan  # ‖P DE[xⁿ]‖_*' (when the stopping test needs it)

    def line(self) -> str:
        """One line of progress output."""
        return (
            f"step {self.step:5d}  t = {self.time:9.4f}  τ = {self.tau:.3e}  "
            f"E_h = {self.energy:+.6e}  defect = {self.defect:.3e}  "
            f"ΔE/τ = {self.rate:.2e}  {per_step(self.seconds)}"
        )


def _space(mesh: Mesh, degree: int) -> FunctionSpace:
    """[P_k]³ × [P₁]³ × DG₁ × DG₁ × P₁: centreline, frame and the three multipliers."""
    cell = mesh.basix_cell()
    elements = [
        basix.ufl.element("P", cell, degree, shape=(3,)),
        basix.ufl.element("P", cell, 1, shape=(3,)),
        basix.ufl.element("DG", cell, 1),
        basix.ufl.element("DG", cell, 1),
        basix.ufl.element("P", cell, 1),
    ]
    return dolfinx.fem.functionspace(mesh, basix.ufl.mixed_element(elements))


class RodTau:
    """Adaptive τ of the rod flow (``flow.adaptive_tau``): accept and grow, or halve and redo.

    A step is accepted when the energy did not rise (beyond round-off), the largest constraint
    defect after the linearised step, before the projection, is at most ``flow.defect_bound``
    (the linearisation error, O(τ²)) and the nonlocal terms accept the state; τ then grows by
    ``flow.tau_growth``, up to ``flow.tau_max_ratio`` times the initial τ. Otherwise the step
    is taken back and redone with τ/2, down to 10⁻⁶ of the initial τ (below that it is
    accepted as it is). Redone steps are counted in ``rejected_steps``.
    """

    def __init__(self, flow: RodFlow, settings: FlowSpec):
        """The controller of ``flow``, from its τ."""
        self.flow, self.settings = flow, settings
        self.initial = flow.tau
        self.rejected_steps = 0

    def step(self) -> RodStep:
        """One accepted step; τ grown for the next one."""
        flow = self.flow
        saved, energy0 = flow.save(), flow._last_energy
        redone = 0
        while True:
            info = flow.step()
            if self._accepted(info, energy0) or flow.tau / 2 < 1e-6 * self.initial:
                break
            flow.restore(saved)
            flow.tau, redone = flow.tau / 2, redone + 1
        self.rejected_steps += redone
        terms = flow.energy.nonlocal_terms
        if terms:
            info.safety = safety(terms, redone)
        cap = self.settings.tau_max_ratio * self.initial
        flow.tau = min(self.settings.tau_growth * flow.tau, cap)
        return info

    def _accepted(self, info: RodStep, energy0: float) -> bool:
        """E did not rise and the linearisation error is small; then the nonlocal terms accept."""
        lowered = steps.not_raised(energy0, info.energy)
        close = self.flow.linear_defect <= self.settings.defect_bound
        return passes(lowered and close, self.flow.energy.nonlocal_terms)


class RodFlow(EnergyFlow):
    """The constrained gradient flow of a rod energy E(u, b) (a Driver).

    Args:
        mesh: the rod's interval mesh.
        degree: the polynomial degree of the centreline u.
        energy_fn: (u, b) ↦ the rod energy.
        settings: the [flow] section (with the rod's defaults).
        state: the start: centreline, frame and end conditions.
        observers: told of every step and of the end of the run.
        measures: figures of the state recorded with every step (e.g. the writhe).
    """

    settings: FlowSpec

    def __init__(
        self,
        mesh: Mesh,
        degree: int,
        energy_fn: RodEnergy,
        settings: FlowSpec,
        state: RodState,
        observers: Sequence[Observer] = (),
        measures: Callable[[RodFlow], dict[str, float]] | None = None,
    ):
        self.comm: MPI.Comm = mesh.comm
        self._measures = measures
        self.settings, self.observers = settings, list(observers)
        self.W = _space(mesh, degree)
        (Vu, self._udofs), (Vb, self._bdofs) = (compat.collapse(self.W.sub(i)) for i in (0, 1))
        self.u: Function = dolfinx.fem.Function(Vu, name="centreline")
        self.b: Function = dolfinx.fem.Function(Vb, name="frame")
        self.u.interpolate(state.centreline)
        self.b.interpolate(state.frame)
        self.energy = energy_fn(self.u, self.b)
        self.defects = Defects(self.u, self.b)
        # clamped: the H² seminorm of u and the H¹ seminorm of b are norms already, and an
        # L² part would only slow down the large rotations of the rod
        self._l2 = not state.pinned
        self.time, self.step_count = 0.0, 0
        self.energy_increases: list[int] = []
        length = integral(dolfinx.fem.form(1.0 * ufl.dx(domain=mesh)), self.comm)
        cells = mesh.topology.index_map(1).size_global
        tau = length / cells if settings.tau == "h" else float(settings.tau)
        self._tau = values.constant(mesh, tau)
        self._bcs = self._end_conditions(state.clamped, state.pinned)
        self._build_forms()
        self._project()  # the start meets the constraints at the nodes, not at the Gauss points
        self._E_form = dolfinx.fem.form(self.energy.total)
        self._last_energy = self.evaluate_energy()
        self._last_increment: Array = np.zeros(0)
        self.linear_defect = 0.0  # the largest defect after the last linearised step
        self.safeguard = Safeguard(self, self.energy)
        self.control = RodTau(self, settings) if settings.adaptive_tau else None

    # -- set-up -----------------------------------------------------------------------------
    def _end_conditions(self, clamped: tuple[float, ...], pinned: tuple[float, ...]) -> list[Any]:
        """δu = 0 at pinned ends, δb = 0 and the frame multiplier at clamped ends.

        The frame multiplier's row would be empty there. The start meets the end data; the slope u′ is imposed weakly by the energy (Nitsche).
        """
        mesh = self.W.mesh
        bcs: list[Any] = []  # DirichletBC (its generic parameter differs between versions)
        for index, ends in ((0, pinned), (1, clamped), (4, clamped)):
            if not ends:
                continue
            nodes = dolfinx.mesh.locate_entities_boundary(
                mesh, 0, lambda x, ends=ends: np.any([np.isclose(x[0], s) for s in ends], axis=0)
            )
            sub = self.W.sub(index)
            space, _ = compat.collapse(sub)
            zero: Function = dolfinx.fem.Function(space)
            dofs = dolfinx.fem.locate_dofs_topological((sub, space), 0, nodes)
            bcs.append(dolfinx.fem.dirichletbc(zero, dofs, sub))
        return bcs

    def _build_forms(self) -> None:
        """The step matrix and right-hand side (reassembled at every step)."""
        u, b, mesh = self.u, self.b, self.W.mesh
        du, db, l1, l2, l3 = ufl.TrialFunctions(self.W)
        v, c, q1, q2, q3 = ufl.TestFunctions(self.W)

        def first(form: ufl.Form, test: Expr, test_b: Expr) -> ufl.Form:
            out: ufl.Form = ufl.derivative(form, u, test) + ufl.derivative(form, b, test_b)
            return out

        hessian = first(first(self.energy.implicit, v, c), du, db)
        step_metric = metric(du, db, v, c, mesh, self._l2)
        t = tangent(u)
        dx, dv = ufl.dx(domain=mesh), nodal(mesh)

        def residual(p1: Expr, p2: Expr, p3: Expr) -> ufl.Form:
            """The constraints (|u′|² − 1)/2, u′·b and (|b|² − 1)/2 in their moments and nodes."""
            form: ufl.Form = (
                0.5 * (ufl.dot(t, t) - 1.0) * p1 * dx
                + ufl.dot(t, b) * p2 * dx
                + 0.5 * (ufl.dot(b, b) - 1.0) * p3 * dv
            )
            return form

        def constraint(x: Expr, y: Expr, p1: Expr, p2: Expr, p3: Expr) -> ufl.Form:
            """B_n((x, y), p): the derivative of the residual at (uⁿ, bⁿ) in the direction (x, y)."""
            return first(residual(p1, p2, p3), x, y)

        kkt = constraint(v, c, l1, l2, l3) + constraint(du, db, q1, q2, q3)
        self._a = dolfinx.fem.form((1.0 / self._tau) * step_metric + hessian + kkt)
        rhs = first(self.energy.total, v, c)
        for term in self.energy.nonlocal_terms:  # depend on u only
            rhs += ufl.derivative(term.linearisation, u, v)
        self._L = dolfinx.fem.form(-rhs)
        self._residual = dolfinx.fem.form(-residual(q1, q2, q3))  # the projection's right side
        self.K = dolfinx.fem.petsc.create_matrix(self._a)
        self._rhs_fn: Function = dolfinx.fem.Function(self.W)  # a ghosted vector in every version
        self.rhs = self._rhs_fn.x.petsc_vec
        self.solution: Function = dolfinx.fem.Function(self.W)
        # the measure's metric has the L² parts always: the straight clamped rod's motion
        # δu = s·(u′ × b) has δu″ = 0 and meets the linearised constraints
        kkt_l2 = metric(du, db, v, c, mesh, True) + kkt
        self.measure = RodStationarity(
            self.W, kkt_l2, self._bcs, self.rhs, self._L, self.settings.solver
        )
        self.solver = linear.DirectStepSolver(self.comm, self.K, self.settings.solver, None)

    # -- the Driver protocol ----------------------------------------------------------------
    @property
    def tau(self) -> float:
        """The time step τ (halved by the safeguard for a redone step)."""
        return float(self._tau.value)

    @tau.setter
    def tau(self, value: float) -> None:
        self._tau.value = np.asarray(value)

    @property
    def shape(self) -> Function:
        """The centreline u (written to VTX and drawn)."""
        return self.u

    def options_prefixes(self) -> list[str]:
        """The options prefix of the step solver's KSP."""
        return self.solver.prefixes()

    def checkpoint_fields(self) -> dict[str, Function]:
        """The centreline and the frame."""
        return {"u": self.u, "b": self.b}

    def checkpoint_state(self) -> dict[str, Any]:
        """The counters of :class:`StepCounters`, and with adaptive τ the grown τ."""
        state = super().checkpoint_state()
        if self.control is not None:
            state.update(tau=self.tau, rejected_steps=self.control.rejected_steps)
        return state

    def restore_state(self, state: dict[str, Any]) -> None:
        """Continue from a checkpoint's counters: an adaptive run with the τ it had."""
        super().restore_state(state)
        if self.control is not None:
            self.tau = float(state.get("tau", self.tau))
            self.control.rejected_steps = int(state.get("rejected_steps", 0))

    def summary(self) -> dict[str, Any]:
        """The flow's numbers for ``summary.json`` (collective)."""
        out: dict[str, Any] = {
            "dofs": self.num_dofs,
            "cells": self.W.mesh.topology.index_map(1).size_global,
            "energy": self.evaluate_energy(),
            "tau": self.tau,
            "energy_increases": list(self.energy_increases),
        }
        if self.control is not None:
            out["rejected_steps"] = self.control.rejected_steps
        out.update(self.defects())
        if self.energy.nonlocal_terms:
            self.evaluate_energy()  # the terms at the current state
            out["min_distance"] = min(term.min_distance for term in self.energy.nonlocal_terms)
        return out

    # -- one step ---------------------------------------------------------------------------
    def step(self) -> RodStep:
        """One step from (uⁿ, bⁿ) to (uⁿ⁺¹, bⁿ⁺¹) (collective)."""
        t0 = time.perf_counter()
        for term in self.energy.nonlocal_terms:
            term.update()  # their loads at uⁿ
        self._last_increment = self._solve(self._L)
        increment = mpi.global_max(self.comm, float(np.max(np.abs(self._last_increment))))
        if self.control is not None:  # the linearisation error, before the projection
            self.linear_defect = max(self.defects().values())
        unprojected = self.evaluate_energy() if self.settings.projection_steps else math.nan
        self._last_increment += self._project()
        energy = self.evaluate_energy()  # after the projection
        projection = (
            {} if math.isnan(unprojected) else {"energy_change_by_projection": energy - unprojected}
        )
        rate = (self._last_energy - energy) / self.tau
        self._last_energy = energy
        self.step_count += 1
        self.time += self.tau
        defect = max(self.defects().values())
        seconds = time.perf_counter() - t0
        info = RodStep(
            self.step_count, self.time, self.tau, energy, defect, increment, rate, seconds
        )
        info.projection = projection
        return info

    def _project(self) -> Array:
        """``flow.projection_steps`` Newton corrections towards the constraints; their sum."""
        change: Array = np.zeros(self._udofs.size + self._bdofs.size)
        for _ in range(self.settings.projection_steps):
            change += self._solve(self._residual)
        return change

    def _solve(self, rhs: compat.Form) -> Array:
        """Assemble the step matrix at the current state, solve with ``rhs`` and add the solution.

        ``self._L`` gives the step, ``self._residual`` one projection: the least correction
        in the step's norm that solves the constraints linearised at the current state (a
        Newton step for them). Returns the change (δu, δb) of the degrees of freedom.
        """
        self.K.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(self.K, self._a, self._bcs)  # type: ignore[arg-type]
        self.K.assemble()
        compat.assemble_vector_into(self.rhs, rhs)
        dolfinx.fem.petsc.set_bc(self.rhs, self._bcs)  # homogeneous: no lifting needed
        self.solver.solve(self.rhs, self.solution.x.petsc_vec)
        self.solution.x.scatter_forward()
        x = self.solution.x.array
        du, db = x[self._udofs].copy(), x[self._bdofs].copy()
        self.u.x.array[:] += du
        self.b.x.array[:] += db
        return np.concatenate([du, db])

    def save(self) -> tuple[Array, Array, float, float, int]:
        """The state a redone step starts from: u, b, the last energy, the time, the count."""
        arrays = (self.u.x.array.copy(), self.b.x.array.copy())
        return (*arrays, self._last_energy, self.time, self.step_count)

    def restore(self, saved: tuple[Array, Array, float, float, int]) -> None:
        """Take back the state of :meth:`save`."""
        self.u.x.array[:], self.b.x.array[:] = saved[0], saved[1]
        self._last_energy, self.time, self.step_count = saved[2:]

    def _undo(self) -> None:
        """Take back the last step (it produced a non-finite state)."""
        n = self._udofs.size
        self.u.x.array[:] -= self._last_increment[:n]
        self.b.x.array[:] -= self._last_increment[n:]
        self._last_energy = self.evaluate_energy()

    def _stop(self, info: RodStep) -> tuple[bool, str, int] | None:
        """(converged, reason, signal) when the run should end after ``info``; None to go on.

        The test is :func:`dgplate.solvers.steps.stop_reason`; the measure, when it needs
        it, is stored in the record.
        """
        if measured(self.settings):
            info.stationarity = self.measure()
        reason = stop_reason(self.settings, info.rate, info.stationarity)
        if reason:
            return True, reason, 0
        signum = interrupt.requested(self.comm)  # collective
        return (False, interrupt.reason(signum), signum) if signum else None

    def run(self, max_steps: int | None = None) -> FlowResult:
        """Step until the stopping rule holds or the step budget is spent."""
        budget = max_steps or self.remaining_steps()
        history: list[Any] = []
        increases: list[int] = []
        outcome: tuple[bool, str, int] | None = None
        for _ in range(budget):
            try:
                info = self.control.step() if self.control else self.safeguard.step(self.step)
                if self._measures is not None:  # the model's per-step figures (collective)
                    info.figures = self._measures(self)
            except SolverError as exc:
                outcome = (False, f"step {self.step_count + 1} failed: {exc}", 0)
                break
            if not (math.isfinite(info.energy) and math.isfinite(info.defect)):
                self._undo()
                outcome = (False, f"diverged at step {info.step}: E = {info.energy}", 0)
                break
            outcome = self._stop(info)  # first: it fills the record's stationarity
            self.record_step(info, history, increases)
            if outcome is not None:
                break
        total = max_steps or self.settings.max_steps  # as set: resumed runs' steps count too
        test = stopping_value(self.settings, math.nan, math.nan)[1]
        spent = f"step budget of {total} steps spent before {test} < {self.settings.tol:g}"
        outcome = outcome or (False, spent, 0)
        defect = max(self.defects().values())
        result = FlowResult.of(outcome, history, increases, self.evaluate_energy(), defect)
        for obs in self.observers:
            obs.finish(self, result)
        return result

    def destroy(self) -> None:
        """Free the solvers and the matrices."""
        self.solver.destroy()
        self.K.destroy()
        self.measure.destroy()
