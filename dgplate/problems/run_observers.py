"""The observers of one run, made before its driver and handed to it.

Progress lines, checkpoints, the VTX series and the frames, in the order in which they hear of
each step. They are made from the problem's settings before the driver exists
(``model.driver(flow, observers.all, initial)``) and opened on the driver once it is restored
and the output folder exists.
"""

from __future__ import annotations

from pathlib import Path

from dgplate.io.output import CHECKPOINT
from dgplate.io.progress import ProgressPrinter
from dgplate.problems import pictures, report
from dgplate.problems.material import length_mm
from dgplate.problems.observers import Checkpoints, FrameWriter, SeriesWriter
from dgplate.problems.pictures import FRAMES
from dgplate.problems.prepare import Prepared
from dgplate.solvers.driver import Driver, Observer, RunResult


class RunObservers:
    """The runner's observers of one run: progress, checkpoints, VTX series and frames.

    Args:
        prepared: the problem, its output folder, resume point, mesh and model.
        wall0: ``time.perf_counter()`` at the start of the run.
    """

    def __init__(self, prepared: Prepared, wall0: float):
        problem, start, comm = prepared.problem, prepared.start, prepared.tagged.comm
        self.prepared = prepared
        earlier = prepared.earlier
        self.printer = ProgressPrinter(
            comm, problem.output.progress, start=wall0, earlier_steps=len(earlier)
        )
        earlier_wall = float(start.state.get("wall_time_s", 0.0)) if start is not None else 0.0
        self.checkpoints = Checkpoints(
            prepared.target.absolute() / CHECKPOINT,
            problem.identity(),
            earlier,
            (earlier_wall, wall0),
        )
        every, metric = problem.output.every, prepared.model.metric
        unit = length_mm(problem.material)
        self.series = SeriesWriter(every, metric, unit) if problem.output.vtx else None
        self.frames: FrameWriter | None = pictures.frames(problem, prepared.model)

    @property
    def all(self) -> list[Observer]:
        """The observers, in the order in which they hear of a step."""
        writers = [self.series, self.frames]
        return [self.printer, self.checkpoints, *(w for w in writers if w is not None)]

    def open(self, driver: Driver, folder: Path) -> None:
        """Start on the (restored) driver, writing into ``folder`` (collective).

        The series and the frames write the first state at once; a resumed run's frames are
        copied first from the output folder.
        """
        prepared = self.prepared
        problem, tagged = prepared.problem, prepared.tagged
        label = {
            "problem": problem.name,
            "model": problem.model.name,
            "cells": report.cells(tagged),
            "dofs": driver.num_dofs,
            "ranks": tagged.comm.size,
        }
        self.checkpoints.open(driver, label)
        if self.series is not None:
            self.series.open(driver, folder / "deformation.bp")
        if self.frames is not None:
            earlier = prepared.target / FRAMES if prepared.start is not None else None
            self.frames.open(driver, folder / FRAMES, earlier)

    def finish(self, driver: Driver, result: RunResult) -> None:
        """Tell every observer that the run ended with ``result`` (for a run with no step)."""
        for observer in self.all:
            observer.finish(driver, result)

    def close(self) -> None:
        """Close the VTX series (after an error on every rank; collective)."""
        if self.series is not None:
            self.series.close()
