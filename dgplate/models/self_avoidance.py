"""Self-avoidance added to an isometric plate model (docs/self_avoidance.md).

:func:`with_self_avoidance` is the one call by which a plate builder (Kirchhoff, bilayer,
foundation, LCE) adds ρ·TP[y] (:mod:`dgplate.dg.self_avoidance`) to its energy, as a nonlocal
explicit term of the flow, and its energy and the least distance of non-neighbouring points to
``summary.json``. :func:`add_tangent_point` does the same for an energy of more arguments than
y (the thermal bilayer's ``energy(y, θ)``). The start is checked when the flow builds the
energy (its first state).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

from dgplate.compat import Function
from dgplate.dg.energy import Energy
from dgplate.dg.self_avoidance import PlateTangentPoint, SelfAvoidance
from dgplate.models.base import PlateModel


def add_tangent_point(
    plate_energy: Callable[..., Energy], params: SelfAvoidance
) -> tuple[Callable[..., Energy], Callable[[Function], dict[str, Any]]]:
    """``energy(y, ...)`` with ρ·TP[y] as a nonlocal term, and the term's figures.

    The figures (``self_avoidance_energy``, ``min_distance``; {} before the energy is built)
    are those of the term of the last energy built, at its current state.
    """
    terms: list[PlateTangentPoint] = []

    def energy(y: Function, *args: Any) -> Energy:
        term = PlateTangentPoint(y, params)
        terms.append(term)
        base = plate_energy(y, *args)
        return replace(base, nonlocal_terms=[*base.nonlocal_terms, term])

    def figures(y: Function) -> dict[str, Any]:
        return terms[-1].summary() if terms else {}

    return energy, figures


def with_self_avoidance(model: PlateModel, params: SelfAvoidance | None) -> PlateModel:
    """``model`` with ρ·TP added to its energy; unchanged without parameters."""
    if params is None:
        return model
    energy, figures = add_tangent_point(model.energy, params)
    return replace(model, energy=energy, measures=[*model.measures, figures])
