"""``model.metric``: the target metric G of a prestrained plate (docs/prestrain.md).

A prestrained (non-Euclidean) plate is constrained to ∇yᵀ∇y = G instead of the isometry
∇yᵀ∇y = I, G a symmetric positive definite 2×2 field on ω, the first fundamental form the
plate's material wants (Bonito, Guignard, Nochetto and Yang, J. Comput. Phys. 2022). Its
entries are numbers or formulas in x, y (:mod:`dgplate.expressions`); G must be finite and
positive definite at every geometry node and cell midpoint of the mesh
(:func:`dgplate.expressions.sample_points`), else an ``InputError`` naming ``model.metric``
and the point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import expressions, values
from dgplate.compat import Array, Mesh
from dgplate.errors import InputError
from dgplate.schema import option

#: ``dgplate schema``'s line for ``model.metric``.
HELP = (
    "target metric G of a prestrained plate, the constraint ∇yᵀ∇y = G instead of I "
    "(docs/prestrain.md): {g11 = .., g12 = .., g22 = ..}, numbers or formulas in x, y (or r, theta); {} none"
)


@dataclass(frozen=True)
class MetricSpec:
    """``model.metric``: the entries of the symmetric G (each a number or a formula in x, y)."""

    g11: float | str = option(1.0, "G₁₁: a number or a formula in x, y (or r, theta)")
    g12: float | str = option(0.0, "G₁₂ = G₂₁: a number or a formula in x, y (or r, theta)")
    g22: float | str = option(1.0, "G₂₂: a number or a formula in x, y (or r, theta)")

    def entries(self) -> dict[str, float | str]:
        """The three entries by name.

        Returns:
            ``{"g11": …, "g12": …, "g22": …}``, each a number or a formula.
        """
        return {"g11": self.g11, "g12": self.g12, "g22": self.g22}

    def validate(self, key: str) -> None:
        """The formulas, without a mesh (syntax, names, constant parts).

        Args:
            key: the table's dotted key (``model.metric``), as named in messages.
        """
        for name, value in self.entries().items():
            expressions.check(value, f"{key}.{name}")


def target_metric(spec: MetricSpec, mesh: Mesh, key: str = "model.metric") -> Expr:
    """G as a UFL 2×2 expression (numbers as Constants), checked SPD on the mesh (collective).

    Args:
        spec: the validated ``model.metric``.
        mesh: the plate's mesh.
        key: the key named in error messages.

    Returns:
        The matrix [[g11, g12], [g12, g22]].
    """
    entries = {
        name: values.constant(mesh, value)
        if isinstance(value, float)
        else expressions.formula(value, mesh, f"{key}.{name}")
        for name, value in spec.entries().items()
    }
    check_positive_definite(spec, mesh, key)
    matrix: Expr = ufl.as_matrix(
        [[entries["g11"], entries["g12"]], [entries["g12"], entries["g22"]]]
    )
    return matrix


def check_positive_definite(spec: MetricSpec, mesh: Mesh, key: str = "model.metric") -> None:
    """InputError on every rank when G is not finite and SPD at some sample point of the mesh.

    Args:
        spec: the validated ``model.metric``.
        mesh: the plate's mesh (:func:`dgplate.expressions.sample_points`: nodes, midpoints).
        key: the key named in the message.
    """
    points = expressions.sample_points(mesh)
    g11, g12, g22 = (_at(value, points, f"{key}.{name}") for name, value in spec.entries().items())
    det = g11 * g22 - g12**2
    bad = np.flatnonzero(~(np.isfinite(det) & (g11 > 0) & (det > 0)))
    local = None
    if bad.size:
        i = bad[0]
        local = (*points[i], g11[i], g12[i], g22[i])
    found = [b for b in mesh.comm.allgather(local) if b is not None]
    if found:
        x, y, a, b, c = found[0]
        raise InputError(
            f"{key}: G is not symmetric positive definite at (x, y) = ({x:.6g}, {y:.6g}): "
            f"g11 = {a:.6g}, g12 = {b:.6g}, g22 = {c:.6g} (det G = {a * c - b * b:.6g})"
        )


def _at(value: float | str, points: Array, key: str) -> Array:
    """An entry at ``points``, one value per point."""
    values_at = value if isinstance(value, float) else expressions.evaluate(value, points, key)
    return np.broadcast_to(np.asarray(values_at, dtype=np.float64), len(points))
