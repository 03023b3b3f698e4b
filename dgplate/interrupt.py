"""Stop a run cleanly on SIGINT or SIGTERM, at the next step boundary.

Slurm sends SIGTERM at a job's time limit and a user presses Ctrl-C: either way the run should
end with its outputs, not with a traceback from inside PETSc. While :class:`StopOnSignal` is
active, the first signal only sets a flag; the drivers ask :func:`requested` at each step
boundary (a collective, so a signal that reached one rank stops all of them at the same step),
write what they have, and the command line exits with 128 + the signal number (130 for SIGINT,
143 for SIGTERM). A second signal exits at once.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable
from types import FrameType, TracebackType
from typing import TypeAlias

from mpi4py import MPI

#: What ``signal.signal`` installs and returns.
Handler: TypeAlias = "Callable[[int, FrameType | None], object] | int | signal.Handlers | None"

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_received = 0
_depth = 0  # nested StopOnSignal contexts: only the outermost installs and restores


def _handler(signum: int, _frame: FrameType | None) -> None:
    """Record the first signal (and say so on rank 0); exit at once on the second."""
    global _received
    if _received:
        os._exit(128 + signum)  # the second signal: no clean-up, now
    _received = signum
    if MPI.COMM_WORLD.rank == 0:  # mpirun forwards the signal to every rank: say it once
        sys.stderr.write(
            f"dgplate: {signal.Signals(signum).name} received: stopping at the next step "
            "(send it again to stop at once)\n"
        )
        sys.stderr.flush()


class StopOnSignal:
    """Context manager: SIGINT and SIGTERM request a stop instead of killing the run.

    Outside the main thread (where Python cannot install handlers) it does nothing. The
    previous handlers are restored on exit, so notebooks and callers keep theirs.
    """

    def __enter__(self) -> StopOnSignal:
        global _received, _depth
        self._previous: dict[int, Handler] = {}
        _depth += 1
        if _depth == 1 and threading.current_thread() is threading.main_thread():
            _received = 0
            for sig in SIGNALS:
                self._previous[sig] = signal.signal(sig, _handler)
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        global _depth
        _depth -= 1
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)


def requested(comm: MPI.Comm) -> int:
    """The signal any rank received (0: none). Collective: call it on every rank."""
    return int(comm.allreduce(_received, op=MPI.MAX))


def reason(signum: int) -> str:
    """``'interrupted (SIGTERM)'``: the ``reason`` of an interrupted run's summary."""
    return f"interrupted ({signal.Signals(signum).name})"


def exit_code(signum: int) -> int:
    """The shell's convention for a process ended by a signal: 128 + its number."""
    return 128 + signum
