"""Continuation in the clamped data: a gradient flow whose boundary data move with α.

Clamped data may follow a path φ(α), α ∈ (0, 1] (docs/continuation.md): by default
φ(α) = (1 − α)·id + α·g, or any formula in x, y and ``alpha``. α is a DOLFINx Constant of the
forms, so a new value changes the data without recompiling anything, and since g and Φ enter
the Nitsche terms linearly the flow's constant matrix does not depend on α either: only the
right-hand side and the energy see it.

:class:`AlphaSchedule` says how α advances: a list of increasing values, each a *stage* relaxed by
the flow (warm-started from the last) until its stopping rule holds or the stage's budget is
spent; or a fixed increment δα per flow step (Bonito–Nochetto–Ntogkas, §6.3), after which the
flow relaxes at α = 1 until it converges. Every change of α rebases the flow's energy, so that
the energy decrease of a step, and the list of steps at which the energy went up, count only
the flow's own work and not the work done by moving the data.

:class:`MovingClampFlow` implements the runner's :class:`~dgplate.solvers.driver.Driver`
protocol: one record per flow step (:class:`MovingClampStep`, the flow's :class:`StepInfo`
with α and the stage), checkpoints that keep α, and α along the path in ``summary.json``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from itertools import pairwise
from typing import Any

from mpi4py import MPI

import numpy as np

from dgplate.compat import Constant, Function
from dgplate.errors import InputError
from dgplate.schema import Check, option
from dgplate.solvers.driver import Driver, Observer, Record, RunOutcome, RunResult, StoppingTest
from dgplate.solvers.flow import GradientFlow
from dgplate.solvers.steps import FlowResult, StepInfo, stop_reason

__all__ = ["AlphaSchedule", "MovingClampFlow", "MovingClampSpec", "MovingClampStep", "StageRecord"]

_MAX_PATH = 200  # stages listed in summary.json (a δα schedule has thousands)


@dataclass(frozen=True)
class AlphaSchedule:
    """How α advances: the values of the stages and the flow steps each may take.

    ``alphas``: increasing values in (0, 1], one stage each, relaxed until the flow's
    stopping rule holds or ``stage_steps`` flow steps are spent (the last stage: until the
    flow converges or its whole budget is spent). ``rate`` > 0 instead: α = min(1, n·δα) at
    flow step n, one step per value, then the stage α = 1.
    """

    alphas: tuple[float, ...] = ()
    rate: float = 0.0
    stage_steps: int = 200

    @property
    def stages(self) -> int:
        """The number of values of α."""
        return math.ceil(1.0 / self.rate - 1e-9) if self.rate else len(self.alphas)

    def alpha(self, stage: int) -> float:
        """α of a stage (0-based)."""
        if self.rate:
            return min(1.0, (stage + 1) * self.rate)
        return self.alphas[stage]

    def budget(self, stage: int) -> int | None:
        """Flow steps a stage may take; None: the last stage, until the flow converges."""
        if stage == self.stages - 1:
            return None
        return 1 if self.rate else self.stage_steps


@dataclass(frozen=True)
class MovingClampSpec:
    """The table ``model.continuation``: how the clamped data move along α ∈ (0, 1].

    Exactly one of ``steps``, ``alpha`` and ``rate``; :meth:`schedule` gives the stages.
    """

    steps: int | None = option(
        None, "α = 1/N, 2/N, …, 1: N stages", shown="(one of steps, alpha, rate)", ge=1
    )
    alpha: list[float] | None = option(
        None,
        "the values of α, increasing",
        shown="(one of steps, alpha, rate)",
        each=Check(gt=0, le=1),
    )
    rate: float | None = option(
        None,
        "α grows by δα per flow step",
        shown="(one of steps, alpha, rate)",
        gt=0,
        le=1,
    )
    stage_steps: int = option(200, "flow steps per stage (the last: until converged)", ge=1)

    def validate(self, key: str) -> None:
        """Exactly one of steps, alpha and rate; the values of alpha increasing.

        Args:
            key: the table's dotted key (``model.continuation``), as named in messages.
        """
        given = [name for name in ("steps", "alpha", "rate") if getattr(self, name) is not None]
        if len(given) != 1:
            raise InputError(
                f"{key} needs exactly one of steps = N, alpha = [increasing values in (0, 1]] "
                f"or rate = δα, got {given!r}"
            )
        alphas = self.alpha
        if alphas is not None and not (alphas and all(b > a for a, b in pairwise(alphas))):
            raise InputError(f"{key}.alpha must increase strictly (and not be empty), got {alphas}")

    def schedule(self) -> AlphaSchedule:
        """The stages of α."""
        if self.rate is not None:
            return AlphaSchedule(rate=self.rate, stage_steps=self.stage_steps)
        if self.steps is not None:
            alphas = tuple((i + 1) / self.steps for i in range(self.steps))
            return AlphaSchedule(alphas=alphas, stage_steps=self.stage_steps)
        return AlphaSchedule(alphas=tuple(self.alpha or ()), stage_steps=self.stage_steps)


@dataclass
class MovingClampStep(StepInfo):
    """One flow step of the continuation: the flow's record, α and the stage (1-based)."""

    alpha: float = 1.0
    stage: int = 1

    def line(self) -> str:
        """The flow's progress line with α."""
        return f"α = {self.alpha:.5f}  " + super().line()


@dataclass
class StageRecord:
    """The end of a stage: α, its flow steps, whether it converged, E_h and D_h."""

    alpha: float
    steps: int
    converged: bool
    energy: float
    defect: float


class _Forward:
    """The inner flow's observer: its records, with α, go to the continuation's observers."""

    def __init__(self, owner: MovingClampFlow):
        self.owner = owner

    def step(self, driver: Driver, record: Record) -> None:
        """Forward the flow's step."""
        assert isinstance(record, StepInfo)
        self.owner.forward(record)

    def finish(self, driver: Driver, result: RunResult) -> None:
        """Nothing: the continuation tells its observers when its own run ends."""


class MovingClampFlow(Driver):
    """The constrained gradient flow with clamped data moved along α (a Driver).

    The flow reports to this driver, which reports to its observers. Collective on the mesh
    communicator.

    Args:
        flow: the gradient flow of an energy whose clamped data reference ``alpha``.
        alpha: the Constant α that moves the clamped data.
        schedule: the values of α, stage by stage, and when a stage ends.
        observers: told of every flow step (with α) and of the end of the run.
    """

    def __init__(
        self,
        flow: GradientFlow,
        alpha: Constant,
        schedule: AlphaSchedule,
        observers: Sequence[Observer] = (),
    ):
        self.alpha_constant, self.schedule = alpha, schedule
        self.observers: list[Observer] = list(observers)
        self.flow = flow
        flow.observers = [_Forward(self)]
        self.comm: MPI.Comm = self.flow.comm
        self.stage = 0  # the current stage (0-based)
        self.stage_steps = 0  # flow steps done in the current stage
        self.stages: list[StageRecord] = []  # finished stages
        self._history: list[MovingClampStep] = []  # this run's records
        self._set_alpha(schedule.alpha(0))

    # -- the runner's view ------------------------------------------------------------------
    @property
    def alpha(self) -> float:
        """The current value of α."""
        return float(self.alpha_constant.value)

    @property
    def y(self) -> Function:
        """The deformation y: ω → ℝ³."""
        return self.flow.y

    shape = y

    @property
    def step_count(self) -> int:
        """Flow steps so far (over resumes)."""
        return self.flow.step_count

    @step_count.setter
    def step_count(self, value: int) -> None:
        self.flow.step_count = value

    @property
    def time(self) -> float:
        """The flow's pseudo-time."""
        return self.flow.time

    @property
    def checkpoint_every(self) -> int:
        """Flow steps between checkpoints: ``flow.checkpoint_every``."""
        return self.flow.checkpoint_every

    def options_prefixes(self) -> list[str]:
        """The options prefixes of the flow's step solver."""
        return self.flow.options_prefixes()

    def stopping_test(self, record: Any) -> StoppingTest:
        """The flow's stopping test at ``record`` (a flow step, with α)."""
        return self.flow.stopping_test(record)

    @property
    def num_dofs(self) -> int:
        """Unknowns of the flow's step system."""
        return self.flow.num_dofs

    def remaining_steps(self) -> int:
        """Flow steps left of ``flow.max_steps``."""
        return self.flow.remaining_steps()

    def _set_alpha(self, value: float) -> None:
        self.alpha_constant.value = np.asarray(value)
        self.flow.rebase_energy()  # the data moved: measure the flow's decrease from here

    # -- steps ------------------------------------------------------------------------------
    @property
    def finished(self) -> bool:
        """True once the last stage has converged."""
        return self.stage >= self.schedule.stages

    def path_progress(self) -> tuple[float, str] | None:
        """The part of the α path done (stages ended, up to the last stage's start) and its end.

        The progress printer estimates from it when α = 1 is reached; the last stage (until
        the flow converges) is not part of the estimate. None: a single stage.
        """
        last = self.schedule.stages - 1
        return (min(self.stage / last, 1.0), "α = 1") if last > 0 else None

    def forward(self, info: StepInfo) -> None:
        """Report a flow step with its α; end the stage when it is done.

        A stage is done when the flow's stopping rule (``flow.stop``, the test that ends the
        flow's run) holds or its budget is spent; the next α is set before the observers hear
        of the step, so that a checkpoint written now continues with the next stage.
        """
        self.stage_steps += 1
        record = MovingClampStep(**asdict(info), alpha=self.alpha, stage=self.stage + 1)
        self._history.append(record)
        allowed = self.schedule.budget(self.stage)
        converged = bool(stop_reason(self.flow.settings, info.rate, info.stationarity))
        if converged or (allowed is not None and self.stage_steps >= allowed):
            self._end_stage(converged, info)
        for observer in self.observers:
            observer.step(self, record)

    def _end_stage(self, converged: bool, info: StepInfo) -> None:
        """Keep the stage's figures and move α to the next value (if any)."""
        if self.schedule.stages <= _MAX_PATH:
            self.stages.append(
                StageRecord(self.alpha, self.stage_steps, converged, info.energy, info.defect)
            )
        self.stage += 1
        self.stage_steps = 0
        if not self.finished:
            self._set_alpha(self.schedule.alpha(self.stage))

    def run(self, max_steps: int | None = None) -> RunResult:
        """Stages until the last converges, the budget is spent, a failure or an interrupt."""
        budget = max_steps or self.remaining_steps()
        self._history = []
        stopped: FlowResult | None = None  # a flow run that was interrupted or failed
        while stopped is None and len(self._history) < budget and not self.finished:
            allowed = self.schedule.budget(self.stage)
            limit = budget - len(self._history)
            if allowed is not None:
                limit = min(limit, allowed - self.stage_steps)
            result = self.flow.run(max_steps=limit)
            if result.interrupted or (result.steps < limit and not result.converged):
                stopped = result  # interrupted, or the flow failed (solver error, divergence)
        outcome = self._outcome(stopped)
        for observer in self.observers:
            observer.finish(self, outcome)
        return outcome

    def _outcome(self, stopped: FlowResult | None) -> RunOutcome:
        """Converged once the last stage converged; otherwise why the run stopped."""
        steps = len(self._history)
        stage = min(self.stage + 1, self.schedule.stages)
        where = f"α = {self.alpha:g} (stage {stage} of {self.schedule.stages})"
        if self.finished:
            reason = f"{where} reached and the flow converged"
        elif stopped is not None:
            reason = f"at {where}: {stopped.reason}"
        else:
            reason = f"step budget of {steps} steps spent at {where}"
        signum = stopped.interrupted if stopped is not None else 0
        return RunOutcome(self.finished, reason, steps, list(self._history), signum)

    # -- checkpoints ------------------------------------------------------------------------
    def checkpoint_fields(self) -> dict[str, Function]:
        """The flow's functions."""
        return self.flow.checkpoint_fields()

    def checkpoint_state(self) -> dict[str, Any]:
        """The flow's counters, α, the stage and the finished stages."""
        return {
            "flow": self.flow.checkpoint_state(),
            "alpha": self.alpha,
            "stage": self.stage,
            "stage_steps": self.stage_steps,
            "stages": [asdict(s) for s in self.stages[-_MAX_PATH:]],
        }

    def restore_state(self, state: dict[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state` (the fields are restored first)."""
        self.stage, self.stage_steps = int(state["stage"]), int(state["stage_steps"])
        self.stages = [StageRecord(**s) for s in state["stages"]]
        self.alpha_constant.value = np.asarray(float(state["alpha"]))
        self.flow.restore_state(state["flow"])

    # -- results ----------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        """The flow's numbers, α, the stages done and (up to 200) stage ends along the path."""
        out = self.flow.summary()
        out["alpha"] = self.alpha
        out["continuation_stage"] = min(self.stage + 1, self.schedule.stages)
        out["continuation_stages"] = self.schedule.stages
        if self.schedule.stages <= _MAX_PATH:
            out["alpha_path"] = [asdict(s) for s in self.stages]
        return out

    def destroy(self) -> None:
        """Free the flow's PETSc objects."""
        self.flow.destroy()
