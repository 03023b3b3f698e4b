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

from dgplate.mesh.tagged import rectangle
from dgplate.solvers.newton import Continuation, LoadStep, record_type


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
    with Continuation(
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
    with Continuation(u, energy, bcs, load_factor, [1.0], "dgplate_test_prefix_", **keys):
        with pytest.raises(ValueError, match="in use"):
            Continuation(u, energy, bcs, load_factor, [1.0], "dgplate_test_prefix_", **keys)
    assert not any(k.startswith("dgplate_test_prefix_") for k in PETSc.Options().getAll())
    for schedule in ([], [0.5, 0.5], [float("nan")], [0.0]):
        with pytest.raises(ValueError):
            Continuation(u, energy, bcs, load_factor, schedule, "dgplate_test_schedule_", **keys)


def test_probe_fields():
    cls = record_type(["w_center"])
    row = cls(step=1, load_factor=0.5, iterations=2, residual=0.0, energy=1.0, seconds=0.1,
              w_center=3.0)  # fmt: skip
    assert "w_center 3" in row.line() and row.line().startswith("load step    1")
    with pytest.raises(ValueError, match="energy"):
        record_type(["energy"])
