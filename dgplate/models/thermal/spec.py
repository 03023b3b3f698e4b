"""The thermal bilayer's problem-file section :class:`ThermalSpec` and its checks.

``model.name = "thermal"`` (docs/design.md §1, "Thermal bilayer"); the model is
:mod:`dgplate.models.thermal`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

from dgplate import expressions
from dgplate.coupling.heat import HeatSource
from dgplate.coupling.thermal import Schedule
from dgplate.dg.forms import (
    PENALTY_LENGTH_HELP,
    Penalty,
    check_penalty_length,
)
from dgplate.dg.self_avoidance import SelfAvoidance
from dgplate.errors import InputError
from dgplate.schema import option


def is_plain_number(value: Any) -> bool:
    """A number typed as one (an int or a float, not a bool, not a formula)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def _names(value: Any, key: str) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise InputError(f"{key} must be a list of group names, got {value!r}")
    return value


def _check_table(table: dict[str, Any], key: str, positive: bool) -> None:
    for name, value in table.items():
        if not is_plain_number(value) or (positive and not value > 0):
            what = "a number > 0" if positive else "a number"
            raise InputError(f"{key}.{name} must be {what}, got {value!r}")


def _check_penalty(penalty: dict[str, Any], aspect: float | str) -> None:
    unknown = set(penalty) - {"gamma0", "gamma1", "gradient_power"}
    if unknown:
        raise InputError(
            f"unknown key model.penalty.{sorted(unknown)[0]} (known: gamma0, gamma1, gradient_power)"
        )
    _check_table(penalty, "model.penalty", positive=True)
    Penalty(**{k: float(v) for k, v in penalty.items()})  # the ranges
    if isinstance(aspect, str) and aspect != "mesh":
        raise InputError(f"model.penalty_aspect must be a number >= 1 or 'mesh', got {aspect!r}")
    if not isinstance(aspect, str) and not aspect >= 1:
        raise InputError(f"model.penalty_aspect must be >= 1, got {aspect!r}")


def _check_hinges(hinges: dict[str, Any]) -> None:
    for name, faces in hinges.items():
        if not (
            isinstance(faces, list) and len(faces) == 2 and all(isinstance(f, str) for f in faces)
        ):
            raise InputError(
                f"model.hinges.{name} must be [inner panel, outer panel], got {faces!r}"
            )


def _check_closure(closure: dict[str, Any]) -> None:
    if not closure:
        return
    if set(closure) != {"edge", "panel", "target"}:
        raise InputError(
            f"model.closure must be a table {{edge, panel, target}}, got keys {sorted(closure)}"
        )
    if not isinstance(closure["edge"], str) or not isinstance(closure["panel"], str):
        raise InputError("model.closure.edge and model.closure.panel must be group names")
    target = closure["target"]
    if not isinstance(target, list) or len(target) != 3:
        raise InputError(f"model.closure.target must be 3 numbers or formulas, got {target!r}")
    expressions.check(target, "model.closure.target")


def _check_alpha(spec: ThermalSpec) -> None:
    if isinstance(spec.alpha, str):
        if spec.alpha != "calibrate":
            raise InputError(
                f"model.alpha must be a number, a table or 'calibrate', got {spec.alpha!r}"
            )
        if not spec.hinges or not spec.holds:
            raise InputError(
                "model.alpha = 'calibrate' needs model.hinges (where α acts) and model.holds "
                "(it calibrates at the hinges' temperature at the first hold)"
            )
        if not 0 < abs(spec.fold_angle) < 180:
            raise InputError(f"model.fold_angle must be in (0°, 180°), got {spec.fold_angle!r}")
    elif isinstance(spec.alpha, dict):
        if not spec.alpha:
            raise InputError("model.alpha must not be an empty table")
        _check_table(spec.alpha, "model.alpha", positive=False)


def _check_mu(mu: float | dict[str, Any]) -> None:
    if isinstance(mu, dict):
        if not mu:
            raise InputError("model.mu must not be an empty table")
        _check_table(mu, "model.mu", positive=True)
    elif not mu > 0:
        raise InputError(f"model.mu must be > 0, got {mu!r}")


@dataclass
class ThermalSpec:
    """[model] of a heat-coupled thermal bilayer (``name = "thermal"``)."""

    name: str = option("thermal", "the model")
    degree: int = option(2, "polynomial degree k >= 2 of the DG space of y")
    mu: float | dict[str, Any] = option(
        1.0, "bending rigidity μ: a number or {cell group = value} (every panel and hinge)"
    )
    alpha: float | dict[str, Any] | str = option(
        1.0,
        "α in Z = −αθI (curvature per unit temperature): a number, {cell group = value} (0 on unlisted groups: passive panels), or 'calibrate': on the hinges, α such that one hinge strip with this mesh's hinge cells folds by fold_angle at the hinges' mean temperature at the first hold",
    )
    fold_angle: float = option(90.0, "alpha = 'calibrate': the target fold angle in degrees")
    hinges: dict[str, Any] = option(
        {},
        "{hinge cell group = [inner panel, outer panel]}: fold angles per hinge in summary.json and history.csv (degrees, positive the way a heated hinge folds)",
    )
    anchor: str = option(
        "", "a panel held in its reference place by a weak spring ½k∫|y − (x, y, 0)|² ('': none)"
    )
    anchor_stiffness: float = option(1000.0, "the anchor's spring constant k > 0")
    clamped: list[str] = option([], "facet groups with flat clamped data (Nitsche); usually none")
    penalty: dict[str, Any] = option(
        {"gamma0": 5000.0, "gamma1": 1100.0},
        "IP penalties γ₀ (h⁻³[y]) and γ₁ (h⁻ᵖ[∇y]), and gradient_power p (default 1)",
    )
    penalty_aspect: float | str = option(
        1.0,
        "thin cells: γ₀ scaled by A³ and γ₁ by A; a number A >= 1, or 'mesh': A = the largest ratio of a cell's longest to its shortest edge (hinge strips of thin cells)",
    )
    penalty_length: str = option("diameter", PENALTY_LENGTH_HELP)
    kappa: float = option(1.0, "heat diffusivity κ > 0 (θ_t − κΔθ = s, insulated edges)")
    source: list[Any] = option(
        [[0.0, 1.0]],
        "heat source schedule [[t₀, s₀], [t₁, s₁], …]: s = sᵢ for tᵢ ≤ t < tᵢ₊₁ (0 before t₀)",
    )
    source_regions: list[str] = option([], "cell groups the source heats ([]: the whole plate)")
    theta0: float = option(0.0, "initial temperature θ(0)")
    heat_degree: int = option(1, "degree of the continuous Lagrange space of θ (1 or 2)")
    heat_step: float = option(0.1, "heat time step Δt > 0 (implicit Euler)")
    end_time: float = option(1.0, "final time")
    flow_steps: int = option(
        40, "flow step budget after each heat step (the flow stops earlier at flow.tol)"
    )
    holds: list[float] = option(
        [],
        "times at which the plate is relaxed at fixed θ before the next heat step, increasing, at most end_time (e.g. the source's switch and the end)",
    )
    hold_steps: int = option(300, "flow step budget of a hold")
    hold_tau: float = option(0.0, "τ of the holds (0: the flow's τ)")
    closure: dict[str, Any] = option(
        {},
        "{edge = facet group, panel = cell group, target = [3 numbers or formulas in x, y]}: closure_gap = the largest distance of the edge's nodes from target(x, y), in the panel's frame",
    )
    edges: dict[str, Any] = option(
        {},
        "{facet group = panel}: <group>_height and <group>_distance, the mean height above the panel and the mean in-plane distance from its centre of the group's nodes, in the panel's frame",
    )
    self_avoidance: dict[str, float] = option(
        {},
        "self-avoidance ρ·TP[y] by the tangent-point potential, explicit in every relaxation step (docs/self_avoidance.md): {} none, or {rho = ρ >= 0, q = exponent > 4 (4.5), theta = cluster-tree admissibility (0.5; 0 = exact sums), quadrature_degree = 2, max_redo = halvings of τ per step (8), approach = redo a step when the least distance falls below this fraction (0.5)}",
    )

    def __post_init__(self) -> None:
        if self.degree < 2:
            raise InputError(f"model.degree must be >= 2 for the H² dG method, got {self.degree}")
        _check_mu(self.mu)
        _check_alpha(self)
        _check_hinges(self.hinges)
        _check_penalty(self.penalty, self.penalty_aspect)
        check_penalty_length(self.penalty_length, "model.penalty_length")
        SelfAvoidance.from_table(self.self_avoidance)  # validated (and warned about) once
        _check_closure(self.closure)
        for key in ("clamped", "source_regions"):
            _names(getattr(self, key), f"model.{key}")
        for group, panel in self.edges.items():
            if not isinstance(panel, str):
                raise InputError(f"model.edges.{group} must be a panel name, got {panel!r}")
        self._check_heat()

    def _check_heat(self) -> None:
        if self.heat_degree not in (1, 2):
            raise InputError(f"model.heat_degree must be 1 or 2, got {self.heat_degree!r}")
        for key in ("kappa", "heat_step", "anchor_stiffness"):
            if not getattr(self, key) > 0:
                raise InputError(f"model.{key} must be > 0, got {getattr(self, key)!r}")
        if self.hold_tau < 0:
            raise InputError(f"model.hold_tau must be >= 0 (0: the flow's τ), got {self.hold_tau}")
        try:
            self.heat_source()
        except InputError as err:
            raise InputError(f"model.source: {err}") from None
        try:
            self.schedule()
        except InputError as err:
            raise InputError(f"model.{err}") from None

    def heat_source(self) -> HeatSource:
        """The validated source schedule."""
        if not isinstance(self.source, list) or not all(
            isinstance(p, list) and len(p) == 2 for p in self.source
        ):
            raise InputError(f"source must be a list of [time, value] pairs, got {self.source!r}")
        regions = tuple(self.source_regions) or None
        return HeatSource(tuple((p[0], p[1]) for p in self.source), regions)

    def schedule(self) -> Schedule:
        """Heat steps, flow budgets and holds."""
        if not all(is_plain_number(t) for t in self.holds):
            raise InputError(f"holds must be a list of times, got {self.holds!r}")
        hold_tau = float(self.hold_tau) if self.hold_tau > 0 else None
        return Schedule(
            self.end_time, self.flow_steps, tuple(self.holds), self.hold_steps, hold_tau
        )

    @property
    def self_avoidance_params(self) -> SelfAvoidance | None:
        """The validated ``self_avoidance`` table (None: none).

        Parsed again on each call rather than kept in an attribute: the spec's ``__dict__`` is
        its problem-file keys. The warning of q <= 4 was given by the constructor.
        """
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return SelfAvoidance.from_table(self.self_avoidance)

    @property
    def penalty_params(self) -> Penalty:
        """The penalties before the thin-cell scaling."""
        return Penalty(**{k: float(v) for k, v in self.penalty.items()})


# -- the model ---------------------------------------------------------------------------------
