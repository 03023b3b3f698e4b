"""Self-avoidance of a plate: ρ·TP[y] as an explicit, nonlocal term of its energy.

The tangent-point potential TP (:mod:`dgplate.dg.tangent_point`) is a double sum over the
cell quadrature points of the deformed plate y, with the unit normal ν = ∂₁y × ∂₂y / |∂₁y × ∂₂y|.
It is not a UFL integral, so it enters the flow as a :class:`~dgplate.dg.energy.Nonlocal`
term: at yⁿ the pair sums give the partial derivatives G_i = ∂TP/∂y(x_i) and H_i = ∂TP/∂ν(x_i)
(divided by the quadrature weights w_i, so that they are densities), stored in quadrature
functions; the UFL functional

    L(y) = ∫ G·y + H·ν(y) dx     (with the same quadrature)

then has the derivative DL[y](v) = Σ_i ∂TP/∂y_i·v(x_i) + ∂TP/∂ν_i·Dν[y](v)(x_i) = DTP[y](v)
by the chain rule: the normal's dependence on y is not lagged, only the whole derivative is
taken at yⁿ (fully explicit, as in Bartels–Meyer–Palus). The step matrix does not change.

MPI: each rank evaluates its own cells' points against the points of all ranks, gathered and
sorted by their reference coordinates, so that the sums and the tree do not depend on the
partition; the source-side derivatives are summed over the ranks.

A rod (:class:`CurveTangentPoint`) is the same with the unit tangent t = u′/|u′| in place of
ν, |P_t^⊥ d| = |d − (t·d)t| in the pair sums and the arc-length weights of its 1D mesh.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mpi4py import MPI

import basix
import basix.ufl
import dolfinx.fem
import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import compat, mpi
from dgplate.compat import Array, Function
from dgplate.dg import tangent_point as tp
from dgplate.errors import InputError
from dgplate.schema import option


@dataclass(frozen=True)
class SelfAvoidance:
    """A validated ``model.self_avoidance`` table of a surface: ρ·TP with exponent q.

    ``theta``: the cluster tree's admissibility (0: exact all-pairs sums); ``max_redo``: how
    often a step may be redone with τ/2; ``approach``: a step is redone when the least distance
    of non-neighbouring points falls below this fraction of its value before the step. q ≤ 4
    is accepted for surfaces: a warning before the run says that such a q is not
    self-avoiding (:func:`dgplate.problems.advice.before_run`).
    """

    rho: float = option(1e-4, "the weight ρ of TP[y]", ge=0)
    q: float = option(4.5, "the exponent (> 4 to avoid self-contact)", gt=2)
    theta: float = option(
        0.5, "the cluster tree's admissibility (0: exact all-pairs sums)", ge=0, lt=2
    )
    quadrature_degree: int = option(2, "the quadrature degree of the sums", ge=1)
    max_redo: int = option(8, "how often a step may be redone with τ/2", ge=0)
    approach: float = option(
        0.5,
        "redo a step when the least distance of non-neighbouring points falls below this fraction of its value before the step",
        gt=0,
        lt=1,
    )


@dataclass(frozen=True)
class CurveSelfAvoidance(SelfAvoidance):
    """The table of a rod's self-avoidance.

    [BL]'s ρ = 0.1 of the twisted-circle experiment, an exponent q = 3 > 2 (self-avoiding for
    curves) and exact sums (a rod has few points).
    """

    rho: float = option(0.1, "the weight ρ of TP[u]", ge=0)
    q: float = option(3.0, "the exponent (> 2: self-avoiding for curves)", gt=2)
    theta: float = option(
        0.0, "the cluster tree's admissibility (0: exact all-pairs sums)", ge=0, lt=2
    )


def unit_normal(y: Expr) -> Expr:
    """ν = ∂₁y × ∂₂y / |∂₁y × ∂₂y| of a deformation y of a flat reference domain."""
    n = ufl.cross(y.dx(0), y.dx(1))
    normal: Expr = n / ufl.sqrt(ufl.inner(n, n))
    return normal


class PlateTangentPoint:
    """ρ·TP[y] of a plate deformation y: the :class:`~dgplate.dg.energy.Nonlocal` protocol."""

    curve = False  # the directions are normals (plates) or tangents (rods)

    def _direction(self, y: Expr) -> Expr:
        """The unit direction whose projector measures the tangent-point radius: ν(y)."""
        return unit_normal(y)

    def _measure(self, mesh: Any) -> Expr:
        """The factor of the reference quadrature weights: the cell's area element."""
        area: Expr = abs(ufl.JacobianDeterminant(mesh))  # type: ignore[arg-type]
        return area

    def __init__(self, y: Function, params: SelfAvoidance, key: str = "model.self_avoidance"):
        self.y, self.params = y, params
        self.max_redo = params.max_redo
        mesh = y.function_space.mesh
        self.comm: MPI.Comm = mesh.comm
        degree = params.quadrature_degree
        cell = mesh.basix_cell()
        element = basix.ufl.quadrature_element(cell, value_shape=(3,), degree=degree)
        scalar = basix.ufl.quadrature_element(cell, value_shape=(), degree=degree)
        self._Q = dolfinx.fem.functionspace(mesh, element)
        self._G: Function = dolfinx.fem.Function(self._Q)
        self._H: Function = dolfinx.fem.Function(self._Q)
        self._scratch: Function = dolfinx.fem.Function(self._Q)
        points = compat.interpolation_points(self._Q.element)
        _, rule = basix.make_quadrature(basix.CellType[str(cell).split(".")[-1]], degree)
        weights: Array = np.asarray(rule, dtype=np.float64)
        self._cells = mesh.topology.index_map(mesh.topology.dim).size_local
        self._dofs = self._Q.dofmap.list[: self._cells]
        self._y_at = self._compile(y, points)
        self._nu_at = self._compile(self._direction(y), points)
        area = self._measure(mesh)
        sq = dolfinx.fem.functionspace(mesh, scalar)
        w = self._sample(area, sq, points, 1)[:, :, 0] * weights[None, :]
        self._w = w.reshape(-1)
        ref = self._sample(ufl.SpatialCoordinate(mesh), sq, points, mesh.geometry.dim, vector=True)
        ref = ref.reshape(-1, ref.shape[-1])
        self._layout(np.c_[ref, np.zeros((len(ref), 2))][:, :2], mesh)  # a 1D mesh: (s, 0)
        dx = ufl.dx(metadata={"quadrature_degree": degree})
        #: L(y) = ∫ G·y + H·ν(y): its derivative at the current y is ρ·DTP[y]
        self.linearisation: ufl.Form = (
            ufl.inner(self._G, y) + ufl.inner(self._H, self._direction(y))
        ) * dx
        self._state: Array | None = None
        self._value = 0.0
        self.min_distance = math.inf
        self._accepted = math.inf
        self.last: tp.TPResult | None = None
        self._check_start(key)

    # -- sampling ---------------------------------------------------------------------------
    def _compile(self, expr: Expr, points: Array) -> compat.Expression:
        compiled: compat.Expression = dolfinx.fem.Expression(expr, points)
        return compiled

    def _sample(
        self, expr: Expr, space: Any, points: Array, size: int, vector: bool = False
    ) -> Array:
        """Values (owned cells, points, size) of ``expr`` at the quadrature points."""
        if vector:
            element = basix.ufl.quadrature_element(
                self.y.function_space.mesh.basix_cell(),
                value_shape=(size,),
                degree=self.params.quadrature_degree,
            )
            space = dolfinx.fem.functionspace(self.y.function_space.mesh, element)
        f: Function = dolfinx.fem.Function(space)
        f.interpolate(self._compile(expr, points))
        dofs = space.dofmap.list[: self._cells]
        values = f.x.array.reshape(-1, size)
        return np.asarray(values[dofs])

    def _at_points(self, compiled: compat.Expression) -> Array:
        """A compiled vector expression at the owned quadrature points, shape (M_own, 3)."""
        f = self._scratch
        f.interpolate(compiled)
        return np.asarray(f.x.array.reshape(-1, 3)[self._dofs].reshape(-1, 3).copy())

    def _layout(self, ref: Array, mesh: Any) -> None:
        """The global order of the points (by reference coordinates) and vertex ids."""
        geometry = compat.geometry_dofmap(mesh)[: self._cells]
        corners = mesh.geometry.x[geometry][:, :, :2]  # the reference cells' nodes
        spread = np.ptp(corners, axis=1) if self._cells else np.zeros((1, 2))
        self._h = mpi.global_max(self.comm, float(np.linalg.norm(spread, axis=1).max()))
        per_point = len(ref) // max(self._cells, 1) if self._cells else 0
        nodes = np.repeat(corners, per_point, axis=0) if self._cells else np.zeros((0, 3, 2))
        gathered = self.comm.allgather((ref, nodes.reshape(len(ref), -1)))
        all_ref = np.concatenate([g[0] for g in gathered])
        all_nodes = np.concatenate([g[1] for g in gathered])
        scale = max(float(np.ptp(all_ref)), 1e-300)
        key = np.round(all_ref / scale, 9)
        self._order = np.lexsort((key[:, 1], key[:, 0]))
        offset = sum(len(g[0]) for g in gathered[: self.comm.rank])
        rank_of = np.empty(len(all_ref), dtype=np.int64)
        rank_of[self._order] = np.arange(len(all_ref))
        self._mine = rank_of[offset : offset + len(ref)]  # own points in the sorted order
        node_keys = np.round(all_nodes.reshape(-1, 2) / scale, 9)
        _, ids = np.unique(node_keys, axis=0, return_inverse=True)
        self._vertices = ids.reshape(len(all_ref), -1)[self._order].astype(np.int64)
        self._targets = np.zeros(len(all_ref), dtype=bool)
        self._targets[self._mine] = True

    # -- evaluation -------------------------------------------------------------------------
    def cloud(self) -> tuple[tp.Cloud, float]:
        """The gathered points of the current y (sorted) and the neighbour reach."""
        x = self._at_points(self._y_at)
        nu = self._at_points(self._nu_at)
        gathered = self.comm.allgather((x, nu, self._w))
        pts = np.concatenate([g[0] for g in gathered])[self._order]
        normals = np.concatenate([g[1] for g in gathered])[self._order]
        w = np.concatenate([g[2] for g in gathered])[self._order]
        cloud = tp.Cloud(pts, normals, w, self._vertices, self.curve)
        return cloud, self._reach(cloud)

    def _reach(self, cloud: tp.Cloud) -> float:
        """An upper bound of the distance of points of neighbouring cells.

        Two cells that share a vertex hold points at most two cell diameters apart; the
        deformation is nearly isometric, and the margin 1.5 covers its defect.
        """
        return 3.0 * self._h

    def update(self) -> float:
        """ρ·TP at the current y; refreshes G, H of :attr:`linearisation` (collective, cached)."""
        state = self.y.x.array
        same = self._state is not None and np.array_equal(state, self._state)
        if mpi.global_all(self.comm, same):
            return self._value
        cloud, reach = self.cloud()
        p = self.params
        result = tp.evaluate(cloud, p.q, p.theta, reach, self._targets)
        energy = mpi.global_sum(self.comm, result.energy)
        d_points = mpi.sum_arrays(self.comm, result.d_points)
        d_normals = mpi.sum_arrays(self.comm, result.d_normals)
        mine = self._mine
        w = cloud.weights[mine][:, None]
        for target, values in ((self._G, d_points), (self._H, d_normals)):
            target.x.array.reshape(-1, 3)[self._dofs.reshape(-1)] = p.rho * values[mine] / w
            target.x.scatter_forward()
        exact = p.theta == 0  # then the sums met every pair: their least distance is the one
        local = result.min_distance if exact else tp.min_distance(cloud, reach / 3.0, self._targets)
        self.min_distance = mpi.global_min(self.comm, local)
        self._state, self._value, self.last = state.copy(), p.rho * energy, result
        return self._value

    def accept(self) -> bool:
        """Whether the state may follow the last accepted one (the safety net).

        Refused when the least distance of non-neighbouring points fell below
        ``approach`` times its value at the last accepted state.
        """
        self.update()
        ok = self.min_distance > self.params.approach * min(self._accepted, 1e300)
        if ok:
            self._accepted = self.min_distance
        return bool(ok)

    def _check_start(self, key: str) -> None:
        """An initial state in which two non-neighbouring cells meet or cross is refused."""
        self.update()
        cloud, _ = self.cloud()
        size = float(np.linalg.norm(np.ptp(cloud.points, axis=0)))
        if not self.min_distance > 1e-6 * size:
            raise InputError(
                f"{key}: the initial state intersects itself (non-neighbouring cells "
                f"{self.min_distance:.3g} apart)"
            )
        if not self.curve:  # segments that meet are caught by the least distance above
            self._check_crossings(key)
        self._accepted = self.min_distance

    def _check_crossings(self, key: str) -> None:
        """A start whose sheets cross between the quadrature points is refused.

        The deformed cells are replaced by the triangles of their corners (y at the vertices:
        two triangles per quadrilateral), gathered in the reference order, and every pair of
        triangles of non-neighbouring cells is tested for a transversal crossing.
        """
        mesh = self.y.function_space.mesh
        element = basix.ufl.element(
            "Lagrange", mesh.basix_cell(), 1, shape=(3,), discontinuous=True
        )
        space = dolfinx.fem.functionspace(mesh, element)
        corners: Function = dolfinx.fem.Function(space)
        corners.interpolate(self.y)
        at = corners.x.array.reshape(-1, 3)[space.dofmap.list[: self._cells]]
        ref = mesh.geometry.x[compat.geometry_dofmap(mesh)[: self._cells]][:, :, :2]
        split = [[0, 1, 3], [0, 3, 2]] if at.shape[1] == 4 else [[0, 1, 2]]
        gathered = self.comm.allgather((at, ref))
        at = np.concatenate([g[0] for g in gathered])
        ref = np.concatenate([g[1] for g in gathered])
        order = np.lexsort((ref.mean(axis=1)[:, 1], ref.mean(axis=1)[:, 0]))
        at, ref = at[order], ref[order]
        scale = max(float(np.ptp(ref)), 1e-300)
        _, ids = np.unique(np.round(ref.reshape(-1, 2) / scale, 9), axis=0, return_inverse=True)
        ids = ids.reshape(len(ref), -1).astype(np.int64)
        triangles = at[:, split].reshape(-1, 3, 3)
        pairs = tp.crossings(triangles, np.repeat(ids, len(split), axis=0))
        if len(pairs):
            a, b = (tuple(c.round(3).tolist()) for c in ref[pairs[0] // len(split)].mean(axis=1))
            raise InputError(
                f"{key}: the initial state intersects itself ({len(pairs)} pairs of triangles "
                f"of non-neighbouring cells cross, e.g. of the cells at (x, y) = {a} and {b})"
            )

    def summary(self) -> dict[str, float]:
        """Figures for ``summary.json``."""
        return {"self_avoidance_energy": self.update(), "min_distance": self.min_distance}


class CurveTangentPoint(PlateTangentPoint):
    """ρ·TP[u] of a rod's centreline u on its 1D mesh (an interval, or a closed polygon).

    The direction is the unit tangent t = u′/|u′| (``derivative`` is d/ds of the rod's mesh),
    the weights are the reference weights times the cell's length element |J|; two points are
    neighbours when their segments share a node, which closes up around a closed rod.
    """

    curve = True

    def __init__(
        self,
        u: Function,
        params: SelfAvoidance,
        derivative: Callable[[Expr], Expr],
        key: str = "model.self_avoidance",
    ):
        self._derivative = derivative
        super().__init__(u, params, key)

    def _direction(self, y: Expr) -> Expr:
        """The unit tangent t = u′/|u′|."""
        du = self._derivative(y)
        unit: Expr = du / ufl.sqrt(ufl.inner(du, du))
        return unit

    def _measure(self, mesh: Any) -> Expr:
        """|J| of the 1D cell in ℝ¹ or ℝ² (the length of its reference interval's image)."""
        J = ufl.Jacobian(mesh)
        length: Expr = ufl.sqrt(ufl.inner(J, J))
        return length
