"""A rigid obstacle added to an isometric plate model (docs/obstacle.md).

:func:`with_obstacle` is the one call by which a plate builder (Kirchhoff, bilayer, and so the
foundation model) adds the penalty of :mod:`dgplate.dg.obstacle_penalty` to its energy and the contact
figures of :mod:`dgplate.measure.contact` to its ``summary.json``. The clamped data are
checked when the model is built, the start when the flow builds the energy (its first state).
"""

from __future__ import annotations

from dataclasses import replace

from ufl.core.expr import Expr

from dgplate.compat import Function
from dgplate.dg.energy import Energy
from dgplate.dg.obstacle_penalty import Obstacle
from dgplate.measure.contact import Contact
from dgplate.models.base import DataPath, PlateModel, along_path


def with_obstacle(
    model: PlateModel, obstacle: Obstacle | None, g: Expr, path: DataPath | None = None
) -> PlateModel:
    """``model`` with the obstacle's penalty and contact figures; unchanged without one.

    ``g``: the clamped data, which must not penetrate the obstacle (an ``InputError``), at
    any α of the ``path`` they follow.
    """
    if obstacle is None:
        return model
    contact = Contact(obstacle, model.facets, model.degree)
    along_path(path, contact.clamped_check(g))
    plate_energy = model.energy

    def energy(y: Function) -> Energy:
        contact.check_start(y)
        return contact.add_to(plate_energy(y), y)

    return replace(model, energy=energy, measures=[*model.measures, contact.summary])
