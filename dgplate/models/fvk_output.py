"""Outputs of an FvK run: summary.json, history.csv, a VTX series and a PNG of the deflection.

Built on the shared blocks: ``dgplate.io.output.OutputDir`` (files appear only once the run is
over, also when a load step failed: then with ``converged = false``),
``dgplate.io.vtx.DeformationWriter`` (VTX, or XDMF without ADIOS2) and
``dgplate.measure.fields.surface_grid`` + ``dgplate.io.plotting.render_png`` (off-screen picture). The
plate's deformation is y = (x₁ + u₁, x₂ + u₂, w) in [DG_k]³, so ParaView shows FvK runs like
every other model. Collective calls run on every rank; rank 0 writes the small files.
"""

from __future__ import annotations

import csv
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import ufl

from dgplate import compat
from dgplate.io.output import OutputDir, write_json
from dgplate.io.plotting import render_png
from dgplate.io.vtx import DeformationWriter
from dgplate.measure.fields import surface_grid
from dgplate.models.fvk import allreduce_array

HISTORY_COLUMNS = ("step", "load_factor", "load", "w_max", "w_center", "iterations", "energy")


def deformation(problem) -> tuple[dolfinx.fem.Function, dolfinx.fem.Expression]:
    """y = x + (u₁, u₂, w) in [DG_k]³ (empty) and the expression to interpolate into it."""
    V = dolfinx.fem.functionspace(problem.mesh, ("DG", problem.params.degree, (3,)))
    w, u = ufl.split(problem.state)
    x = ufl.SpatialCoordinate(problem.mesh)
    y = ufl.as_vector([x[0] + u[0], x[1] + u[1], w])
    expr = dolfinx.fem.Expression(y, compat.interpolation_points(V.element))
    return dolfinx.fem.Function(V, name="deformation"), expr


def deformed_bbox(y: dolfinx.fem.Function) -> list[list[float]]:
    """[[xmin, ymin, zmin], [xmax, ymax, zmax]] of the deformed mid-surface (DOF values)."""
    n = y.function_space.dofmap.index_map.size_local
    points = y.x.array.reshape(-1, 3)[:n]
    comm = y.function_space.mesh.comm
    lo = allreduce_array(comm, points.min(axis=0, initial=np.inf), op=MPI.MIN)
    hi = allreduce_array(comm, points.max(axis=0, initial=-np.inf), op=MPI.MAX)
    return [lo.tolist(), hi.tolist()]


def summary(problem, wall_time: float, failure: str | None = None) -> dict:
    """The run's figures for summary.json (docs/design.md §7 plus the FvK ones). Collective.

    ``failure`` (the SolverError's message) makes it ``converged = false`` with that reason;
    the figures are then those of the last converged load step (None if there is none).
    """
    p, hist = problem.params, problem.history
    y, expr = deformation(problem)
    y.interpolate(expr)
    last = hist[-1] if hist else dict.fromkeys(("load", "w_max", "w_center", "energy"))
    w_center = last["w_center"]
    return {
        "model": "fvk",
        "dofs": int(problem.dofs),
        "ranks": int(problem.comm.size),
        "steps": len(hist),
        "load_steps": len(p.load_factors()),
        "load_factors": [h["load_factor"] for h in hist],
        "converged": failure is None,
        "reason": failure or f"all {len(hist)} load steps converged",
        "load": last["load"],
        "pressure": p.pressure,
        "w_max": last["w_max"],
        "w_center": w_center,
        "probe": [float(c) for c in problem.probe],
        "w_center_over_thickness": None if w_center is None else w_center / p.thickness,
        "D": p.D,
        "history": [{c: h[c] for c in HISTORY_COLUMNS} for h in hist],
        "snes_iterations": [h["iterations"] for h in hist],
        "residual_norms": [h["residual_norms"] for h in hist],
        "energy": last["energy"],
        "isometry_defect": None,
        "bbox": deformed_bbox(y),
        "wall_time_s": wall_time,
        "dolfinx_version": compat.version_string(),
        "parameters": dict(vars(p)),
    }


def plot_deflection(problem, path: Path) -> None:
    """The surface (x₁, x₂, s·w) coloured by w, s chosen so the relief is visible. Collective."""
    w = problem.collapse_w()
    xy = problem.mesh.geometry.x[:, :2]
    lo = allreduce_array(problem.comm, xy.min(axis=0), op=MPI.MIN)
    hi = allreduce_array(problem.comm, xy.max(axis=0), op=MPI.MAX)
    wmax = abs(problem.w_max()) or 1.0
    scale = 0.2 * float(np.max(hi - lo)) / wmax
    relief = dolfinx.fem.Function(w.function_space)
    relief.x.array[:] = scale * w.x.array
    grid = surface_grid(relief, point_values={"w": w})
    title = f"FvK deflection w (max {wmax:.4g}), relief x{scale:.3g}"
    render_png(grid, path, "w", title)


class Writer:
    """The output directory of one run, staged until ``finish``."""

    def __init__(self, problem, out_dir, force: bool = False, resume: bool = False):
        self.problem, self.comm = problem, problem.comm
        self.stage = OutputDir(self.comm, Path(out_dir), force, resume)
        self.y, self.expr = deformation(problem)
        self.series = DeformationWriter(self.stage.path / "fvk.bp", self.y, comm=self.comm)

    def write_step(self, lam: float) -> None:
        self.y.interpolate(self.expr)
        self.series.write(lam)

    def finish(self, summary: dict) -> Path:
        self.series.close()
        plot_deflection(self.problem, self.stage.path / "final.png")
        summary["png"] = "final.png"
        summary["series"] = self.series.path.name
        write_json(self.comm, self.stage.path / "summary.json", summary)
        if self.comm.rank == 0:
            with open(self.stage.path / "history.csv", "w", newline="") as f:
                rows = csv.writer(f)
                rows.writerow(HISTORY_COLUMNS)
                for h in self.problem.history:
                    rows.writerow([h[c] for c in HISTORY_COLUMNS])
        return self.stage.commit()

    def abort(self) -> None:
        """Drop the staged results; not collective (see :meth:`OutputDir.discard`)."""
        self.stage.discard()
