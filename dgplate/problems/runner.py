"""Run a validated problem: mesh → model → driver → outputs (the CLI's engine, and the API).

The runner is written once for every model: the registry builds the model
(:mod:`dgplate.problems.registry`), the model builds its driver
(:class:`dgplate.solvers.driver.Driver`), and the observers here print progress and write the
VTX series and the checkpoints; at the end one writer commits ``history.csv``, the picture and
``summary.json``. ``run(load_problem("p.toml", {"flow.tau": 0.1}))`` does what
``dgplate run p.toml --set flow.tau=0.1`` does.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import ufl

from dgplate import compat, interrupt, mpi
from dgplate.errors import InputError
from dgplate.io import checkpoint
from dgplate.io.output import (
    CHECKPOINT,
    OutputDir,
    ProgressPrinter,
    bounding_box,
    print0,
    printing_ends_on_closed_pipe,
    write_history,
    write_json,
)
from dgplate.io.records import summary_is_current
from dgplate.mesh.tagged import TaggedMesh, load_geo, rectangle
from dgplate.models import starts
from dgplate.models.base import Model
from dgplate.problems import advice, sizing
from dgplate.problems.registry import MODELS
from dgplate.problems.specs import MeshSpec, Problem
from dgplate.solvers.driver import Driver

Initial = Callable[[np.ndarray], np.ndarray]


#: The summary's figures in a :class:`Result`'s one-line ``repr``.
_REPR_KEYS = ("steps", "energy", "isometry_defect")


@dataclass
class Result:
    """What :func:`run` returns: the summary (also ``summary.json``) and the final state.

    ``result["energy"]`` reads the summary. ``shape`` is the final deformation y: ω → ℝ³;
    ``fields`` holds every function of the final state (those a checkpoint stores);
    ``history`` the rows of ``history.csv``; ``folder`` the output folder. In a notebook a
    result shows itself as a table of its main figures and its ``final.png``.
    """

    summary: dict[str, Any]
    shape: dolfinx.fem.Function[np.float64] | None = None
    fields: dict[str, dolfinx.fem.Function[np.float64]] = field(default_factory=dict)
    history: list[dict[str, Any]] = field(default_factory=list)
    folder: Path | None = None

    def __getitem__(self, key: str) -> Any:
        return self.summary[key]

    def _repr_html_(self) -> str:
        """Jupyter's view: the main figures of summary.json and the final picture."""
        import base64
        import html

        keys = ["problem", "model", "converged", "reason", "steps", "energy"]
        keys += ["isometry_defect", "dofs", "ranks", "wall_time_s"]
        rows = "".join(
            f"<tr><th style='text-align:left'>{key}</th><td style='text-align:left'>"
            f"{html.escape(_shown(self.summary[key]))}</td></tr>"
            for key in keys
            if key in self.summary
        )
        out = f"<table>{rows}</table>"
        picture = self.folder / "final.png" if self.folder is not None else None
        if picture is not None and picture.is_file():
            data = base64.b64encode(picture.read_bytes()).decode("ascii")
            out += f"<img src='data:image/png;base64,{data}' style='max-width:640px'>"
        return f"<div style='display:flex;gap:1em;align-items:flex-start'>{out}</div>"

    def get(self, key: str, default: Any = None) -> Any:
        """``summary.get(key, default)``."""
        return self.summary.get(key, default)

    def __repr__(self) -> str:
        """One line: the run, how it ended, E_h and D_h (the summary has everything)."""
        s = self.summary
        shown = [f"{s.get('problem', '?')} ({s.get('model', '?')})"]
        if "converged" in s:
            shown.append("converged" if s["converged"] else "not converged")
        shown += [f"{key}={_shown(s[key])}" for key in _REPR_KEYS if key in s]
        folder = f", folder={str(self.folder)!r}" if self.folder is not None else ""
        return f"Result({', '.join(shown)}{folder})"


def build_mesh(spec: MeshSpec, comm: MPI.Comm) -> TaggedMesh:
    """The tagged mesh of the [mesh] section."""
    if spec.type == "rectangle":
        return rectangle(comm, spec.corners, spec.cells, spec.cell_type, spec.diagonal)
    return load_geo(comm, spec.file, spec.parameters, recombine=spec.recombine)


#: How long the ranks of a run that failed wait for each other before the clean-up that
#: needs them all (closing the VTX files, removing the staged outputs).
ERROR_AGREE_SECONDS = 5.0


class SeriesWriter:
    """VTX time series of ``driver.shape``, every ``every`` steps and at the end."""

    def __init__(self, driver: Driver, path: Path, every: int):
        from dgplate.io.vtx import DeformationWriter

        self.writer = DeformationWriter(path, driver.shape, comm=driver.comm)
        self.every = every
        self.writer.write(driver.time)

    def step(self, driver: Driver, record: Any) -> None:
        """Write every ``every`` steps."""
        if record.step % self.every == 0:
            self.writer.write(driver.time)

    def finish(self, driver: Driver, result: Any) -> None:
        """Write the final state (unless just written) and close the file."""
        if result.steps % self.every:
            self.writer.write(driver.time)
        self.close()

    def close(self) -> None:
        """Close the file (collective); the states written so far stay readable."""
        self.writer.close()


class FrameWriter:
    """Pictures of ``driver.shape`` at the start, every ``every`` steps and at the end; a GIF.

    The pictures are drawn by ``draw(path, title)`` (the run's final.png function) into
    ``folder`` as ``frame_<step>.png``; the title carries the step, the time, the energy and,
    with self-avoidance, the least distance of non-neighbouring points. On ``--resume`` the
    earlier run's frames (``earlier``) are copied first, so the GIF shows the whole run.
    Collective (the pictures gather the shape); rank 0 writes.
    """

    def __init__(
        self,
        draw: Callable[[Path, str], None],
        folder: Path,
        every: int,
        name: str,
        driver: Driver,
        earlier: Path | None = None,
    ):
        self.draw, self.folder, self.every, self.name = draw, folder, every, name
        self.comm: MPI.Comm = driver.comm
        if self.comm.rank == 0:
            folder.mkdir(parents=True, exist_ok=True)
            for old in sorted(earlier.glob("frame_*.png")) if earlier else ():
                shutil.copyfile(old, folder / old.name)
        self.last = -1
        self._frame(driver.step_count, {"time": driver.time})

    def _frame(self, step: int, row: dict[str, Any]) -> None:
        lines = [self.name, f"step {step}"]
        for key, label, fmt, line in _FRAME_FIGURES:
            value = row.get(key)
            if isinstance(value, float | int) and not isinstance(value, bool):
                if line == len(lines):
                    lines.append("")
                lines[line] += f"{', ' if lines[line] else ''}{label} = {value:{fmt}}"
        self.draw(self.folder / f"frame_{step:06d}.png", "\n".join(lines))
        self.last = step

    def step(self, driver: Driver, record: Any) -> None:
        """A frame every ``every`` steps."""
        if record.step % self.every == 0:
            self._frame(record.step, history_row(record))

    def finish(self, driver: Driver, result: Any) -> None:
        """A frame of the last state (unless just drawn), whatever ended the run."""
        if self.last != driver.step_count:
            row = history_row(result.history[-1]) if result.history else {"time": driver.time}
            self._frame(driver.step_count, row)

    def gif(self, path: Path) -> None:
        """Assemble the frames into ``path`` (rank 0; written atomically)."""
        from dgplate.io.plotting import frames_to_gif

        if self.comm.rank == 0:
            frames = sorted(self.folder.glob("frame_*.png"))
            frames_to_gif(frames, path, fps=FRAMES_PER_SECOND, comm=self.comm)


#: (history column, label, format, line) of the figures in a frame's title (three short
#: lines: the name; the step, time and energy; the least distance, with self-avoidance).
_FRAME_FIGURES = (
    ("time", "t", ".4g", 1),
    ("energy", "E", ".5g", 1),
    ("min_distance", "least distance", ".3g", 2),
)


def history_row(record: Any) -> dict[str, Any]:
    """A record as one row of history.csv: its fields, a nested table's entries as columns."""
    row: dict[str, Any] = {}
    for key, value in asdict(record).items():
        if isinstance(value, dict):
            row.update(value)
        else:
            row[key] = value
    return row


class Checkpoints:
    """Checkpoints of a driver every ``every`` steps (0: none on the way) and on ``save()``.

    The state holds the problem's input and fingerprint and the whole history so far (from the
    checkpoint a run resumed from, and this run's steps), so that a resumed run reports
    every step.
    """

    def __init__(
        self,
        directory: Path,
        every: int,
        problem: dict[str, Any],
        earlier: list[dict[str, Any]],
        wall: tuple[float, float] = (0.0, 0.0),
        label: dict[str, Any] | None = None,
    ):
        self.directory, self.every, self.problem = directory, every, problem
        self.fingerprint = checkpoint.fingerprint(problem)
        self.history: list[dict[str, Any]] = list(earlier)
        # (wall time of the runs this one resumes, perf_counter at this run's start)
        self.earlier_wall, self.wall0 = wall
        #: what ``dgplate show`` prints of a run that has a checkpoint but no summary yet
        self.label = label or {}

    def wall_time(self) -> float:
        """Seconds of wall time over this run and those it resumes."""
        return self.earlier_wall + time.perf_counter() - self.wall0

    def step(self, driver: Driver, record: Any) -> None:
        """Keep the record; save every ``every`` steps."""
        self.history.append(history_row(record))
        if self.every and record.step % self.every == 0:
            self.save(driver)

    def finish(self, driver: Driver, result: Any) -> None:
        """Nothing: the runner saves the final checkpoint once the outcome is known."""

    def save(self, driver: Driver, finished: bool = False, reason: str = "") -> None:
        """Write the checkpoint now (collective); ``finished``: the run converged (``reason``)."""
        state = {
            "fingerprint": self.fingerprint,
            "input": self.problem,
            "step": driver.step_count,
            "driver": driver.checkpoint_state(),
            "history": self.history,
            "finished": finished,
            "reason": reason,
            "wall_time_s": self.wall_time(),
            "label": self.label,
        }
        checkpoint.save(self.directory, driver.comm, driver.checkpoint_fields(), state)


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
        with interrupt.setting_up():
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
    report = {
        "problem": problem.name,
        "model": problem.model.name,
        "setting": _setting(problem, comm.size, _size(problem, tagged)),
        "cells": _cells(tagged),
        "dofs": _dofs(driver),
        "ranks": comm.size,
        "output": str(target.absolute()),
        "resume_step": driver.step_count if start is not None else None,
        "warnings": advice.before_run(problem, tagged, initial) if start is None else [],
    }
    driver.destroy()  # not on an error: it is collective, and the error may be on one rank
    return report


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
        _header(problem, target, start, comm, (size.cells, size.dofs))
    tagged, model = build_model(problem, comm)
    if header and not known:
        _header(problem, target, start, comm, _size(problem, tagged))
    return target, start, tagged, model


def build_model(problem: Problem, comm: MPI.Comm) -> tuple[TaggedMesh, Model]:
    """The problem's mesh and model on ``comm`` (collective)."""
    entry = MODELS[problem.model.name]
    own = entry.mesh  # a model with its own mesh (a rod) has no [mesh]
    tagged = own(problem.model, comm) if own else build_mesh(problem.mesh, comm)
    cells = _cells(tagged)
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
    with compiling(comm):
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
            "cells": _cells(tagged),
            "dofs": _dofs(driver),
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
        return _frames(job, model, driver, out)

    result, frames = _run_or_clean_up(driver, out, start, writers)
    if frames is not None:
        frames.gif(out.path / f"{problem.name}.gif")
    checkpoints.save(driver, finished=result.converged, reason=result.reason)
    summary = _summary(problem, tagged, model, driver, result, len(checkpoints.history))
    advice.warn(comm, advice.after_run(problem, driver, summary, _area(tagged)))
    write_history(comm, out.path / "history.csv", checkpoints.history)
    if problem.output.png:
        from dgplate.io.history_chart import plot_history  # pyvista: 1 s to import

        _picture(problem, model, driver, summary, out.path / "final.png")
        _held_pictures(problem, model, driver, out.path)
        if comm.rank == 0:
            flow = problem.flow
            plot_history(
                checkpoints.history, out.path / "history.png", problem.name, flow.tol, flow.stop
            )
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


def _shown(value: Any) -> str:
    """A summary value as a notebook shows it: floats to 6 significant digits."""
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _dofs(driver: Driver) -> int:
    return int(driver.summary().get("dofs", 0))


def _cells(tagged: TaggedMesh) -> int:
    return int(tagged.mesh.topology.index_map(tagged.mesh.topology.dim).size_global)


def _setting(problem: Problem, ranks: int, size: tuple[int, int]) -> str:
    """``model kirchhoff, 256 cells, 7,680 dofs on 2 rank(s)``: what a run solves, and where."""
    cells, dofs = size
    return f"model {problem.model.name}, {cells:,} cells, {dofs:,} dofs on {ranks} rank(s)"


def _size(problem: Problem, tagged: TaggedMesh) -> tuple[int, int]:
    """(cells, dofs) of the built mesh, before the forms (:func:`sizing.mesh_unknowns`)."""
    return _cells(tagged), sizing.mesh_unknowns(problem.model, problem.flow, tagged.mesh)


def _header(
    problem: Problem,
    target: Path,
    start: checkpoint.Checkpoint | None,
    comm: MPI.Comm,
    size: tuple[int, int],
) -> None:
    """The run's first line: what it solves, on how many ranks, and where it writes."""
    resumed = f", resumed at step {start.state['step']}" if start is not None else ""
    setting = _setting(problem, comm.size, size)
    print0(comm, f"dgplate: {problem.name}: {setting}{resumed}, output → {target.absolute()}")


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


def _area(tagged: TaggedMesh) -> float:
    """|Ω|, the area of the reference plate."""
    one = dolfinx.fem.form(dolfinx.fem.Constant(tagged.mesh, 1.0) * ufl.dx(domain=tagged.mesh))
    return float(tagged.comm.allreduce(dolfinx.fem.assemble_scalar(one), op=MPI.SUM))


def _frames(job: _Job, model: Model, driver: Driver, out: OutputDir) -> FrameWriter | None:
    """The observer drawing ``output.frames_every``'s frames (None: not asked for)."""
    problem = job.problem
    every = problem.output.frames_every
    if not every:
        return None

    def draw(path: Path, title: str) -> None:
        _draw(problem, model, driver, path, title, window_size=FRAME_SIZE, reference=False)

    earlier = job.target / FRAMES if job.start is not None else None
    frames = FrameWriter(draw, out.path / FRAMES, every, problem.name, driver, earlier)
    driver.observers.append(frames)
    return frames


#: The folder of the frames in the output folder, and their size in pixels (the frames leave
#: out final.png's outline of the reference domain, which would dwarf e.g. a knotted ribbon).
FRAMES = "frames"
FRAME_SIZE = (640, 480)
FRAMES_PER_SECOND = 5.0


def _picture(
    problem: Problem, model: Model, driver: Driver, summary: dict[str, Any], path: Path
) -> None:
    """final.png of the final shape (collective: the lines are gathered)."""
    energy, defect = summary.get("energy"), summary.get("isometry_defect")
    title = problem.name
    if isinstance(energy, float):
        title += f": E_h = {energy:.4e}"
    if isinstance(defect, float):
        title += f", D_h = {defect:.2e}"
    _draw(problem, model, driver, path, title)


def _held_pictures(problem: Problem, model: Model, driver: Driver, folder: Path) -> None:
    """``<name>.png`` of the shapes a model keeps besides the final one (collective).

    A thermal model's ``held_shapes``: the box closed at the switch (``at_switch.png``),
    where final.png shows it open again after cooling. Each is drawn as final.png is, from
    the driver's shape set to it for the picture and put back afterwards.
    """
    held = getattr(model, "held_shapes", None)
    shapes = held(driver) if held is not None else {}
    if not shapes:
        return
    final = driver.shape.x.array.copy()
    for name, (values, title) in shapes.items():
        driver.shape.x.array[:] = values
        _draw(problem, model, driver, folder / f"{name}.png", f"{problem.name}, {title}")
    driver.shape.x.array[:] = final


def _draw(
    problem: Problem, model: Model, driver: Driver, path: Path, title: str, **options: Any
) -> None:
    """A picture of the current shape: the model's own, else the coloured surface.

    Collective: the lines are gathered. ``options`` (``window_size``, ``reference``) go to the surface's
    picture; a model's own picture keeps its size.
    """
    from dgplate.io.plotting import plot_deformation

    own = getattr(model, "picture", None)  # a model's own picture (a rod: a striped tube)
    if own is not None:
        own(driver, path, title)
        return
    plot_deformation(
        driver.shape,
        path,
        title=title,
        color_by=problem.output.color_by,
        lines=model.lines(driver),
        **options,
    )


def _summary(
    problem: Problem,
    tagged: TaggedMesh,
    model: Model,
    driver: Driver,
    result: Any,
    steps: int,
) -> dict[str, Any]:
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
    summary["dolfinx_version"] = compat.version_string()
    summary["input"] = problem.raw
    return summary
