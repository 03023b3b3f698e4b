"""The thermal bilayer's problem-file sections: [model] (:class:`ThermalSpec`) and [schedule].

``model.name = "thermal"`` (docs/design.md §1, "Thermal bilayer"); the model is
:mod:`dgplate.models.thermal`. [schedule] (:class:`ScheduleSpec`) holds the settings of its
driver: the heat steps and the holds.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from itertools import pairwise
from typing import ClassVar, Literal

from dgplate import expressions
from dgplate.coupling.heat import HeatSource
from dgplate.coupling.thermal_driver import Schedule
from dgplate.dg.forms import PENALTY_LENGTH_HELP, PENALTY_LENGTHS, Penalty
from dgplate.dg.self_avoidance import SelfAvoidance
from dgplate.errors import InputError
from dgplate.schema import REQUIRED, Check, option, section


def is_plain_number(value: object) -> bool:
    """A number typed as one (an int or a float, not a bool, not a formula)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


@dataclass
class ScheduleSpec:
    """[schedule]: the heat steps and holds of the thermal model's driver."""

    heat_step: float = option(0.1, "heat time step Δt (implicit Euler)", gt=0)
    end_time: float = option(1.0, "final time", gt=0)
    flow_steps: int = option(
        40, "flow step budget after each heat step (the flow stops earlier at flow.tol)", ge=1
    )
    holds: list[float] = option(
        [],
        "times at which the plate is relaxed at fixed θ before the next heat step, increasing, at most end_time (e.g. the source's switch and the end)",
        each=Check(ge=0),
    )
    hold_steps: int = option(300, "flow step budget of a hold", ge=1)
    hold_tau: float = option(
        0.0, "τ of the holds, their first τ with adaptive τ (0: the flow's τ)", ge=0
    )

    def __post_init__(self) -> None:
        """The holds increase and end by end_time."""
        holds = self.holds
        if not (all(b > a for a, b in pairwise(holds)) and all(t <= self.end_time for t in holds)):
            raise InputError(
                f"schedule.holds must increase strictly in [0, end_time = {self.end_time:g}], "
                f"got {holds}"
            )

    def schedule(self) -> Schedule:
        """Heat steps, flow budgets and holds, as the driver takes them."""
        hold_tau = self.hold_tau if self.hold_tau > 0 else None
        return Schedule(
            self.end_time, self.flow_steps, tuple(self.holds), self.hold_steps, hold_tau
        )


@dataclass(frozen=True)
class Closure:
    """``model.closure``: where the closure gap of a folded box is measured."""

    edge: str = option(REQUIRED, "the facet group of the closing edge")
    panel: str = option(REQUIRED, "the cell group in whose frame the target is given")
    target: list[float | str] = option(
        REQUIRED, "where the edge should lie: 3 numbers or formulas in x, y", length=3
    )


@dataclass
class ThermalSpec:
    """[model] of a heat-coupled thermal bilayer (``name = "thermal"``)."""

    #: The keys that moved to [schedule].
    MOVED: ClassVar[dict[str, str]] = {f.name: f"schedule.{f.name}" for f in fields(ScheduleSpec)}

    name: str = option("thermal", "the model")
    degree: int = option(2, "polynomial degree k of the DG space of y (H² dG: k >= 2)", ge=2)
    mu: float | dict[str, float] = option(
        1.0,
        "bending rigidity μ: a number or {cell group = value} (every panel and hinge)",
        gt=0,
        each=Check(gt=0),
    )
    alpha: float | dict[str, float] | Literal["calibrate"] = option(
        1.0,
        "α in Z = −αθI (curvature per unit temperature): a number, {cell group = value} (0 on unlisted groups: passive panels), or 'calibrate': on the hinges, α such that one hinge strip with this mesh's hinge cells folds by fold_angle at the hinges' mean temperature at the first hold",
    )
    fold_angle: float = option(
        90.0, "alpha = 'calibrate': the target fold angle in degrees", gt=-180, lt=180
    )
    hinges: dict[str, list[str]] = option(
        {},
        "{hinge cell group = [inner panel, outer panel]}: fold angles per hinge in summary.json and history.csv (degrees, positive the way a heated hinge folds)",
        each=Check(length=2),
    )
    anchor: str = option(
        "", "a panel held in its reference place by a weak spring ½k∫|y − (x, y, 0)|² ('': none)"
    )
    anchor_stiffness: float = option(1000.0, "the anchor's spring constant k", gt=0)
    clamped: list[str] = option([], "facet groups with flat clamped data (Nitsche); usually none")
    penalty: Penalty = option(Penalty(), "IP penalties γ₀ (h⁻³[y]) and γ₁ (h⁻ᵖ[∇y])")
    penalty_aspect: float | Literal["mesh"] = option(
        1.0,
        "thin cells: γ₀ scaled by A³ and γ₁ by A; a number A >= 1, or 'mesh': A = the largest ratio of a cell's longest to its shortest edge (hinge strips of thin cells)",
        ge=1,
    )
    penalty_length: str = option("diameter", PENALTY_LENGTH_HELP, choices=PENALTY_LENGTHS)
    kappa: float = option(1.0, "heat diffusivity κ (θ_t − κΔθ = s, insulated edges)", gt=0)
    source: list[list[float]] = option(
        [[0.0, 1.0]],
        "heat source schedule [[t₀, s₀], [t₁, s₁], …]: s = sᵢ for tᵢ ≤ t < tᵢ₊₁ (0 before t₀)",
        each=Check(length=2),
    )
    source_regions: list[str] = option([], "cell groups the source heats ([]: the whole plate)")
    theta0: float = option(0.0, "initial temperature θ(0)")
    heat_degree: int = option(
        1, "degree of the continuous Lagrange space of θ (1 or 2)", choices=(1, 2)
    )
    closure: Closure | None = option(
        None,
        "closure_gap = the largest distance of the edge's nodes from target(x, y), in the panel's frame: {} none",
    )
    edges: dict[str, str] = option(
        {},
        "{facet group = panel}: <group>_height and <group>_distance, the mean height above the panel and the mean in-plane distance from its centre of the group's nodes, in the panel's frame",
    )
    self_avoidance: SelfAvoidance | None = option(
        None,
        "self-avoidance ρ·TP[y] by the tangent-point potential, explicit in every relaxation step (docs/self_avoidance.md): {} none",
    )
    schedule: ScheduleSpec = section(ScheduleSpec, "schedule")

    def __post_init__(self) -> None:
        """What spans keys: calibration, the closure's formulas, the source schedule."""
        if self.alpha == "calibrate" and not (self.hinges and self.schedule.holds):
            raise InputError(
                "model.alpha = 'calibrate' needs model.hinges (where α acts) and schedule.holds "
                "(it calibrates at the hinges' temperature at the first hold)"
            )
        if self.alpha == {} or self.mu == {}:
            raise InputError(f"model.{'alpha' if self.alpha == {} else 'mu'} must not be empty")
        if self.closure is not None:
            expressions.check(self.closure.target, "model.closure.target")
        try:
            self.heat_source()
        except InputError as err:
            raise InputError(f"model.source: {err}") from None

    def heat_source(self) -> HeatSource:
        """The source schedule (its times checked by :class:`HeatSource`)."""
        regions = tuple(self.source_regions) or None
        return HeatSource(tuple((p[0], p[1]) for p in self.source), regions)
