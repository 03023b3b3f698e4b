"""Matrices stored in the sparsity of their actual couplings.

DOLFINx allocates a form's matrix from the dofmaps: on a vector-valued (mixed) space every
degree of freedom of a cell couples to every other one of that cell and its facet neighbours.
The flow's constant block does not couple the three components of y (bending and metric are
sums over components), so two thirds of the stored entries are exact zeros. Dropping them
halves the memory of the step matrix, makes its products three times cheaper and shrinks the
LU factors (fewer structural nonzeros for the ordering).
"""

from __future__ import annotations

from typing import Any, cast

import dolfinx.common
import numpy as np
import numpy.typing as npt
from petsc4py import PETSc

from dgplate import compat

#: Stored entries handled at once by :func:`without_exact_zeros`.
_BLOCK_ENTRIES = 1 << 22


def without_exact_zeros(
    A: PETSc.Mat, keep_rows: npt.NDArray[np.bool_], keep_cols: npt.NDArray[np.int64]
) -> PETSc.Mat:
    """A copy of the assembled ``A`` without its exact zeros.

    Entries in the owned rows flagged by ``keep_rows`` (a mask over the local rows) and in the
    columns listed in ``keep_cols`` (sorted global indices) are kept whatever their value:
    those are the rows and columns whose values change later (the constraint block), zero or
    not now. The copy has A's local-to-global maps, so forms assemble into it as into A;
    zeros are then skipped, and a non-zero outside the pattern raises instead of being
    silently allocated.
    """
    # the CSR copy of A lives only inside _kept_entries: freed before the compact copy is made
    counts, kept_indices, kept_values = _kept_entries(*A.getValuesCSR(), keep_rows, keep_cols)
    new_indptr = np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType)
    # petsc4py's stubs want sequences where it takes arrays, and call sizes layouts
    sizes = cast("tuple[tuple[int, int], tuple[int, int]]", A.getSizes())
    new_indices = np.concatenate([np.zeros(0, PETSc.IntType), *kept_indices])
    new_values = np.concatenate([np.zeros(0, PETSc.ScalarType), *kept_values])
    csr = (new_indptr, new_indices.astype(PETSc.IntType, copy=False), new_values)
    compact = PETSc.Mat().createAIJ(size=sizes, csr=csr, comm=A.comm)  # type: ignore[arg-type]
    compact.setLGMap(*A.getLGMap())
    compact.assemble()
    compact.setOption(compat.IGNORE_ZERO_ENTRIES, True)
    compact.setOption(compat.NEW_NONZERO_LOCATION_ERR, True)
    return compact


def _kept_entries(
    indptr: npt.NDArray[np.integer[Any]],
    indices: npt.NDArray[np.integer[Any]],
    values: npt.NDArray[np.inexact[Any]],
    keep_rows: npt.NDArray[np.bool_],
    keep_cols: npt.NDArray[np.int64],
) -> tuple[
    npt.NDArray[np.int64], list[npt.NDArray[np.integer[Any]]], list[npt.NDArray[np.inexact[Any]]]
]:
    """Per local row, the number of entries kept; the kept columns and values, by row block.

    In blocks of rows: the masks and the row index of each entry are then never whole-matrix
    arrays (at 256² they would be several GB per rank, next to the matrix and its copy). The
    kept arrays are copies, so the caller's CSR arrays can be freed once this returns.
    """
    num_rows = len(indptr) - 1
    counts = np.zeros(num_rows, dtype=np.int64)
    kept_indices, kept_values = [], []
    rows_per_block = max(1, _BLOCK_ENTRIES * num_rows // max(len(indices), 1))
    for first in range(0, num_rows, rows_per_block):
        last = min(first + rows_per_block, num_rows)
        lo, hi = indptr[first], indptr[last]
        rows = np.repeat(np.arange(first, last), np.diff(indptr[first : last + 1]))
        cols, vals = indices[lo:hi], values[lo:hi]
        keep = (vals != 0.0) | keep_rows[rows] | np.isin(cols, keep_cols)
        counts[first:last] = np.bincount(rows[keep] - first, minlength=last - first)
        kept_indices.append(cols[keep])
        kept_values.append(vals[keep])
    return counts, kept_indices, kept_values


def global_indices(
    index_map: dolfinx.common.IndexMap, bs: int, local: npt.NDArray[np.int64]
) -> npt.NDArray[np.int64]:
    """Global indices of local (owned or ghost) degrees of freedom of a blocked index map."""
    blocks = index_map.local_to_global(np.asarray(local // bs, dtype=np.int32))
    indices: npt.NDArray[np.int64] = np.asarray(blocks, dtype=np.int64) * bs + local % bs
    return indices
