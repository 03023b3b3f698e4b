"""Pictures of a rod: a tube around the centreline u with a stripe along the director b.

A line shows the centreline's shape but not its twist; a tube with a coloured stripe drawn
along b shows how the frame [u′, b, u′ × b] turns about the tangent (a straight rod twisted by
φ shows a helical stripe of φ/2π turns). Collective: every rank sends its nodal values, rank 0
renders off-screen with pyvista and writes the PNG.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import dolfinx.fem
import numpy as np
import pyvista

from dgplate.io.images import offscreen_png
from dgplate.io.plotting import _set_camera

__all__ = ["plot_rod", "rod_polyline"]

Array = np.ndarray


def _gather(f: dolfinx.fem.Function[np.float64]) -> tuple[Array, Array] | None:
    """(parameter, values) of f's owned nodes on rank 0, sorted by the parameter; None elsewhere.

    The parameter is s on an interval and the polygon's angle for a closed rod (a 1D mesh in
    the plane).
    """
    space = f.function_space
    owned = space.dofmap.index_map.size_local
    x = space.tabulate_dof_coordinates()[:owned]
    key = np.arctan2(x[:, 1], x[:, 0]) if space.mesh.geometry.dim > 1 else x[:, 0]
    parts = space.mesh.comm.gather((key, f.x.array.reshape(-1, 3)[:owned]), root=0)
    if parts is None:
        return None
    keys = np.concatenate([p[0] for p in parts])
    order = np.argsort(keys, kind="stable")
    return keys[order], np.concatenate([p[1] for p in parts])[order]


def rod_polyline(
    u: dolfinx.fem.Function[np.float64], b: dolfinx.fem.Function[np.float64]
) -> tuple[Array, Array, bool] | None:
    """The nodes of u in order, b at them (⟂ the polyline's tangent, unit) and closedness.

    b (P₁) is interpolated linearly in the parameter to u's nodes, made orthogonal to the
    central-difference tangent of the polyline and normalised. Collective; None off rank 0.
    """
    closed = u.function_space.mesh.geometry.dim > 1
    centre, frame = _gather(u), _gather(b)
    if centre is None or frame is None:
        return None
    (s, points), (sb, nodal) = centre, frame
    period = 2.0 * np.pi if closed else None
    director = np.column_stack([np.interp(s, sb, nodal[:, k], period=period) for k in range(3)])
    if closed:
        tangent = np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)
    else:
        tangent = np.gradient(points, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    director -= np.sum(director * tangent, axis=1)[:, None] * tangent
    director /= np.linalg.norm(director, axis=1)[:, None]
    return points, director, closed


def _tube(points: Array, closed: bool, radius: float) -> pyvista.PolyData:
    """A tube of the given radius around the polyline through ``points``."""
    if closed:
        points = np.vstack([points, points[:1]])
    line = pyvista.MultipleLines(points)  # one polyline: a seamless tube
    tube: pyvista.PolyData = line.tube(radius=radius, n_sides=24, capping=not closed)
    return tube


#: The most nodes the tube's radius is worked out from (their pairwise distances: 32 MB).
RADIUS_SAMPLE = 2000


def _default_radius(points: Array, closed: bool) -> float:
    """1 % of the length, or less where strands come close: 0.4 × their least distance.

    Two nodes are on different strands where the rod has come back: their distance is less
    than half the arc length between them (cyclically for a closed rod), which no smooth
    piece of curve shorter than about 3.8 radii of curvature does. At most
    :data:`RADIUS_SAMPLE` nodes, evenly spaced, are compared: memory and time stay bounded
    for any number of cells.
    """
    ends = np.vstack([points, points[:1]]) if closed else points
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ends, axis=0), axis=1))])
    length = float(arc[-1])
    sample = np.arange(0, len(points), -(-len(points) // RADIUS_SAMPLE))
    at, where = arc[sample], points[sample]
    apart = np.abs(at[:, None] - at[None, :])
    if closed:
        apart = np.minimum(apart, length - apart)
    distance = np.linalg.norm(where[:, None, :] - where[None, :, :], axis=2)
    strands = distance[distance < 0.5 * apart]
    return min(0.01 * length, 0.4 * float(strands.min())) if strands.size else 0.01 * length


def plot_rod(
    u: dolfinx.fem.Function[np.float64],
    b: dolfinx.fem.Function[np.float64],
    path: str | Path,
    title: str = "",
    *,
    radius: float | None = None,
    min_radius: float = 0.0,
    sphere: tuple[float, Sequence[float]] | None = None,
    window_size: tuple[int, int] = (1000, 800),
) -> None:
    """final.png of a rod: a grey tube around u with a red stripe along b (collective).

    The stripe is a thinner tube through u + r·b on the surface of the tube of radius r
    (default 1 % of the polyline's length, less where strands come close, at least
    ``min_radius``), so it winds around the tube as the frame turns. ``sphere = (R, centre)``
    draws a confining ball, translucent, and frames the view on it at its true size.
    """
    line = rod_polyline(u, b)
    if line is None:
        return
    points, director, closed = line
    if radius is None:
        radius = max(_default_radius(points, closed), min_radius)
    with offscreen_png(path, window_size) as plotter:
        plotter.set_background("white")
        plotter.add_mesh(_tube(points, closed, radius), color="#c8ccd4", smooth_shading=True)
        stripe = _tube(points + 0.9 * radius * director, closed, 0.35 * radius)
        plotter.add_mesh(stripe, color="#d62728", smooth_shading=True)
        if not closed:  # the start s = 0
            plotter.add_mesh(pyvista.Sphere(radius=1.6 * radius, center=points[0]), color="black")
        if title:
            plotter.add_title(title, font_size=10, color="black")
        if sphere is not None:
            ball = pyvista.Sphere(radius=sphere[0], center=tuple(sphere[1]), theta_resolution=48)
            plotter.add_mesh(ball, color="#6baed6", opacity=0.15, smooth_shading=True)
            _set_camera(plotter, "iso", np.asarray(ball.bounds))
            plotter.enable_parallel_projection()  # the ball's true size
        else:
            _set_camera(plotter, "iso", np.asarray(plotter.bounds))
            if closed:  # an open rod fills the width of the view already
                plotter.camera.zoom(1.3)
