"""Run a validated problem: mesh → model → gradient flow → outputs (the CLI's engine).

``run_problem`` is also the Python API: ``run_problem(load_problem("p.toml", ["flow.tau=0.1"]))``
does what ``dgplate run p.toml --set flow.tau=0.1`` does.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from dgplate import compat, interrupt
from dgplate.errors import InputError
from dgplate.io import checkpoint
from dgplate.io.output import (
    CHECKPOINT,
    OutputDir,
    ProgressPrinter,
    bounding_box,
    print0,
    write_history,
    write_json,
)
from dgplate.mesh.tagged import TaggedMesh, load_geo, rectangle
from dgplate.problems import advice
from dgplate.problems.registry import MODELS
from dgplate.problems.specs import MeshSpec, Problem
from dgplate.solvers.flow import FlowResult, FlowSettings, GradientFlow, StepInfo


def build_mesh(spec: MeshSpec, comm: MPI.Comm) -> TaggedMesh:
    if spec.type == "rectangle":
        return rectangle(comm, spec.corners, spec.cells, spec.cell_type, spec.diagonal)
    return load_geo(comm, spec.file, spec.parameters, recombine=spec.recombine)


def max_cell_diameter(tagged: TaggedMesh) -> float:
    """The largest cell diameter (τ = 'h' in problem files, as in the published runs)."""
    mesh = tagged.mesh
    tdim = mesh.topology.dim
    num_owned = mesh.topology.index_map(tdim).size_local
    local = mesh.h(tdim, np.arange(num_owned, dtype=np.int32))
    return float(mesh.comm.allreduce(float(local.max(initial=0.0)), op=MPI.MAX))


class _SeriesWriter:
    """VTX time series of the deformation, every ``every`` steps and at the end."""

    def __init__(self, flow: GradientFlow, path: Path, every: int):
        from dgplate.io.vtx import DeformationWriter

        self.writer = DeformationWriter(path, flow.y, comm=flow.comm)
        self.every = every
        self.writer.write(flow.time)

    def step(self, flow: GradientFlow, info: StepInfo) -> None:
        if info.step % self.every == 0:
            self.writer.write(info.time)

    def finish(self, flow: GradientFlow, result: FlowResult) -> None:
        if result.steps % self.every:
            self.writer.write(flow.time)
        self.writer.close()


class FlowCheckpoints:
    """Checkpoints of a flow every ``every`` steps (0: none on the way) and on ``save()``.

    The state holds the problem's fingerprint and the whole history so far (``earlier``, from
    the checkpoint a run resumed from, and this run's steps), so that a resumed run reports
    every step.
    """

    def __init__(
        self,
        directory: Path,
        every: int,
        fingerprint: str,
        earlier: list[StepInfo] | None = None,
        increases: list[int] | None = None,
    ):
        self.directory, self.every, self.fingerprint = directory, every, fingerprint
        self.history: list[StepInfo] = list(earlier or [])
        self.increases: list[int] = list(increases or [])

    def step(self, flow: GradientFlow, info: StepInfo) -> None:
        self.history.append(info)
        if self.every and info.step % self.every == 0:
            self.save(flow)

    def finish(self, flow: GradientFlow, result: FlowResult) -> None:
        self.increases += result.energy_increases

    def save(self, flow: GradientFlow, finished: bool = False) -> None:
        """Write the checkpoint now (collective)."""
        state = {
            "fingerprint": self.fingerprint,
            "step": flow.step_count,
            "flow": flow.checkpoint_state(),
            "history": [asdict(info) for info in self.history],
            "energy_increases": self.increases,
            "finished": finished,
        }
        checkpoint.save(self.directory, flow.comm, flow.checkpoint_fields(), state)


def _resume_point(problem: Problem, target: Path, comm: MPI.Comm) -> checkpoint.Checkpoint:
    """The checkpoint to continue from; refuses another problem's or a finished run's."""
    found = checkpoint.load(target / CHECKPOINT, comm, checkpoint.fingerprint(problem.raw))
    done = int(found.state["step"])
    if found.state.get("finished"):
        raise InputError(
            f"--resume: the run in {target} converged at step {done}; nothing to resume"
        )
    if MODELS[problem.model.name].kind == "flow" and done >= problem.flow.max_steps:
        raise InputError(
            f"--resume: the run in {target} spent flow.max_steps = {problem.flow.max_steps} "
            f"steps already ({done}); raise flow.max_steps to continue it"
        )
    return found


@dataclass
class Result:
    """What :func:`run` returns: the summary (also ``summary.json``) and the final state.

    ``result["energy"]`` reads the summary. ``shape`` is the final deformation y: ω → ℝ³;
    ``fields`` holds every function of the final state (those a checkpoint stores).
    """

    summary: dict[str, Any]
    shape: dolfinx.fem.Function | None = None
    fields: dict[str, dolfinx.fem.Function] = field(default_factory=dict)
    history: list[Any] = field(default_factory=list)

    def __getitem__(self, key: str) -> Any:
        return self.summary[key]

    def get(self, key: str, default: Any = None) -> Any:
        """``summary.get``."""
        return self.summary.get(key, default)


def run(
    problem: Problem,
    out: str | Path | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    initial: Callable[[np.ndarray], np.ndarray] | None = None,
    force: bool = False,
    resume: bool = False,
) -> Result:
    """Solve ``problem`` and write its outputs to ``out`` (default: ``output.dir``).

    What ``dgplate run`` does, from Python: see :func:`run_problem`.
    """
    return run_problem(problem, out, comm, initial, force, resume)


def run_problem(
    problem: Problem,
    out_dir: str | Path | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    initial: Callable[[np.ndarray], np.ndarray] | None = None,
    force: bool = False,
    resume: bool = False,
) -> dict[str, Any]:
    """Solve ``problem`` and write its outputs; returns the summary (also summary.json).

    Everything that can be validated is validated before the output directory is created;
    the output folder is checked before anything is computed (:class:`OutputDir`: ``force``
    writes into a folder of a user's files, deleting none of them). A flow that does not
    converge, or is interrupted by SIGINT/SIGTERM, still writes its outputs, with
    ``converged = false`` and the reason, and a checkpoint; ``resume`` continues from the
    checkpoint in the output folder, on any number of ranks. ``initial`` (x ↦ y(x), e.g. an
    exact fold) starts the flow from a given shape instead of the flat plate.
    """
    wall0 = time.perf_counter()
    target = Path(out_dir or problem.output.dir or f"out/{problem.name}")
    OutputDir.check(comm, target, force, resume)
    start = _resume_point(problem, target, comm) if resume else None
    with interrupt.StopOnSignal():
        tagged = build_mesh(problem.mesh, comm)
        entry = MODELS[problem.model.name]
        if entry.kind == "newton":
            from dgplate.models.fvk import run_fvk

            problem.model.validate(tagged)
            summary = run_fvk(
                tagged,
                problem.model,
                out_dir=target,
                comm=comm,
                progress=bool(problem.output.progress),
                force=force,
                start=start,
                fingerprint=checkpoint.fingerprint(problem.raw),
            )
            summary.setdefault("problem", problem.name)
            return summary
        return _run_flow(problem, tagged, target, comm, initial, force, start, wall0)


def _run_flow(
    problem: Problem,
    tagged: TaggedMesh,
    target: Path,
    comm: MPI.Comm,
    initial: Callable[[np.ndarray], np.ndarray] | None,
    force: bool,
    start: checkpoint.Checkpoint | None,
    wall0: float,
) -> dict[str, Any]:
    model = MODELS[problem.model.name].build(problem.model, tagged)
    tau = max_cell_diameter(tagged) if problem.flow.tau == "h" else float(problem.flow.tau)
    settings = FlowSettings(
        tau=tau,
        tol=problem.flow.tol,
        max_steps=problem.flow.max_steps,
        l2_metric=problem.flow.l2,
        solver_options=problem.flow.solver,
        multiplier_degree=problem.flow.multiplier_degree,
        projection_steps=problem.flow.projection_steps,
        linear_solver=problem.flow.linear_solver,
        refactor_its=problem.flow.refactor_its,
        edge_constraint=problem.flow.edge_constraint,
    )
    observers: list = []
    if problem.output.progress:
        observers.append(ProgressPrinter(comm, problem.output.progress))
    flow = model.driver(settings, observers, initial)
    if start is None:
        advice.warn(comm, advice.before_flow(problem, tagged, initial))
    earlier: list[StepInfo] = []
    increases: list[int] = []
    if start is not None:
        start.restore(flow.checkpoint_fields())
        flow.restore_state(start.state["flow"])
        earlier = [StepInfo(**row) for row in start.state["history"]]
        increases = list(start.state["energy_increases"])
    out = OutputDir(comm, target, force, resume=start is not None)
    resumed = f", resumed at step {flow.step_count}" if start is not None else ""
    print0(
        comm,
        f"dgplate: {problem.name}: model {problem.model.name}, {flow.num_dofs} dofs on "
        f"{comm.size} rank(s), τ = {tau:.4g}{resumed}, output → {out.target}",
    )
    checkpoints = FlowCheckpoints(
        out.checkpoint_dir,
        problem.flow.checkpoint_every,
        checkpoint.fingerprint(problem.raw),
        earlier,
        increases,
    )
    flow.observers.append(checkpoints)
    if problem.output.vtx:
        flow.observers.append(
            _SeriesWriter(flow, out.path / "deformation.bp", problem.output.every)
        )
    try:
        result = flow.run(problem.flow.max_steps - flow.step_count)
    except BaseException:
        out.discard()  # the checkpoints stay
        raise
    checkpoints.save(flow, finished=result.converged)
    result.history, result.energy_increases = checkpoints.history, checkpoints.increases
    result.steps = len(result.history)
    summary = make_summary(problem, flow, result, tagged, wall0)
    advice.warn(comm, advice.after_flow(flow, summary))
    summary.update(model.figures(flow))
    write_history(comm, out.path / "history.csv", result.history)
    if problem.output.png:
        from dgplate.io.plotting import plot_deformation

        title = f"{problem.name}: E_h = {result.energy:.4e}, D_h = {result.defect:.2e}"
        lines = model.lines(flow)  # collective
        plot_deformation(
            flow.y,
            out.path / "final.png",
            title=title,
            color_by=problem.output.color_by,
            lines=lines,
        )
    summary["wall_time_s"] = time.perf_counter() - wall0
    write_json(comm, out.path / "summary.json", summary)
    out.commit()
    flow.destroy()
    return summary


def make_summary(
    problem: Problem, flow: GradientFlow, result: FlowResult, tagged, wall0: float
) -> dict:
    mesh = tagged.mesh
    return {
        "problem": problem.name,
        "model": problem.model.name,
        "dofs": flow.num_dofs,
        "cells": mesh.topology.index_map(mesh.topology.dim).size_global,
        "degree": problem.model.degree,
        "ranks": flow.comm.size,
        "steps": result.steps,
        "converged": result.converged,
        "reason": result.reason,
        "interrupted": result.interrupted,
        "energy": result.energy,
        "isometry_defect": result.defect,
        "bbox": bounding_box(flow.y),
        "tau": flow.tau,
        "energy_increases": result.energy_increases,
        "solver_fallbacks": sum(info.fallbacks for info in result.history),
        "wall_time_s": time.perf_counter() - wall0,
        "dolfinx_version": compat.version_string(),
        "input": problem.raw,
    }
