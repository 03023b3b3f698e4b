"""A folder of several runs (a demo's, a convergence study's): claiming it, running or reusing each.

Each run goes into a subfolder, so that the whole can be resumed wherever it was stopped.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate.io import checkpoint
from dgplate.io.output import CHECKPOINT, OutputDir, is_dgplate_output, print0, write_marker
from dgplate.io.run_reader import summary_is_current
from dgplate.problems.prepare import extends
from dgplate.problems.result import Result
from dgplate.problems.results import load_result
from dgplate.problems.runner import run
from dgplate.problems.specs import Problem


def claim(folder: Path, force: bool, comm: MPI.Comm) -> None:
    """Take ``folder``, which holds several runs and pictures of its own. Collective.

    It is refused as a run's output folder is, when it holds a user's files (unless
    ``force``; a folder whose subfolders are all dgplate's is an earlier run of the same),
    and otherwise marked as dgplate's (listing no file, so that no later run deletes
    anything in it): the runs go into its subfolders, and the pictures there replace only
    those of an earlier run.

    Args:
        folder: the folder of the runs.
        force: write into a folder of a user's files (deleting none of them).
        comm: the ranks of the runs.
    """
    if comm.rank == 0 and folder.is_dir() and not is_dgplate_output(folder):
        runs = [p for p in folder.iterdir() if p.is_dir()]
        if runs and all(is_dgplate_output(p) for p in runs):  # an earlier run of the same
            write_marker(folder, [])
    comm.barrier()
    OutputDir.check(comm, folder, force)
    if comm.rank == 0:
        folder.mkdir(parents=True, exist_ok=True)
        if not is_dgplate_output(folder) and not any(folder.iterdir()):
            write_marker(folder, [])
    comm.barrier()


def run_or_reuse(
    problem: Problem,
    out: Path,
    comm: MPI.Comm,
    force: bool = False,
    resume: bool = False,
    **options: Any,
) -> tuple[Result, bool]:
    """:func:`dgplate.run` into ``out``; with ``resume``, a run done there earlier is reused.

    With ``resume``, a run that has a checkpoint in ``out`` continues from it, one that
    finished there returns its :class:`Result` read back (:func:`dgplate.load_result`)
    without running again, and one that has not started yet starts. Collective.

    Args:
        problem: a validated problem.
        out: the run's output folder.
        comm: the ranks of the run.
        force: write into a folder of a user's files.
        resume: reuse or continue what ``out`` holds.
        options: more keywords for :func:`dgplate.run` (``initial``, ``allow_large``).

    Returns:
        The result, and whether it was reused (no step taken).

    Raises:
        InputError: ``out`` is not dgplate's (without ``force``), or with ``resume`` holds
            the checkpoint of another problem.
    """
    state = _checkpoint_state(problem, out, comm) if resume else None
    if state is not None and state.get("finished") and not extends(problem, state):
        done = comm.bcast(summary_is_current(out) if comm.rank == 0 else None)
        if done:  # else it was stopped while writing its outputs: the resume writes them
            print0(comm, f"{out}: finished earlier, its results are reused")
            return load_result(out, comm), True
    result = run(problem, out=out, comm=comm, force=force, resume=state is not None, **options)
    return result, False


def _checkpoint_state(problem: Problem, out: Path, comm: MPI.Comm) -> dict[str, Any] | None:
    """The state of the checkpoint of ``problem`` in ``out``, or ``None`` if there is none.

    Collective. Raises ``InputError`` for another problem's checkpoint.
    """
    folder = out / CHECKPOINT
    exists = comm.bcast((folder / checkpoint.STATE_FILE).is_file() if comm.rank == 0 else None)
    if not exists:
        return None
    return checkpoint.load(folder, comm, problem.identity()).state
