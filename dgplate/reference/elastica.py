"""The clamped–clamped elastica: the exact buckled shape of a strip with shortened ends.

An inextensible strip of length L, clamped flat at both ends, whose ends are pushed together by
Δ, bends in one direction only; its centre line is Euler's elastica θ'' + λ² sin θ = 0 (θ the
tangent angle, λ² = P/B the end force over the bending stiffness) with θ = 0 at both ends. The
first (symmetric) mode is one full period of the inflectional elastica: with the modulus
k = sin(θ₀/2) (θ₀ the largest tangent angle, at the inflection points s = L/4 and 3L/4) and
sin(θ/2) = k sin φ, the arc length is λ ds = dφ / √(1 − k² sin²φ), so a quarter period is
K(k)/λ = L/4. Integrating cos θ = 1 − 2k² sin²φ and sin θ = 2k sin φ √(1 − k² sin²φ) over the
quarters gives

    Δ / L = 2 (1 − E(k)/K(k)),        H / L = k / K(k)

for the end shortening Δ and the midpoint height H (K, E the complete elliptic integrals of the
first and second kind). Small k: Δ ≈ k²L and H ≈ 2kL/π, the Euler mode w = ½H(1 − cos 2πx/L).
See A. E. H. Love, *A Treatise on the Mathematical Theory of Elasticity*, 4th ed., 1927,
§§262–263, and S. P. Timoshenko, J. M. Gere, *Theory of Elastic Stability*, 2nd ed., 1961,
§2.7; the derivation is written out in docs/continuation.md. K and E are computed by the
arithmetic–geometric mean (M. Abramowitz, I. A. Stegun, *Handbook of Mathematical Functions*,
1964, §17.6), exact to round-off and equal to ``scipy.special.ellipk``/``ellipe`` of m = k²,
so that SciPy is no dependency.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["clamped_elastica", "clamped_elastica_curve", "elliptic_ke"]


def elliptic_ke(k: float) -> tuple[float, float]:
    """The complete elliptic integrals K(k) and E(k) of modulus 0 <= k < 1 (AGM, A&S 17.6)."""
    a, b, c = 1.0, math.sqrt(1.0 - k * k), k
    total, power = 0.5 * c * c, 0.5
    for _ in range(64):  # quadratic convergence: a handful of rounds for k < 1 − 1e-12
        if abs(c) <= 1e-17 * a:
            break
        a, b, c = 0.5 * (a + b), math.sqrt(a * b), 0.5 * (a - b)
        power *= 2.0
        total += power * c * c
    K = math.pi / (2.0 * a)
    return K, K * (1.0 - total)


def _shortening(k: float) -> float:
    """Δ/L of the clamped–clamped elastica of modulus k."""
    K, E = elliptic_ke(k)
    return 2.0 * (1.0 - E / K)


def clamped_elastica(length: float, shortening: float) -> dict[str, float]:
    """Modulus k, largest tangent angle θ₀ (degrees), midpoint height H and λ for Δ, L.

    ``shortening`` Δ must lie in (0, L): Δ/L → 1 as k → 1 (the loop closes on itself).
    """
    ratio = shortening / length
    if not 0 < ratio < 1:
        raise ValueError(f"the end shortening must lie in (0, L), got Δ/L = {ratio}")
    lo, hi = 0.0, 1.0 - 1e-12  # Δ/L increases with k: bisection to round-off
    for _ in range(200):
        k = 0.5 * (lo + hi)
        lo, hi = (k, hi) if _shortening(k) < ratio else (lo, k)
    k = 0.5 * (lo + hi)
    K = elliptic_ke(k)[0]
    return {
        "k": k,
        "theta0_deg": math.degrees(2 * math.asin(k)),
        "height": length * k / K,
        "lambda": 4 * K / length,
    }


def clamped_elastica_curve(
    length: float, shortening: float, samples: int = 20001
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arc length s, x and z of the clamped–clamped elastica of length L shortened by Δ.

    With sin(θ/2) = k sin φ, λ ds = dφ / √(1 − k² sin²φ) (docs/continuation.md):
    s = F(φ, k)/λ, x = (2E(φ, k) − F(φ, k))/λ, z = 2k(1 − cos φ)/λ for φ ∈ [0, 2π], with the
    incomplete elliptic integrals F, E by the trapezoidal rule on ``samples`` points in φ.
    The curve runs from (0, 0) to (L − Δ, 0).

    Args:
        length: L.
        shortening: Δ in (0, L).
        samples: points of the table.

    Returns:
        The tables s, x and z (increasing s).
    """
    shape = clamped_elastica(length, shortening)
    k, lam = shape["k"], shape["lambda"]
    phi = np.linspace(0.0, 2.0 * np.pi, samples)
    root = np.sqrt(1.0 - (k * np.sin(phi)) ** 2)
    step = phi[1] - phi[0]

    def integral(f: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * step)])

    F, E = integral(1.0 / root), integral(root)
    return F / lam, (2.0 * E - F) / lam, 2.0 * k * (1.0 - np.cos(phi)) / lam
