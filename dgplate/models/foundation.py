"""Kirchhoff plate on an elastic foundation: E_h[y] + ½k∫|y − (x₁, x₂, 0)|².

The example of "How to add a model" (docs/design.md §6): a spec with one more key, and an
energy that adds one quadratic term to the Kirchhoff energy. Quadratic terms go into
``Energy.implicit`` (the flow's constant matrix); the flow, its constraint and every output are
reused as they are. A free plate under a uniform load f₃ floats at y₃ = f₃/k.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import ufl

from dgplate import values
from dgplate.compat import Function
from dgplate.dg.energy import Energy
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import PlateModel, flat_identity
from dgplate.models.kirchhoff import KirchhoffSpec, build_kirchhoff
from dgplate.schema import is_number, option


@dataclass
class FoundationSpec(KirchhoffSpec):
    """[model] of a plate on an elastic foundation: the Kirchhoff keys plus k."""

    name: str = option("foundation", "the model")
    k: float = option(1.0, "foundation stiffness k > 0 (force per unit area and length)")

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (is_number(self.k) and self.k > 0):
            raise InputError(f"model.k must be a number > 0, got {self.k!r}")


def build_foundation(spec: FoundationSpec, tagged: TaggedMesh) -> PlateModel:
    """The Kirchhoff plate of ``spec`` with the foundation's energy added.

    Args:
        spec: the validated ``[model]`` section.
        tagged: the mesh with its named cell and facet groups.

    Returns:
        The Kirchhoff model whose energy adds ½∫k|y − x|².
    """
    plate = build_kirchhoff(spec, tagged)
    k = values.constant(tagged.mesh, spec.k)
    rest, _ = flat_identity(tagged.mesh)

    def energy(y: Function) -> Energy:
        bending = plate.energy(y)
        spring = 0.5 * k * ufl.inner(y - rest, y - rest) * ufl.dx
        return replace(bending, implicit=bending.implicit + spring)

    return replace(plate, energy=energy)
