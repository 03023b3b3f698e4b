"""A finished run read back from its output folder, as the :class:`Result` ``run`` returned.

``dgplate.load_result("out/box")`` reads ``summary.json`` and ``history.csv`` and, with
``state=True`` (the default), rebuilds the problem's mesh and model from the input recorded
in the summary and restores the final state from the checkpoint: ``result.shape`` is then the
final deformation on this process's ranks, whatever number of ranks the run had. The run
on a cluster, the look at it in a notebook.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate.errors import InputError
from dgplate.io import checkpoint
from dgplate.io.output import CHECKPOINT
from dgplate.io.run_reader import read_history, read_summary, runs_in
from dgplate.problems.prepare import build_model
from dgplate.problems.result import Result
from dgplate.problems.specs import problem_from_dict


def load_result(folder: str | Path, comm: MPI.Comm = MPI.COMM_WORLD, state: bool = True) -> Result:
    """The :class:`Result` of the run whose outputs are in ``folder``.

    Args:
        folder: a dgplate output folder (``run``'s ``out``).
        comm: the ranks to hold the final state (collective on it when ``state``).
        state: rebuild the mesh and the model and restore the final state from the
            checkpoint (``shape``, ``fields``); False reads the files only.

    Returns:
        The run's summary, history and folder, with the final state when ``state``.

    Raises ``InputError`` for a folder dgplate did not write or that cannot be read; with
    ``state`` also for a run whose summary is missing or older than its checkpoint (still
    running, or killed: ``state=False`` reads what it has), a mesh file that cannot be found
    from here, or a checkpoint of another problem.
    """
    path = Path(folder)
    read = comm.bcast(_read_or_error(path, comm), root=0)
    if isinstance(read, InputError):
        raise read
    summary, history = read
    result = Result(summary, history=history, folder=path.absolute())
    if not state:
        return result
    if "input" not in summary or summary.get("stale"):
        raise InputError(
            f"{path}: the run has no summary for its last checkpoint (still running, or "
            "killed); load_result(..., state=False) reads what it has"
        )
    problem = problem_from_dict(summary["input"], summary["problem"])
    found = checkpoint.load(path / CHECKPOINT, comm, problem.identity(), purpose="load_result")
    _, model = build_model(problem, comm)
    driver = model.driver(problem.flow, [], None)
    driver.resume_from(found)
    result.shape, result.fields = driver.shape, driver.checkpoint_fields()
    driver.destroy()
    return result


def _read_or_error(
    path: Path, comm: MPI.Comm
) -> tuple[dict[str, Any], list[dict[str, Any]]] | InputError | None:
    """Summary and history, read on rank 0; None elsewhere.

    Any error comes back as an ``InputError`` to raise on every rank, so that no rank waits
    in a collective for one that failed.
    """
    if comm.rank != 0:
        return None
    try:
        summary = read_summary(path)
        inner = [run for run in runs_in([path]) if run != path]
        if summary["status"] == "started" and inner:  # a demo's or a study's folder
            names = ", ".join(str(run.relative_to(path)) for run in inner[:5])
            more = f" and {len(inner) - 5} more" if len(inner) > 5 else ""
            return InputError(f"{path} holds several runs ({names}{more}); load one of them")
        return summary, read_history(path)
    except InputError as err:
        return err
    except Exception as err:  # a damaged file: one line, on every rank
        return InputError(f"{path}: cannot read the run: {type(err).__name__}: {err}")
