"""Reference values for the Föppl–von Kármán model: published tables and exact solutions.

- Linear Kirchhoff plate, uniform load q on a square of side a, centre deflection in units of
  q a⁴/D: simply supported 0.00406, clamped 0.00126 (Timoshenko & Woinowsky-Krieger, *Theory of
  Plates and Shells*, 2nd ed., 1959, Tables 8 and 35); the series give 0.0040624 (Navier, below)
  and 0.0012653.
- Large deflection: Levy, *Square plate with clamped edges under normal pressure producing large
  deflections*, NACA Report 740 (1942), also NACA TN 847, Table 5: centre deflection w_c/t of a
  clamped square plate against Q = p a⁴/(E t⁴), ν = 0.316, edges held against in-plane
  displacement normal to the edge and free to slide along it. (Digits as transcribed in public
  sources; see docs/fvk.md.)
- Cylindrical bending of a strip clamped and held at both ends, with or without a hinge
  (crease) in the middle: an exact FvK solution for ν = 0 (the 2D plate with free long edges is
  then exactly one-dimensional).
- Snap-through of a shallow sinusoidal strip (:func:`sinusoidal_strip_folds`): ν = 0, pinned
  and immovable ends, natural shape e sin(πx/L), pressure q sin(πx/L); the one-mode solution is
  exact and derived there, as in the classical analysis of low arches (Timoshenko, J. Appl.
  Mech. 2, 1935; Fung & Kaplan, NACA TN 2840, 1952) but with the bending measured from flat.
- Snap-through of a clamped–clamped strip whose clamps are turned against its buckled shape
  (:func:`clamped_strip_thresholds`): ν = 0, ends pushed together by Δ, then turned by ±α; the
  inverted state meets the antisymmetric mode and folds at thresholds in closed form, derived
  there from the shallow (FvK) beam equations.
- Euler buckling of a simply supported square plate under uniaxial end shortening:
  N_cr = 4π²D/a² (Timoshenko & Gere, §9.2, k = 4), :func:`square_plate_critical_shortening`;
  with the unloaded edges held straight and immovable, the buckling shortening and Koiter's
  initial post-buckling slope (:func:`held_square_plate_postbuckling`, exact one-mode solution).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]

SIMPLY_SUPPORTED_PUBLISHED, CLAMPED_PUBLISHED = 0.00406, 0.00126
CLAMPED_SERIES = 0.0012653

LEVY_NU = 0.316
LEVY_Q = (17.79, 38.3, 63.4, 95.0, 134.9, 184.0, 245.0, 318.0, 402.0)
LEVY_W = (0.237, 0.471, 0.695, 0.912, 1.121, 1.323, 1.521, 1.714, 1.902)


def navier_simply_supported(terms: int = 401, compression: float = 0.0) -> float:
    """Centre deflection of the simply supported square plate in units of q a⁴/D (linear).

    ``compression`` = N/N_cr adds an equibiaxial membrane compression N (N_cr = 2π²D/a², the
    buckling load of the square under equal compression in both directions).
    """
    m = np.arange(1, terms + 1, 2)
    M, N = np.meshgrid(m, m)
    signs = (-1.0) ** ((M + N) // 2 - 1)
    k2 = M**2 + N**2
    return float(16 / np.pi**6 * np.sum(signs / (M * N * (k2**2 - 2 * compression * k2))))


def _series(
    z: npt.ArrayLike, coefficients: Sequence[float], direct: Callable[[Array], Array]
) -> Array:
    """The function ``direct`` at z, or its Taylor series in z² where |z| < 1.

    The series has no cancellation for small z.
    """
    z = np.atleast_1d(np.asarray(z, dtype=float))
    small = np.abs(z) < 1
    out = np.empty_like(z)
    square, series = z[small] ** 2, np.zeros(np.count_nonzero(small))
    for c in reversed(coefficients):  # Horner's scheme in z²
        series = series * square + c
    out[small] = series
    out[~small] = direct(z[~small])
    return out


def _sinhc(z: npt.ArrayLike) -> Array:
    """The function sinh z / z."""
    terms = [1 / math.factorial(2 * i + 1) for i in range(9)]
    return _series(z, terms, lambda z: np.sinh(z) / z)


def _coshc(z: npt.ArrayLike) -> Array:
    """The function 2 (cosh z − 1) / z²."""
    terms = [2 / math.factorial(2 * i + 2) for i in range(9)]
    return _series(z, terms, lambda z: 2 * (np.cosh(z) - 1) / z**2)


def _f3(z: npt.ArrayLike) -> Array:
    """The function (sinh z − z) / z³."""
    terms = [1 / math.factorial(2 * i + 3) for i in range(9)]
    return _series(z, terms, lambda z: (np.sinh(z) - z) / z**3)


def _f4(z: npt.ArrayLike) -> Array:
    """The function (cosh z − 1 − z²/2) / z⁴."""
    terms = [1 / math.factorial(2 * i + 4) for i in range(9)]
    return _series(z, terms, lambda z: (np.cosh(z) - 1 - z**2 / 2) / z**4)


def strip_centre_deflection(q: float, L: float, E: float, t: float, hinge: bool) -> float:
    """Centre deflection of a strip (ν = 0) clamped and held (u = 0) at x = 0 and x = L.

    Each half carries a tension N = D k²: D w'''' − N w'' = q, w = w' = 0 at x = 0 and, at the
    centre x = ℓ = L/2, a hinge (w'' = 0, D w''' − N w' = 0) or symmetry (w' = 0, w''' = 0).
    With C = (cosh kx − 1)/k², S = (sinh kx − kx)/k³ and P = (cosh kx − 1 − (kx)²/2)/k⁴,
    w = c₂ C + c₃ S + q P/D; these are evaluated without cancellation for small kx, so beam
    theory is the limit N → 0. The held ends fix N = (E t/L) ∫₀^ℓ w'² dx (bisection on log N).
    """
    D, A, ell = E * t**3 / 12, E * t, L / 2
    x = np.linspace(0.0, ell, 4001)

    def shape(N: float) -> tuple[float, Array]:
        """w(ℓ) and w' at the points x for the tension N."""
        k = np.sqrt(N / D)
        z, zl = k * x, k * ell
        sh_k = ell * _sinhc(zl)[0]  # sinh(kℓ)/k
        cm_k2 = ell**2 * _coshc(zl)[0] / 2  # (cosh kℓ − 1)/k²
        ch = 1 + k**2 * cm_k2  # cosh kℓ
        s_l = ell**3 * _f3(zl)[0]
        if hinge:  # the shear condition gives c₃ = −qℓ/D; then w''(ℓ) = 0
            c3 = -q * ell / D
            c2 = -(c3 * sh_k + q * cm_k2 / D) / ch
        else:  # w'(ℓ) = 0, w'''(ℓ) = 0
            M = np.array([[sh_k, cm_k2], [k**2 * sh_k, ch]])
            c2, c3 = np.linalg.solve(M, [-q * s_l / D, -q * sh_k / D])
        w_l = float(c2 * cm_k2 + c3 * s_l + q * ell**4 * _f4(zl)[0] / D)
        dw = c2 * x * _sinhc(z) + c3 * x**2 * _coshc(z) / 2 + q * x**3 * _f3(z) / D
        return w_l, dw

    def excess(N: float) -> float:
        """N minus the tension that the deflection of N stretches the strip to."""
        dw = shape(N)[1]
        return N - A / L * float(np.sum((dw[1:] ** 2 + dw[:-1] ** 2) / 2 * np.diff(x)))

    lo, hi = 1e-14 * A, A
    for _ in range(200):  # about 60 halvings of log N reach round-off
        mid = math.sqrt(lo * hi)
        if not lo < mid < hi:
            break
        lo, hi = (mid, hi) if excess(mid) < 0 else (lo, mid)
    return shape(math.sqrt(lo * hi))[0]


def sinusoidal_strip_folds(E: float, t: float, L: float, e: float) -> tuple[float, float]:
    """The limit point (q*, a*) of a shallow sinusoidal FvK strip, ν = 0, pinned immovable ends.

    The natural shape w₀ = e sin(πx/L) and the pressure q sin(πx/L) (along +z) keep the
    deflection w = a sin(πx/L): the membrane force N = E t (π/L)² (a² − e²)/4 is constant and
    the bending moment is measured from flat, so equilibrium is

        q = (π/L)⁴ a [D + E t (a² − e²)/4],   D = E t³/12,

    (derived here; the classical low-arch analysis of Fung & Kaplan, *Buckling of low arches or
    curved beams of small curvature*, NACA TN 2840, 1952, with the bending measured from flat). The
    unloaded arch a₀² = e² − t²/3 exists for e² > t²/3; q has its extremes where dq/da = 0,
    a*² = (e² − t²/3)/3, and no unsymmetric mode bifurcates first for e² < 11t²/6.

    Args:
        E: Young's modulus.
        t: thickness.
        L: span.
        e: rise of the natural shape (t²/3 < e² < 11t²/6).

    Returns:
        (q*, a*): the downward pressure amplitude at the fold of the upward arch (q* > 0, the
        pressure −q* sin(πx/L)) and the rise of the arch there.
    """
    if not t * t / 3 < e * e < 11 * t * t / 6:
        raise ValueError(f"the rise e = {e:g} must satisfy t²/3 < e² < 11t²/6 (t = {t:g})")
    a = math.sqrt((e * e - t * t / 3) / 3)
    return sinusoidal_strip_load(a, E, t, L, e), a


def sinusoidal_strip_load(a: float, E: float, t: float, L: float, e: float) -> float:
    """The downward pressure amplitude q at which w = a sin(πx/L) is an equilibrium.

    The strip of :func:`sinusoidal_strip_folds`: q = −(π/L)⁴ a [D + E t (a² − e²)/4] for the
    pressure −q sin(πx/L), D = E t³/12. For e² < 4t²/3 (e = t in the demos) every equilibrium
    of the strip is one of these, so this is the whole equilibrium curve: from the arch a₀
    through the fold a* and the flat strip to the fold −a* and the snapped arch (for larger e
    antisymmetric equilibria, N = −4π²D/L², branch off the middle segment at a² = e² − 4t²/3).
    The cubic is odd in a, and q − q* has the double root a*, so the snapped arch under q* has
    a = −2a*.

    Args:
        a: the rise (the centre deflection).
        E: Young's modulus.
        t: thickness.
        L: span.
        e: rise of the natural shape.

    Returns:
        q (positive: downward).
    """
    k4, D = (math.pi / L) ** 4, E * t**3 / 12
    return -k4 * a * (D + E * t * (a * a - e * e) / 4)


def square_plate_critical_shortening(t: float, a: float, nu: float) -> float:
    """Δ_cr = N_cr a/(E t) = π² t²/(3(1 − ν²) a) of a simply supported square plate (k = 4).

    Args:
        t: the thickness.
        a: the side.
        nu: Poisson's ratio.

    Returns:
        The shortening Δ_cr of the loaded edge at the buckling load.
    """
    return math.pi**2 * t * t / (3 * (1 - nu * nu) * a)


def held_square_plate_postbuckling(t: float, a: float, nu: float) -> tuple[float, float]:
    """Buckling and initial post-buckling of the square plate with held unloaded edges.

    The square 0 < x, y < a, simply supported (w = 0) on all four edges; the loaded edges x = 0
    and x = a straight, u = 0 and u = −Δ, free to slide along themselves (N_xy = 0); the
    unloaded edges y = 0, a held straight and immovable, v = 0, free to slide (N_xy = 0). Before
    buckling N_y = ν N_x, so the mode w = f sin(πx/a) sin(πy/a) appears at N_x = 4π²D/(a²(1+ν)),

        Δ_c = π² t²/(3 (1 + ν) a),

    and on the buckled branch

        Δ/Δ_c = 1 + (3/8)(3 − ν)(1 + ν)(f/t)² + O(f⁴).

    Derived here by the one-mode method of the classical large-deflection analysis of buckled
    plates (Marguerre, *Die mittragende Breite der gedrückten Platte*, Luftfahrtforschung 14,
    1937; Timoshenko & Gere, *Theory of Elastic Stability*, 2nd ed. 1961, ch. 9): the Airy
    function F = E t f²/32 [cos(2πx/a) + cos(2πy/a)] − N_x y²/2 − N_y x²/2 solves the
    compatibility equation for w exactly, has N_xy ≡ 0, and its displacements keep all four
    edges straight with v = 0 on y = 0 and y = a once N_y = ν N_x − π²E t f²/(8a²) (checked by
    integrating the strains), so it is the exact membrane field of w. The Galerkin equation of
    the mode, N_x + N_y = 4π²D/a² + π²E t f²/(8a²), and the shortening
    Δ = (N_x − ν N_y) a/(E t) + π² f²/(8a) give the relation. The coefficient is Koiter's
    initial post-buckling slope exactly: by w ↦ −w the second-order field is the membrane field
    of the mode alone (resolved here without approximation), and the deflection's correction
    orthogonal to the mode enters the energy only at order f⁶. The terms O(f⁴) are not those of
    the one-mode solution. (With the unloaded edges straight but free to move, N_y = 0, the
    same steps give Δ/Δ_cr = 1 + (3/4)(1 − ν²)(f/t)²; with one unloaded edge stress-free the
    membrane field of the mode has no such closed form.)

    Args:
        t: the thickness.
        a: the side.
        nu: Poisson's ratio.

    Returns:
        (Δ_c, b): the buckling shortening and the slope b = d(Δ/Δ_c)/d((f/t)²) at f = 0.
    """
    return math.pi**2 * t * t / (3 * (1 + nu) * a), 3 * (3 - nu) * (1 + nu) / 8


def turned_strip_slope_factor(tau: float) -> float:
    """μ(τ) = 2|sin(τ/2)|/√(1 − sin τ/τ): α/√(½∫w′²) on the symmetric branch of compression τ.

    The shallow strip 0 < ξ < 1 clamped with w(0) = w(1) = 0, w′(0) = −w′(1) = α under the
    compression N = −Dτ² (w′′′′ + τ²w′′ = 0) has one symmetric deflection for τ ≠ 2πk, a
    combination of 1, ξ, cos τξ and sin τξ, whose ½∫w′² integrates to α²/μ(τ)² (derived here;
    checked against quadrature in tests/models/test_fvk_path.py).

    Args:
        tau: the compression τ = L√(−N/D), away from the zeros of sin(τ/2).

    Returns:
        μ(τ).
    """
    return 2 * abs(math.sin(tau / 2)) / math.sqrt(1 - math.sin(tau) / tau)


def _bisect(f: Callable[[float], float], a: float, b: float) -> float:
    """The root of f in [a, b] (f(a), f(b) of opposite signs) to round-off, by bisection."""
    fa = f(a)
    for _ in range(200):
        m = 0.5 * (a + b)
        if m in (a, b):
            break
        if (f(m) > 0) == (fa > 0):
            a, fa = m, f(m)
        else:
            b = m
    return 0.5 * (a + b)


def _argmax(f: Callable[[float], float], a: float, b: float) -> float:
    """The maximiser of a unimodal f on [a, b], by golden-section search to round-off."""
    ratio = (math.sqrt(5) - 1) / 2
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    while b - a > 1e-12 * max(1.0, abs(b)):
        if f(c) > f(d):
            b, d = d, c
            c = b - ratio * (b - a)
        else:
            a, c = c, d
            d = a + ratio * (b - a)
    return 0.5 * (a + b)


#: The first compression above 2π at which an antisymmetric clamped mode exists:
#: tan(τ/2) = τ/2, τ = 8.98682 (the second Euler load of the clamped–clamped strip).
TAU_ANTISYMMETRIC = 2 * _bisect(lambda z: math.tan(z) - z, math.pi + 0.1, 1.5 * math.pi - 1e-9)


def clamped_strip_thresholds(delta: float, t: float, L: float = 1.0) -> tuple[float, float]:
    """The clamp angles at which the inverted state of a turned clamped–clamped strip ends.

    A strip of span L and thickness t (FvK, ν = 0: a beam) is clamped at both ends, its ends
    pushed together by Δ, so it buckles (down: the inverted state); then both clamps are turned
    by α against it, w′(0) = −w′(L) = α. The inverted state is the symmetric solution of
    w′′′′ + τ²w′′ = 0 with τ ∈ (2π, 4π), and the end shortening fixes τ through

        ½∫w′² dx = Δ − τ²t²/(12L)   (N L/(E t): the strip's own shortening),

    so α(τ) = μ(τ)√(Δ/L − τ²t²/(12L²)) (:func:`turned_strip_slope_factor`). Derived here:

    - at τ = τ_a = 8.98682 (tan(τ/2) = τ/2) the antisymmetric clamped mode becomes neutral: a
      simple bifurcation (the stability index goes from 0 to 1) at α_b = μ(τ_a)√(…), where
      μ(τ_a) = 2 exactly (there 1 − sin τ/τ = sin²(τ/2));
    - the symmetric branch turns (a fold, the index from 1 to 2) where α(τ) is largest:
      α_f/√(Δ/L) = 2.0119 at τ = 9.2032 in the inextensible limit t²/Δ → 0.

    In units of √(Δ/L), the thresholds tend to μ = α/√(Δ/L) = 2 and 2.0119 in the shallow,
    inextensible limit (to compare with the elastica at finite Δ/L).

    Args:
        delta: the end shortening Δ.
        t: the thickness.
        L: the span.

    Returns:
        (α_b, α_f): the clamp angles (slopes) at the bifurcation and at the fold; a ValueError
        when the strip is too thick for Δ to bifurcate before it folds (t²/(12ΔL) ≳ 0.004).
    """
    fold = turned_strip_fold_tau(delta, t, L)
    if fold <= TAU_ANTISYMMETRIC:
        raise ValueError(
            f"t = {t:g} is too thick for Δ = {delta:g}: the inverted state folds (τ = {fold:.4f}) "
            "before it meets the antisymmetric mode"
        )
    return _inverted_slope(TAU_ANTISYMMETRIC, delta, t, L), _inverted_slope(fold, delta, t, L)


def _inverted_slope(tau: float, delta: float, t: float, L: float) -> float:
    """α(τ) = μ(τ)√(Δ/L − τ²t²/(12L²)) on the symmetric branches of the turned strip."""
    return turned_strip_slope_factor(tau) * math.sqrt(delta / L - (tau * t / L) ** 2 / 12)


def turned_strip_fold_tau(delta: float, t: float, L: float = 1.0) -> float:
    """The compression τ at the fold of :func:`clamped_strip_thresholds`: α(τ) largest.

    Args:
        delta: the end shortening Δ.
        t: the thickness.
        L: the span.

    Returns:
        τ_f (9.2032 in the inextensible limit); a ValueError when Δ/L ≤ (4π)²t²/(12L²).
    """
    if delta / L <= 16 * math.pi**2 * t * t / (12 * L * L):
        raise ValueError(
            f"the shortening Δ = {delta:g} is too small for t = {t:g}: Δ/L > (4π)²t²/(12L²)"
        )
    return _argmax(
        lambda tau: _inverted_slope(tau, delta, t, L), TAU_ANTISYMMETRIC - 0.5, 4 * math.pi - 0.5
    )


def clamped_strip_natural_rise(alpha: float, delta: float, t: float, L: float = 1.0) -> float:
    """The centre deflection of the natural state of the turned strip of :func:`clamped_strip_thresholds`.

    The natural state is the symmetric solution buckled the way the clamps turn, with τ in
    (0, 2π): w = c (cos τ(x/L − ½) − cos(τ/2)), c = αL/(τ sin(τ/2)) from w′(0) = α, and τ
    fixed by the shortening, α = μ(τ)√(Δ/L − τ²t²/(12L²)) (:func:`turned_strip_slope_factor`).
    α falls from √6 √(Δ/L) (τ → 0) to 0 (τ → 2π, the first Euler mode). It is stable, and it is
    where the inverted state snaps to at its bifurcation α_b. Derived here, ν = 0 (a beam).

    Args:
        alpha: the clamp angle (slope), 0 < α < √(6Δ/L) (about; beyond it the strip is
            stretched).
        delta: the end shortening Δ.
        t: the thickness.
        L: the span.

    Returns:
        w_c = c (1 − cos(τ/2)) = αL tan(τ/4)/τ > 0.
    """
    shortening, stretch = delta / L, t * t / (12 * L * L)

    def slope(tau: float) -> float:
        return _inverted_slope(tau, delta, t, L) - alpha

    # τ above 10⁻³ keeps 1 − sin τ/τ ≈ τ²/6 clear of round-off; τ² stretch stays below the
    # shortening (the strip is compressed; t = 0: inextensible), and τ below 2π
    low = 1e-3
    compressed = math.sqrt(shortening / stretch) if stretch > 0 else math.inf
    high = min(2 * math.pi, compressed) * (1 - 1e-12)
    if not alpha > 0 or high <= low or slope(low) <= 0:
        raise ValueError(f"no natural state at α = {alpha:g} for Δ = {delta:g}, t = {t:g}")
    tau = _bisect(slope, low, high)
    return alpha * L * math.tan(tau / 4) / tau


def clamped_strip_antisymmetric_energy(
    alpha: float, delta: float, t: float, L: float = 1.0, E: float = 1.0, width: float = 1.0
) -> float:
    """The energy on the antisymmetric branch of the turned strip of :func:`clamped_strip_thresholds`.

    On that branch (the one that leaves the inverted state at its bifurcation α_b), τ stays at
    τ_a (tan(τ_a/2) = τ_a/2), so the compression −N = Dτ_a²/L² is constant, and
    w = α W_s + A W_a: W_s the symmetric solution with W_s′(0) = −W_s′(L) = 1,
    W_s′′(0) = −(τ_a/L) cot(τ_a/2) = −2/L, and W_a the antisymmetric clamped mode. The two are
    orthogonal in ½∫w′², so the shortening ½∫w′² = Δ − τ_a²t²/(12L) fixes A²∫W_a′² + α²∫W_s′²
    and the branch is a closed curve from α_b through α = 0 to −α_b, where it meets the
    mirrored inverted state. Integrating ∫w′′² by parts, with w′′′ + (τ_a/L)²w′ constant and
    w(0) = w(L) = 0, gives ∫w′′² = (τ_a/L)² ∫w′² − 2αW_s′′(0)α = (τ_a/L)² ∫w′² + 4α²/L (the
    antisymmetric part cancels at the two ends): derived here, with ν = 0 (a beam),

        Π = width · [D τ_a²/L² (Δ − τ_a²t²/(12L)) + 2Dα²/L + ½ E t L (τ_a²t²/(12L²))²],

    D = Et³/12: a parabola in α whose vertex is the clamped strip's second Euler mode.

    Args:
        alpha: the clamp angle (slope), |α| ≤ α_b.
        delta: the end shortening Δ.
        t: the thickness.
        L: the span.
        E: Young's modulus.
        width: the strip's width.

    Returns:
        The energy Π (bending and membrane) of the state at α on that branch.
    """
    D = E * t**3 / 12
    strain = TAU_ANTISYMMETRIC**2 * t * t / (12 * L * L)
    bending = D * TAU_ANTISYMMETRIC**2 / L**2 * (delta - strain * L) + 2 * D * alpha**2 / L
    return width * (bending + 0.5 * E * t * L * strain**2)
