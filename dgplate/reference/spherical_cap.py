"""The spherical cap: the exact prestrained plate whose target metric is that of a sphere.

The disc ω = {|x| < ρ₀} with the metric of a sphere of radius R in geodesic polar coordinates,
G = dr² + R² sin²(r/R) dθ², is in the Cartesian coordinates x = r n of ω

    G = n⊗n + a(r)² (I − n⊗n) = I + q(r) (|x|² I − x⊗x),   a(r) = R sin(r/R)/r,
    q(r) = (a² − 1)/r²  (→ −1/(3R²) as r → 0).

Its realisations y (∇yᵀ∇y = G) with the least bending energy are the caps of the sphere,
y(x) = a(r) x + R(1 − cos(r/R)) e₃ up to rigid motions: on the constraint set the energy of
the second fundamental form, |G^{-1/2} II G^{-1/2}|² = κ₁² + κ₂² ≥ 2κ₁κ₂ = 2K = 2/R², is
least exactly where II = G/R (umbilic points), and the sphere is the only surface of umbilic
points. The plate's energy is that of dgplate's Kirchhoff model with a metric,

    E[y] = ½ μ ∫_ω Σ_k |G^{-1/2} D²y_k G^{-1/2}|² dx,

the energy of Bonito, Guignard, Nochetto and Yang (J. Comput. Phys. 2022) with λ = 0 and
their μ/12 written ½μ (dgplate's normalisation of the Kirchhoff energy, ½∫μ|D²y|² for G = I).
On the constraint set D²y_k = Γᵐ ∂_m y_k + II ν_k, so the density is 2/R² plus a function of
G alone (the Christoffel symbols' part): :func:`energy_density` evaluates it at the cap by
the chain rule, at x = r e₁ (the density is invariant under rotations of ω).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = [
    "cap",
    "energy",
    "energy_density",
    "geodesic_polar_formulas",
    "metric_formulas",
    "trace_density",
]

#: below this (r/R)² the formulas of G use the Taylor series of q (no cancellation in a² − 1)
SERIES_BELOW = 1 / 64


def metric_formulas(R: float) -> dict[str, str]:
    """The entries g11, g12, g22 of G as formulas in x, y (``model.metric``).

    q(r) is the closed form for (r/R)² > ``SERIES_BELOW`` and its Taylor series inside (from
    sin²ρ/ρ² = 1 − ρ²/3 + 2ρ⁴/45 − ρ⁶/315 + 2ρ⁸/14175 − 2ρ¹⁰/467775 + …, ρ = r/R; the first
    term left out is below 10⁻¹⁷/R² there), so G is exact to round-off, at r = 0 too.

    Args:
        R: the sphere's radius.

    Returns:
        The three formulas by key.
    """
    return geodesic_polar_formulas(R, 1)


def geodesic_polar_formulas(R: float, sign: int) -> dict[str, str]:
    """G = dr² + S(r)² dθ² of the sphere (sign 1) or the hyperbolic plane (sign −1).

    S(r) = R sin(r/R) for the sphere of radius R (K = 1/R²), R sinh(r/R) for the hyperbolic
    plane of curvature K = −1/R²; G = I + q(r)(|x|²I − x⊗x) with q = (S²/r² − 1)/r², its
    Taylor series for (r/R)² ≤ ``SERIES_BELOW`` (sinh²ρ/ρ² is sin²ρ/ρ² with ρ² → −ρ²: the
    same coefficients, all positive).

    Args:
        R: the radius R > 0.
        sign: 1 for the sphere, −1 for the hyperbolic plane.

    Returns:
        The three formulas g11, g12, g22 by key.
    """
    s, R2 = "(x*x + y*y)", f"{R!r}**2"
    p = f"({s}/{R2})"  # ρ²
    trig, first, minus = ("sin", "-", "-") if sign > 0 else ("sinh", "", "+")
    closed = f"({R2}*{trig}(sqrt{s}/{R!r})**2/{s} - 1)/{s}"
    series = (
        f"({first}1/3 + 2*{p}/45 {minus} {p}**2/315 + 2*{p}**3/14175 {minus} 2*{p}**4/467775)/{R2}"
    )
    q = f"where({p} > {SERIES_BELOW!r}, {closed}, {series})"
    return {"g11": f"1 + ({q})*y*y", "g12": f"-({q})*x*y", "g22": f"1 + ({q})*x*x"}


def cap(x: npt.NDArray[np.float64], R: float) -> npt.NDArray[np.float64]:
    """The cap y(x) = a(r) x + R(1 − cos(r/R)) e₃, a(r) = R sin(r/R)/r.

    Args:
        x: points of the disc, shape (2 or 3, n) (a third row is ignored).
        R: the sphere's radius.

    Returns:
        y at the points, shape (3, n).
    """
    r = np.hypot(x[0], x[1])
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(r > 0, R * np.sin(r / R) / np.where(r > 0, r, 1.0), 1.0)
    return np.vstack([a * x[0], a * x[1], R * (1 - np.cos(r / R))])


def energy_density(r: npt.NDArray[np.float64], R: float) -> npt.NDArray[np.float64]:
    """Σ_k |G^{-1/2} D²y_k G^{-1/2}|² of the cap at |x| = r > 0 (→ 2/R² as r → 0).

    With y = a(r)x + b(r)e₃, at x = r e₁: G⁻¹ = diag(1, a⁻²), D²y₁ = diag(ra'' + 2a', a'),
    D²y₂ = a'(e₁⊗e₂ + e₂⊗e₁), D²y₃ = diag(b'', b'/r).

    Args:
        r: radii, all > 0.
        R: the sphere's radius.

    Returns:
        The density at each radius.
    """
    rho = r / R
    a = R * np.sin(rho) / r
    da = np.cos(rho) / r - R * np.sin(rho) / r**2
    dda = -np.sin(rho) / (R * r) - 2 * np.cos(rho) / r**2 + 2 * R * np.sin(rho) / r**3
    db, ddb = np.sin(rho), np.cos(rho) / R
    density: npt.NDArray[np.float64] = (
        (r * dda + 2 * da) ** 2 + da**2 / a**4 + 2 * da**2 / a**2 + ddb**2 + (db / r) ** 2 / a**4
    )
    return density


def trace_density(r: npt.NDArray[np.float64], R: float) -> npt.NDArray[np.float64]:
    """Σ_k tr(G^{-1/2} D²y_k G^{-1/2})² = Σ_k (G⁻¹ : D²y_k)² of the cap at |x| = r > 0 (→ 4/R²).

    At x = r e₁, as :func:`energy_density`: G⁻¹ : D²y₁ = ra'' + 2a' + a'/a², G⁻¹ : D²y₂ = 0,
    G⁻¹ : D²y₃ = b'' + b'/(ra²).

    Args:
        r: radii, all > 0.
        R: the sphere's radius.

    Returns:
        The density of the trace term at each radius.
    """
    rho = r / R
    a = R * np.sin(rho) / r
    da = np.cos(rho) / r - R * np.sin(rho) / r**2
    dda = -np.sin(rho) / (R * r) - 2 * np.cos(rho) / r**2 + 2 * R * np.sin(rho) / r**3
    db, ddb = np.sin(rho), np.cos(rho) / R
    density: npt.NDArray[np.float64] = (r * dda + 2 * da + da / a**2) ** 2 + (
        ddb + db / (r * a**2)
    ) ** 2
    return density


def energy(
    R: float, radius: float = 1.0, mu: float = 1.0, points: int = 200, poisson: float = 0.0
) -> float:
    """E of the cap on the disc |x| < ``radius``: ½μ·2π ∫₀^radius (density + c·trace) r dr.

    c = ν/(1 − ν) weighs :func:`trace_density` (the energy's trace term, ``model.poisson``).
    On the constraint set both parts are least at umbilic points (κ₁² + κ₂² ≥ 2κ₁κ₂ and
    (κ₁ + κ₂)² ≥ 4κ₁κ₂), so the cap is the minimiser for every ν ≥ 0.

    Gauss–Legendre quadrature with ``points`` nodes (the integrand is smooth: exact to
    round-off with the default).

    Args:
        R: the sphere's radius.
        radius: the disc's radius.
        mu: the rigidity μ.
        points: the quadrature's nodes.
        poisson: Poisson's ratio ν of the trace term.

    Returns:
        The cap's energy.
    """
    nodes, weights = np.polynomial.legendre.leggauss(points)
    r = 0.5 * radius * (nodes + 1)
    density = energy_density(r, R)
    if poisson:
        density = density + poisson / (1 - poisson) * trace_density(r, R)
    integral = 0.5 * radius * float(np.sum(weights * density * r))
    return 0.5 * mu * 2 * math.pi * integral
