"""Small MPI helpers on NumPy arrays (a base module: it imports nothing from dgplate).

mpi4py's lower-case ``allreduce`` pickles its argument and reduces whole objects, so it cannot
take the element-wise minimum or maximum of an array; these helpers use the buffer interface.
All of them are collective on ``comm``.
"""

from __future__ import annotations

from typing import Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt


def allreduce_array(comm: MPI.Comm, values: npt.ArrayLike, op: MPI.Op = MPI.SUM) -> np.ndarray:
    """Element-wise reduction of a float array over ``comm`` (``op``: SUM, MIN, MAX, …)."""
    local = np.ascontiguousarray(values, dtype=np.float64)
    out = np.empty_like(local)
    comm.Allreduce(local, out, op=op)
    return out


def bounds(comm: MPI.Comm, points: npt.NDArray[Any]) -> tuple[np.ndarray, np.ndarray]:
    """Element-wise minimum and maximum over the rows of ``points`` (n × d) on all ranks.

    A rank without rows contributes nothing (±inf).
    """
    points = np.asarray(points, dtype=np.float64)
    lo = allreduce_array(comm, points.min(axis=0, initial=np.inf), op=MPI.MIN)
    hi = allreduce_array(comm, points.max(axis=0, initial=-np.inf), op=MPI.MAX)
    return lo, hi
