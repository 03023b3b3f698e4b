"""Steps that must not raise the energy: nonlocal safeguards (plate and rod) and active sets.

Nonlocal terms of the energy (self-avoidance, :class:`dgplate.dg.energy.Nonlocal`) are
explicit: a step too long for them may bring parts of the body through each other. Active sets
(an obstacle's contact set) are taken from the step's start and may miss points that enter
them. Either way a refused step is taken back and redone.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol, TypeVar

from dgplate.dg.energy import Energy, Nonlocal
from dgplate.solvers.step_system import FlowCounts, StepSystem

#: How often a step that raised E_h is redone with τ/2 when only active sets ask for it.
HALVINGS = 10


class GuardedRecord(Protocol):
    """What a safeguard reads of a step's record, and the figures it adds."""

    tau: float
    energy: float
    rate: float
    safety: dict[str, float]


Info = TypeVar("Info", bound=GuardedRecord)


class Redoable(Protocol):
    """A flow whose state can be saved and taken back, and whose τ can be set."""

    @property
    def tau(self) -> float:
        """The time step of the next step."""
        ...

    @tau.setter
    def tau(self, value: float) -> None: ...

    def save(self) -> Any:
        """The state and the counters a redo starts from."""
        ...

    def restore(self, saved: Any) -> None:
        """Take back the state of :meth:`save`."""
        ...


def safety(terms: Sequence[Nonlocal], redone: int) -> dict[str, float]:
    """A step's record of the safety net: the least distance the terms measured, steps redone."""
    distance = min([term.min_distance for term in terms], default=math.inf)
    return {"min_distance": distance, "redone": float(redone)}


def passes(local: bool, terms: Sequence[Nonlocal]) -> bool:
    """Whether a step passes: its local tests, and then the nonlocal terms' ``accept()``.

    The terms are asked only about a step that passed the rest (collective; ``local`` is the
    same on every rank): their ``accept()`` takes the state as the reference of their next
    test (self-avoidance: the least distance), and a refused state must not become it
    (docs/performance.md, the trefoil ribbon).

    Args:
        local: whether the step passed the tests that need no reference.
        terms: the energy's nonlocal terms.

    Returns:
        Whether the step is accepted.
    """
    return local and all([term.accept() for term in terms])


def rose(info: GuardedRecord) -> bool:
    """Whether the step raised the energy beyond round-off."""
    return -info.rate * info.tau > 1e-12 * max(1.0, abs(info.energy))


class Safeguard:
    """A step that the nonlocal terms accept and that does not raise E, else redone with τ/2.

    At most ``max_redo`` times (the largest of the terms'; :data:`HALVINGS` with active sets
    alone); τ is restored for the next step. Without nonlocal terms and active sets a plain step.
    """

    def __init__(self, flow: Redoable, energy: Energy):
        """The safeguard of ``flow``, whose energy is ``energy``."""
        self.flow, self.energy = flow, energy

    def step(self, take: Callable[[], Info]) -> Info:
        """One step by ``take``, redone as long as it is refused; its record has ``safety``.

        Nonlocal terms with ``max_redo = 0`` (the LDG Hessian's) have no safety net.
        """
        terms = [term for term in self.energy.nonlocal_terms if term.max_redo > 0]
        if not terms and not self.energy.active_sets:
            return take()
        flow = self.flow
        tau, saved = flow.tau, flow.save()
        limit = max([term.max_redo for term in terms], default=HALVINGS)
        redone = 0
        info = take()
        while not self.acceptable(info) and redone < limit:
            flow.restore(saved)
            flow.tau, redone = flow.tau / 2, redone + 1
            info = take()
        if redone:
            flow.tau = tau
        info.safety = safety(terms, redone)
        return info

    def acceptable(self, info: GuardedRecord) -> bool:
        """E did not go up (beyond round-off), and then the nonlocal terms accept the new state."""
        return passes(not rose(info), self.energy.nonlocal_terms)


class ActiveSetStep:
    """A step with active sets: from the sets of yⁿ, redone with larger sets when E_h rose.

    A step that lowers E_h is accepted as it is (points that entered a set join it at the
    next step, as in a semismooth Newton iteration). A step that raised E_h is taken back, the
    sets are enlarged by the points in them at the trial state, and the step is redone from yⁿ,
    at most ``max_redo`` times (counted in ``active_set_redos``). With every entering point in
    the sets the step is energy stable (docs/obstacle.md); if the sets did not grow, the
    increase is left to the :class:`Safeguard` (which halves τ).
    """

    def __init__(self, flow: Redoable, system: StepSystem, counts: FlowCounts):
        """The active sets of ``system``'s energy, for steps of ``flow``."""
        self.flow, self.system, self.counts = flow, system, counts

    def step(self, take: Callable[[], Info]) -> Info:
        """One step by ``take`` with the active sets grown until it does not raise E_h."""
        sets = self.system.energy.active_sets
        if not sets:
            return take()
        self.system.begin_active_sets()
        saved = self.flow.save()
        info = take()
        for _ in range(max(term.max_redo for term in sets)):
            if not rose(info) or not any([term.enlarge() for term in sets]):
                break
            self.flow.restore(saved)
            self.counts.active_set_redos += 1
            self.system.active_sets_changed()
            info = take()
        return info
