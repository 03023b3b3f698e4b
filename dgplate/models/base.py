"""What every plate model returns: an energy split for the semi-implicit gradient flow."""

from __future__ import annotations

from dataclasses import dataclass

import ufl


@dataclass
class Energy:
    """A discrete energy E_h = implicit + explicit.

    ``implicit`` is quadratic in the deformation: its Hessian is the constant flow matrix, so it
    is assembled once per run. ``explicit`` holds nonlinear terms (the bilayer's ν term, an
    obstacle's concave part); the flow evaluates their derivative at the previous iterate.
    ``constant`` is added to reported energies only (e.g. ½∫μ|Z|² of a bilayer).
    """

    implicit: ufl.Form
    explicit: ufl.Form | None = None
    constant: float = 0.0

    @property
    def total(self) -> ufl.Form:
        return self.implicit if self.explicit is None else self.implicit + self.explicit


def flat_identity(mesh):
    """The flat reference deformation y⁰(x) = (x₁, x₂, 0) and its gradient [I₂; 0]."""
    x = ufl.SpatialCoordinate(mesh)
    g = ufl.as_vector([x[0], x[1], 0.0])
    Phi = ufl.as_matrix([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    return g, Phi


def piecewise_constant(tagged, values, key: str):
    """μ-like data: a number (a Constant), or {cell group name: number} turned into a DG0
    function; either way a value of the forms, not part of their code (:mod:`dgplate.values`)."""
    from dgplate.errors import InputError
    from dgplate.values import constant

    if isinstance(values, int | float) and not isinstance(values, bool):
        if not values > 0:
            raise InputError(f"{key} must be > 0, got {values}")
        return constant(tagged.mesh, values)
    if not isinstance(values, dict) or not values:
        raise InputError(f"{key} must be a number or a table {{group = value}}, got {values!r}")
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
            raise InputError(f"{key}.{name} must be a number > 0, got {value!r}")
    return tagged.group_function(values, key=key)


def clamped_data(value, mesh, key: str = "model.boundary_data"):
    """Nitsche data (g, Φ) on clamped faces from a problem file.

    ``"flat"``: g = (x, y, 0), Φ = [I₂; 0]. A table ``{g = [3 formulas], Phi = [[2], [2], [2]]}``
    gives any data, e.g. a folded sheet; Φ defaults to ∇g. Numbers in the table are Constants
    (:mod:`dgplate.values`).
    """
    from dgplate import values
    from dgplate.errors import InputError

    if value == "flat":
        return flat_identity(mesh)
    if not isinstance(value, dict) or "g" not in value or set(value) - {"g", "Phi"}:
        raise InputError(
            f"{key} must be 'flat' or a table {{g = [..3..], Phi = [[..2..] x3]}}, got {value!r}"
        )
    g = values.vector(value["g"], mesh, f"{key}.g", 3)
    if "Phi" not in value:
        return g, ufl.grad(g)
    rows = value["Phi"]
    if not (
        isinstance(rows, list)
        and len(rows) == 3
        and all(isinstance(r, list) and len(r) == 2 for r in rows)
    ):
        raise InputError(f"{key}.Phi must be a 3×2 matrix [[..], [..], [..]], got {rows!r}")
    return g, values.array(rows, mesh, f"{key}.Phi")
