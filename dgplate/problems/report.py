"""What a run says of itself: its first line, the compile notice and summary.json's figures."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import ufl

from dgplate import compat
from dgplate.io import checkpoint
from dgplate.io.output import bounding_box, print0
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import Model
from dgplate.problems import sizing
from dgplate.problems.specs import Problem
from dgplate.solvers.driver import Driver


def cells(tagged: TaggedMesh) -> int:
    """The mesh's cells over all ranks."""
    return int(tagged.mesh.topology.index_map(tagged.mesh.topology.dim).size_global)


def setting(problem: Problem, ranks: int, size: tuple[int, int]) -> str:
    """``model kirchhoff, 256 cells, 7,680 dofs on 2 rank(s)``: what a run solves, and where."""
    cells, dofs = size
    return f"model {problem.model.name}, {cells:,} cells, {dofs:,} dofs on {ranks} rank(s)"


def size_of(problem: Problem, tagged: TaggedMesh) -> tuple[int, int]:
    """(cells, dofs) of the built mesh, before the forms (:func:`sizing.mesh_unknowns`)."""
    return cells(tagged), sizing.mesh_unknowns(problem.model, problem.flow, tagged.mesh)


def header(
    problem: Problem,
    target: Path,
    start: checkpoint.Checkpoint | None,
    comm: MPI.Comm,
    size: tuple[int, int],
) -> None:
    """The run's first line: what it solves, on how many ranks, and where it writes."""
    resumed = f", resumed at step {start.state['step']}" if start is not None else ""
    setting_line = setting(problem, comm.size, size)
    print0(comm, f"dgplate: {problem.name}: {setting_line}{resumed}, output → {target.absolute()}")


@contextlib.contextmanager
def compiling(comm: MPI.Comm) -> Iterator[None]:
    """Say so on rank 0 when forms are compiled in the block (not found in the JIT cache).

    One line before the first compilation, and one with the time when the block ends: the
    first run of a problem's shape is silent for a while otherwise.
    """
    started: list[float] = []

    def announce() -> None:
        started.append(time.perf_counter())
        print0(
            comm, "dgplate: compiling forms (first run of this problem shape, cached afterwards)…"
        )

    with compat.on_first_compile(announce):
        yield
    if started:
        print0(comm, f"dgplate: forms compiled in {time.perf_counter() - started[0]:.1f} s")


def area(tagged: TaggedMesh) -> float:
    """|Ω|, the area of the reference plate."""
    one = dolfinx.fem.form(dolfinx.fem.Constant(tagged.mesh, 1.0) * ufl.dx(domain=tagged.mesh))
    return float(tagged.comm.allreduce(dolfinx.fem.assemble_scalar(one), op=MPI.SUM))


def summary(
    problem: Problem,
    tagged: TaggedMesh,
    model: Model,
    driver: Driver,
    result: Any,
    steps: int,
) -> dict[str, Any]:
    """summary.json's figures: the run, the driver's and the model's, the bounding box, the input.

    With a [material], ``physical`` holds the figures in SI units (docs/units.md).

    Args:
        problem: the problem run.
        tagged: its mesh.
        model: its model (``figures``).
        driver: the driver after the run (``summary``).
        result: the driver's run result (converged, reason, interrupted).
        steps: the steps of the whole run (with those before a resume).

    Returns:
        The summary; the runner adds the wall time and the memory.
    """
    mesh = tagged.mesh
    summary: dict[str, Any] = {
        "problem": problem.name,
        "model": problem.model.name,
        "cells": mesh.topology.index_map(mesh.topology.dim).size_global,
        "degree": getattr(problem.model, "degree", None),
        "ranks": driver.comm.size,
        "steps": steps,
        "converged": result.converged,
        "reason": result.reason,
        "interrupted": result.interrupted,
    }
    summary.update(driver.summary())
    summary["bbox"] = bounding_box(driver.shape)
    summary.update(model.figures(driver))
    if problem.material is not None:
        summary["physical"] = problem.material.figures(summary)
    summary["dolfinx_version"] = compat.version_string()
    summary["input"] = problem.raw
    return summary
