# mypy: disallow-untyped-calls=False
# (UFL is unannotated: calling it is not an error of ours, as in the numerical core)
"""Heat equation on the flat reference domain: θ_t − κΔθ = s(x, t) (docs/design.md §1).

Implicit Euler in time, continuous Lagrange (P1 or P2, Q1 or Q2 on quadrilaterals) in space,
homogeneous Neumann conditions (∂θ/∂n = 0: the plate exchanges no heat through its edges).
One step from θⁿ to θⁿ⁺¹ = θ(tⁿ + Δt) solves

    ∫ θⁿ⁺¹ v + Δt κ ∫ ∇θⁿ⁺¹·∇v = ∫ θⁿ v + Δt ∫ s(·, tⁿ⁺¹) v      for all v.

The matrix M + Δt κ K does not change: it is assembled and factorised once, each step only
assembles the right-hand side. The source is either a :class:`HeatSource` (a piecewise
constant time schedule, optionally restricted to cell groups: "s = 5 until t = 28.2, then −5")
or any callable ``(x, t) -> UFL expression`` with ``t`` a DOLFINx Constant (manufactured
solutions). Everything is collective; reductions (min/max/mean) return the same numbers on
every rank, and results do not depend on the number of ranks.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from petsc4py import PETSc

from dgplate import values
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh
from dgplate.solvers import linear


@dataclass(frozen=True)
class HeatSource:
    """A source s(x, t) that is piecewise constant in time, optionally only in some regions.

    ``schedule`` lists ``(t_i, s_i)`` pairs with strictly increasing times: s = s_i for
    t_i ≤ t < t_{i+1} (the last value holds for ever, s = 0 before t_0). ``regions`` names the
    cell groups that are heated (None: the whole plate). The value at a time step is taken at
    the mean over the step (:meth:`average`), exact for this piecewise constant schedule.
    """

    schedule: tuple[tuple[float, float], ...]
    regions: Sequence[str] | None = None  # stored as a tuple

    def __post_init__(self) -> None:
        pairs = tuple((float(t), float(s)) for t, s in self.schedule)
        if not pairs:
            raise InputError("heat source schedule is empty: give at least one (time, value)")
        for i in range(1, len(pairs)):
            if not pairs[i][0] > pairs[i - 1][0]:
                raise InputError(
                    f"heat source schedule times must increase strictly: t = {pairs[i][0]:g} "
                    f"(entry {i}) follows t = {pairs[i - 1][0]:g} (entry {i - 1})"
                )
        object.__setattr__(self, "schedule", pairs)
        if self.regions is not None:
            regions = (self.regions,) if isinstance(self.regions, str) else tuple(self.regions)
            object.__setattr__(self, "regions", regions)

    @classmethod
    def switched(
        cls,
        before: float,
        after: float,
        switch_time: float,
        regions: Sequence[str] | None = None,
    ) -> HeatSource:
        """S = ``before`` for 0 ≤ t < switch_time, then ``after`` (the box's heating/cooling)."""
        return cls(((0.0, before), (switch_time, after)), regions)

    def value(self, t: float) -> float:
        """S at time t (inside the heated regions)."""
        current = 0.0
        for start, s in self.schedule:
            if t >= start:
                current = s
        return current

    def average(self, t0: float, t1: float) -> float:
        """(1/(t1 − t0)) ∫_{t0}^{t1} s dt: the exact mean of the schedule over a time step.

        The heat solver uses this mean, so a switch inside (or at the end of) a step takes
        effect with its exact weight and round-off in the times cannot move it by a step.
        """
        if not t1 > t0:
            return self.value(t1)
        starts = [t for t, _ in self.schedule] + [math.inf]
        total = 0.0
        for i, (start, s) in enumerate(self.schedule):
            lo, hi = max(start, t0), min(starts[i + 1], t1)
            if hi > lo:
                total += s * (hi - lo)
        return total / (t1 - t0)

    @property
    def switch_times(self) -> tuple[float, ...]:
        """The times at which the source changes value (after the first)."""
        return tuple(t for t, _ in self.schedule[1:])


class HeatSolver:
    """θ_t − κΔθ = s with implicit Euler on a (tagged) plate mesh.

    ``kappa`` > 0 (diffusivity), ``dt`` > 0 (time step), ``degree`` of the continuous Lagrange
    space (1 or 2), ``theta0`` the initial temperature at time ``t0`` (a number or a callable
    for ``Function.interpolate``). ``source`` is a :class:`HeatSource`, a callable ``(x, t)``
    returning a UFL expression (``t`` is the Constant ``self.t_next``), or None (no source).
    ``solver_options`` override the PETSc options (default: MUMPS LU, factorised once).
    """

    def __init__(
        self,
        tagged: TaggedMesh,
        kappa: float,
        dt: float,
        source: HeatSource | Callable[..., Any] | None = None,
        degree: int = 1,
        theta0: float | Callable[..., Any] = 0.0,
        solver_options: Mapping[str, str | int | float] | None = None,
        t0: float = 0.0,
    ) -> None:
        self.tagged, self.kappa, self.degree = tagged, kappa, degree
        mesh = tagged.mesh
        self.mesh, self.comm = mesh, mesh.comm
        self.V = dolfinx.fem.functionspace(mesh, ("Lagrange", degree))
        self.theta: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(
            self.V, name="temperature"
        )
        self._previous: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(self.V)
        if callable(theta0):
            self.theta.interpolate(theta0)
        else:
            self.theta.x.array[:] = float(theta0)
        self.t0 = float(t0)
        self.last_source = 0.0  # the scheduled source's mean over the last step
        self.time, self.steps = self.t0, 0
        self._dt = values.constant(mesh, dt)
        self.t_next = values.constant(mesh, self.t0 + dt)
        self.source = source
        self._source_value = values.constant(mesh, 0.0)
        x = ufl.SpatialCoordinate(mesh)
        if isinstance(source, HeatSource):
            s = self._source_value * self._indicator(source.regions)
        elif callable(source):
            s = source(x, self.t_next)
        else:
            s = None
        u, v = ufl.TrialFunction(self.V), ufl.TestFunction(self.V)
        kappa_c = values.constant(mesh, kappa)
        a = (u * v + self._dt * kappa_c * ufl.inner(ufl.grad(u), ufl.grad(v))) * ufl.dx
        L = self._previous * v * ufl.dx
        if s is not None:
            L += self._dt * s * v * ufl.dx
        self._a, self._L = dolfinx.fem.form(a), dolfinx.fem.form(L)
        self.A = dolfinx.fem.petsc.assemble_matrix(self._a)
        self.A.assemble()
        self._b_fn = dolfinx.fem.Function(self.V)  # a ghosted vector in every version
        self.b = self._b_fn.x.petsc_vec
        self._solver_options = solver_options
        self.ksp: PETSc.KSP | None = (
            None  # made at the first step (a constant temperature needs no solver)
        )
        self._area = self._integral(values.constant(mesh, 1.0))
        self._mean_form = dolfinx.fem.form(self.theta * ufl.dx)

    # -- set-up helpers ---------------------------------------------------------------------
    def _indicator(self, regions: Sequence[str] | None) -> Any:
        """1 on the heated cell groups, 0 elsewhere (a DG0 field), or 1 for the whole plate."""
        if regions is None:
            return values.constant(self.mesh, 1.0)
        # an unknown group raises an InputError naming it
        heated = dict.fromkeys(regions, 1.0)
        return self.tagged.group_function(heated, default=0.0, key="heated")

    def _integral(self, expr: Any) -> float:
        local = dolfinx.fem.assemble_scalar(dolfinx.fem.form(expr * ufl.dx))
        return float(self.comm.allreduce(local, op=MPI.SUM))

    # -- time stepping ----------------------------------------------------------------------
    @property
    def dt(self) -> float:
        """The time step Δt."""
        return float(self._dt.value)

    def step(self) -> float:
        """Advance θ by one time step; returns the new time. Collective.

        A scheduled source enters with its mean over the step, a callable source at the end
        of the step (t = tⁿ⁺¹, implicit Euler). Times are t0 + n Δt (no accumulated sums).
        """
        t_old = self.time
        t_new = self.t0 + (self.steps + 1) * self.dt
        self.t_next.value = np.asarray(t_new)
        if isinstance(self.source, HeatSource):
            self.last_source = self.source.average(t_old, t_new)
            self._source_value.value = np.asarray(self.last_source)
        self._previous.x.array[:] = self.theta.x.array
        with self.b.localForm() as local:
            local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(self.b, self._L)
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self.ksp is None:
            self.ksp = linear.make_ksp(self.comm, self.A, self._solver_options, "heat_")
        linear.solve(self.ksp, self.b, self.theta.x.petsc_vec)
        self.theta.x.scatter_forward()
        self.time, self.steps = t_new, self.steps + 1
        return t_new

    def checkpoint_state(self) -> dict[str, Any]:
        """The counters that continue the heat equation from θ (a checkpoint's part)."""
        return {"steps": self.steps, "time": self.time, "last_source": self.last_source}

    def restore_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state` (θ itself is restored as a field)."""
        self.steps, self.time = int(state["steps"]), float(state["time"])
        self.last_source = float(state["last_source"])

    def advance_to(self, t_end: float) -> int:
        """Step until ``time`` reaches ``t_end`` (to within 1e-9 Δt); returns the step count."""
        count = 0
        while self.time < t_end - 1e-9 * self.dt:
            self.step()
            count += 1
        return count

    # -- figures ----------------------------------------------------------------------------
    def min_max(self) -> tuple[float, float]:
        """Smallest and largest nodal value of θ (owned dofs, reduced over all ranks)."""
        owned = self.V.dofmap.index_map.size_local
        nodal = self.theta.x.array[:owned].real
        lo = nodal.min() if nodal.size else np.inf
        hi = nodal.max() if nodal.size else -np.inf
        return float(self.comm.allreduce(lo, op=MPI.MIN)), float(
            self.comm.allreduce(hi, op=MPI.MAX)
        )

    def mean(self, region: str | None = None) -> float:
        """Area-weighted mean of θ over the plate or over one cell group."""
        if region is None:
            local = dolfinx.fem.assemble_scalar(self._mean_form)
            return float(self.comm.allreduce(local, op=MPI.SUM)) / self._area
        dx = ufl.Measure("dx", domain=self.mesh, subdomain_data=self.tagged.cell_tags)
        tag = self.tagged.tag(region, self.mesh.topology.dim)
        one = values.constant(self.mesh, 1.0)
        num = dolfinx.fem.assemble_scalar(dolfinx.fem.form(self.theta * dx(tag)))
        den = dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * dx(tag)))
        num, den = self.comm.allreduce(np.array([num, den], dtype=float), op=MPI.SUM)
        return float(num / den)

    def l2_error(self, exact: Callable[..., Any], quadrature_degree: int = 6) -> float:
        """‖θ − exact(x, t)‖_L² at the current time (``exact`` as for a callable source)."""
        t = values.constant(self.mesh, self.time)
        x = ufl.SpatialCoordinate(self.mesh)
        e = self.theta - exact(x, t)
        dx = ufl.Measure("dx", domain=self.mesh, metadata={"quadrature_degree": quadrature_degree})
        local = dolfinx.fem.assemble_scalar(dolfinx.fem.form(e * e * dx))
        return math.sqrt(self.comm.allreduce(local, op=MPI.SUM))

    def destroy(self) -> None:
        """Free the PETSc solver and matrix."""
        for obj in (self.ksp, self.A):
            if obj is not None:
                obj.destroy()


__all__ = ["HeatSolver", "HeatSource"]
