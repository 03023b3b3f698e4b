"""Pictures of the deformed plate: gather the DG surface to rank 0, render it off-screen.

``surface_grid`` (from :mod:`dgplate.measure.fields`) gathers the surface as VTK Lagrange cells;
``render_png`` draws it with pyvista without a display; ``plot_deformation`` does both for a
deformation coloured by bending or isometry defect; ``plot_curve`` draws a rod's centreline.
Picture files and animations are written by :mod:`dgplate.io.images`, montages of pictures by
:mod:`dgplate.io.montage` (both re-exported here).
Functions taking a DOLFINx function are collective; only rank 0 renders and writes.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import dolfinx.fem
import numpy as np
import pyvista
from ufl.core.expr import Expr

from dgplate.compat import Array
from dgplate.io.images import frames_to_gif, offscreen_png, save_figure, start_offscreen
from dgplate.io.montage import montage
from dgplate.measure.fields import (
    REFERENCE,
    bending_density,
    defect_density,
    gauss_density,
    surface_grid,
)

#: Scalar-bar labels of the fields ``plot_deformation`` can colour by.
COLOR_LABELS = {
    "curvature": "bending |D²y|",
    "defect": "isometry defect density",
    "gauss": "Gaussian curvature K",
}
#: The power of a length in each field (its unit with lengths in mm: mm^-power).
_LENGTH_POWER = {"curvature": 1, "defect": 0, "gauss": 2}
_VIEWS = {"iso": (1.0, -1.4, 1.1), "top": (0.0, 0.0, 1.0), "front": (0.0, -1.0, 0.0)}
_VIEWS.update({"xy": _VIEWS["top"], "xz": _VIEWS["front"], "yz": (1.0, 0.0, 0.0)})
_LOOK = {"smooth_shading": True, "specular": 0.3, "specular_power": 25, "ambient": 0.15}
_BAR = {"title": "", "vertical": False, "position_x": 0.25, "width": 0.5, "position_y": 0.03}
_BAR |= {"height": 0.07, "label_font_size": 16, "color": "black", "fmt": "%.3g", "n_labels": 5}


def _smooth_surface(grid: pyvista.UnstructuredGrid, levels: int = 3) -> pyvista.PolyData:
    """Triangulated higher-order surface (each Lagrange cell subdivided ``levels`` times)."""
    try:
        surface = grid.extract_surface(nonlinear_subdivision=levels, algorithm="dataset_surface")
    except TypeError:  # pyvista < 0.47 has no ``algorithm`` argument
        surface = grid.extract_surface(nonlinear_subdivision=levels)
    smooth: pyvista.PolyData = surface.compute_normals(
        cell_normals=False, split_vertices=False, auto_orient_normals=False
    )
    return smooth


def _reference_outline(grid: pyvista.UnstructuredGrid) -> pyvista.PolyData:
    """Boundary edges of the undeformed domain, from the cells' corner nodes (z = 0)."""
    legacy, faces, i = np.asarray(grid.cells), [], 0
    for vtk_type in np.asarray(grid.celltypes):
        corners = 3 if int(vtk_type) in (5, 22, 69) else 4  # triangles, else quadrilaterals
        faces.append(np.r_[corners, legacy[i + 1 : i + 1 + corners]])
        i += legacy[i] + 1
    reference = np.asarray(grid.point_data[REFERENCE], dtype=np.float64)
    flat = pyvista.PolyData(reference, faces=np.concatenate(faces))
    size = float(np.ptp(reference, axis=0).max()) or 1.0
    return _boundary_edges(flat.clean(tolerance=1e-9 * size, absolute=True))


def _boundary_edges(surface: pyvista.PolyData) -> pyvista.PolyData:
    """Edges with one adjacent face.

    Edges with one adjacent face. DG cells share no points, so on the deformed surface
    these are all element edges; on the cleaned reference mesh, the domain's boundary.
    """
    return surface.extract_feature_edges(
        boundary_edges=True, feature_edges=False, manifold_edges=False, non_manifold_edges=False
    )


def _set_camera(plotter: pyvista.Plotter, camera: str | Sequence[Any], bounds: np.ndarray) -> None:
    """Look at the centre of ``bounds`` from a named view, a direction or a camera position."""
    if isinstance(camera, str):
        if camera not in _VIEWS:
            raise ValueError(
                f"camera must be one of {sorted(_VIEWS)} or a position, not {camera!r}"
            )
        direction = np.asarray(_VIEWS[camera])
        up = (0.0, 1.0, 0.0) if camera in ("top", "xy") else (0.0, 0.0, 1.0)
        if camera != "iso":  # axis views read best without perspective
            plotter.enable_parallel_projection()  # type: ignore[call-arg]  # pyvista's _Wrapped stub
    elif len(camera) == 3 and np.ndim(camera[0]) == 0:
        direction, up = np.asarray(camera, dtype=float), (0.0, 0.0, 1.0)
    else:  # a full pyvista camera position: (position, focal point, view up)
        plotter.camera_position = camera  # type: ignore[assignment]  # pyvista accepts any position
        plotter.reset_camera(bounds=bounds)  # type: ignore[call-arg]  # pyvista's _Wrapped stub
        return
    centre = 0.5 * (bounds[0::2] + bounds[1::2])
    distance = 4.0 * max(float(np.linalg.norm(bounds[1::2] - bounds[0::2])), 1e-12)
    eye = centre + distance * direction / np.linalg.norm(direction)
    plotter.camera_position = [tuple(eye), tuple(centre), up]
    plotter.reset_camera(bounds=bounds)  # type: ignore[call-arg]  # pyvista's _Wrapped stub


def _fit(plotter: pyvista.Plotter, points: np.ndarray, top: float, bottom: float) -> None:
    """Zoom and shift the view so ``points`` fill the picture.

    Zoom and shift the view so ``points`` fill the picture, leaving the top and bottom
    fractions free for the title and the colour bar (tighter than the bounding sphere).
    """
    camera, (width, height) = plotter.camera, plotter.window_size
    matrix = camera.GetCompositeProjectionTransformMatrix(width / height, -1, 1)
    m = np.array([[matrix.GetElement(i, j) for j in range(4)] for i in range(4)])
    ndc = np.c_[points, np.ones(len(points))] @ m.T
    xy = ndc[:, :2] / ndc[:, 3:]
    lo, hi, margin = xy.min(axis=0), xy.max(axis=0), 0.04
    room = np.array([2.0 - 2 * margin, 2.0 - 2 * (top + bottom) - 2 * margin])
    scale = float(np.clip(np.min(room / np.maximum(hi - lo, 1e-9)), 0.1, 20.0))
    if camera.parallel_projection:
        camera.parallel_scale /= scale
    else:
        angle = np.radians(camera.view_angle) / 2
        camera.view_angle = float(np.degrees(2 * np.arctan(np.tan(angle) / scale)))
    centre = 0.5 * scale * (lo + hi) - np.array([0.0, bottom - top])
    camera.SetWindowCenter(*centre)
    plotter.reset_camera_clipping_range()


def _colour_range(values: np.ndarray, clim: tuple[float, float] | None) -> tuple[float, float]:
    """``clim`` or the data range, widened so a (nearly) constant field reads as one colour."""
    if clim is not None:
        return float(clim[0]), float(clim[1])
    finite = values[np.isfinite(values)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    half = max(0.5 * (hi - lo), 1e-2 * max(abs(lo), abs(hi)), 1e-12)
    mid = 0.5 * (lo + hi)
    return mid - half, mid + half


def render_png(
    grid: pyvista.UnstructuredGrid | None,
    path: str | Path,
    scalars: str | None = None,
    title: str = "",
    camera: str | Sequence[Any] = "iso",
    clim: tuple[float, float] | None = None,
    show_edges: bool = False,
    lines: Sequence[np.ndarray] | None = None,
    *,
    reference: bool = True,
    window_size: tuple[int, int] = (1200, 900),
    cmap: str = "viridis",
) -> None:
    """Render the surface off-screen to a PNG (no display needed); a no-op for ``None``.

    ``scalars`` names a cell or point array of ``grid``. ``camera`` is "iso", "top"/"xy",
    "front"/"xz", "yz", a view direction (3 numbers) or a pyvista camera position. ``lines``
    are polylines (N×3 arrays) drawn on top in red, e.g. creases. ``reference`` adds a light
    outline of the undeformed domain. The PNG is written under a temporary name and moved
    into place, so a reader never sees half a file.
    """
    if grid is None:
        return
    with offscreen_png(path, window_size) as plotter:
        _draw(plotter, grid, scalars, title, camera, clim, show_edges, lines, reference, cmap)


def _draw(  # the plotter is Any: pyvista's stubs reject its documented keyword tables
    plotter: Any,
    grid: pyvista.UnstructuredGrid,
    scalars: str | None,
    title: str,
    camera: str | Sequence[Any],
    clim: tuple[float, float] | None,
    show_edges: bool,
    lines: Sequence[np.ndarray] | None,
    reference: Any,
    cmap: str,
) -> None:
    """Put the surface, outline, lines, labels and camera of ``render_png`` into ``plotter``."""
    surface = _smooth_surface(grid)
    plotter.set_background("white")
    if scalars:
        # The bar's own title overlaps its labels and drops some glyphs: label it with a text.
        colour: dict[str, Any] = {"scalars": scalars, "cmap": cmap, "scalar_bar_args": _BAR}
        colour["clim"] = _colour_range(np.asarray(surface[scalars], dtype=float), clim)
        label = plotter.add_text(
            scalars, position=(0.5, 0.115), viewport=True, font_size=13, color="black"
        )
        label.GetTextProperty().SetJustificationToCentered()
    else:
        colour = {"color": "#8fb3d9"}
    plotter.add_mesh(surface, show_scalar_bar=bool(scalars), **_LOOK, **colour)
    if show_edges:
        plotter.add_mesh(_boundary_edges(surface), color="#303030", line_width=1)
    bounds = np.array(surface.bounds, dtype=float)
    if reference and REFERENCE in grid.point_data:
        outline = _reference_outline(grid)
        plotter.add_mesh(outline, color="#a0a0a0", line_width=2)
        lo = np.minimum(bounds[0::2], outline.bounds[0::2])
        hi = np.maximum(bounds[1::2], outline.bounds[1::2])
        bounds = np.column_stack([lo, hi]).reshape(-1)
    if title:
        plotter.add_text(title, position="upper_edge", font_size=14, color="black")
    plotter.add_axes(color="black", viewport=(0.0, 0.0, 0.14, 0.14))
    _set_camera(plotter, camera, bounds)
    shown = [surface.points, outline.points] if reference and REFERENCE in grid.point_data else []
    _fit(
        plotter, np.vstack(shown or [surface.points]), 0.07 if title else 0.0, 0.17 * bool(scalars)
    )
    towards = np.asarray(plotter.camera.position) - np.asarray(plotter.camera.focal_point)
    lift = 3e-3 * np.linalg.norm(np.ptp(surface.points, axis=0)) * towards / np.linalg.norm(towards)
    for polyline in lines or ():  # lifted a hair towards the eye, so the surface cannot hide it
        points = np.asarray(polyline, dtype=np.float64).reshape(-1, 3)
        if points.shape[0] >= 2:
            line = pyvista.lines_from_points(points + lift)
            plotter.add_mesh(line, color="#d62728", line_width=6, render_lines_as_tubes=True)


def plot_deformation(
    u: dolfinx.fem.Function[np.float64],
    path: str | Path,
    title: str = "",
    color_by: str | None = "curvature",
    camera: str | Sequence[Any] = "iso",
    clim: tuple[float, float] | None = None,
    show_edges: bool = False,
    lines: Sequence[np.ndarray] | None = None,
    length_mm: float | None = None,
    metric: Expr | None = None,
    exaggerate: bool = False,
    **options: Any,
) -> None:
    """Picture of the deformed plate, coloured or plain.

    Picture of the deformed plate coloured by |D²y| ("curvature"), the isometry-defect
    density ("defect", vector y only), the Gaussian curvature K = det(II)/det(∇yᵀ∇y) per cell
    ("gauss") or nothing. Collective; rank 0 writes ``path``.

    ``length_mm``: the length of a mesh unit in mm (a [material]'s); the colours are then in
    physical units, a curvature in 1/mm and K in 1/mm². ``metric``: the target metric G of a
    prestrained plate (``model.metric``), the "defect" is then |∇yᵀ∇y − G|. ``exaggerate``:
    a nearly flat shape is drawn with its heights multiplied by :func:`height_factor`, said in
    the title (the colours stay those of the true shape). ``options`` go to ``render_png``
    (reference, window_size, cmap).
    """
    if color_by not in (None, *COLOR_LABELS):
        raise ValueError(
            f"color_by must be None or one of {sorted(COLOR_LABELS)}, not {color_by!r}"
        )
    if u.function_space.mesh.topology.dim == 1:  # a rod's centreline
        plot_curve(u, path, title)
        return
    scalars = COLOR_LABELS[color_by] if color_by else None
    if scalars and not u.ufl_shape:  # a scalar deflection w
        scalars = scalars.replace("y", "w")
    densities: dict[str, Callable[[dolfinx.fem.Function[np.float64]], Array]] = {
        "curvature": bending_density,
        "defect": functools.partial(defect_density, metric=metric),
        "gauss": gauss_density,
    }
    values = {}
    if scalars and color_by:
        power = _LENGTH_POWER[color_by] if length_mm else 0
        if power:
            scalars += " (1/mm)" if power == 1 else f" (1/mm^{power})"
        values = {scalars: densities[color_by](u) / (length_mm or 1.0) ** power}
    grid = surface_grid(u, cell_values=values)
    if grid is not None and exaggerate:
        factor = height_factor(grid.points)
        if factor > 1:
            grid.points[:, 2] *= factor
            lines = [line * np.array([1.0, 1.0, factor]) for line in lines or []]
            title += f"  (heights × {factor:g})"
    render_png(grid, path, scalars, title, camera, clim, show_edges, lines, **options)


#: A shape lower than this part of its span is drawn with its heights exaggerated
#: (:func:`height_factor`), to about :data:`DRAWN_HEIGHT` of the span.
FLAT, DRAWN_HEIGHT = 0.05, 0.15


def height_factor(points: Array) -> float:
    """The factor by which a nearly flat shape's heights (x₃) are drawn: 1, or 2, 5, 10, 20 ….

    A plate whose out-of-plane extent is below :data:`FLAT` of its in-plane span (an FvK arch
    whose rise is a hundredth of its span) would look flat at true scale; its heights are
    multiplied by the largest of 1, 2, 5 × 10ᵏ that keeps them within :data:`DRAWN_HEIGHT` of
    the span.

    Args:
        points: the shape's points, (n, 3).

    Returns:
        The factor (1 for a shape that is not nearly flat, or exactly flat).
    """
    if not len(points) or not np.isfinite(points).all():
        return 1.0
    span = float(np.ptp(points[:, :2], axis=0).max())
    height = float(np.ptp(points[:, 2]))
    if height <= 0 or span <= 0 or height >= FLAT * span:
        return 1.0
    wanted = DRAWN_HEIGHT * span / height
    decade = 10.0 ** math.floor(math.log10(wanted))
    if decade > wanted:  # log10 rounded up just below a power of ten
        decade /= 10
    return max(m * decade for m in (1.0, 2.0, 5.0) if m * decade <= wanted)


def plot_curve(u: dolfinx.fem.Function[np.float64], path: str | Path, title: str = "") -> None:
    """Picture of a curve u: (0, L) → ℝ³ on a 1D mesh (a rod), as a matplotlib 3D line.

    The nodal values are gathered to rank 0 and joined in the order of the parameter s: the
    coordinate of an interval, the angle on a closed rod's polygon (a mesh in the plane), whose
    curve is closed (collective; rank 0 writes ``path``).
    """
    space = u.function_space
    owned = space.dofmap.index_map.size_local
    x = space.tabulate_dof_coordinates()[:owned]
    closed = space.mesh.geometry.dim > 1
    s = np.arctan2(x[:, 1], x[:, 0]) if closed else x[:, 0]
    points = u.x.array.reshape(-1, 3)[:owned]
    gathered = space.mesh.comm.gather((s, points), root=0)
    if gathered is None:
        return
    s_all = np.concatenate([g[0] for g in gathered])
    xyz = np.concatenate([g[1] for g in gathered])[np.argsort(s_all)]
    if closed:
        xyz = np.vstack([xyz, xyz[:1]])
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(6, 5))
    ax: Any = fig.add_subplot(projection="3d")
    ax.plot(xyz[:, 0], xyz[:, 1], xyz[:, 2], color="#1f77b4", linewidth=2.5)
    ax.scatter(*xyz[0], color="black", s=20)
    centre, radius = xyz.mean(axis=0), max(float(np.ptp(xyz, axis=0).max()) / 2, 1e-12)
    ax.set(xlim=centre[0] + [-radius, radius], ylim=centre[1] + [-radius, radius])
    ax.set(zlim=centre[2] + [-radius, radius], xlabel="x", ylabel="y", zlabel="z")
    ax.set_box_aspect((1, 1, 1))
    ax.set_title(title, fontsize=9)
    save_figure(fig, path, dpi=120)


__all__ = [
    "REFERENCE",
    "frames_to_gif",
    "montage",
    "offscreen_png",
    "plot_deformation",
    "render_png",
    "save_figure",
    "start_offscreen",
    "surface_grid",
]
