"""The SQP (Newton) finish of adaptive τ (flow.newton_finish): the step matrix with the
Lagrangian's curvature.

The finish changes the path, not the end: the run must stop at the fixed-τ run's state (E_h to
1e-7 relative, 1 and 2 ranks), lower E_h at every accepted step, and, since the next SQP
matrix is built from the multipliers of the last step solve, a run stopped and resumed from
its checkpoint must take the uninterrupted run's steps. On the bilayer cylinder the SQP matrix
also has the explicit terms' second derivative and the edge moments' curvature.
"""

from itertools import pairwise
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import bnn_flow, stop_and_resume, summary_of

from dgplate.cli import main
from dgplate.errors import InputError
from dgplate.schema import from_dict
from dgplate.solvers.flow import FlowSpec
from dgplate.solvers.projection import Projection

VERTICAL = Path(__file__).resolve().parents[2] / "demos" / "problems" / "vertical_load.toml"
# SQP steps from the start (newton_tau_ratio = 1), so that the 6×6 plate takes some
NEWTON = {"adaptive_tau": True, "newton_finish": True, "newton_tau_ratio": 1.0}


def run_bnn(comm, **flow):
    solver = bnn_flow(
        comm, 6, tol=1e-6, stop="stationarity", projection_steps=1, max_steps=400, **flow
    )
    result = solver.run()
    counts = solver.counts
    solver.destroy()
    return result, counts


@pytest.mark.mpi
def test_newton_finish_ends_at_the_fixed_tau_state():
    fixed, _ = run_bnn(MPI.COMM_WORLD)
    adaptive, _ = run_bnn(MPI.COMM_WORLD, adaptive_tau=True, newton_finish=False)
    newton, counts = run_bnn(MPI.COMM_WORLD, **NEWTON)
    steps = counts.newton_steps
    for result in (fixed, adaptive, newton):
        assert result.converged and result.energy_increases == []
        energies = [row.energy for row in result.history]
        assert all(b <= a + 1e-12 for a, b in pairwise(energies))
    assert newton.energy == pytest.approx(fixed.energy, rel=1e-7)
    assert 0 < steps <= newton.steps
    # the finish takes fewer steps than plain adaptive τ, which takes fewer than fixed τ
    assert newton.steps < adaptive.steps < fixed.steps


@pytest.mark.mpi
def test_sqp_step_left_off_the_constraint_is_refused(monkeypatch):
    """Without its corrections an SQP step of the defect-bound control ends below the
    constrained energy, off the constraint.

    Accepted, every later step would "raise" E_h when its projection restores the constraint;
    the controller must refuse it and redo it as a plain step, and the run still end at the
    fixed-τ state with E_h lowered at every step. (The trust region's SQP steps stay off the
    constraint by design, judged by their merit: tests/solvers/test_trust_region.py.)
    """
    fixed, _ = run_bnn(MPI.COMM_WORLD)
    monkeypatch.setattr(Projection, "close_constraint", lambda self, stats, solver, change: None)
    newton, counts = run_bnn(MPI.COMM_WORLD, **NEWTON, step_control="defect_bound")
    assert newton.converged and newton.energy_increases == []
    assert counts.newton_rejections > 0
    assert newton.energy == pytest.approx(fixed.energy, rel=1e-7)


def test_resumed_newton_run_takes_the_same_steps(tmp_path):
    options = [
        f"--set={key}"
        for key in (
            "mesh.cells=[6,6]",
            "flow.adaptive_tau=true",
            "flow.newton_finish=true",
            "flow.newton_tau_ratio=1",
            "flow.projection_steps=1",
            "flow.stop='stationarity'",
            "flow.tol=1e-6",
            "output.vtx=false",
            "output.png=false",
            "output.progress=0",
        )
    ]
    expected, _, summary = stop_and_resume(VERTICAL, tmp_path, options, max_steps=3)
    assert expected["converged"] and expected["newton_steps"] > 2
    for key in ("steps", "rejected_steps", "newton_steps", "newton_rejections", "step_solves"):
        assert summary[key] == expected[key], key
    assert np.isclose(summary["energy"], expected["energy"], rtol=1e-12, atol=0)


CYLINDER = VERTICAL.parent / "bilayer_cylinder.toml"


def test_newton_finish_on_the_bilayer_cylinder(tmp_path):
    """The explicit terms' D²E_expl and the edge moments' curvature (8×4 cylinder)."""
    common = [
        f"--set={key}"
        for key in (
            "mesh.cells=[8,4]",
            "flow.tau='h'",
            "flow.stop='stationarity'",
            "flow.tol=1e-5",
            "output.vtx=false",
            "output.png=false",
            "output.progress=0",
        )
    ]
    newton = [
        "--set=flow.adaptive_tau=true",
        "--set=flow.newton_tau_ratio=1",
        "--set=flow.defect_bound=0.1",
    ]
    summaries = {}
    fixed_tau = ["--set=flow.method='bnn'"]  # the published fixed-τ steps
    for name, extra in (("fixed", fixed_tau), ("newton", newton)):
        out = tmp_path / name
        assert main(["run", str(CYLINDER), "--out", str(out), *common, *extra]) == 0
        summaries[name] = summary_of(out)
        assert summaries[name]["converged"] and summaries[name]["energy_increases"] == []
    fixed, sqp = summaries["fixed"], summaries["newton"]
    assert sqp["energy"] == pytest.approx(fixed["energy"], rel=1e-7)
    assert sqp["newton_steps"] > 0 and sqp["steps"] < fixed["steps"] / 5


@pytest.mark.parametrize(("key", "value"), [("newton_finish", 1), ("newton_tau_ratio", 0.5)])
def test_bad_newton_keys_are_refused(key, value):
    with pytest.raises(InputError, match=rf"^flow\.{key} must be"):
        from_dict(FlowSpec, {"adaptive_tau": True, key: value}, "flow")
