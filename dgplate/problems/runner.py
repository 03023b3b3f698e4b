"""Run a validated problem: mesh → model → driver → outputs (the CLI's engine, and the API).

The runner is written once for every model: the registry builds the model
(:mod:`dgplate.problems.registry`), the model builds its driver
(:class:`dgplate.solvers.driver.Driver`), and the observers here print progress and write the
VTX series and the checkpoints; at the end one writer commits ``history.csv``, the picture and
``summary.json``. ``run(load_problem("p.toml", {"flow.tau": 0.1}))`` does what
``dgplate run p.toml --set flow.tau=0.1`` does.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from dgplate import compat, interrupt, mpi
from dgplate.errors import InputError
from dgplate.io import checkpoint
from dgplate.io.output import (
    CHECKPOINT,
    OutputDir,
    printing_ends_on_closed_pipe,
    write_history,
    write_json,
)
from dgplate.io.progress import ProgressPrinter
from dgplate.io.records import summary_is_current
from dgplate.mesh.tagged import TaggedMesh, load_geo, rectangle
from dgplate.models import starts
from dgplate.models.base import Model
from dgplate.problems import advice, pictures, report, sizing
from dgplate.problems.observers import Checkpoints, FrameWriter, SeriesWriter
from dgplate.problems.pictures import FRAMES
from dgplate.problems.registry import MODELS
from dgplate.problems.result import Result
from dgplate.problems.specs import MeshSpec, Problem
from dgplate.solvers.driver import Driver
from dgplate.solvers.steps import stopping_column

Initial = Callable[[np.ndarray], np.ndarray]


def build_mesh(spec: MeshSpec, comm: MPI.Comm) -> TaggedMesh:
    """The tagged mesh of the [mesh] section."""
    if spec.type == "rectangle":
        return rectangle(comm, spec.corners, spec.cells, spec.cell_type, spec.diagonal)
    return load_geo(comm, spec.file, spec.parameters, recombine=spec.recombine)


#: How long the ranks of a run that failed wait for each other before the clean-up that
#: needs them all (closing the VTX files, removing the staged outputs).
ERROR_AGREE_SECONDS = 5.0


def _resume_point(problem: Problem, target: Path, comm: MPI.Comm) -> checkpoint.Checkpoint:
    """The checkpoint to continue from; refuses another problem's or a finished run's.

    A run that converged but was stopped before its outputs were in place (no summary.json
    yet) is resumed: it takes no step and writes its outputs.
    """
    found = checkpoint.load(target / CHECKPOINT, comm, problem.identity())
    written = comm.bcast(summary_is_current(target) if comm.rank == 0 else None)
    if found.state.get("finished") and written:
        raise InputError(
            f"--resume: the run in {target} converged at step {found.state['step']}; "
            "nothing to resume"
        )
    return found


def run(
    problem: Problem,
    out: str | Path | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    initial: Initial | str | dict[str, Any] | None = None,
    force: bool = False,
    resume: bool = False,
    allow_large: bool = False,
) -> Result:
    """Solve ``problem``, write its outputs to ``out`` and return the :class:`Result`.

    Args:
        problem: a validated problem (:func:`dgplate.load_problem`).
        out: the output folder (default: ``output.dir``, else ``out/<problem name>``).
        comm: the communicator of the ranks that solve it.
        initial: x ↦ y(x), a start other than the flat plate (e.g. an exact fold), or
            ``"flat"`` or a start table as ``model.start`` (:mod:`dgplate.models.starts`);
            it takes precedence over ``model.start``.
        force: write into a folder of a user's files (deleting none of them).
        resume: continue from the checkpoint in the output folder, on any number of ranks.
        allow_large: run a problem that needs more memory than the job has, or a degree
            beyond :data:`~dgplate.problems.sizing.MAX_DEGREE` (refused otherwise).

    Everything that can be validated is validated before the output folder is touched, and
    the folder is checked before anything is computed (:class:`~dgplate.io.output.OutputDir`).
    A run that does not converge, fails or is interrupted by SIGINT/SIGTERM still writes its
    outputs, with ``converged = false`` and the reason, and a checkpoint.
    """
    wall0 = time.perf_counter()
    with interrupt.StopOnSignal(), printing_ends_on_closed_pipe():
        # every compilation of the set-up is announced, and given up on a signal
        with interrupt.setting_up(), report.compiling(comm):
            set_up = _set_up(problem, out, comm, force, resume, allow_large, header=True)
            target, start, tagged, model = set_up
            initial = starts.resolve(problem.model, initial, tagged.mesh)
            job = _Job(problem, tagged, target, initial, force, start, wall0)
            driver = _build_driver(job, model)
        return _solve(job, model, driver)


def check(
    problem: Problem,
    out: str | Path | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    initial: Initial | str | dict[str, Any] | None = None,
    force: bool = False,
    resume: bool = False,
    allow_large: bool = False,
) -> dict[str, Any]:
    """Validate ``problem`` as :func:`run` would, without solving it or writing anything.

    The output folder, the checkpoint (``resume``), the mesh, the model and its driver with
    the start's checks (an obstacle the start penetrates, a self-intersecting start) are all
    built and checked, so every ``InputError`` that :func:`run` would raise is raised here:
    the check for a cluster job before it queues. Returns what the run would be: problem,
    model, cells, dofs, ranks (and ``setting``, the three in words, as ``run`` prints them),
    the output folder, the step a resume starts from (None) and the warnings ``run`` would
    print. Collective on ``comm``.

    Args: those of :func:`run`; nothing is written, so ``force`` only accepts a user's folder
    and ``resume`` checks the checkpoint there.
    """
    # a compilation left unfinished by a signal is given up (the next run compiles it)
    with interrupt.setting_up(), compat.on_first_compile(lambda: None):
        target, start, tagged, model = _set_up(problem, out, comm, force, resume, allow_large)
        initial = starts.resolve(problem.model, initial, tagged.mesh)
        driver = model.driver(problem.flow, [], initial)
    _start(driver, start, target)
    checked = {
        "problem": problem.name,
        "model": problem.model.name,
        "setting": report.setting(problem, comm.size, report.size_of(problem, tagged)),
        "cells": report.cells(tagged),
        "dofs": report.dofs(driver),
        "ranks": comm.size,
        "output": str(target.absolute()),
        "resume_step": driver.step_count if start is not None else None,
        "warnings": advice.before_run(problem, tagged, initial) if start is None else [],
    }
    driver.destroy()  # not on an error: it is collective, and the error may be on one rank
    return checked


def _set_up(
    problem: Problem,
    out: str | Path | None,
    comm: MPI.Comm,
    force: bool,
    resume: bool,
    allow_large: bool,
    header: bool = False,
) -> tuple[Path, checkpoint.Checkpoint | None, TaggedMesh, Model]:
    """The output folder (checked), the checkpoint to resume from, the mesh and the model.

    A problem too large for the job's memory is refused before anything is built
    (:func:`dgplate.problems.sizing.guard`). ``header``: print the run's first line as soon
    as its size is known: before the mesh is built when the keys say it exactly.
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
    target = Path(out or problem.output.dir or f"out/{problem.name}")
    key = "--out" if out is not None else "output.dir" if problem.output.dir else "output folder"
    OutputDir.check(comm, target, force, resume, key)
    start = _resume_point(problem, target, comm) if resume else None
    size = sizing.guard(problem, comm, allow_large)
    known = size is not None and not size.approximate
    if header and size is not None and known:
        report.header(problem, target, start, comm, (size.cells, size.dofs))
    tagged, model = build_model(problem, comm)
    if header and not known:
        report.header(problem, target, start, comm, report.size_of(problem, tagged))
    return target, start, tagged, model


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


def _start(
    driver: Driver, start: checkpoint.Checkpoint | None, target: Path
) -> list[dict[str, Any]]:
    """Restore ``driver`` from the checkpoint (if any); returns the history so far."""
    if start is None:
        return []
    start.restore(driver.checkpoint_fields())
    driver.restore_state(start.state["driver"])
    if driver.remaining_steps() <= 0 and not start.state.get("finished"):
        driver.destroy()  # collective, and safe: every rank restored the same state
        raise InputError(
            f"--resume: the run in {target} spent its step budget already "
            f"({driver.step_count} steps); raise flow.max_steps to continue it"
        )
    return list(start.state["history"])


@dataclass
class _Finished:
    """How a resumed run ends that had converged before it was stopped: with no step."""

    reason: str
    converged: bool = True
    steps: int = 0
    history: list[Any] = field(default_factory=list)
    interrupted: int = 0


@dataclass
class _Job:
    """What one run is asked to do: the problem on its mesh, where to write, how to start."""

    problem: Problem
    tagged: TaggedMesh
    target: Path
    initial: Initial | None
    force: bool
    start: checkpoint.Checkpoint | None
    wall0: float


def _build_driver(job: _Job, model: Model) -> Driver:
    """The driver: its spaces and forms (compiled, where new, said so)."""
    comm = job.tagged.comm
    printer = ProgressPrinter(comm, job.problem.output.progress, start=job.wall0)
    return model.driver(job.problem.flow, [printer], job.initial)


def _solve(job: _Job, model: Model, driver: Driver) -> Result:
    # no destroy() on an error: it is collective, and the error may have hit one rank only
    result = _run_driver(job, model, driver)
    driver.destroy()
    return result


def _run_driver(job: _Job, model: Model, driver: Driver) -> Result:
    problem, tagged, target, start = job.problem, job.tagged, job.target, job.start
    initial, force, wall0 = job.initial, job.force, job.wall0
    comm = tagged.comm
    earlier = _start(driver, start, target)
    for observer in driver.observers:
        if isinstance(observer, ProgressPrinter):
            observer.earlier_steps = len(earlier)
    if start is None:
        advice.warn(comm, advice.before_run(problem, tagged, initial))
    out = OutputDir(comm, target, force, resume=start is not None)
    earlier_wall = float(start.state.get("wall_time_s", 0.0)) if start is not None else 0.0
    checkpoints = Checkpoints(
        out.checkpoint_dir,
        driver.checkpoint_every,
        problem.identity(),
        earlier,
        (earlier_wall, wall0),
        label={
            "problem": problem.name,
            "model": problem.model.name,
            "cells": report.cells(tagged),
            "dofs": report.dofs(driver),
            "ranks": comm.size,
        },
    )
    driver.observers.append(checkpoints)

    def writers() -> FrameWriter | None:
        """The VTX series and the frames (both write their first state at once)."""
        if problem.output.vtx:
            driver.observers.append(
                SeriesWriter(driver, out.path / "deformation.bp", problem.output.every)
            )
        earlier = job.target / FRAMES if job.start is not None else None
        return pictures.frames(problem, model, driver, out.path / FRAMES, earlier)

    result, frames = _run_or_clean_up(driver, out, start, writers)
    if frames is not None:
        frames.gif(out.path / f"{problem.name}.gif")
    checkpoints.save(driver, finished=result.converged, reason=result.reason)
    summary = report.summary(problem, tagged, model, driver, result, len(checkpoints.history))
    advice.warn(comm, advice.after_run(problem, driver, summary, report.area(tagged)))
    write_history(comm, out.path / "history.csv", checkpoints.history)
    if problem.output.png:
        from dgplate.io.history_chart import plot_history  # pyvista: 1 s to import

        pictures.picture(problem, model, driver, summary, out.path / "final.png")
        pictures.held_pictures(problem, model, driver, out.path)
        if comm.rank == 0:
            tol, column = stopping_column(problem.flow)
            plot_history(checkpoints.history, out.path / "history.png", problem.name, tol, column)
    summary["wall_time_s"] = checkpoints.wall_time()
    if start is not None:
        summary["wall_time_since_resume_s"] = time.perf_counter() - wall0
    summary["peak_memory_mb"] = mpi.peak_memory_mb(comm)
    write_json(comm, out.path / "summary.json", summary)
    out.commit()
    return Result(
        summary, driver.shape, driver.checkpoint_fields(), checkpoints.history, out.target
    )


def _run_or_clean_up(
    driver: Driver,
    out: OutputDir,
    start: checkpoint.Checkpoint | None,
    writers: Callable[[], FrameWriter | None],
) -> tuple[Any, FrameWriter | None]:
    """Open the ``writers``, then ``driver.run()``: the outcome and the frame writer.

    On an error the staged outputs go (the checkpoints stay). The VTX files must be closed
    before their folder goes (ADIOS2 would abort the process at exit); closing is collective,
    so it happens only when every rank has the error (else the job is ending anyway, and the
    next run into the folder removes the staging folder). A run resumed from a finished
    checkpoint takes no step: it only writes its outputs.
    """
    agree = driver.comm.Dup()  # for the error path only: no collective of the run matches it
    try:
        frames = writers()
        if start is not None and start.state.get("finished"):
            result: Any = _Finished(start.state.get("reason") or "converged before the resume")
            for observer in driver.observers:
                observer.finish(driver, result)
        else:
            result = driver.run()
    except BaseException:
        if mpi.all_arrive(agree, ERROR_AGREE_SECONDS):
            for observer in driver.observers:
                if isinstance(observer, SeriesWriter):
                    observer.close()
            out.discard()
        raise  # ``agree`` is not freed: freeing is collective, and this rank is failing
    agree.Free()
    return result, frames
