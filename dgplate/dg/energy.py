"""What every plate model's energy is to the gradient flow: an implicit and an explicit part."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import ufl


class Nonlocal(Protocol):
    """A nonlocal explicit term (e.g. self-avoidance), which is not a UFL integral.

    It has a value and a UFL functional whose derivative at the current state is the term's
    derivative.

    The flow calls :meth:`update` before it assembles the right-hand side and when it reports
    energies, and :meth:`accept` after each step (its safety net: a refused step is redone
    with τ/2). ``min_distance`` is what the term's safety net measured at the last update.
    """

    linearisation: ufl.Form
    min_distance: float
    max_redo: int  # how often the flow may halve τ for one step

    def update(self) -> float:
        """The term's value at the current state; refreshes :attr:`linearisation` (collective)."""
        ...

    def accept(self) -> bool:
        """Whether the current state may follow the last accepted one (collective)."""
        ...


class ActiveSet(Protocol):
    """The set on which an implicit term acts, following the state (an obstacle's contact set).

    The term's implicit part is restricted to the set A (an indicator at quadrature points), so
    the step matrix changes when A does. The flow calls :meth:`begin` once per step, before the
    step is assembled (A from yⁿ), and :meth:`enlarge` after a trial step (A grows by the points
    the trial state brought into the set; the step is then redone with the larger A), at most
    ``max_redo`` times per step.
    """

    max_redo: int

    def begin(self) -> bool:
        """A from the current state yⁿ; whether A changed (collective)."""
        ...

    def enlarge(self) -> bool:
        """A ∪ the set of the current (trial) state; whether A grew (collective)."""
        ...


@dataclass
class Energy:
    """A discrete energy E_h = implicit + explicit.

    ``implicit`` is quadratic in the deformation: its Hessian is the constant flow matrix, so it
    is assembled once per run. ``explicit`` holds nonlinear terms (the bilayer's ν term, an
    obstacle's concave part); the flow evaluates their derivative at the previous iterate.
    ``constant`` is added to reported energies only (e.g. ½∫μ|Z|² of a bilayer).
    ``nonlocal_terms`` are explicit terms that are not UFL integrals (:class:`Nonlocal`).
    ``active_sets`` are the sets to which parts of ``implicit`` are restricted
    (:class:`ActiveSet`): the step matrix is reassembled when one of them changes.
    ``step_shift`` is no part of E_h: its derivative at yⁿ is added to that of E_h in the step's
    right-hand side (the obstacle's active set uses it to move points that enter contact onto
    the obstacle, docs/obstacle.md).
    """

    implicit: ufl.Form
    explicit: ufl.Form | None = None
    constant: float = 0.0
    nonlocal_terms: Sequence[Nonlocal] = ()
    active_sets: Sequence[ActiveSet] = ()
    step_shift: ufl.Form | None = None

    @property
    def total(self) -> ufl.Form:
        """E_h itself: the implicit and the explicit part."""
        if self.explicit is None:
            return self.implicit
        total: ufl.Form = self.implicit + self.explicit
        return total
