"""What every driver is to the runner: steps that report records, a state to write and resume.

A driver advances a model's state: the constrained gradient flow
(:class:`dgplate.solvers.flow.GradientFlow`), the flow staged along a path of clamped data
(:class:`dgplate.solvers.moving_clamp.MovingClampFlow`), the rod's flow
(:class:`dgplate.solvers.rod_flow.RodFlow`), Newton's method over a load schedule
(:class:`dgplate.solvers.newton.LoadPath`) or heat steps each followed by a relaxation
(:class:`dgplate.coupling.thermal_driver.ThermalBilayer`). The runner (:mod:`dgplate.problems.runner`)
is written once against this protocol: its observers print progress, write the VTX series and
the checkpoints, and after the run it writes ``history.csv``, ``summary.json`` and the picture.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol, cast, runtime_checkable

from mpi4py import MPI

from dgplate.compat import Form, Function, FunctionSpace
from dgplate.dg.energy import Energy
from dgplate.dg.forms import integral
from dgplate.solvers.steps import stopping_value


class Record(Protocol):
    """One step of a driver: a dataclass, one row of ``history.csv``."""

    step: int

    def line(self) -> str:
        """One line of progress output."""
        ...


class RunResult(Protocol):
    """How a driver's run ended.

    ``history`` holds this run's records. ``interrupted`` is the signal (SIGINT, SIGTERM)
    that stopped the run, 0 if none. Each driver returns its own dataclass of this shape.
    """

    @property
    def converged(self) -> bool:
        """Whether the stopping rule held."""
        ...

    @property
    def reason(self) -> str:
        """Why the run ended, in words."""
        ...

    @property
    def steps(self) -> int:
        """The number of steps of this run."""
        ...

    @property
    def history(self) -> Sequence[Record]:
        """This run's records."""
        ...

    @property
    def interrupted(self) -> int:
        """The signal that stopped the run; 0: none."""
        ...

    @property
    def energy_increases(self) -> Sequence[int]:
        """The steps of this run at which the energy went up (none for a driver without one)."""
        ...


@dataclass
class RunOutcome:
    """A plain :class:`RunResult`, for drivers without a result type of their own."""

    converged: bool
    reason: str
    steps: int
    history: list[Any] = field(default_factory=list)
    interrupted: int = 0
    energy_increases: list[int] = field(default_factory=list)


class StoppingTest(NamedTuple):
    """A flow's stopping test at one step: its value, its tolerance, its name, the budget."""

    value: float
    tol: float
    name: str  # in a progress line: ``ΔE/τ`` or ``‖P DE_h‖``
    budget: int  # ``flow.max_steps``


class Observer(Protocol):
    """Told of every step and of the end of a run."""

    def step(self, driver: Driver, record: Record) -> None:
        """After each step (collective)."""
        ...

    def finish(self, driver: Driver, result: RunResult) -> None:
        """At the end of ``run`` (collective)."""
        ...


@runtime_checkable
class Narrator(Protocol):
    """An observer that also prints the lines of a run's own phases (the progress printer)."""

    def note(self, line: str) -> None:
        """Print ``line`` (rank 0)."""
        ...


class Driver(Protocol):
    """The runner's view of a solver (all methods are collective on ``comm``).

    Every driver subclasses it, and so inherits the defaults of the optional capabilities at
    the end (a path of known length, the parts of a step, a stopping test, PETSc solvers).
    """

    comm: MPI.Comm
    observers: list[Observer]
    step_count: int  # steps done so far, including those before a resume

    @property
    def checkpoint_every(self) -> int:
        """Steps between checkpoints (0: only at the end)."""
        ...

    @property
    def time(self) -> float:
        """The state's time: pseudo-time, load factor or physical time."""
        ...

    @property
    def shape(self) -> Function:
        """The deformed surface y: ω → ℝ³ (written to VTX and drawn)."""
        ...

    def run(self, max_steps: int | None = None) -> RunResult:
        """Step until converged, interrupted, failed or ``max_steps`` steps are done."""
        ...

    def remaining_steps(self) -> int:
        """How many steps ``run()`` may still take (0: the budget is spent)."""
        ...

    def checkpoint_fields(self) -> dict[str, Function]:
        """The functions a checkpoint stores."""
        ...

    def checkpoint_state(self) -> dict[str, Any]:
        """The counters a checkpoint stores (JSON-able)."""
        ...

    def restore_state(self, state: dict[str, Any]) -> None:
        """Take back the counters of :meth:`checkpoint_state` (after the fields: resume_from)."""
        ...

    def resume_from(self, checkpoint: Any) -> None:
        """Put the driver at ``checkpoint`` (collective): its fields, then its counters.

        Args:
            checkpoint: a :class:`dgplate.io.checkpoint.Checkpoint` of this driver's problem,
                its driver's counters under ``state["driver"]``.
        """
        checkpoint.restore(self.checkpoint_fields())
        self.restore_state(checkpoint.state["driver"])

    def summary(self) -> dict[str, Any]:
        """Numbers for ``summary.json``: dofs, energy, defect and so on."""
        ...

    def destroy(self) -> None:
        """Free PETSc objects."""
        ...

    @property
    def num_dofs(self) -> int:
        """The global number of unknowns (``summary.json``'s ``dofs``)."""
        ...

    # -- optional capabilities, with their defaults --------------------------------------------
    #: the problem-file key of the step budget, named when a resumed run has none left
    budget_key: str = "flow.max_steps"
    #: how the last progress line names a run that ended as it should, and one that did not
    outcome_words: tuple[str, str] = ("converged", "NOT converged")

    def extendable(self) -> bool:
        """Whether the run ended only because its step budget was spent, though it could go on.

        A path that ran out of points inside its range of load factors: its checkpoint can be
        resumed with a larger budget (:attr:`budget_key`). Default: no.
        """
        return False

    def path_progress(self) -> tuple[float, str] | None:
        """The part of a path of known length done and the name of its end; None: no path.

        E.g. ``(0.25, "α = 1")``: the progress lines estimate the time left from it.
        """
        return None

    def step_counts(self) -> dict[str, int]:
        """What the steps so far were made of, by ``summary.json``'s names (default: nothing)."""
        return {}

    def stopping_test(self, record: Any) -> StoppingTest | None:
        """The stopping test at ``record``, from whose decay the time left is estimated.

        Args:
            record: the record of the step just taken.

        Returns:
            The test, or None for a driver that stops otherwise (the default).
        """
        return None

    def options_prefixes(self) -> list[str]:
        """The options prefixes of the PETSc solvers that read the problem's solver options.

        ``flow.solver`` (or FvK's ``model.snes``) options are read under these prefixes; the
        options PETSc never read under any of them are reported after the run. Default: none.
        """
        return []


class StepCounters:
    """The counters of a stepping driver that a checkpoint holds and a resume restores.

    The step count and pseudo-time over all runs, the last step's energy (the next decrease is
    measured from it) and the steps at which the energy went up.
    """

    step_count: int
    #: a class default, so that the flows may set the time the protocol reads as a property
    time: float = 0.0
    _last_energy: float
    energy_increases: list[int]
    observers: list[Observer]

    def record_step(self, info: Any, history: list[Any], increases: list[int]) -> None:
        """Keep a finished step: its record, whether the energy went up, and tell the observers.

        ``info`` has ``step``, ``tau``, ``rate`` and ``energy`` (a flow's step record).
        """
        history.append(info)
        if info.rate < 0 and -info.rate * info.tau > 1e-12 * max(1.0, abs(info.energy)):
            increases.append(info.step)
            self.energy_increases.append(info.step)
        for obs in self.observers:
            obs.step(cast("Driver", self), info)

    def checkpoint_state(self) -> dict[str, Any]:
        """The counters a checkpoint must hold."""
        return {
            "step": self.step_count,
            "time": self.time,
            "energy": self._last_energy,
            "energy_increases": list(self.energy_increases),
        }

    def restore_state(self, state: dict[str, Any]) -> None:
        """Continue from a checkpoint's counters (after its fields were restored)."""
        self.step_count, self.time = int(state["step"]), float(state["time"])
        self._last_energy = float(state["energy"])
        self.energy_increases = [int(s) for s in state.get("energy_increases", [])]


class Budget(Protocol):
    """The [flow] keys of a flow's step budget and stopping test (:class:`~.flow.FlowSpec`)."""

    max_steps: int
    checkpoint_every: int
    tol: float
    stop: str  # "rate" or "stationarity"
    adaptive_tau: bool


class EnergyFlow(StepCounters, Driver):
    """A flow of an :class:`~dgplate.dg.energy.Energy` on a mixed space ``W``.

    What the plate's and the rod's flows share: the size of the step system and the energy of
    the current state, its nonlocal terms (self-avoidance) included.
    """

    W: FunctionSpace
    comm: MPI.Comm
    energy: Energy
    settings: Budget
    _E_form: Form

    @property
    def checkpoint_every(self) -> int:
        """Steps between checkpoints: ``flow.checkpoint_every``."""
        return self.settings.checkpoint_every

    def remaining_steps(self) -> int:
        """Steps left of ``flow.max_steps`` (the budget of a run and its resumed runs)."""
        return max(self.settings.max_steps - self.step_count, 0)

    @property
    def num_dofs(self) -> int:
        """The global number of unknowns of the step system."""
        imap = self.W.dofmap.index_map
        return int(imap.size_global * self.W.dofmap.index_map_bs)

    def stopping_test(self, record: Any) -> StoppingTest:
        """``flow.stop``'s test at ``record`` (:func:`dgplate.solvers.steps.stopping_value`).

        ``record`` is a flow's step, with its ``rate`` (and ``stationarity``).
        """
        s = self.settings
        value, _ = stopping_value(s, record.rate, record.stationarity)
        if s.stop == "stationarity":
            name = "‖P DE_h‖"
        else:
            name = "‖P DE_h‖²" if s.adaptive_tau else "ΔE/τ"
        return StoppingTest(float(value), s.tol, name, s.max_steps)

    def evaluate_energy(self) -> float:
        """The energy of the current state, nonlocal terms included (collective)."""
        terms = sum(term.update() for term in self.energy.nonlocal_terms)
        return integral(self._E_form, self.comm) + self.energy.constant + terms
