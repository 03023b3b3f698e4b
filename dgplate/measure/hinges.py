"""Fold angles of hinges and rigid frames of plate regions (self-folding structures).

A hinge is a strip (cell group) between two faces (cell groups). Its fold angle is the angle
between the faces' area-weighted mean unit normals ν̄ = ∫_F ν / |∫_F ν|, signed by the
deformed hinge axis: for the inner face A, the outer face B and the reference direction d
from A's centroid to B's, the axis is a = ∫_hinge ∇y·t (t = e₃ × d, the reference hinge
direction, normalised) and

    φ = atan2(−(ν̄_A × ν̄_B)·a, ν̄_A·ν̄_B),

positive when B has turned towards the side +ν̄_A (``sense = −1`` flips that convention). For
a flat start y = (x₁, x₂, 0) that is the side +e₃. A face region's rigid frame (centre,
orthonormal frame from the polar factor of the mean gradient) maps the deformed plate back
into that region's reference position, which makes positions comparable whatever rigid
motion the plate has made. Everything here is collective and returns the same numbers on
every rank (integrals are summed over owned cells).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import compat, mpi
from dgplate.compat import Array, Form, Function, Mesh, entities_to_geometry, geometry_dofmap
from dgplate.dg.forms import cell_measure
from dgplate.dg.geometry import image_of_direction, unit_normal
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh, local_entities, make_tags


@dataclass(frozen=True)
class Hinge:
    """A hinge strip ``name`` joining the face ``inner`` (towards the base) to ``outer``."""

    name: str
    inner: str
    outer: str

    def across(self, inner: np.ndarray, outer: np.ndarray) -> np.ndarray:
        """The unit vector across the hinge, from the inner face's centroid to the outer's.

        Args:
            inner: the centroid of the inner face.
            outer: the centroid of the outer face.

        Returns:
            The unit vector; an InputError when the faces' centroids coincide.
        """
        d = outer - inner
        if not np.linalg.norm(d) > 0:
            raise InputError(f"hinge {self.name}: faces {self.inner} and {self.outer} coincide")
        return np.asarray(d / np.linalg.norm(d))


class RegionIntegrals:
    """∫_R expr dx for UFL expressions and named cell groups R, summed over all ranks."""

    def __init__(self, tagged: TaggedMesh, quadrature_degree: int | None = None):
        self.tagged = tagged
        self.mesh = tagged.mesh
        self.dx = cell_measure(self.mesh, quadrature_degree, tagged.cell_tags)

    def forms(self, exprs: Sequence[Expr], region: str) -> list[Form]:
        """The compiled forms ∫_R expr dx of the region ``region``."""
        tag = self.tagged.tag(region, self.mesh.topology.dim)
        return [dolfinx.fem.form(e * self.dx(tag)) for e in exprs]

    def evaluate(self, forms: Sequence[Form]) -> Array:
        """The values of compiled forms, summed over the ranks (collective)."""
        local = np.array([dolfinx.fem.assemble_scalar(f) for f in forms], dtype=float)
        return mpi.sum_arrays(self.mesh.comm, local)

    def __call__(self, exprs: Sequence[Expr], region: str) -> Array:
        """∫_R expr dx for each expression (collective)."""
        return self.evaluate(self.forms(exprs, region))


class FoldAngles:
    """Signed fold angles (radians) of ``hinges`` for the deformation ``y`` (see module doc).

    The forms are compiled once; calling the object evaluates them for the current ``y``.
    """

    def __init__(self, y: Function, tagged: TaggedMesh, hinges: Sequence[Hinge], sense: int = 1):
        assert sense in (1, -1) and hinges, "a sense ±1 and at least one hinge"
        self.y, self.hinges, self.sense = y, list(hinges), sense
        self._int = RegionIntegrals(tagged)
        x = compat.spatial_coordinate(tagged.mesh)
        one = compat.as_ufl(1.0)
        faces = sorted({h.inner for h in hinges} | {h.outer for h in hinges})
        nu = unit_normal(y)
        self._normal_forms = {f: self._int.forms([nu[i] for i in range(3)], f) for f in faces}
        centroids = {}
        for region in faces:
            area, cx, cy = self._int([one, x[0], x[1]], region)
            centroids[region] = np.array([cx, cy]) / area
        self._axis_forms = {}
        for h in self.hinges:
            d = h.across(centroids[h.inner], centroids[h.outer])
            tangent = image_of_direction(y, [-float(d[1]), float(d[0])])
            self._axis_forms[h.name] = self._int.forms([tangent[i] for i in range(3)], h.name)

    def normals(self) -> dict[str, Array]:
        """Area-weighted mean unit normal of each face region."""
        out = {}
        for region, forms in self._normal_forms.items():
            n = self._int.evaluate(forms)
            out[region] = n / np.linalg.norm(n)
        return out

    def __call__(self) -> dict[str, float]:
        """The signed fold angle of each hinge, in radians, by hinge name (collective)."""
        normals = self.normals()
        angles = {}
        for h in self.hinges:
            a = self._int.evaluate(self._axis_forms[h.name])
            a /= np.linalg.norm(a)
            na, nb = normals[h.inner], normals[h.outer]
            sin = -float(np.dot(np.cross(na, nb), a))
            angles[h.name] = self.sense * math.atan2(sin, float(np.dot(na, nb)))
        return angles

    def degrees(self) -> dict[str, float]:
        """The signed fold angles in degrees (collective)."""
        return {k: math.degrees(v) for k, v in self().items()}


class RegionFrame:
    """The rigid motion that best describes a (nearly rigid) region of the deformed plate.

    Centre c = mean of y over the region, frame Q = [f₁ f₂ f₁×f₂] with (f₁ f₂) the polar
    factor of the mean gradient. ``to_reference(p)`` = Qᵀ(p − c) + c_ref maps deformed
    points into the region's reference placement (c_ref the reference centroid, z = 0).
    """

    def __init__(self, y: Function, tagged: TaggedMesh, region: str):
        self._int = RegionIntegrals(tagged)
        x = compat.spatial_coordinate(tagged.mesh)
        G = compat.grad(y)
        exprs = [compat.as_ufl(1.0), x[0], x[1]] + [y[i] for i in range(3)]
        exprs += [G[i, j] for i in range(3) for j in range(2)]
        self._forms = self._int.forms(exprs, region)

    def __call__(self) -> tuple[Array, Array, Array]:
        """(c, Q, c_ref) for the current deformation."""
        values = self._int.evaluate(self._forms)
        area = values[0]
        c_ref = np.array([values[1] / area, values[2] / area, 0.0])
        c = values[3:6] / area
        F = values[6:12].reshape(3, 2) / area
        U, _, Vt = np.linalg.svd(F, full_matrices=False)
        P = U @ Vt  # polar factor: orthonormal columns f₁, f₂
        Q = np.column_stack([P[:, 0], P[:, 1], np.cross(P[:, 0], P[:, 1])])
        return c, Q, c_ref

    def to_reference(self, points: Array) -> Array:
        """Qᵀ(p − c) + c_ref for each row p of ``points`` (collective)."""
        c, Q, c_ref = self()
        mapped: Array = (np.asarray(points) - c) @ Q + c_ref
        return mapped


def _facet_nodes(
    space: compat.FunctionSpace, tagged: TaggedMesh, group: str
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """For each facet of ``group`` and each owned cell beside it: its dofs on the facet.

    Yields the cell's dofs on the facet and their positions along it (0 at one vertex, 1 at
    the other).
    """
    mesh = space.mesh
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    num_owned = mesh.topology.index_map(tdim).size_local
    coords = space.tabulate_dof_coordinates()
    facets = tagged.facets(group)
    nodes = entities_to_geometry(mesh, tdim - 1, facets.astype(np.int32))
    for facet, facet_nodes in zip(facets, nodes):
        a, b = mesh.geometry.x[facet_nodes[:2]]  # the two vertices come first
        length = np.linalg.norm(b - a)
        for cell in f2c.links(facet):
            if cell >= num_owned:
                continue
            cell_dofs = space.dofmap.cell_dofs(cell)
            p = coords[cell_dofs]
            s = np.clip((p - a) @ (b - a) / length**2, 0.0, 1.0)
            on = np.linalg.norm(p - (a + np.outer(s, b - a)), axis=1) < 1e-8 * length
            yield cell_dofs[on], s[on]


def edge_nodes(y: Function, tagged: TaggedMesh, group: str) -> tuple[np.ndarray, np.ndarray]:
    """Reference positions (N×3) and deformed positions (N×3) of y's nodes on a facet group.

    For the Lagrange nodes of y's (DG) space that lie on the facets of ``group`` in owned
    cells (local arrays: reduce over ranks yourself). Nodes on an edge shared by two cells of
    the group appear once per cell.
    """
    space = y.function_space
    found = [dofs for dofs, _ in _facet_nodes(space, tagged, group)]
    dofs = np.concatenate(found).astype(np.int64) if found else np.zeros(0, np.int64)
    values = y.x.array.real.reshape(-1, 3)
    return space.tabulate_dof_coordinates()[dofs], values[dofs]


def edge_segments(y: Function, tagged: TaggedMesh, group: str) -> list[np.ndarray]:
    """The deformed facets of a facet group as polylines.

    One N×3 array of y's nodes per facet and owned cell beside it, in order along the facet
    (local: gather them yourself).
    """
    values = y.x.array.real.reshape(-1, 3)
    return [
        values[dofs[np.argsort(s)]] for dofs, s in _facet_nodes(y.function_space, tagged, group)
    ]


@dataclass(frozen=True)
class HingeGeometry:
    """A hinge strip's extent and cells.

    Its extent across (``width``, from the inner to the outer panel) and along (``length``),
    and its cells: ``across`` × ``along`` (a structured strip).
    """

    width: float
    length: float
    across: int
    along: int


def hinge_geometry(tagged: TaggedMesh, hinge: Hinge) -> HingeGeometry:
    """Measure a hinge strip on the mesh (collective).

    The direction across is that from the inner face's centroid to the outer one's; width and
    length are the extents of the hinge's vertices across and along, and the cell counts are
    those extents over the smallest cell extent in each direction (a structured strip).
    """
    mesh = tagged.mesh
    comm = mesh.comm
    integrals = RegionIntegrals(tagged)
    x = compat.spatial_coordinate(mesh)
    centroids = []
    for region in (hinge.inner, hinge.outer):
        area, cx, cy = integrals([compat.as_ufl(1.0), x[0], x[1]], region)
        centroids.append(np.array([cx, cy]) / area)
    d = hinge.across(centroids[0], centroids[1])
    directions = np.column_stack([d, [-d[1], d[0]]])  # across, along
    owned = tagged.cells(hinge.name)
    owned = owned[owned < mesh.topology.index_map(mesh.topology.dim).size_local]
    corners = mesh.geometry.x[geometry_dofmap(mesh)[owned]][:, :, :2] @ directions
    none = np.full((1, 1, 2), np.nan)  # a rank without hinge cells: ignored by fmin/fmax
    corners = corners if owned.size else none
    local = np.concatenate(
        [-corners.min(axis=(0, 1)), corners.max(axis=(0, 1)), -np.ptp(corners, axis=1).min(0)]
    )
    lo_hi = np.empty(6)
    comm.Allreduce(np.nan_to_num(local, nan=-np.inf), lo_hi, op=MPI.MAX)
    extent = lo_hi[2:4] + lo_hi[0:2]
    cell = -lo_hi[4:6]
    counts = [max(1, round(float(e / c))) for e, c in zip(extent, cell)]
    return HingeGeometry(float(extent[0]), float(extent[1]), counts[0], counts[1])


class ClosureGap:
    """How far the nodes of a facet group are from where they should be, in a panel's frame.

    ``target(ref)`` maps the nodes' reference positions (N×3) to their target positions (N×3)
    in the reference frame of the cell group ``panel`` (:class:`RegionFrame`); calling the
    object returns the largest distance of a node from its target (collective).
    """

    def __init__(
        self,
        y: Function,
        tagged: TaggedMesh,
        edge: str,
        panel: str,
        target: Callable[[np.ndarray], np.ndarray],
    ):
        tagged.facets(edge)  # an unknown group is an InputError now
        self.y, self.tagged, self.edge, self.target = y, tagged, edge, target
        self.frame = RegionFrame(y, tagged, panel)

    def __call__(self) -> float:
        """The largest distance of a node from its target (collective)."""
        ref, pos = edge_nodes(self.y, self.tagged, self.edge)
        local = self.frame.to_reference(pos)
        gap = np.linalg.norm(local - self.target(ref), axis=1).max(initial=0.0)
        return float(self.y.function_space.mesh.comm.allreduce(float(gap), op=MPI.MAX))


class EdgePlacement:
    """Where the nodes of a facet group are, seen from a panel (e.g. the flaps' tips).

    Calling the object returns the nodes' mean height above the panel's plane (positive on
    the side of its normal) and their mean distance, in that plane, from the panel's
    reference centroid, both in the panel's frame (:class:`RegionFrame`; collective).
    """

    def __init__(self, y: Function, tagged: TaggedMesh, edge: str, panel: str) -> None:
        tagged.facets(edge)  # an unknown group is an InputError now
        self.y, self.tagged, self.edge = y, tagged, edge
        self.frame = RegionFrame(y, tagged, panel)

    def __call__(self) -> tuple[float, float]:
        """The nodes' mean height above the panel and mean distance from its centroid."""
        _, pos = edge_nodes(self.y, self.tagged, self.edge)
        c, Q, c_ref = self.frame()
        local = (pos - c) @ Q + c_ref
        comm = self.y.function_space.mesh.comm
        count = comm.allreduce(len(local), op=MPI.SUM)
        height = comm.allreduce(float(np.sum(local[:, 2])), op=MPI.SUM)
        radial = np.linalg.norm(local[:, :2] - c_ref[:2], axis=1)
        distance = comm.allreduce(float(np.sum(radial)), op=MPI.SUM)
        return height / max(count, 1), distance / max(count, 1)


def hinge_strip(
    comm: MPI.Comm,
    width: float = math.pi / 24,
    n: int = 4,
    m: int = 4,
    like: Mesh | None = None,
) -> TaggedMesh:
    """Two unit squares joined by a hinge strip: the test piece of a self-folding net.

    ω = [0, 2 + width] × [0, 1] with cell groups ``left`` = [0, 1] × [0, 1], ``hinge`` =
    [1, 1 + width] × [0, 1] and ``right``; structured quadrilaterals, n × n per square and
    m × n in the hinge (the same cells as ``meshes/box_net.geo``), shared-facet ghosts.
    ``like``: a mesh whose coordinate element the strip takes if it is one of affine
    quadrilaterals (a gmsh mesh has the equispaced variant, DOLFINx's rectangles the
    GLL-warped one), so that forms on the strip have the signatures of those on ``like`` and
    are compiled once for both.
    """
    if not width > 0 or n < 1 or m < 1:
        raise InputError(f"hinge_strip needs width > 0 and n, m >= 1, got {width}, {n}, {m}")
    cols = 2 * n + m
    domain = None if like is None else _affine_quadrilateral_domain(like)
    if like is not None and domain is not None:
        mesh = _grid(comm, domain, like.geometry.dim, cols, n)
    else:
        mesh = dolfinx.mesh.create_rectangle(
            comm,
            [np.array([0.0, 0.0]), np.array([float(cols), 1.0])],
            [cols, n],
            cell_type=dolfinx.mesh.CellType.quadrilateral,
            ghost_mode=dolfinx.mesh.GhostMode.shared_facet,
        )
    x = mesh.geometry.x
    s = x[:, 0].copy()  # column index → physical abscissa, piecewise linear
    x[:, 0] = np.where(
        s <= n, s / n, np.where(s <= n + m, 1 + (s - n) * width / m, 1 + width + (s - n - m) / n)
    )
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    cells = local_entities(mesh, tdim)
    mid = dolfinx.mesh.compute_midpoints(mesh, tdim, cells)[:, 0]
    values = np.where(mid < 1, 1, np.where(mid < 1 + width, 2, 3)).astype(np.int32)
    cell_tags = make_tags(mesh, tdim, cells, values)
    facet_tags = make_tags(mesh, tdim - 1, np.zeros(0, np.int32), np.zeros(0, np.int32))
    groups = {"left": (tdim, 1), "hinge": (tdim, 2), "right": (tdim, 3)}
    return TaggedMesh(mesh, cell_tags, facet_tags, groups, f"hinge strip w={width:g} n={n} m={m}")


def _affine_quadrilateral_domain(mesh: Mesh) -> ufl.Mesh | None:
    """A ``ufl.Mesh`` with the coordinate element of ``mesh``, None unless affine quadrilaterals."""
    domain = mesh.ufl_domain()
    if domain is None or mesh.topology.cell_type != dolfinx.mesh.CellType.quadrilateral:
        return None
    element = domain.ufl_coordinate_element()  # type: ignore[no-untyped-call]
    if element.embedded_superdegree != 1:
        return None
    new: ufl.Mesh = ufl.Mesh(element)  # type: ignore[no-untyped-call]
    return new


def _grid(comm: MPI.Comm, domain: ufl.Mesh, gdim: int, cols: int, rows: int) -> Mesh:
    """[0, cols] × [0, 1] in cols × rows quadrilaterals with the coordinate element of domain."""
    i, j = np.meshgrid(np.arange(cols + 1), np.arange(rows + 1), indexing="xy")
    points = np.c_[i.ravel(), j.ravel() / rows].astype(np.float64)
    corner = (np.arange(rows)[:, None] * (cols + 1) + np.arange(cols)[None, :]).ravel()
    # DOLFINx's quadrilateral: vertices (0,0), (1,0), (0,1), (1,1) of the reference square
    cells = np.c_[corner, corner + 1, corner + cols + 1, corner + cols + 2].astype(np.int64)
    points = np.c_[points, np.zeros((len(points), gdim - 2))]
    if comm.rank:  # rank 0 holds the whole mesh; the partitioner distributes it
        points, cells = points[:0], cells[:0]
    return compat.create_mesh(comm, cells, points, domain, compat.shared_facet_partitioner())


__all__ = [
    "ClosureGap",
    "EdgePlacement",
    "FoldAngles",
    "Hinge",
    "HingeGeometry",
    "RegionFrame",
    "RegionIntegrals",
    "edge_nodes",
    "edge_segments",
    "hinge_geometry",
    "hinge_strip",
]
