"""The one module that knows DOLFINx versions.

dgplate supports DOLFINx 0.9 (Debian 13), 0.10 and 0.11 (PyPI wheel). Every API difference
between those releases is absorbed here, so the rest of the package is written once.
Importing this module refuses an older or unknown-major DOLFINx with a clear message.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.mesh

from dgplate.errors import UnsupportedVersionError

MIN_VERSION = (0, 9)
MAX_TESTED_VERSION = (0, 11)


def _parse_version(text: str) -> tuple[int, int]:
    parts = text.split(".")
    return int(parts[0]), int(parts[1])


DOLFINX_VERSION: tuple[int, int] = _parse_version(dolfinx.__version__)


def require_supported_version(version: tuple[int, int] = DOLFINX_VERSION) -> None:
    """Raise ``UnsupportedVersionError`` for a DOLFINx older than 0.9."""
    if version < MIN_VERSION:
        raise UnsupportedVersionError(
            f"DOLFINx {version[0]}.{version[1]} is not supported: dgplate needs DOLFINx >= "
            f"{MIN_VERSION[0]}.{MIN_VERSION[1]} (Debian 13 python3-dolfinx, conda-forge "
            "fenics-dolfinx or `pip install dolfinx-solver-real`)"
        )


require_supported_version()


def shared_facet_partitioner() -> Callable[..., Any]:
    """A cell partitioner that ghosts the cells across shared facets (needed by dS integrals)."""
    cpp_create = dolfinx.cpp.mesh.create_cell_partitioner
    mode = dolfinx.mesh.GhostMode.shared_facet
    if DOLFINX_VERSION >= (0, 10):
        return cpp_create(mode, 2)
    return cpp_create(mode)


def gmsh_model_to_mesh(model: Any, comm: MPI.Comm, rank: int, gdim: int):
    """Build a shared-facet-ghosted mesh from a gmsh model.

    Returns ``(mesh, cell_tags, facet_tags)``; physical-group names are read by the caller
    from gmsh itself, which works the same in every version.
    """
    partitioner = shared_facet_partitioner()
    if DOLFINX_VERSION >= (0, 10):
        from dolfinx.io import gmsh as gmshio

        data = gmshio.model_to_mesh(model, comm, rank, gdim=gdim, partitioner=partitioner)
        return data.mesh, data.cell_tags, data.facet_tags
    from dolfinx.io import gmshio  # type: ignore[attr-defined, no-redef]

    mesh, cell_tags, facet_tags = gmshio.model_to_mesh(
        model, comm, rank, gdim=gdim, partitioner=partitioner
    )
    return mesh, cell_tags, facet_tags


def interpolation_points(element: Any):
    """Reference interpolation points of a DOLFINx element (method in 0.9, property later)."""
    points = element.interpolation_points
    return points() if callable(points) else points


def rectangle_kwargs() -> dict[str, Any]:
    """Extra keyword arguments of ``create_rectangle`` that not every version accepts."""
    return {}


def petsc_problem_kwargs(prefix: str) -> dict[str, Any]:
    """``LinearProblem``/``NonlinearProblem`` need an options prefix from 0.10 on."""
    return {"petsc_options_prefix": prefix} if DOLFINX_VERSION >= (0, 10) else {}


def collapse(subspace):
    """``(V, dofs)``: the collapsed subspace and the parent-space indices of its local dofs.

    0.11 returns the map as a list holding one array, 0.9 as a flat list.
    """
    import numpy as np

    space, dofs = subspace.collapse()
    return space, np.asarray(dofs, dtype=np.int32).reshape(-1)


def geometry_dofmap(mesh):
    """The cell → geometry node array: 0.11 deprecates ``geometry.dofmap`` for ``dofmaps[0]``."""
    geometry = mesh.geometry
    return geometry.dofmaps[0] if hasattr(geometry, "dofmaps") else geometry.dofmap


def version_string() -> str:
    return dolfinx.__version__
