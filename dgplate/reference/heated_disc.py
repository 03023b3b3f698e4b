"""A free FvK disc with an isotropic natural curvature: the heated disc's two branches.

A disc of radius R and thickness t whose natural curvature is κ₀ I (a temperature difference
through the thickness, or a bilayer's mismatch: ``model.natural_curvature``) first bends into a
bowl, the spherical branch. The bowl's Gaussian curvature stretches its centre and compresses
its rim along its circumference, and past a critical
κ₀ the disc bends more in one direction than the other: the branch bifurcates into a pair of
cylinder-like shapes (Mansfield 1962; Freund 2000; Seffen & McMahon 2007).

**Uniform curvature** (the Ritz model of those papers): w = ½(a x² + b y²). Its Gaussian
curvature ab is constant, so the membrane stress is the free disc's exact one for that Gaussian
curvature, the stress function Φ = Et ab (2R²r² − r⁴)/64, of energy π Et R⁶ (ab)²/384 (the ν
terms vanish on a free edge). The bending energy is ½πR²D[(a − κ₀)² + (b − κ₀)² + 2ν(a − κ₀)(b −
κ₀)]. Divided by ½πR²D, the energy is

    f(a, b) = (a − κ₀)² + (b − κ₀)² + 2ν(a − κ₀)(b − κ₀) + c (ab)²,   c = (1 − ν²)R⁴/(16t²).

- Sphere (a = b): κ₀ = a + c a³/(1 + ν).
- Its Hessian's antisymmetric eigenvalue 2(1 − ν) − 2c a² vanishes at c a² = 1 − ν: the
  bifurcation at a_b = 4t/(R²√(1 + ν)), κ₀_b = 2a_b/(1 + ν) = 8t/(R²(1 + ν)^{3/2}).
- Past it (a ≠ b): c ab = 1 − ν and a + b = (1 + ν)κ₀, so a and b are the roots of
  z² − (1 + ν)κ₀ z + (1 − ν)/c.

All derived here.

**The exact spherical branch** of the FvK equations (the curvature is not uniform: the rim is
compressed along its circumference, the centre stretched). With the slope φ = w′(r) and ψ = r N_r (N_θ = ψ′), the
axisymmetric equations of a free disc are

    D (φ″ + φ′/r − φ/r²) = ψ φ / r,      ψ″ + ψ′/r − ψ/r² = −Et φ² / (2r),

with φ(0) = ψ(0) = 0, and at the rim N_r = 0 (ψ(R) = 0) and M_r = D(φ′ + νφ/r − (1 + ν)κ₀) = 0.
Near the centre φ = a r + a n r³/(8D), ψ = n r − Et a² r³/16 (a the centre curvature, n the
centre stress). :func:`sphere` shoots from r = 10⁻⁴R in (a, n) by the classical Runge–Kutta
method and Newton's method on the two rim conditions, from the uniform-curvature values.

**The exact bifurcation.** With Airy's function F (N_r = F′/r, N_θ = F″ on the bowl, so ψ = F′)
the FvK equations are D∇⁴w = [F, w], ∇⁴F = −½Et[w, w], [a, b] = a_xx b_yy + a_yy b_xx −
2a_xy b_xy. Perturbed by (W(r), Φ(r)) cos 2θ, the mode of the cylinder-like shapes, they give

    D 𝓛𝓛W = ψ′(W′/r − 4W/r²) + (ψ/r)W″ + φ′(Φ′/r − 4Φ/r²) + (φ/r)Φ″,
    𝓛𝓛Φ = −Et[φ′(W′/r − 4W/r²) + (φ/r)W″],

with 𝓛 = d²/dr² + (1/r)d/dr − 4/r², so 𝓛𝓛W = W⁗ + 2W‴/r − 9W″/r² + 9W′/r³ (for axisymmetric a,
[a, B cos 2θ] = [a″(B′/r − 4B/r²) + (a′/r)B″] cos 2θ). Four solutions are regular at the
centre, W or Φ starting as r² or r⁴. The free rim asks of their combination M_r = 0,
W″ + ν(W′/r − 4W/r²) = 0; a vanishing effective shear V_r = −D[(𝓛W)′ − 4(1 − ν)(W′ − W/r)/r²],
W‴ + W″/r − 5W′/r² + 8W/r³ − 4(1 − ν)(W′/r² − W/r³) = 0 (the membrane terms of V_r vanish
with N_r = N_rθ = 0 there); and N_r = N_rθ = 0, Φ = Φ′ = 0. :func:`bifurcation` finds the κ₀
where the 4 × 4 determinant of those conditions vanishes, by the secant method from the
uniform-curvature value.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "DiscSphere",
    "bifurcation",
    "sphere",
    "uniform_bifurcation",
    "uniform_cylinder",
    "uniform_sphere",
]

Array = npt.NDArray[np.float64]


def _stretch_factor(thickness: float, radius: float, nu: float) -> float:
    """C = (1 − ν²)R⁴/(16t²), the weight of (ab)² in the uniform-curvature energy."""
    return (1 - nu**2) * radius**4 / (16 * thickness**2)


def uniform_bifurcation(thickness: float, radius: float, nu: float) -> tuple[float, float]:
    """Where the uniformly curved sphere bifurcates.

    Args:
        thickness: t.
        radius: R.
        nu: Poisson's ratio ν.

    Returns:
        (κ₀_b, a_b): the natural curvature 8t/(R²(1 + ν)^{3/2}) and the sphere's curvature
        4t/(R²√(1 + ν)) there.
    """
    a_b = 4 * thickness / (radius**2 * math.sqrt(1 + nu))
    return 2 * a_b / (1 + nu), a_b


def uniform_sphere(kappa0: float, thickness: float, radius: float, nu: float) -> float:
    """The uniformly curved sphere's curvature a at natural curvature κ₀ (a + c a³/(1+ν) = κ₀).

    Args:
        kappa0: κ₀.
        thickness: t.
        radius: R.
        nu: ν.

    Returns:
        a (the real root of the cubic, by Newton's method from κ₀).
    """
    c = _stretch_factor(thickness, radius, nu) / (1 + nu)
    a = kappa0
    for _ in range(100):
        step = (a + c * a**3 - kappa0) / (1 + 3 * c * a**2)
        a -= step
        if abs(step) <= 1e-15 * max(abs(a), 1e-300):
            break
    return a


def uniform_cylinder(
    kappa0: float, thickness: float, radius: float, nu: float
) -> tuple[float, float] | None:
    """The two curvatures (a > b) of the uniformly curved disc past the bifurcation.

    Args:
        kappa0: the natural curvature κ₀ (past κ₀_b for a pair).
        thickness: the disc's thickness t.
        radius: the disc's radius R.
        nu: Poisson's ratio ν of its material.

    Returns:
        (a, b), roots of z² − (1 + ν)κ₀ z + (1 − ν)/c; None before the bifurcation.
    """
    total = (1 + nu) * kappa0
    product = (1 - nu) / _stretch_factor(thickness, radius, nu)
    discriminant = total**2 - 4 * product
    if discriminant < 0:
        return None
    root = math.sqrt(discriminant)
    return (total + root) / 2, (total - root) / 2


@dataclass(frozen=True)
class DiscSphere:
    """The exact spherical branch's state at one κ₀.

    Attributes:
        center_curvature: a = w″(0).
        center_stress: N_r(0) = N_θ(0).
        rim_height: w(R) − w(0).
        rim_slope: w′(R).
    """

    center_curvature: float
    center_stress: float
    rim_height: float
    rim_slope: float


def _radii(radius: float, steps: int) -> Array:
    """The Runge–Kutta nodes: r₀ = 10⁻⁴R, then graded as r₀ + (R − r₀)(k/steps)².

    Near the centre the equations have terms in 1/r² and 1/r³: a step must stay below r, which
    the grading keeps (uniform steps from r₀ would be 20 r₀ long at 500 steps).
    """
    r0 = 1e-4 * radius
    return np.asarray(r0 + (radius - r0) * (np.arange(steps + 1) / steps) ** 2)


def _integrate(rates: Callable[[float, Array], Array], y: Array, radii: Array) -> Array:
    """Y at the last of ``radii`` by the classical Runge–Kutta method from y at the first."""
    for r, h in zip(radii[:-1], np.diff(radii)):
        k1 = rates(r, y)
        k2 = rates(r + h / 2, y + h / 2 * k1)
        k3 = rates(r + h / 2, y + h / 2 * k2)
        k4 = rates(r + h, y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return y


def _rates(r: float, y: Array, D: float, Et: float) -> Array:
    """d/dr of (φ, φ′, ψ, ψ′, w) for the axisymmetric FvK equations (columns: shots)."""
    phi, dphi, psi, dpsi = y[0], y[1], y[2], y[3]
    return np.array(
        [
            dphi,
            -dphi / r + phi / r**2 + psi * phi / (D * r),
            dpsi,
            -dpsi / r + psi / r**2 - Et * phi**2 / (2 * r),
            phi,
        ]
    )


def _shoot(unknowns: Array, radius: float, D: float, Et: float, steps: int) -> Array:
    """(φ, φ′, ψ, ψ′, w) at the rim for each column (a, n) of ``unknowns``."""
    a, n = unknowns
    r0 = _radii(radius, steps)[0]
    y = np.array(
        [
            a * r0 + a * n * r0**3 / (8 * D),
            a + 3 * a * n * r0**2 / (8 * D),
            n * r0 - Et * a**2 * r0**3 / 16,
            n - 3 * Et * a**2 * r0**2 / 16,
            0.5 * a * r0**2,
        ]
    )
    return _integrate(lambda r, y: _rates(r, y, D, Et), y, _radii(radius, steps))


def sphere(
    kappa0: float,
    thickness: float,
    radius: float = 1.0,
    nu: float = 0.3,
    E: float = 1.0,
    steps: int = 500,
) -> DiscSphere:
    """The exact axisymmetric (spherical-branch) state of the free disc at natural curvature κ₀.

    Args:
        kappa0: κ₀ (> 0).
        thickness: t.
        radius: R.
        nu: ν.
        E: Young's modulus (the state does not depend on it).
        steps: Runge–Kutta steps from the centre to the rim (the error is O(steps⁻⁴): the rim
            height within 2·10⁻¹² relative at 250 steps, 2·10⁻⁹ at 125, at κ₀R²/t = 5.4).

    Returns:
        The centre curvature and stress, the rim's height over the centre and its slope.
    """
    D = E * thickness**3 / (12 * (1 - nu**2))
    Et = E * thickness
    a = uniform_sphere(kappa0, thickness, radius, nu)
    x = np.array([a, Et * a**2 * radius**2 / 16])
    scale = np.array([abs(a), max(Et * a**2 * radius**2 / 16, 1e-300)])

    def residual(columns: Array) -> Array:
        rim = _shoot(columns, radius, D, Et, steps)
        moment = rim[1] + nu * rim[0] / radius - (1 + nu) * kappa0
        return np.array([moment / kappa0, rim[2] / (Et * radius * kappa0**2 * radius**2)])

    for _ in range(50):
        shots = np.column_stack([x, *(x + 1e-6 * scale * e for e in np.eye(2))])
        values = residual(shots)
        jacobian = (values[:, 1:] - values[:, :1]) / (1e-6 * scale)
        step = np.linalg.solve(jacobian, -values[:, 0])
        x = x + step
        if np.all(np.abs(step) <= 1e-13 * scale):
            break
    else:
        raise ArithmeticError(f"the bowl at κ₀ = {kappa0:g} did not converge")
    rim = _shoot(x[:, None], radius, D, Et, steps)[:, 0]
    return DiscSphere(float(x[0]), float(x[1]), float(rim[4]), float(rim[0]))


def _mode_rates(r: float, base: Array, mode: Array, D: float, Et: float) -> Array:
    """d/dr of (W, W′, W″, W‴, Φ, Φ′, Φ″, Φ‴) of the cos 2θ perturbation (columns: solutions)."""
    phi, dphi, psi, dpsi = base[0], base[1], base[2], base[3]
    W, W1, W2, W3, P, P1, P2, P3 = mode
    bend = dphi * (W1 / r - 4 * W / r**2) + phi / r * W2  # [w₀, W cos 2θ]
    stress = dpsi * (W1 / r - 4 * W / r**2) + psi / r * W2  # [F₀, W cos 2θ]
    stress += dphi * (P1 / r - 4 * P / r**2) + phi / r * P2  # [Φ cos 2θ, w₀]
    w4 = stress / D - 2 * W3 / r + 9 * W2 / r**2 - 9 * W1 / r**3
    p4 = -Et * bend - 2 * P3 / r + 9 * P2 / r**2 - 9 * P1 / r**3
    return np.array([W1, W2, W3, w4, P1, P2, P3, p4])


def _rim_determinant(
    kappa0: float, thickness: float, radius: float, nu: float, steps: int
) -> float:
    """The determinant of the free rim's conditions on the regular cos 2θ solutions (E = 1)."""
    D, Et = thickness**3 / (12 * (1 - nu**2)), thickness
    state = sphere(kappa0, thickness, radius, nu, steps=steps)
    a, n = state.center_curvature, state.center_stress
    r0 = _radii(radius, steps)[0]
    base = np.array([a * r0, a, n * r0, n, 0.0])
    mode = np.zeros((8, 4))
    for column, (offset, power) in enumerate(((0, 2), (0, 4), (4, 2), (4, 4))):
        mode[offset : offset + 4, column] = [
            r0**power,
            power * r0 ** (power - 1),
            power * (power - 1) * r0 ** (power - 2),
            power * (power - 1) * (power - 2) * r0 ** (power - 3),
        ]

    def rates(r: float, y: Array) -> Array:  # the bowl's 5 unknowns, then the 8 × 4 of the modes
        base, mode = y[:5], y[5:].reshape(8, 4)
        return np.concatenate([_rates(r, base, D, Et), _mode_rates(r, base, mode, D, Et).ravel()])

    y = _integrate(rates, np.concatenate([base, mode.ravel()]), _radii(radius, steps))
    mode = y[5:].reshape(8, 4)
    R = radius
    W, W1, W2, W3, P, P1, _, _ = mode
    conditions = np.array(
        [
            W2 + nu * (W1 / R - 4 * W / R**2),
            W3 + W2 / R - 5 * W1 / R**2 + 8 * W / R**3 - 4 * (1 - nu) * (W1 / R**2 - W / R**3),
            P,
            P1,
        ]
    )
    conditions /= np.linalg.norm(conditions, axis=0)  # the solutions' scales
    conditions /= np.linalg.norm(conditions, axis=1)[:, None]  # the conditions' units
    return float(np.linalg.det(conditions))


def bifurcation(thickness: float, radius: float = 1.0, nu: float = 0.3, steps: int = 500) -> float:
    """The natural curvature κ₀ where the exact bowl bifurcates into the cos 2θ mode.

    Args:
        thickness: t.
        radius: R.
        nu: ν.
        steps: Runge–Kutta steps from the centre to the rim (the error is O(steps⁻⁴):
            3·10⁻⁹ relative at 500 steps, 3·10⁻⁸ at 250).

    Returns:
        κ₀ at the root of the rim's determinant (module docstring).
    """
    k0, _ = uniform_bifurcation(thickness, radius, nu)
    x0, x1 = k0, 1.02 * k0
    f0 = _rim_determinant(x0, thickness, radius, nu, steps)
    f1 = _rim_determinant(x1, thickness, radius, nu, steps)
    for _ in range(50):
        if f1 == f0:
            break
        x0, f0, x1 = x1, f1, x1 - f1 * (x1 - x0) / (f1 - f0)
        if abs(x1 - x0) <= 1e-12 * abs(x1):
            return x1
        f1 = _rim_determinant(x1, thickness, radius, nu, steps)
    raise ArithmeticError("the bowl's bifurcation was not found")
