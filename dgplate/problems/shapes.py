"""A finished run's shape for the lab: a printable solid, and a comparison with a scan.

``dgplate export RUN --solid out.stl`` thickens the final mid-surface (:mod:`dgplate.io.solid`)
and writes binary STL (or PLY, VTU); ``dgplate compare RUN scan.xyz`` aligns a measured point cloud to it
(:mod:`dgplate.measure.alignment`) and reports the distances. Both read the run back with
:func:`dgplate.load_result` and work on rank 0. With a [material] the coordinates are in
millimetres (what slicers for 3D printers and most scanners use) and the thickness is the
layers'; without one they are in the mesh's units and ``thickness`` must be given.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from dgplate.errors import InputError
from dgplate.io import scan as scans
from dgplate.io import solid
from dgplate.measure.alignment import align
from dgplate.problems.results import load_result
from dgplate.problems.specs import problem_from_dict


def export_solid(
    folder: str | Path, path: str | Path, thickness: float | None, comm: MPI.Comm = MPI.COMM_WORLD
) -> dict[str, Any]:
    """Write the run's thickened sheet to ``path`` and return its figures (collective).

    Args:
        folder: the run's output folder.
        path: the .stl, .ply or .vtu file to write (not an existing file: none is overwritten).
        thickness: the sheet's thickness in the mesh's units; None: the [material]'s.
        comm: the ranks that read the run.

    Returns:
        On every rank: ``triangles``, ``watertight``, ``volume`` and ``area_times_thickness``
        (in the file's units) and ``units`` (``mm`` or ``mesh``).
    """
    target = Path(path)
    _new_file(target, "--solid", solid.FORMATS)
    if thickness is not None and not (thickness > 0 and math.isfinite(thickness)):
        raise InputError(f"--thickness must be a finite number > 0, got {thickness}")
    surface, scale, layers = _surface(folder, comm)
    if thickness is None:
        if layers is None:
            raise InputError(
                "--thickness is required: the run has no [material] to take the thickness from"
            )
        thickness = layers
    t = thickness * scale
    figures: dict[str, Any] | None = None
    if surface is not None:
        points, triangles = surface
        vertices, faces = solid.thicken(points, triangles, t)
        solid.write_solid(target, vertices, faces)
        figures = {
            "triangles": len(faces),
            "watertight": solid.is_watertight(faces),
            "volume": solid.volume(vertices, faces),
            "area_times_thickness": solid.area(points, triangles) * t,
            "units": _units(scale),
        }
    shared: dict[str, Any] = comm.bcast(figures, root=0)
    return shared


def compare_scan(
    folder: str | Path,
    path: str | Path,
    comm: MPI.Comm = MPI.COMM_WORLD,
    picture: str | Path | None = None,
) -> dict[str, Any]:
    """Align a scan to the run's mid-surface and measure their distances (collective).

    Args:
        folder: the run's output folder.
        path: the scan (:func:`dgplate.io.scan.read_scan`), in the run's units (mm with a
            [material], else the mesh's).
        comm: the ranks that read the run.
        picture: a PNG to draw the aligned scan in, coloured by its signed distance to the
            surface (not an existing file); None: none.

    Returns:
        On every rank: ``points``, ``rms`` and ``max`` (the scan's distances to the surface
        after the alignment), ``hausdorff`` (the larger of that and the surface's vertices'
        largest distance to the scan), ``rotation``, ``translation`` (the motion of the scan)
        ``angle_deg`` (its rotation angle), ``steps`` and ``units``.
    """
    if picture is not None:
        _new_file(Path(picture), "--map", (".png",))
    points = None if comm.rank else _or_error(lambda: scans.read_scan(Path(path)))
    points = comm.bcast(points, root=0)
    if isinstance(points, InputError):
        raise points
    surface, scale, _ = _surface(folder, comm)
    figures: dict[str, Any] | None = None
    if surface is not None:
        vertices, triangles = surface
        found = align(points, vertices, scans.SurfaceLocator(vertices, triangles))
        moved = points @ found.rotation.T + found.translation
        figures = {
            "points": len(points),
            "rms": found.rms,
            "max": float(found.distances.max()),
            "hausdorff": max(float(found.distances.max()), scans.largest_gap(vertices, moved)),
            "rotation": found.rotation.tolist(),
            "translation": found.translation.tolist(),
            "angle_deg": math.degrees(
                math.acos(max(-1.0, min(1.0, (np.trace(found.rotation) - 1) / 2)))
            ),
            "steps": found.steps,
            "units": _units(scale),
        }
        if picture is not None:
            title = f"{Path(path).name}: RMS {found.rms:.4g} {_units(scale)}"
            scans.plot_distances(surface, moved, Path(picture), title, _units(scale))
    shared: dict[str, Any] = comm.bcast(figures, root=0)
    return shared


def _new_file(target: Path, option: str, formats: tuple[str, ...]) -> None:
    """A file to write: of one of ``formats``, in an existing folder, not there yet."""
    if target.suffix.lower() not in formats:
        raise InputError(f"{option} {target}: the file must end in {', '.join(formats)}")
    if target.exists():
        raise InputError(f"{option} {target} exists; remove it or name another file")
    if not target.parent.is_dir():
        raise InputError(f"{option} {target}: no such folder {target.parent}")


def _or_error(read: Any) -> Any:
    """``read()``, or the InputError it raised (to raise on every rank)."""
    try:
        return read()
    except InputError as err:
        return err


def _surface(folder: str | Path, comm: MPI.Comm) -> tuple[Any, float, float | None]:
    """The run's mid-surface in the output's units, and its scales.

    Returns:
        (points and triangles on rank 0, None elsewhere; millimetres per mesh unit, or 1
        without a [material]; the [material]'s thickness in mesh units, or None).
    """
    summary = load_result(folder, comm, state=False).summary
    if summary.get("model") == "rod":
        raise InputError(f"{folder}: a rod's run has a centreline, not a sheet")
    result = load_result(folder, comm)
    material = problem_from_dict(result.summary["input"], result.summary["problem"]).material
    assert result.shape is not None
    surface = solid.mid_surface(result.shape)
    if material is None:
        return surface, 1.0, None
    scale = material.length_mm
    if surface is not None:
        surface = (surface[0] * scale, surface[1])
    return surface, scale, material.thickness / material.length


def _units(scale: float) -> str:
    return "mm" if scale != 1.0 else "mesh"
