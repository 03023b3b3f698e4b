"""Measured shapes: a scan's points from a file, and the closest points on a computed surface.

A scan is a point cloud: ``.xyz``, ``.txt`` or ``.csv`` text with x, y, z in the first three
columns (whitespace or commas; a header line is skipped), or the points of a ``.ply``,
``.stl``, ``.vtp`` or ``.vtk`` file (read by pyvista). The closest points come from VTK's cell
locator (through pyvista, already a dependency) rather than a k-d tree of the vertices
(SciPy's): the distance to the surface, not to its nearest vertex, is what a scan's deviation
is.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

from dgplate.errors import InputError

Array: TypeAlias = "npt.NDArray[np.float64]"
TEXT = (".xyz", ".txt", ".csv")
MESHES = (".ply", ".stl", ".vtp", ".vtk")


def read_scan(path: Path) -> Array:
    """The points of a scan file, (k, 3); a file that holds none is a one-line InputError.

    Args:
        path: a ``.xyz``, ``.txt``, ``.csv``, ``.ply``, ``.stl``, ``.vtp`` or ``.vtk`` file.

    Returns:
        The points, each once.
    """
    suffix = path.suffix.lower()
    if suffix not in TEXT + MESHES:
        raise InputError(f"scan {path}: unknown format (known: {', '.join(TEXT + MESHES)})")
    if not path.is_file():
        raise InputError(f"scan not found: {path}")
    try:
        points = _text_points(path) if suffix in TEXT else _mesh_points(path)
    except (ValueError, OSError, IndexError) as err:
        raise InputError(f"scan {path}: cannot read its points: {err}") from None
    points = np.unique(points, axis=0)
    if len(points) < 4 or not np.isfinite(points).all():
        raise InputError(f"scan {path}: needs at least 4 finite points, has {len(points)}")
    return points


def _text_points(path: Path) -> Array:
    lines = path.read_text(encoding="utf-8").replace(",", " ").splitlines()
    rows = [line.split() for line in lines if line.strip() and not line.startswith("#")]
    if rows and not _numeric(rows[0][0]):
        rows = rows[1:]  # a header
    return np.array([[float(v) for v in row[:3]] for row in rows], dtype=float).reshape(-1, 3)


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _mesh_points(path: Path) -> Array:
    import pyvista

    return np.asarray(pyvista.read(path).points, dtype=float).reshape(-1, 3)


class SurfaceLocator:
    """The closest points of a triangulated surface, and its unit normals there.

    Args:
        points: the surface's points, (n, 3).
        triangles: its triangles, (m, 3).
    """

    def __init__(self, points: Array, triangles: npt.NDArray[np.int64]) -> None:
        import pyvista

        faces = np.hstack([np.full((len(triangles), 1), 3), triangles]).ravel()
        self._surface = pyvista.PolyData(points, faces)
        corner = points[triangles]
        normal = np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0])
        self._normals = normal / np.linalg.norm(normal, axis=1)[:, None]

    def __call__(self, queries: Array) -> tuple[Array, Array]:
        """(the closest points on the surface, the normals of their triangles) of ``queries``."""
        found: Any = self._surface.find_closest_cell(queries, return_closest_point=True)
        cells, near = found  # (cells, points) with return_closest_point
        return np.asarray(near, dtype=float).reshape(-1, 3), self._normals[np.ravel(cells)]


def largest_gap(points: Array, cloud: Array) -> float:
    """The largest distance from one of ``points`` to its nearest point of ``cloud``."""
    import pyvista

    found: Any = pyvista.PolyData(cloud).find_closest_cell(points, return_closest_point=True)
    near = found[1]
    return float(np.linalg.norm(np.asarray(near).reshape(-1, 3) - points, axis=1).max())


def plot_distances(
    surface: tuple[Array, npt.NDArray[np.int64]],
    scan: Array,
    path: Path,
    title: str,
    units: str,
) -> None:
    """A picture of the aligned scan's points coloured by their signed distance to the surface.

    The surface is drawn in light grey; a point above it (on the side of its normal) has a
    positive distance. Rank 0 only (no collectives); written atomically.

    Args:
        surface: the surface's points and triangles.
        scan: the aligned scan's points, (k, 3).
        path: the PNG file.
        title: the picture's title.
        units: the distances' units, for the colour bar's label.
    """
    import pyvista

    from dgplate.io.images import offscreen_png

    points, triangles = surface
    near, normal = SurfaceLocator(points, triangles)(scan)
    cloud = pyvista.PolyData(scan)
    cloud["distance"] = np.einsum("ij,ij->i", scan - near, normal)
    largest = float(np.abs(cloud["distance"]).max()) or 1.0  # white is on the surface
    faces = np.hstack([np.full((len(triangles), 1), 3), triangles]).ravel()
    with offscreen_png(path, (1200, 900)) as plotter:
        plotter.set_background("white")
        plotter.add_mesh(pyvista.PolyData(points, faces), color="#d0d0d0", opacity=0.5)
        plotter.add_mesh(
            cloud,
            scalars="distance",
            cmap="coolwarm",
            clim=[-largest, largest],
            point_size=7,
            render_points_as_spheres=True,
            scalar_bar_args={"title": f"signed distance ({units})", "color": "black"},
        )
        plotter.add_text(title, position="upper_edge", font_size=14, color="black")
        plotter.view_isometric()
