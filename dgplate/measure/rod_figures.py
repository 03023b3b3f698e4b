"""Figures of a rod's shape: its nodes in order, the writhe and link, the error to an exact arc.

Pure NumPy on the nodal values of the centreline u (gathered on every rank), and the twist
angle ∫b′·d of a flow's state; every function is collective on the rod's mesh.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from dgplate import compat, mpi
from dgplate.compat import Array, Function
from dgplate.dg.forms import integral
from dgplate.solvers.rod_flow import RodFlow, tangent


def nodes_in_order(u: Function) -> Array:
    """The nodal values of u (degrees of freedom) in the order of the parameter, on every rank.

    The order is s on an interval and the polygon's angle for a closed rod; each rank sends its
    owned nodes (collective).
    """
    space = u.function_space
    owned = space.dofmap.index_map.size_local
    x = space.tabulate_dof_coordinates()[:owned]
    key = np.arctan2(x[:, 1], x[:, 0]) if space.mesh.geometry.dim > 1 else x[:, 0]
    parts = space.mesh.comm.allgather((key, u.x.array.reshape(-1, 3)[:owned]))
    keys = np.concatenate([part[0] for part in parts])
    points: Array = np.concatenate([part[1] for part in parts])[np.argsort(keys, kind="stable")]
    return points


def writhe(points: Array, part: tuple[int, int] = (0, 1)) -> float:
    """The writhe of the closed polygon through ``points`` (n, 3): Gauss's double integral.

    Wr = (1/4π) ΣΣ_{i≠j} (eᵢ × eⱼ)·(mᵢ − mⱼ)/|mᵢ − mⱼ|³ over the edges eᵢ with midpoints mᵢ,
    the midpoint rule of (1/4π)∬ (u′(s) × u′(σ))·(u(s) − u(σ))/|u(s) − u(σ)|³. A planar curve
    has Wr = 0 exactly (the triple product of three vectors in a plane vanishes).

    The numerators are two matrix products, (eᵢ × eⱼ)·mᵢ = (mᵢ × eᵢ)·eⱼ and
    (eᵢ × eⱼ)·mⱼ = eᵢ·(eⱼ × mⱼ), and the squared distances |mᵢ|² + |mⱼ|² − 2mᵢ·mⱼ a third (the
    midpoints centred first), so that no (n, n, 3) array is formed (it is computed after every
    step of a closed rod). ``part`` = (k, m): only the k-th of m blocks of the rows i, a rank's
    share (the writhe is the sum of the m parts).
    """
    edges = np.roll(points, -1, axis=0) - points
    mids = points + 0.5 * edges
    mids = mids - mids.mean(axis=0)
    rows = np.array_split(np.arange(len(points)), part[1])[part[0]]
    e, m = edges[rows], mids[rows]
    numerator = np.cross(m, e) @ edges.T - e @ np.cross(edges, mids).T
    norms = np.sum(mids**2, axis=1)
    square = norms[rows][:, None] + norms[None, :] - 2.0 * (m @ mids.T)
    square[np.arange(rows.size), rows] = np.inf
    return float(np.sum(numerator / (square * np.sqrt(square))) / (4.0 * math.pi))


def shape_figures(u: Function, closed: bool, center: Sequence[float] | None) -> dict[str, float]:
    """Writhe (closed rods) and, in a sphere, max |u − c| at the nodes (collective).

    Args:
        u: The centreline.
        closed: Whether the rod is closed (its writhe is reported).
        center: The centre c of the confining sphere (None: no sphere).

    Returns:
        ``writhe`` and ``max_distance_to_center``, each when it applies.
    """
    out: dict[str, float] = {}
    if not closed and center is None:
        return out
    points = nodes_in_order(u)
    if closed:
        out["writhe"] = writhe(points)
    if center is not None:
        reach = np.linalg.norm(points - np.asarray(center), axis=1)
        out["max_distance_to_center"] = float(np.max(reach))
    return out


def arc_error(u: Function, exact: Callable[[Array], Array], length: float) -> dict[str, float]:
    """The largest over the nodes of |u − exact arc| / L (collective).

    Args:
        u: The centreline on an interval (0, L).
        exact: The exact centreline at parameters s (n,), as points (3, n).
        length: L.

    Returns:
        ``arc_error``.
    """
    space = u.function_space
    owned = space.dofmap.index_map.size_local
    s = space.tabulate_dof_coordinates()[:owned, 0]
    exact_values = exact(s).T
    local = float(
        np.max(np.linalg.norm(u.x.array.reshape(-1, 3)[:owned] - exact_values, axis=1), initial=0.0)
    )
    return {"arc_error": mpi.global_max(space.mesh.comm, local) / length}


class StepFigures:
    """A closed rod's twist angle ∫b′·d and writhe after every step (history.csv).

    Their sum Tw + Wr (Tw = twist angle/2π) is the link, which is conserved while the rod does
    not pass through itself (Călugăreanu); a crossing changes Wr by ±2.
    """

    def __init__(self) -> None:
        self._twist: compat.Form | None = None

    def __call__(self, flow: RodFlow) -> dict[str, float]:
        """The figures of the flow's current state (collective)."""
        u, b = flow.u, flow.b
        if self._twist is None:
            twist = ufl.dot(tangent(b), ufl.cross(tangent(u), b))  # type: ignore[no-untyped-call]
            self._twist = dolfinx.fem.form(twist * ufl.dx(domain=u.function_space.mesh))
        twist = integral(self._twist, flow.comm)
        wr = mpi.global_sum(flow.comm, writhe(nodes_in_order(u), (flow.comm.rank, flow.comm.size)))
        return {"twist_angle": twist, "writhe": wr, "link": link(twist, wr)}


def link(twist_angle: float, wr: float) -> float:
    """Lk = Tw + Wr in turns (Călugăreanu): Tw = ∫b′·d / 2π, the writhe ``wr`` in turns."""
    return twist_angle / (2.0 * math.pi) + wr
