"""The runner's observers of a driver: the VTX series, the frames and the checkpoints.

Each has ``step(driver, record)`` and ``finish(driver, result)`` (the driver's observer
protocol, :class:`dgplate.solvers.driver.Observer`). Each is made before the driver, from the
problem's settings, and handed to it; ``open(driver, …)`` then starts it on the driver's state
(restored, on ``--resume``) once the output folder exists, before the first step.
"""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

from mpi4py import MPI

from ufl.core.expr import Expr

from dgplate.io import checkpoint
from dgplate.solvers.driver import Driver

#: Frames per second of the GIF made of the frames.
FRAMES_PER_SECOND = 5.0


class SeriesWriter:
    """VTX time series of ``driver.shape``, every ``every`` steps and at the end.

    ``metric``: the plate's target metric G (None: none), for its Gaussian curvature field.
    ``length_mm``: one mesh unit in mm (a ``[material]``'s): the series in mm; None: mesh units.
    """

    def __init__(self, every: int, metric: Expr | None = None, length_mm: float | None = None):
        self.every, self.metric, self.length_mm = every, metric, length_mm
        self.writer: Any = None  # a DeformationWriter once opened

    def open(self, driver: Driver, path: Path) -> None:
        """Create the series at ``path`` and write the first state (collective)."""
        from dgplate.io.vtx import DeformationWriter

        self.writer = DeformationWriter(
            path, driver.shape, comm=driver.comm, metric=self.metric, length_mm=self.length_mm
        )
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
        """Close the file, if open (collective); the states written so far stay readable."""
        if self.writer is not None:
            self.writer.close()


class FrameWriter:
    """Pictures of ``driver.shape`` at the start, every ``every`` steps and at the end; a GIF.

    The pictures are drawn by ``draw(driver, path, title)`` (the run's final.png function)
    into the folder given to :meth:`open` as ``frame_<step>.png``; the title carries the step,
    the time, the energy and, with self-avoidance, the least distance of non-neighbouring
    points. Collective (the pictures gather the shape); rank 0 writes.
    """

    def __init__(self, draw: Callable[[Driver, Path, str], None], every: int, name: str):
        self.draw, self.every, self.name = draw, every, name
        self.folder = Path()
        self.last = -1

    def open(self, driver: Driver, folder: Path, earlier: Path | None = None) -> None:
        """Draw the first frame into ``folder``, after the ``earlier`` run's (on ``--resume``).

        The earlier run's frames are copied first, so that the GIF shows the whole run.
        """
        self.folder = folder
        self.comm: MPI.Comm = driver.comm
        if self.comm.rank == 0:
            folder.mkdir(parents=True, exist_ok=True)
            for old in sorted(earlier.glob("frame_*.png")) if earlier else ():
                shutil.copyfile(old, folder / old.name)
        self._frame(driver, driver.step_count, {"time": driver.time})

    def _frame(self, driver: Driver, step: int, row: dict[str, Any]) -> None:
        lines = [self.name, f"step {step}"]
        for key, label, fmt, line in _FRAME_FIGURES:
            value = row.get(key)
            if isinstance(value, float | int) and not isinstance(value, bool):
                if line == len(lines):
                    lines.append("")
                lines[line] += f"{', ' if lines[line] else ''}{label} = {value:{fmt}}"
        self.draw(driver, self.folder / f"frame_{step:06d}.png", "\n".join(lines))
        self.last = step

    def step(self, driver: Driver, record: Any) -> None:
        """A frame every ``every`` steps."""
        if record.step % self.every == 0:
            self._frame(driver, record.step, history_row(record))

    def finish(self, driver: Driver, result: Any) -> None:
        """A frame of the last state (unless just drawn), whatever ended the run."""
        if self.last != driver.step_count:
            row = history_row(result.history[-1]) if result.history else {"time": driver.time}
            self._frame(driver, driver.step_count, row)

    def gif(self, path: Path) -> None:
        """Assemble the frames into ``path`` (rank 0; written atomically)."""
        from dgplate.io.images import frames_to_gif

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
    """Checkpoints of a driver every ``driver.checkpoint_every`` steps and on ``save()``.

    The state holds the problem's input and fingerprint and the whole history so far (from the
    checkpoint a run resumed from, and this run's steps), so that a resumed run reports
    every step.
    """

    def __init__(
        self,
        directory: Path,
        problem: dict[str, Any],
        earlier: list[dict[str, Any]],
        wall: tuple[float, float] = (0.0, 0.0),
    ):
        self.directory, self.problem = directory, problem
        self.fingerprint = checkpoint.fingerprint(problem)
        self.history: list[dict[str, Any]] = list(earlier)
        # (wall time of the runs this one resumes, perf_counter at this run's start)
        self.earlier_wall, self.wall0 = wall
        self.every = 0  # steps between checkpoints (0: none on the way), set by ``open``
        #: what ``dgplate show`` prints of a run that has a checkpoint but no summary yet
        self.label: dict[str, Any] = {}

    def open(self, driver: Driver, label: dict[str, Any]) -> None:
        """Checkpoint ``driver`` every ``driver.checkpoint_every`` steps, with ``label``."""
        self.every, self.label = driver.checkpoint_every, label

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

    def save(
        self, driver: Driver, finished: bool = False, reason: str = "", extendable: bool = False
    ) -> None:
        """Write the checkpoint now (collective).

        Args:
            driver: the run's driver.
            finished: the run converged.
            reason: why the run ended, in words.
            extendable: it ended only because its budget was spent (:meth:`Driver.extendable`):
                a resume with a larger budget goes on.
        """
        state = {
            "fingerprint": self.fingerprint,
            "input": self.problem,
            "step": driver.step_count,
            "driver": driver.checkpoint_state(),
            "history": self.history,
            "finished": finished,
            "extendable": extendable,
            "reason": reason,
            "wall_time_s": self.wall_time(),
            "label": self.label,
        }
        checkpoint.save(self.directory, driver.comm, driver.checkpoint_fields(), state)
