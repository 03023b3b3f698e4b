"""Isometry-constrained Kirchhoff plate: E_h[y] = ½ a_h(y, y) − ∫ f·y (docs/design.md §1–§2).

The bending part is the interior-penalty form of :mod:`dgplate.dg.forms` with rigidity μ (a cell-wise
coefficient) and Nitsche data g, Φ on clamped facets. The isometry constraint is not part of the
energy: the gradient flow imposes its linearisation (:mod:`dgplate.solvers.constraint`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Unpack

from mpi4py import MPI

import dolfinx.fem
import ufl
from ufl.core.expr import Expr

from dgplate import expressions, values
from dgplate.compat import Function
from dgplate.dg.energy import Energy
from dgplate.dg.forms import (
    PENALTY_LENGTH_HELP,
    BendingData,
    FacetSets,
    Penalty,
    bending_energy,
    check_penalty_length,
    facet_sets,
)
from dgplate.dg.lifting import HESSIAN_HELP, check_hessian, ldg_energy
from dgplate.dg.obstacle import Obstacle
from dgplate.dg.self_avoidance import SelfAvoidance
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh, rectangle
from dgplate.models import starts
from dgplate.models.base import (
    PlateModel,
    clamped_data,
    continuation_path,
    continuation_schedule,
    piecewise_constant,
)
from dgplate.models.obstacle import with_obstacle
from dgplate.models.self_avoidance import with_self_avoidance
from dgplate.schema import option
from dgplate.solvers.continuation import AlphaSchedule


def kirchhoff_energy(
    y: Expr,
    facets: FacetSets,
    penalty: Penalty,
    load: Expr | None = None,
    ldg_degree: int | None = None,
    **data: Unpack[BendingData],
) -> Energy:
    """The discrete Kirchhoff energy of the deformation ``y`` (a UFL Function in [DG_k]³).

    ``data``: the rigidity ``mu`` and the clamped data ``g``, ``Phi`` of the bending energy.
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


@dataclass
class KirchhoffSpec:
    """[model] of a single-layer isometric plate."""

    name: str = option("kirchhoff", "the model")
    degree: int = option(2, "polynomial degree k >= 2 of the DG space")
    clamped: list[str] = option([], "facet groups with clamped data (Γ_D); empty: a free plate")
    crease: list[str] = option([], "interior facet groups along which the plate may fold")
    load: list[float | str] = option(
        [0.0, 0.0, 0.0], "body force f: three numbers or formulas in x, y"
    )
    mu: float | dict[str, float] = option(1.0, "bending rigidity: a number or {cell group = value}")
    penalty: dict[str, float] = option(
        {"gamma0": 5000.0, "gamma1": 1100.0},
        "IP penalties γ₀ (h⁻³[y]) and γ₁ (h⁻ᵖ[∇y]); gradient_power p (default 1, at most 3) over-penalises gradient jumps",
    )
    penalty_length: str = option("diameter", PENALTY_LENGTH_HELP)
    hessian: str = option("broken", HESSIAN_HELP)
    continuation: dict[str, object] = option(
        {},
        "move the clamped data along α ∈ (0, 1]: {steps = N} (α = 1/N, …, 1), {alpha = [increasing values]} or {rate = δα} (α grows by δα per flow step); stage_steps = flow steps per stage (200). Path: boundary_data formulas in x, y, alpha, else (1 − α)·id + α·g",
    )
    boundary_data: str | dict[str, object] = option(
        "flat",
        "clamped data: 'flat' (g = (x, y, 0), Φ = [I; 0]) or {g = [3 formulas], Phi = [[..], [..], [..]]} (Φ defaults to ∇g)",
    )
    obstacle: dict[str, object] = option(
        {},
        "rigid obstacle (penalty (1/2ε)∫(s)₋², docs/obstacle.md): {} none, or {type = 'above'|'below' (y₃ ≥ ψ | y₃ ≤ ψ), psi = number or formula in x, y (required)}, {type = 'plane', normal = [3], point = [3]} (n·(y − p) ≥ 0), {type = 'sphere', center = [3], radius = R, side = 'outside'|'inside'}; each with epsilon = ε > 0 (default 1e-4) and treatment = 'splitting' (default; the convex part implicit, the concave part explicit) or 'active_set' (the implicit part on the last contact set only)",
    )

    self_avoidance: dict[str, float] = option(
        {},
        "self-avoidance ρ·TP[y] by the tangent-point potential (docs/self_avoidance.md): {} none, or {rho = ρ >= 0, q = exponent > 4 (4.5), theta = cluster-tree admissibility (0.5; 0 = exact sums), quadrature_degree = 2, max_redo = halvings of τ per step (8), approach = redo a step when the least distance falls below this fraction (0.5)}",
    )
    start: str | dict[str, object] = option("flat", starts.HELP)

    def __post_init__(self) -> None:
        if self.degree < 2:
            raise InputError(f"model.degree must be >= 2 for the H² dG method, got {self.degree}")
        for key in ("clamped", "crease"):
            names = getattr(self, key)
            if not all(isinstance(n, str) for n in names):
                raise InputError(f"model.{key} must be a list of facet group names, got {names!r}")
        if isinstance(self.boundary_data, str) and self.boundary_data != "flat":
            raise InputError(
                f"model.boundary_data must be 'flat' or a table {{g, Phi}}, got {self.boundary_data!r}"
            )
        self._penalty = Penalty.from_table(self.penalty, "model.penalty")
        check_penalty_length(self.penalty_length, "model.penalty_length")
        check_hessian(self.hessian)
        self._obstacle = Obstacle.from_table(self.obstacle, "model.obstacle")
        self._self_avoidance = SelfAvoidance.from_table(self.self_avoidance)
        self._start = starts.Start.from_table(self.start)
        self._check_data()

    def _check_data(self) -> None:
        """The load and the clamped data: numbers and valid formulas (shapes of the load)."""
        if not isinstance(self.load, list) or len(self.load) != 3:
            raise InputError(
                f"model.load must be a list of 3 numbers or formulas, got {self.load!r}"
            )
        expressions.check(self.load, "model.load")
        self._schedule = continuation_schedule(self.continuation, self.clamped, self.boundary_data)
        moving = {"alpha": 1.0} if self.continuation else None
        if isinstance(self.boundary_data, dict):
            for name in ("g", "Phi"):
                if name in self.boundary_data:
                    expressions.check(
                        self.boundary_data[name], f"model.boundary_data.{name}", moving
                    )

    @property
    def schedule(self) -> AlphaSchedule | None:
        """The validated ``continuation`` (None: the clamped data do not move)."""
        return self._schedule

    @property
    def penalty_params(self) -> Penalty:
        """The validated ``penalty`` table (missing keys: :class:`Penalty`'s defaults)."""
        return self._penalty

    @property
    def ldg_degree(self) -> int | None:
        """The degree of the liftings with ``hessian = 'ldg'`` (that of y), else None."""
        return self.degree if self.hessian == "ldg" else None

    @property
    def obstacle_params(self) -> Obstacle | None:
        """The validated ``obstacle`` table (None: no obstacle)."""
        return self._obstacle

    @property
    def start_params(self) -> starts.Start:
        """The validated ``start`` (the flow's first state)."""
        return self._start

    @property
    def self_avoidance_params(self) -> SelfAvoidance | None:
        """The validated ``self_avoidance`` table (None: none)."""
        return self._self_avoidance


def build_kirchhoff(spec: KirchhoffSpec, tagged: TaggedMesh) -> PlateModel:
    """Facet sets and the energy of a Kirchhoff problem (validates group names)."""
    facets = facet_sets(tagged, spec.clamped, spec.crease, spec.penalty_length)
    load = values.vector(spec.load, tagged.mesh, "model.load", 3)
    mu = piecewise_constant(tagged, spec.mu, "model.mu")
    path = continuation_path(spec.schedule, tagged.mesh)
    g, Phi = clamped_data(spec.boundary_data, tagged.mesh, path=path)
    penalty = spec.penalty_params

    def energy_fn(y: Function) -> Energy:
        return kirchhoff_energy(y, facets, penalty, load, spec.ldg_degree, mu=mu, g=g, Phi=Phi)

    plate = PlateModel(facets, spec.degree, energy_fn, continuation=path)
    return with_self_avoidance(
        with_obstacle(plate, spec.obstacle_params, g, path), spec.self_avoidance_params
    )


def bnn_plate(comm: MPI.Comm, cells: int) -> PlateModel:
    """The plate of Bonito–Nochetto–Ntogkas (M3AS 2021), Table 1, on cells × cells Q2 cells.

    ω = (0, 4)² clamped flat on x₁ = 0 and x₂ = 0 under f = (0, 0, 2.5·10⁻²); their τ = h is
    :func:`dgplate.reference.bnn.bnn_h`. Tests and benchmarks of the flow's solvers use it.
    """
    tagged = rectangle(comm, [[0, 0], [4, 4]], [cells, cells])
    spec = KirchhoffSpec(degree=2, clamped=["left", "bottom"], load=[0, 0, 2.5e-2])
    return build_kirchhoff(spec, tagged)
