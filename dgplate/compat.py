"""The one module that knows DOLFINx versions, and where the libraries' typing falls short.

dgplate supports DOLFINx 0.9 (Debian 13), 0.10 and 0.11 (PyPI wheel). Every API difference
between those releases is absorbed here, so the rest of the package is written once.
Importing this module refuses an older or unknown-major DOLFINx with a clear message.

The type aliases below name DOLFINx's classes with the scalar type dgplate computes in (real
double precision): DOLFINx's classes are generic in it. They are strings, so that they are
never evaluated at run time (DOLFINx 0.9's classes are not all generic). Where the
annotations of DOLFINx, petsc4py or UFL do not say what they accept or return, the typed
names further down say it once, so that the rest of the package needs no ``type: ignore``.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import inspect
import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias, cast

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.jit
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl
from petsc4py import PETSc
from ufl.core.expr import Expr

if TYPE_CHECKING:
    import basix.ufl

from dgplate import interrupt
from dgplate.errors import UnsupportedVersionError

MIN_VERSION = (0, 9)
MAX_TESTED_VERSION = (0, 11)

Mesh: TypeAlias = "dolfinx.mesh.Mesh[np.float64]"
MeshTags: TypeAlias = "dolfinx.mesh.MeshTags"
FunctionSpace: TypeAlias = "dolfinx.fem.FunctionSpace[np.float64]"
Function: TypeAlias = "dolfinx.fem.Function[np.float64]"
Constant: TypeAlias = "dolfinx.fem.Constant[np.float64]"
Form: TypeAlias = "dolfinx.fem.Form[np.float64]"
Expression: TypeAlias = "dolfinx.fem.Expression[np.float64]"
FiniteElement: TypeAlias = "dolfinx.fem.FiniteElement[np.float64]"
#: A real array, e.g. coordinates or the values of a function's degrees of freedom.
Array: TypeAlias = "npt.NDArray[np.float64]"
#: An array of local indices (cells, facets, degrees of freedom).
Indices: TypeAlias = "npt.NDArray[np.int32]"


def _parse_version(text: str) -> tuple[int, int]:
    """``(major, minor)`` of a version string such as ``0.11.0.post0``."""
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

#: Seconds a process waits for a form that another process is compiling (a second MPI job,
#: a parallel test worker, runs sharing a cluster's cache). DOLFINx's default, 10 s, is less
#: than gcc takes for a large dG form, and the waiting process then fails with a timeout.
JIT_WAIT_SECONDS = 900


def wait_longer_for_jit() -> None:
    """Raise DOLFINx's default JIT timeout to :data:`JIT_WAIT_SECONDS`.

    Only the default changes: a ``dolfinx_jit_options.json`` of the user's still overrides it.
    """
    default, doc = dolfinx.jit.DOLFINX_DEFAULT_JIT_OPTIONS["timeout"]
    if isinstance(default, int) and default < JIT_WAIT_SECONDS:
        dolfinx.jit.DOLFINX_DEFAULT_JIT_OPTIONS["timeout"] = (JIT_WAIT_SECONDS, doc)


wait_longer_for_jit()

#: The C compiler's flags for the forms FFCx generates, in place of DOLFINx's ``-O2``: gcc
#: compiles the large dG forms in about half the time and the kernels run as fast
#: (benchmarks/jit_flags.py, docs/performance.md). A first run, and a CI run with an empty
#: JIT cache, spend much of their time in gcc.
JIT_COMPILE_ARGS = ["-O1", "-g0"]


def compile_forms_faster() -> None:
    """Make :data:`JIT_COMPILE_ARGS` DOLFINx's default flags for compiling forms.

    Only the default changes: a ``dolfinx_jit_options.json`` of the user's still overrides it.
    The flags are part of the JIT cache's key, so forms compiled with other flags are compiled
    once more, not mixed up.
    """
    _, doc = dolfinx.jit.DOLFINX_DEFAULT_JIT_OPTIONS["cffi_extra_compile_args"]
    dolfinx.jit.DOLFINX_DEFAULT_JIT_OPTIONS["cffi_extra_compile_args"] = (
        list(JIT_COMPILE_ARGS),
        doc,
    )


compile_forms_faster()


def load_each_compiled_module_once() -> None:
    """Keep the modules of compiled forms that this process has loaded, and reuse them.

    For every ``dolfinx.fem.form`` FFCx looks its module up in the JIT cache folder: a listing
    of the whole folder (4 ms at its 7,000 files after a test suite), then a fresh import of the
    module; under MPI rank 0 does it before the others. A process that builds the same form
    again (every step of a load path, every level of a study, every test) paid that each time.
    The key is FFCx's own: the module name holds the form's signature and the compiler options,
    so a form is reused exactly when FFCx would have loaded the same file. Only modules found
    in the cache are kept; a compilation still happens once, as before. Safe to call more than
    once.
    """
    import ffcx.codegeneration.jit as ffcx_jit

    load: Callable[[str, list[str], Path, int], tuple[Any, Any]] = ffcx_jit.get_cached_module
    if hasattr(load, "__wrapped__"):
        return
    loaded: dict[tuple[str, tuple[str, ...], str], tuple[Any, Any]] = {}

    @functools.wraps(load)
    def get_cached_module(
        module_name: str, object_names: list[str], cache_dir: Path, timeout: int
    ) -> tuple[Any, Any]:
        key = (module_name, tuple(object_names), str(cache_dir))
        found = loaded.get(key)
        if found is None:
            found = load(module_name, object_names, cache_dir, timeout)
            if found[0] is not None:  # (None, None): not cached yet, FFCx compiles it
                loaded[key] = found
        return found

    ffcx_jit.get_cached_module = get_cached_module


load_each_compiled_module_once()


@contextlib.contextmanager
def on_first_compile(announce: Callable[[], None]) -> Iterator[None]:
    """Call ``announce`` once, before the first form the block compiles (a JIT cache miss).

    FFCx's ``get_cached_module`` (0.9 to 0.11) creates the C file of a form it does not find
    and returns no module: the caller then compiles it and marks it ready. A process that
    ends before that (:func:`dgplate.interrupt.setting_up`) renames the C file as FFCx does
    on a failed compilation; left in place, it would make the next run wait for it. FFCx's
    entry points that DOLFINx calls (``compile_forms`` and the like) run under
    :func:`dgplate.interrupt.compiling`.
    """
    import ffcx.codegeneration.jit as jit

    original: Callable[..., Any] = jit.get_cached_module
    entries = {name: getattr(jit, name) for name in COMPILE_ENTRIES}
    announced: list[bool] = []

    signature = inspect.signature(original)

    def get_cached_module(*args: Any, **kwargs: Any) -> Any:
        found = original(*args, **kwargs)
        if found[0] is None:  # this process compiles it
            # (module name, object names, cache folder, timeout), by position or by name
            module_name, _, cache_dir, *_ = signature.bind(*args, **kwargs).arguments.values()
            c_file = Path(cache_dir).joinpath(module_name).with_suffix(".c")
            interrupt.CLEAN_UP.append(functools.partial(_abandon, c_file))
            if not announced:
                announced.append(True)
                announce()
        return found

    jit.get_cached_module = get_cached_module
    for name, entry in entries.items():
        setattr(jit, name, _under_python_handlers(entry))
    try:
        yield
    finally:
        jit.get_cached_module = original
        for name, entry in entries.items():
            setattr(jit, name, entry)
        interrupt.CLEAN_UP.clear()


#: FFCx's compilers that DOLFINx calls (FFCx 0.9 to 0.11).
COMPILE_ENTRIES = ("compile_forms", "compile_expressions")


def _under_python_handlers(compile_objects: Callable[..., Any]) -> Callable[..., Any]:
    """``compile_objects`` run under :func:`dgplate.interrupt.compiling`."""

    @functools.wraps(compile_objects)
    def compile_under_python_handlers(*args: Any, **kwargs: Any) -> Any:
        with interrupt.compiling():
            return compile_objects(*args, **kwargs)

    return compile_under_python_handlers


def _abandon(c_file: Path) -> None:
    """Rename an unfinished compilation's C file to ``.c.failed`` (FFCx's own clean-up)."""
    if not c_file.with_suffix(".c.cached").exists():
        os.replace(c_file, c_file.with_suffix(".c.failed"))


def shared_facet_partitioner() -> Callable[..., object]:
    """A cell partitioner that ghosts the cells across shared facets (needed by dS integrals).

    The C++ partitioner has no Python type: it maps (comm, parts, cell types, cells) to the
    destination ranks of each cell.
    """
    cpp_create = dolfinx.cpp.mesh.create_cell_partitioner
    mode = dolfinx.mesh.GhostMode.shared_facet
    if DOLFINX_VERSION >= (0, 10):
        return cpp_create(mode, 2)  # type: ignore[no-any-return]  # untyped C++ binding
    return cpp_create(mode)  # type: ignore[no-any-return]


def gmsh_model_to_mesh(
    model: object, comm: MPI.Comm, rank: int, gdim: int
) -> tuple[Mesh, MeshTags | None, MeshTags | None]:
    """Build a shared-facet-ghosted mesh from a gmsh model (``gmsh.model`` on ``rank``).

    Returns ``(mesh, cell_tags, facet_tags)``; physical-group names are read by the caller
    from gmsh itself, which works the same in every version.
    """
    partitioner = shared_facet_partitioner()
    if DOLFINX_VERSION >= (0, 10):
        from dolfinx.io import gmsh as gmshio

        data = gmshio.model_to_mesh(model, comm, rank, gdim=gdim, partitioner=partitioner)
        return data.mesh, data.cell_tags, data.facet_tags
    legacy: Any = importlib.import_module("dolfinx.io.gmshio")  # 0.9: returns a plain tuple
    mesh, cell_tags, facet_tags = legacy.model_to_mesh(
        model, comm, rank, gdim=gdim, partitioner=partitioner
    )
    return mesh, cell_tags, facet_tags


def create_mesh(
    comm: MPI.Comm,
    cells: npt.NDArray[np.int64],
    x: Array,
    domain: ufl.Mesh,
    partitioner: Callable[..., object] | None = None,
) -> Mesh:
    """A mesh from cells (node indices) and node coordinates ``x`` (num_nodes, gdim).

    ``domain`` is the coordinate element as a ``ufl.Mesh``. DOLFINx 0.9's
    ``create_mesh(comm, cells, x, e, partitioner)`` takes the coordinates before the element,
    0.10 and 0.11 have ``create_mesh(comm, cells, e, x, partitioner, max_facet_to_cell_links)``
    (the same names, another order).
    """
    if DOLFINX_VERSION >= (0, 10):
        return dolfinx.mesh.create_mesh(comm, cells, domain, x, partitioner)
    legacy: Any = dolfinx.mesh.create_mesh  # 0.9: (comm, cells, x, e, partitioner)
    mesh: Mesh = legacy(comm, cells, x, domain, partitioner)
    return mesh


def interpolation_points(element: FiniteElement) -> Array:
    """Reference interpolation points of a DOLFINx element (method in 0.9, property later)."""
    points: object = element.interpolation_points
    return np.asarray(points() if callable(points) else points, dtype=np.float64)


def collapse(subspace: FunctionSpace) -> tuple[FunctionSpace, Indices]:
    """``(V, dofs)``: the collapsed subspace and the parent-space indices of its local dofs.

    0.11 returns the map as a list holding one array, 0.9 as a flat list.
    """
    space, dofs = subspace.collapse()
    return space, np.asarray(dofs, dtype=np.int32).reshape(-1)


def geometry_dofmap(mesh: Mesh) -> Indices:
    """The cell → geometry node array: 0.11 deprecates ``geometry.dofmap`` for ``dofmaps[0]``."""
    geometry: Any = mesh.geometry  # the attribute depends on the version
    return np.asarray(geometry.dofmaps[0] if hasattr(geometry, "dofmaps") else geometry.dofmap)


def coordinate_element_degree(mesh: Mesh) -> int:
    """The degree of the mesh's coordinate element (2 for curved gmsh ``order = 2`` cells).

    DOLFINx 0.11 deprecates ``geometry.cmap`` for ``geometry.cmaps[0]``.
    """
    geometry: Any = mesh.geometry  # the attribute depends on the version
    cmap = geometry.cmaps[0] if hasattr(geometry, "cmaps") else geometry.cmap
    return int(cmap.degree)


def entities_to_geometry(mesh: Mesh, dim: int, entities: npt.ArrayLike) -> Indices:
    """Geometry nodes of each entity (one row per entity), also for no entities.

    DOLFINx 0.9 divides by the number of entities and dies of SIGFPE on an empty list, which
    is what a rank holds when none of a facet group's facets are its own.
    """
    entities = np.asarray(entities, dtype=np.int32)
    if entities.size:
        return np.asarray(dolfinx.mesh.entities_to_geometry(mesh, dim, entities))
    one = dolfinx.mesh.entities_to_geometry(mesh, dim, np.zeros(1, dtype=np.int32))
    return np.asarray(one)[:0]


# petsc4py's stubs declare the members of its enumerations as int while its methods are
# annotated to take the enumeration classes: the members dgplate passes are typed here, once.
INSERT = cast("PETSc.InsertMode", PETSc.InsertMode.INSERT)
ADD = cast("PETSc.InsertMode", PETSc.InsertMode.ADD)
FORWARD = cast("PETSc.ScatterMode", PETSc.ScatterMode.FORWARD)
REVERSE = cast("PETSc.ScatterMode", PETSc.ScatterMode.REVERSE)
SAME_NONZERO_PATTERN = cast("PETSc.Mat.Structure", PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
SUBSET_NONZERO_PATTERN = cast("PETSc.Mat.Structure", PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
DIFFERENT_NONZERO_PATTERN = cast(
    "PETSc.Mat.Structure", PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN
)
NORM_INFINITY = cast("PETSc.NormType", PETSc.NormType.INFINITY)
IGNORE_ZERO_ENTRIES = cast("PETSc.Mat.Option", PETSc.Mat.Option.IGNORE_ZERO_ENTRIES)
NEW_NONZERO_LOCATION_ERR = cast("PETSc.Mat.Option", PETSc.Mat.Option.NEW_NONZERO_LOCATION_ERR)
SYMMETRIC = cast("PETSc.Mat.Option", PETSc.Mat.Option.SYMMETRIC)


def converged_reason(ksp: PETSc.KSP) -> int:
    """The KSP's converged reason as the int it is (negative: diverged)."""
    return cast(int, ksp.getConvergedReason())  # the stubs call it a ConvergedReason


def accumulate_ghosts(vector: PETSc.Vec) -> None:
    """Add the contributions assembled into ghost entries to their owners' entries."""
    vector.ghostUpdate(addv=ADD, mode=REVERSE)


# ``dolfinx.fem.petsc.assemble_matrix`` and ``assemble_vector`` dispatch on their first
# argument; their annotations show only the variants that create the matrix or vector.


def assemble_matrix_into(matrix: PETSc.Mat, form: Form) -> None:
    """Zero ``matrix`` and assemble the bilinear ``form`` into it (in its sparsity pattern)."""
    matrix.zeroEntries()
    add_matrix_form(matrix, form)


def add_matrix_form(matrix: PETSc.Mat, form: Form) -> None:
    """Add the bilinear ``form`` to the assembled ``matrix`` (in its sparsity pattern)."""
    dolfinx.fem.petsc.assemble_matrix(matrix, form)  # type: ignore[arg-type]
    matrix.assemble()


def assemble_vector_into(vector: PETSc.Vec, form: Form) -> None:
    """Zero the ghosted ``vector``, assemble the linear ``form`` into it, add up the ghosts."""
    with vector.localForm() as local:
        local.set(0.0)
    dolfinx.fem.petsc.assemble_vector(vector, form)  # type: ignore[arg-type]
    accumulate_ghosts(vector)


# UFL is not annotated, and mypy (strict) refuses calls of unannotated functions outside
# dg/, solvers/ and models/: the few UFL functions that other modules call get their types here.
spatial_coordinate: Callable[[Mesh], Expr] = ufl.SpatialCoordinate
grad: Callable[[Expr], Expr] = ufl.grad
as_ufl: Callable[[float], Expr] = ufl.as_ufl
as_vector: Callable[[Sequence[object]], Expr] = ufl.as_vector
as_tensor: Callable[[Sequence[object]], Expr] = ufl.as_tensor


def ufl_element(space: FunctionSpace) -> basix.ufl._ElementBase:
    """The basix.ufl element of a function space (its degree, continuity, shape)."""
    element: Callable[[], basix.ufl._ElementBase] = space.ufl_element
    return element()


def vtk_mesh(
    space: FunctionSpace, cells: Indices
) -> tuple[npt.NDArray[np.integer[Any]], npt.NDArray[np.integer[Any]], Array]:
    """VTK topology, cell types and points of the given cells of a Lagrange space.

    ``dolfinx.plot.vtk_mesh`` dispatches on its first argument; its annotations show only the
    variant that takes a mesh.
    """
    import dolfinx.plot

    topology, types, points = dolfinx.plot.vtk_mesh(space, entities=cells)  # type: ignore[arg-type]
    return np.asarray(topology), np.asarray(types), np.asarray(points)


def version_string() -> str:
    """The installed DOLFINx version, as reported in ``summary.json``."""
    return dolfinx.__version__
