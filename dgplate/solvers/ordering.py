"""A numbering of the unknowns that does not depend on how the mesh is partitioned.

MUMPS chooses its elimination order (METIS nested dissection) from the sparsity graph in the
global numbering it is given. DOLFINx numbers the unknowns rank by rank, so 1, 2 and 3 ranks
hand MUMPS differently numbered copies of the same graph, and METIS, which is sensitive to the
numbering, returns orderings whose fill differs by up to ~10 %. On the BNN 64² plate the 2-rank
factors held 125 M entries against 114 M on 1 rank, which capped the 1 → 2-rank speed-up of the
substitutions that dominate the flow.

For discontinuous spaces every unknown belongs to exactly one cell, so (original cell index,
local unknown) numbers the unknowns in the same way on any number of ranks: MUMPS then sees the
same graph, orders it the same, and only splits the elimination tree between the ranks. The
factors differ from the serial ones only by the parallel splitting (117 M entries in all on 2
ranks, 59 M per rank, at 64²), and the pivot order no longer depends on the partition.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from dgplate import mpi
from dgplate.compat import FunctionSpace


def cellwise_numbering(space: FunctionSpace) -> PETSc.IS | None:
    """Rows of the cell-wise numbering owned here, as global indices of the space's numbering.

    The cell-wise number of the j-th unknown of the cell with original index c is c·n + j (n
    unknowns per cell). Each rank owns as many rows of that numbering as it owns unknowns, so
    the returned IS (of the space's index-map communicator) selects the permuted matrix with
    ``A.createSubMatrix(is_, is_)``. ``None`` when unknowns are shared between cells
    (continuous spaces), where no such numbering exists.
    """
    mesh = space.mesh
    tdim = mesh.topology.dim
    cells = mesh.topology.index_map(tdim)
    imap, bs = space.dofmap.index_map, space.dofmap.index_map_bs
    comm = imap.comm
    dofs = space.dofmap.list[: cells.size_local]
    if bs > 1:
        dofs = (dofs[:, :, None] * bs + np.arange(bs)).reshape(dofs.shape[0], -1)
    per_cell = dofs.shape[1]
    owned = imap.size_local * bs
    if per_cell * cells.size_global != imap.size_global * bs:
        return None  # some unknown is shared between cells
    original = np.asarray(mesh.topology.original_cell_index[: cells.size_local], dtype=np.int64)
    # each owned cell holds only owned unknowns, and all of them: the rows this rank owns
    local_ok = (
        dofs.size == owned
        and (dofs.size == 0 or int(dofs.max()) < owned)
        and len(original) == cells.size_local
    )
    largest = int(mpi.global_max(comm, int(original.max(initial=-1))))
    if not mpi.global_all(comm, local_ok) or largest != cells.size_global - 1:
        return None  # no usable original cell indices (a mesh built in an unusual way)
    start = imap.local_range[0] * bs
    cellwise = (original[:, None] * per_cell + np.arange(per_cell)).reshape(-1)
    native = start + dofs.reshape(-1).astype(np.int64)
    # petsc4py's stubs want sequences where it takes arrays
    ordering = PETSc.AO().createMemoryScalable(
        cellwise.astype(PETSc.IntType), native.astype(PETSc.IntType), comm=comm
    )
    wanted = np.arange(start, start + owned, dtype=PETSc.IntType)
    rows = ordering.app2petsc(wanted)  # type: ignore[arg-type]
    ordering.destroy()
    indices = np.asarray(rows, dtype=PETSc.IntType)
    return PETSc.IS().createGeneral(indices, comm=comm)  # type: ignore[arg-type]
