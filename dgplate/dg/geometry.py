"""Geometry of a mesh that several layers need: cell sizes, written once."""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.mesh
import numpy as np


def max_cell_diameter(mesh: dolfinx.mesh.Mesh) -> float:
    """The largest cell diameter over all ranks (τ = 'h' in problem files, as published)."""
    tdim = mesh.topology.dim
    num_owned = mesh.topology.index_map(tdim).size_local
    local = mesh.h(tdim, np.arange(num_owned, dtype=np.int32))
    return float(mesh.comm.allreduce(float(local.max(initial=0.0)), op=MPI.MAX))
