"""A printable solid: the deformed sheet thickened to y ± (t/2)ν, as a closed triangle surface.

The mid-surface is the deformation y at the mesh's vertices (the mean of the cells' values:
the dG field jumps a little across facets), each cell cut into triangles oriented like the
reference plate, so that their normals point along the model's ν = ∂₁y × ∂₂y. Each vertex
moves by ±t/2 along its normal (the area-weighted mean of its triangles'); the top copy keeps
the orientation, the bottom one is reversed, and each boundary edge gets a side quad of two
triangles. The surface is then closed and consistently oriented (every directed edge is met
once, in reverse, by another triangle: :func:`is_watertight`), and its volume follows from
the divergence theorem (:func:`volume`). It is written as binary STL by a writer of its own
(:func:`write_stl`, a few lines of NumPy), or as PLY or VTU by pyvista (:func:`write_solid`).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import TypeAlias

import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from dgplate import compat
from dgplate.compat import Function

Array: TypeAlias = "npt.NDArray[np.float64]"
Triangles: TypeAlias = "npt.NDArray[np.int64]"

#: A triangle of binary STL: its unit normal, its corners and a 16-bit attribute (0).
STL_RECORD = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])

#: The triangles of a cell, by its vertices in DOLFINx's order (quadrilateral: tensor product).
_SPLIT = {3: [[0, 1, 2]], 4: [[0, 1, 3], [0, 3, 2]]}


def mid_surface(y: Function) -> tuple[Array, Triangles] | None:
    """The deformed mid-surface: (points, triangles) on rank 0, None elsewhere (collective).

    Args:
        y: the deformation (any degree, continuous or not).

    Returns:
        The points (y at the mesh's vertices, shared by the cells around them) and the
        triangles (rows of three point indices, oriented along ν).
    """
    mesh = y.function_space.mesh
    owned = mesh.topology.index_map(mesh.topology.dim).size_local
    corners = 3 if mesh.topology.cell_type == dolfinx.mesh.CellType.triangle else 4
    nodes = compat.geometry_dofmap(mesh)[:owned, :corners]
    x = mesh.geometry.x
    cells = np.repeat(np.arange(owned, dtype=np.int32), corners)
    values = np.asarray(y.eval(x[nodes.reshape(-1)], cells)).reshape(owned, corners, 3)
    ids = np.asarray(mesh.geometry.input_global_indices)[nodes]
    gathered = mesh.comm.gather((ids, values, x[nodes][:, :, :2]), root=0)
    if gathered is None:
        return None
    ids = np.concatenate([g[0] for g in gathered])
    values = np.concatenate([g[1] for g in gathered])
    reference = np.concatenate([g[2] for g in gathered])
    unique, index = np.unique(ids.reshape(-1), return_inverse=True)
    index = index.reshape(ids.shape)
    count = np.bincount(index.reshape(-1), minlength=unique.size).astype(float)
    points = np.stack(
        [np.bincount(index.reshape(-1), values[..., a].reshape(-1), unique.size) for a in range(3)],
        axis=1,
    )
    triangles = np.concatenate([index[:, split] for split in _SPLIT[corners]])
    flat = np.concatenate([reference[:, split] for split in _SPLIT[corners]])
    a, b, c = flat[:, 0], flat[:, 1], flat[:, 2]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    triangles[area < 0] = triangles[area < 0][:, ::-1]
    return points / count[:, None], triangles.astype(np.int64)


def thicken(points: Array, triangles: Triangles, thickness: float) -> tuple[Array, Triangles]:
    """The closed surface of the sheet ``points ± (thickness/2)·normal`` (module docstring).

    Args:
        points: the mid-surface's points, (n, 3).
        triangles: its triangles, (m, 3), consistently oriented.
        thickness: t, in the units of ``points``.

    Returns:
        The solid's vertices (2n: top, then bottom) and triangles (2m + 2 per boundary edge),
        oriented outwards.
    """
    n = len(points)
    corner = points[triangles]
    face = np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0])  # 2 × area
    normal = np.zeros_like(points)
    for k in range(3):
        np.add.at(normal, triangles[:, k], face)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    vertices = np.concatenate(
        [points + 0.5 * thickness * normal, points - 0.5 * thickness * normal]
    )
    a, b = boundary_edges(triangles).T
    sides = np.concatenate([np.stack([b, a, a + n], axis=1), np.stack([a + n, b + n, b], axis=1)])
    faces = np.concatenate([triangles, triangles[:, ::-1] + n, sides])
    return vertices, faces


def _directed_edges(triangles: Triangles) -> Triangles:
    """Every triangle's edges (a, b) in its orientation: (3m, 2)."""
    return np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])


def boundary_edges(triangles: Triangles) -> Triangles:
    """The directed edges (a, b) whose reverse (b, a) no triangle has: the boundary."""
    edges = _directed_edges(triangles)
    size = int(triangles.max(initial=0)) + 1
    key, reverse = edges[:, 0] * size + edges[:, 1], edges[:, 1] * size + edges[:, 0]
    return edges[~np.isin(reverse, key)]


def is_watertight(triangles: Triangles) -> bool:
    """Closed and consistently oriented: each directed edge once, and its reverse once.

    Then every (undirected) edge belongs to exactly two triangles, which run along it in
    opposite directions.
    """
    edges = _directed_edges(triangles)
    size = int(triangles.max(initial=0)) + 1
    key = edges[:, 0] * size + edges[:, 1]
    reverse = edges[:, 1] * size + edges[:, 0]
    return bool(np.unique(key).size == key.size and np.isin(reverse, key).all())


def volume(vertices: Array, triangles: Triangles) -> float:
    """The enclosed volume, Σ v₀·(v₁ × v₂)/6 (divergence theorem; > 0 if oriented outwards)."""
    v = vertices[triangles]
    return float(np.einsum("ij,ij->", v[:, 0], np.cross(v[:, 1], v[:, 2])) / 6)


def area(vertices: Array, triangles: Triangles) -> float:
    """The total area of the triangles."""
    v = vertices[triangles]
    return float(np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1).sum() / 2)


#: The formats of :func:`write_solid`.
FORMATS = (".stl", ".ply", ".vtu")


def write_solid(path: Path, vertices: Array, triangles: Triangles) -> None:
    """The solid as binary STL (:func:`write_stl`), or as PLY or VTU through pyvista.

    Written to a temporary file beside ``path`` and moved into place: never half-written.

    Args:
        path: the file, ending in one of :data:`FORMATS`.
        vertices: the solid's vertices, (n, 3).
        triangles: its triangles, (m, 3).
    """
    suffix = path.suffix.lower()
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=suffix)
    os.close(handle)
    try:
        if suffix == ".stl":
            write_stl(Path(temporary), vertices, triangles)
        else:
            import pyvista

            faces = np.hstack([np.full((len(triangles), 1), 3), triangles]).ravel()
            surface = pyvista.PolyData(vertices, faces)
            shaped = surface if suffix == ".ply" else surface.cast_to_unstructured_grid()
            shaped.save(temporary)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_stl(path: Path, vertices: Array, triangles: Triangles) -> None:
    """Binary STL: an 80-byte header, the count, then :data:`STL_RECORD` per triangle.

    Written by NumPy rather than VTK's writer: the file is what a printer takes, exactly
    these triangles in this order, with no VTK import (a second) on the way.
    """
    data = np.zeros(len(triangles), dtype=STL_RECORD)
    corner = vertices[triangles]
    normal = np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0])
    length = np.linalg.norm(normal, axis=1)[:, None]
    data["normal"] = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    data["vertices"] = corner
    header = b"dgplate solid: the deformed sheet thickened along its normals".ljust(80)
    path.write_bytes(header + np.uint32(len(data)).tobytes() + data.tobytes())
