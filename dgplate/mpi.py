"""Reductions over a communicator, written once with their types.

mpi4py's object-based ``comm.allreduce`` returns ``Any`` and cannot take the element-wise
minimum or maximum of arrays; these helpers say what comes back and are collective: every
rank of ``comm`` must call them, and every rank gets the same result.
"""

from __future__ import annotations

import resource
import time

from mpi4py import MPI

import numpy as np
import numpy.typing as npt


def global_sum(comm: MPI.Comm, local: float) -> float:
    """The sum of a number over the ranks."""
    return float(comm.allreduce(float(local), op=MPI.SUM))


def global_max(comm: MPI.Comm, local: float) -> float:
    """The largest of a number over the ranks."""
    return float(comm.allreduce(float(local), op=MPI.MAX))


def global_min(comm: MPI.Comm, local: float) -> float:
    """The smallest of a number over the ranks."""
    return float(comm.allreduce(float(local), op=MPI.MIN))


def global_count(comm: MPI.Comm, local: int) -> int:
    """The sum of a count over the ranks."""
    return int(comm.allreduce(int(local), op=MPI.SUM))


def global_all(comm: MPI.Comm, local: bool) -> bool:
    """True when the flag holds on every rank."""
    return bool(comm.allreduce(bool(local), op=MPI.LAND))


def least(comm: MPI.Comm, local: tuple[float, ...] | None) -> tuple[float, ...] | None:
    """The least of the ranks' tuples (lexicographic), with the rank that gave it appended.

    Ties between ranks go to the lower rank only when the tuples are equal; put what must
    decide them (coordinates, not ranks) in the tuple to keep a choice partition-independent.

    Args:
        comm: the communicator.
        local: this rank's candidate, or None when it has none.

    Returns:
        The least candidate with the rank that gave it appended, or None when no rank has
        one.
    """
    mine = [] if local is None else [(*local, comm.rank)]
    found = [entry for entries in comm.allgather(mine) for entry in entries]
    return min(found) if found else None


def sum_arrays(comm: MPI.Comm, local: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The element-wise sum of equally shaped arrays over the ranks."""
    return np.asarray(comm.allreduce(np.asarray(local, dtype=np.float64), op=MPI.SUM))


def allreduce_array(
    comm: MPI.Comm, values: npt.ArrayLike, op: MPI.Op = MPI.SUM
) -> npt.NDArray[np.float64]:
    """Element-wise reduction of a float array by ``op`` (SUM, MIN, MAX, …)."""
    send = np.ascontiguousarray(values, dtype=np.float64)
    out = np.empty_like(send)
    comm.Allreduce(send, out, op=op)
    return out


def peak_memory_mb(comm: MPI.Comm) -> dict[str, float]:
    """The resident-set peak of this process so far (MiB): the largest rank's and the sum."""
    mine = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux
    return {"max_rank": global_max(comm, mine), "total": global_sum(comm, mine)}


def bounding_box(
    comm: MPI.Comm, points: npt.NDArray[np.float64]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The corners (lo, hi) of the box around the rows of ``points`` of all ranks.

    A rank may hold no points (shape (0, d)): it contributes ±inf.
    """
    lo = allreduce_array(comm, points.min(axis=0, initial=np.inf), op=MPI.MIN)
    hi = allreduce_array(comm, points.max(axis=0, initial=-np.inf), op=MPI.MAX)
    return lo, hi


bounds = bounding_box  # the name the FvK probes use


def arrive_within(comm: MPI.Comm, seconds: float) -> bool:
    """True when every rank of ``comm`` reaches this within ``seconds`` of this rank.

    One non-blocking barrier: near the deadline ranks may disagree (one gives up while
    another still sees the barrier complete). ``comm`` should be used for nothing else (a
    ``Dup``): when some rank never arrives, the barrier stays pending on it.
    """
    if comm.size == 1:
        return True
    request = comm.Ibarrier()
    deadline = time.monotonic() + seconds
    while not request.Test():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def all_arrive(comm: MPI.Comm, seconds: float) -> bool:
    """Whether every rank of ``comm`` calls this, each waiting at most about ``seconds``.

    For an error path: a collective clean-up (closing a file) is safe only when every rank
    has the error. Two barriers make the ranks agree: one that gave up in the first never
    enters the second, so the others give up there too; and since every rank enters the
    second within moments of the first's completion, none gives up there alone. ``comm``
    as for :func:`arrive_within`.
    """
    return arrive_within(comm, seconds) and arrive_within(comm, seconds)
