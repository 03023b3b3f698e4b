"""Bilayer plates with spontaneous curvature Z (docs/design.md §1).

E[y] = ½∫μ|II(y) − Z|² − ∫f·y under the isometry constraint. For isometries |II| = |D²y|, so

    E[y] = ½∫μ|D²y|² − ∫μ Z : (D²y·ν) + ½∫μ|Z|² − ∫f·y,      ν = ∂₁y × ∂₂y / |∂₁y × ∂₂y|.

The first term is the interior-penalty bending energy of :mod:`dgplate.dg.forms`. The coupling term
uses the *distributional* Hessian H(y) of the broken field, so that the smooth minimiser
satisfies the discrete equations (consistency):

    ⟨H(y), T⟩ = Σ_T ∫ D²y : T − Σ_e ∫ [∇y] : {T n} + Σ_e ∫ [y] · {div T · n},   T = μ ν ⊗ Z.

Without the face terms the broken Hessian misses the curvature concentrated in gradient jumps
and the interior-penalty consistency terms −{D²y n}:[∇v] are left unbalanced: the plate then
rolls to a wrong radius (``consistent=False`` keeps that variant for comparison; the cylinder
test shows the difference). On crease faces the [∇y] term is dropped, like in the bending form.
The coupling term is not quadratic: the gradient flow treats it explicitly (at yⁿ).
"""

from __future__ import annotations

from dataclasses import dataclass

import ufl

from dgplate import expressions, values
from dgplate.dg.energy import Energy
from dgplate.dg.forms import (
    CLAMPED,
    CREASE,
    SMOOTH,
    FacetSets,
    Penalty,
    bending_energy,
    facet_sets,
    jump,
)
from dgplate.errors import InputError
from dgplate.models.base import PlateModel, clamped_data, piecewise_constant
from dgplate.models.kirchhoff import KirchhoffSpec
from dgplate.schema import option


def unit_normal(y):
    """ν(y) = ∂₁y × ∂₂y / |∂₁y × ∂₂y|, the unit normal of the deformed surface."""
    n = ufl.cross(y.dx(0), y.dx(1))
    return n / ufl.sqrt(ufl.inner(n, n))


def second_fundamental_form(y):
    """II_ij = ∂_ij y · ν (broken, cell-wise)."""
    nu = unit_normal(y)
    return ufl.as_matrix([[ufl.dot(y.dx(i).dx(j), nu) for j in range(2)] for i in range(2)])


def curvature_coupling(
    y, faces: FacetSets, Z, mu=1.0, g=None, Phi=None, consistent=True, degree=None
):
    """−⟨H(y), μ ν⊗Z⟩: the spontaneous-curvature term of the energy (see module docstring)."""
    md = {} if degree is None else {"quadrature_degree": degree}
    dx = ufl.Measure("dx", domain=faces.mesh, metadata=md)
    nu = unit_normal(y)
    T = mu * ufl.outer(nu, Z)  # 3 × 2 × 2
    form = -ufl.inner(ufl.grad(ufl.grad(y)), T) * dx
    if not consistent:
        return form
    n = faces.n
    dS = faces.dS.reconstruct(metadata=md)
    ds = faces.ds.reconstruct(metadata=md)
    form += ufl.inner(jump(ufl.grad(y)), ufl.dot(ufl.avg(T), n("+"))) * dS(SMOOTH)
    value_faces = dS(SMOOTH) + dS(CREASE) if faces.num_crease else dS(SMOOTH)
    form -= ufl.inner(jump(y), ufl.dot(ufl.avg(ufl.div(T)), n("+"))) * value_faces
    if faces.has_clamped:
        form += ufl.inner(ufl.grad(y) - Phi, ufl.dot(T, n)) * ds(CLAMPED)
        form -= ufl.inner(y - g, ufl.dot(ufl.div(T), n)) * ds(CLAMPED)
    return form


def bilayer_energy(
    y,
    faces: FacetSets,
    penalty: Penalty,
    Z,
    mu=None,
    load=None,
    g=None,
    Phi=None,
    consistent: bool = True,
    degree: int | None = None,
) -> Energy:
    """Bending (implicit) + curvature coupling and ½∫μ|Z|² (explicit) − load."""
    mu_ = 1.0 if mu is None else mu
    implicit = bending_energy(y, faces, penalty, mu=mu, g=g, Phi=Phi)
    if load is not None:
        implicit -= ufl.inner(load, y) * faces.dx
    explicit = curvature_coupling(y, faces, Z, mu_, g, Phi, consistent, degree)
    explicit += 0.5 * mu_ * ufl.inner(Z, Z) * faces.dx
    return Energy(implicit=implicit, explicit=explicit)


# -- problem files -----------------------------------------------------------------------------
def _check_symmetric(matrix, key: str) -> None:
    if not (
        isinstance(matrix, list)
        and len(matrix) == 2
        and all(isinstance(r, list) and len(r) == 2 for r in matrix)
    ):
        raise InputError(f"{key} must be a 2×2 matrix [[Z11, Z12], [Z21, Z22]], got {matrix!r}")
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


def spontaneous_curvature(value, tagged, key: str = "model.Z"):
    """Z from a problem file: a number α (Z = αI), a 2×2 matrix of numbers or formulas in x, y,
    or {cell group = number or matrix} (piecewise constant). Numbers are Constants, tables DG0
    functions (:mod:`dgplate.values`).
    """
    mesh = tagged.mesh
    if isinstance(value, int | float) and not isinstance(value, bool):
        return values.constant(mesh, value) * ufl.Identity(2)
    if isinstance(value, list):
        _check_symmetric(value, key)
        return values.array(value, mesh, key)
    if isinstance(value, dict) and value:
        matrices = {}
        for name, entry in value.items():
            sub = f"{key}.{name}"
            if isinstance(entry, int | float) and not isinstance(entry, bool):
                entry = [[float(entry), 0.0], [0.0, float(entry)]]
            _check_symmetric(entry, sub)
            if not all(
                isinstance(v, int | float) and not isinstance(v, bool) for row in entry for v in row
            ):
                raise InputError(
                    f"{sub} must hold numbers (formulas go in a single matrix), got {entry!r}"
                )
            matrices[name] = entry
        return tagged.group_function(matrices, shape=(2, 2), key=key)
    raise InputError(
        f"{key} must be a number, a 2×2 matrix or a table {{group = value}}, got {value!r}"
    )


@dataclass
class BilayerSpec(KirchhoffSpec):
    """[model] of a bilayer plate: the Kirchhoff keys plus the spontaneous curvature."""

    name: str = option("bilayer", "the model")
    Z: float | list | dict = option(
        1.0,
        "spontaneous curvature: α (Z = αI), [[Z11, Z12], [Z12, Z22]] (numbers or formulas in x, y), or {cell group = value}",
    )
    consistent: bool = option(
        True, "include the face terms of the distributional Hessian in the Z coupling"
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        if isinstance(self.Z, list):  # formulas are checked now; the shape when it is built
            expressions.check(self.Z, "model.Z")


def build_bilayer(spec: BilayerSpec, tagged) -> PlateModel:
    from dgplate.measure.analysis import curvature_summary

    faces = facet_sets(tagged, clamped=spec.clamped, crease=spec.crease)
    load = values.vector(spec.load, tagged.mesh, "model.load", 3)
    mu = piecewise_constant(tagged, spec.mu, "model.mu")
    Z = spontaneous_curvature(spec.Z, tagged)
    g, Phi = clamped_data(spec.boundary_data, tagged.mesh)
    penalty = spec.penalty_params
    degree = 3 * spec.degree + 2

    def energy_fn(y) -> Energy:
        return bilayer_energy(y, faces, penalty, Z, mu, load, g, Phi, spec.consistent, degree)

    return PlateModel(faces, spec.degree, energy_fn, measures=[curvature_summary])
