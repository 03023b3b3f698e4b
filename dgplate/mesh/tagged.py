"""Meshes with named regions: built-in rectangles and gmsh ``.geo`` files.

Every mesh is distributed with shared-facet ghosting, because the dG forms integrate over
interior facets (``dS``) and a rank must see both cells of each facet it owns. Cell and facet
regions are addressed by name (gmsh physical groups); an unknown name is an ``InputError``
that lists the names the mesh does have.
"""

from __future__ import annotations

import contextlib
import re
import signal
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from dgplate import compat, interrupt, mpi
from dgplate.compat import Array, Function, Indices, Mesh, MeshTags
from dgplate.errors import InputError, read_user_text

MESH_DIR = Path(__file__).resolve().parents[2] / "meshes"

#: Facet-group names of the built-in rectangle.
RECTANGLE_SIDES = ("left", "right", "bottom", "top")


@dataclass
class TaggedMesh:
    """A DOLFINx mesh with its cell/facet tags and the physical-group names."""

    mesh: Mesh
    cell_tags: MeshTags | None
    facet_tags: MeshTags | None
    groups: dict[str, tuple[int, int]] = field(default_factory=dict)  # name -> (dim, tag)
    source: str = "built-in"

    @property
    def comm(self) -> MPI.Comm:
        """The mesh's communicator."""
        comm: MPI.Comm = self.mesh.comm
        return comm

    def names(self, dim: int) -> list[str]:
        """The names of the groups of dimension ``dim`` (2: cells, 1: facets), sorted."""
        return sorted(name for name, (d, _) in self.groups.items() if d == dim)

    def tag(self, name: str, dim: int, key: str | None = None) -> int:
        """The integer tag of the physical group ``name`` of dimension ``dim``.

        An unknown name is an InputError that lists the groups the mesh has; ``key``, the
        problem-file entry that named the group (``model.clamped``), begins its message.
        """
        entry = self.groups.get(name)
        if entry is None or entry[0] != dim:
            kind = "cell" if dim == self.mesh.topology.dim else "facet"
            available = ", ".join(self.names(dim)) or "none"
            where = f"{key}: " if key else ""
            raise InputError(
                f"{where}unknown {kind} group '{name}' in mesh {self.source} "
                f"(available: {available})"
            )
        return entry[1]

    def facets(self, name: str, key: str | None = None) -> Indices:
        """Local indices of the facets in group ``name`` (owned and ghost); ``key``: :meth:`tag`."""
        tag = self.tag(name, self.mesh.topology.dim - 1, key)
        assert self.facet_tags is not None
        return self.facet_tags.find(tag)

    def cells(self, name: str, key: str | None = None) -> Indices:
        """Local indices of the cells in group ``name`` (owned and ghost); ``key``: :meth:`tag`."""
        tag = self.tag(name, self.mesh.topology.dim, key)
        assert self.cell_tags is not None
        return self.cell_tags.find(tag)

    def group_function(
        self,
        values: Mapping[str, npt.ArrayLike],
        default: npt.ArrayLike | None = None,
        shape: tuple[int, ...] = (),
        key: str = "value",
    ) -> Function:
        """A DG0 function (scalar or of ``shape``) with one value per cell group.

        A number stands for all entries of a ``shape``d value. Cells of no listed group get
        ``default``; without a default every owned cell must be covered, or an InputError
        says how many are not (``key`` names the problem-file entry). An unknown group name
        raises an InputError that begins with ``key`` and names the group. Collective.
        """
        mesh = self.mesh
        space = dolfinx.fem.functionspace(mesh, ("DG", 0, shape) if shape else ("DG", 0))
        function: Function = dolfinx.fem.Function(space, name=key.split(".")[-1])
        size = int(np.prod(shape))
        blocks = function.x.array.reshape(-1, size)
        if default is not None:
            blocks[:] = np.broadcast_to(np.ravel(np.asarray(default, dtype=float)), (size,))
        cell_map = mesh.topology.index_map(mesh.topology.dim)
        covered = np.zeros(cell_map.size_local + cell_map.num_ghosts, dtype=bool)
        for group, value in values.items():
            cells = self.cells(group, key)
            row = np.broadcast_to(np.ravel(np.asarray(value, dtype=float)), (size,))
            blocks[space.dofmap.list[cells].reshape(-1)] = row
            covered[cells] = True
        function.x.scatter_forward()
        if default is None:
            local = int(np.count_nonzero(~covered[: cell_map.size_local]))
            missing = mpi.global_count(mesh.comm, local)
            if missing:
                raise InputError(
                    f"{key} leaves {missing} cell(s) without a value "
                    f"(cell groups: {self.names(mesh.topology.dim)})"
                )
        return function


def rectangle(
    comm: MPI.Comm,
    corners: Sequence[Sequence[float]],
    cells: Sequence[int],
    cell_type: str = "quadrilateral",
    diagonal: str = "right",
) -> TaggedMesh:
    """A structured rectangle with facet groups left/right/bottom/top and cell group 'plate'."""
    (x0, y0), (x1, y1) = corners
    ctype = dolfinx.mesh.CellType[cell_type]
    diag = dolfinx.mesh.DiagonalType[diagonal]
    mesh = dolfinx.mesh.create_rectangle(
        comm,
        [np.array([x0, y0]), np.array([x1, y1])],
        [int(cells[0]), int(cells[1])],
        cell_type=ctype,
        diagonal=diag,
        ghost_mode=dolfinx.mesh.GhostMode.shared_facet,
    )
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    indices, values = [], []
    sides = _rectangle_sides(corners)
    for tag, name in enumerate(RECTANGLE_SIDES, start=1):
        found = dolfinx.mesh.locate_entities_boundary(mesh, tdim - 1, sides[name])
        indices.append(found)
        values.append(np.full(found.size, tag, dtype=np.int32))
    facet_tags = make_tags(mesh, tdim - 1, np.concatenate(indices), np.concatenate(values))
    cells_here = local_entities(mesh, tdim)
    cell_tags = make_tags(mesh, tdim, cells_here, np.ones(cells_here.size, dtype=np.int32))
    groups = {name: (tdim - 1, tag) for tag, name in enumerate(RECTANGLE_SIDES, start=1)}
    groups["plate"] = (tdim, 1)
    source = f"rectangle {list(corners)} {list(cells)} {cell_type}"
    return TaggedMesh(mesh, cell_tags, facet_tags, groups, source)


def _rectangle_sides(
    corners: Sequence[Sequence[float]],
) -> dict[str, Callable[[Array], npt.NDArray[np.bool_]]]:
    """The markers of the sides of the rectangle, by name."""
    (x0, y0), (x1, y1) = corners
    tol = 1e-10 * max(x1 - x0, y1 - y0)
    return {
        "left": lambda x: np.isclose(x[0], x0, atol=tol),
        "right": lambda x: np.isclose(x[0], x1, atol=tol),
        "bottom": lambda x: np.isclose(x[1], y0, atol=tol),
        "top": lambda x: np.isclose(x[1], y1, atol=tol),
    }


def local_entities(mesh: Mesh, dim: int) -> Indices:
    """The local indices of this rank's entities of dimension ``dim``, owned and ghost."""
    index_map = mesh.topology.index_map(dim)
    return np.arange(index_map.size_local + index_map.num_ghosts, dtype=np.int32)


def make_tags(mesh: Mesh, dim: int, indices: npt.ArrayLike, values: npt.ArrayLike) -> MeshTags:
    """MeshTags from possibly repeated, unsorted entity indices (the last value wins)."""
    entities = np.asarray(indices, dtype=np.int32)
    order = np.argsort(entities, kind="stable")
    entities, tags = entities[order], np.asarray(values, dtype=np.int32)[order]
    keep = np.append(entities[1:] != entities[:-1], True) if entities.size else np.array([], bool)
    return dolfinx.mesh.meshtags(mesh, dim, entities[keep], tags[keep])


#: The old, private name of :func:`make_tags`.
_make_tags = make_tags


def resolve_geo(name: str | Path) -> Path:
    """A ``.geo`` path as given, or looked up in the project's ``meshes/`` folder."""
    path = Path(name)
    candidates = [path, MESH_DIR / path, MESH_DIR / f"{path}.geo"]
    for candidate in candidates:
        if candidate.is_file():
            return candidate.resolve()
    raise InputError(f"mesh file not found: {name} (also looked in {MESH_DIR})")


def geo_parameters(path: Path) -> dict[str, str]:
    """The ``DefineConstant`` parameters of a .geo file, name -> default value as written."""
    text = read_user_text(path, "mesh file")
    params: dict[str, str] = {}
    for block in re.findall(r"DefineConstant\s*\[(.*?)\]\s*;", text, flags=re.S):
        for match in re.finditer(r"(\w+)\s*=\s*\{\s*([^,}]+)", block):
            params[match.group(1)] = match.group(2).strip()
    return params


def load_geo(
    comm: MPI.Comm,
    name: str | Path,
    parameters: Mapping[str, float] | None = None,
    recombine: bool | None = None,
    gmsh_options: Mapping[str, float] | None = None,
) -> TaggedMesh:
    """Mesh a gmsh ``.geo`` file on rank 0 and distribute it with shared-facet ghosts.

    ``parameters`` override the file's ``DefineConstant`` values (an unknown name is an error);
    ``recombine=True`` asks gmsh for quadrilaterals. The whole communicator sees the same error
    when gmsh fails on rank 0.
    """
    path = resolve_geo(name)
    parameters = dict(parameters or {})
    _check_parameters(path, parameters)
    import gmsh

    error, groups = None, None
    with signal_handlers_kept():
        if comm.rank == 0:
            gmsh.initialize(["dgplate"], readConfigFiles=False)
            gmsh.option.setNumber("General.Terminal", 0)
            # gmsh's default of 10 retries of the boundary recovery splits the edges of a
            # self-intersecting boundary for many minutes; 5 ends such a file at once (no cells)
            # with gmsh 4.15 (4.13, Debian 13's, goes on whatever the option says)
            gmsh.option.setNumber("Mesh.MaxRetries", MAX_RETRIES)
            error, groups = _generate(gmsh, path, parameters, recombine, gmsh_options or {})
        error = comm.bcast(error, root=0)
        if error is not None:
            if comm.rank == 0:
                gmsh.finalize()
            raise InputError(error)
        try:
            mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(
                gmsh.model if comm.rank == 0 else None, comm, 0, gdim=2
            )
        finally:
            if comm.rank == 0:
                gmsh.finalize()
    groups = comm.bcast(groups, root=0)
    mesh.topology.create_connectivity(1, 2)
    return TaggedMesh(mesh, cell_tags, facet_tags, groups, source=path.name)


#: gmsh's ``Mesh.MaxRetries`` (:func:`load_geo`'s ``gmsh_options`` may set another).
MAX_RETRIES = 5

#: Nodes on the curves up to which :func:`geo_size` meshes the surfaces at the file's sizes.
ESTIMATE_NODES = 400


def geo_size(
    comm: MPI.Comm, name: str | Path, parameters: Mapping[str, float], recombine: bool | None
) -> tuple[int, str] | None:
    """About how many cells :func:`load_geo` makes of a .geo file, and their type, cheaply.

    gmsh meshes the curves (their nodes grow like 1/h only), then the surfaces with every size
    scaled by f = curve nodes / :data:`ESTIMATE_NODES` where that is > 1: the cells grow like
    1/h², so the estimate is f² times those of the coarse mesh (exact for f = 1). A geometry
    whose curves all keep their nodes (transfinite) is meshed as it is: exact, not cheap. None when
    gmsh fails: :func:`load_geo` reports why. Collective (gmsh runs on rank 0).
    """
    path = resolve_geo(name)
    _check_parameters(path, parameters)
    import gmsh

    size: tuple[int, str] | None = None
    with signal_handlers_kept():
        if comm.rank == 0:
            gmsh.initialize(["dgplate"], readConfigFiles=False)
            try:
                gmsh.option.setNumber("General.Terminal", 0)
                gmsh.option.setNumber("Mesh.MaxRetries", MAX_RETRIES)
                size = _coarse_count(gmsh, path, parameters, recombine)
            except Exception:  # gmsh's own error, which load_geo reports
                size = None
            finally:
                gmsh.finalize()
    found: tuple[int, str] | None = comm.bcast(size, root=0)
    return found


def _coarse_count(
    gmsh: ModuleType, path: Path, parameters: Mapping[str, float], recombine: bool | None
) -> tuple[int, str]:
    """(cells, cell type) of :func:`geo_size`'s estimate (gmsh initialised, rank 0)."""
    for key, value in parameters.items():
        gmsh.parser.setNumber(key, [float(value)])
    if recombine:
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.merge(str(path))
    gmsh.model.mesh.generate(1)
    nodes = len(gmsh.model.mesh.getNodes(1, -1, includeBoundary=True)[0])
    factor = max(1.0, nodes / ESTIMATE_NODES)
    gmsh.model.mesh.clear()
    scale = gmsh.option.getNumber("Mesh.MeshSizeFactor")
    gmsh.option.setNumber("Mesh.MeshSizeFactor", scale * factor)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 0)  # not Blossom: as many, quicker
    gmsh.model.mesh.generate(1)
    # Transfinite curves keep their nodes at any size factor, and their surfaces' cells with
    # them: when no curve coarsened (polar_disc.geo, every cell a transfinite surface) the
    # coarse mesh is the mesh itself. When only some did, the assumed factor stays: the guard
    # may over-estimate, never under-estimate, a surface bounded by free curves.
    if len(gmsh.model.mesh.getNodes(1, -1, includeBoundary=True)[0]) >= 0.99 * nodes:
        factor = 1.0
    gmsh.model.mesh.generate(2)
    types, tags, _ = gmsh.model.mesh.getElements(2)
    counts = {int(kind): len(cells) for kind, cells in zip(types, tags, strict=True)}
    quads = counts.get(3, 0)  # gmsh's element type 3: the 4-node quadrilateral
    cell_type = "quadrilateral" if quads > sum(counts.values()) / 2 else "triangle"
    return round(sum(counts.values()) * factor**2), cell_type


@contextlib.contextmanager
def signal_handlers_kept() -> Iterator[None]:
    """Put back the SIGINT and SIGTERM handlers on leaving, whatever the block did to them.

    ``gmsh.initialize`` resets SIGINT (in Python) and SIGTERM (in C++) to the default action,
    which ends the process at once, and ``gmsh.finalize`` does not restore them: without this
    a run on a gmsh mesh would lose the clean stop of :class:`dgplate.interrupt.StopOnSignal`
    (outputs, checkpoint, exit 130/143). Handlers can only be set in the main thread.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in saved.items():
            if handler is not None:
                signal.signal(sig, handler)
        interrupt.renew()  # a set-up's handlers, which Python does not know of


def _check_parameters(path: Path, parameters: Mapping[str, float]) -> None:
    """Every overridden parameter must be a ``DefineConstant`` of the file."""
    known = geo_parameters(path)
    unknown = sorted(set(parameters) - set(known))
    if unknown:
        raise InputError(
            f"mesh parameter(s) {', '.join(unknown)} not defined in {path.name} "
            f"(DefineConstant there: {', '.join(sorted(known)) or 'none'})"
        )


def _generate(
    gmsh: ModuleType,
    path: Path,
    parameters: Mapping[str, float],
    recombine: bool | None,
    options: Mapping[str, float],
) -> tuple[str | None, dict[str, tuple[int, int]] | None]:
    """Mesh the file with gmsh (initialised, on rank 0): ``(error, physical groups)``."""
    try:
        for key, value in parameters.items():
            gmsh.parser.setNumber(key, [float(value)])
        for key, value in options.items():
            gmsh.option.setNumber(key, float(value))
        if recombine:
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.merge(str(path))
        gmsh.model.mesh.generate(2)
        groups = {}
        for dim, tag in gmsh.model.getPhysicalGroups():
            label = gmsh.model.getPhysicalName(dim, tag) or f"{dim}:{tag}"
            groups[label] = (int(dim), int(tag))
    except Exception as exc:  # gmsh raises plain Exceptions with its log message
        return f"gmsh failed on {path.name}: {exc}", None
    if not any(dim == 2 for dim, _ in groups.values()):
        return f"{path.name} defines no Physical Surface: name the plate's cell regions", groups
    surfaces = [tag for dim, tag in groups.values() if dim == 2]
    cells = sum(
        len(tags)
        for surface in surfaces
        for entity in gmsh.model.getEntitiesForPhysicalGroup(2, surface)
        for tags in gmsh.model.mesh.getElements(2, entity)[1]
    )
    if cells == 0:
        given = f" with {dict(parameters)}" if parameters else ""
        return f"gmsh made no cells from {path.name}{given}: check its geometry", groups
    return None, groups
