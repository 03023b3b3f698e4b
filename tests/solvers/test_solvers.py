"""Step solvers: the default (lagged) solver must not fail where direct LU solves succeed.

A one-side-clamped strip with Z = [[−5, 0], [0, 0]], a coarse mesh and τ = 1 rolls up by
large rotations in its first steps. The previous step's (δy, λ) is then a guess whose residual
is ~10⁵‖b‖ (it violates the new linearised constraint), PETSc stops FGMRES with DIVERGED_DTOL
before the first iteration, and without a fall-back from a zero guess the flow stopped at
step 2. Both tests are ``mpi``: under mpirun every rank takes the same path and only rank 0
logs.
"""

import logging

from mpi4py import MPI

import helpers
import numpy as np
import pytest
from petsc4py import PETSc

from dgplate import compat
from dgplate.io.output import bounding_box
from dgplate.mesh.tagged import rectangle
from dgplate.models.bilayer import BilayerSpec, build_bilayer
from dgplate.models.kirchhoff import KirchhoffSpec, bnn_plate, build_kirchhoff
from dgplate.reference.bnn import bnn_h
from dgplate.solvers.flow import FlowSpec, GradientFlow
from dgplate.solvers.lagged import RATE_WINDOW


def rolling_strip(comm: MPI.Comm, linear_solver: str):
    """The 2×1 strip, clamped at x = 0, rolling about the y axis (radius 0.2: 1.6 turns)."""
    tagged = rectangle(comm, [[0, 0], [2, 1]], [8, 4])
    model = build_bilayer(BilayerSpec(clamped=["left"], Z=[[-5.0, 0.0], [0.0, 0.0]]), tagged)
    settings = FlowSpec(
        tau=1.0,
        max_steps=300,
        multiplier_degree=1,
        projection_steps=1,
        linear_solver=linear_solver,
    )
    flow = GradientFlow(model.facets, 2, model.energy, settings)
    result = flow.run()
    box = bounding_box(flow.y)
    flow.destroy()
    return result, box


def logged(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "dgplate.solvers.linear"]


@pytest.mark.mpi
def test_rolling_strip_default_solver_falls_back_and_matches_direct(comm, caplog):
    with caplog.at_level(logging.WARNING, logger="dgplate.solvers.linear"):
        lagged, box = rolling_strip(comm, "lagged")
    direct, _ = rolling_strip(comm, "direct")
    assert direct.converged, direct.reason
    assert lagged.converged, lagged.reason
    fallbacks = [info.fallbacks for info in lagged.history]
    print(
        f"\nrolling strip: lagged {lagged.steps} steps, E_h = {lagged.energy:.10e}, "
        f"{sum(fallbacks)} fall-back(s) at steps "
        f"{[i + 1 for i, n in enumerate(fallbacks) if n]}; direct {direct.steps} steps, "
        f"E_h = {direct.energy:.10e}; x-extent {box[1][0] - box[0][0]:.3f}"
    )
    assert lagged.energy == pytest.approx(direct.energy, rel=1e-8)
    assert lagged.steps == direct.steps
    assert lagged.defect < 1e-10
    assert box[1][0] - box[0][0] < 0.7, "the strip of length 2 rolls up (radius 0.2)"
    assert box[0][2] < -0.5, "it rolls downwards (Z₁₁ < 0) and over the clamped edge"
    assert fallbacks[1] >= 1, "step 2 is the one the old guess made fail"
    messages = logged(caplog)
    assert len(messages) == (sum(fallbacks) if comm.rank == 0 else 0)
    assert comm.rank or "DIVERGED_DTOL after 0 iterations" in messages[0]


@pytest.mark.mpi
def test_failed_fresh_factors_fall_back_to_a_direct_solve(comm, caplog):
    """FGMRES limited to one iteration at an unreachable tolerance fails with any factors:
    every solve then ends in the direct LU solve, which gives the direct solver's flow."""
    tagged = rectangle(comm, [[0, 0], [4, 4]], [4, 4])
    spec = KirchhoffSpec(clamped=["left", "bottom"], load=[0.0, 0.0, 0.025])
    model = build_kirchhoff(spec, tagged)
    results = {}
    for kind, options in (("direct", {}), ("lagged", {"ksp_max_it": 1, "ksp_rtol": 1e-30})):
        settings = FlowSpec(tau=1.0, max_steps=3, linear_solver=kind, solver=options)
        flow = GradientFlow(model.facets, 2, model.energy, settings)
        with caplog.at_level(logging.WARNING, logger="dgplate.solvers.linear"):
            results[kind] = flow.run()
        flow.destroy()
    lagged, direct = results["lagged"], results["direct"]
    assert [info.fallbacks for info in lagged.history] == [2, 2, 2]
    messages = logged(caplog)
    assert len(messages) == (6 if comm.rank == 0 else 0)
    assert comm.rank or "with fresh factors failed" in messages[-1]
    assert np.allclose(
        [h.energy for h in lagged.history], [h.energy for h in direct.history], rtol=1e-12
    )


def bnn_flow(comm: MPI.Comm, **settings) -> GradientFlow:
    """The BNN vertical-load plate on 4×4 cells, τ = 1."""
    return helpers.bnn_flow(comm, 4, **{"tau": 1.0, **settings})


@pytest.mark.mpi
def test_step_matrix_carried_by_increments_equals_its_whole_assembly(comm):
    """K follows yⁿ by B(yⁿ − y_K) (b_n is linear in y): after five increments it equals
    A_const + B(yⁿ) assembled whole, to round-off."""
    flow = bnn_flow(comm, max_steps=5)
    flow.run()
    system = flow.system
    system.assemble()  # K for the state after step 5, as the next step would have it
    assert system._K_updates == 5  # steps 2–6 added increments; step 1 assembled K whole
    whole = system.K.duplicate(copy=False)
    compat.assemble_matrix_into(whole, system._a_const)
    compat.add_matrix_form(whole, system._b)
    scale = whole.norm(PETSc.NormType.INFINITY)
    whole.axpy(-1.0, system.K)
    assert whole.norm(PETSc.NormType.INFINITY) < 1e-13 * scale
    whole.destroy()
    flow.destroy()


@pytest.mark.mpi
def test_lagged_solver_refactorises_ldlt_without_a_copy_cache(comm):
    """The lagged solver factorises the symmetric step matrix as LDLᵀ, makes a new permuted
    copy at each refactorisation without PETSc's reuse cache, and gives the direct LU flow."""
    results = {}
    for kind in ("lagged", "direct"):
        flow = bnn_flow(comm, max_steps=4, linear_solver=kind, refactor_its=1)
        results[kind] = flow.run()
        if kind == "lagged":
            solver = flow.system.solver
            assert solver.factor_ksp.getPC().getType() == "cholesky"
            assert solver.factorisations >= 2  # a refactorisation with a new copy
            assert solver.P.query("SubMatrix") is None
            # PETSc's own copy keeps the cache under MPI: what _permuted_copy drops is there
            raw = solver.K.createSubMatrix(solver.numbering, solver.numbering)
            assert (raw.query("SubMatrix") is not None) == (comm.size > 1)
            raw.destroy()
        flow.destroy()
    assert np.allclose(
        [h.energy for h in results["lagged"].history],
        [h.energy for h in results["direct"].history],
        rtol=1e-9,
    )


@pytest.mark.mpi
def test_lagged_solver_keeps_lu_for_another_factor_package(comm):
    """LDLᵀ is MUMPS's: with SuperLU_dist named, the lagged solver factorises K as LU (a
    Cholesky there would fail on the saddle point) and gives the default solver's flow."""
    energies = {}
    for package in ("superlu_dist", "mumps"):
        flow = bnn_flow(comm, max_steps=3, solver={"pc_factor_mat_solver_type": package})
        energies[package] = [h.energy for h in flow.run().history]
        pc = flow.system.solver.factor_ksp.getPC()
        assert pc.getFactorSolverType() == package
        assert pc.getType() == ("lu" if package == "superlu_dist" else "cholesky")
        flow.destroy()
    assert np.allclose(energies["superlu_dist"], energies["mumps"], rtol=1e-9)


@pytest.mark.mpi
def test_lagged_solve_that_stagnates_is_stopped_early(comm):
    """On the BNN plate (16², τ = h) the third step's FGMRES, preconditioned by the first
    step's factors, drops fast and then stagnates near 10⁻⁹ of ‖r₀‖, short of its target: it
    is stopped once its recent rate cannot reach the target within ksp_max_it, redone with
    fresh factors, and the flow equals the direct LU flow."""
    model = bnn_plate(comm, 16)
    results = {}
    for kind in ("lagged", "direct"):
        settings = FlowSpec(tau=bnn_h(16), max_steps=4, linear_solver=kind)
        flow = GradientFlow(model.facets, model.degree, model.energy, settings)
        results[kind] = flow.run()
        flow.destroy()
    lagged = results["lagged"].history
    print("\nFGMRES iterations per step:", [h.iterations for h in lagged])
    stopped = [h for h in lagged[1:] if h.factor_s > 0 and h.iterations > settings.refactor_its]
    # Serially the stagnating step comes at step 3, every time. On 2 ranks the factorisation's
    # round-off differs between runs, and so does whether a solve stagnates: CI runs gave
    # [2, 9, 17, 6] (stopped at step 3) and [2, 17, 1, 6] (step 2 converged in 17 with old
    # factors, step 3 refactorised at once), so the scenario itself is asserted serially only.
    if comm.size == 1:
        assert stopped, "a step with old factors past refactor_its was redone with fresh ones"
    # stopped within two rate windows past refactor_its, well before ksp_max_it = 30, then a
    # few more with fresh factors (13 + 1 serially; 15 + 2 on 2 ranks in one CI run, where
    # parallel round-off changed the stagnating tail's rate; 30 + 1 without the early stop)
    assert all(h.iterations <= settings.refactor_its + 2 * RATE_WINDOW for h in lagged)
    assert not any(h.fallbacks for h in lagged)
    assert np.allclose(
        [h.energy for h in lagged], [h.energy for h in results["direct"].history], rtol=1e-9
    )
