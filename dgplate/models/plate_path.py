"""[path] of the isometry-constrained plates: their equilibria followed in a load factor λ.

``path.method = "arclength"`` replaces the gradient flow by the arclength continuation of the
plate's Lagrangian (:mod:`dgplate.solvers.constrained_path`, docs/path_following.md), from
λ = ``path.lambda_start``: from the start deformation at λ = 0, else from the gradient flow's
minimiser at that λ. λ scales one datum of the energy (``path.parameter``):

- "load": ``model.load``;
- "boundary_data": the clamped data move with λ as with ``model.continuation`` (formulas in
  ``alpha`` are the path, α = λ; otherwise (1 − λ)·id + λ·g); ∂R/∂λ is then a central
  difference with the step :data:`DERIVATIVE_STEP` (the data need not be quadratic in λ);
- "natural_curvature" (a bilayer's default): Z;
- "metric": the target metric, G_λ = I + λ(G − I) (``model.metric`` or ``model.director``);
  the energy is rational in G, so ∂R/∂λ is a central difference as for the data. The flat
  plate at λ = 0 is a critical point of every curving mode at once (any small G_λ − I of
  nonzero Gauss curvature buckles it), so this path starts at ``path.lambda_start`` > 0.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import values
from dgplate.compat import Mesh
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import ArcLengthPath, DataPath
from dgplate.models.metric import check_positive_definite
from dgplate.schema import option
from dgplate.solvers.moving_clamp import AlphaSchedule
from dgplate.solvers.path_spec import PathKeys

#: What a plate's load factor λ can scale (``path.parameter``).
PARAMETERS = ("load", "boundary_data", "natural_curvature", "metric")

#: The values of λ in [−lambda_max, lambda_max] at which formulas in alpha must be finite.
FORMULA_SAMPLES = 41

#: The step h of ∂R/∂λ = (R(λ + h) − R(λ − h))/2h for clamped data moving with λ and for the
#: metric: an error O(h²) ≈ 10⁻⁸ of the derivative, far below what the corrector needs.
DERIVATIVE_STEP = 1e-4


@dataclass
class PlatePathSpec(PathKeys):
    """[path] of a constrained plate: the path's keys and what its load factor scales."""

    parameter: str = option(
        "load",
        "what the load factor λ scales: 'load' (model.load), 'boundary_data' (the clamped data "
        "move with λ as with model.continuation: formulas in alpha, α = λ), "
        "'natural_curvature' (a bilayer's Z) or 'metric' (the target metric: I + λ(G − I))",
        choices=PARAMETERS,
    )
    lambda_start: float = option(
        0.0,
        "the load factor the path starts at: 0 starts from model.start; another value from the "
        "gradient flow's minimiser at that λ (run with [flow]); a 'metric' path needs one > 0",
    )

    def arclength(self, mesh: Mesh) -> ArcLengthPath | None:
        """The path's λ (at 1 until the path starts) and settings; None without arclength.

        Args:
            mesh: the plate's mesh (of the Constant λ).

        Returns:
            The path, or None when ``method`` is not 'arclength'.
        """
        if self.method != "arclength":
            return None
        settings = self.settings()
        if self.parameter in ("boundary_data", "metric"):
            settings = dataclasses.replace(settings, derivative_step=DERIVATIVE_STEP)
        return ArcLengthPath(values.constant(mesh, 1.0), settings, self.lambda_start)

    def scaled(self, datum: Expr, name: str, path: ArcLengthPath | None) -> Expr:
        """``datum`` times λ when the path's parameter is ``name``, else ``datum`` itself.

        Args:
            datum: a datum of the energy.
            name: its name among :data:`PARAMETERS`.
            path: the path (None: no path).

        Returns:
            The datum the energy takes.
        """
        if path is None or self.parameter != name:
            return datum
        scaled: Expr = path.factor * datum
        return scaled

    def scaled_metric(
        self, metric: Expr | None, spec: Any, tagged: TaggedMesh, path: ArcLengthPath | None
    ) -> Expr | None:
        """G_λ = I + λ(G − I) when the path's parameter is 'metric', else ``metric`` itself.

        G_λ is checked positive definite at λ = ±(lambda_max + ds_max), as far as the last
        step of a path can reach (G_λ is affine in λ: so along the whole path).

        Args:
            metric: the target metric G of the plate (None: none).
            spec: the plate's [model] section (its ``target_metric`` and ``metric_key``).
            tagged: the plate's mesh with its cell groups.
            path: the path (None: no path).

        Returns:
            The metric the energy and the constraint take.
        """
        if path is None or self.parameter != "metric" or metric is None:
            return metric
        reach = self.lambda_max + self.ds_max
        ends = (-reach, reach)
        check_positive_definite(spec.target_metric, tagged.mesh, spec.metric_key, tagged, ends)
        identity = ufl.Identity(2)
        scaled: Expr = identity + path.factor * (metric - identity)
        return scaled

    def moving_data(self, path: ArcLengthPath | None) -> DataPath | None:
        """The clamped data's path when they move with λ, else None.

        Its α is λ; its "schedule" holds the values of λ the path may take, at which formulas
        in alpha are checked to be finite (:func:`dgplate.models.base.clamped_data`).

        Args:
            path: the path (None: no path).

        Returns:
            The data's path, or None.
        """
        if path is None or self.parameter != "boundary_data":
            return None
        values = np.linspace(-self.lambda_max, self.lambda_max, FORMULA_SAMPLES)
        return DataPath(path.factor, AlphaSchedule(alphas=tuple(float(v) for v in values)))

    @property
    def moves_data(self) -> bool:
        """Whether the clamped data move with λ (formulas in alpha are allowed)."""
        return self.method == "arclength" and self.parameter == "boundary_data"

    def check(self, spec: Any) -> None:
        """What the path cannot follow, one InputError naming the key.

        Args:
            spec: the plate's [model] section (a :class:`dgplate.models.kirchhoff.KirchhoffSpec`).
        """
        if self.method != "arclength":
            return
        self._check_start(spec)
        if not spec.clamped and any(component != 0 for component in spec.load):
            raise InputError(
                "model.load: not on a free plate with path.method = 'arclength' (the pins "
                "that hold its rigid motions would carry the load)"
            )
        if self.parameter == "boundary_data" and not spec.clamped:
            raise InputError(
                "path.parameter = 'boundary_data' needs model.clamped: the facets whose data move"
            )
        if self.parameter == "boundary_data" and spec.boundary_data == "flat":
            raise InputError(
                "path.parameter = 'boundary_data' needs model.boundary_data = {g = [...]}: "
                "the data the path moves (formulas in alpha, or the data at λ = 1)"
            )
        if self.parameter == "natural_curvature" and not hasattr(spec, "Z"):
            raise InputError(
                f"path.parameter = 'natural_curvature': the {spec.name} model has no Z"
            )
        refused = {
            "model.crease": (spec.crease, "a free crease's flap turns at no energy"),
            "model.obstacle": (spec.obstacle, "its active set is no part of the Lagrangian"),
            "model.self_avoidance": (spec.self_avoidance, "a term that is not an integral"),
            "model.continuation": (spec.continuation, "the path moves the data by λ itself"),
            "model.hessian": (spec.ldg_degree is not None, "the lifted Hessian is not an integral"),
            "model.space": (
                spec.continuous,
                "a continuous y's constraint is singular at the flat plate",
            ),
        }
        for key, (given, why) in refused.items():
            if given:
                raise InputError(f"{key}: not with path.method = 'arclength' ({why})")

    def _check_start(self, spec: Any) -> None:
        """``lambda_start`` inside the path's range; a metric path's > 0, with a metric."""
        if not abs(self.lambda_start) < self.lambda_max:
            raise InputError(
                f"path.lambda_start = {self.lambda_start:g} must lie inside "
                f"(-path.lambda_max, path.lambda_max) = (-{self.lambda_max:g}, {self.lambda_max:g})"
            )
        if self.parameter != "metric":
            return
        if spec.target_metric is None:
            raise InputError(
                "path.parameter = 'metric' needs a target metric (model.metric or model.director)"
            )
        if self.lambda_start <= 0:
            raise InputError(
                "path.parameter = 'metric' needs path.lambda_start > 0: the flat plate at λ = 0 "
                "is critical in every curving mode at once; the path starts from the flow's "
                "minimiser at path.lambda_start"
            )


@dataclass
class BilayerPathSpec(PlatePathSpec):
    """[path] of a bilayer: as a plate's, λ scaling Z by default."""

    parameter: str = option(
        "natural_curvature",
        "what the load factor λ scales: 'natural_curvature' (Z), 'load' (model.load), "
        "'boundary_data' (the clamped data move with λ as with model.continuation: formulas "
        "in alpha, α = λ) or 'metric' (the target metric: I + λ(G − I))",
        choices=PARAMETERS,
    )
