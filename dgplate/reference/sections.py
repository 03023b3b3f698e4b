"""Second moments of area I and torsion constants J of a rod's cross-section.

A rod of Young's modulus E and shear modulus G = E/(2(1 + ν)) has the bending stiffness EI
and the torsional stiffness GJ.

- Circle of radius r: I = πr⁴/4, J = πr⁴/2 (the polar moment).
- Rectangle of width b ≥ thickness h: I = bh³/12 about the axis of weaker bending, and Saint-
  Venant's series J = (bh³/3)[1 − (192/π⁵)(h/b) Σ_{n odd} tanh(nπb/(2h))/n⁵] (S. P.
  Timoshenko, J. N. Goodier, *Theory of Elasticity*, 3rd ed., 1970, §109): J = 0.1406 bh³ for
  a square, 0.229 bh³ for b = 2h, and bh³/3 for a thin strip.
"""

from __future__ import annotations

import math

__all__ = ["circle_section", "rectangle_section"]


def circle_section(radius: float) -> tuple[float, float]:
    """(I, J) of a disc of the given radius."""
    return math.pi * radius**4 / 4, math.pi * radius**4 / 2


def rectangle_section(width: float, thickness: float) -> tuple[float, float]:
    """(I, J) of a rectangle: I about the axis of weaker bending, J by Saint-Venant's series.

    Args:
        width: one side.
        thickness: the other (either may be the larger).

    Returns:
        I = bh³/12 and J, with b ≥ h the longer and the shorter side.
    """
    b, h = max(width, thickness), min(width, thickness)
    series = sum(math.tanh(n * math.pi * b / (2 * h)) / n**5 for n in range(1, 200, 2))
    return b * h**3 / 12, b * h**3 / 3 * (1 - 192 / math.pi**5 * (h / b) * series)
