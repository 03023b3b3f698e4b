"""A heavy strip lifted off a table: the exact lift-off length and its penalised version.

A strip of bending rigidity μ (per unit width) and weight q per unit area is clamped
horizontally at height H above a rigid table (y₃ ≥ 0). In small-deflection Euler–Bernoulli
theory (H ≪ ℓ) it is free on (0, ℓ) and lies on the table beyond the lift-off point ℓ:

    μ w'''' = −q on (0, ℓ),   w(0) = H, w'(0) = 0,   w(ℓ) = w'(ℓ) = w''(ℓ) = 0,

so w(x) = q/(72μ) (4ℓ(ℓ − x)³ − 3(ℓ − x)⁴) and ℓ = (72 μ H / q)^{1/4} (docs/obstacle.md).

With the table replaced by the penalty (1/2ε)∫(w)₋², the contact starts at ℓ_ε ≠ ℓ, with
ℓ_ε → ℓ as ε → 0 at the rate of the boundary-layer length (4με)^{1/4}. :func:`penalised_lift_off`
computes ℓ_ε of the one-dimensional penalised beam by finite differences and an active-set
Newton iteration: the reference of a plate run at finite ε.
"""

from __future__ import annotations

import numpy as np


def lift_off_length(mu: float, height: float, weight: float) -> float:
    """ℓ = (72 μ H / q)^{1/4}, the exact lift-off length on a rigid table."""
    return float((72.0 * mu * height / weight) ** 0.25)


def penalised_lift_off(
    mu: float, height: float, weight: float, epsilon: float, length: float, n: int = 3000
) -> float:
    """ℓ_ε: where the penalised beam on (0, length) first goes below the table.

    Minimises ∫ ½μ w''² + q w + (1/2ε)(w)₋² with w(0) = H, w'(0) = 0 and a free end, on n
    intervals (second differences; the clamp by a ghost node), by Newton's method on the active
    set {w < 0}, continued in ε from 10⁻³ down by decades; the zero crossing is interpolated linearly between nodes.
    """
    h = length / n
    # unknowns w_1 .. w_n (w_0 = H); ghost w_{-1} = w_1 (w'(0) = 0); free end: natural
    D = np.zeros((n + 1, n + 2))  # second differences at nodes 0..n of (w_{-1}, w_0, ..., w_n)
    for i in range(1, n):
        D[i, i : i + 3] = np.array([1.0, -2.0, 1.0]) / h**2
    D[0, 0:3] = np.array([1.0, -2.0, 1.0]) / h**2
    weights = np.full(n + 1, h)
    weights[[0, n]] = h / 2  # trapezoidal rule; the end rows vanish at the free end
    weights[n] = 0.0
    # map the unknowns u = (w_1..w_n) to the full vector (w_{-1}, w_0, w_1..w_n)
    P = np.zeros((n + 2, n))
    P[0, 0] = 1.0
    P[2:, :] = np.eye(n)
    shift = np.zeros(n + 2)
    shift[1] = height
    DP = D @ P
    K = mu * DP.T @ (weights[:, None] * DP)
    rhs0 = -mu * DP.T @ (weights * (D @ shift)) - weight * h * np.ones(n)
    rhs0[-1] += weight * h / 2
    active = np.zeros(n, dtype=bool)
    u = np.zeros(n)
    # below ε ~ 1e-8 the active-set iteration from an empty set cycles: it is warm-started
    # from the active set of ten times larger ε, down from 1e-3
    schedule = [e for e in 10.0 ** np.arange(-3.0, np.log10(epsilon), -1.0) if e > epsilon]
    for eps in [*schedule, epsilon]:
        for _ in range(100):
            mass = np.where(active, h / eps, 0.0)
            u = np.linalg.solve(K + np.diag(mass), rhs0)
            new = u < 0
            if np.array_equal(new, active):
                break
            active = new
    w = np.concatenate([[height], u])
    first = int(np.argmax(w < 0))
    return float(h * (first - 1 + w[first - 1] / (w[first - 1] - w[first])))


#: Bonito–Nochetto–Ntogkas (M3AS 2021), §6.2, obstacle y₃ ≤ 0.2 with 1024 cells: the final
#: isometry defect D_h and the penetration into the obstacle, as quoted (≈).
BNN_OBSTACLE = {"isometry_defect": 9e-5, "penetration": 2e-3}
