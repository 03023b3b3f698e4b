"""How large a problem is before anything is built: its unknowns and the memory its run needs.

A rod of ``model.cells = 100000000`` or a plate of ``model.degree = 40`` would take the machine's
memory (or hours of form compilation) before printing a line, and on a shared cluster node
take the node down with it. :func:`guard` refuses such a problem at once, from its keys alone:
the unknowns follow from the mesh size, the degree and the model (:func:`unknowns`), the
memory from those by a model calibrated on measured runs (:func:`memory_mb`), and the memory
there is from the machine, its cgroup and the process limit (:func:`available_mb`).
``--allow-large`` (``allow_large=True``) runs it anyway.
"""

from __future__ import annotations

import math
import resource
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate.errors import InputError

#: The highest polynomial degree run without ``--allow-large``. The forms' quadrature degree
#: grows like 3k + 2: compiling the plate's forms took 65 s and 1 GB at degrees 4 and 6, and
#: 290 s at degree 10 (cold cache, a loaded two-core machine); the step matrix's blocks grow
#: like k², so a finer mesh of degree 2 or 3 resolves more for the same memory.
MAX_DEGREE = 6

#: Memory of one process before the problem (Python, DOLFINx, PETSc, MPI): 250-262 MB measured.
BASE_MB = 250.0

#: Bytes per unknown of a rod (a 1D banded system): 3.06 KB at 20,000 and 3.03 KB at 80,000
#: cells (degree 2: 280,007 and 1,120,007 unknowns, peaks of 1,107 and 3,647 MB in two steps).
ROD_BYTES = 3100.0

#: Bytes per unknown of a plate, per unknown of its cells (b): the LU factors of a 2D mesh grow
#: like b·log₂(cells) per unknown, so PLATE_BYTES[0] + PLATE_BYTES[1]·log₂(cells), times b.
#: Fitted to the peak memory (summary.json) of the vertical-load plate, default solver: one
#: step of Q2 (b = 30) on 16², 32² and 64² cells, 300, 467 and 1,160 MB, and of P2 triangles
#: (b = 21) on 2·32² cells, 456 MB (estimates 300, 470, 1,200 and 474 MB); whole runs on 2
#: ranks (docs/guide.md, "Sizing a cluster run"): 1,470 MB at 64² and 5,067 MB at 128²
#: (estimates 1,449 and 4,578 MB). 48² measured 606 MB, the estimate 767 MB.
PLATE_BYTES = (150.0, 10.0)

#: The FvK model's factor on PLATE_BYTES (Newton with LU factors of w ∈ DG_k coupled to
#: u ∈ [CG_k]²): fvk_square on 32² and 48² cells (17,666 and 39,554 unknowns) peaked at 652
#: and 1,132 MB, 24.7 and 23.2 kB per unknown (estimates 669 and 1,182 MB).
FVK_FACTOR = 5.5

MB = 2.0**20


@dataclass(frozen=True)
class Size:
    """A problem's size: its cells, unknowns and the memory of its whole run (all ranks)."""

    cells: int
    dofs: int
    memory_mb: float
    key: str  # the key that sets the size ("mesh.cells", "model.cells", …)
    approximate: bool = False  # gmsh's cells, estimated from a coarser mesh


def _nodes(cell_type: str, degree: int) -> int:
    """Nodes of a degree-``degree`` element on a quadrilateral, triangle or interval."""
    if cell_type == "quadrilateral":
        return (degree + 1) ** 2
    if cell_type == "triangle":
        return (degree + 1) * (degree + 2) // 2
    return degree + 1


def _continuous_nodes(cell_type: str, degree: int, counts: tuple[int, int, int]) -> int:
    """Nodes of the continuous degree-``degree`` space on a 2D mesh of (cells, vertices, edges)."""
    cells, vertices, edges = counts
    k = degree
    inside = (k - 1) ** 2 if cell_type == "quadrilateral" else (k - 1) * (k - 2) // 2
    return vertices + (k - 1) * edges + inside * cells


def unknowns(model: Any, flow: Any, cell_type: str, counts: tuple[int, int, int]) -> int:
    """The unknowns of the step system of ``model`` on a mesh of (cells, vertices, edges).

    Exact for the meshes DOLFINx builds (the count :attr:`Driver.num_dofs` reports): the plate's
    flow solves for y ∈ [DG_k]³ (continuous with ``model.space = 'c0'``) and a multiplier in
    [DG_m]³ (P_m with a continuous y) and the edge moments per cell, the FvK model for
    w ∈ DG_k and u ∈ [CG_k]², a rod for u ∈ [P_k]³, b ∈ [P₁]³, two DG₁ multipliers and a P₁
    one (:func:`dgplate.solvers.rod_flow._space`).
    """
    cells, vertices, _ = counts
    k = int(model.degree)
    if model.name == "rod":
        nodes = vertices + (k - 1) * cells  # P_k on an interval
        return 3 * nodes + 3 * vertices + 4 * cells + vertices
    if model.name == "fvk":
        return cells * _nodes(cell_type, k) + 2 * _continuous_nodes(cell_type, k, counts)
    m = int(getattr(flow, "multiplier_degree", 0))
    edge = 2 if getattr(flow, "edge_constraint", False) else 0  # EdgeConstraint.SIZE
    if getattr(model, "continuous", False):
        y = 3 * _continuous_nodes(cell_type, k, counts)
        return y + cells * (3 * _nodes("triangle", m) + edge)  # P_m moments on any cell
    return cells * (3 * _nodes(cell_type, k) + 3 * _nodes(cell_type, m) + edge)


def mesh_unknowns(model: Any, flow: Any, mesh: Any) -> int:
    """:func:`unknowns` on a built mesh, from its numbers of cells, vertices and edges."""
    topology = mesh.topology
    if topology.index_map(1) is None:
        topology.create_entities(1)  # the facets of a plate, which its forms need anyway
    cells, vertices, edges = (topology.index_map(dim).size_global for dim in (topology.dim, 0, 1))
    return unknowns(model, flow, topology.cell_name(), (cells, vertices, edges))


def _rectangle_counts(mesh: Any) -> tuple[str, tuple[int, int, int]]:
    """(cell type, (cells, vertices, edges)) of the [mesh] rectangle."""
    nx, ny = (int(n) for n in mesh.cells)
    vertices, edges = (nx + 1) * (ny + 1), nx * (ny + 1) + ny * (nx + 1)
    if mesh.cell_type == "quadrilateral":
        return "quadrilateral", (nx * ny, vertices, edges)
    if mesh.diagonal == "crossed":  # four triangles about a new centre vertex
        return "triangle", (4 * nx * ny, vertices + nx * ny, edges + 4 * nx * ny)
    return "triangle", (2 * nx * ny, vertices, edges + nx * ny)


def estimate(problem: Any, comm: MPI.Comm) -> Size | None:
    """The size of ``problem`` from its keys, before anything is built (collective).

    Exact for a rectangle and a rod; for a gmsh mesh, gmsh's estimate
    (:func:`dgplate.mesh.tagged.geo_size`; None when gmsh fails on the file).
    """
    model = problem.model
    if model.name == "rod":
        n = int(model.cells)
        closed = getattr(model, "ends", "") == "closed"
        counts, cell_type, key = (n, n if closed else n + 1, n), "interval", "model.cells"
    elif problem.mesh.type == "rectangle":
        cell_type, counts = _rectangle_counts(problem.mesh)
        key = "mesh.cells"
    else:
        from dgplate.mesh.tagged import geo_size  # DOLFINx: not for the parser's help text

        mesh = problem.mesh
        found = geo_size(comm, mesh.file, mesh.parameters, mesh.recombine)
        if found is None:
            return None
        cells, cell_type = found
        vertices = cells if cell_type == "quadrilateral" else cells // 2  # Euler, about
        counts = (cells, vertices, vertices + cells)
        key = "mesh.parameters" if mesh.parameters else "mesh.file"
    dofs = unknowns(model, problem.flow, cell_type, counts)
    memory = memory_mb(cell_type, counts[0], dofs, comm.size, model.name)
    return Size(counts[0], dofs, memory, key, approximate=problem.mesh.type == "gmsh")


def memory_mb(cell_type: str, cells: int, dofs: int, ranks: int, model: str = "") -> float:
    """The peak memory of a run of ``model`` (MB, summed over ``ranks``).

    Calibrated on measured runs (the constants above say which).
    """
    if cell_type == "interval":
        per_dof = ROD_BYTES
    else:
        block = dofs / max(cells, 1)
        per_dof = block * (PLATE_BYTES[0] + PLATE_BYTES[1] * math.log2(max(cells, 2)))
        per_dof *= FVK_FACTOR if model == "fvk" else 1.0
    return ranks * BASE_MB + dofs * per_dof / MB


def available_mb(comm: MPI.Comm) -> tuple[float, str]:
    """The memory the job may use on all its ranks (MB), and what sets that limit.

    The least of the machine's memory, its cgroup's limit (a container, a Slurm job) and the
    process limit (``ulimit -v``): the first two are shared by the ranks on one node, so the
    job has them once per node; the last holds for each rank. Collective.
    """
    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    nodes = comm.allreduce(1 if node.rank == 0 else 0)
    node.Free()
    limits = [(_physical_mb(), "the machine's memory"), (_cgroup_mb(), "the cgroup memory limit")]
    per_node, what = min(
        ((value, name) for value, name in limits if value is not None), default=(math.inf, "")
    )
    total = per_node * nodes
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY and soft / MB * comm.size < total:
        total, what = soft / MB * comm.size, "the process limit (ulimit -v)"
    return float(comm.allreduce(total, op=MPI.MIN)), what


def _physical_mb() -> float | None:
    """MemTotal of /proc/meminfo (MB); None where there is none."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def _cgroup_mb() -> float | None:
    """The memory limit of this process's cgroup (v2 ``memory.max``, v1 ``limit_in_bytes``)."""
    candidates = [Path("/sys/fs/cgroup/memory/memory.limit_in_bytes")]
    try:
        for line in Path("/proc/self/cgroup").read_text().splitlines():
            if line.startswith("0::"):
                group = Path("/sys/fs/cgroup") / line[3:].lstrip("/")
                candidates += [p / "memory.max" for p in (group, *group.parents)]
    except OSError:
        pass
    limits = []
    for path in candidates:
        try:
            text = path.read_text().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 2**60:  # v1's "no limit" is a huge number
            limits.append(int(text) / MB)
    return min(limits, default=None)


def check_degree(model: Any, allow_large: bool) -> None:
    """InputError for a degree beyond :data:`MAX_DEGREE` (unless ``allow_large``)."""
    degree = getattr(model, "degree", None)
    if isinstance(degree, int) and degree > MAX_DEGREE and not allow_large:
        raise InputError(
            f"model.degree = {degree} is above {MAX_DEGREE}, the highest degree run without "
            "--allow-large: its forms take many minutes to compile, and a finer mesh of "
            "degree 2 or 3 resolves more for the memory"
        )


def guard(problem: Any, comm: MPI.Comm, allow_large: bool = False) -> Size | None:
    """Refuse a problem too large for the memory of the job (InputError), before it is built.

    Returns its estimated :class:`Size` (None: gmsh fails on the mesh file). Collective.
    """
    check_degree(problem.model, allow_large)
    size = estimate(problem, comm)
    if size is None or allow_large:
        return size
    limit, what = available_mb(comm)
    if size.memory_mb > limit:
        raise InputError(
            f"{size.key}: {'about ' if size.approximate else ''}{size.cells:,} cells of degree {problem.model.degree} make "
            f"{size.dofs:,} unknowns, which need about {size.memory_mb / 1024:,.1f} GB, more than "
            f"{what} ({limit / 1024:,.1f} GB on {comm.size} rank(s)); use fewer cells, or "
            "--allow-large to insist"
        )
    return size
