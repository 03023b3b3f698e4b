"""Timoshenko's bimetal strip: the curvature of two bonded layers with a misfit strain.

Two layers of thicknesses t₁ (bottom) and t₂ (top), total h = t₁ + t₂, moduli E₁ and E₂, whose
stress-free strains differ by ε = ε₂ − ε₁ (a misfit, or (α₂ − α₁)ΔT), bend to the curvature

    1/ρ = 6 ε (1 + m)² / (h [3 (1 + m)² + (1 + m n)(m² + 1/(m n))]),   m = t₁/t₂, n = E₁/E₂,

with the centre of curvature on the side of the layer that is shorter when free (S. P.
Timoshenko, "Analysis of bi-metal thermostats", J. Opt. Soc. Am. 11, 233–255, 1925, eq. 4).
Equal thicknesses and moduli give 1/ρ = 3ε/(2h), the radius 2h/(3ε).
"""

from __future__ import annotations

__all__ = ["timoshenko_curvature"]


def timoshenko_curvature(
    strain: float, bottom: float, top: float, modulus_bottom: float, modulus_top: float
) -> float:
    """Timoshenko's curvature 1/ρ of a bimetal strip (module docstring).

    Args:
        strain: the misfit ε = ε_top − ε_bottom of the stress-free strains.
        bottom: the bottom layer's thickness t₁.
        top: the top layer's thickness t₂.
        modulus_bottom: the bottom layer's modulus E₁.
        modulus_top: the top layer's modulus E₂.

    Returns:
        1/ρ, positive when the top layer is the longer one when free (ε > 0).
    """
    m, n, h = bottom / top, modulus_bottom / modulus_top, bottom + top
    return 6 * strain * (1 + m) ** 2 / (h * (3 * (1 + m) ** 2 + (1 + m * n) * (m**2 + 1 / (m * n))))
