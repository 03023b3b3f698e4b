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

The ``active_set`` treatment (``treatment = "active_set"``) restricts the implicit part to the
contact set A of the current state, an indicator χ at the quadrature points (:class:`ContactSet`):
implicit (1/2ε)∫χ s² (sphere: χ|y − c|²), explicit P_ε minus that. Where χ = 1 the explicit
part is concave as above; where χ = 0 it is (1/2ε)(s)₋², which does not act as long as s stays
≥ 0 there. So a step is energy stable when no point outside A enters contact: the flow enlarges A
by the points the trial step brought into contact and redoes the step (A only grows within a
step, so this ends). Free parts are then free of the (1/ε) mass, and ε can be small.

The obstacle ``above``/``below`` a height ψ(x₁, x₂) is Lagrangian: ψ is evaluated at each
material point's reference position (exact for a constant ψ, an approximation when the plate
slides in-plane over a varying ψ); planes and spheres are spatial obstacles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import basix.ufl
import dolfinx.fem
import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import compat, expressions, mpi, values
from dgplate.compat import Function, Mesh
from dgplate.dg.energy import Energy
from dgplate.errors import InputError
from dgplate.schema import REQUIRED, option

#: The obstacle types of ``model.obstacle.type``.
TYPES = ("above", "below", "plane", "sphere")
_SIDES = ("outside", "inside")
#: How the penalty enters the flow (``model.obstacle.treatment``).
TREATMENTS = ("splitting", "active_set")


@dataclass(frozen=True)
class Obstacle:
    """A validated ``model.obstacle`` table (see :data:`TYPES`).

    ``above``: y₃ ≥ ψ; ``below``: y₃ ≤ ψ (ψ a number or a formula in x, y); ``plane``:
    n·(y − p) ≥ 0 (the plate stays on the side n points to); ``sphere``: |y − c| ≥ R
    (``side = "outside"``) or ≤ R (``"inside"``). ``epsilon`` is the penalty parameter ε > 0.
    """

    #: The keys that only some types take (:func:`dgplate.schema.from_dict`).
    TYPE_KEYS: ClassVar[dict[str, tuple[str, ...]]] = {
        "above": ("psi",),
        "below": ("psi",),
        "plane": ("normal", "point"),
        "sphere": ("center", "radius", "side"),
    }

    type: str = option(
        REQUIRED, "above: y₃ ≥ ψ, below: y₃ ≤ ψ, plane: n·(y − p) ≥ 0, sphere", choices=TYPES
    )
    epsilon: float = option(1e-4, "the penalty parameter ε of (1/2ε)∫(s)₋²", gt=0)
    treatment: str = option(
        "splitting",
        "'splitting' (the convex part implicit, the concave part explicit) or 'active_set' (the implicit part on the last contact set only)",
        choices=TREATMENTS,
    )
    psi: float | str | None = option(
        None, "above, below: the height ψ, a number or a formula in x, y", shown="(required)"
    )
    normal: list[float] = option([0.0, 0.0, 1.0], "plane: the normal n", length=3, nonzero=True)
    point: list[float] = option([0.0, 0.0, 0.0], "plane: a point p of the plane", length=3)
    center: list[float] = option([0.0, 0.0, 0.0], "sphere: the centre c", length=3)
    radius: float = option(1.0, "sphere: the radius R", gt=0)
    side: str = option("outside", "sphere: which side the plate keeps to", choices=_SIDES)

    def validate(self, key: str) -> None:
        """ψ of above and below: given, and a valid formula.

        Args:
            key: the table's dotted key (``model.obstacle``), as named in messages.
        """
        if self.type in ("above", "below"):
            if self.psi is None:
                raise InputError(
                    f"{key}.psi is required for type '{self.type}': the obstacle's height ψ "
                    "(a number or a formula in x, y)"
                )
            expressions.check(self.psi, f"{key}.psi")

    @property
    def linear(self) -> bool:
        """Whether s(y) is affine in y (exact quadratic–concave splitting)."""
        return self.type != "sphere"

    def distance(self, y: Expr, mesh: Mesh, key: str = "model.obstacle") -> Expr:
        """s(y): ≥ 0 where y is admissible, < 0 by the penetration depth (a UFL scalar)."""
        if self.type in ("above", "below"):
            height = _height(expressions.parse(self.psi, mesh, f"{key}.psi"), mesh)
            gap: Expr = y[2] - height if self.type == "above" else height - y[2]
            return gap
        if self.type == "plane":
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

    def energy(self, y: Function, mesh: Mesh, degree: int) -> Energy:
        """The penalty P_ε split into an implicit (convex quadratic) and an explicit part.

        ``degree``: the polynomial degree of y; the quadrature has degree 2k + 2 for both parts,
        so that they cancel exactly where no contact is. With ``treatment = "active_set"`` the
        implicit part is restricted to the contact set (:class:`ContactSet`, in
        ``Energy.active_sets``).
        """
        quadrature = 2 * degree + 2
        dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": quadrature})
        inv = 1.0 / values.constant(mesh, self.epsilon)
        s = self.distance(y, mesh)
        negative = ufl.min_value(s, 0.0)
        square = s * s if self.linear else _squared_distance(y, self.center, mesh)
        if self.treatment == "active_set":
            contact = ContactSet(s, mesh, quadrature)
            implicit: ufl.Form = 0.5 * inv * contact.chi * square * dx
            explicit: ufl.Form = 0.5 * inv * (negative**2 - contact.chi * square) * dx
            # points of A not in contact at yⁿ (they entered it at a trial step): their step
            # aims at the obstacle, (1/2ε)(s)² instead of (1/2ε)(s − s(yⁿ))²
            shift: ufl.Form = 0.5 * inv * contact.chi * ufl.max_value(s, 0.0) ** 2 * dx
            return Energy(implicit, explicit, active_sets=(contact,), step_shift=shift)
        implicit = 0.5 * inv * square * dx
        if self.linear:
            explicit = -0.5 * inv * ufl.max_value(s, 0.0) ** 2 * dx
        else:
            explicit = 0.5 * inv * (negative**2 - square) * dx
        return Energy(implicit=implicit, explicit=explicit)


def _squared_distance(y: Expr, center: list[float], mesh: Mesh) -> Expr:
    """|y − c|², the sphere's isotropic stabilisation."""
    shift = y - values.constant(mesh, list(center))
    square: Expr = ufl.dot(shift, shift)
    return square


class ContactSet:
    """The contact set A = {s < 0} of the ``active_set`` treatment, χ = 1_A at quadrature points.

    χ lives in a quadrature space of the penalty's degree, so that (1/2ε)∫χ s² is exactly the
    penalty's s² restricted to the points of A. It starts at χ = 1 (the splitting), so that the
    step matrix's sparsity pattern, built once, has every coupling of the penalty.
    :meth:`begin` sets A = {s(yⁿ) < 0}; :meth:`enlarge` adds the points in contact at a trial
    state. Both report a change on any rank to all ranks.
    """

    #: redone steps per step at most (A grows by at least one point per redo)
    max_redo = 50

    def __init__(self, s: Expr, mesh: Mesh, degree: int) -> None:
        element = basix.ufl.quadrature_element(mesh.basix_cell(), value_shape=(), degree=degree)
        space = dolfinx.fem.functionspace(mesh, element)
        self.comm = mesh.comm
        self.chi: Function = dolfinx.fem.Function(space, name="contact_set")
        self.chi.x.array[:] = 1.0
        self._state: Function = dolfinx.fem.Function(space)
        indicator = ufl.conditional(ufl.lt(s, 0.0), 1.0, 0.0)
        self._indicator: compat.Expression = dolfinx.fem.Expression(
            indicator, compat.interpolation_points(space.element)
        )

    def _in_contact(self) -> np.ndarray:
        """1 at the quadrature points where the current state penetrates, else 0."""
        self._state.interpolate(self._indicator)
        return self._state.x.array.real.copy()

    def _put(self, chi: np.ndarray) -> bool:
        """χ := ``chi``; whether it changed on any rank (collective)."""
        same = bool(np.array_equal(chi, self.chi.x.array.real))
        self.chi.x.array[:] = chi
        return not mpi.global_all(self.comm, same)

    def begin(self) -> bool:
        """A = {s(yⁿ) < 0}; whether it changed (collective)."""
        return self._put(self._in_contact())

    def enlarge(self) -> bool:
        """A ∪ {s(ỹ) < 0} at a trial state ỹ; whether A grew (collective)."""
        return self._put(np.maximum(self.chi.x.array.real, self._in_contact()))


def _height(psi: float | Expr, mesh: Mesh) -> Expr:
    """ψ as a value of the forms: a Constant when it is a number or folds to one."""
    if isinstance(psi, float | ufl.constantvalue.ScalarValue):  # "0.2 + 0*x" folds to 0.2
        return values.constant(mesh, float(psi))
    return psi
