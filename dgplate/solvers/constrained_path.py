"""Arclength continuation of the isometry-constrained plates: Newton on their Lagrangian.

The equilibria of a constrained plate are the critical points of the Lagrangian on the flow's
mixed space W ∋ w = (y, μ[, p]) (:func:`dgplate.solvers.step_system.mixed_space`):

    L(w; λ) = E_h[y; λ] + s Σ_T ∫_T μ : (∇yᵀ∇y − G)  [+ s Σ_e edge moments(y) · p + ½ ∫ χ |p|²/h],

the last two with ``flow.edge_constraint`` (χ = 1 on the cells without a free facet, whose
edge multipliers are thus zero). DL(w; λ) = 0 holds the discrete constraint exactly, so a path
point is the flow's discrete minimiser at the same λ (with the same quadrature: the forms are
built in y ∈ V and moved into W by ``ufl.replace``), and no projection is needed. The Jacobian
D²L is the SQP matrix of :mod:`dgplate.solvers.sqp` without the flow's (1/τ) metric term: a
saddle-point (KKT) matrix, factorised by MUMPS LU as any Jacobian of the path.

- **Scaling.** The constraint rows are scaled by s = ‖D²_y L‖_∞ / ‖D_μ D_y L‖_∞ at the start
  (the Jacobian's y rows: their own columns against the multipliers'), so that they weigh
  like the others (only μ and p change with s). The pinned edge multipliers of interior cells
  get the weight c = ‖D²_y L‖_∞ (½ c χ|p|²/h² on a cell of diameter h): their eigenvalues,
  about c, lie far from 0, where the critical ones are looked for.
- **Stability index.** The KKT matrix has m = rank B negative eigenvalues whatever the state,
  and the inertia of its LDLᵀ factorisation is m plus that of the Hessian on the tangent space
  of the constraint (ZᵀHZ). The index reported is the negative count minus m, with m the
  global number of multiplier unknowns (the rows of B have full rank: 3 or 12 per cell
  against the 15 strain directions of a Q2 cell, and the edge moments are chosen independent,
  :class:`dgplate.solvers.constraint.EdgeConstraint`). A zero eigenvalue of the KKT matrix is one
  of ZᵀHZ (det KKT ∝ det ZᵀHZ · det BBᵀ), so folds and bifurcations are located on the KKT
  eigenvalues nearest 0 as on a plain Hessian (:mod:`dgplate.solvers.special_points`).
- **Arclength.** The inner product of the path counts y and λ only (the multipliers follow).

Energies that are not UFL integrals of y alone (self-avoidance, LDG lifted Hessians), active
sets (obstacles) and step shifts have no Lagrangian here: they are refused.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import ufl
from petsc4py import PETSc
from ufl.core.expr import Expr

from dgplate import compat, values
from dgplate.compat import Constant, Function, FunctionSpace, Indices
from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets
from dgplate.errors import InputError
from dgplate.solvers import transfer
from dgplate.solvers.arclength import Multipliers
from dgplate.solvers.constraint import (
    EdgeConstraint,
    metric_measure,
    metric_tensor_defect,
    refuse_edge_moments_with_metric,
    symmetric,
)
from dgplate.solvers.continuation import BranchPath, PathSettings
from dgplate.solvers.driver import Observer
from dgplate.solvers.flow import Initial, flat
from dgplate.solvers.newton import Probes
from dgplate.solvers.rigid_pins import hold_in_place, rigid_pins
from dgplate.solvers.step_system import StepSettings, max_row_sum, mixed_space


@dataclass
class ConstrainedProblem:
    """The Lagrangian of a constrained plate on its mixed space, for :class:`BranchPath`.

    Attributes:
        state: w = (y, μ[, p]) ∈ W, at the start deformation and zero multipliers.
        lagrangian: L(w), a form of rank 0.
        scale: the Constant s of the constraint rows (1 until :meth:`balance`).
        pin: the Constant c of the pinned edge multipliers (1 until :meth:`balance`).
        constraint_rows: m, the global number of multiplier unknowns.
        y: the deformation in V, :meth:`deformation` copies w's y into it.
        vdofs: y's local dofs in W.
    """

    state: Function
    lagrangian: ufl.Form
    scale: Constant
    pin: Constant
    constraint_rows: int
    y: Function
    vdofs: Indices

    def deformation(self) -> Function:
        """The deformation y of the current state (updated in place)."""
        self.y.x.array[:] = self.state.x.array[self.vdofs]
        self.y.x.scatter_forward()
        return self.y

    def weight(self) -> PETSc.Vec:
        """1 on y's unknowns, 0 on the multipliers': the arclength's inner product (destroy it)."""
        weight: PETSc.Vec = self.state.x.petsc_vec.duplicate()
        with weight.localForm() as local:
            local.set(0.0)
            local.array[self.vdofs] = 1.0
        return weight

    def balance(self, jacobian: PETSc.Mat) -> None:
        """S = ‖D²_y L‖_∞ / ‖D_μ D_y L‖_∞ of ``jacobian`` (assembled with s = 1, μ = 0).

        Args:
            jacobian: D²L at the start state, assembled with s = 1.
        """
        rows = _owned_global(self.state, self.vdofs)
        start, end = jacobian.getOwnershipRange()
        others = np.setdiff1d(np.arange(start, end, dtype=rows.dtype), rows)
        comm = jacobian.comm
        is_y = PETSc.IS().createGeneral(rows.tolist(), comm=comm)
        is_mu = PETSc.IS().createGeneral(others.tolist(), comm=comm)
        norms = []
        for columns in (is_y, is_mu):
            block = jacobian.createSubMatrix(is_y, columns)
            norms.append(max_row_sum(block))
            block.destroy()
        is_y.destroy()
        is_mu.destroy()
        if norms[1] > 0:
            self.scale.value = np.asarray(norms[0] / norms[1])
        self.pin.value = np.asarray(norms[0])


def _owned_global(state: Function, local_dofs: Indices) -> Indices:
    """The global indices of the owned ones of ``local_dofs`` (unrolled by the block size)."""
    imap, bs = state.function_space.dofmap.index_map, state.function_space.dofmap.index_map_bs
    owned = local_dofs[local_dofs < imap.size_local * bs]
    result: Indices = (owned + imap.local_range[0] * bs).astype(np.int32)
    return result


def refuse_nonlocal(energy: Energy) -> None:
    """An InputError for energies the Lagrangian cannot hold (the module's docstring)."""
    if energy.nonlocal_terms:
        raise InputError(
            "path.method = 'arclength': not with self-avoidance or model.hessian = 'ldg' "
            "(terms that are not integrals of y)"
        )
    if energy.active_sets or energy.step_shift is not None:
        raise InputError("path.method = 'arclength': not with an obstacle (an active set)")


def constrained_problem(
    facets: FacetSets,
    degree: int,
    energy_fn: Callable[[Function], Energy],
    settings: StepSettings,
    metric: Expr | None = None,
    initial: Initial | None = None,
) -> ConstrainedProblem:
    """The Lagrangian of ``energy_fn`` under the flow's constraints (the module's docstring).

    Args:
        facets: the mesh and its facet sets.
        degree: the degree k of y ∈ [DG_k]³.
        energy_fn: the energy of a deformation y (its parameters at their start values).
        settings: the [flow] keys of the constraint (multiplier degree, edge moments).
        metric: the target metric G (None: I).
        initial: the start deformation; None: the flat plate.

    Returns:
        The problem, its state at ``initial`` with zero multipliers, s = 1.
    """
    refuse_edge_moments_with_metric(metric, settings.edge_constraint)
    mesh = facets.mesh
    W = mixed_space(mesh, degree, settings)
    V, vdofs = compat.collapse(W.sub(0))
    y: Function = dolfinx.fem.Function(V, name="deformation")
    transfer.interpolate(y, initial or flat)
    energy = energy_fn(y)
    refuse_nonlocal(energy)
    state: Function = dolfinx.fem.Function(W, name="state")
    state.x.array[vdofs] = y.x.array
    state.x.scatter_forward()
    y_w, mu, *edge_mu = ufl.split(state)
    s = values.constant(mesh, 1.0)
    constraint = ufl.inner(metric_tensor_defect(y, metric), symmetric(mu)) * metric_measure(
        y, metric
    )
    pinned: ufl.Form | None = None
    c = values.constant(mesh, 1.0)
    rows = _global_size(W.sub(1))
    if settings.edge_constraint:
        edge, (p,) = EdgeConstraint(facets), edge_mu
        constraint += edge.residual(y, p)
        pinned = 0.5 * c * edge.interior * ufl.inner(p, p) / facets.h**2 * ufl.dx
        rows += EdgeConstraint.SIZE * _cells_with_free_facet(edge)
    lagrangian = ufl.replace(energy.total + s * constraint, {y: y_w})
    if pinned is not None:
        lagrangian += pinned
    return ConstrainedProblem(state, lagrangian, s, c, rows, y, vdofs)


def _global_size(space: FunctionSpace) -> int:
    """The global number of unknowns of a subspace."""
    collapsed, _ = compat.collapse(space)
    dofmap = collapsed.dofmap
    return int(dofmap.index_map.size_global * dofmap.index_map_bs)


def _cells_with_free_facet(edge: EdgeConstraint) -> int:
    """The global number of cells whose edge multipliers are not pinned."""
    space = edge.interior.function_space
    owned = space.dofmap.index_map.size_local
    free = int(np.count_nonzero(edge.interior.x.array[:owned] == 0.0))
    return int(space.mesh.comm.allreduce(free, op=MPI.SUM))


def constrained_branch_path(
    problem: ConstrainedProblem,
    load_factor: Constant,
    settings: PathSettings,
    prefix: str,
    *,
    options: Mapping[str, Any] | None = None,
    probes: Probes | None = None,
    observers: Sequence[Observer] = (),
    free: bool = False,
    prelude: Callable[[], int] | None = None,
) -> BranchPath:
    """The arclength continuation of ``problem`` in ``load_factor`` (collective).

    Args:
        problem: the Lagrangian and its state (:func:`constrained_problem`).
        load_factor: the Constant λ the energy depends on; its value is λ₀.
        settings: the path's settings.
        prefix: the PETSc options prefix.
        options: PETSc options of the Newton solver at the start (and of its linear solver).
        probes: numbers of the state added to every record.
        observers: told of every point and of the end of the run.
        free: whether the plate is free (nothing clamped): its rigid motions are then held by
            six pins (:func:`dgplate.solvers.rigid_pins.rigid_pins`).
        prelude: sets the start state before the first point of a path that has none yet
            (a flow to a minimiser); returns the signal that stopped it (0: none).

    Returns:
        The driver, its constraint rows balanced at the start state.
    """
    pins = rigid_pins(problem.state) if free else []

    def start(fresh: bool) -> int:
        """The prelude on a path without points; the pins where the start state has them."""
        signum = prelude() if prelude is not None and fresh else 0
        hold_in_place(pins, problem.state)
        return signum

    path = BranchPath(
        problem.state,
        problem.lagrangian,
        pins,
        load_factor,
        settings,
        prefix,
        options,
        shape=problem.deformation,
        probes=probes,
        observers=observers,
        multipliers=Multipliers(problem.constraint_rows, problem.weight()),
        prelude=start,
    )
    problem.balance(path.newton.jacobian())
    return path
