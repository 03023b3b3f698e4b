"""[path] of the isometry-constrained plates: their equilibria followed in a load factor λ.

``path.method = "arclength"`` replaces the gradient flow by the arclength continuation of the
plate's Lagrangian (:mod:`dgplate.solvers.constrained_path`, docs/path_following.md), from
λ = 0. λ multiplies one datum of the energy (``path.parameter``):

- "load": ``model.load``;
- "boundary_data": the clamped data move with λ as with ``model.continuation`` (formulas in
  ``alpha`` are the path, α = λ; otherwise (1 − λ)·id + λ·g); ∂R/∂λ is then a central
  difference with the step :data:`BOUNDARY_DATA_STEP` (the data need not be quadratic in λ);
- "natural_curvature" (a bilayer's default): Z.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from ufl.core.expr import Expr

from dgplate import values
from dgplate.compat import Mesh
from dgplate.errors import InputError
from dgplate.models.base import ArcLengthPath, DataPath
from dgplate.schema import option
from dgplate.solvers.moving_clamp import AlphaSchedule
from dgplate.solvers.path_spec import PathKeys

#: What a plate's load factor λ can scale (``path.parameter``).
PARAMETERS = ("load", "boundary_data", "natural_curvature")

#: The values of λ in [−lambda_max, lambda_max] at which formulas in alpha must be finite.
FORMULA_SAMPLES = 41

#: The step h of ∂R/∂λ = (R(λ + h) − R(λ − h))/2h for clamped data moving with λ: an error
#: O(h²) ≈ 10⁻⁸ of the derivative, far below what the corrector needs.
BOUNDARY_DATA_STEP = 1e-4


@dataclass
class PlatePathSpec(PathKeys):
    """[path] of a constrained plate: the path's keys and what its load factor scales."""

    parameter: str = option(
        "load",
        "what the load factor λ scales: 'load' (model.load), 'boundary_data' (the clamped data "
        "move with λ as with model.continuation: formulas in alpha, α = λ) or "
        "'natural_curvature' (a bilayer's Z)",
        choices=PARAMETERS,
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
        if self.parameter == "boundary_data":
            settings = dataclasses.replace(settings, derivative_step=BOUNDARY_DATA_STEP)
        return ArcLengthPath(values.constant(mesh, 1.0), settings)

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
        }
        for key, (given, why) in refused.items():
            if given:
                raise InputError(f"{key}: not with path.method = 'arclength' ({why})")


@dataclass
class BilayerPathSpec(PlatePathSpec):
    """[path] of a bilayer: as a plate's, λ scaling Z by default."""

    parameter: str = option(
        "natural_curvature",
        "what the load factor λ scales: 'natural_curvature' (Z), 'load' (model.load) or "
        "'boundary_data' (the clamped data move with λ as with model.continuation: formulas "
        "in alpha, α = λ)",
        choices=PARAMETERS,
    )
