"""Measures of a thermal bilayer's shape: forms built on the deformation, region means.

The measures themselves (hinge fold angles, closure gap, edge placements) are in
:mod:`dgplate.measure.hinges`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import dolfinx.fem
import numpy as np
import ufl

from dgplate.measure.hinges import RegionIntegrals
from dgplate.mesh.tagged import TaggedMesh


def cell_group_mean(tagged: TaggedMesh, expr: Any, region: str) -> float:
    """Area-weighted mean of a scalar UFL expression over a cell group (collective)."""
    one = ufl.as_ufl(1.0)  # type: ignore[no-untyped-call]
    area, total = RegionIntegrals(tagged)([one, expr], region)
    return float(total / area) if area else float(np.nan)


class OnShape:
    """A measure whose forms need the deformation Function.

    A measure whose forms need the deformation Function: built at the first call for a
    given ``y`` (collective), then evaluated.
    """

    def __init__(
        self, make: Callable[[dolfinx.fem.Function[np.float64]], Callable[[], dict[str, float]]]
    ):
        self.make = make
        self._y: dolfinx.fem.Function[np.float64] | None = None
        self._measure: Callable[[], dict[str, float]] | None = None

    def __call__(self, y: dolfinx.fem.Function[np.float64]) -> dict[str, float]:
        """The figures of the shape ``y`` (collective)."""
        if self._measure is None or y is not self._y:
            self._y, self._measure = y, self.make(y)
        return self._measure()
