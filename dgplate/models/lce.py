"""Liquid-crystal-elastomer plates (docs/design.md §1, docs/lce.md).

A thin nematic elastomer sheet whose director turns through the thickness (a twist) or tilts
from in-plane to normal (a splay) wants to bend when it is actuated. The plate limit of
Agostiniani & DeSimone (2017) is the bending energy

    I_lce[y] = ½∫ |II(y) − A|²     subject to   ∇yᵀ∇y = I₂,

A = γ R(θ) A₀ R(θ)ᵀ,  A₀ = diag(−1, 1) (twist) or diag(−1, 0) (splay),  R(θ) the rotation by
the director angle θ(x) (a number or a formula in x, y). It is the bilayer energy with the
spontaneous curvature Z = A, so this module only builds A and hands it to
:func:`dgplate.models.bilayer.bilayer_energy`.

A has the eigenvalues −γ along d = (cos θ, sin θ) and a₂γ (a₂ = 1 twist, 0 splay) along d⊥,
whatever θ is; hence the pointwise lower bound ½|II − A|² ≥ ½ (smaller eigenvalue)², i.e.
``lower_bound`` = ½γ²|ω| (twist) or 0 (splay) in ``summary.json``; for constant θ a cylinder
attains it (docs/lce.md).

``model.metric`` adds an in-plane target metric G, the constraint ∇yᵀ∇y = G and the energy
½∫|G^{-1/2}(II − A)G^{-1/2}|² (:mod:`dgplate.models.bilayer`). The model's own
``model.director`` is the profile through the thickness, so the G of an in-plane director
field (:mod:`dgplate.models.director`) is given here by its entries in ``model.metric``. The
bound ``lower_bound`` is that of the isometric plate: with a G it is left out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import dolfinx.fem
import ufl
from ufl.core.expr import Expr

from dgplate import expressions, values
from dgplate.compat import Function
from dgplate.dg.energy import Energy
from dgplate.dg.forms import explicit_quadrature, facet_sets, integral
from dgplate.dg.gauss_penalty import gauss_penalty_measures
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import PlateModel, clamped_data, continuation_path, piecewise_constant
from dgplate.models.bilayer import bilayer_energy
from dgplate.models.kirchhoff import KirchhoffSpec, spec_metric
from dgplate.models.metric import HELP as metric_help
from dgplate.models.metric import MetricSpec
from dgplate.models.obstacle import with_obstacle
from dgplate.models.self_avoidance import with_self_avoidance
from dgplate.schema import option

__all__ = ["DIRECTORS", "LCESpec", "build_lce", "director_curvature"]

#: The second eigenvalue of A₀ = diag(−1, a₂) per director profile through the thickness.
DIRECTORS = {"twist": 1.0, "splay": 0.0}


def director_curvature(gamma: Expr, theta: Expr | float, second: Expr | float) -> Expr:
    """A = γ R(θ) diag(−1, a₂) R(θ)ᵀ = γ(−d⊗d + a₂ d⊥⊗d⊥), d = (cos θ, sin θ), d⊥ = (−sin θ, cos θ)."""
    d = ufl.as_vector([ufl.cos(theta), ufl.sin(theta)])
    d_perp = ufl.as_vector([-ufl.sin(theta), ufl.cos(theta)])
    A: Expr = gamma * (-ufl.outer(d, d) + second * ufl.outer(d_perp, d_perp))
    return A


@dataclass
class LCESpec(KirchhoffSpec):
    """[model] of a liquid-crystal-elastomer plate: the Kirchhoff keys plus the director."""

    name: str = option("lce", "the model")
    director: str = option(  # type: ignore[assignment]  # the profile, not the metric's table
        "twist",
        "director profile through the thickness: 'twist' (A₀ = diag(−1, 1)) or 'splay' (A₀ = diag(−1, 0))",
        choices=tuple(sorted(DIRECTORS)),
    )
    metric: MetricSpec | None = option(
        None,
        f"{metric_help}; an in-plane director's G goes here by its entries (model.director is the profile through the thickness)",
    )
    gamma: float = option(
        1.0, "actuation strength γ (a curvature; γ < 0 bends the other way): A = γ R(θ) A₀ R(θ)ᵀ"
    )
    theta: float | str = option(
        0.0,
        "director angle θ in radians from the x axis: a number or a formula in x, y (or r, theta); the eigenvalue −γ of A is along (cos θ, sin θ)",
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        expressions.check(self.theta, "model.theta")


def build_lce(spec: LCESpec, tagged: TaggedMesh) -> PlateModel:
    """Facet sets, the energy (the bilayer energy with Z = A) and the figures of an LCE plate.

    Moving clamped data (``continuation``), an ``obstacle`` and self-avoidance act as on the
    Kirchhoff plate and the bilayer.

    Args:
        spec: the validated ``[model]`` section.
        tagged: the mesh with its named cell and facet groups.

    Returns:
        The model: its facet sets, energy, flow settings and curvature figures.
    """
    from dgplate.measure.analysis import curvature_summary

    mesh = tagged.mesh
    facets = facet_sets(tagged, spec.clamped, spec.crease, spec.penalty_length)
    load = values.vector(spec.load, mesh, "model.load", 3)
    mu = piecewise_constant(tagged, spec.mu, "model.mu")
    path = continuation_path(spec.schedule, mesh)
    g, Phi = clamped_data(spec.boundary_data, mesh, path=path)
    theta = values.array(spec.theta, mesh, "model.theta")
    second = values.constant(mesh, DIRECTORS[spec.director])
    gamma = values.constant(mesh, spec.gamma)
    A = director_curvature(gamma, theta, second)
    penalty = spec.penalty
    degree = explicit_quadrature(spec.degree)
    metric = spec_metric(spec, tagged)

    def energy_fn(y: Function) -> Energy:
        return bilayer_energy(
            y,
            facets,
            penalty,
            A,
            mu,
            load,
            g,
            Phi,
            degree=degree,
            gauss=spec.gauss_penalty,
            ldg_degree=spec.ldg_degree,
            metric=metric,
            trace_weight=spec.trace_weight,
        )

    def lower_bound(y: Function) -> dict[str, Any]:
        """½∫μ (γa₂)²: the isometric energy is never below it (a₂ = 1 twist, 0 splay)."""
        density = 0.5 * mu * (gamma * second) ** 2
        return {"lower_bound": integral(dolfinx.fem.form(density * facets.dx), mesh.comm)}

    plate = PlateModel(
        facets,
        spec.degree,
        energy_fn,
        measures=[
            curvature_summary,
            *([lower_bound] if metric is None and not spec.poisson else []),  # G = I, ν = 0
            *gauss_penalty_measures(facets, spec.gauss_penalty, degree, metric),
        ],
        continuation=path,
        metric=metric,
        continuous=spec.continuous,
    )
    return with_self_avoidance(with_obstacle(plate, spec.obstacle, g, path), spec.self_avoidance)
