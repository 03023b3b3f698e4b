"""Adaptive τ (flow.adaptive_tau): checkpoints keep τ, and the step matrix follows the
controller's τ only when they differ by more than flow.refactor_factor.

A run interrupted and resumed must take the same steps with the same τ as an uninterrupted
one (the resumed run would otherwise restart from the initial τ). With a refactor factor the
steps between refactorisations keep the factorised τ: they are still steps of the flow, and
the run must end at the fixed-τ run's state, with the energy going down at every step.
"""

import math
from itertools import pairwise
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import PROBLEMS, QUIET, bnn_flow, stop_and_resume

import dgplate
from dgplate.errors import InputError
from dgplate.schema import from_dict
from dgplate.solvers.flow import FlowSpec

VERTICAL = Path(__file__).resolve().parents[2] / "demos" / "problems" / "vertical_load.toml"
# 6×6 BNN plate, adaptive τ from τ = h with a tight defect bound (the defect-bound control):
# some steps are rejected
ADAPTIVE = [
    f"--set={key}"
    for key in (
        "mesh.cells=[6,6]",
        "flow.linear_solver='direct'",
        "flow.adaptive_tau=true",
        "flow.step_control='defect_bound'",
        "flow.defect_bound=2e-3",
        "flow.refactor_factor=3",
        "flow.projection_steps=1",
        "flow.stop='stationarity'",
        "flow.tol=1e-5",
        "output.vtx=false",
        "output.png=false",
        "output.progress=0",
    )
]


def test_resumed_adaptive_run_keeps_its_tau(tmp_path):
    expected, stopped, summary = stop_and_resume(VERTICAL, tmp_path, ADAPTIVE, max_steps=4)
    assert expected["converged"] and expected["rejected_steps"] > 0
    assert stopped["tau"] != pytest.approx(expected["tau"])
    for key in ("steps", "rejected_steps", "refactorisations"):
        assert summary[key] == expected[key], key
    assert summary["tau"] == expected["tau"]
    assert np.isclose(summary["energy"], expected["energy"], rtol=1e-10, atol=0)
    lines = (tmp_path / "reference" / "history.csv").read_text().splitlines()
    # the stopping measure is in every row, below the tolerance in the last
    header, *table = [line.split(",") for line in lines]
    column = [float(row[header.index("stationarity")]) for row in table]
    assert all(math.isfinite(value) for value in column) and column[-1] < 1e-5


def bnn(comm, n=6, **flow):
    return bnn_flow(
        comm, n, tol=1e-5, stop="stationarity", projection_steps=1, max_steps=400, **flow
    )


@pytest.mark.mpi
def test_refactor_factor_keeps_tau_between_refactorisations():
    runs = {}
    for name, flow in (
        ("fixed", {}),
        ("every change", {"adaptive_tau": True, "tau_growth_max": 2.0}),
        ("factor 3", {"adaptive_tau": True, "tau_growth_max": 2.0, "refactor_factor": 3.0}),
    ):
        solver = bnn(MPI.COMM_WORLD, **flow)
        result = solver.run()
        assert result.converged and result.energy_increases == [], name
        runs[name] = (result, solver.counts.refactorisations, solver.counts.rejected_steps)
        solver.destroy()
    fixed = runs["fixed"][0]
    for name in ("every change", "factor 3"):
        result, count, rejected = runs[name]
        assert rejected == 0
        assert result.energy == pytest.approx(fixed.energy, rel=1e-6), name
        taus = [row.tau for row in result.history]
        changes = sum(b != a for a, b in pairwise(taus))
        # every change is one refactorisation; the last may come after the last step
        assert changes <= count <= changes + 1, name
    assert runs["fixed"][1] == 0
    # every change: τ doubles after each step; factor 3: it is put into the matrix every
    # second step, ×4
    every, factor3 = runs["every change"][0], runs["factor 3"][0]
    assert [b.tau / a.tau for a, b in pairwise(every.history)] == (
        pytest.approx([2.0] * (every.steps - 1))
    )
    taus = [row.tau for row in factor3.history]
    assert taus[:5] == pytest.approx([taus[0], taus[0], 4 * taus[0], 4 * taus[0], 16 * taus[0]])
    assert runs["factor 3"][1] < runs["every change"][1]


def growth_record(solver):
    """Record, at every growth of τ: rejections so far, defect before projection, τ before, after."""
    control = solver.control
    record, grow = [], control._grow_tau

    def recorded():
        before = control.target
        grow()
        record.append((solver.counts.rejected_steps, control.linear_defect, before, control.target))

    control._grow_tau = recorded
    return record


def fast_factor(bound, defect):
    """The growth of the SQP-finish runs before a rejection: √(bound/D)/2 in [2, 8]."""
    return min(max(0.5 * math.sqrt(bound / defect), 2.0), 8.0)


@pytest.mark.mpi
@pytest.mark.parametrize(
    ("newton_finish", "bound"),
    [(True, 1e-2), (True, 2e-3), (False, 1e-2)],
    ids=["finish", "finish-rejections", "plain"],
)
def test_tau_grows_by_the_defect_until_the_first_rejection(newton_finish, bound):
    """With the defect-bound control and the SQP finish, τ grows by √(bound/D)/2 in [2, 8]
    until a rejection, then by 2;
    without it, by 2 throughout. Either way the run ends at the fixed-τ state.

    The 6² plate with the default bound has no rejection; with 2·10⁻³ the first step is
    rejected, and the later steps, whose defects would allow more, still grow by 2.
    """
    fixed = bnn(MPI.COMM_WORLD)
    reference = fixed.run()
    fixed.destroy()
    ratio = 1e3  # SQP steps only at the cap: the growth below it is what is tested
    flow = {
        "adaptive_tau": True,
        "step_control": "defect_bound",
        "defect_bound": bound,
        "newton_finish": newton_finish,
    }
    solver = bnn(MPI.COMM_WORLD, tau_max_ratio=ratio, newton_tau_ratio=ratio, **flow)
    record = growth_record(solver)
    result = solver.run()
    cap = ratio * solver.control.initial
    solver.destroy()
    assert result.converged and result.energy_increases == []
    assert result.energy == pytest.approx(reference.energy, rel=1e-6)
    assert len(record) == result.steps
    factors = [
        fast_factor(bound, defect) if newton_finish and not rejected else 2.0
        for rejected, defect, *_ in record
    ]
    expected = [min(f * before, cap) for f, (*_, before, _) in zip(factors, record, strict=True)]
    assert [after for *_, after in record] == pytest.approx(expected, rel=1e-12)
    if bound == 1e-2 and newton_finish:  # the rule grew τ faster than doubling
        assert max(factors) > 2.0
    if bound == 2e-3:  # after the rejection, defects that would have allowed more
        assert all(rejected > 0 for rejected, *_ in record)
        assert max(fast_factor(bound, defect) for _, defect, *_ in record) > 2.0


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("refactor_factor", 0.5),
        ("tau_growth", 1.0),
        ("tau_growth_max", 0.5),
        ("tau_max_ratio", math.inf),
    ],
)
def test_bad_controller_numbers_are_refused(key, value):
    with pytest.raises(InputError, match=rf"^flow\.{key} must be "):
        from_dict(FlowSpec, {"adaptive_tau": True, key: value}, "flow")


def test_growing_tau_does_not_end_the_rate_test_early(tmp_path):
    """Plain adaptive τ with the rate test (bilayer cylinder 8×4, the file's τ = 0.25, tol 10⁻⁶).

    τ grows a thousandfold, and with it the rate (E_h[yⁿ⁻¹] − E_h[yⁿ])/τ falls whatever the
    state: measured, the raw rate ended the run after 24 steps with E_h 3.2·10⁻⁵ above the
    critical point's 0.98752852 (the fixed-τ run of 71 steps: 1.1·10⁻⁶). With a changing τ the
    rate test takes the rate's limit τ → 0, ‖P DE_h‖_*'²: 30 steps, 5·10⁻⁸ above it.
    """
    overrides = {
        **QUIET,
        "mesh.cells": [8, 4],
        "flow.adaptive_tau": True,
        "flow.newton_finish": False,
        "flow.stop": "rate",
        "flow.max_steps": 300,
    }
    problem = dgplate.load_problem(PROBLEMS / "bilayer_cylinder.toml", overrides=overrides)
    result = dgplate.run(problem, out=tmp_path / "out", comm=MPI.COMM_SELF)
    assert result["converged"] and result["tau"] == 250.0  # τ at its cap, 10³ τ⁰
    assert result["reason"].startswith("‖P DE_h[yⁿ]‖_*'² (the rate's limit τ → 0")
    rows = (tmp_path / "out" / "history.csv").read_text().splitlines()
    header, last = rows[0].split(","), rows[-1].split(",")
    assert float(last[header.index("stationarity")]) ** 2 < 1e-6
    assert 0 <= result["energy"] - 0.98752852 < 1e-6
