"""Warnings for input that is accepted but pointless, and for results that cannot be trusted.

Each function returns the warnings as one-line messages; :func:`warn` prints them on rank 0 as
``dgplate: warning: <message>`` on stderr. The runner calls :func:`before_run` once the input
is fully validated (and h known) and :func:`after_run` once the driver has stopped; a run goes
on after a warning (bad input is an ``InputError`` instead, see :mod:`dgplate.problems.specs`).
"""

from __future__ import annotations

import ctypes
import functools
import sys
from collections.abc import Callable, Iterable, Mapping
from typing import TYPE_CHECKING, Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import ufl
from petsc4py import PETSc

from dgplate import expressions, values
from dgplate.dg.geometry import max_cell_diameter
from dgplate.dg.self_avoidance import SelfAvoidance
from dgplate.errors import InputError
from dgplate.io.output import print0
from dgplate.models.metric import MetricSpec, largest_jump
from dgplate.models.plate_path import PlatePathSpec
from dgplate.solvers.tau import ADAPTIVE_ONLY

if TYPE_CHECKING:
    import dolfinx.mesh
    import numpy as np

    from dgplate.mesh.tagged import TaggedMesh
    from dgplate.problems.specs import Problem
    from dgplate.solvers.driver import Driver

    Mesh = dolfinx.mesh.Mesh[np.float64]

#: τ above this many h: the energy bound of the isometry defect, D_h ≤ C τ E_h[y⁰], is then
#: a thousand times the O(h) defect of the published runs (τ = h), i.e. of order one on any
#: mesh with h ≥ 10⁻³; the step is close to a plain Newton step of the linearised problem, and
#: the stopping test (E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < tol, divided by a huge τ, holds almost at once
#: whatever the state (τ = 1e300 "converges" in one step).
TAU_MAX_PER_H = 1e3
#: τ below this many h²: the flow reaches the minimiser at a pseudo-time of order one, i.e.
#: after more than 10⁶/h² steps, and near the stopping test a step lowers E_h by τ·tol, which
#: for tol = 10⁻⁶ and h ≈ 10⁻² is 10⁻¹⁶, the round-off of E_h: the test then compares noise.
TAU_MIN_PER_H2 = 1e-6
#: D_h per unit reference area above which a state is not an approximate isometry: the
#: mean of |∇yᵀ∇y − I| over the plate is then of order one.
DEFECT_LIMIT = 0.1


def warn(comm: MPI.Comm, messages: Iterable[str]) -> None:
    """Print each message as one ``dgplate: warning:`` line on stderr, on rank 0 only."""
    for message in messages:  # a closed stderr ends the printing, not the run
        print0(comm, f"dgplate: warning: {' '.join(message.split())}", file=sys.stderr)


# -- before the run ------------------------------------------------------------------------------
def before_run(
    problem: Problem, tagged: TaggedMesh, initial: Callable[..., Any] | None = None
) -> list[str]:
    """Warnings about a problem once it is fully validated.

    Warnings about a problem once it is fully validated (its driver built, so that a
    warning never precedes an input error): nothing to solve, a load on a free plate, τ far
    from h.
    """
    messages = [nothing_to_solve(problem, tagged.mesh, starts_flat=initial is None)]
    messages.append(free_load(problem, tagged.mesh))
    messages.append(weak_self_avoidance(problem))
    messages += adaptive_only(problem)
    messages += path_only(problem)
    messages.append(metric_jump(problem, tagged))
    messages.append(long_cells(problem))
    messages.append(few_cells(problem, tagged.mesh))
    if problem.flow.tau != "h":
        messages.append(tau_scale(float(problem.flow.tau), max_cell_diameter(tagged.mesh)))
    return [m for m in messages if m]


def adaptive_only(problem: Problem) -> list[str]:
    """Warnings for keys of the τ controller given while ``flow.adaptive_tau`` is false."""
    given = problem.raw.get("flow") or {}
    if problem.flow.adaptive_tau:
        return []
    return [
        f"flow.{key} has no effect without flow.adaptive_tau = true (τ stays flow.tau)"
        for key in ADAPTIVE_ONLY
        if key in given
    ]


def path_only(problem: Problem) -> list[str]:
    """Warnings for [path] keys without the arclength method, and for driver keys with it.

    FvK's continuation reads only ``newton.snes`` of [newton] (its start's Newton solver); a
    plate's reads only ``flow.multiplier_degree`` and ``flow.edge_constraint`` of [flow] (its
    constraint), unless it starts at ``path.lambda_start`` ≠ 0 from the flow's minimiser, whose
    flow reads all of [flow] but ``checkpoint_every``. A plate's ``path.parameter`` is read by
    the path alone, FvK's by its load steps as well.
    """
    path = getattr(problem.model, "path", None)
    if path is None:
        return []
    plate = isinstance(path, PlatePathSpec)
    if path.method != "arclength":
        read = ("method",) if plate else ("method", "parameter")
        given = [key for key in problem.raw.get("path") or {} if key not in read]
        return [f"path.{key} has no effect without path.method = 'arclength'" for key in given]
    if plate and path.lambda_start:  # the flow to the start at λ₀ reads [flow] but its checkpoints
        if "checkpoint_every" in (problem.raw.get("flow") or {}):
            return [
                "flow.checkpoint_every has no effect on the flow to the path's start: it is not "
                "checkpointed (a stopped start runs again on --resume); the path checkpoints "
                "its points"
            ]
        return []
    section, read = ("flow", PLATE_PATH_FLOW_KEYS) if plate else ("newton", ("snes",))
    given = [key for key in problem.raw.get(section) or {} if key not in read]
    return [
        f"{section}.{key} has no effect with path.method = 'arclength' (of [{section}] the "
        f"continuation reads {', '.join(f'{section}.{k}' for k in read)} only)"
        for key in given
    ]


#: The [flow] keys a plate's path reads: those of its constraint.
PLATE_PATH_FLOW_KEYS = ("multiplier_degree", "edge_constraint")


#: Rectangle cells this many times longer than wide warn: with the cell diameter as the length
#: of the penalties, the jumps across their long facets are penalised as if the cells were as
#: wide as long. On the arch's n × 2 strip w stopped converging (+0.06 % at aspect 3.2, +0.12 %
#: at 6.4, docs/path_following.md); 3 leaves the shipped files' cells (2 at most) alone.
LONG_CELLS = 3.0


def long_cells(problem: Problem) -> str | None:
    """A warning when the penalties take the cell diameter on a rectangle of long, thin cells.

    ``penalty_length = "facet_normal"`` (the cell's height normal to each facet) restores
    second order there. Meshes from gmsh are left alone: their cells vary, and the diameter is
    the published methods' length.
    """
    mesh = problem.mesh
    if getattr(problem.model, "penalty_length", None) != "diameter" or mesh.type != "rectangle":
        return None
    (x0, y0), (x1, y1) = mesh.corners
    width, height = (x1 - x0) / mesh.cells[0], (y1 - y0) / mesh.cells[1]
    aspect = max(width / height, height / width)
    if aspect < LONG_CELLS:
        return None
    return (
        f"model.penalty_length = 'diameter' on cells {aspect:.3g} times longer than wide "
        f"(mesh.cells = {list(mesh.cells)}): the jumps across their long sides are penalised "
        "too weakly and the result may not converge under refinement; penalty_length = "
        "'facet_normal' takes each facet's normal length instead (docs/path_following.md)"
    )


#: A gmsh plate with fewer cells than this resolves no bending (its size parameter is too large).
FEW_CELLS = 8


def few_cells(problem: Problem, mesh: Mesh) -> str | None:
    """A warning when a gmsh plate came out with a handful of cells (``h`` too large).

    A rectangle's cell count is what ``mesh.cells`` says; a .geo file's follows from its
    parameters, and ``h = 10`` on the 5 × 2 L-plate gives 3 cells without a word from gmsh.
    """
    if problem.mesh.type != "gmsh" or mesh.topology.dim != 2:
        return None
    cells = mesh.comm.allreduce(mesh.topology.index_map(2).size_local, op=MPI.SUM)
    if cells >= FEW_CELLS:
        return None
    given = dict(problem.mesh.parameters)
    return (
        f"the mesh of {problem.mesh.file} has {cells} cell(s)"
        + (f" with mesh.parameters = {given}" if given else "")
        + ": too few to resolve a bending shape; smaller size parameters in mesh.parameters "
        "(h in most shipped files) give more"
    )


#: A jump of G's entries between cell groups above this is a jump, not round-off.
METRIC_JUMP = 1e-9


def metric_jump(problem: Problem, tagged: TaggedMesh) -> str | None:
    """A warning when a group table of ``model.metric`` makes G jump where no crease is.

    Where G jumps, the surface that realises it has a kink in its plane, which the
    interior-penalty energy charges in its gradient jumps: E_h then grows as h falls
    (docs/prestrain.md). The nodes of crease facets are left out. Collective.
    """
    spec = problem.model
    metric = getattr(spec, "metric", None)
    if not isinstance(metric, MetricSpec) or not metric.groups():
        return None
    jump, (x, y) = largest_jump(metric, tagged.mesh, tagged, spec.crease)
    if jump <= METRIC_JUMP:
        return None
    return (
        f"model.metric: G jumps between cell groups (by {jump:.3g} at (x, y) = ({x:.4g}, "
        f"{y:.4g})): the surface has a kink there that the energy's gradient-jump terms "
        "charge, and E_h grows as h falls; make the interface a crease (model.crease), "
        "docs/prestrain.md"
    )


def weak_self_avoidance(problem: Problem) -> str | None:
    """A warning when a plate's tangent-point exponent q ≤ 4 does not keep it from crossing."""
    params = getattr(problem.model, "self_avoidance", None)
    if not isinstance(params, SelfAvoidance) or problem.model.name == "rod" or params.q > 4:
        return None
    return (
        f"model.self_avoidance.q = {params.q:g} <= 4: the tangent-point energy is then finite "
        "on self-intersecting surfaces and does not keep the plate from passing through itself"
    )


def nothing_to_solve(problem: Problem, mesh: Mesh, starts_flat: bool = True) -> str | None:
    """A warning when the flat start already minimises a Kirchhoff or bilayer plate.

    A warning when the flat start already minimises a Kirchhoff or bilayer plate: no load,
    no clamped data other than flat, Z = 0 (bilayer). Collective on ``mesh``.

    An empty problem file (no [model]) is the first case. None for other models.
    """
    spec = problem.model
    if not starts_flat or spec.name not in ("kirchhoff", "bilayer") or spec.continuation:
        return None
    if getattr(spec, "target_metric", None) is not None:  # the flat start violates ∇yᵀ∇y = G
        return None
    if not _no_load(spec.load, mesh):
        return None
    if spec.clamped and not _flat_data(spec.boundary_data, mesh):
        return None
    if spec.name == "bilayer" and not _zero(spec.Z, mesh):
        return None
    what = "model.load and model.Z are zero" if spec.name == "bilayer" else "model.load is zero"
    message = (
        f"nothing to solve: {what} and the plate is free or clamped flat, so the flat start "
        "is already the minimiser (E_h = 0) and the flow stops at once"
    )
    if not problem.raw.get("model"):
        message = f"no [model] given (a free kirchhoff plate without load); {message}"
    return message


def free_load(problem: Problem, mesh: Mesh) -> str | None:
    """A warning when a net force pulls a Kirchhoff or bilayer plate that nothing holds.

    With nothing clamped and no obstacle, a load whose resultant ∫f is not zero leaves the
    energy unbounded below (along the translations): the flow carries the plate away for as
    long as it runs (E_h falling steadily, ΔE/τ constant). A balanced load warns of nothing.
    Collective on ``mesh``.
    """
    spec = problem.model
    if spec.name not in ("kirchhoff", "bilayer") or spec.clamped or spec.obstacle is not None:
        return None
    if _no_load(spec.load, mesh):
        return None
    load = values.vector(spec.load, mesh, "model.load", 3)
    dx = ufl.dx(domain=mesh)
    forms = [load[i] * dx for i in range(3)] + [(abs(load[0]) + abs(load[1]) + abs(load[2])) * dx]
    local = [dolfinx.fem.assemble_scalar(dolfinx.fem.form(form)) for form in forms]
    *net, size = mesh.comm.allreduce(np.array(local, dtype=float), op=MPI.SUM)
    if np.linalg.norm(net) <= 1e-10 * size:
        return None
    return (
        f"model.load on a plate with nothing clamped and no model.obstacle: its resultant "
        f"∫f = ({', '.join(f'{v:.3g}' for v in net)}) is not zero, so the plate has no "
        "minimiser and the flow carries it away until its step budget is spent; clamp a side "
        "(model.clamped) or add an obstacle"
    )


def _no_load(load: Any, mesh: Mesh) -> bool:
    """Whether every component of ``model.load`` is zero (numbers or formulas)."""
    return all(_agree(f, 0.0, mesh) for f in load)


_FLAT = {"g": ["x", "y", 0.0], "Phi": [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]}


def _flat_data(value: Any, mesh: Mesh) -> bool:
    """Clamped data g = (x, y, 0), Φ = [I₂; 0]: 'flat', or numbers and formulas equal to it."""
    if value == "flat":
        return True
    return _same_shape_and_values(value.g, _FLAT["g"], mesh) and _same_shape_and_values(
        value.Phi or _FLAT["Phi"], _FLAT["Phi"], mesh
    )


def _same_shape_and_values(value: Any, flat: Any, mesh: Mesh) -> bool:
    if isinstance(flat, list):
        return (
            isinstance(value, list)
            and len(value) == len(flat)
            and all(_same_shape_and_values(v, f, mesh) for v, f in zip(value, flat))
        )
    return _agree(value, flat, mesh)


def _zero(value: Any, mesh: Mesh) -> bool:
    """Z = 0 everywhere: a zero number, a matrix of zeros, or {group = zero} for every group."""
    if isinstance(value, dict):
        return all(_zero(entry, mesh) for entry in value.values())
    if isinstance(value, list):
        return all(_zero(entry, mesh) for entry in value)
    return _agree(value, 0.0, mesh)


def _agree(value: Any, reference: Any, mesh: Mesh) -> bool:
    """expressions.agree, False for a value that is no number or formula (the build says so)."""
    try:
        return expressions.agree(value, reference, mesh)
    except InputError:
        return False


def tau_scale(tau: float, h: float) -> str | None:
    """A warning when τ is absurdly large (> 10³ h) or small (< 10⁻⁶ h²) for the mesh size h."""
    if tau > TAU_MAX_PER_H * h:
        return (
            f"flow.tau = {tau:g} is more than {TAU_MAX_PER_H:g} h (h = {h:.3g}): the isometry "
            "defect grows like τ, and the stopping test (E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < tol divides "
            "by τ, so it holds almost at once whatever the state; use flow.tau = 'h' or a "
            "value near h"
        )
    if tau < TAU_MIN_PER_H2 * h * h:
        return (
            f"flow.tau = {tau:g} is less than {TAU_MIN_PER_H2:g} h² (h = {h:.3g}): each step "
            f"advances the flow by τ, so reaching pseudo-time 1 takes {1 / tau:.1e} steps, and "
            "the energy decrease per step is lost in round-off; use flow.tau = 'h' or a value "
            "near h"
        )
    return None


# -- after the flow ------------------------------------------------------------------------------
def after_run(
    problem: Problem, driver: Driver, summary: Mapping[str, Any], area: float
) -> list[str]:
    """Warnings once the driver has stopped (before it is destroyed).

    Warnings once the driver has stopped (before it is destroyed): [flow] solver options
    and FvK's ``newton.snes`` options that PETSc never read, and a final state far from an
    isometry (``area`` = |Ω|).
    """
    unused = unused_solver_options(problem.flow.solver, driver)
    newton = getattr(problem.model, "newton", None)
    snes = getattr(newton, "snes", None)
    if snes:
        unused += unused_solver_options(snes, driver, "newton.snes")
    return unused + advise_result(summary, area)


def advise_result(summary: Mapping[str, Any], area: float = 1.0) -> list[str]:
    """A warning when the final isometry defect per unit area D_h/|Ω| exceeds DEFECT_LIMIT.

    The flow imposes the linearised constraint only; a state with D_h of order one (a bilayer
    on a 4×4 mesh reports converged with D_h = 5.8) is no approximate isometry at all.
    """
    defect = summary.get("isometry_defect")
    if defect is None or not area > 0 or not defect / area > DEFECT_LIMIT:
        return []
    state = "converged" if summary.get("converged") else "final"
    tau = summary.get("tau")
    tau_text = f" (now {tau:.3g})" if isinstance(tau, float) else ""
    return [
        f"the {state} state has isometry defect D_h = {defect:.3g} on an area of {area:.3g} "
        f"(D_h/|Ω| = {defect / area:.2g} > {DEFECT_LIMIT:g}): the linearisation of "
        "∇yᵀ∇y = I is not valid that far from an isometry, so the shape cannot be trusted; "
        f"use a smaller flow.tau{tau_text} or flow.projection_steps = 2"
    ]


def unused_solver_options(
    options: Mapping[str, Any], driver: Driver, key: str = "flow.solver"
) -> list[str]:
    """Warnings for ``flow.solver`` (or ``newton.snes``: ``key``) options PETSc never read.

    Warnings for the keys of ``options`` that PETSc never read (misspelt, or not used by the
    chosen solver); collective. Call after the run: MUMPS reads its options only at the first
    factorisation. The driver's ``options_prefixes()`` (its step solver's KSPs, FvK's SNES)
    say where the options were read.
    """
    given = list(options)
    if not given:
        return []
    prefixes = sorted(set(driver.options_prefixes()))
    present = PETSc.Options().getAll()
    unused = []
    for option in given:
        names = [p + option for p in prefixes if p + option in present]
        used = [option_used(name) for name in names]
        if None in used:  # this petsc4py cannot tell: no warning rather than a wrong one
            return []
        if not any(used):
            unused.append(option)
    everywhere = set.intersection(*map(set, driver.comm.allgather(unused)))
    where = " or ".join(f"-{p}" for p in prefixes)
    return [
        f"{key}.{name} was never read by PETSc (options prefix {where}): a misspelt "
        "option, or one that the chosen solver does not use"
        for name in unused
        if name in everywhere
    ]


def option_used(name: str) -> bool | None:
    """Whether PETSc has read the option ``name`` (given without '-'); None if unknowable.

    petsc4py ≥ 3.24 has ``Options.used``; older ones (Debian 13's 3.22) have no Python API
    for it, and :func:`c_option_used` asks PETSc itself.
    """
    options = PETSc.Options()
    if hasattr(options, "used"):
        return bool(options.used(name))
    return c_option_used(name)


def c_option_used(name: str) -> bool | None:
    """``PetscOptionsUsed`` through ctypes, on the global options database; None if absent.

    The function is looked up via the petsc4py extension module (dlsym searches the libpetsc
    it links), so the very library petsc4py uses answers. Its flag is read as a C int: the
    PetscBool of PETSc < 3.24, the versions that need this path (3.24 made it a one-byte
    bool, which a zeroed int also reads correctly on little-endian machines).
    """
    function = _petsc_options_used()
    if function is None:
        return None
    flag = ctypes.c_int(0)
    if function(None, name.encode(), ctypes.byref(flag)) != 0:
        return None
    return bool(flag.value)


@functools.cache
def _petsc_options_used() -> Any:
    try:
        function = ctypes.CDLL(PETSc.__file__).PetscOptionsUsed
    except (OSError, AttributeError, TypeError):
        return None
    function.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.POINTER(ctypes.c_int)]
    function.restype = ctypes.c_int
    return function
