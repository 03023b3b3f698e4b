"""A rigid obstacle by penalty and a quadratic–concave splitting (docs/obstacle.md).

The plate y must keep a signed distance s(y) ≥ 0 from a rigid obstacle; the penalty

    P_ε[y] = (1/2ε) ∫_ω (s(y))₋²,      (s)₋ = min(s, 0),

is added to the energy. The gradient flow needs a quadratic part (its constant step matrix)
and a part it evaluates at yⁿ. With (s)₋² = s² − (s)₊²:

* s linear in y (``above``, ``below``, ``plane``): (1/2ε)∫s² is quadratic and convex, it goes
  into ``Energy.implicit``; −(1/2ε)∫(s)₊² is concave, into ``Energy.explicit``. A convex part
  taken implicitly and a concave part explicitly make the step unconditionally energy stable,
  and every step is a linear problem with a constant matrix.
* s not linear (``sphere``): the isotropic stabilisation. Implicit (1/2ε)∫|y − c|², explicit
  P_ε − (1/2ε)∫|y − c|². The explicit part is concave because the Hessian of ½(s)₋² is at most
  the identity for the distance to a sphere from either side (docs/obstacle.md), so the step is
  again stable with a constant matrix.

The price of the splitting: the implicit part puts (1/ε) times an L² mass into the step
matrix everywhere, also where the plate is far from the obstacle, so free parts move at most
~ε·(force) per step in the constrained direction. Small ε needs many steps.

The obstacle ``above``/``below`` a height ψ(x₁, x₂) is Lagrangian: ψ is evaluated at each
material point's reference position (exact for a constant ψ, an approximation when the plate
slides in-plane over a varying ψ); planes and spheres are spatial obstacles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import ufl
from ufl.core.expr import Expr

from dgplate import expressions, values
from dgplate.compat import Mesh
from dgplate.dg.energy import Energy
from dgplate.errors import InputError
from dgplate.schema import is_number

#: The obstacle types of ``model.obstacle.type``.
TYPES = ("above", "below", "plane", "sphere")
#: The keys of ``model.obstacle``: which each type takes besides ``type`` and ``epsilon``.
_KEYS = {
    "above": ("psi",),
    "below": ("psi",),
    "plane": ("normal", "point"),
    "sphere": ("center", "radius", "side"),
}
_SIDES = ("outside", "inside")


def _vector(value: object, key: str) -> tuple[float, float, float]:
    """Three finite numbers."""
    if not isinstance(value, list) or len(value) != 3 or not all(is_number(v) for v in value):
        raise InputError(f"{key} must be a list of 3 numbers, got {value!r}")
    numbers = tuple(float(v) for v in value)
    if not all(math.isfinite(v) for v in numbers):
        raise InputError(f"{key} must be finite, got {value!r}")
    return numbers[0], numbers[1], numbers[2]


@dataclass(frozen=True)
class Obstacle:
    """A validated ``model.obstacle`` table (see :data:`TYPES`).

    ``above``: y₃ ≥ ψ; ``below``: y₃ ≤ ψ (ψ a number or a formula in x, y); ``plane``:
    n·(y − p) ≥ 0 (the plate stays on the side n points to); ``sphere``: |y − c| ≥ R
    (``side = "outside"``) or ≤ R (``"inside"``). ``epsilon`` is the penalty parameter ε > 0.
    """

    kind: str
    epsilon: float
    psi: float | str = 0.0
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 1.0
    side: str = "outside"

    @classmethod
    def from_table(cls, table: object, key: str = "model.obstacle") -> Obstacle | None:
        """The obstacle of a problem file's table; ``{}`` (no obstacle) gives None.

        Unknown types and keys, ε ≤ 0, malformed vectors, radii and formulas are one-line
        ``InputError`` lines naming the key.
        """
        if not isinstance(table, dict):
            raise InputError(f"{key} must be a table {{type = ..., epsilon = ...}}, got {table!r}")
        if not table:
            return None
        kind = table.get("type")
        if kind not in TYPES:
            raise InputError(f"{key}.type must be one of {', '.join(TYPES)}, got {kind!r}")
        known = ("type", "epsilon", *_KEYS[kind])
        unknown = sorted(set(table) - set(known))
        if unknown:
            raise InputError(
                f"unknown key {key}.{unknown[0]} for type '{kind}' (known: {', '.join(known)})"
            )
        epsilon = table.get("epsilon", 1e-4)
        if not (is_number(epsilon) and epsilon > 0 and math.isfinite(epsilon)):
            raise InputError(f"{key}.epsilon must be a number > 0, got {epsilon!r}")
        data: dict[str, Any] = {"kind": kind, "epsilon": float(epsilon)}
        data.update(_parse_geometry(kind, table, key))
        return cls(**data)

    @property
    def linear(self) -> bool:
        """Whether s(y) is affine in y (exact quadratic–concave splitting)."""
        return self.kind != "sphere"

    def distance(self, y: Expr, mesh: Mesh, key: str = "model.obstacle") -> Expr:
        """s(y): ≥ 0 where y is admissible, < 0 by the penetration depth (a UFL scalar)."""
        if self.kind in ("above", "below"):
            height = _height(expressions.parse(self.psi, mesh, f"{key}.psi"), mesh)
            gap: Expr = y[2] - height if self.kind == "above" else height - y[2]
            return gap
        if self.kind == "plane":
            norm = math.sqrt(sum(v * v for v in self.normal))
            n = values.constant(mesh, [v / norm for v in self.normal])
            p = values.constant(mesh, list(self.point))
            plane: Expr = ufl.dot(n, y - p)
            return plane
        c = values.constant(mesh, list(self.center))
        R = values.constant(mesh, self.radius)
        r = ufl.sqrt(ufl.dot(y - c, y - c))
        sphere: Expr = r - R if self.side == "outside" else R - r
        return sphere

    def contact_densities(self, s: Expr, mesh: Mesh) -> tuple[Expr, Expr]:
        """The indicator of contact 1_{s < 0} and the contact pressure (1/ε)(s)₋ ≥ 0."""
        indicator: Expr = ufl.conditional(ufl.lt(s, 0.0), 1.0, 0.0)
        pressure: Expr = -ufl.min_value(s, 0.0) / values.constant(mesh, self.epsilon)
        return indicator, pressure

    def energy(self, y: Expr, mesh: Mesh, degree: int) -> Energy:
        """The penalty P_ε split into an implicit (convex quadratic) and an explicit part.

        ``degree``: the polynomial degree of y; the quadrature has degree 2k + 2 for both parts,
        so that they cancel exactly where no contact is.
        """
        dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": 2 * degree + 2})
        inv = 1.0 / values.constant(mesh, self.epsilon)
        s = self.distance(y, mesh)
        negative = ufl.min_value(s, 0.0)
        if self.linear:
            implicit: ufl.Form = 0.5 * inv * s * s * dx
            explicit: ufl.Form = -0.5 * inv * ufl.max_value(s, 0.0) ** 2 * dx
        else:
            shift = y - values.constant(mesh, list(self.center))
            implicit = 0.5 * inv * ufl.dot(shift, shift) * dx
            explicit = 0.5 * inv * (negative**2 - ufl.dot(shift, shift)) * dx
        return Energy(implicit=implicit, explicit=explicit)


def _height(psi: float | Expr, mesh: Mesh) -> Expr:
    """ψ as a value of the forms: a Constant when it is a number or folds to one."""
    if isinstance(psi, float | ufl.constantvalue.ScalarValue):  # "0.2 + 0*x" folds to 0.2
        return values.constant(mesh, float(psi))
    return psi


def _parse_geometry(kind: str, table: dict[str, Any], key: str) -> dict[str, Any]:
    """The keys of one obstacle type, checked (ψ as a formula, vectors, radius, side)."""
    if kind in ("above", "below"):
        psi = table.get("psi", 0.0)
        expressions.check(psi, f"{key}.psi")
        return {"psi": float(psi) if is_number(psi) else psi}
    if kind == "plane":
        normal = _vector(table.get("normal", [0.0, 0.0, 1.0]), f"{key}.normal")
        if math.sqrt(sum(v * v for v in normal)) == 0.0:
            raise InputError(f"{key}.normal must not be the zero vector")
        return {
            "normal": normal,
            "point": _vector(table.get("point", [0.0, 0.0, 0.0]), f"{key}.point"),
        }
    radius = table.get("radius", 1.0)
    if not (is_number(radius) and radius > 0 and math.isfinite(radius)):
        raise InputError(f"{key}.radius must be a number > 0, got {radius!r}")
    side = table.get("side", "outside")
    if side not in _SIDES:
        raise InputError(f"{key}.side must be 'outside' or 'inside', got {side!r}")
    center = _vector(table.get("center", [0.0, 0.0, 0.0]), f"{key}.center")
    return {"center": center, "radius": float(radius), "side": side}
