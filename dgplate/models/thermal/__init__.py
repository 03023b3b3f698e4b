"""Heat-coupled thermal bilayer (docs/design.md §1, "Thermal bilayer"): ``model.name = "thermal"``.

A bilayer whose layers expand differently with temperature θ has the spontaneous curvature

    Z = −α θ I₂,     E[y] = ½∫ μ |II(y) − Z|²   (isometry constrained),

where α (per unit temperature) is the curvature the thermal strain mismatch produces and μ the
bending rigidity. Both are piecewise constant over cell groups: soft bilayer hinges (μ = 1,
α > 0) between stiff passive panels (μ = 20, α = 0). The panels need α = 0, not only a large μ:
with Z on a panel too, the panel pays ½μ|II − Z|² = μ|Z|² flat but only ½μ|Z|² rolled to a
cylinder of curvature |Z| (isometries can match one principal curvature), so any μ lets it
roll. θ solves the heat equation of :mod:`dgplate.coupling.heat`; the driver
:class:`dgplate.coupling.thermal_driver.ThermalBilayer` alternates heat steps and relaxations of the
plate by the constrained gradient flow. The compiled energy references the temperature
Function, so a heat step changes Z without recompiling anything.

Rigid motions. A free net has none of its edges clamped; by default the flow then adds the L²
product to its metric. ``anchor`` ties one panel to its reference placement by a weak spring
½k∫_anchor |y − (x, 0)|² (quadratic: part of the constant matrix). The anchored panel stays
flat and in place in every folded state, so the spring is (nearly) unloaded at equilibrium and
biases no fold; it keeps positions in a fixed frame, and it makes the energy's Hessian definite
on rigid motions, so the L² term may be left out (``flow.l2_metric = false``), which lets far
panels fold as fast as near ones (the L² metric weighs a panel by its lever arm).

The package holds the problem-file section (:mod:`dgplate.models.thermal.spec`), the energy in
pure UFL (:mod:`dgplate.models.thermal.energy`) and the model :class:`ThermalModel` that builds
the driver (:func:`build_thermal`, :mod:`dgplate.models.thermal.model`).
"""

from dgplate.models.thermal.energy import (
    anchor_energy,
    aspect_penalty,
    cell_aspect_ratio,
    hinge_penalty,
    region_coefficient,
    thermal_curvature,
    thermal_energy,
)
from dgplate.models.thermal.model import ThermalModel, build_thermal, calibrate_alpha
from dgplate.models.thermal.spec import ThermalSpec

__all__ = [
    "ThermalModel",
    "ThermalSpec",
    "anchor_energy",
    "aspect_penalty",
    "build_thermal",
    "calibrate_alpha",
    "cell_aspect_ratio",
    "hinge_penalty",
    "region_coefficient",
    "thermal_curvature",
    "thermal_energy",
]
