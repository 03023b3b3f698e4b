"""The Schur-complement step solver (flow.linear_solver = 'schur') against direct LU solves.

Both solve the same saddle-point systems, so the flows must agree to the Krylov tolerance
(1e-12 of the Schur residual): the deformations after several steps to 1e-10, relative.
"""

import logging

from mpi4py import MPI

import numpy as np
import pytest

from dgplate.errors import InputError
from dgplate.mesh.tagged import rectangle
from dgplate.models.bilayer import BilayerSpec, build_bilayer
from dgplate.models.kirchhoff import bnn_plate
from dgplate.reference.bnn import bnn_h
from dgplate.solvers import linear, schur
from dgplate.solvers.flow import FlowSpec, GradientFlow

AGREE = 1e-10


def bnn(comm, solver, n=4, projection_steps=1, pc="bfbt"):
    """The BNN vertical-load plate on n×n cells (``pc``: the Schur preconditioner)."""
    model = bnn_plate(comm, n)
    settings = FlowSpec(
        tau=bnn_h(n),
        tol=1e-12,
        projection_steps=projection_steps,
        linear_solver=solver,
        solver={"schur_pc": pc} if solver == "schur" else {},
    )
    return GradientFlow(model.facets, 2, model.energy, settings)


def bilayer(comm, solver, edge_constraint=True, pc="bfbt"):
    """A 6×3 bilayer strip rolling up: explicit part, degree-1 multipliers, edge moments."""
    tagged = rectangle(comm, [[0, 0], [2, 1]], [6, 3])
    spec = BilayerSpec(clamped=["left"], Z=1.0)
    model = build_bilayer(spec, tagged)
    settings = FlowSpec(
        tau=0.05,
        tol=1e-12,
        multiplier_degree=1,
        projection_steps=2,
        linear_solver=solver,
        edge_constraint=edge_constraint,
        solver={"schur_pc": pc} if solver == "schur" else {},
    )
    return GradientFlow(model.facets, 2, model.energy, settings)


def states(build, steps, comm=MPI.COMM_SELF, then=None):
    """Run the direct and the Schur flow ``steps`` steps; their energies and deformations."""
    out = {}
    for kind in ("direct", "schur"):
        flow = build(comm, kind)
        result = flow.run(steps)
        if then is not None:
            then(flow)
            result = flow.run(steps)
        assert result.steps == steps and result.energy_increases == []
        y = flow.y.x.array[: flow.V.dofmap.index_map.size_local * 3].copy()
        out[kind] = (result.energy, result.defect, y, flow.solver)
        flow.destroy()
    return out


def assert_agree(out):
    (e_d, _, y_d, _), (e_s, _, y_s, solver) = out["direct"], out["schur"]
    assert isinstance(solver, schur.SchurStepSolver)
    assert abs(e_s - e_d) <= AGREE * abs(e_d)
    assert np.max(np.abs(y_s - y_d)) <= AGREE * np.max(np.abs(y_d))


@pytest.mark.mpi
def test_vertical_load_with_projection():
    assert_agree(states(bnn, 3, comm=MPI.COMM_WORLD))


def test_cell_preconditioner():
    """The cell-block preconditioner alone (no BFBᵀ) gives the same steps."""

    def build(comm, kind):
        return bnn(comm, kind, pc="cell")

    out = states(build, 2)
    assert out["schur"][3].preconditioner == "cell" and out["schur"][3].inner is None
    assert_agree(out)


def test_unknown_preconditioner():
    with pytest.raises(InputError, match=r"flow\.solver\.schur_pc"):
        bnn(MPI.COMM_SELF, "schur", pc="amg")


@pytest.mark.mpi
def test_auxiliary_space_preconditioner():
    """The continuous-space (Woodbury) preconditioner, the flow's default for 'schur': same
    steps, a few dozen iterations."""

    def build(comm, kind):
        model = bnn_plate(comm, 6)
        settings = FlowSpec(tau=bnn_h(6), tol=1e-12, linear_solver=kind)
        return GradientFlow(model.facets, 2, model.energy, settings)

    out = states(build, 3, comm=MPI.COMM_WORLD)
    solver = out["schur"][3]
    assert solver.preconditioner == "aux" and solver.aux.rebuilds >= 1
    assert solver.aux.baseline < 60  # the cell-block preconditioner needs hundreds
    # the profile: Σ and its preconditioner applied at least once per CG iteration, and timed
    for tally in (solver.sigma_tally, solver.pc_tally):
        assert tally.applications > 3 * solver.aux.baseline // 2 and tally.seconds > 0
    assert_agree(out)


@pytest.mark.mpi
def test_auxiliary_space_with_edge_constraint():
    out = states(lambda comm, kind: bilayer(comm, kind, pc="aux"), 2, comm=MPI.COMM_WORLD)
    assert out["schur"][3].C is not None
    assert_agree(out)


@pytest.mark.mpi
def test_bilayer_with_edge_constraint():
    """Pinned edge multipliers make C ≠ 0 and Σ indefinite: MINRES."""
    out = states(bilayer, 2, comm=MPI.COMM_WORLD)
    assert out["schur"][3].C is not None
    assert_agree(out)


@pytest.mark.parametrize("pc", ["bfbt", "aux"])
def test_new_tau_refactorises(pc):
    def halve(flow):
        flow.tau = flow.tau / 2

    out = states(lambda comm, kind: bnn(comm, kind, pc=pc), 2, then=halve)
    assert out["schur"][3].factorisations == 2
    if pc == "aux":
        assert out["schur"][3].aux.rebuilds == 2  # the new A_c makes H stale
    assert_agree(out)


def test_structure_check_sees_couplings():
    """A_const passes; K (with the constraint block) couples the multipliers to y."""
    flow = bnn(MPI.COMM_SELF, "schur")
    split = flow.solver.components, flow.solver.multipliers
    assert schur.unsupported(flow.A_const, split) == ""
    flow.assemble_system()
    assert "couples multipliers" in schur.unsupported(flow.K, split)
    flow.destroy()


def test_unsupported_structure_falls_back(caplog, monkeypatch):
    monkeypatch.setattr(schur, "unsupported", lambda *_: "the implicit part couples components")
    monkeypatch.setattr(schur, "_reported", set())
    with caplog.at_level(logging.WARNING, logger="dgplate.solvers.schur"):
        flow = bnn(MPI.COMM_SELF, "schur")
    assert isinstance(flow.solver, linear.LaggedStepSolver)
    if MPI.COMM_WORLD.rank == 0:
        assert any("couples components" in r.getMessage() for r in caplog.records)
    flow.destroy()


@pytest.mark.mpi
def test_same_result_on_one_and_two_ranks():
    results = []
    for comm in (MPI.COMM_SELF, MPI.COMM_WORLD):
        flow = bnn(comm, "schur", projection_steps=1)
        result = flow.run(3)
        results.append((result.energy, result.defect))
        assert isinstance(flow.solver, schur.SchurStepSolver)
        flow.destroy()
    (e1, d1), (e2, d2) = results
    assert e2 == pytest.approx(e1, rel=AGREE, abs=0)
    assert d2 == pytest.approx(d1, rel=1e-6, abs=1e-13)
