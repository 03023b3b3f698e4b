"""The cell-wise numbering handed to MUMPS: a permutation, and the same on any number of ranks."""

from typing import Any, cast

from mpi4py import MPI

import basix.ufl
import dolfinx.fem
import numpy as np
import pytest
from helpers import bnn_flow as vertical_load_flow
from petsc4py import PETSc

from dgplate.mesh.tagged import rectangle
from dgplate.solvers.ordering import cellwise_numbering


def _cellwise_step_matrix(comm) -> tuple[PETSc.Mat, PETSc.IS]:
    flow = vertical_load_flow(comm, 6)
    flow.step()  # a bent state: every constraint entry is filled
    flow.system.assemble()
    numbering = cellwise_numbering(flow.W)
    assert numbering is not None
    return flow.system.K.createSubMatrix(numbering, numbering), numbering


@pytest.mark.mpi
def test_cellwise_numbering_is_a_permutation(comm):
    P, numbering = _cellwise_step_matrix(comm)
    rows = np.concatenate(comm.allgather(numbering.getIndices()))
    assert np.array_equal(np.sort(rows), np.arange(P.getSize()[0]))
    # each rank keeps as many rows as it owns in DOLFINx's numbering
    assert numbering.getLocalSize() == P.getLocalSize()[0]


@pytest.mark.mpi
def test_cellwise_step_matrix_does_not_depend_on_the_partition(comm):
    """In the cell-wise numbering the step matrix on N ranks equals the serial one, entry for
    entry (to round-off from the summation order): MUMPS then orders the same graph."""
    serial, _ = _cellwise_step_matrix(MPI.COMM_SELF)
    parallel, _ = _cellwise_step_matrix(comm)
    n = serial.getSize()[0]
    probe = np.sin(np.arange(n) + 1.0)  # a vector given in the cell-wise numbering
    x = parallel.createVecRight()
    first, last = x.getOwnershipRange()
    x.setArray(probe[first:last])
    y = parallel.createVecLeft()
    parallel.mult(x, y)
    mine = np.concatenate(comm.allgather(y.getArray()))
    reference = serial.createVecLeft()
    serial.mult(_vec(serial, probe), reference)
    scale = np.max(np.abs(reference.getArray()))
    assert np.max(np.abs(mine - reference.getArray())) <= 1e-12 * scale
    # the same sparsity graph, not only the same action
    assert (
        parallel.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"]
        == serial.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"]
    )


def _vec(A: PETSc.Mat, values: np.ndarray) -> PETSc.Vec:
    v = A.createVecRight()
    v.setArray(cast(Any, values))  # petsc4py's stub asks for a Sequence; it takes any array
    return v


def test_no_cellwise_numbering_for_continuous_spaces():
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [3, 3])
    mesh = tagged.mesh
    continuous = dolfinx.fem.functionspace(mesh, basix.ufl.element("Lagrange", "quadrilateral", 2))
    broken = dolfinx.fem.functionspace(
        mesh, basix.ufl.element("DG", "quadrilateral", 2, shape=(3,))
    )
    assert cellwise_numbering(continuous) is None
    numbering = cellwise_numbering(broken)
    assert numbering is not None
    assert np.array_equal(np.sort(numbering.getIndices()), np.arange(9 * 27))
