"""The transversal-crossing check of the start of a self-avoiding plate (docs/self_avoidance.md).

A start whose sheets cross between the quadrature points is not caught by the least distance
of the points; the triangle–triangle test of the deformed cells' corners catches it.
"""

from mpi4py import MPI

import numpy as np
import pytest

import dgplate
from dgplate.dg import pair_search
from dgplate.dg import tangent_point as tp


def test_crossing_triangles_are_found_and_neighbours_skipped():
    """A triangle pierced by another is one pair; a common vertex id, or a gap, is none."""
    flat = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    piercing = np.array([[0.2, 0.2, -1.0], [0.3, 0.2, 1.0], [0.2, 0.3, 1.0]])
    triangles = np.stack([flat, piercing, piercing + np.array([0.0, 0.0, 3.0])])
    ids = np.arange(9).reshape(3, 3)
    assert tp.crossings(triangles, ids).tolist() == [[0, 1]]
    ids[1, 0] = 0  # neighbouring cells: not tested
    assert tp.crossings(triangles, ids).tolist() == []


def test_sweep_finds_every_crossing_pair():
    """The x-sweep of bounding boxes against all pairs, on random triangles."""
    triangles = np.random.default_rng(0).random((120, 3, 3))
    ids = np.arange(360).reshape(120, 3)
    everything = [
        (i, j)
        for i in range(120)
        for j in range(i + 1, 120)
        if (pair_search._edges_through(triangles[[i]], triangles[[j]])
            | pair_search._edges_through(triangles[[j]], triangles[[i]]))[0]
    ]  # fmt: skip
    assert len(everything) > 100
    assert sorted(map(tuple, tp.crossings(triangles, ids).tolist())) == everything


def nodal_cubic(x: np.ndarray) -> np.ndarray:
    """The strip along the nodal cubic (t² − 1, t³ − t): the sheets at t = ±1 cross at 90°."""
    return np.vstack([x[0] ** 2 - 1, x[1], x[0] ** 3 - x[0]])


def strip(cells: list[int]) -> dict:
    return {
        "mesh": {"type": "rectangle", "corners": [[-1.5, 0.0], [1.5, 1.0]], "cells": cells},
        "model": {"name": "kirchhoff", "degree": 2, "self_avoidance": {"rho": 1e-4}},
        "flow": {"tau": 0.01, "max_steps": 1},
    }


@pytest.mark.mpi
def test_a_start_crossing_between_quadrature_points_is_refused(tmp_path):
    """The crossing lies between the points of the cells at t = ±1 (0.1 apart on 30 cells);
    every rank raises the same error (the triangles are gathered)."""
    comm = MPI.COMM_WORLD
    problem = dgplate.problem_from_dict(strip([30, 2]), "crossing")
    out = comm.bcast(tmp_path / "out" if comm.rank == 0 else None)
    with pytest.raises(dgplate.InputError, match=r"^model.self_avoidance: .* cross, e\.g\."):
        dgplate.run(problem, out=out, comm=comm, initial=nodal_cubic)


def test_the_same_strip_uncrossed_starts(tmp_path):
    """Only the part t < 0.9 (no node): accepted, and one step runs."""
    problem = dgplate.problem_from_dict(
        {**strip([24, 2]), "mesh": {"type": "rectangle", "corners": [[-1.5, 0.0], [0.9, 1.0]],
                                   "cells": [24, 2]}},
        "open",
    )  # fmt: skip
    result = dgplate.run(problem, out=tmp_path / "out", initial=nodal_cubic)
    assert result["min_distance"] > 0
