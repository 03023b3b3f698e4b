"""The model of "How to add a model": a plate on an elastic foundation, run by `dgplate.run`.

A free plate under a uniform load f = (0, 0, f₃) on a foundation of stiffness k floats at
y = (x₁, x₂, f₃/k): a rigid translation (an isometry, no bending), with E_h = −|Ω| f₃²/(2k).
"""

import math

import pytest

import dgplate


@pytest.mark.mpi
def test_free_plate_floats_at_load_over_stiffness(tmp_path, comm):
    f3, k = 0.5, 2.0
    problem = dgplate.problem_from_dict(
        {
            "mesh": {"cells": [4, 4]},
            "model": {"name": "foundation", "k": k, "load": [0.0, 0.0, f3]},
            "flow": {"tau": 1.0, "tol": 1e-10},
            "output": {"png": False, "progress": 0},
        },
        "foundation",
    )
    out = comm.bcast(tmp_path / "out" if comm.rank == 0 else None)  # one folder for all ranks
    result = dgplate.run(problem, out=out, comm=comm)
    assert result["converged"]
    assert math.isclose(result["energy"], -(f3**2) / (2 * k), rel_tol=1e-8)
    # E_h is quadratic about its minimiser: a decrease below tol leaves y₃ within ~√(tol τ/k)
    (zmin, zmax) = (result["bbox"][0][2], result["bbox"][1][2])
    assert abs(zmin - f3 / k) < 1e-4 and abs(zmax - f3 / k) < 1e-4
    assert result.shape is not None
    assert comm.rank != 0 or (out / "summary.json").exists()


def test_stiffness_must_be_positive():
    with pytest.raises(dgplate.InputError, match=r"model\.k must be a number > 0"):
        dgplate.problem_from_dict({"model": {"name": "foundation", "k": 0.0}}, "bad")
