"""Published reference values that demos, tests and benchmarks compare against.

Sources and set-ups: docs/design.md §8.
"""

import math

# Bonito, Nochetto, Ntogkas (M3AS 2021), Table 1: the plate (0, 4)² clamped on two
# perpendicular edges under f = (0, 0, 2.5e-2), Q2, γ₀ = 5000, γ₁ = 1100, τ = h, tol 1e-6.
# cells per side -> (E_h, D_h, steps)
BNN_TABLE1: dict[int, tuple[float, float, int]] = {
    16: (-7.53e-3, 4.02e-3, 13),
    32: (-5.76e-3, 1.63e-3, 28),
    64: (-4.26e-3, 6.07e-4, 76),
    128: (-3.30e-3, 2.28e-4, 140),
}


def bnn_h(cells: int) -> float:
    """H of the BNN plate (0, 4)² on cells × cells squares (the diagonal), their τ."""
    return math.sqrt(2) * 4 / cells
