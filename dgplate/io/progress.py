"""Progress lines of a run on rank 0: when to print, the time elapsed and the time left."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, TextIO

from mpi4py import MPI

from dgplate.io.output import count_of, print0

if TYPE_CHECKING:
    from dgplate.solvers.driver import Driver, Record, RunResult


#: ``output.progress = "auto"``: a progress line when both this many seconds and this many
#: steps have passed since the last one (whichever gives fewer lines), and at the first step;
#: and whenever ``AUTO_MAX_SECONDS`` have passed, so that slow steps are not silent.
AUTO_SECONDS = 1.0
AUTO_STEPS = 10
AUTO_MAX_SECONDS = 10.0
#: Steps of the stopping test's recent decay from which the time to the tolerance is estimated.
DECAY_WINDOW = 20


class ProgressPrinter:
    """Rank-0 progress: record lines, each with the time elapsed and left, and how it ended.

    ``every``: ``"auto"`` prints the first step's line, then one when at least
    :data:`AUTO_SECONDS` and :data:`AUTO_STEPS` steps have passed since the last, or
    :data:`AUTO_MAX_SECONDS`, and the last step's line; an integer n ≥ 1 every n-th step's line; 0 none. A record that is
    ``notable`` (a path's special point) is printed whenever ``every`` is not 0. The
    final line (converged or not, after how many steps) is always printed. Only rank 0
    prints, so only rank 0 decides, from its own clock: no collective, nothing for the ranks
    to agree on.

    The time left: a driver with a path of known length (a continuation in α, a heating
    schedule, load steps) has ``path_progress() -> (fraction done, name of the end)``; the
    estimate is the pace since the first step (which holds the compilation and the first
    factorisation, so it is left out): ``(12 s; α = 1 in ~3 min)``. Otherwise a driver with
    a stopping test (``stopping_test(record)``: the flows' rate or ‖P DE_h‖) is extrapolated
    from the test's geometric decay over the last :data:`DECAY_WINDOW` steps:
    ``(12 s; ΔE/τ < 1e-06 in ~85 steps, ~40 s)``, or ``step budget spent in ~…`` when that
    comes first.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        every: int | str = "auto",
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.perf_counter,
        start: float | None = None,
        earlier_steps: int = 0,
    ):
        self.comm, self.every, self.stream, self.clock = comm, every, stream or sys.stdout, clock
        self.start = clock() if start is None else start
        #: steps done before a resume, so that the last line counts them all
        self.earlier_steps = earlier_steps
        self._path_start: tuple[float, float] | None = None  # (clock, fraction) at step one
        self._last: tuple[int, float] | None = None  # (step, clock) of the last line printed
        self._decay: list[tuple[int, float, float]] = []  # (step, clock, log of the test)

    def step(self, driver: Driver, record: Record) -> None:
        """Print the record's line when it is due, with the time elapsed and left (rank 0)."""
        if self.comm.rank != 0:
            return
        now = self.clock()
        left = self._path_left(driver, now) or self._decay_left(driver, record, now)
        notable = self.every != 0 and getattr(record, "notable", False)
        if notable or self._due(record.step, now):
            self._print(f"{record.line()}  ({duration(now - self.start)}{left})")
            self._last = (record.step, now)

    def note(self, line: str) -> None:
        """Print a line of the run's own (the metric start's) unless ``every`` is 0 (rank 0)."""
        if self.every != 0:
            self._print(line)

    def _due(self, step: int, now: float) -> bool:
        """Whether the line of ``step`` is printed (see the class)."""
        if self.every != "auto":
            return bool(self.every) and step % int(self.every) == 0
        if self._last is None:
            return True
        step0, time0 = self._last
        if now - time0 >= AUTO_MAX_SECONDS:
            return True
        return step - step0 >= AUTO_STEPS and now - time0 >= AUTO_SECONDS

    def _print(self, line: str) -> None:
        print0(self.comm, line, file=self.stream)

    def _path_left(self, driver: Driver, now: float) -> str:
        """``"; α = 1 in ~3 min"``, or ``""`` without a path or a pace yet."""
        done = driver.path_progress()
        if done is None:
            return ""
        fraction, end = done
        if self._path_start is None:
            self._path_start = (now, fraction)
            return ""
        start, first = self._path_start
        if not first < fraction < 1.0 or now <= start:
            return ""
        seconds = (now - start) * (1.0 - fraction) / (fraction - first)
        return f"; {end} in ~{duration(seconds)}"

    def _decay_left(self, driver: Driver, record: Record, now: float) -> str:
        """``"; ΔE/τ < 1e-06 in ~85 steps, ~40 s"`` from the test's recent decay, or ``""``."""
        test = driver.stopping_test(record)
        if test is None:
            return ""
        value, tol, name, budget = test
        if not (math.isfinite(value) and value > 0):
            return ""
        self._decay = [*self._decay[-DECAY_WINDOW:], (record.step, now, math.log(value))]
        if len(self._decay) < 6 or value <= tol:  # 5 steps after the first, with compiling
            return ""
        (step0, time0, log0), (step1, time1, log1) = self._decay[1], self._decay[-1]
        if log1 >= log0:
            return ""
        per_step = (log0 - log1) / (step1 - step0)
        steps = (log1 - math.log(tol)) / per_step
        pace = (time1 - time0) / (step1 - step0)
        if steps > budget - record.step:
            steps = budget - record.step
            return f"; step budget spent in ~{steps:.0f} steps, ~{duration(pace * steps)}"
        return f"; {name} < {tol:g} in ~{steps:.0f} steps, ~{duration(pace * steps)}"

    def finish(self, driver: Driver, result: RunResult) -> None:
        """Print the last step's line (if due), how the run ended, and energy increases."""
        last = result.history[-1] if result.history else None
        if last is not None and self.every == "auto" and self._last is not None:
            if self._last[0] != last.step and self.comm.rank == 0:
                self._print(f"{last.line()}  ({duration(self.clock() - self.start)})")
        status = driver.outcome_words[0 if result.converged else 1]
        steps = count_of(result.steps, "step")
        if self.earlier_steps:
            whole = count_of(self.earlier_steps + result.steps, "step")
            steps = f"{whole} ({result.steps} since the resume)"
        counts = driver.step_counts()
        if counts:  # what a step was made of, named as in summary.json
            steps += " [" + ", ".join(_counted(k, n) for k, n in counts.items()) + "]"
        self._print(f"{status} after {steps}: {result.reason}")
        increases = result.energy_increases
        if increases:
            self._print(f"dgplate: warning: the energy increased at step(s) {increases[:10]}")


def _counted(key: str, n: int) -> str:
    """``heat_steps``, 3 → ``3 heat steps`` (the summary's key in words)."""
    return count_of(n, key.replace("_", " ").removesuffix("s"))


def duration(seconds: float) -> str:
    """A rounded duration for people: ``4.2 s``, ``45 s``, ``12 min``, ``3.5 h``."""
    if seconds < 9.95:
        return f"{seconds:.1f} s"
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"
