"""Self-avoidance added to an isometric plate model (docs/self_avoidance.md).

:func:`with_self_avoidance` is the one call by which a plate builder (Kirchhoff, bilayer,
foundation, LCE) adds ρ·TP[y] (:mod:`dgplate.dg.self_avoidance`) to its energy, as a nonlocal
explicit term of the flow, and its energy and the least distance of non-neighbouring points to
``summary.json``. The start is checked when the flow builds the energy (its first state).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from dgplate.compat import Function
from dgplate.dg.energy import Energy
from dgplate.dg.self_avoidance import PlateTangentPoint, SelfAvoidance
from dgplate.models.base import PlateModel


def with_self_avoidance(model: PlateModel, params: SelfAvoidance | None) -> PlateModel:
    """``model`` with ρ·TP added to its energy; unchanged without parameters."""
    if params is None:
        return model
    plate_energy = model.energy
    terms: list[PlateTangentPoint] = []

    def energy(y: Function) -> Energy:
        term = PlateTangentPoint(y, params)
        terms.append(term)
        base = plate_energy(y)
        return replace(base, nonlocal_terms=[*base.nonlocal_terms, term])

    def summary(y: Function) -> dict[str, Any]:
        return terms[-1].summary() if terms else {}

    return replace(model, energy=energy, measures=[*model.measures, summary])
