"""Stop a run cleanly on SIGINT or SIGTERM, at the next step boundary.

Slurm sends SIGTERM at a job's time limit and a user presses Ctrl-C: either way the run should
end with its outputs, not with a traceback from inside PETSc. While :class:`StopOnSignal` is
active, the first signal only sets a flag; the drivers ask :func:`requested` at each step
boundary (a collective, so a signal that reached one rank stops all of them at the same step),
write what they have, and the command line exits with 128 + the signal number (130 for SIGINT,
143 for SIGTERM). A second signal exits at once.

Before the first step there is nothing to keep, and the set-up may spend minutes in one call of
compiled code (a large mesh, a form compilation; under MPI a rank waits in a collective while
another compiles), where a Python handler would run only when the call returns. So on the
command line (``StopOnSignal(at_once=True)``) a signal during the set-up (:func:`setting_up`)
ends the process at once, with 130 or 143 and without PETSc's crash report: the C library
calls the handler directly, which renames the C file of a form compilation this process left
unfinished (:data:`CLEAN_UP`, else the next run would wait for it) and exits. While a form
compiles (Python, and a wait for the compiler) Python's own handlers do the same
(:func:`compiling`).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from types import FrameType, TracebackType
from typing import Any, TypeAlias

from mpi4py import MPI

#: What ``signal.signal`` installs and returns.
Handler: TypeAlias = "Callable[[int, FrameType | None], object] | int | signal.Handlers | None"

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_received = 0
_depth = 0  # nested StopOnSignal contexts: only the outermost installs and restores
_at_once = False  # whether the outermost StopOnSignal ends the set-up at once (the CLI)
_rank = 0  # MPI.COMM_WORLD's rank, for the handler that may not call MPI
_ending = False  # inside setting_up: a signal ends the process at once

#: What a process that ends at once during the set-up does first (e.g. give up an unfinished
#: form compilation, :func:`dgplate.compat.on_first_compile`): only system calls, no MPI.
CLEAN_UP: list[Callable[[], None]] = []


def _handler(signum: int, _frame: FrameType | None) -> None:
    """Record the first signal (and say so on rank 0); exit at once on the second."""
    global _received
    if _received:
        os._exit(128 + signum)  # the second signal: no clean-up, now
    _received = signum
    if MPI.COMM_WORLD.rank == 0:  # mpirun forwards the signal to every rank: say it once
        with contextlib.suppress(OSError):  # a closed stderr: the run stops all the same
            sys.stderr.write(
                f"dgplate: {signal.Signals(signum).name} received: stopping at the next step "
                "(send it again to stop at once)\n"
            )
            sys.stderr.flush()


class StopOnSignal:
    """Context manager: SIGINT and SIGTERM request a stop instead of killing the run.

    Outside the main thread (where Python cannot install handlers) it does nothing. The
    previous handlers are restored on exit, so notebooks and callers keep theirs. ``at_once``
    (the command line's choice; a notebook's kernel must survive a Ctrl-C): the blocks marked
    :func:`setting_up` end the process at once on either signal.
    """

    def __init__(self, at_once: bool = False) -> None:
        self.at_once = at_once

    def __enter__(self) -> StopOnSignal:
        global _received, _depth, _at_once
        self._previous: dict[int, Handler] = {}
        _depth += 1
        if _depth == 1 and threading.current_thread() is threading.main_thread():
            _received, _at_once = 0, self.at_once
            for sig in SIGNALS:
                self._previous[sig] = signal.signal(sig, _handler)
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        global _depth, _at_once
        _depth -= 1
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)
        if self._previous:
            _at_once = False


@contextlib.contextmanager
def setting_up() -> Iterator[None]:
    """A set-up or compile phase: SIGINT and SIGTERM end the process at once in it.

    Only inside a ``StopOnSignal(at_once=True)`` (the command line), in the main thread;
    elsewhere it does nothing. The stop-at-a-step handlers are back on leaving the block.
    """
    if not _at_once or threading.current_thread() is not threading.main_thread():
        yield
        return
    global _rank, _ending
    _rank = MPI.COMM_WORLD.rank
    saved = {sig: signal.getsignal(sig) for sig in SIGNALS}
    _ending = True
    renew()
    try:
        yield
    finally:
        _ending = False
        for sig, handler in saved.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)


def renew() -> None:
    """Install the set-up's handlers again after a library reset them (gmsh does).

    Only inside :func:`setting_up`; elsewhere it does nothing.
    """
    if _ending:
        for sig in SIGNALS:
            _libc_signal(sig, _END_NOW)


@contextlib.contextmanager
def compiling() -> Iterator[None]:
    """A C compiler's run inside :func:`setting_up`: Python's own handlers end the process.

    The C-level handler runs wherever the signal lands, and a compilation is mostly Python
    (FFCx, cffi, setuptools) and a wait for the compiler: the handler could interrupt this
    thread inside ``malloc`` or while it takes back the GIL after the wait, and its own
    allocations or its GIL would then wait for a lock the thread already holds, forever.
    Python's handlers run between bytecodes, where that cannot happen, and a wait for a child
    process returns to run them at once. The C-level handlers are back on leaving the block.
    Outside :func:`setting_up` it does nothing.
    """
    if not _ending or threading.current_thread() is not threading.main_thread():
        yield
        return
    for sig in SIGNALS:
        signal.signal(sig, _end_from_python)
    try:
        yield
    finally:
        renew()


def _end_from_python(signum: int, _frame: FrameType | None) -> None:
    """:func:`_end`, as Python's handler (:func:`compiling`)."""
    _end(signum)


def _end_now(signum: int) -> None:
    """:func:`_end`, called by the C library in the signal's context (even in compiled code).

    The signal may come while the interrupted code has an exception set (being raised or
    handled): every builtin called then fails with SystemError ("returned a result with an
    exception set") and the handler returned without ending the process. It is cleared first.
    """
    _clear_python_error()
    _end(signum)


def _end(signum: int) -> None:
    """End the process with 128 + ``signum`` now: the least Python possible, and no MPI.

    The process's own children (a C compiler FFCx started) end first: left running, they
    would report the C file the clean-up renamed as missing.
    """
    if _has_children():  # only then the scan of /proc, whose reads allocate (see below)
        _end_children(os.getpid())
    for clean_up in CLEAN_UP:
        with contextlib.suppress(Exception):
            clean_up()
    if _rank == 0:  # mpirun forwards the signal to every rank: say it once
        os.write(2, _ENDED[signum])
    os._exit(128 + signum)


def _has_children() -> bool:
    """Whether this process has a child (one system call, no allocation of note).

    The handler runs inside whatever compiled code the signal interrupted, maybe inside the C
    library's malloc, whose lock a second allocation of the same thread would wait for forever:
    it does as little as it can when there is no compiler to end (a mesh's set-up).
    """
    try:
        os.waitpid(-1, os.WNOHANG)  # reaps at most one finished child: the process ends anyway
    except ChildProcessError:
        return False
    return True


def _end_children(root: int) -> None:
    """Stop, then kill, every descendant of process ``root`` (Linux's /proc; elsewhere nothing).

    Each one found is stopped (SIGSTOP) at once, and /proc is read again until a reading
    finds no new one: none can start another process unseen (a compiler driver starts
    ``cc1``, then ``as``).
    """
    stopped: set[int] = set()
    with contextlib.suppress(OSError):
        while new := _descendants(root) - stopped:
            for pid in new:
                with contextlib.suppress(OSError):
                    os.kill(pid, signal.SIGSTOP)
            stopped |= new
    for pid in stopped:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def _descendants(ancestor: int) -> set[int]:
    """The processes descending from ``ancestor``, from the parents /proc gives."""
    parent_of = {int(pid): _parent(pid) for pid in os.listdir("/proc") if pid.isdigit()}
    found: set[int] = set()
    while grown := {p for p, q in parent_of.items() if q in found | {ancestor}} - found:
        found |= grown
    return found


def _parent(pid: str) -> int:
    """The parent of process ``pid`` from /proc/PID/stat (0: gone or unreadable)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as stat:
            fields = stat.read().rsplit(b")", 1)[1].split()  # after the (command name)
        return int(fields[1])
    except (OSError, IndexError, ValueError):
        return 0


#: The line of :func:`_end_now` per signal, made beforehand (no formatting in the handler).
_ENDED = {
    int(sig): f"dgplate: {sig.name} during the set-up: stopped, nothing written\n".encode()
    for sig in SIGNALS
}
_HANDLER = ctypes.CFUNCTYPE(None, ctypes.c_int)
_END_NOW = _HANDLER(_end_now)
_clear_python_error = ctypes.pythonapi.PyErr_Clear
_clear_python_error.argtypes, _clear_python_error.restype = [], None


def _libc_signal(signum: int, handler: Any) -> None:
    """Install a C-level ``handler`` (Python's own run only between bytecodes)."""
    libc = ctypes.CDLL(None)
    libc.signal.argtypes = [ctypes.c_int, _HANDLER]
    libc.signal.restype = ctypes.c_void_p
    libc.signal(signum, handler)


def requested(comm: MPI.Comm) -> int:
    """The signal any rank received (0: none). Collective: call it on every rank."""
    return int(comm.allreduce(_received, op=MPI.MAX))


def reason(signum: int) -> str:
    """``'interrupted (SIGTERM)'``: the ``reason`` of an interrupted run's summary."""
    return f"interrupted ({signal.Signals(signum).name})"


def exit_code(signum: int) -> int:
    """The shell's convention for a process ended by a signal: 128 + its number."""
    return 128 + signum
