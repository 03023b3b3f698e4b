"""The Gauss-curvature penalty (β/2) Σ_T h_T⁻¹ ∫_T (det II(y) − K det G)² (``model.gauss_penalty``).

On a surface y with ∇yᵀ∇y = G, det II = K det G, K the Gaussian curvature of G alone
(Theorema egregium; Brioschi's formula, :func:`dgplate.dg.geometry.metric_gauss_curvature`).
Without a target metric G = I and K = 0: every isometry of a flat plate is developable. So the
term vanishes on the exact solutions: it is consistent. It prices the states that a constraint
imposed on cell moments leaves free: a one-cell layer along a free edge whose curvature is
doubly curved or flattened, held in the gradient jumps between cells (docs/bilayer.md,
docs/prestrain.md). The weight h⁻¹ makes the price grow under refinement.

A G whose curvature is concentrated (the tip of a director's +1 defect, where the Brioschi K
is not defined) has no smooth K det G to take: the term is for G of bounded curvature.
"""

from __future__ import annotations

from collections.abc import Callable

import dolfinx.fem
import ufl
from ufl.core.expr import Expr

from dgplate import values
from dgplate.compat import Function
from dgplate.dg.forms import FacetSets, cell_measure, integral
from dgplate.dg.geometry import metric_gauss_curvature, second_fundamental_form


def gauss_penalty(
    y: Expr,
    facets: FacetSets,
    beta: float,
    degree: int | None = None,
    metric: Expr | None = None,
) -> ufl.Form:
    """(β/2) Σ_T h_T⁻¹ ∫_T (det II(y) − K det G)², II the broken second fundamental form.

    Args:
        y: the deformation (a UFL Function in [DG_k]³).
        facets: the mesh's facet sets (their cell size h).
        beta: β ≥ 0, the weight.
        degree: the quadrature degree of the integral (None: FFCx's estimate).
        metric: the target metric G (None: I, the isometric plate, K det G = 0).

    Returns:
        The term as a UFL functional of y.
    """
    II = second_fundamental_form(y)
    defect = II[0, 0] * II[1, 1] - II[0, 1] * II[1, 0]
    if metric is not None:
        defect -= metric_gauss_curvature(metric) * ufl.det(metric)
    weight = values.constant(facets.mesh, beta) / facets.h
    form: ufl.Form = 0.5 * weight * defect**2 * cell_measure(facets.mesh, degree)
    return form


def gauss_penalty_measures(
    facets: FacetSets, beta: float, degree: int | None = None, metric: Expr | None = None
) -> list[Callable[[Function], dict[str, float]]]:
    """The measure for ``summary.json`` of the penalty's value at the final y (a part of E_h).

    Args:
        facets: the mesh's facet sets.
        beta: β ≥ 0, the weight (0: no penalty, no measure).
        degree: the quadrature degree, as for :func:`gauss_penalty`.
        metric: the target metric G (None: I).

    Returns:
        [y ↦ ``{"gauss_penalty_energy": value}``] (collective), or [] when β = 0.
    """

    def measure(y: Function) -> dict[str, float]:
        form = dolfinx.fem.form(gauss_penalty(y, facets, beta, degree, metric))
        return {"gauss_penalty_energy": integral(form, facets.mesh.comm)}

    return [measure] if beta > 0 else []
