"""The FvK energy Π(u, w), its facet sets, the mixed space and the in-plane conditions.

The terms are derived in the docstring of :mod:`dgplate.models.fvk`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeAlias

from mpi4py import MPI

import basix.ufl
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from dgplate import compat, expressions, values
from dgplate.dg.forms import (
    FREE,
    FacetSets,
    Penalty,
    bending_energy,
    facet_sets,
    grad_laplacian,
    hessian,
    jump,
)
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.fvk.spec import PARAMETERS, FvKSpec
from dgplate.mpi import allreduce_array

#: Facet-set ids of simply supported and mirror boundary facets (beside dg.SMOOTH … dg.FREE = 1 … 4).
SIMPLY_SUPPORTED, MIRROR = 5, 6


def membrane_strain(u: Any, w: Any, prestrain: Any = 0.0, natural: Any = None) -> Any:
    """ε = sym∇u + ½(∇w⊗∇w − ∇w₀⊗∇w₀) − ε₀ I (element-wise gradient of a dG deflection).

    ``natural`` is the natural shape w₀ as a UFL expression (None: flat).
    """
    gw = ufl.grad(w)
    eps = ufl.sym(ufl.grad(u)) + 0.5 * ufl.outer(gw, gw) - prestrain * ufl.Identity(2)
    if natural is not None:
        g0 = ufl.grad(natural)
        eps -= 0.5 * ufl.outer(g0, g0)
    return eps


def natural_shape(spec: FvKSpec, mesh: dolfinx.mesh.Mesh[np.float64]) -> Any:
    """w₀ of ``model.natural_shape`` as a UFL expression, None for a flat (constant) w₀."""
    shape = expressions.parse(spec.natural_shape, mesh, "model.natural_shape")
    return None if isinstance(shape, float) else shape


def plane_stress(eps: Any, stiffness: Any, nu: Any) -> Any:
    """stiffness·[(1−ν)ε + ν tr(ε) I]: N for stiffness A, M (with ε = κ) for stiffness D."""
    return stiffness * ((1 - nu) * eps + nu * ufl.tr(eps) * ufl.Identity(2))


def _cofactor(A: Any) -> Any:
    return ufl.tr(A) * ufl.Identity(2) - A


def fvk_bending_energy(
    w: Any,
    faces: FacetSets,
    penalty: Penalty,
    D: Any,
    nu: Any,
    simply_supported: bool,
    slope: Any = None,
) -> ufl.Form:
    """½a_h(w, w) with the Poisson part and simply supported facets (:mod:`dgplate.models.fvk`).

    ``slope`` is the ∇w prescribed on the clamped facets (a UFL vector; None: 0).
    """
    n, h = faces.n, faces.h_boundary
    gamma0, gamma1 = penalty.constants(faces.mesh)
    H = hessian(w)
    Phi = ufl.as_vector((0.0, 0.0)) if slope is None else slope
    energy: ufl.Form = bending_energy(w, faces, penalty, mu=D, g=0.0, Phi=Phi)
    energy += nu * D * ufl.det(H) * faces.dx
    energy -= (
        nu
        * D
        * ufl.inner(ufl.dot(ufl.avg(_cofactor(H)), n("+")), jump(ufl.grad(w)))
        * faces.dS_smooth()
    )
    if faces.has_clamped:
        jump_out = ufl.grad(w) - Phi  # [∇w] on a clamped facet
        energy -= nu * D * ufl.inner(ufl.dot(_cofactor(H), n), jump_out) * faces.ds_clamped()
    if simply_supported:
        tgrad = ufl.dot(ufl.Identity(2) - ufl.outer(n, n), ufl.grad(w))
        moment_n = ufl.dot(plane_stress(H, D, nu), n)
        energy += (
            -ufl.inner(moment_n, tgrad)
            + 0.5 * penalty.gradient_weight(h, gamma1) * D * ufl.inner(tgrad, tgrad)
            + D * ufl.inner(ufl.dot(grad_laplacian(w), n), w)
            + 0.5 * gamma0 * D / h**3 * w * w
        ) * faces.ds(SIMPLY_SUPPORTED)
    return energy


def mirror_energy(w: Any, faces: FacetSets, penalty: Penalty, D: Any, nu: Any) -> ufl.Form:
    """The Nitsche terms of ∂w/∂n = 0 on mirror facets: −∫M_nn ∂ₙw + ½γ₁D/hᵖ (∂ₙw)².

    On a mirror plane the slope across it and the effective shear vanish; an element-wise
    integration by parts leaves M_nn ∂ₙv there, the only term the condition touches.
    """
    n, h = faces.n, faces.h_boundary
    _, gamma1 = penalty.constants(faces.mesh)
    slope = ufl.dot(ufl.grad(w), n)
    moment_nn = ufl.dot(ufl.dot(plane_stress(hessian(w), D, nu), n), n)
    weight = penalty.gradient_weight(h, gamma1)
    form: ufl.Form = (-moment_nn * slope + 0.5 * weight * D * slope * slope) * faces.ds(MIRROR)
    return form


def natural_curvature_energy(w: Any, faces: FacetSets, moment: Any, slope: Any = None) -> ufl.Form:
    """−M₀[Σ∫ tr D²w − Σ∫ n·[∇w]]: the work of the natural moment M₀ I = D(1 + ν)κ₀ I.

    Bending measured from κ₀ I adds −∫M₀I:D²w to ½a_h(w, w) (and a constant). The facet terms
    are those of the IP method with M − M₀I in place of M: on smooth interior facets, clamped
    facets ([∇w] = ∇w − Φ) and mirror facets; so the broken integral reduces to the boundary
    term of a smooth w, and the method stays consistent.

    Args:
        w: the deflection.
        faces: the facet sets (mirror facets have id :data:`MIRROR`).
        moment: M₀ = D(1 + ν)κ₀ (scaled with the load where the path says so).
        slope: the clamped facets' prescribed ∇w (None: 0).

    Returns:
        The form, to add to the energy.
    """
    n = faces.n
    grad = ufl.grad(w)
    work: ufl.Form = ufl.tr(hessian(w)) * faces.dx
    work -= ufl.inner(n("+"), jump(grad)) * faces.dS_smooth()
    if faces.has_clamped:
        out = grad if slope is None else grad - slope
        work -= ufl.inner(n, out) * faces.ds_clamped()
    work -= ufl.inner(n, grad) * faces.ds(MIRROR)
    form: ufl.Form = -moment * work
    return form


def scaling(parameter: str, load_factor: Any) -> Callable[[str], Any]:
    """The factor of each datum: λ for the one ``parameter`` names (every one for "load"), else 1.

    Args:
        parameter: ``path.parameter``.
        load_factor: the Constant λ.

    Returns:
        datum name ↦ its factor (λ or 1.0).
    """

    def factor(datum: str) -> Any:
        assert datum in PARAMETERS, datum
        return load_factor if parameter in ("load", datum) else 1.0

    return factor


def clamp_slope(spec: FvKSpec, mesh: dolfinx.mesh.Mesh[np.float64]) -> Any:
    """The ∇w of ``model.clamp_slope`` at full load.

    Args:
        spec: the [model] section.
        mesh: the plate's mesh (formulas are parsed on it).

    Returns:
        The slope as a UFL vector; None when it is 0.
    """
    if all(component in (0, 0.0) for component in spec.clamp_slope):
        return None
    parts = [
        expressions.parse(c, mesh, f"model.clamp_slope[{i}]")
        for i, c in enumerate(spec.clamp_slope)
    ]
    return ufl.as_vector([values.constant(mesh, p) if isinstance(p, float) else p for p in parts])


def fvk_energy(
    state: dolfinx.fem.Function[np.float64],
    faces: FacetSets,
    spec: FvKSpec,
    load_factor: dolfinx.fem.Constant[np.float64],
    tip: Any = None,
) -> ufl.Form:
    """Π(u, w) of the state (w, u) ∈ DG_k × [CG_k]² at the load factor of ``load_factor``.

    E, ν, t, p and ε₀ enter as Constants (:mod:`dgplate.values`). ``tip`` is the cell measure
    of the indenter's cell group (``model.indenter``), where the penalty
    ½ k E t ∫(w − w₀ + λδ)² pushes the plate down rigidly by λδ from its natural shape.
    The load factor scales the data that ``path.parameter`` names (all with "load"); the
    others enter at their full values.
    """
    mesh = faces.mesh
    scale = scaling(spec.path.parameter, load_factor)
    E, nu, t, prestrain = (
        values.constant(mesh, v) for v in (spec.E, spec.nu, spec.thickness, spec.prestrain)
    )
    pressure = expressions.parse(spec.pressure, mesh, "model.pressure")
    if isinstance(pressure, float):
        pressure = values.constant(mesh, pressure)
    D = E * t**3 / (12 * (1 - nu**2))
    A = E * t / (1 - nu**2)
    w, u = ufl.split(state)
    natural = natural_shape(spec, mesh)
    eps = membrane_strain(u, w, scale("prestrain") * prestrain, natural)
    energy: ufl.Form = 0.5 * ufl.inner(plane_stress(eps, A, nu), eps) * faces.dx
    simply_supported = bool(spec.simply_supported)
    slope = clamp_slope(spec, mesh)
    if slope is not None:
        slope = scale("clamp_slope") * slope
    energy += fvk_bending_energy(w, faces, spec.penalty, D, nu, simply_supported, slope)
    if spec.mirror:
        energy += mirror_energy(w, faces, spec.penalty, D, nu)
    if spec.natural_curvature:
        kappa0 = values.constant(mesh, spec.natural_curvature)
        moment = scale("natural_curvature") * D * (1 + nu) * kappa0
        energy += natural_curvature_energy(w, faces, moment, slope)
    energy -= scale("pressure") * pressure * w * faces.dx
    if spec.indenter is not None and tip is not None:
        depth, stiffness = (
            values.constant(mesh, v) for v in (spec.indentation, spec.indenter_stiffness)
        )
        w0 = natural if natural is not None else 0.0
        gap = w - w0 + scale("indentation") * depth
        energy += 0.5 * stiffness * E * t * tip * gap * gap * faces.dx
    return energy


# -- facets, spaces and in-plane conditions ----------------------------------------------------
def fvk_facet_sets(tagged: TaggedMesh, spec: FvKSpec) -> FacetSets:
    """dg.facet_sets plus the simply supported and mirror facets (ids SIMPLY_SUPPORTED, MIRROR)."""
    facets = facet_sets(tagged, spec.clamped, spec.crease, spec.penalty_length)
    groups = {
        "simply_supported": (spec.simply_supported, SIMPLY_SUPPORTED),
        "mirror": (spec.mirror, MIRROR),
    }
    if not spec.simply_supported and not spec.mirror:
        return facets
    mesh, fdim = tagged.mesh, tagged.mesh.topology.dim - 1
    fmap = mesh.topology.index_map(fdim)
    tags = facets.tags.values.copy()
    position = np.full(fmap.size_local + fmap.num_ghosts, -1, dtype=np.int64)
    position[facets.tags.indices] = np.arange(facets.tags.indices.size)
    for key, (names, tag) in groups.items():
        for group in names:
            indices = tagged.facets(group)
            is_owned = indices < fmap.size_local
            wrong = np.count_nonzero(tags[position[indices]][is_owned] != FREE)
            owned = np.count_nonzero(is_owned)
            wrong, owned = allreduce_array(mesh.comm, [wrong, owned]).astype(int)
            if wrong or not owned:
                raise InputError(
                    f"model.{key}: group '{group}' must be non-empty boundary facets that are "
                    f"not clamped or given another condition ({wrong} of {owned} are not)"
                )
            tags[position[indices]] = tag
    meshtags = dolfinx.mesh.meshtags(mesh, fdim, facets.tags.indices, tags)
    return FacetSets(mesh, meshtags, facets.num_clamped, facets.num_crease, spec.penalty_length)


def fvk_space(
    mesh: dolfinx.mesh.Mesh[np.float64], degree: int
) -> dolfinx.fem.FunctionSpace[np.float64]:
    """W = DG_k × [CG_k]²: the deflection w and the in-plane displacement u."""
    cell = mesh.basix_cell()
    elements = [
        basix.ufl.element("DG", cell, degree),
        basix.ufl.element("Lagrange", cell, degree, shape=(2,)),
    ]
    return dolfinx.fem.functionspace(mesh, basix.ufl.mixed_element(elements))


def edge_axis(tagged: TaggedMesh, group: str, key: str) -> int:
    """Component of u normal to an axis-parallel edge group: 0 for x = const, 1 for y = const.

    ``key`` names the input that asked for it in the error (a straight edge along x or y).
    """
    mesh = tagged.mesh
    facets = tagged.facets(group)
    x = mesh.geometry.x[compat.entities_to_geometry(mesh, mesh.topology.dim - 1, facets)]
    spread = np.ptp(x[:, :, :2], axis=1) if facets.size else np.zeros((0, 2))
    scale = np.ptp(mesh.geometry.x[:, :2], axis=0).max()
    flags = np.array([np.all(spread[:, 0] < 1e-10 * scale), np.all(spread[:, 1] < 1e-10 * scale)])
    flags = allreduce_array(mesh.comm, flags, op=MPI.MIN).astype(int)
    if flags.sum() != 1:
        raise InputError(f"{key} needs a straight edge parallel to the x or y axis")
    return int(np.argmax(flags))


def _component_values(tagged: TaggedMesh, group: str, condition: Any, key: str) -> list[Any]:
    """[u_x, u_y] at full load of one group's condition, "free" for a free component.

    ``key`` names the input of a "normal" condition in its error.
    """
    if condition == "fixed":
        return [0.0, 0.0]
    if condition == "free":
        return ["free", "free"]
    if condition == "normal":
        components: list[Any] = ["free", "free"]
        components[edge_axis(tagged, group, key)] = 0.0
        return components
    return list(condition)


# a string: DOLFINx 0.9's Constant is not subscriptable at run time
BCValues: TypeAlias = "list[tuple[Any, Any]]"  # (Constant or ScaledData, value at full load)


def membrane_bcs(
    space: dolfinx.fem.FunctionSpace[np.float64], tagged: TaggedMesh, spec: FvKSpec
) -> tuple[list[dolfinx.fem.DirichletBC[np.float64]], BCValues]:
    """Dirichlet conditions on u, and their (Constant, value at full load) pairs."""
    conditions: dict[str, Any] = dict.fromkeys([*spec.clamped, *spec.simply_supported], "fixed")
    conditions.update(dict.fromkeys(spec.mirror, "normal"))
    conditions.update(spec.membrane)
    fdim = tagged.mesh.topology.dim - 1
    bcs: list[dolfinx.fem.DirichletBC[np.float64]] = []
    bc_values: BCValues = []
    for group, condition in conditions.items():
        facets = tagged.facets(group)
        given = group in spec.membrane or group not in spec.mirror
        key = f"model.membrane.{group} = 'normal'" if given else f"model.mirror: group '{group}'"
        for component, value in enumerate(_component_values(tagged, group, condition, key)):
            if value == "free":
                continue
            sub = space.sub(1).sub(component)
            key = f"model.membrane.{group}[{component}]"
            data = expressions.parse(value, tagged.mesh, key)
            if isinstance(data, float):
                dofs = dolfinx.fem.locate_dofs_topological(sub, fdim, facets)
                constant = values.constant(tagged.mesh, 0.0)
                bcs.append(dolfinx.fem.dirichletbc(constant, dofs, sub))
                bc_values.append((constant, data))
            else:
                bc, scaled = _formula_bc(sub, fdim, facets, data)
                bcs.append(bc)
                bc_values.append(scaled)
    if not bcs:
        raise InputError(
            "model.membrane: no edge holds the in-plane displacement (rigid in-plane "
            "motions); clamp, simply support, mirror or fix at least one edge"
        )
    return bcs, bc_values


class ScaledData:
    """Dirichlet data g = λ·g₁ given by a formula: a Function whose ``value`` is set like a Constant's.

    The continuation driver scales every Dirichlet datum with the load factor by assigning
    ``datum.value = λ·(value at full load)``; here the value at full load is the array of g₁ at the
    degrees of freedom of the collapsed subspace, and the assignment writes λ·g₁ into g.
    """

    def __init__(self, function: dolfinx.fem.Function[np.float64]) -> None:
        self.function = function

    @property
    def value(self) -> np.ndarray:
        """The current nodal values of g."""
        return self.function.x.array

    @value.setter
    def value(self, array: np.ndarray) -> None:
        self.function.x.array[:] = array


def _formula_bc(
    sub: dolfinx.fem.FunctionSpace[np.float64], fdim: int, facets: np.ndarray, data: Any
) -> tuple[dolfinx.fem.DirichletBC[np.float64], Any]:
    """U_i = λ·f(x, y) on ``facets`` for a formula f: the condition and its (datum, full load)."""
    collapsed, _ = sub.collapse()
    full: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(collapsed)
    full.interpolate(dolfinx.fem.Expression(data, compat.interpolation_points(collapsed.element)))
    function: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(collapsed)
    dofs = dolfinx.fem.locate_dofs_topological((sub, collapsed), fdim, facets)
    bc: dolfinx.fem.DirichletBC[np.float64] = dolfinx.fem.dirichletbc(function, dofs, sub)
    return bc, (ScaledData(function), full.x.array.copy())
