"""Starts of a plate's flow given in a problem file (``model.start``) or as ``initial``.

A start is a deformation y⁰: ω → ℝ³ from which the flow begins, a function of the points x
(shape (3, n)) as :meth:`dolfinx.fem.Function.interpolate` takes it. Besides the flat plate
(the default) a problem file names one of a small family:

- ``"flat"`` (or ``{type = "flat"}``): y⁰(x) = (x₁, x₂, 0);
- ``{type = "arc", radius = R, at = a, along = "x"}``: the plate rolled into a circular arc
  of radius R about a line parallel to the x₂ axis, tangent to the plane along x₁ = a:
  y⁰ = (a + R sin((x₁ − a)/R), x₂, R(1 − cos((x₁ − a)/R))), an isometry; R < 0 bends down,
  ``along = "y"`` rolls along x₂ instead. A plate clamped flat on x₁ = a starts from data
  that match its clamp;
- ``{type = "formula", g = [3 numbers or formulas in x, y]}``: y⁰ = g;
- ``{type = "elastica", length = L, shortening = Δ, at = a}``: the strip a < x₁ < a + L,
  clamped flat at both ends, on Euler's clamped–clamped elastica with its ends pushed
  together by Δ (:func:`dgplate.reference.elastica.clamped_elastica_curve`), the ends at
  x₁ = a + Δ/2 and a + L − Δ/2: an isometry.

:func:`resolve` picks the start of a run: the ``initial`` of :func:`dgplate.run` (a function,
one of these tables, or ``"flat"``) if given, else ``model.start``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from dgplate import expressions
from dgplate.compat import Array, Mesh
from dgplate.errors import InputError
from dgplate.reference.elastica import clamped_elastica_curve
from dgplate.schema import REQUIRED, from_dict, option
from dgplate.solvers.flow import Initial

#: ``dgplate schema``'s line for ``model.start``.
HELP = (
    "the flow's start: 'flat' (y = (x, y, 0)); {type = 'arc', radius = R, at = a (0), "
    "along = 'x'|'y'} (rolled into an arc of radius R, tangent to the plane along x₁ = a; "
    "R < 0 bends down); {type = 'formula', g = [3 numbers or formulas in x, y]}; "
    "{type = 'elastica', length = L, shortening = Δ, at = a (0)} (the strip a < x₁ < a + L "
    "clamped at both ends on the elastica with its ends Δ closer)"
)


@dataclass(frozen=True)
class Start:
    """A validated start table (:func:`Start.from_table`); :meth:`function` evaluates it."""

    #: The keys that only some types take (:func:`dgplate.schema.from_dict`).
    TYPE_KEYS: ClassVar[dict[str, tuple[str, ...]]] = {
        "flat": (),
        "arc": ("radius", "at", "along"),
        "formula": ("g",),
        "elastica": ("length", "shortening", "at"),
    }
    #: The keys each type needs.
    _NEEDS: ClassVar[dict[str, tuple[str, ...]]] = {
        "arc": ("radius",),
        "formula": ("g",),
        "elastica": ("length", "shortening"),
    }

    type: str = option(REQUIRED, "the start", choices=tuple(TYPE_KEYS))
    radius: float | None = option(None, "arc: the radius R ≠ 0 (R < 0 bends down)")
    at: float = option(0.0, "arc, elastica: where the shape begins along x₁ (or x₂)")
    along: str = option("x", "arc: the direction it rolls along", choices=("x", "y"))
    g: list[float | str] | None = option(None, "formula: y⁰ = g(x, y)", length=3)
    length: float | None = option(None, "elastica: the strip's length L")
    shortening: float | None = option(None, "elastica: its ends Δ closer, 0 < Δ < L")

    @classmethod
    def from_table(cls, value: object, key: str = "model.start") -> Start:
        """The start of ``'flat'`` or a table ``{type = ..., ...}``; InputError naming the key."""
        if value == "flat":
            return cls("flat")
        if not isinstance(value, dict):
            raise InputError(
                f"{key} must be 'flat' or a table {{type = 'flat' | 'arc' | 'formula', ...}}, "
                f"got {value!r}"
            )
        return from_dict(cls, value, key)

    def validate(self, key: str) -> None:
        """The keys the type needs, R ≠ 0, 0 < Δ < L and the formulas.

        Args:
            key: the table's dotted key (``model.start``), as named in messages.
        """
        missing = [name for name in self._NEEDS.get(self.type, ()) if getattr(self, name) is None]
        if missing:
            raise InputError(f"{key}.{missing[0]} is required for type '{self.type}'")
        if self.radius == 0:
            raise InputError(f"{key}.radius must be a finite number ≠ 0, got 0")
        if self.type == "elastica" and not 0 < self.shortening < self.length:  # type: ignore[operator]
            raise InputError(
                f"{key}: the shortening must lie in (0, length), got shortening = "
                f"{self.shortening:g}, length = {self.length:g}"
            )
        if self.g is not None:
            expressions.check(self.g, f"{key}.g")

    def function(self, mesh: Mesh, key: str = "model.start") -> Initial | None:
        """y⁰ as a function of the points; None for the flat start.

        Collective: formulas are checked to be finite on the plate, on every rank.

        Args:
            mesh: the plate's mesh.
            key: the key named in error messages.

        Returns:
            The function x ↦ y⁰(x), or None for the flat start.
        """
        if self.type == "arc":
            return self._arc_function
        if self.type == "elastica":
            return self._elastica_function
        if self.type == "formula":
            for i, entry in enumerate(self.g or ()):
                if isinstance(entry, str):
                    expressions.check_finite_on_mesh(entry, mesh, f"{key}.g[{i}]")
            return self._formula_function
        return None

    def _arc_function(self, x: Array) -> Array:
        radius, i = float(self.radius or 1.0), "xy".index(self.along)
        angle = (x[i] - self.at) / radius
        y = np.array(x, dtype=np.float64, copy=True)
        y[i] = self.at + radius * np.sin(angle)
        y[2] = radius * (1.0 - np.cos(angle))
        return y

    def _elastica_function(self, x: Array) -> Array:
        length, shortening = float(self.length or 0.0), float(self.shortening or 0.0)
        s, xs, zs = clamped_elastica_curve(length, shortening)
        arc = x[0] - self.at
        left = self.at + shortening / 2
        return np.vstack([left + np.interp(arc, s, xs), x[1], np.interp(arc, s, zs)])

    def _formula_function(self, x: Array) -> Array:
        points = np.ascontiguousarray(x[:2].T)
        rows = []
        for i, entry in enumerate(self.g or ()):
            key = f"start.g[{i}]"
            value = entry if isinstance(entry, float) else expressions.evaluate(entry, points, key)
            rows.append(np.broadcast_to(np.asarray(value, dtype=np.float64), x.shape[1]))
        return np.vstack(rows)


def resolve(spec: Any, initial: object, mesh: Mesh) -> Initial | None:
    """The start of a run: ``initial`` (of :func:`dgplate.run`), else ``model.start``.

    ``initial`` takes precedence over ``model.start`` as ``--out`` does over ``output.dir``.

    Args:
        spec: the problem's [model] spec (its ``start_params``, if it has a ``start`` key).
        initial: None, a function x ↦ y(x), ``"flat"`` or a start table as ``model.start``.
        mesh: the plate's mesh (formulas are checked on it; collective).

    Returns:
        The function to interpolate the start from; None for the model's default start.
    """
    given: Start | None = getattr(spec, "start_params", None)
    if initial is None:
        return given.function(mesh) if given is not None else None
    if isinstance(initial, str | dict):
        if spec.name == "rod":
            raise InputError(
                "initial: a rod starts straight, or from a function s ↦ u(s) or a RodStart, "
                f"got {initial!r}"
            )
        return Start.from_table(initial, "initial").function(mesh, "initial")
    if not callable(initial):
        raise InputError(
            "initial must be a function x ↦ y(x) (points of shape (3, n)), 'flat' or a start "
            f"table as model.start, got {type(initial).__name__} {initial!r}"
        )
    return initial
