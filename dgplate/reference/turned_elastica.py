"""The turned clamped–clamped strip as an elastica: its thresholds at finite end shortening.

The shallow (FvK) thresholds of :func:`dgplate.reference.fvk.clamped_strip_thresholds` hold in
the limit Δ/L → 0. This module computes them without that limit: the strip is a planar rod of
length L (ν = 0: a beam of bending stiffness B = EI and axial stiffness EA = 12B/t²), clamped at
both ends, its ends pushed together by Δ and both clamps turned by the angle α against its
inverted (buckled-down) state: θ(0) = α, θ(L) = −α, x(L) = L − Δ, y(L) = 0. With the
contact force (−P, Q) constant along the rod, the axial strain ε = (−P cos θ + Q sin θ)/EA and
the arc length s of the unstretched rod, the equilibrium equations are those of Reissner's
extensible elastica (no shear):

    θ′ = m/B,   m′ = −(1 + ε)(P sin θ + Q cos θ),   x′ = (1 + ε) cos θ,   y′ = (1 + ε) sin θ.

- The **inverted state** is symmetric: Q = 0 and θ odd about s = L/2, so it is found on the half
  rod by shooting in (α, m(0)) at a given P to θ(L/2) = 0, x(L/2) = (L − Δ)/2.
- It **folds** where α is largest along the branch: there the Jacobian of that shooting map in
  (m(0), P) at fixed α is singular.
- It **bifurcates** where an antisymmetric perturbation exists: δθ even about L/2 (δP = 0,
  δQ ≠ 0), i.e. where the half rod's map (m(0), Q) ↦ (m(L/2), y(L/2)) at fixed α and P is
  singular (δm(L/2) = 0 makes δθ even; δy(L/2) = 0 then keeps y(L) = 0).

In the shallow limit (Δ/L → 0, t²/(ΔL) fixed) these are the closed forms of
:func:`~dgplate.reference.fvk.clamped_strip_thresholds`, and at α = 0 the inverted state is the
clamped elastica of :mod:`dgplate.reference.elastica` (both checked in
tests/models/test_fvk_path.py). The equations are integrated by the classical Runge–Kutta
method of order 4 on ``steps`` steps of the half rod, vectorised over the shots of a
central-difference Jacobian; the thresholds are roots of smooth functions of P, found by the
secant method from the shallow values. Derived and written here (no SciPy, as in
:mod:`dgplate.reference.elastica`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from dgplate.reference.fvk import (
    TAU_ANTISYMMETRIC,
    clamped_strip_thresholds,
    turned_strip_fold_tau,
    turned_strip_slope_factor,
)

__all__ = ["turned_strip_elastica_thresholds"]

Array = npt.NDArray[np.float64]

#: The central-difference steps, relative to the unknowns' scales a, a√P, P and aP (a the
#: angles' scale, :func:`_angle_scale`).
_H = 1e-4


def _angle_scale(base: Array) -> float:
    """The scale of the angles at (α, m(0), P, Q): the larger of |α| and |m(0)|/√P."""
    return max(abs(float(base[0])), abs(float(base[1])) / math.sqrt(float(base[2])))


class _HalfRod:
    """The half rod 0 ≤ s ≤ ½ (L = B = 1) of the turned strip, shot from its clamp.

    Args:
        shortening: Δ/L.
        stretch: B/(EA L²) = t²/(12L²).
        steps: Runge–Kutta steps over the half rod.
    """

    def __init__(self, shortening: float, stretch: float, steps: int) -> None:
        self.shortening, self.stretch, self.steps = shortening, stretch, steps
        self.last: Array | None = None

    def _rates(self, state: Array, force: Array) -> Array:
        theta, moment = state[0], state[1]
        P, Q = force
        cos, sin = np.cos(theta), np.sin(theta)
        extension = 1 + self.stretch * (-P * cos + Q * sin)
        return np.stack(
            [moment, -extension * (P * sin + Q * cos), extension * cos, extension * sin]
        )

    def shoot(self, alpha: Array, moment: Array, P: Array, Q: Array) -> Array:
        """(θ, m, x, y) at s = ½ of the shots from θ(0) = α, m(0) = moment (arrays alike)."""
        state = np.stack([alpha, moment, np.zeros_like(alpha), np.zeros_like(alpha)])
        force, h = np.stack([P, Q]), 0.5 / self.steps
        for _ in range(self.steps):
            k1 = self._rates(state, force)
            k2 = self._rates(state + 0.5 * h * k1, force)
            k3 = self._rates(state + 0.5 * h * k2, force)
            k4 = self._rates(state + h * k3, force)
            state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return state

    def jacobian(self, base: Array, unknowns: tuple[int, ...]) -> tuple[Array, Array]:
        """The end state at ``base`` = (α, m(0), P, Q) and its derivatives in ``unknowns``.

        Returns:
            (end, J): the end state (4,) and J[i, j] = ∂end_i/∂base_unknowns[j] (central
            differences, all shots in one integration).
        """
        alpha, P = _angle_scale(base), base[2]
        steps = _H * np.array([alpha, alpha * math.sqrt(P), P, alpha * P])[list(unknowns)]
        shots = np.tile(base[:, None], (1, 1 + 2 * len(unknowns)))
        for j, k in enumerate(unknowns):
            shots[k, 1 + 2 * j] += steps[j]
            shots[k, 2 + 2 * j] -= steps[j]
        end = self.shoot(*shots)
        J = (end[:, 1::2] - end[:, 2::2]) / (2 * steps)
        return end[:, 0], J

    def inverted(self, P: float, guess: tuple[float, float]) -> Array:
        """The inverted state at the force P: (α, m(0), P, 0), by Newton from ``guess``."""
        base = np.array([guess[0], guess[1], P, 0.0])
        target = np.array([0.0, 0.5 * (1 - self.shortening)])
        previous = math.inf
        for _ in range(50):
            end, J = self.jacobian(base, (0, 1))
            update = np.linalg.solve(J[[0, 2]], end[[0, 2]] - target)
            base[:2] -= update
            scale = _angle_scale(base)
            size = max(abs(update[0]) / scale, abs(update[1]) / (scale * math.sqrt(P)))
            # the update, not the residual (x(½) ≈ ½ holds to round-off only): small, or no
            # longer falling fourfold once small (round-off, the smaller Δ the larger)
            if size <= 1e-13 or (size <= 1e-9 and size > previous / 4):
                return base
            previous = size
        raise ArithmeticError(f"the inverted state at P = {P:g} did not converge")

    def inverted_at(self, tau: float) -> Array:
        """The inverted state at P = τ², from the last one found (at first the shallow one)."""
        if self.last is None:  # the shallow state: θ = −c τ sin(τ(s − ½)), m(0) = −α τ cot(τ/2)
            alpha = turned_strip_slope_factor(tau) * math.sqrt(
                self.shortening - tau * tau * self.stretch
            )
            start = (alpha, -alpha * tau / math.tan(tau / 2))
        else:
            start = (float(self.last[0]), float(self.last[1]))
        self.last = self.inverted(tau * tau, start)
        return self.last

    def fold_measure(self, state: Array) -> float:
        """dα/dP along the inverted branch at ``state`` (zero at the fold)."""
        _, J = self.jacobian(state, (0, 1, 2))
        J = J[[0, 2]]
        return float(-np.linalg.solve(J[:, :2], J[:, 2])[0])

    def bifurcation_measure(self, state: Array) -> float:
        """The determinant of ∂(m(½), y(½))/∂(m(0), Q) at fixed α, P (zero at the bifurcation)."""
        _, J = self.jacobian(state, (1, 3))
        return float(np.linalg.det(J[[1, 3]]))


def _secant(f: Callable[[float], float], a: float, b: float, what: str) -> float:
    """A root of f by the secant method from a, b (close to it)."""
    fa, fb = f(a), f(b)
    for _ in range(40):
        if fb == fa:
            break
        a, b, fa = b, b - fb * (b - a) / (fb - fa), fb
        if abs(b - a) <= 1e-10 * abs(b):
            return b
        fb = f(b)
    raise ArithmeticError(f"the turned elastica's {what} was not found")


def turned_strip_elastica_thresholds(
    delta: float, t: float = 0.0, L: float = 1.0, steps: int = 400
) -> dict[str, float]:
    """The clamp angles at which the turned strip's inverted state ends, as an elastica.

    The set-up of :func:`dgplate.reference.fvk.clamped_strip_thresholds` without the shallow
    approximation (see the module's docstring): the bifurcation onto the antisymmetric mode and
    the fold of the inverted state, at the finite end shortening Δ.

    Args:
        delta: the end shortening Δ, 0 < Δ/L < ½ (Newton starts from the shallow state, so
            the larger Δ/L beyond about 0.2, the likelier it fails).
        t: the thickness (t = 0: inextensible).
        L: the length of the rod.
        steps: Runge–Kutta steps over the half rod (400: the angles to about 2·10⁻¹⁰; the
            error falls as steps⁻⁴).

    Returns:
        ``bifurcation`` and ``fold``: the clamp angles α (radians; the clamps' slopes are
        tan α), and ``tau_bifurcation``, ``tau_fold``: L√(P/B) there.
    """
    if not 0 < delta / L < 0.5:
        raise ValueError(f"the end shortening must lie in (0, L/2), got Δ/L = {delta / L:g}")
    clamped_strip_thresholds(delta, t, L)  # a ValueError for too thick a strip, or too short Δ
    shallow_fold = turned_strip_fold_tau(delta, t, L)
    rod = _HalfRod(delta / L, t * t / (12 * L * L), steps)

    def root(measure: Callable[[Array], float], start: float, name: str) -> float:
        return _secant(lambda x: measure(rod.inverted_at(x)), start, start * 1.001, name)

    thresholds: dict[str, float] = {}
    for name, measure, start in (
        ("bifurcation", rod.bifurcation_measure, TAU_ANTISYMMETRIC),
        ("fold", rod.fold_measure, shallow_fold),
    ):
        tau = root(measure, start, name)
        thresholds[name] = float(rod.inverted_at(tau)[0])
        thresholds[f"tau_{name}"] = tau
    if not 0 < thresholds["bifurcation"] < thresholds["fold"]:
        raise ArithmeticError(f"the turned elastica left its inverted state: {thresholds}")
    if not thresholds["tau_bifurcation"] < thresholds["tau_fold"]:
        raise ValueError(
            f"t = {t:g} is too thick for Δ = {delta:g}: the inverted elastica folds "
            f"(τ = {thresholds['tau_fold']:.4f}) before it meets the antisymmetric mode"
        )
    return thresholds
