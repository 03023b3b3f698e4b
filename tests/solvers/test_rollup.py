"""The trust-region step control (flow.step_control) on large rotations: a 12 × 1 strip with
Z = diag(κ, 0), clamped on its short side, rolls into a cylinder of radius 1/κ (II = Z, E = 0)
in a number of steps that does not grow with the angle, and ends at the defect-bound
control's state (benchmarks/rollup.py measures both at the issue's mesh).
"""

import math
import tempfile
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import load_benchmark

from dgplate.problems.runner import run

ROLLUP = load_benchmark("rollup")
CELLS = [24, 2]


def roll(turns, control):
    """The roll-up on 24 × 2 cells: its summary and the largest |y₃| (the height reached)."""
    comm = MPI.COMM_WORLD
    folder = comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0)
    result = run(ROLLUP.problem(turns, CELLS, control), Path(folder) / "run", comm)
    assert result.shape is not None
    local = np.abs(result.shape.x.array.reshape(-1, 3)[:, 2]).max(initial=0.0)
    return result.summary, comm.allreduce(local, op=MPI.MAX)


@pytest.mark.mpi
def test_half_turn_rolls_into_its_cylinder():
    """½ turn: κ = π/12, the free end above the clamped side at 2/κ = 7.639; E_h → 0 (E_h of
    the flat strip ½κ²|ω| = 0.411; measured 7.9·10⁻⁴ in 14 steps, the height 2/κ·(1 + 2.9·10⁻³)).
    14 steps, 2 refused, 32 step solves (5 refused and 38 solves with τ doubled after every
    accepted step and halved after every refused one)."""
    summary, height = roll(0.5, "trust_region")
    assert summary["converged"] and summary["energy_increases"] == []
    assert summary["steps"] <= 16 and summary["newton_rejections"] == 0
    assert summary["rejected_steps"] <= 3 and summary["step_solves"] <= 34
    assert summary["energy"] < 1e-3
    assert height == pytest.approx(2 * 12 / math.pi, rel=5e-3)


def test_quarter_turn_ends_at_the_defect_bound_state_in_fewer_steps():
    """¼ turn (free end at height 1/κ = 7.639): measured 10 steps against 48, E_h 5.0·10⁻⁵ in
    both, agreeing to 5·10⁻¹⁴; the heights 1/κ·(1 − 7.7·10⁻⁴) to 3·10⁻⁶ (both stop at
    ‖P DE_h‖_*' < 10⁻⁶, not at the same state)."""
    old, old_height = roll(0.25, "defect_bound")
    new, new_height = roll(0.25, "trust_region")
    for summary in (old, new):
        assert summary["converged"] and summary["energy_increases"] == []
        assert summary["isometry_defect"] < 1e-12
    assert new["energy"] == pytest.approx(old["energy"], abs=1e-8)
    assert new_height == pytest.approx(old_height, abs=2e-5)
    assert new_height == pytest.approx(24 / math.pi, rel=2e-3)
    assert new["steps"] <= 12 and 4 * new["steps"] <= old["steps"]
