"""Bilayer plates with spontaneous curvature Z (docs/design.md §1).

E[y] = ½∫μ|II(y) − Z|² − ∫f·y under the isometry constraint. For isometries |II| = |D²y|, so

    E[y] = ½∫μ|D²y|² − ∫μ Z : (D²y·ν) + ½∫μ|Z|² − ∫f·y,      ν = ∂₁y × ∂₂y / |∂₁y × ∂₂y|.

The first term is the interior-penalty bending energy of :mod:`dgplate.dg.forms`. The coupling term
uses the *distributional* Hessian H(y) of the broken field, so that the smooth minimiser
satisfies the discrete equations (consistency):

    ⟨H(y), T⟩ = Σ_T ∫ D²y : T − Σ_e ∫ [∇y] : {T n} + Σ_e ∫ [y] · {div T · n},   T = μ ν ⊗ Z.

Without the facet terms the broken Hessian misses the curvature concentrated in gradient jumps
and the interior-penalty consistency terms −{D²y n}:[∇v] are left unbalanced: the plate then
rolls to a wrong radius (``consistent=False`` keeps that variant for comparison; the cylinder
test shows the difference). On crease facets the [∇y] term is dropped, like in the bending form.
The coupling term is not quadratic: the gradient flow treats it explicitly (at yⁿ).

With a target metric G (``model.metric``, ``model.director``; docs/prestrain.md) the plate is
constrained to ∇yᵀ∇y = G and its energy is ½∫μ|G^{-1/2}(II − Z)G^{-1/2}|² (Bonito, Guignard,
Nochetto and Yang, J. Comput. Phys. 2022, Z in the reference coordinates), i.e.

    ½∫μ|G^{-1/2}IIG^{-1/2}|² − ∫μ II : G⁻¹ZG⁻¹ + ½∫μ Z : G⁻¹ZG⁻¹.

The first term is the Kirchhoff energy with the metric (up to a function of G); as
II : W = Σ_k D²y_k : W ν_k for any W (D²y_k = Γᵐ∂_m y_k + II ν_k and ν ⊥ ∂_m y), the
coupling is the one above with Z replaced by G⁻¹ZG⁻¹ (:func:`metric_curvature`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import ufl
from ufl.core.expr import Expr

from dgplate import expressions, values
from dgplate.compat import Function
from dgplate.dg.energy import Energy
from dgplate.dg.forms import (
    BendingData,
    Coefficient,
    FacetSets,
    Penalty,
    cell_measure,
    distributional_hessian,
    explicit_quadrature,
    facet_sets,
    metric_quadrature,
)
from dgplate.dg.gauss_penalty import gauss_penalty, gauss_penalty_measures
from dgplate.dg.geometry import second_fundamental_form, unit_normal
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import (
    PlateModel,
    clamped_data,
    continuation_path,
    piecewise_constant,
)
from dgplate.models.kirchhoff import KirchhoffSpec, kirchhoff_energy, spec_metric, trace_constant
from dgplate.models.obstacle import with_obstacle
from dgplate.models.plate_path import BilayerPathSpec
from dgplate.models.self_avoidance import with_self_avoidance
from dgplate.schema import Check, is_matrix, is_number, option, section

__all__ = [
    "BilayerSpec",
    "bilayer_energy",
    "build_bilayer",
    "curvature_coupling",
    "gauss_penalty",
    "metric_curvature",
    "second_fundamental_form",
    "spontaneous_curvature",
    "unit_normal",
]


def curvature_coupling(
    y: Expr,
    facets: FacetSets,
    Z: Expr,
    mu: Coefficient = 1.0,
    g: Expr | None = None,
    Phi: Expr | None = None,
    consistent: bool = True,
    degree: int | None = None,
) -> ufl.Form:
    """−⟨H(y), μ ν⊗Z⟩: the spontaneous-curvature term of the energy (see module docstring)."""
    nu = unit_normal(y)
    T = mu * ufl.outer(nu, Z)  # 3 × 2 × 2
    if consistent:
        coupling: ufl.Form = -distributional_hessian(y, T, facets, g, Phi, degree)
        return coupling
    form: ufl.Form = -ufl.inner(ufl.grad(ufl.grad(y)), T) * cell_measure(facets.mesh, degree)
    return form


def metric_curvature(Z: Expr, metric: Expr | None) -> Expr:
    """G⁻¹ZG⁻¹, the spontaneous curvature as the coupling with a target metric G tests it.

    Then II : G⁻¹ZG⁻¹ is the cross term of |G^{-1/2}(II − Z)G^{-1/2}|² and Z : G⁻¹ZG⁻¹ its
    constant.

    Args:
        Z: the spontaneous curvature, a UFL 2×2 expression.
        metric: the target metric G (None: I, and Z itself).

    Returns:
        The 2×2 expression G⁻¹ZG⁻¹.
    """
    if metric is None:
        return Z
    inverse = ufl.inv(metric)
    weighted: Expr = ufl.dot(inverse, ufl.dot(Z, inverse))
    return weighted


def bilayer_energy(
    y: Expr,
    facets: FacetSets,
    penalty: Penalty,
    Z: Expr,
    mu: Coefficient | None = None,
    load: Expr | None = None,
    g: Expr | None = None,
    Phi: Expr | None = None,
    consistent: bool = True,
    degree: int | None = None,
    gauss: float = 0.0,
    ldg_degree: int | None = None,
    metric: Expr | None = None,
    trace_weight: float = 0.0,
) -> Energy:
    """Bending (implicit) + curvature coupling and ½∫μ Z : G⁻¹ZG⁻¹ (explicit) − load.

    ``gauss`` > 0 adds :func:`gauss_penalty` with β = ``gauss`` to the explicit part.
    ``ldg_degree``: the bending energy with the LDG reconstructed Hessian
    (:func:`~dgplate.models.kirchhoff.kirchhoff_energy`); the coupling keeps the
    distributional Hessian (equal to ∫ H_h(y) : T where T lies in the lifting space).
    ``metric``: the target metric G (None: I, the isometric plate): the bending energy with
    G, the coupling and the constant with G⁻¹ZG⁻¹ (module docstring), at the quadrature
    degree ``degree`` (None: :func:`~dgplate.dg.forms.metric_quadrature`).
    ``trace_weight`` c = ν/(1 − ν): the trace term c tr(G^{-1/2}(II − Z)G^{-1/2})², i.e. the
    rigidity (1 + c)μ of the bending part (with the constant of
    :func:`~dgplate.models.kirchhoff.trace_constant`), the coupling with
    G⁻¹ZG⁻¹ + c tr(G⁻¹Z)G⁻¹ and the constant ½∫μ (Z : G⁻¹ZG⁻¹ + c tr(G⁻¹Z)²).
    """
    rigidity = 1.0 if mu is None else mu
    c = trace_weight
    data: BendingData = {"mu": (1 + c) * rigidity if c else mu, "g": g, "Phi": Phi}
    dx = facets.dx
    if metric is not None:
        data["metric"] = metric
        degree = metric_quadrature(y) if degree is None else degree
        dx = cell_measure(facets.mesh, degree)
    bending = kirchhoff_energy(y, facets, penalty, load, ldg_degree, **data)
    weighted = metric_curvature(Z, metric)
    constant = ufl.inner(Z, weighted)
    if c:
        inverse = ufl.Identity(2) if metric is None else ufl.inv(metric)
        trace = ufl.inner(inverse, Z)  # tr(G⁻¹Z)
        weighted = weighted + c * trace * inverse
        constant = constant + c * trace**2
        if metric is not None:
            implicit = bending.implicit + trace_constant(rigidity, c, metric, facets, degree)
            bending = replace(bending, implicit=implicit)
    explicit = curvature_coupling(y, facets, weighted, rigidity, g, Phi, consistent, degree)
    explicit += 0.5 * rigidity * constant * dx
    if gauss > 0:
        explicit += gauss_penalty(y, facets, gauss, degree, metric)
    return replace(bending, explicit=explicit)


# -- problem files -----------------------------------------------------------------------------
def _check_symmetric(matrix: object, key: str) -> None:
    """A 2×2 matrix (a spec's) whose off-diagonal entries agree (formulas: up to spaces)."""
    assert is_matrix(matrix, 2, 2)
    a, b = matrix[0][1], matrix[1][0]
    same = (
        (a == b)
        if not (isinstance(a, str) or isinstance(b, str))
        else str(a).replace(" ", "") == str(b).replace(" ", "")
    )
    if not same:
        raise InputError(
            f"{key} must be symmetric: {key}[0][1] = {a!r} differs from {key}[1][0] = {b!r}"
        )


def spontaneous_curvature(value: object, tagged: TaggedMesh, key: str = "model.Z") -> Expr:
    """Z from a problem file.

    A number α (Z = αI), a 2×2 matrix of numbers or formulas in x, y, or {cell group = number
    or matrix} (piecewise constant). Numbers are Constants, tables DG0 functions
    (:mod:`dgplate.values`).
    """
    mesh = tagged.mesh
    if is_number(value):
        scaled: Expr = values.constant(mesh, value) * ufl.Identity(2)
        return scaled
    if isinstance(value, list):
        _check_symmetric(value, key)
        matrix = values.array(value, mesh, key)
        assert not isinstance(matrix, float)  # a 2×2 matrix gives a tensor
        return matrix
    assert isinstance(value, dict)
    matrices = {name: _group_matrix(entry, f"{key}.{name}") for name, entry in value.items()}
    return tagged.group_function(matrices, shape=(2, 2), key=key)


def _group_matrix(entry: object, key: str) -> list[list[float]]:
    """The value of one cell group of a Z table: a number α (αI) or a symmetric 2×2 matrix."""
    if is_number(entry):
        entry = [[float(entry), 0.0], [0.0, float(entry)]]
    _check_symmetric(entry, key)
    assert is_matrix(entry, 2, 2)
    return [[float(v) for v in row if is_number(v)] for row in entry]


@dataclass
class BilayerSpec(KirchhoffSpec):
    """[model] of a bilayer plate: the Kirchhoff keys plus the spontaneous curvature."""

    name: str = option("bilayer", "the model")
    Z: float | list[list[float | str]] | dict[str, float | list[list[float]]] = option(
        1.0,
        "spontaneous curvature: α (Z = αI), [[Z11, Z12], [Z12, Z22]] (numbers or formulas in x, y), or {cell group = α or a matrix of numbers}",
        length=2,
        each=Check(length=2, each=Check(length=2)),
    )
    consistent: bool = option(
        True, "include the face terms of the distributional Hessian in the Z coupling"
    )
    path: BilayerPathSpec = section(BilayerPathSpec, "path")

    def __post_init__(self) -> None:
        super().__post_init__()
        if isinstance(self.Z, list):  # formulas are checked now; the shape when it is built
            expressions.check(self.Z, "model.Z")


def build_bilayer(spec: BilayerSpec, tagged: TaggedMesh) -> PlateModel:
    """Facet sets, the energy and the curvature figures of a bilayer problem.

    Args:
        spec: the validated ``[model]`` section.
        tagged: the mesh with its named cell and facet groups.

    Returns:
        The model: its facet sets, energy (with the spontaneous curvature Z), flow
        settings and curvature figures.
    """
    from dgplate.measure.analysis import curvature_summary

    facets = facet_sets(tagged, spec.clamped, spec.crease, spec.penalty_length)
    arclength = spec.path.arclength(tagged.mesh)
    load = values.vector(spec.load, tagged.mesh, "model.load", 3)
    load = spec.path.scaled(load, "load", arclength)
    mu = piecewise_constant(tagged, spec.mu, "model.mu")
    Z = spec.path.scaled(spontaneous_curvature(spec.Z, tagged), "natural_curvature", arclength)
    path = continuation_path(spec.schedule, tagged.mesh)
    moving = spec.path.moving_data(arclength)
    g, Phi = clamped_data(spec.boundary_data, tagged.mesh, path=path or moving)
    penalty = spec.penalty
    degree = explicit_quadrature(spec.degree)
    metric = spec.path.scaled_metric(spec_metric(spec, tagged), spec, tagged, arclength)

    def energy_fn(y: Function) -> Energy:
        return bilayer_energy(
            y,
            facets,
            penalty,
            Z,
            mu,
            load,
            g,
            Phi,
            spec.consistent,
            degree,
            spec.gauss_penalty,
            spec.ldg_degree,
            metric,
            spec.trace_weight,
        )

    plate = PlateModel(
        facets,
        spec.degree,
        energy_fn,
        measures=[
            curvature_summary,
            *gauss_penalty_measures(facets, spec.gauss_penalty, degree, metric),
        ],
        continuation=path,
        metric=metric,
        arclength=arclength,
        continuous=spec.continuous,
    )
    return with_self_avoidance(with_obstacle(plate, spec.obstacle, g, path), spec.self_avoidance)
