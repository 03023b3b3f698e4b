"""What every plate model's energy is to the gradient flow: an implicit and an explicit part."""

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
        """E_h itself: the implicit and the explicit part."""
        if self.explicit is None:
            return self.implicit
        total: ufl.Form = self.implicit + self.explicit
        return total
