"""What a run and a check do before the driver: the output folder, the resume point, the model.

:func:`prepare` checks the arguments and the output folder, loads the checkpoint to resume
from, refuses a problem too large for the job and builds the mesh and the model: everything
that may raise an ``InputError`` before the output folder is touched. :func:`restore` then
puts a built driver back at the checkpoint's state.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate.errors import InputError
from dgplate.io import checkpoint
from dgplate.io.output import CHECKPOINT, OutputDir
from dgplate.io.run_reader import summary_is_current
from dgplate.mesh.tagged import TaggedMesh, load_geo, rectangle
from dgplate.models.base import Model
from dgplate.problems import report, sizing
from dgplate.problems.registry import MODELS
from dgplate.problems.specs import MeshSpec, Problem
from dgplate.solvers.driver import Driver


@dataclass
class Prepared:
    """A problem ready for its driver: the output folder, the resume point, mesh and model."""

    problem: Problem
    target: Path  # the output folder, checked
    start: checkpoint.Checkpoint | None  # the checkpoint to resume from (None: a new run)
    tagged: TaggedMesh
    model: Model

    @property
    def earlier(self) -> list[dict[str, Any]]:
        """The history rows of the runs resumed ([] for a new run)."""
        return list(self.start.state["history"]) if self.start is not None else []


def build_mesh(spec: MeshSpec, comm: MPI.Comm) -> TaggedMesh:
    """The tagged mesh of the [mesh] section."""
    if spec.type == "rectangle":
        return rectangle(comm, spec.corners, spec.cells, spec.cell_type, spec.diagonal)
    return load_geo(comm, spec.file, spec.parameters, recombine=spec.recombine)


def build_model(problem: Problem, comm: MPI.Comm) -> tuple[TaggedMesh, Model]:
    """The problem's mesh and model on ``comm`` (collective)."""
    entry = MODELS[problem.model.name]
    own = entry.mesh  # a model with its own mesh (a rod) has no [mesh]
    tagged = own(problem.model, comm) if own else build_mesh(problem.mesh, comm)
    cells = report.cells(tagged)
    if cells < comm.size:
        raise InputError(
            f"mesh: {cells} cell(s) for {comm.size} ranks: every rank needs a cell; refine "
            "the mesh or run on fewer ranks"
        )
    return tagged, entry.build(problem.model, tagged)


def prepare(
    problem: Problem,
    out: str | Path | None,
    comm: MPI.Comm,
    options: tuple[bool, bool, bool],
    header: bool = False,
) -> Prepared:
    """The output folder (checked), the checkpoint to resume from, the mesh and the model.

    Args:
        problem: the problem (anything else is an ``InputError``).
        out: the output folder given (None: ``output.dir``, else ``out/<problem name>``).
        comm: the ranks of the run.
        options: (force, resume, allow_large), as :func:`dgplate.problems.runner.run` has them.
        header: print the run's first line as soon as its size is known: before the mesh
            is built when the keys say it exactly.

    Returns:
        What the driver is built from. A problem too large for the job's memory is refused
        before anything is built (:func:`dgplate.problems.sizing.guard`).
    """
    force, resume, allow_large = options
    folder = target(problem, out)
    key = "--out" if out is not None else "output.dir" if problem.output.dir else "output folder"
    OutputDir.check(comm, folder, force, resume, key)
    start = _resume_point(problem, folder, comm) if resume else None
    size = sizing.guard(problem, comm, allow_large)
    known = size is not None and not size.approximate
    if header and size is not None and known:
        report.header(problem, folder, start, comm, (size.cells, size.dofs))
    tagged, model = build_model(problem, comm)
    if header and not known:
        report.header(problem, folder, start, comm, report.size_of(problem, tagged))
    return Prepared(problem, folder, start, tagged, model)


def target(problem: Problem, out: str | Path | None, default: str | None = None) -> Path:
    """The output folder of ``problem`` given ``out``; ``InputError`` for a wrong argument.

    Args:
        problem: what :func:`dgplate.run` (or ``converge``) was given as the problem.
        out: the ``out`` argument: a folder path, or None.
        default: the folder without ``out`` (``{name}``: the problem's name); None:
            ``output.dir``, else ``out/<name>``.

    Returns:
        The folder.
    """
    if not isinstance(problem, Problem):
        raise InputError(
            "the problem must be a dgplate.Problem (dgplate.load_problem(path) reads a file), "
            f"got {type(problem).__name__}"
        )
    if out is not None and not isinstance(out, str | os.PathLike):
        raise InputError(f"out must be a folder path, got {type(out).__name__} {out!r}")
    if out is not None and not os.fspath(out).strip():
        raise InputError(
            "--out is empty: give a folder, or omit --out for output.dir (else out/<name>)"
        )
    if default is not None:
        return Path(out or default.format(name=problem.name))
    return Path(out or problem.output.dir or f"out/{problem.name}")


def _resume_point(problem: Problem, target: Path, comm: MPI.Comm) -> checkpoint.Checkpoint:
    """The checkpoint to continue from; refuses another problem's or a finished run's.

    A run that converged but was stopped before its outputs were in place (no summary.json
    yet) is resumed: it takes no step and writes its outputs. A path that ended only because
    its points were spent (``extendable``) goes on, if its budget was raised (:func:`restore`).
    """
    found = checkpoint.load(target / CHECKPOINT, comm, problem.identity())
    written = comm.bcast(summary_is_current(target) if comm.rank == 0 else None)
    state = found.state
    if state.get("finished") and state.get("extendable") and (written or extends(problem, state)):
        state["finished"] = False  # it goes on from its last point (restore checks the budget)
    elif state.get("finished") and written:
        raise InputError(
            f"--resume: the run in {target} converged at step {state['step']}; nothing to resume"
        )
    return found


def extends(problem: Problem, state: Mapping[str, Any]) -> bool:
    """Whether a checkpoint's path, which spent its points, is asked for more by ``problem``.

    Args:
        problem: the problem resumed.
        state: the checkpoint's state (``extendable``: the path ended only by its budget).

    Returns:
        True when ``problem``'s ``path.steps`` exceeds the points the path has.
    """
    path = getattr(problem.model, "path", None)
    more = int(getattr(path, "steps", 0)) > int(state.get("step", 0))
    return bool(state.get("extendable")) and more


def restore(driver: Driver, prepared: Prepared) -> None:
    """Put ``driver`` back at the checkpoint's state (nothing for a new run; collective).

    A resumed run whose step budget is spent (and which had not converged) is an
    ``InputError`` naming the budget's key (``flow.max_steps``, a path's ``path.steps``).
    """
    start = prepared.start
    if start is None:
        return
    driver.resume_from(start)
    if driver.remaining_steps() <= 0 and not start.state.get("finished"):
        driver.destroy()  # collective, and safe: every rank restored the same state
        raise InputError(
            f"--resume: the run in {prepared.target} spent its step budget already "
            f"({driver.step_count} steps); raise {driver.budget_key} to continue it"
        )
