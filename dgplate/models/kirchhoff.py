"""Isometry-constrained Kirchhoff plate: E_h[y] = ½ a_h(y, y) − ∫ f·y (docs/design.md §1–§2).

The bending part is the interior-penalty form of :mod:`dgplate.dg.forms` with rigidity μ (a cell-wise
coefficient) and Nitsche data g, Φ on clamped facets. The isometry constraint is not part of the
energy: the gradient flow imposes its linearisation (:mod:`dgplate.solvers.constraint`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal, Unpack

from mpi4py import MPI

import dolfinx.fem
import ufl
from ufl.core.expr import Expr

from dgplate import expressions, values
from dgplate.compat import Function
from dgplate.dg.energy import Energy
from dgplate.dg.forms import (
    PENALTY_LENGTH_HELP,
    PENALTY_LENGTHS,
    BendingData,
    Coefficient,
    FacetSets,
    Penalty,
    bending_energy,
    cell_measure,
    explicit_quadrature,
    facet_sets,
)
from dgplate.dg.gauss_penalty import gauss_penalty, gauss_penalty_measures
from dgplate.dg.geometry import trace_excess
from dgplate.dg.lifting import HESSIAN_HELP, HESSIANS, ldg_energy
from dgplate.dg.obstacle_penalty import Obstacle
from dgplate.dg.self_avoidance import SelfAvoidance
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh, rectangle
from dgplate.models import starts
from dgplate.models.base import (
    BoundaryData,
    PlateModel,
    clamped_data,
    continuation_path,
    continuation_schedule,
    piecewise_constant,
)
from dgplate.models.director import HELP as director_help
from dgplate.models.director import Director
from dgplate.models.director_smoothness import check_smooth
from dgplate.models.metric import HELP as metric_help
from dgplate.models.metric import MetricSpec, target_metric
from dgplate.models.obstacle import with_obstacle
from dgplate.models.plate_path import PlatePathSpec
from dgplate.models.self_avoidance import with_self_avoidance
from dgplate.schema import Check, option, section
from dgplate.solvers.moving_clamp import AlphaSchedule, MovingClampSpec


def kirchhoff_energy(
    y: Expr,
    facets: FacetSets,
    penalty: Penalty,
    load: Expr | None = None,
    ldg_degree: int | None = None,
    **data: Unpack[BendingData],
) -> Energy:
    """The discrete Kirchhoff energy of the deformation ``y`` (a UFL Function in [DG_k]³).

    ``data``: the rigidity ``mu``, the clamped data ``g``, ``Phi`` and the target ``metric``
    G of the bending energy (:func:`dgplate.dg.forms.bending_energy`).
    ``ldg_degree`` k: the LDG energy with the reconstructed Hessian of degree k
    (:mod:`dgplate.dg.lifting`; ``y`` must then be a Function); None: interior penalty.
    """
    if ldg_degree is not None:
        assert isinstance(y, dolfinx.fem.Function)
        return ldg_energy(y, facets, penalty, ldg_degree, load, **data)
    energy = bending_energy(y, facets, penalty, **data)
    if load is not None:
        energy -= ufl.inner(load, y) * facets.dx
    return Energy(implicit=energy)


#: The spaces of y (``model.space``), the default first.
SPACES = ("dg", "c0")


@dataclass
class KirchhoffSpec:
    """[model] of a single-layer isometric plate."""

    name: str = option("kirchhoff", "the model")
    degree: int = option(2, "polynomial degree k of the DG space (H² dG: k >= 2)", ge=2)
    clamped: list[str] = option([], "facet groups with clamped data (Γ_D); empty: a free plate")
    crease: list[str] = option([], "interior facet groups along which the plate may fold")
    load: list[float | str] = option(
        [0.0, 0.0, 0.0], "body force f: three numbers or formulas in x, y", length=3
    )
    mu: float | dict[str, float] = option(
        1.0, "bending rigidity: a number or {cell group = value}", gt=0, each=Check(gt=0)
    )
    penalty: Penalty = option(Penalty(), "IP penalties γ₀ (h⁻³[y]) and γ₁ (h⁻ᵖ[∇y])")
    penalty_length: str = option("diameter", PENALTY_LENGTH_HELP, choices=PENALTY_LENGTHS)
    hessian: str = option("broken", HESSIAN_HELP, choices=HESSIANS)
    space: str = option(
        "dg",
        "the space of y: 'dg' ([DG_k]³, interior penalty on the jumps of y and of ∇y) or 'c0' (continuous [Q_k]³ or [P_k]³, the C⁰ interior-penalty method: jumps of ∇y only; flow.multiplier_degree = 1 then takes P1 moments on quadrilaterals too; needs flow.adaptive_tau and flow.step_control = 'defect_bound'; its step systems are singular at a flat state and the flow from the flat plate may end at another stationary state than from a start near the shape: docs/accuracy.md)",
        choices=SPACES,
    )
    gauss_penalty: float = option(
        0.0,
        "β: add (β/2)Σ_T h⁻¹∫_T (det II − K det G)² (K: the Gauss curvature of the target metric G; K = 0, G = I without one) against the free-edge layers of the cell-moment constraint (docs/prestrain.md); 0: none",
        ge=0,
    )
    poisson: float = option(
        0.0,
        "Poisson's ratio ν of the bending energy: adds ½∫μ ν/(1−ν) Σ_k tr(G^{-1/2}D²y_k G^{-1/2})² (ν/(1−ν) = λ/(2μ+λ) in Lamé's constants; with Z: tr(G^{-1/2}(II − Z)G^{-1/2})²; docs/prestrain.md); 0: none",
        gt=-1,
        le=0.5,
    )
    continuation: MovingClampSpec | None = option(
        None,
        "move the clamped data along α ∈ (0, 1] (docs/continuation.md): {} none. Path: boundary_data formulas in x, y, alpha, else (1 − α)·id + α·g",
    )
    boundary_data: Literal["flat"] | BoundaryData = option(
        "flat",
        "clamped data: 'flat' (g = (x, y, 0), Φ = [I; 0]) or {g = [3 formulas], Phi = [[..], [..], [..]]} (Φ defaults to ∇g)",
    )
    obstacle: Obstacle | None = option(
        None, "rigid obstacle (penalty (1/2ε)∫(s)₋², docs/obstacle.md): {} none"
    )
    self_avoidance: SelfAvoidance | None = option(
        None,
        "self-avoidance ρ·TP[y] by the tangent-point potential (docs/self_avoidance.md): {} none",
    )
    start: str | dict[str, object] = option("flat", starts.HELP)
    metric: MetricSpec | None = option(None, metric_help)
    director: dict[str, float | str] = option({}, director_help)
    path: PlatePathSpec = section(PlatePathSpec, "path")

    def __post_init__(self) -> None:
        self._start = starts.Start.from_table(self.start)
        table = self.director  # the lce model's own 'director' is a profile name
        self._director = Director.from_table(table) if isinstance(table, dict) and table else None
        self.path.check(self)
        if self.metric is not None and self._director is not None:
            raise InputError(
                "model.director sets the target metric, as model.metric does: give one of them"
            )
        if self.target_metric is not None and self.hessian == "ldg":
            raise InputError(
                f"{self.metric_key} needs model.hessian = 'broken' (the LDG energy has no G)"
            )
        expressions.check(self.load, "model.load")
        data = self.boundary_data
        on_path = self.path.moves_data  # formulas in alpha move with the path's λ
        self._schedule = None
        if not on_path:
            formulas = data if data == "flat" else data.formulas()
            self._schedule = continuation_schedule(self.continuation, self.clamped, formulas)
        moving = {"alpha": 1.0} if self.continuation or on_path else None
        if isinstance(data, BoundaryData):
            expressions.check(data.g, "model.boundary_data.g", moving)
            if data.Phi is not None:
                expressions.check(data.Phi, "model.boundary_data.Phi", moving)

    @property
    def trace_weight(self) -> float:
        """The weight c = ν/(1 − ν) of the energy's trace term (0 without ``poisson``)."""
        return self.poisson / (1 - self.poisson)

    @property
    def schedule(self) -> AlphaSchedule | None:
        """The stages of ``continuation`` (None: the clamped data do not move)."""
        return self._schedule

    @property
    def continuous(self) -> bool:
        """Whether y is continuous (``space = 'c0'``)."""
        return self.space == "c0"

    @property
    def ldg_degree(self) -> int | None:
        """The degree of the liftings with ``hessian = 'ldg'`` (that of y), else None."""
        return self.degree if self.hessian == "ldg" else None

    @property
    def target_metric(self) -> MetricSpec | None:
        """G of ``metric`` or of ``director`` (None: neither, the isometric plate)."""
        return self._director.metric() if self._director is not None else self.metric

    @property
    def metric_key(self) -> str:
        """The key that gives G, as named in messages: ``model.metric`` or ``model.director``."""
        return "model.metric" if self.metric is not None else "model.director"

    @property
    def director_params(self) -> Director | None:
        """The validated ``director`` table (None: none, or the lce model's profile name)."""
        return self._director

    @property
    def start_params(self) -> starts.Start:
        """The validated ``start`` (the flow's first state)."""
        return self._start


def spec_metric(spec: KirchhoffSpec, tagged: TaggedMesh) -> Expr | None:
    """G of a plate's ``model.metric`` or ``model.director`` on its mesh (collective).

    Args:
        spec: the validated ``[model]`` section (kirchhoff, foundation, bilayer, lce).
        tagged: the plate's mesh with its cell groups (for G per group).

    Returns:
        G as a UFL 2×2 expression, checked SPD on the mesh; None without a target metric.
    """
    given = spec.target_metric
    if given is None:
        return None
    director = spec.director_params
    if director is not None and isinstance(director.angle, str):  # before G's formulas, on θ
        expressions.check_finite_on_mesh(director.angle, tagged.mesh, "model.director.angle")
        check_smooth(director, tagged.mesh)
    return target_metric(given, tagged.mesh, spec.metric_key, tagged)


def build_kirchhoff(spec: KirchhoffSpec, tagged: TaggedMesh) -> PlateModel:
    """Facet sets and the energy of a Kirchhoff problem (validates group names).

    Args:
        spec: the validated ``[model]`` section.
        tagged: the mesh with its named cell and facet groups.

    Returns:
        The model: its facet sets, energy, flow settings and figures.
    """
    facets = facet_sets(tagged, spec.clamped, spec.crease, spec.penalty_length)
    arclength = spec.path.arclength(tagged.mesh)
    load = spec.path.scaled(
        values.vector(spec.load, tagged.mesh, "model.load", 3), "load", arclength
    )
    mu = piecewise_constant(tagged, spec.mu, "model.mu")
    path = continuation_path(spec.schedule, tagged.mesh)
    moving = spec.path.moving_data(arclength)
    g, Phi = clamped_data(spec.boundary_data, tagged.mesh, path=path or moving)
    penalty = spec.penalty
    metric = spec.path.scaled_metric(spec_metric(spec, tagged), spec, tagged, arclength)
    c = spec.trace_weight
    data: BendingData = {"mu": (1 + c) * mu if c else mu, "g": g, "Phi": Phi}
    if metric is not None:
        data["metric"] = metric

    beta, degree = spec.gauss_penalty, explicit_quadrature(spec.degree)

    def energy_fn(y: Function) -> Energy:
        energy = kirchhoff_energy(y, facets, penalty, load, spec.ldg_degree, **data)
        if c and metric is not None:
            constant = trace_constant(mu, c, metric, facets, degree)
            energy = replace(energy, implicit=energy.implicit + constant)
        if beta > 0:
            gauss = gauss_penalty(y, facets, beta, degree, metric)
            explicit = gauss if energy.explicit is None else energy.explicit + gauss
            energy = replace(energy, explicit=explicit)
        return energy

    measures = gauss_penalty_measures(facets, beta, degree, metric)
    plate = PlateModel(
        facets,
        spec.degree,
        energy_fn,
        measures,
        path,
        metric=metric,
        arclength=arclength,
        continuous=spec.continuous,
    )
    return with_self_avoidance(with_obstacle(plate, spec.obstacle, g, path), spec.self_avoidance)


def trace_constant(
    mu: Coefficient, c: float, metric: Expr, facets: FacetSets, degree: int | None
) -> ufl.Form:
    """½∫μ c F(G): the part of the trace term c Σₖ tr(AD²yₖA)² that is not c Σₖ |AD²yₖA|².

    On every y with ∇yᵀ∇y = G the trace term equals c(Σₖ|AD²yₖA|² + F(G)), F of G alone
    (:func:`~dgplate.dg.geometry.trace_excess`): so the energy is the metric plate's with
    rigidity (1 + c)μ plus this constant, and the minimisers do not depend on ν. Written so,
    the discrete energy has no term 2c det(AD²yA) that a cell could lower by curving twice
    where the constraint, held in cell means, lets it (docs/prestrain.md).

    Args:
        mu: the rigidity μ.
        c: ν/(1 − ν).
        metric: the target metric G.
        facets: the mesh's facet sets.
        degree: the quadrature degree.

    Returns:
        The constant as a form (no y in it).
    """
    form: ufl.Form = 0.5 * c * mu * trace_excess(metric) * cell_measure(facets.mesh, degree)
    return form


def bnn_plate(comm: MPI.Comm, cells: int) -> PlateModel:
    """The plate of Bonito–Nochetto–Ntogkas (M3AS 2021), Table 1, on cells × cells Q2 cells.

    ω = (0, 4)² clamped flat on x₁ = 0 and x₂ = 0 under f = (0, 0, 2.5·10⁻²); their τ = h is
    :func:`dgplate.reference.bnn.bnn_h`. Tests and benchmarks of the flow's solvers use it.
    """
    tagged = rectangle(comm, [[0, 0], [4, 4]], [cells, cells])
    spec = KirchhoffSpec(degree=2, clamped=["left", "bottom"], load=[0, 0, 2.5e-2])
    return build_kirchhoff(spec, tagged)
