"""``model.director``: the target metric of a liquid-crystal elastomer from its director field.

A nematic elastomer sheet whose in-plane director makes the angle θ(x) with the x axis
contracts by λ along the director and stretches by λ^{−ν} across it when it is heated (Modes,
Bhattacharya and Warner 2011), so it wants the metric

    G = R(θ) diag(λ², λ^{−2ν}) R(θ)ᵀ,

i.e. G₁₁ = λ² cos²θ + λ^{−2ν} sin²θ, G₁₂ = (λ² − λ^{−2ν}) sin θ cos θ,
G₂₂ = λ² sin²θ + λ^{−2ν} cos²θ. :meth:`Director.metric` writes these as the entries of a
:class:`~dgplate.models.metric.MetricSpec` (formulas when θ is one), so that the director
plate is the prestrained plate of that G (docs/prestrain.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from dgplate import expressions
from dgplate.errors import InputError
from dgplate.models.metric import MetricSpec

#: ``dgplate schema``'s line for ``model.director``.
HELP = (
    "director of a liquid-crystal elastomer, its target metric G = R(θ) diag(λ², λ^(-2ν)) R(θ)ᵀ "
    "in place of model.metric (docs/prestrain.md): {angle = θ (radians from the x axis, a "
    "number or a formula in x, y (or r, theta)), lambda = λ > 0 (contraction along the director), nu = ν "
    "(0.5)}; {} none"
)

_KEYS = ("angle", "lambda", "nu")


@dataclass(frozen=True)
class Director:
    """The director angle θ (a number or a formula in x, y), the contraction λ and ν."""

    angle: float | str
    stretch: float  # λ, the key ``lambda``
    nu: float = 0.5

    @classmethod
    def from_table(cls, table: Mapping[str, object], key: str = "model.director") -> Director:
        """The director of the table ``{angle = .., lambda = .., nu = ..}``.

        Args:
            table: the table as read from the problem file.
            key: the table's dotted key, as named in messages.

        Returns:
            The director; an InputError naming the key of a missing, unknown or bad entry.
        """
        for name in table:
            if name not in _KEYS:
                raise InputError(f"unknown key {key}.{name} (known keys: {', '.join(_KEYS)})")
        for name in _KEYS[:2]:
            if name not in table:
                raise InputError(f"{key}.{name} is required")
        angle = table["angle"]
        expressions.check(angle, f"{key}.angle")
        stretch = expressions.finite_number(table["lambda"], f"{key}.lambda")
        if stretch <= 0:
            raise InputError(f"{key}.lambda must be > 0, got {table['lambda']!r}")
        nu = expressions.finite_number(table.get("nu", 0.5), f"{key}.nu")
        try:
            along, across = stretch**2, stretch ** (-2 * nu)
        except OverflowError:
            along = across = math.inf
        if not (0 < along < math.inf and 0 < across < math.inf):
            raise InputError(
                f"{key}.lambda, {key}.nu: λ² and λ^(-2ν) must be finite and > 0 in floating "
                f"point, got λ = {stretch!r}, ν = {nu!r}"
            )
        assert isinstance(angle, float | int | str)  # expressions.check took it
        return cls(angle if isinstance(angle, str) else float(angle), stretch, nu)

    def metric(self) -> MetricSpec:
        """G = R(θ) diag(λ², λ^{−2ν}) R(θ)ᵀ as the entries of ``model.metric``.

        Returns:
            Numbers for a constant θ, else formulas in x, y built on the text of θ.
        """
        along, across = self.stretch**2, self.stretch ** (-2 * self.nu)
        if isinstance(self.angle, float):
            c, s = math.cos(self.angle), math.sin(self.angle)
            return MetricSpec(
                g11=along * c * c + across * s * s,
                g12=(along - across) * s * c,
                g22=along * s * s + across * c * c,
            )
        cos, sin = f"cos({self.angle})", f"sin({self.angle})"
        return MetricSpec(
            g11=f"{along!r}*{cos}**2 + {across!r}*{sin}**2",
            g12=f"{along - across!r}*{sin}*{cos}",
            g22=f"{along!r}*{sin}**2 + {across!r}*{cos}**2",
        )
