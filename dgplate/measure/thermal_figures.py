"""Measures of a thermal bilayer's shape built on the deformation Function.

The measures themselves (hinge fold angles, closure gap, edge placements) are in
:mod:`dgplate.measure.hinges`.
"""

from __future__ import annotations

from collections.abc import Callable

import dolfinx.fem
import numpy as np


class OnShape:
    """A measure whose forms need the deformation Function.

    Built at the first call for a given ``y`` (collective), then evaluated.
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
