"""A start on another mesh of the same plate: a deformation interpolated between meshes.

A start is a function of the points (:data:`dgplate.solvers.flow.Initial`); a deformation
computed on another mesh (a coarser level of a convergence study) cannot be one under MPI,
where the points of a rank lie in cells of other ranks. :class:`MeshStart` carries it, and
:func:`interpolate` evaluates it by DOLFINx's interpolation between non-matching meshes
(``create_interpolation_data`` and ``Function.interpolate_nonmatching``, called the same way
in DOLFINx 0.9–0.11): collective, on every rank at once.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import dolfinx.fem
import numpy as np

from dgplate.compat import Array, Function
from dgplate.dg.geometry import max_cell_diameter
from dgplate.errors import InputError


@dataclass(frozen=True)
class MeshStart:
    """The start y⁰ = ``shape``, a deformation of the same plate on another mesh."""

    shape: Function

    def __call__(self, x: Array) -> Array:
        """Not a function of points: only the plates' gradient flow takes this start."""
        raise InputError(
            "initial: a deformation on another mesh starts a plate's gradient flow only"
        )


def interpolate(target: Function, start: MeshStart | Callable[[Array], Array]) -> None:
    """Interpolate ``start`` (a function of the points, or a :class:`MeshStart`) into ``target``.

    A :class:`MeshStart` is evaluated at ``target``'s interpolation points, which may lie
    outside its mesh where a curved boundary is meshed anew: the point is then taken in the
    nearest cell within a cell diameter. Collective.

    Args:
        target: the function to set.
        start: the start.
    """
    if not isinstance(start, MeshStart):
        target.interpolate(start)
        return
    mesh = target.function_space.mesh
    cells = np.arange(mesh.topology.index_map(mesh.topology.dim).size_local, dtype=np.int32)
    source = start.shape
    padding = max_cell_diameter(source.function_space.mesh)
    data = dolfinx.fem.create_interpolation_data(
        target.function_space, source.function_space, cells, padding
    )
    target.interpolate_nonmatching(source, cells, data)
    target.x.scatter_forward()
