"""The Newton continuation driver (dgplate.solvers.newton) on a problem that is not a plate.

Π(u) = ∫ ½|∇u|² + ¼u⁴ − λ f u on the unit square, u = λ g on the left edge: the driver sees
only a state, an energy, conditions and a load factor.
"""

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest
import ufl
from petsc4py import PETSc

from dgplate.errors import SolverError
from dgplate.mesh.tagged import rectangle
from dgplate.solvers import eigen
from dgplate.solvers.newton import LoadPath, LoadStep, Stability, record_type


def scalar_problem(comm=MPI.COMM_SELF):
    tagged = rectangle(comm, [[0, 0], [1, 1]], [6, 6])
    mesh = tagged.mesh
    space = dolfinx.fem.functionspace(mesh, ("Lagrange", 1))
    u = dolfinx.fem.Function(space, name="u")
    load_factor = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
    f = dolfinx.fem.Constant(mesh, PETSc.ScalarType(40.0))
    energy = (
        0.5 * ufl.inner(ufl.grad(u), ufl.grad(u)) + 0.25 * u**4 - load_factor * f * u
    ) * ufl.dx
    value = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
    dofs = dolfinx.fem.locate_dofs_topological(space, 1, tagged.facets("left"))
    bc = dolfinx.fem.dirichletbc(value, dofs, space)
    return u, energy, [bc], load_factor, value


def shape_of(u):
    space = dolfinx.fem.functionspace(u.function_space.mesh, ("Lagrange", 1, (3,)))
    y = dolfinx.fem.Function(space)

    def shape():
        y.interpolate(lambda x: np.vstack([x[0], x[1], 0 * x[0]]))
        return y

    return shape


def test_generic_energy_and_boundary_data():
    u, energy, bcs, load_factor, value = scalar_problem()
    peak = {"u_max": lambda: float(u.x.array.max())}
    with LoadPath(
        u, energy, bcs, load_factor, [0.5, 1.0], "dgplate_test_newton_",
        bc_values=[(value, 0.1)], shape=shape_of(u), probes=lambda: {k: f() for k, f in peak.items()},
    ) as driver:  # fmt: skip
        result = driver.run()
        assert result.converged and result.steps == 2 and driver.time == 1.0
        assert float(value.value) == pytest.approx(0.1)  # the boundary data follow the load
        record = driver.history[-1]
        assert isinstance(record, LoadStep) and record.u_max > 0.1
        assert record.iterations <= 6 and record.residual < 1e-9
        assert driver.shape.ufl_shape == (3,)
        assert driver.summary()["load_factors"] == [0.5, 1.0]


def test_one_live_driver_per_prefix_and_checked_schedules():
    u, energy, bcs, load_factor, _ = scalar_problem()
    keys = dict(shape=shape_of(u))
    with LoadPath(u, energy, bcs, load_factor, [1.0], "dgplate_test_prefix_", **keys):
        with pytest.raises(ValueError, match="in use"):
            LoadPath(u, energy, bcs, load_factor, [1.0], "dgplate_test_prefix_", **keys)
    assert not any(k.startswith("dgplate_test_prefix_") for k in PETSc.Options().getAll())
    for schedule in ([], [0.5, 0.5], [float("nan")], [0.0]):
        with pytest.raises(ValueError):
            LoadPath(u, energy, bcs, load_factor, schedule, "dgplate_test_schedule_", **keys)


def test_probe_fields():
    cls = record_type(["w_center"])
    row = cls(step=1, load_factor=0.5, iterations=2, residual=0.0, energy=1.0, seconds=0.1,
              w_center=3.0)  # fmt: skip
    assert "w_center 3" in row.line() and row.line().startswith("load step    1")
    with pytest.raises(ValueError, match="energy"):
        record_type(["energy"])


# -- stability: Hessian eigenvalues (dgplate.solvers.eigen) -------------------------------------
def laplacian_1d(n, shift, comm=MPI.COMM_WORLD):
    """tridiag(−1, 2, −1) − shift·I: eigenvalues 2 − 2cos(kπ/(n+1)) − shift, k = 1 … n."""
    A = PETSc.Mat().createAIJ([n, n], nnz=3, comm=comm)
    start, end = A.getOwnershipRange()
    for i in range(start, end):
        A[i, i] = 2.0 - shift
        if i > 0:
            A[i, i - 1] = -1.0
        if i < n - 1:
            A[i, i + 1] = -1.0
    A.assemble()
    exact = 2 - 2 * np.cos(np.arange(1, n + 1) * np.pi / (n + 1)) - shift
    return A, exact


@pytest.mark.mpi
@pytest.mark.parametrize("solver", ["slepc", "lanczos"])
def test_eigenvalues_nearest_zero_of_an_indefinite_matrix(solver):
    """Both solvers find the eigenvalues nearest 0 of an indefinite matrix, on any ranks."""
    if solver == "slepc" and not eigen.have_slepc():
        pytest.skip("slepc4py is not importable")
    A, exact = laplacian_1d(200, shift=0.05)
    pairs = eigen.nearest_eigenpairs(A, 3, solver=solver)
    nearest = np.sort(exact[np.argsort(np.abs(exact))[:3]])
    assert pairs.solver == solver and pairs.values == pytest.approx(nearest, rel=1e-8)
    assert pairs.values[0] < 0 < pairs.values[-1]
    for value, vector in zip(pairs.values, pairs.vectors):  # unit eigenvectors, signed
        residual = A.createVecLeft()
        A.mult(vector, residual)
        residual.axpy(-value, vector)
        assert residual.norm() < 1e-6 and vector.norm() == pytest.approx(1.0)
        assert vector.sum() > -1e-10  # signed (an odd mode has sum 0 either way)
    pairs.destroy()
    A.destroy()


def test_fallback_without_slepc(monkeypatch):
    """Without slepc4py, "auto" is Lanczos; an unknown solver is refused."""
    monkeypatch.setattr(eigen, "have_slepc", lambda: False)
    assert eigen.resolve_solver("auto") == "lanczos"
    A, exact = laplacian_1d(50, shift=0.0, comm=MPI.COMM_SELF)
    pairs = eigen.nearest_eigenpairs(A, 1, shift=0.005)  # the lowest, the nearest the shift
    assert pairs.solver == "lanczos" and pairs.values == pytest.approx(exact[:1], rel=1e-9)
    with pytest.raises(ValueError, match="eigensolver must be one of"):
        eigen.resolve_solver("arpack")


STRAIGHT = [0.25, 0.45, 0.49, 0.51, 0.6, 0.8]
# past ½ the stable branch grows like √(λ − ½): steps that double λ − ½, so that Newton (not a
# descent method) from one state is attracted by the next one rather than by u = 0
AROUND = [0.25, 0.45, 0.49, 0.51, 0.52, 0.54, 0.58, 0.66, 0.8]


def pitchfork(comm, solver, perturb, schedule=STRAIGHT):
    """Π = ∫ ½|∇u|² − λc u²/2 + ¼u⁴, u = 0 on the left edge (P2, 8×8).

    u = 0 solves every load; its Hessian −Δ − λc loses positivity at λc = (π/2)², the lowest
    eigenvalue of −Δ on the unit square with u = 0 at x = 0 and ∂u/∂n = 0 elsewhere (mode
    sin(πx/2)). Beyond, u = 0 is unstable and a push along the mode leads to the stable branch.
    """
    tagged = rectangle(comm, [[0, 0], [1, 1]], [8, 8])
    mesh = tagged.mesh
    space = dolfinx.fem.functionspace(mesh, ("Lagrange", 2))
    u = dolfinx.fem.Function(space, name="u")
    load_factor = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
    c = dolfinx.fem.Constant(mesh, PETSc.ScalarType(2 * (np.pi / 2) ** 2))  # crossing at ½
    energy = (
        0.5 * ufl.inner(ufl.grad(u), ufl.grad(u)) - 0.5 * load_factor * c * u**2 + 0.25 * u**4
    ) * ufl.dx
    dofs = dolfinx.fem.locate_dofs_topological(space, 1, tagged.facets("left"))
    bc = dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), dofs, space)
    stability = Stability(perturb=perturb, solver=solver)
    peak = {"u_max": lambda: u.function_space.mesh.comm.allreduce(
        float(np.abs(u.x.array).max()), op=MPI.MAX)}  # fmt: skip
    return LoadPath(
        u, energy, [bc], load_factor, schedule, "dgplate_test_pitch_",
        shape=shape_of(u), probes=lambda: {k: f() for k, f in peak.items()}, stability=stability,
    )  # fmt: skip


@pytest.mark.mpi
@pytest.mark.parametrize("solver", ["auto", "lanczos"])
def test_eigenvalue_path_crossing_and_perturbation(solver):
    """The lowest eigenvalue crosses zero at λ = ½ (P2 8×8: within 0.1 %), on 1 or 2 ranks."""
    with pitchfork(MPI.COMM_WORLD, solver, perturb=0.0) as driver:
        assert driver.run().converged
        summary = driver.summary()
        lowest = summary["lowest_eigenvalues"]
        assert lowest[:3] == sorted(lowest[:3], reverse=True) and lowest[2] > 0 > lowest[3]
        assert summary["critical_load_factor"] == pytest.approx(0.5, rel=1e-3)
        assert summary["perturbations"] == [] and driver.history[-1].u_max == 0
    with pitchfork(MPI.COMM_WORLD, solver, perturb=0.05, schedule=AROUND) as driver:
        assert driver.run().converged
        summary, last = driver.summary(), driver.history[-1]
        push = summary["perturbations"]
        assert [p["load_factor"] for p in push] == [0.51] and push[0]["eigenvalue"] < 0
        assert min(summary["lowest_eigenvalues"]) > 0  # on the stable branch past ½
        # Landau: u ≈ A sin(πx/2), A² = 4(λ/λc − 1)λc/(3·1) at λ = 0.8 → max u ≈ 1.75
        assert last.u_max == pytest.approx(np.sqrt(4 * (0.8 / 0.5 - 1) * np.pi**2 / 4 / 3),
                                           rel=0.05)  # fmt: skip
        assert last.lowest_eigenvalue > 0 and summary["eigensolver"] in ("slepc", "lanczos")


@pytest.mark.parametrize("solver", ["slepc", "lanczos"])
def test_singular_shift_is_a_solver_error(solver):
    """K − σI singular (here K = 0): a SolverError, which the driver turns into a NaN."""
    if solver == "slepc" and not eigen.have_slepc():
        pytest.skip("slepc4py is not importable")
    A, _ = laplacian_1d(20, shift=2.0, comm=MPI.COMM_SELF)
    A.zeroEntries()
    A.assemble()
    with pytest.raises(SolverError, match=f"the eigensolver \\({solver}\\) failed near 0"):
        eigen.nearest_eigenpairs(A, 2, solver=solver)


def test_the_lifting_runs_only_where_the_iterate_misses_the_boundary_data(monkeypatch):
    """u = λ g on the left edge with g moving at each load step: skipping the lifting
    J(g − u) where u holds g exactly (it is zero) gives the states of a lifting at
    every residual bit for bit. A load step's first residual, where g has moved, lifts; the
    damped Newton steps reach g only to round-off here (1 of 9 residuals skips), fixed
    clamps exactly (the FvK cone of test_fvk_leave.py: 138 of 138)."""
    from dgplate.solvers import snes

    holds = snes.NewtonSolver._holds_dirichlet_data
    outcomes: list[bool] = []

    def counted(self, x):
        outcomes.append(holds(self, x))
        return outcomes[-1]

    states = []
    for check in (counted, lambda self, x: False):  # the second lifts at every residual
        monkeypatch.setattr(snes.NewtonSolver, "_holds_dirichlet_data", check)
        u, energy, bcs, load_factor, value = scalar_problem()
        with LoadPath(
            u, energy, bcs, load_factor, [0.5, 1.0], "dgplate_test_lifting_",
            bc_values=[(value, 0.1)], shape=shape_of(u),
        ) as driver:  # fmt: skip
            assert driver.run().converged
        states.append(u.x.array.copy())
    assert np.array_equal(states[0], states[1])
    assert not outcomes[0] and True in outcomes
