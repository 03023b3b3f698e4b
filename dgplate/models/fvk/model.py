"""The FvK model: :class:`FvKModel` and :func:`build_fvk`, which make Newton's driver of a spec.

The model is described in the docstring of :mod:`dgplate.models.fvk`.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from dgplate import compat, expressions, values
from dgplate.dg.forms import FacetSets
from dgplate.errors import InputError
from dgplate.measure.probes import DeflectionProbes, PointProbe
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import Initial, Model
from dgplate.models.fvk.energy import (
    BCValues,
    edge_axis,
    fvk_energy,
    fvk_facet_sets,
    fvk_space,
    membrane_bcs,
)
from dgplate.models.fvk.spec import FvKSpec
from dgplate.mpi import bounds
from dgplate.solvers.continuation import BranchPath
from dgplate.solvers.driver import Observer
from dgplate.solvers.newton import LoadPath, Relaxation

#: PETSc options prefix of the FvK driver: ``-dgplate_fvk_snes_monitor`` on the command line.
PREFIX = "dgplate_fvk_"

_HINT = "try more newton.load_steps or other newton.snes options"


def _check_group_names(spec: FvKSpec, tagged: TaggedMesh) -> None:
    for key in ("clamped", "simply_supported", "mirror", "crease", "membrane"):
        for group in getattr(spec, key):
            tagged.facets(group, f"model.{key}")


def _probe(spec: FvKSpec, mesh: dolfinx.mesh.Mesh[np.float64]) -> PointProbe:
    """The probe of w_center: ``model.probe``, or the centre of the mesh's bounding box."""
    if spec.probe is None:
        lo, hi = bounds(mesh.comm, mesh.geometry.x[:, :2])
        return _point_probe(mesh, [float(c) for c in (lo + hi) / 2], "model.probe")
    return _point_probe(mesh, spec.probe, "model.probe")


def _point_probe(mesh: dolfinx.mesh.Mesh[np.float64], point: list[float], key: str) -> PointProbe:
    """A probe at ``point``; an InputError naming ``key`` when it lies outside the mesh."""
    point = [float(c) for c in point]
    try:
        return PointProbe(mesh, point)
    except ValueError:
        raise InputError(f"{key} {point} lies outside the mesh") from None


def pin_deflection(
    space: dolfinx.fem.FunctionSpace[np.float64], point: list[float]
) -> dolfinx.fem.DirichletBC[np.float64]:
    """W = 0 at one node at ``point``: ``model.pin``, the height of a plate nothing holds up.

    The deflection is discontinuous, so every cell at that vertex has a node there; holding
    all of them would also join the cells at that point, so only the node of the cell of least
    original (input) index is held, whatever the partition, on every rank that has it.

    Args:
        space: the mixed space (w, u).
        point: [x, y], a vertex of the mesh.

    Returns:
        The condition on the deflection; an InputError when no vertex lies at ``point``.
    """
    mesh = space.mesh
    comm = mesh.comm
    sub = space.sub(0)
    collapsed, _ = sub.collapse()
    lo, hi = bounds(comm, mesh.geometry.x[:, :2])
    tol = 1e-8 * float(np.max(hi - lo))
    x0, y0 = (float(c) for c in point)

    def near(x: np.ndarray) -> np.ndarray:
        return np.asarray(np.hypot(x[0] - x0, x[1] - y0) < tol)

    dofs = dolfinx.fem.locate_dofs_geometrical((sub, collapsed), near)[0]
    cells = _owned_cells_at(mesh, dolfinx.mesh.locate_entities(mesh, 0, near))
    original = np.asarray(mesh.topology.original_cell_index, dtype=np.int64)[cells]
    none = np.iinfo(np.int64).max
    first = comm.allreduce(int(original.min(initial=none)), op=MPI.MIN)
    if first == none:
        raise InputError(f"model.pin {[x0, y0]} is not a vertex of the mesh")
    index_map, bs = space.dofmap.index_map, space.dofmap.index_map_bs
    numbers = index_map.local_to_global((dofs // bs).astype(np.int32)) * bs + dofs % bs
    mine = none
    if first in original:
        cell = int(cells[np.flatnonzero(original == first)[0]])
        (dof,) = np.intersect1d(sub.dofmap.cell_dofs(cell), dofs)
        mine = int(numbers[np.flatnonzero(dofs == dof)[0]])
    chosen = comm.allreduce(mine, op=MPI.MIN)
    held = dofs[numbers == chosen].astype(np.int32)
    return dolfinx.fem.dirichletbc(values.constant(mesh, 0.0), held, sub)


def _owned_cells_at(mesh: dolfinx.mesh.Mesh[np.float64], vertices: np.ndarray) -> np.ndarray:
    """The owned cells that have one of ``vertices`` (local indices)."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(0, tdim)
    links = mesh.topology.connectivity(0, tdim)
    found = [links.links(int(v)) for v in vertices]
    cells = np.unique(np.concatenate(found)) if found else np.zeros(0, dtype=np.int32)
    owned: np.ndarray = cells[cells < mesh.topology.index_map(tdim).size_local]
    return owned


# -- hooks of the driver -------------------------------------------------------------------------
class Deformation:
    """The shape hook: y = (x₁ + u₁, x₂ + u₂, w) ∈ [DG_k]³ of a state (w, u)."""

    def __init__(self, state: dolfinx.fem.Function[np.float64], degree: int) -> None:
        mesh = state.function_space.mesh
        space = dolfinx.fem.functionspace(mesh, ("DG", degree, (3,)))
        w, u = ufl.split(state)
        x = ufl.SpatialCoordinate(mesh)
        y = ufl.as_vector([x[0] + u[0], x[1] + u[1], w])
        self.y: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(space, name="deformation")
        self._expr: dolfinx.fem.Expression[np.float64] = dolfinx.fem.Expression(
            y, compat.interpolation_points(space.element)
        )

    def __call__(self) -> dolfinx.fem.Function[np.float64]:
        """Y of the current state."""
        self.y.interpolate(self._expr)
        return self.y


def start_from(state: dolfinx.fem.Function[np.float64], initial: Initial) -> None:
    """W = y₃ and u = (y₁, y₂) − x of a deformation x ↦ y(x), as the first iterate."""
    parts: list[Callable[[np.ndarray], np.ndarray]] = [
        lambda x: initial(x)[2],
        lambda x: initial(x)[:2] - x[:2],
    ]
    for index, part in enumerate(parts):
        space, dofs = compat.collapse(state.function_space.sub(index))
        function = dolfinx.fem.Function(space)
        function.interpolate(part)
        state.x.array[dofs] = function.x.array
    state.x.scatter_forward()


# -- the model -----------------------------------------------------------------------------------
@dataclass
class FvKModel(Model):
    """An FvK plate on a mesh: facets, the mixed space, in-plane conditions and the probe.

    One driver at a time (the conditions' Constants and the options prefix are shared).
    """

    spec: FvKSpec
    facets: FacetSets
    space: dolfinx.fem.FunctionSpace[np.float64]
    bcs: list[dolfinx.fem.DirichletBC[np.float64]]
    bc_values: BCValues
    probe: PointProbe
    tip: dolfinx.fem.Function[np.float64] | None = None
    named_probes: dict[str, PointProbe] | None = None

    def driver(
        self, flow: object, observers: Sequence[Observer], initial: Initial | None
    ) -> LoadPath | BranchPath:
        """The load path from the unloaded flat plate or from ``initial``.

        Newton over the load schedule, or with ``path.method = "arclength"`` the arclength
        continuation (:class:`dgplate.solvers.continuation.BranchPath`). ``flow`` (the
        problem's [flow] section) is ignored: FvK is not a gradient flow.
        """
        state: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(self.space, name="state")
        if initial is not None:
            start_from(state, initial)
        load_factor = values.constant(self.facets.mesh, 0.0)
        energy = fvk_energy(state, self.facets, self.spec, load_factor, self.tip)
        bc_values = self.scaled_bc_values()
        newton = self.spec.newton
        if self.spec.path.method == "arclength":
            return BranchPath(
                state,
                energy,
                self.bcs,
                load_factor,
                self.spec.path.settings(),
                PREFIX,
                newton.snes,
                bc_values=bc_values,
                shape=Deformation(state, self.spec.degree),
                probes=DeflectionProbes(state, self.probe, self.named_probes),
                observers=observers,
            )
        return LoadPath(
            state,
            energy,
            self.bcs,
            load_factor,
            newton.load_factors,
            PREFIX,
            newton.snes,
            bc_values=bc_values,
            observers=observers,
            shape=Deformation(state, self.spec.degree),
            probes=DeflectionProbes(state, self.probe, self.named_probes),
            hint=_HINT,
            stability=newton.stability_options,
            relaxation=Relaxation(tau=newton.relaxation_tau) if newton.relaxation else None,
        )

    def scaled_bc_values(self) -> BCValues:
        """The edge displacements the load factor scales; the others are set to their full values.

        Returns:
            The (datum, value at full load) pairs of the driver: all of them when
            ``path.parameter`` is "load" or "membrane", none otherwise.
        """
        if self.spec.path.parameter in ("load", "membrane"):
            return self.bc_values
        for datum, value in self.bc_values:
            datum.value = np.asarray(value, dtype=float)
        return []

    def figures(self, driver: LoadPath | BranchPath) -> dict[str, Any]:
        """The FvK numbers of the last converged load step (None before the first)."""
        spec = self.spec
        last = asdict(driver.history[-1]) if driver.history else {}
        w_center = last.get("w_center")
        scaled = spec.path.parameter in ("load", "pressure")
        return {
            "load": (last["load_factor"] if scaled else 1.0) * spec.pressure
            if last and not isinstance(spec.pressure, str)
            else None,
            "pressure": spec.pressure,
            "w_max": last.get("w_max"),
            "w_center": w_center,
            "probe": [float(c) for c in self.probe.point[0, :2]],
            "w_center_over_thickness": None if w_center is None else w_center / spec.thickness,
            "D": spec.D,
        }

    def lines(self, driver: LoadPath | BranchPath) -> list[np.ndarray]:
        """No lines are drawn on an FvK plate."""
        return []


def build_fvk(spec: FvKSpec, tagged: TaggedMesh) -> FvKModel:
    """The FvK model of ``spec`` on ``tagged`` (checks the group names on the mesh).

    Args:
        spec: the validated ``[model]`` section.
        tagged: the mesh with its named cell and facet groups.

    Returns:
        The model: its mixed space (u, w), energy, membrane conditions and the Newton
        load path's settings.
    """
    _check_group_names(spec, tagged)
    facets = fvk_facet_sets(tagged, spec)
    space = fvk_space(tagged.mesh, spec.degree)
    bcs, bc_values = membrane_bcs(space, tagged, spec)
    _check_free_plate_is_held(spec, tagged)
    if spec.pin is not None:
        bcs.append(pin_deflection(space, spec.pin))
    tip = None
    if spec.indenter is not None:
        tip = tagged.group_function({spec.indenter: 1.0}, 0.0, key="model.indenter")
        _check_indentation(spec, tagged.mesh)
    named = {
        name: _point_probe(tagged.mesh, point, f"model.probes.{name}")
        for name, point in spec.probes.items()
    }
    probe = _probe(spec, tagged.mesh)
    return FvKModel(spec, facets, space, bcs, bc_values, probe, tip, named)


def _check_free_plate_is_held(spec: FvKSpec, tagged: TaggedMesh) -> None:
    """A bent plate that no edge holds up needs mirror edges along x and along y (and a pin).

    Without a clamped or simply supported group (or an indenter), the mirror edges alone hold
    the tilts of w and the sliding of u along them: one mirror axis leaves a tilt and a
    sliding free, and the Jacobian is singular.
    """
    if spec.held_up or not spec.bent:
        return
    axes = {edge_axis(tagged, group, f"model.mirror: group '{group}'") for group in spec.mirror}
    if axes != {0, 1}:
        raise InputError(
            "model.mirror: a plate that no clamped or simply supported group holds needs mirror "
            "edges along x and along y (its tilts and its sliding are free otherwise): model a "
            "quarter of a plate symmetric about both axes"
        )


def _check_indentation(spec: FvKSpec, mesh: dolfinx.mesh.Mesh[np.float64]) -> None:
    """Warn (rank 0, stderr) when the indentation exceeds the height of the natural shape.

    The height is max w₀ − min w₀ over the mesh nodes: pushed further, the cone would invert.
    """
    shape = spec.natural_shape
    points = mesh.geometry.x[:, :2]
    local = (
        expressions.evaluate(shape, points, "model.natural_shape")
        if isinstance(shape, str)
        else np.full(len(points), float(shape))
    )
    local = np.broadcast_to(np.asarray(local, dtype=float), (len(points),))
    lo, hi = bounds(mesh.comm, local[:, None])
    height = float(hi[0] - lo[0])
    if spec.indentation > height and mesh.comm.rank == 0:
        print(
            f"dgplate: warning: model.indentation = {spec.indentation:g} exceeds the height "
            f"{height:g} of model.natural_shape: the cone would invert",
            file=sys.stderr,
            flush=True,
        )
