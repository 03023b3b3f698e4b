"""Measurements along a crease C: fold angles and the deformed crease lines (docs/design.md §1).

A crease is a union of interior facets (the facets tagged ``CREASE`` by
:func:`dgplate.dg.forms.facet_sets`). The deformation is continuous across C but its gradient may
jump, so the deformed surface has a kink there. For each crease facet the *fold angle* is the
angle between the unit normals ν = ∂₁y × ∂₂y / |∂₁y × ∂₂y| of the two adjacent cells, evaluated
at the facet midpoint: 0° for a flat sheet, 180° for a sheet folded flat onto itself. The
*signed* fold angle is positive for a valley fold (the sheet on either side turns towards the
normal ν of the other side — the convention of the bilayer model, where Z = αI with α > 0 bends
towards +ν) and negative for a mountain fold.

Summaries are over the whole crease: min, max and the length-weighted mean (weights: the
reference facet lengths, i.e. the chords between the facet's vertices), and the length of C,
∫_C ds in the reference configuration (on curved cells their curved facets, not the chords),
reduced over the communicator, so every rank gets the same numbers and they do not depend on
the number of ranks. The crease lines in deformed coordinates (``polylines``) are gathered to
rank 0 for pictures (``plot_deformation(..., lines=...)``).

Works for vector deformations y ∈ [DG_k]³ and for scalar deflections w (surface (x₁, x₂, w)),
on triangles and quadrilaterals. Every function here is collective on the mesh communicator.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import basix
import dolfinx.fem
import numpy as np
import numpy.typing as npt

from dgplate import compat, mpi
from dgplate.compat import Array, Function, Indices
from dgplate.dg.forms import CREASE, FacetSets
from dgplate.dg.geometry import oriented_normal, surface, unit_normal


def _reference_facets(cell_name: str) -> tuple[Array, npt.NDArray[np.int64]]:
    """Reference vertex coordinates and the (two) vertices of each facet of a 2D cell."""
    cell = basix.CellType[cell_name]
    vertices = np.asarray(basix.geometry(cell), dtype=np.float64)
    facets = np.asarray(basix.topology(cell)[1], dtype=np.int64)
    return vertices, facets


class CreaseMeasure:
    """Fold angles and deformed crease lines of ``u`` on the crease facets of ``facets``.

    The set-up (which cells border which crease facet, and through which of their local
    facets) is done once; ``summary()`` and ``polylines()`` then evaluate the current ``u``.
    ``samples`` is the number of segments each crease facet is drawn with.
    """

    def __init__(self, u: Function, facets: FacetSets, samples: int = 4):
        mesh = facets.mesh
        self.mesh, self.comm, self.u = mesh, mesh.comm, u
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        mesh.topology.create_connectivity(tdim, tdim - 1)
        num_owned = mesh.topology.index_map(tdim - 1).size_local
        tags = facets.tags
        crease = tags.indices[tags.values == CREASE]
        self.facets: Indices = crease[crease < num_owned].astype(np.int32)  # owned crease facets
        self.cells, self.local = self._bordering_cells()

        # Reference points: each local facet sampled at samples + 1 equispaced points from its
        # first to its second vertex (the midpoint is among them when samples is even).
        samples = max(2, 2 * ((int(samples) + 1) // 2))
        self.samples = samples
        ref_vertices, ref_facets = _reference_facets(mesh.topology.cell_name())
        t = np.linspace(0.0, 1.0, samples + 1)
        start, end = ref_vertices[ref_facets[:, 0]], ref_vertices[ref_facets[:, 1]]
        points = start[:, None, :] + t[None, :, None] * (end - start)[:, None, :]
        self._num_per_facet = samples + 1
        self._ref_points = points.reshape(-1, tdim)
        self._reference_geometry(ref_facets)
        self.facet_sets = facets
        self._length_form: compat.Form | None = None  # ∫_C ds, compiled by the first length()

        y = surface(u)
        grad, nu = compat.grad(y), unit_normal(y)
        # y, ν, ∂₁y, ∂₂y at every sample point of every reference facet
        values = [*[y[i] for i in range(3)], *[nu[i] for i in range(3)]]
        values += [grad[i, j] for j in range(2) for i in range(3)]
        self._expr: compat.Expression = dolfinx.fem.Expression(
            compat.as_vector(values), self._ref_points
        )

    def _bordering_cells(self) -> tuple[Indices, Indices]:
        """For each crease facet, its two cells and its local index in each of them."""
        tdim = self.mesh.topology.dim
        f_to_c = self.mesh.topology.connectivity(tdim - 1, tdim)
        c_to_f = self.mesh.topology.connectivity(tdim, tdim - 1)
        cells = np.zeros((self.facets.size, 2), dtype=np.int32)
        local = np.zeros((self.facets.size, 2), dtype=np.int32)
        for k, facet in enumerate(self.facets):
            pair = f_to_c.links(facet)
            if pair.size != 2:  # cannot happen with shared-facet ghosting and interior facets
                raise RuntimeError(
                    f"crease facet {facet} sees {pair.size} cell(s) on rank {self.comm.rank}: "
                    "the mesh must be distributed with shared-facet ghosts"
                )
            cells[k] = pair
            for side in range(2):
                local[k, side] = int(np.flatnonzero(c_to_f.links(pair[side]) == facet)[0])
        return cells, local

    def _reference_geometry(self, ref_facets: npt.NDArray[np.int64]) -> None:
        """Each crease facet's vertices (as the first cell sees them), length and unit normal.

        The normal points from the first cell to the second; ``same_order`` says whether the
        second cell sees the facet's vertices in the same order as the first.
        """
        x = self.mesh.geometry.x[:, :2]
        dofmap = compat.geometry_dofmap(self.mesh)
        num = self.facets.size
        self.ends = np.zeros((num, 2, 2))
        self.normals = np.zeros((num, 2))
        self.same_order = np.ones(num, dtype=bool)
        for k in range(num):
            first, second = dofmap[self.cells[k, 0]], dofmap[self.cells[k, 1]]
            a, b = ref_facets[self.local[k, 0]]
            self.ends[k] = x[first[a]], x[first[b]]
            tangent = self.ends[k, 1] - self.ends[k, 0]
            centres = x[first].mean(axis=0), x[second].mean(axis=0)
            self.normals[k] = oriented_normal(tangent, *centres)
            a, _ = ref_facets[self.local[k, 1]]
            self.same_order[k] = np.allclose(x[second[a]], self.ends[k, 0])
        self.lengths = np.linalg.norm(self.ends[:, 1] - self.ends[:, 0], axis=1)

    @property
    def num_facets(self) -> int:
        """Global number of crease facets."""
        return mpi.global_count(self.comm, int(self.facets.size))

    def _evaluate(self) -> Array:
        """Values (y, ν, ∂₁y, ∂₂y) at the sample points: shape (facets, 2 sides, points, 12).

        The points of each side are ordered like the first side's facet.
        """
        num = self.facets.size
        out = np.zeros((num, 2, self._num_per_facet, 12))
        if num == 0:
            return out
        cells = self.cells.reshape(-1)
        values = np.asarray(self._expr.eval(self.mesh, cells)).real
        values = values.reshape(cells.size, -1, 12)
        per = self._num_per_facet
        for side in range(2):
            rows = values[side::2]
            start = self.local[:, side] * per
            index = start[:, None] + np.arange(per)[None, :]
            picked = np.take_along_axis(rows, index[:, :, None], axis=1)
            if side == 1:
                flip = ~self.same_order
                picked[flip] = picked[flip, ::-1]
            out[:, side] = picked
        return out

    def fold_angles(self) -> tuple[Array, Array, Array]:
        """Per owned crease facet: fold angle, signed fold angle and the jump |[y]|.

        The fold angle in degrees (0..180), the signed one positive for a valley fold, and
        the jump at the midpoint (continuity across C).
        """
        data = self._evaluate()
        mid = self.samples // 2
        y0, y1 = data[:, 0, mid, 0:3], data[:, 1, mid, 0:3]
        nu0, nu1 = data[:, 0, mid, 3:6], data[:, 1, mid, 3:6]
        cos = np.einsum("ki,ki->k", nu0, nu1)
        sin = np.linalg.norm(np.cross(nu0, nu1), axis=1)
        angle = np.degrees(np.arctan2(sin, cos))
        # conormal of the second side, pointing away from C into that side: ∇y₁ n
        g1 = data[:, 1, mid, 6:12].reshape(-1, 2, 3)  # rows ∂₁y, ∂₂y
        conormal = np.einsum("kj,kji->ki", self.normals, g1)
        sign = np.where(np.einsum("ki,ki->k", conormal, nu0) >= 0.0, 1.0, -1.0)
        return angle, sign * angle, np.linalg.norm(y1 - y0, axis=1)

    def length(self) -> float:
        """|C| = ∫_C ds in the reference configuration. Collective.

        By quadrature on the cells' own geometry: on curved (order-2) cells the curved facets,
        not their chords.
        """
        if self._length_form is None:
            mesh = self.mesh
            degree = 2 * compat.coordinate_element_degree(mesh)
            ds_crease = self.facet_sets.dS(CREASE, metadata={"quadrature_degree": degree})
            self._length_form = dolfinx.fem.form(dolfinx.fem.Constant(mesh, 1.0) * ds_crease)
        local = float(dolfinx.fem.assemble_scalar(self._length_form).real)
        return mpi.global_sum(self.comm, local)

    def summary(self) -> dict[str, Any]:
        """Fold-angle statistics over C (same numbers on every rank), for summary.json."""
        comm = self.comm
        angle, signed, gap = self.fold_angles()
        w = self.lengths
        total = mpi.global_sum(comm, float(w.sum()))

        def stats(values: Array) -> dict[str, float]:
            lo = mpi.global_min(comm, float(values.min(initial=np.inf)))
            hi = mpi.global_max(comm, float(values.max(initial=-np.inf)))
            mean = mpi.global_sum(comm, float(np.dot(values, w))) / total if total else 0.0
            return {"min": lo, "max": hi, "mean": mean}

        return {
            "fold_angle_deg": stats(angle),
            "crease": {
                "facets": self.num_facets,
                "length": self.length(),
                "signed_fold_angle_deg": stats(signed),
                "max_value_jump": mpi.global_max(comm, float(gap.max(initial=0.0))),
            },
        }

    def polylines(self) -> list[Array]:
        """The crease in deformed coordinates as polylines (N×3 arrays) on rank 0.

        [] on the other ranks. Each facet is drawn with ``samples`` segments at the mean of
        the two sides' values; facets are chained into polylines by their shared reference
        vertices.
        """
        data = self._evaluate()
        points = 0.5 * (data[:, 0, :, 0:3] + data[:, 1, :, 0:3])
        gathered = self.comm.gather((self.ends, points), root=0)
        if gathered is None:  # not rank 0
            return []
        ends = np.concatenate([g[0] for g in gathered]) if gathered else np.zeros((0, 2, 2))
        pts = np.concatenate([g[1] for g in gathered]) if gathered else np.zeros((0, 0, 3))
        return _chain(ends, pts)


def _chain(ends: Array, points: Array) -> list[Array]:
    """Join segments that share end points into polylines.

    Segment k has the reference end points ``ends[k]`` and the sampled points ``points[k]``.
    Closed curves come back closed (first point repeated).
    """
    if ends.shape[0] == 0:
        return []
    scale = float(np.ptp(ends.reshape(-1, 2), axis=0).max()) or 1.0
    keys = np.round(ends / (1e-9 * scale)).astype(np.int64)
    at: dict[tuple[int, ...], list[tuple[int, int]]] = defaultdict(list)
    for k in range(ends.shape[0]):
        for end in range(2):
            at[tuple(keys[k, end])].append((k, end))
    used = np.zeros(ends.shape[0], dtype=bool)

    def walk(k: int, end: int) -> list[Array]:
        """Follow the chain leaving segment k through its end ``end``."""
        parts: list[Array] = []
        while True:
            nxt = [(j, e) for j, e in at[tuple(keys[k, end])] if not used[j]]
            if not nxt:
                return parts
            j, e = nxt[0]
            used[j] = True
            parts.append(points[j] if e == 0 else points[j, ::-1])
            k, end = j, 1 - e

    lines: list[Array] = []
    # start at a free end (degree 1) where there is one, so open arcs come out in one piece
    order = sorted(
        range(ends.shape[0]), key=lambda k: min(len(at[tuple(keys[k, e])]) for e in (0, 1))
    )
    for k in order:
        if used[k]:
            continue
        used[k] = True
        backward = walk(k, 0)
        forward = walk(k, 1)
        pieces = [p[::-1] for p in reversed(backward)] + [points[k]] + forward
        line = pieces[0]
        for piece in pieces[1:]:
            line = np.vstack([line, piece[1:]])
        lines.append(line)
    return lines


def fold_angle_summary(u: Function, facets: FacetSets) -> dict[str, Any]:
    """``CreaseMeasure(u, facets).summary()``: fold angles over C for summary.json."""
    return CreaseMeasure(u, facets).summary()


def crease_polylines(u: Function, facets: FacetSets, samples: int = 4) -> list[Array]:
    """The deformed crease lines on rank 0 ([] elsewhere), for ``plot_deformation(lines=)``."""
    return CreaseMeasure(u, facets, samples).polylines()


__all__ = [
    "CreaseMeasure",
    "crease_polylines",
    "fold_angle_summary",
]
