"""Heat-coupled thermal bilayer (docs/design.md §1, "Thermal bilayer").

A bilayer whose layers expand differently with temperature θ has the spontaneous curvature

    Z = −α θ I₂,     E[y] = ½∫ μ |II(y) − Z|²   (isometry constrained),

where α (per unit temperature) is the curvature the thermal strain mismatch produces and μ the
bending rigidity. Both are piecewise constant over cell groups: soft bilayer hinges (μ = 1,
α > 0) between stiff passive faces (μ = 20, α = 0). The faces need α = 0, not only a large μ:
with Z on a face too, the face pays ½μ|II − Z|² = μ|Z|² flat but only ½μ|Z|² rolled to a
cylinder of curvature |Z| (isometries can match one principal curvature), so any μ lets it
roll. θ solves the heat equation of
:mod:`dgplate.coupling.heat`; the coupling is quasi-static and one-way: after each heat time step the
plate is relaxed by the constrained H² gradient flow of :mod:`dgplate.solvers.flow`, warm-started from
the previous shape, until the flow's stopping rule ((E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < ``tol``) holds or
the step budget ``flow_steps`` is spent. The compiled energy references the temperature
Function, so a heat step changes Z without recompiling anything; the flow's constant matrix
(metric + bending) does not depend on θ and is never reassembled.

Rigid motions. A free net has none of its edges clamped; by default the flow then adds the L²
product to its metric. ``anchor`` ties one face region to its reference placement by a weak
spring ½k∫_anchor |y − (x, 0)|² (quadratic: part of the constant matrix). The anchored face
stays flat and in place in every folded state, so the spring is (nearly) unloaded at
equilibrium and biases no fold; it keeps positions in a fixed frame, and it makes the energy's
Hessian definite on rigid motions, so the L² term may be left out (``l2_metric=False``), which
lets far faces fold as fast as near ones (the L² metric weighs a face by its lever arm).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace

import dolfinx.fem
import numpy as np
import ufl

from dgplate.coupling.heat import HeatSolver
from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets, Penalty, facet_sets
from dgplate.errors import InputError
from dgplate.io.checkpoint import Checkpoint
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import flat_identity, piecewise_constant
from dgplate.models.bilayer import bilayer_energy
from dgplate.solvers.flow import FlowResult, FlowSpec, GradientFlow
from dgplate.values import constant


def region_coefficient(tagged: TaggedMesh, values, key: str, default: float = 0.0):
    """A coefficient that may vanish: a number (everywhere, a Constant), or {cell group: number}
    with ``default`` on the cells of no listed group (a DG0 field). Unlike μ it may be 0 or < 0.
    """
    if isinstance(values, int | float) and not isinstance(values, bool):
        return constant(tagged.mesh, values)
    if not isinstance(values, dict) or not values:
        raise InputError(f"{key} must be a number or a table {{group = value}}, got {values!r}")
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InputError(f"{key}.{name} must be a number, got {value!r}")
    return tagged.group_function(values, default=default, key=key)


def thermal_curvature(theta, alpha):
    """Z = −α θ I₂ (a UFL 2×2 expression; θ a Function, α a number or a DG0 field)."""
    return -alpha * theta * ufl.Identity(2)


def anchor_energy(y, tagged: TaggedMesh, region: str, stiffness: float):
    """½k∫_region |y − (x₁, x₂, 0)|²: a weak spring holding a face in its reference place."""
    if not stiffness > 0:
        raise InputError(f"anchor stiffness must be > 0, got {stiffness!r}")
    mesh = tagged.mesh
    # an indicator field rather than dx(tag): DOLFINx 0.9 wants one subdomain_data per
    # integral type in a form, and the bending energy's dx carries none
    indicator = tagged.group_function({region: 1.0}, default=0.0, key="anchor")
    g, _ = flat_identity(mesh)
    k = constant(mesh, stiffness)
    return 0.5 * k * indicator * ufl.inner(y - g, y - g) * ufl.dx(domain=mesh)


def thermal_energy(
    y,
    faces: FacetSets,
    penalty: Penalty,
    theta,
    alpha,
    mu=None,
    degree: int | None = None,
    anchor=None,
) -> Energy:
    """The bilayer energy with Z = −αθI (flat clamped data where faces are clamped), plus an
    optional anchor term (``anchor`` a UFL form from :func:`anchor_energy`, implicit).
    """
    g, Phi = flat_identity(faces.mesh)
    Z = thermal_curvature(theta, alpha)
    energy = bilayer_energy(y, faces, penalty, Z, mu, None, g, Phi, True, degree)
    if anchor is not None:
        energy.implicit = energy.implicit + anchor
    return energy


@dataclass
class ThermalSettings:
    """Parameters of the heat-coupled bilayer.

    alpha: thermal curvature coefficient, Z = −αθI: a number (everywhere) or {group: α}
      (0 on unlisted groups: passive single-layer faces). mu: bending rigidity, a number or
      {group: μ} (every cell needs a value). flow_steps: step budget of the gradient flow
      after each heat step (it stops earlier when the flow's tolerance is met).
      anchor / anchor_stiffness: a face region held by a weak spring (None: no spring).
      clamped: facet groups with flat clamped data (Nitsche), usually none.
    """

    alpha: float | dict = 1.0
    mu: float | dict = 1.0
    flow_steps: int = 40
    degree: int = 2
    penalty: Penalty = field(default_factory=Penalty)
    anchor: str | None = None
    anchor_stiffness: float = 1000.0
    clamped: Sequence[str] = ()

    def __post_init__(self) -> None:
        if not (isinstance(self.flow_steps, int) and self.flow_steps >= 1):
            raise InputError(f"flow_steps must be an integer >= 1, got {self.flow_steps!r}")
        if self.degree < 2:
            raise InputError(f"degree must be >= 2 for the H² dG method, got {self.degree}")


@dataclass
class HeatStepRecord:
    """What one heat step did: one row of the demo's history.csv."""

    step: int
    time: float
    source: float  # the scheduled source's mean over the last heat step
    theta_min: float
    theta_max: float
    theta_mean: float
    flow_steps: int
    flow_converged: bool
    energy: float
    defect: float
    seconds: float
    hold: bool = False  # a relaxation at fixed θ (no heat step), e.g. at the switch
    figures: dict = field(default_factory=dict)

    def row(self) -> dict:
        out = {k: v for k, v in self.__dict__.items() if k != "figures"}
        out.update(self.figures)
        return out


class ThermalBilayer:
    """Heat steps, each followed by a warm-started relaxation of the plate.

    ``measure(self) -> dict`` adds figures (e.g. hinge angles) to every record; ``observers``
    go to the gradient flow (per flow step). Collective on the mesh communicator.
    """

    def __init__(
        self,
        tagged: TaggedMesh,
        heat: HeatSolver,
        flow_settings: FlowSpec,
        settings: ThermalSettings,
        measure: Callable[[ThermalBilayer], dict] | None = None,
        observers: Sequence = (),
    ):
        if heat.mesh is not tagged.mesh:
            raise InputError("the heat solver and the plate must live on the same mesh")
        self.tagged, self.heat, self.settings, self.measure = tagged, heat, settings, measure
        self.faces = facet_sets(tagged, clamped=list(settings.clamped))
        self.alpha = region_coefficient(tagged, settings.alpha, "thermal.alpha")
        self.mu = piecewise_constant(tagged, settings.mu, "thermal.mu")
        degree = 3 * settings.degree + 2

        def energy_fn(y) -> Energy:
            anchor = None
            if settings.anchor is not None:
                anchor = anchor_energy(y, tagged, settings.anchor, settings.anchor_stiffness)
            return thermal_energy(
                y, self.faces, settings.penalty, heat.theta, self.alpha, self.mu, degree, anchor
            )

        self.flow = GradientFlow(self.faces, settings.degree, energy_fn, flow_settings, observers)
        self.records: list[HeatStepRecord] = []
        self.last_result: FlowResult | None = None

    @property
    def y(self) -> dolfinx.fem.Function:
        return self.flow.y

    @property
    def theta(self) -> dolfinx.fem.Function:
        return self.heat.theta

    @property
    def time(self) -> float:
        return self.heat.time

    def relax(self, max_steps: int | None = None) -> FlowResult:
        """Run the flow for the current θ (warm start), at most ``max_steps`` steps."""
        self.flow.rebase_energy()  # θ changed Z, hence the energy
        self.last_result = self.flow.run(max_steps=max_steps or self.settings.flow_steps)
        return self.last_result

    def advance(self, max_steps: int | None = None) -> HeatStepRecord:
        """One heat step, then relax the plate; returns (and stores) the record."""
        t0 = time.perf_counter()
        self.heat.step()
        result = self.relax(max_steps)
        return self._record(result, time.perf_counter() - t0)

    def hold(self, max_steps: int, tau: float | None = None) -> HeatStepRecord:
        """Relax at the current temperature without a heat step (e.g. at the switch, to the
        flow's tolerance), optionally with another τ (restored afterwards: each change
        reassembles the flow's constant matrix once); returns (and stores) the record, with
        the time of the last heat step.
        """
        t0 = time.perf_counter()
        previous = self.flow.tau
        if tau is not None and tau != previous:
            self.flow.tau = tau
        try:
            result = self.relax(max_steps)
        finally:
            if self.flow.tau != previous:
                self.flow.tau = previous
        return self._record(result, time.perf_counter() - t0, hold=True)

    def _record(self, result: FlowResult, seconds: float, hold: bool = False) -> HeatStepRecord:
        lo, hi = self.heat.min_max()
        record = HeatStepRecord(
            step=self.heat.steps,
            time=self.heat.time,
            source=self.heat.last_source,
            theta_min=lo,
            theta_max=hi,
            theta_mean=self.heat.mean(),
            flow_steps=result.steps,
            flow_converged=result.converged,
            energy=result.energy,
            defect=result.defect,
            seconds=seconds,
            hold=hold,
            figures=self.measure(self) if self.measure else {},
        )
        self.records.append(record)
        return record

    def run(
        self,
        t_end: float,
        callback: Callable[[ThermalBilayer, HeatStepRecord], None] | None = None,
    ) -> list[HeatStepRecord]:
        """Heat steps until ``t_end``; ``callback(self, record)`` after each.

        Stops early when the flow was interrupted (SIGINT/SIGTERM, see :attr:`interrupted`).
        """
        out = []
        while self.heat.time < t_end - 1e-9 * self.heat.dt and not self.interrupted:
            record = self.advance()
            out.append(record)
            if callback is not None:
                callback(self, record)
        return out

    @property
    def interrupted(self) -> int:
        """The signal that stopped the last relaxation (0: none)."""
        return self.last_result.interrupted if self.last_result is not None else 0

    def checkpoint_fields(self) -> dict[str, dolfinx.fem.Function]:
        """The plate's and the heat equation's state (see :mod:`dgplate.io.checkpoint`)."""
        return {**self.flow.checkpoint_fields(), "theta": self.heat.theta}

    def checkpoint_state(self) -> dict:
        """The counters and the records so far."""
        return {
            "step": self.heat.steps,
            "flow": self.flow.checkpoint_state(),
            "heat": self.heat.checkpoint_state(),
            "records": [asdict(r) for r in self.records],
        }

    def restore(self, found: Checkpoint) -> None:
        """Continue from a checkpoint written from :meth:`checkpoint_fields` and ``_state``."""
        found.restore(self.checkpoint_fields())
        self.flow.restore_state(found.state["flow"])
        self.heat.restore_state(found.state["heat"])
        self.records = [HeatStepRecord(**r) for r in found.state["records"]]

    def energy_parts(self) -> dict[str, float]:
        """Total energy and isometry defect of the current shape."""
        return {"energy": self.flow.evaluate_energy(), "isometry_defect": self.flow.defect()}

    def destroy(self) -> None:
        self.flow.destroy()
        self.heat.destroy()


def hinge_penalty(width: float, n: int, m: int, base: Penalty | None = None) -> Penalty:
    """IP penalties for hinge strips of m cells across (width/m) and 1/n along.

    The dG forms take h_e as the cell diameter, which on a thin hinge cell is its long side
    1/n, not the width w/m across which the hinge bends: the value-jump penalty γ₀h_e⁻³ is then
    (aspect)³ too weak and the coupling term −∫[y]·{div T·n} (which rewards value jumps
    linearly) makes the discrete hinge fold far too much (108° instead of 90° on a strip with
    m = 8, n = 4). Scaling γ₀ by A³ and γ₁ by A, A = (1/n)/(w/m), restores the penalties a
    face-normal h_e would give. On the square faces this only stiffens the jumps more.
    """
    base = base or Penalty()
    aspect = max(1.0, (1.0 / n) / (width / m))
    return replace(base, gamma0=base.gamma0 * aspect**3, gamma1=base.gamma1 * aspect)


def calibrate_alpha(
    comm,
    width: float,
    n: int,
    m: int,
    theta: float,
    flow_settings: FlowSpec,
    mu_hinge: float = 1.0,
    mu_face: float = 20.0,
    target: float = np.pi / 2,
    max_steps: int = 2000,
) -> tuple[float, dict]:
    """The coupling α at which one discrete hinge of this mesh folds by ``target`` at θ.

    c·w = target gives α_cw = target / (w θ) (a hinge of width w bent to curvature c = αθ
    turns by c·w). The discrete hinge (m cells across, n along, between two stiff squares,
    one anchored) folds a little less, an O(h) discretisation error of the curvature jump at
    the hinge edges. This relaxes that strip at θ with α_cw and corrects α by one secant step
    (the fold angle is linear in α): α = α_cw · target / φ_h. Returns α and the figures.
    """
    from dgplate.measure.hinges import FoldAngles, Hinge, hinge_strip

    alpha_cw = target / (width * theta)
    tagged = hinge_strip(comm, width, n, m)
    heat = HeatSolver(tagged, 1.0, 1.0, None, theta0=theta)
    settings = ThermalSettings(
        alpha={"hinge": alpha_cw},
        mu={"left": mu_face, "hinge": mu_hinge, "right": mu_face},
        flow_steps=max_steps,
        anchor="left",
        penalty=hinge_penalty(width, n, m),
    )
    model = ThermalBilayer(tagged, heat, flow_settings, settings)
    sense = -1 if alpha_cw * theta > 0 else 1  # Z = −αθI bends towards −ν when αθ > 0
    angles = FoldAngles(model.y, tagged, [Hinge("hinge", "left", "right")], sense=sense)
    result = model.relax(max_steps)
    phi = angles()["hinge"]
    model.destroy()
    info = {
        "alpha_cw": alpha_cw,
        "theta": theta,
        "strip_fold_deg": float(np.degrees(phi)),
        "strip_flow_steps": result.steps,
        "strip_converged": result.converged,
        "factor": float(target / phi),
    }
    return alpha_cw * target / phi, info


def cell_group_mean(tagged: TaggedMesh, expr, region: str) -> float:
    """Area-weighted mean of a scalar UFL expression over a cell group (collective)."""
    from dgplate.measure.hinges import RegionIntegrals

    area, total = RegionIntegrals(tagged)([ufl.as_ufl(1.0), expr], region)
    return float(total / area) if area else float(np.nan)


__all__ = [
    "HeatStepRecord",
    "ThermalBilayer",
    "ThermalSettings",
    "anchor_energy",
    "calibrate_alpha",
    "cell_group_mean",
    "hinge_penalty",
    "region_coefficient",
    "thermal_curvature",
    "thermal_energy",
]
