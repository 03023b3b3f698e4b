"""Isometry-constrained Kirchhoff plates: Bonito–Nochetto–Ntogkas (M3AS 2021), Table 1.

ω = (0,4)², clamped on two perpendicular edges, f = (0, 0, 2.5e−2), Q2, γ₀ = 5000, γ₁ = 1100,
τ = h, stop when (E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < 1e−6.
"""

import math

from mpi4py import MPI

import numpy as np
import pytest
from helpers import PARITY_RTOL
from helpers import bnn_flow as vertical_load_flow

from dgplate.mesh.tagged import rectangle
from dgplate.models.kirchhoff import KirchhoffSpec, build_kirchhoff
from dgplate.reference.bnn import BNN_TABLE1
from dgplate.solvers.flow import FlowSpec, GradientFlow

TABLE1 = BNN_TABLE1


@pytest.mark.parametrize("n", [16, 32])
def test_table1_rows(n):
    flow = vertical_load_flow(MPI.COMM_SELF, n)
    result = flow.run()
    energy, defect, steps = TABLE1[n]
    print(
        f"\n{n}x{n}: E_h = {result.energy:.4e} (paper {energy}), D_h = {result.defect:.4e} "
        f"(paper {defect}), steps = {result.steps} (paper {steps})"
    )
    assert result.converged
    assert flow.num_dofs == 30 * n * n  # 27 displacement + 3 multiplier dofs per cell
    assert result.energy == pytest.approx(energy, rel=5e-3)
    assert result.defect == pytest.approx(defect, rel=1e-2)
    assert abs(result.steps - steps) <= 2
    energies = [h.energy for h in result.history]
    assert all(np.diff(energies) < 0), "the energy must decrease at every step"
    assert not result.energy_increases


def test_defect_scales_with_tau():
    """D_h = O(τ): halving τ on 16×16 roughly halves the isometry defect."""
    h = math.sqrt(2) / 4
    defects = [vertical_load_flow(MPI.COMM_SELF, 16, tau=tau).run().defect for tau in (h, h / 2)]
    ratio = defects[0] / defects[1]
    print(f"\nD_h(τ = h) / D_h(τ = h/2) = {ratio:.3f}")
    assert 1.6 < ratio < 2.4


def test_triangles_p2_run():
    """P2 on triangles, similar DoFs to 16×16 Q2 (7,680): the flow converges monotonically."""
    flow = vertical_load_flow(MPI.COMM_SELF, 14, cell_type="triangle")
    result = flow.run()
    print(
        f"\nP2 triangles 14x14x2, {flow.num_dofs} dofs: E_h = {result.energy:.4e}, "
        f"D_h = {result.defect:.4e}, steps = {result.steps}"
    )
    assert result.converged
    assert all(np.diff([h.energy for h in result.history]) < 0)
    assert -2e-2 < result.energy < 0 and result.defect < 1e-2


def test_free_plate_balanced_load():
    """No clamped faces: the L² metric controls rigid motions, the flow runs and converges."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [4, 1]], [16, 4])
    # zero net force and zero net moment: symmetric about x = 2 with zero mean
    spec = KirchhoffSpec(clamped=[], load=[0, 0, "0.01*((x - 2)**2 - 4/3)"])
    model = build_kirchhoff(spec, tagged)
    assert not model.facets.has_clamped
    flow = GradientFlow(model.facets, 2, model.energy, FlowSpec(tau=0.1, max_steps=400))
    result = flow.run()
    assert result.converged, result.reason
    assert result.energy < 0 and np.isfinite(result.energy)
    assert all(np.diff([h.energy for h in result.history]) <= 1e-14)
    assert result.defect < 1e-2


@pytest.mark.mpi
@pytest.mark.parametrize(
    "solver, rtol_energy, rtol_defect",
    # the lagged solver stops GMRES at 1e-12 of |b|; partitions take different iterations,
    # and D_h, a small difference of large terms, then agrees to ~1e-8 rather than round-off
    [("direct", PARITY_RTOL, PARITY_RTOL), ("lagged", 1e-7, 1e-6)],
)
@pytest.mark.parity
def test_same_result_on_any_number_of_ranks(solver, rtol_energy, rtol_defect):
    serial = vertical_load_flow(MPI.COMM_SELF, 16, linear_solver=solver).run()
    parallel = vertical_load_flow(MPI.COMM_WORLD, 16, linear_solver=solver).run()
    assert parallel.steps == serial.steps
    assert parallel.energy == pytest.approx(serial.energy, rel=rtol_energy, abs=0)
    assert parallel.defect == pytest.approx(serial.defect, rel=rtol_defect, abs=0)


def test_lagged_factorisation_matches_direct_solves():
    """The default solver reuses one LU factorisation as a GMRES preconditioner over many
    steps; it must reproduce the flow of a fresh factorisation every step: same step count,
    E_h and D_h to 1e-8, and far fewer factorisations than steps."""
    results, factorisations = {}, {}
    for kind in ("direct", "lagged"):
        flow = vertical_load_flow(MPI.COMM_SELF, 16, linear_solver=kind)
        results[kind] = flow.run()
        factorisations[kind] = sum(h.factor_s > 0 for h in results[kind].history)
        flow.destroy()
    direct, lagged = results["direct"], results["lagged"]
    assert lagged.steps == direct.steps == 13
    assert lagged.energy == pytest.approx(direct.energy, rel=1e-8)
    assert lagged.defect == pytest.approx(direct.defect, rel=1e-8)
    assert factorisations["direct"] == 13
    assert factorisations["lagged"] <= 3
    assert all(h.iterations >= 1 for h in lagged.history)
    assert np.mean([h.iterations for h in lagged.history]) <= 12


@pytest.mark.mpi
def test_step_matrix_drops_only_exact_zeros():
    """The step matrix is stored without the constant block's exact zeros (the components of
    y do not couple): it must equal the matrix of the step form in DOLFINx's full pattern, entry
    for entry, with well under two thirds of its stored entries."""
    import dolfinx.fem.petsc
    from petsc4py import PETSc

    flow = vertical_load_flow(MPI.COMM_WORLD, 6)
    flow.step()  # b_n at a bent state: every constraint entry is filled
    flow.system.assemble()
    full = dolfinx.fem.petsc.assemble_matrix(flow.system.step_form)
    full.assemble()
    stored = (
        flow.system.K.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"],
        full.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"],
    )
    scale = full.norm(PETSc.NormType.FROBENIUS)
    full.axpy(-1.0, flow.system.K, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    assert full.norm(PETSc.NormType.FROBENIUS) <= 1e-14 * scale
    assert stored[0] < 0.6 * stored[1]
    flow.destroy()


def test_compact_matrix_refuses_a_nonzero_outside_its_pattern():
    """Zeros assembled into a dropped position are skipped; a non-zero there raises instead of
    being dropped or silently allocated."""
    from petsc4py import PETSc

    from dgplate.solvers.sparsity import without_exact_zeros

    dense = PETSc.Mat().createAIJ(size=(3, 3), nnz=3, comm=MPI.COMM_SELF)
    lgmap = PETSc.LGMap().create(np.arange(3, dtype=PETSc.IntType), comm=MPI.COMM_SELF)
    dense.setLGMap(lgmap, lgmap)
    dense.setValues(range(3), range(3), np.diag([1.0, 2.0, 0.0]).ravel())
    dense.assemble()
    compact = without_exact_zeros(dense, np.array([False, False, True]), np.array([2]))
    assert compact.getInfo()["nz_used"] == 7  # all but (0, 1) and (1, 0)
    compact.setValueLocal(0, 1, 0.0, addv=PETSc.InsertMode.ADD_VALUES)  # skipped
    compact.setValueLocal(2, 0, 3.0, addv=PETSc.InsertMode.ADD_VALUES)  # kept row
    with pytest.raises(PETSc.Error):
        compact.setValueLocal(0, 1, 1.0, addv=PETSc.InsertMode.ADD_VALUES)
