"""What a run writes once its driver has stopped, committed together into the output folder.

The GIF of the frames, the final checkpoint, history.csv, the pictures and summary.json (with
the wall time and the memory), and the warnings about the result.
"""

from __future__ import annotations

import time

from dgplate import mpi
from dgplate.io.output import OutputDir, write_history, write_json
from dgplate.problems import advice, pictures, report
from dgplate.problems.prepare import Prepared
from dgplate.problems.result import Result
from dgplate.problems.run_observers import RunObservers
from dgplate.solvers.driver import Driver, RunResult
from dgplate.solvers.steps import stopping_column


def write_outputs(
    prepared: Prepared,
    driver: Driver,
    observers: RunObservers,
    result: RunResult,
    out: OutputDir,
) -> Result:
    """Write the outputs of a run that ended with ``result`` and commit them (collective).

    Args:
        prepared: the problem, its mesh and model, and the checkpoint resumed (if any).
        driver: the driver, stopped (not destroyed).
        observers: the run's observers (their history and checkpoints, the frames).
        result: how the driver's run ended.
        out: the output folder, whose staged results are committed.

    Returns:
        The run's :class:`Result`.
    """
    problem, tagged, comm = prepared.problem, prepared.tagged, prepared.tagged.comm
    checkpoints = observers.checkpoints
    if observers.frames is not None:
        observers.frames.gif(out.path / f"{problem.name}.gif")
    checkpoints.save(driver, result.converged, result.reason, driver.extendable())
    summary = report.summary(
        problem, tagged, prepared.model, driver, result, len(checkpoints.history)
    )
    advice.warn(comm, advice.after_run(problem, driver, summary, report.area(tagged)))
    write_history(comm, out.path / "history.csv", checkpoints.history)
    if problem.output.png:
        from dgplate.io.angle_chart import plot_angles
        from dgplate.io.branch_chart import plot_branch
        from dgplate.io.history_chart import plot_history  # pyvista: 1 s to import

        pictures.picture(problem, prepared.model, driver, summary, out.path / "final.png")
        pictures.held_pictures(problem, prepared.model, driver, out.path)
        if comm.rank == 0:
            tol, column = stopping_column(problem.flow)
            plot_history(checkpoints.history, out.path / "history.png", problem.name, tol, column)
            plot_branch(checkpoints.history, out.path / "branch.png", problem.name)
            plot_angles(checkpoints.history, out.path / "angles.png", problem.name)
    summary["wall_time_s"] = checkpoints.wall_time()
    if prepared.start is not None:
        summary["wall_time_since_resume_s"] = time.perf_counter() - checkpoints.wall0
    summary["peak_memory_mb"] = mpi.peak_memory_mb(comm)
    write_json(comm, out.path / "summary.json", summary)
    out.commit()
    return Result(
        summary, driver.shape, driver.checkpoint_fields(), checkpoints.history, out.target
    )
