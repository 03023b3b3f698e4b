"""What every driver is to the runner: steps that report records, a state to write and resume.

A driver advances a model's state: the constrained gradient flow
(:class:`dgplate.solvers.flow.GradientFlow`), Newton's method over a load schedule
(:class:`dgplate.solvers.newton.Continuation`) or heat steps each followed by a relaxation
(:class:`dgplate.coupling.thermal.ThermalBilayer`). The runner (:mod:`dgplate.problems.runner`)
is written once against this protocol: its observers print progress, write the VTX series and
the checkpoints, and after the run it writes ``history.csv``, ``summary.json`` and the picture.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

from mpi4py import MPI

import dolfinx.fem


class Record(Protocol):
    """One step of a driver: a dataclass, one row of ``history.csv``."""

    step: int

    def line(self) -> str:
        """One line of progress output."""
        ...


@dataclass
class RunResult:
    """How a driver's run ended.

    ``history`` holds this run's records. ``interrupted`` is the signal (SIGINT, SIGTERM)
    that stopped the run, 0 if none.
    """

    converged: bool
    reason: str
    steps: int
    history: list[Any] = field(default_factory=list)
    interrupted: int = 0


class Observer(Protocol):
    """Told of every step and of the end of a run."""

    def step(self, driver: Any, record: Any) -> None:
        """After each step (collective)."""
        ...

    def finish(self, driver: Any, result: Any) -> None:
        """At the end of ``run`` (collective)."""
        ...


class Driver(Protocol):
    """The runner's view of a solver (all methods are collective on ``comm``)."""

    comm: MPI.Comm
    observers: list[Observer]
    step_count: int  # steps done so far, including those before a resume
    checkpoint_every: int  # steps between checkpoints (0: only at the end)

    @property
    def time(self) -> float:
        """The state's time: pseudo-time, load factor or physical time."""
        ...

    @property
    def shape(self) -> dolfinx.fem.Function:
        """The deformed surface y: ω → ℝ³ (written to VTX and drawn)."""
        ...

    def run(self, max_steps: int | None = None) -> RunResult:
        """Step until converged, interrupted, failed or ``max_steps`` steps are done."""
        ...

    def remaining_steps(self) -> int:
        """How many steps ``run()`` may still take (0: the budget is spent)."""
        ...

    def checkpoint_fields(self) -> dict[str, dolfinx.fem.Function]:
        """The functions a checkpoint stores."""
        ...

    def checkpoint_state(self) -> dict[str, Any]:
        """The counters a checkpoint stores (JSON-able)."""
        ...

    def restore_state(self, state: dict[str, Any]) -> None:
        """Take back the counters of :meth:`checkpoint_state` (the fields are restored first)."""
        ...

    def summary(self) -> dict[str, Any]:
        """Numbers for ``summary.json``: dofs, energy, defect, …"""
        ...

    def destroy(self) -> None:
        """Free PETSc objects."""
        ...
