"""The interior-penalty dG core on the clamped biharmonic problem (docs/design.md §8,
"Linear biharmonic problem"; measured rates in docs/verification.md).

Manufactured solution u = x²(1−x)²y²(1−y)² on (0,1)², clamped on all sides. Theory for degree
k: broken H² error O(h^{k−1}), H¹ O(h^k), L² O(h^{k+1}) for k ≥ 3 (O(h²) for k = 2).
"""

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from helpers import rates

from dgplate.dg.forms import Penalty, facet_sets
from dgplate.mesh.tagged import RECTANGLE_SIDES, load_geo, rectangle
from dgplate.solvers.biharmonic import solve_biharmonic

LEVELS = [4, 8, 16, 32, 64]

# (cell type, degree, penalty, expected rates H², H¹, L²). Penalties: the value-jump penalty
# must grow with the degree for stability; beyond that the smallest stable values show the
# asymptotic rates on the coarsest meshes.
CASES = [
    ("quadrilateral", 2, Penalty(100.0, 100.0), (1.0, 2.0, 2.0)),
    ("triangle", 2, Penalty(10.0, 10.0), (1.0, 2.0, 2.0)),
    # over-penalised gradient jumps (γ₁h⁻³, used for bilayers): still consistent, same rates
    ("quadrilateral", 2, Penalty(100.0, 100.0, gradient_power=3.0), (1.0, 2.0, 2.0)),
    ("triangle", 3, Penalty(1000.0, 50.0), (2.0, 3.0, 4.0)),
]


def exact_solution(mesh, shape=()):
    x = ufl.SpatialCoordinate(mesh)
    u = x[0] ** 2 * (1 - x[0]) ** 2 * x[1] ** 2 * (1 - x[1]) ** 2
    return ufl.as_vector([u, 2 * u, -u]) if shape else u


def solve_on(comm, n, cell_type, degree, penalty, shape=()):
    tagged = rectangle(comm, [[0, 0], [1, 1]], [n, n], cell_type)
    faces = facet_sets(tagged, clamped=RECTANGLE_SIDES)
    return solve_biharmonic(faces, degree, exact_solution(tagged.mesh, shape), penalty, shape)


@pytest.mark.parametrize("cell_type,degree,penalty,expected", CASES)
def test_convergence_rates(cell_type, degree, penalty, expected, capsys):
    results = [solve_on(MPI.COMM_SELF, n, cell_type, degree, penalty) for n in LEVELS]
    table = {key: [r.errors[key] for r in results] for key in ("H2", "H1", "L2")}
    observed = {key: rates(errs) for key, errs in table.items()}
    with capsys.disabled():
        print(
            f"\n{cell_type} k={degree} (γ0={penalty.gamma0}, γ1={penalty.gamma1}, p={penalty.gradient_power})"
        )
        print(
            f"{'cells':>6} {'dofs':>7} {'H2 err':>10} rate {'H1 err':>10} rate {'L2 err':>10} rate"
        )
        for i, (n, r) in enumerate(zip(LEVELS, results)):
            row = f"{n:>3}x{n:<3}{r.dofs:>7}"
            for key in ("H2", "H1", "L2"):
                rate = f"{observed[key][i - 1]:4.2f}" if i else "  - "
                row += f" {r.errors[key]:10.3e} {rate}"
            print(row)
    for key, theory in zip(("H2", "H1", "L2"), expected):
        assert abs(observed[key][-1] - theory) <= 0.15, (key, observed[key])
        assert all(np.diff(table[key]) < 0), f"{key} errors must decrease: {table[key]}"


def test_vector_unknown_matches_scalar():
    """The ℝ³ unknown decouples into three scalar problems: errors scale with the data."""
    scalar = solve_on(MPI.COMM_SELF, 8, "quadrilateral", 2, Penalty(100.0, 100.0))
    vector = solve_on(MPI.COMM_SELF, 8, "quadrilateral", 2, Penalty(100.0, 100.0), (3,))
    for key in ("H2", "H1", "L2"):
        assert vector.errors[key] == pytest.approx(np.sqrt(6) * scalar.errors[key], rel=1e-9)
    assert vector.dofs == 3 * scalar.dofs


@pytest.mark.mpi
@pytest.mark.parametrize("source", ["builtin", "gmsh"])
def test_errors_independent_of_ranks(source):
    """The same errors on every communicator size (run under mpirun -n 2 by `make test`)."""

    def errors(comm):
        if source == "builtin":
            return solve_on(comm, 8, "quadrilateral", 2, Penalty(100.0, 100.0)).errors
        tagged = load_geo(comm, "rectangle", {"Lx": 1, "Ly": 1, "h": 0.15})
        faces = facet_sets(tagged, clamped=RECTANGLE_SIDES)
        penalty = Penalty(10.0, 10.0)
        return solve_biharmonic(faces, 2, exact_solution(tagged.mesh), penalty).errors

    parallel, serial = errors(MPI.COMM_WORLD), errors(MPI.COMM_SELF)
    for key in parallel:
        assert parallel[key] == pytest.approx(serial[key], rel=1e-10, abs=0)
