"""Run a validated problem: mesh → model → driver → outputs (the CLI's engine, and the API).

The runner is written once for every model: :mod:`~dgplate.problems.prepare` checks the
output folder and builds the model (:mod:`dgplate.problems.registry`); the run's observers
(:mod:`~dgplate.problems.run_observers`: progress, checkpoints, VTX series, frames) are made
and handed to the driver that the model builds (:class:`dgplate.solvers.driver.Driver`), after
the model's calibration, if any; at the end :mod:`~dgplate.problems.outputs` commits
``history.csv``, the pictures and ``summary.json``.
``run(load_problem("p.toml", {"flow.tau": 0.1}))`` does what ``dgplate run p.toml --set
flow.tau=0.1`` does.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from dgplate import compat, interrupt, mpi
from dgplate.io.output import OutputDir, printing_ends_on_closed_pipe
from dgplate.models import starts
from dgplate.problems import advice, report
from dgplate.problems.outputs import write_outputs
from dgplate.problems.prepare import Prepared, prepare, restore
from dgplate.problems.result import Result
from dgplate.problems.run_observers import RunObservers
from dgplate.problems.specs import Problem
from dgplate.solvers.driver import Driver, RunOutcome, RunResult

Initial = Callable[[np.ndarray], np.ndarray]

#: How long the ranks of a run that failed wait for each other before the clean-up that
#: needs them all (closing the VTX files, removing the staged outputs).
ERROR_AGREE_SECONDS = 5.0


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

    Returns:
        The run's summary figures, history, final state and output folder.

    Everything that can be validated is validated before the output folder is touched, and
    the folder is checked before anything is computed (:class:`~dgplate.io.output.OutputDir`).
    A run that does not converge, fails or is interrupted by SIGINT/SIGTERM still writes its
    outputs, with ``converged = false`` and the reason, and a checkpoint.
    """
    wall0 = time.perf_counter()
    with interrupt.StopOnSignal(), printing_ends_on_closed_pipe():
        # every compilation of the set-up is announced, and given up on a signal
        with interrupt.setting_up(), report.compiling(comm):
            prepared = prepare(problem, out, comm, (force, resume, allow_large), header=True)
            initial = starts.resolve(problem.model, initial, prepared.tagged.mesh)
            observers = RunObservers(prepared, wall0)
            prepared.model.calibrate(problem.flow)  # a solve of its own (the box's α)
            driver = prepared.model.driver(problem.flow, observers.all, initial)
        # no destroy() on an error: it is collective, and the error may have hit one rank only
        result = _solve(prepared, driver, observers, initial, force)
        driver.destroy()
        return result


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
    the check for a cluster job before it queues. Collective on ``comm``.

    Args:
        problem: a validated problem (:func:`dgplate.load_problem`).
        out: the output folder :func:`run` would write (checked, not written).
        comm: the communicator of the ranks that would solve it.
        initial: the start, as for :func:`run` (its checks are made).
        force: accept a folder of a user's files, as :func:`run` would.
        resume: check the checkpoint in the output folder, as a resumed run would.
        allow_large: accept a problem beyond the size guard, as :func:`run` would.

    Returns:
        What the run would be: problem, model, cells, dofs, ranks (and ``setting``, the
        three in words, as ``run`` prints them), the output folder, the step a resume starts
        from (None), the warnings ``run`` would print and, for a model calibrated before its
        run (``model.alpha = 'calibrate'``), what the run will calibrate (``calibration``;
        None: nothing), which check does not solve for.
    """
    # a compilation left unfinished by a signal is given up (the next run compiles it)
    with interrupt.setting_up(), compat.on_first_compile(lambda: None):
        prepared = prepare(problem, out, comm, (force, resume, allow_large))
        tagged, start = prepared.tagged, prepared.start
        initial = starts.resolve(problem.model, initial, tagged.mesh)
        driver = prepared.model.driver(problem.flow, [], initial)
    restore(driver, prepared)
    checked = {
        "problem": problem.name,
        "model": problem.model.name,
        "setting": report.setting(problem, comm.size, report.size_of(problem, tagged)),
        "cells": report.cells(tagged),
        "dofs": driver.num_dofs,
        "ranks": comm.size,
        "output": str(prepared.target.absolute()),
        "resume_step": driver.step_count if start is not None else None,
        "warnings": advice.before_run(problem, tagged, initial) if start is None else [],
        "calibration": prepared.model.pending_calibration(),
    }
    driver.destroy()  # not on an error: it is collective, and the error may be on one rank
    return checked


def _solve(
    prepared: Prepared,
    driver: Driver,
    observers: RunObservers,
    initial: Initial | None,
    force: bool,
) -> Result:
    """Restore the driver, run it with its outputs staged, and write and commit them."""
    problem, start, comm = prepared.problem, prepared.start, prepared.tagged.comm
    restore(driver, prepared)
    if start is None:
        advice.warn(comm, advice.before_run(problem, prepared.tagged, initial))
    out = OutputDir(comm, prepared.target, force, resume=start is not None)
    result = _run_or_clean_up(driver, out, observers)
    return write_outputs(prepared, driver, observers, result, out)


def _run_or_clean_up(driver: Driver, out: OutputDir, observers: RunObservers) -> RunResult:
    """Open the ``observers`` on the driver, then ``driver.run()``: the outcome.

    On an error the staged outputs go (the checkpoints stay). The VTX files must be closed
    before their folder goes (ADIOS2 would abort the process at exit); closing is collective,
    so it happens only when every rank has the error (else the job is ending anyway, and the
    next run into the folder removes the staging folder). A run resumed from a checkpoint
    that had converged before it was stopped takes no step: it only writes its outputs.
    """
    start = observers.prepared.start
    agree = driver.comm.Dup()  # for the error path only: no collective of the run matches it
    try:
        observers.open(driver, out.path)
        if start is not None and start.state.get("finished"):
            reason = start.state.get("reason") or "converged before the resume"
            result: RunResult = RunOutcome(True, reason, 0)
            observers.finish(driver, result)
        else:
            result = driver.run()
    except BaseException:
        if mpi.all_arrive(agree, ERROR_AGREE_SECONDS):
            observers.close()
            out.discard()
        raise  # ``agree`` is not freed: freeing is collective, and this rank is failing
    agree.Free()
    return result
