"""Heat steps, each followed by a relaxation of the plate: the thermal bilayer's driver.

The coupling is quasi-static and one-way (docs/design.md §1, "Thermal bilayer"): the
temperature θ solves the heat equation of :mod:`dgplate.coupling.heat` on the flat reference
domain, and after each heat step the plate is relaxed by the constrained H² gradient flow of
:mod:`dgplate.solvers.flow`, warm-started from the previous shape, until the flow's stopping
rule (``flow.stop``: by default ‖P DE_h‖ < ``tol``) holds or the budget
:attr:`Schedule.flow_steps` is spent (the step that spends it is not tested). The energy is
built once from ``energy(y, θ)`` and references the temperature Function, so a heat step
changes the spontaneous curvature without recompiling anything; the flow's constant matrix
does not depend on θ, only on τ.

A *hold* relaxes the plate at a fixed temperature, without a heat step, with its own budget and
optionally another τ (:attr:`Schedule.holds`): the self-folding box is held at the peak
temperature (the closed box) and at the end. :class:`ThermalBilayer` implements the runner's
:class:`~dgplate.solvers.driver.Driver` protocol: one driver step is one heat step or one
hold, each reported to the observers as a :class:`HeatStepRecord`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, TypeAlias

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from dgplate import interrupt
from dgplate.coupling.heat import HeatSolver
from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets
from dgplate.errors import InputError
from dgplate.solvers.driver import Driver, Observer, RunOutcome, RunResult
from dgplate.solvers.flow import FlowSpec, GradientFlow
from dgplate.solvers.steps import FlowResult

#: ``energy(y, θ)``: the plate's energy for the deformation y and the temperature θ.
ThermalEnergy: TypeAlias = (
    "Callable[[dolfinx.fem.Function[np.float64], dolfinx.fem.Function[np.float64]], Energy]"
)
#: ``measure(y) -> {name: number}``: figures of a shape added to every record (collective).
# a string: DOLFINx 0.9's Function is not subscriptable at run time
Measure: TypeAlias = "Callable[[dolfinx.fem.Function[np.float64]], dict[str, float]]"


@dataclass
class HeatStepRecord:
    """What one driver step did (a heat step and its relaxation, or a hold).

    One row of ``history.csv``; ``figures`` holds the numbers of the driver's measures (hinge
    angles, closure gap, …), written as columns of their own by :meth:`row`.
    """

    step: int  # the driver's step: heat steps and holds, counted over resumes
    heat_step: int  # heat steps done so far
    time: float  # physical time
    source: float  # the scheduled source's mean over the last heat step
    theta_min: float
    theta_max: float
    theta_mean: float
    flow_steps: int
    flow_converged: bool
    energy: float
    defect: float
    seconds: float  # the heat step and the relaxation
    hold: bool = False  # a relaxation at fixed θ (no heat step)
    heat_seconds: float = 0.0  # the heat step alone
    figures: dict[str, float] = field(default_factory=dict)

    def row(self) -> dict[str, Any]:
        """The record as one flat table row: the figures become columns."""
        out = {k: v for k, v in asdict(self).items() if k != "figures"}
        out.update(self.figures)
        return out

    def line(self) -> str:
        """One line of progress: time, source, θ range, flow, figures, energy, defect."""
        figures = "  ".join(
            f"{name.removeprefix('angle_').removeprefix('hinge_')} {value:.4g}"
            for name, value in self.figures.items()
        )
        flow = f"flow {self.flow_steps:4d} steps{' (conv.)' if self.flow_converged else ''}"
        kind = "hold" if self.hold else f"s = {self.source:+.3g}"
        return (
            f"t = {self.time:8.4f}  {kind}  θ ∈ [{self.theta_min:.3f}, {self.theta_max:.3f}]  "
            f"{flow}  {figures}  E_h = {self.energy:+.6e}  D_h = {self.defect:.2e}  "
            f"{self.seconds:.1f} s"
        )


@dataclass(frozen=True)
class Schedule:
    """When the driver steps the heat equation and when it holds.

    Heat steps continue until ``end_time``; after each one the flow takes at most
    ``flow_steps`` steps. When the time reaches a hold time (``holds``, increasing, at most
    ``end_time``) the plate is relaxed at that temperature for at most ``hold_steps`` steps
    with τ = ``hold_tau`` (None: the flow's τ), before the next heat step. The values are
    those of a checked [schedule] (:class:`dgplate.models.thermal.spec.ScheduleSpec`).
    """

    end_time: float
    flow_steps: int = 40
    holds: tuple[float, ...] = ()
    hold_steps: int = 300
    hold_tau: float | None = None


class ThermalBilayer(Driver):
    """Heat steps, each followed by a warm-started relaxation of the plate (a Driver).

    Collective on the mesh communicator.

    Args:
        facets: the plate's facet sets (with its mesh).
        degree: the deformation's polynomial degree.
        energy: (y, θ) ↦ the plate's energy (θ is ``heat.theta``).
        heat: the heat equation's solver.
        flow: the [flow] section of the relaxations.
        schedule: the heat steps and holds.
        measures: figures of the shape added to every record.
        observers: told of every record (``step(driver, record)``) and of the end of
            :meth:`run` (``finish(driver, result)``).
        initial: x ↦ y(x), in place of the flat start.
    """

    def __init__(
        self,
        facets: FacetSets,
        degree: int,
        energy: ThermalEnergy,
        heat: HeatSolver,
        flow: FlowSpec,
        schedule: Schedule,
        measures: Sequence[Measure] = (),
        observers: Sequence[Observer] = (),
        initial: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> None:
        if heat.mesh is not facets.mesh:
            raise InputError("the heat solver and the plate must live on the same mesh")
        self.heat, self.schedule = heat, schedule
        self.measures = list(measures)
        self.observers: list[Observer] = list(observers)
        self.comm: MPI.Comm = facets.mesh.comm
        self.flow = GradientFlow(facets, degree, lambda y: energy(y, heat.theta), flow, (), initial)
        self.records: list[HeatStepRecord] = []  # every record, those before a resume too
        self.step_count = 0
        self.holds_done = 0
        self.last_result: FlowResult | None = None
        self.held = HeldShapes(self.y.function_space)

    # -- the runner's view ------------------------------------------------------------------
    @property
    def y(self) -> dolfinx.fem.Function[np.float64]:
        """The deformation y: ω → ℝ³."""
        return self.flow.y

    shape = y  # the deformed surface of the Driver protocol (written to VTX and drawn)

    @property
    def num_dofs(self) -> int:
        """Unknowns of the flow's step system (deformation and multipliers)."""
        return self.flow.num_dofs

    @property
    def theta(self) -> dolfinx.fem.Function[np.float64]:
        """The temperature θ on the reference domain."""
        return self.heat.theta

    @property
    def time(self) -> float:
        """The physical time of the heat equation."""
        return self.heat.time

    def path_progress(self) -> tuple[float, str]:
        """The part of the heating schedule done, t / end_time, and its end (for the ETA)."""
        end = self.schedule.end_time
        return min(self.heat.time / end, 1.0), f"t = {end:g}"

    @property
    def interrupted(self) -> int:
        """The signal that stopped the last relaxation (0: none)."""
        return self.last_result.interrupted if self.last_result is not None else 0

    @property
    def finished(self) -> bool:
        """True when every hold is done and the time has reached the end time."""
        return self.holds_done == len(self.schedule.holds) and not self._before(
            self.schedule.end_time
        )

    @property
    def checkpoint_every(self) -> int:
        """Heat steps between checkpoints: ``flow.checkpoint_every``."""
        return self.flow.settings.checkpoint_every

    def options_prefixes(self) -> list[str]:
        """The options prefixes of the flow's step solver."""
        return self.flow.options_prefixes()

    def remaining_steps(self) -> int:
        """1 while heat steps or holds remain, else 0."""
        return 0 if self.finished else 1

    def _before(self, t: float) -> bool:
        return self.heat.time < t - 1e-9 * self.heat.dt

    # -- steps ------------------------------------------------------------------------------
    def relax(self, max_steps: int | None = None, test_last: bool = True) -> FlowResult:
        """Run the flow at the current θ (warm start), at most ``max_steps`` steps.

        The default budget is :attr:`Schedule.flow_steps`; ``test_last`` as in
        :meth:`~dgplate.solvers.flow.GradientFlow.run`.
        """
        self.flow.rebase_energy()  # θ changed Z, hence the energy
        budget = max_steps or self.schedule.flow_steps
        self.last_result = self.flow.run(max_steps=budget, test_last=test_last)
        return self.last_result

    def advance(self, max_steps: int | None = None) -> HeatStepRecord:
        """One heat step, then relax the plate; returns (and stores) the record.

        Its last flow step is not tested (a solve as costly as a step; the holds are tested).
        """
        t0 = time.perf_counter()
        self.heat.step()
        heat_seconds = time.perf_counter() - t0
        result = self.relax(max_steps, test_last=False)
        return self._record(result, time.perf_counter() - t0, heat_seconds=heat_seconds)

    def hold(self, max_steps: int | None = None, tau: float | None = None) -> HeatStepRecord:
        """Relax at the current temperature without a heat step; the record (stored too).

        Budget ``max_steps`` (default :attr:`Schedule.hold_steps`), optionally another τ
        (restored afterwards: each change reassembles the flow's constant matrix once). The
        record carries the time of the last heat step.
        """
        t0 = time.perf_counter()
        previous = self.flow.tau
        if tau is not None and tau != previous:
            self.flow.tau = tau
        try:
            result = self.relax(max_steps or self.schedule.hold_steps)
        finally:
            if self.flow.tau != previous:
                self.flow.tau = previous
        return self._record(result, time.perf_counter() - t0, hold=True)

    def _record(
        self, result: FlowResult, seconds: float, hold: bool = False, heat_seconds: float = 0.0
    ) -> HeatStepRecord:
        lo, hi = self.heat.min_max()
        figures = _safety(result)
        for measure in self.measures:
            figures.update(measure(self.y))
        self.step_count += 1
        record = HeatStepRecord(
            step=self.step_count,
            heat_step=self.heat.steps,
            time=self.heat.time,
            source=self.heat.last_source,
            theta_min=lo,
            theta_max=hi,
            theta_mean=self.heat.mean(),
            flow_steps=result.steps,
            flow_converged=result.converged,
            energy=result.energy,
            defect=result.defect,
            seconds=seconds,
            hold=hold,
            heat_seconds=heat_seconds,
            figures=figures,
        )
        self.records.append(record)
        return record

    def _next_step(self) -> HeatStepRecord | None:
        """The schedule's next step: a heat step, or the hold that is due.

        None when a hold was interrupted: it is not counted, and a resumed run does it again.
        """
        holds = self.schedule.holds
        due = self.holds_done < len(holds) and not self._before(holds[self.holds_done])
        if not due:
            return self.advance()
        steps_before = self.step_count
        record = self.hold(self.schedule.hold_steps, self.schedule.hold_tau)
        if self.interrupted:
            self.records.pop()
            self.step_count = steps_before
            return None
        self.holds_done += 1
        self.held.keep(record.step, self.y)
        return record

    def _outcome(self) -> tuple[bool, str]:
        """Converged and reason once the schedule is done: every hold must have converged."""
        for record in self.records:
            if record.hold and not record.flow_converged:
                return False, (
                    f"the hold at t = {record.time:g} spent its {self.schedule.hold_steps} "
                    "flow steps before the flow's tolerance"
                )
        return True, (
            f"schedule done: t = {self.heat.time:g} after {self.heat.steps} heat steps and "
            f"{self.holds_done} hold(s)"
        )

    def run(self, max_steps: int | None = None) -> RunResult:
        """Heat steps and holds until the end of the schedule (or a stop).

        The stops: an interrupt (SIGINT/SIGTERM, at a step boundary), a failed relaxation,
        or ``max_steps`` driver steps.

        The result's ``history`` holds this run's records; :attr:`records` all of them.
        """
        history: list[HeatStepRecord] = []
        converged, reason, signum = False, f"step budget of {max_steps} steps spent", 0
        while not self.finished and (max_steps is None or len(history) < max_steps):
            record = self._next_step()
            if record is not None:
                history.append(record)
                for observer in self.observers:
                    observer.step(self, record)
            signum = self.interrupted or interrupt.requested(self.comm)
            failure = None if record is None else _failure(self.last_result, record, self.schedule)
            if signum or failure:
                reason = interrupt.reason(signum) if signum else str(failure)
                break
        if self.finished:
            converged, reason = self._outcome()
        result = RunOutcome(converged, reason, len(history), history, signum)
        for observer in self.observers:
            observer.finish(self, result)
        return result

    # -- checkpoints ------------------------------------------------------------------------
    def checkpoint_fields(self) -> dict[str, dolfinx.fem.Function[np.float64]]:
        """The plate's and the heat equation's state, and the held shapes (``held_<step>``)."""
        return {**self.flow.checkpoint_fields(), "theta": self.heat.theta, **self.held.fields()}

    def checkpoint_state(self) -> dict[str, Any]:
        """The counters of the driver, the flow and the heat equation, and the records."""
        return {
            "step": self.step_count,
            "holds_done": self.holds_done,
            "finished": self.finished,
            "flow": self.flow.checkpoint_state(),
            "heat": self.heat.checkpoint_state(),
            "records": [asdict(r) for r in self.records],
            "held": self.held.steps(),
        }

    def resume_from(self, checkpoint: Any) -> None:
        """Put the driver at ``checkpoint`` with the shapes held before (none: an old one's)."""
        super().resume_from(checkpoint)
        self.held.expect(checkpoint.state["driver"].get("held", ()))
        checkpoint.restore(self.held.fields())

    def restore_state(self, state: dict[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state` (the fields are restored first)."""
        self.step_count = int(state["step"])
        self.holds_done = int(state["holds_done"])
        self.flow.restore_state(state["flow"])
        self.heat.restore_state(state["heat"])
        self.records = [HeatStepRecord(**r) for r in state["records"]]

    # -- results ----------------------------------------------------------------------------
    def step_counts(self) -> dict[str, int]:
        """What the driver's steps were made of: heat steps, holds and the flow steps of all.

        The runner's ``steps`` counts the driver's steps (heat steps and holds, the rows of
        ``history.csv``); these counts appear under the same names in ``summary.json`` and
        in the last progress line.
        """
        return {
            "heat_steps": self.heat.steps,
            "holds": self.holds_done,
            "flow_steps": self.flow.step_count,
        }

    def summary(self) -> dict[str, Any]:
        """Numbers for ``summary.json``: dofs, step counts, time, energy, defect."""
        return {
            "dofs": self.flow.num_dofs,
            **self.step_counts(),
            "time": self.heat.time,
            "tau": self.flow.tau,
            "energy": self.flow.evaluate_energy(),
            "isometry_defect": self.flow.defect(),
            "energy_increases": list(self.flow.energy_increases),
        }

    def destroy(self) -> None:
        """Free the flow's and the heat solver's PETSc objects."""
        self.flow.destroy()
        self.heat.destroy()


def _failure(result: FlowResult | None, record: HeatStepRecord, schedule: Schedule) -> str | None:
    """Why the relaxation of ``record`` failed (a solver error or divergence), if it did.

    A flow (``result``) that stopped before its budget without converging or being interrupted.
    """
    if result is None or result.converged or result.interrupted:
        return None
    budget = schedule.hold_steps if record.hold else schedule.flow_steps
    if result.steps >= budget:
        return None  # the budget is spent: the normal end of a heat step's relaxation
    return f"the relaxation at t = {record.time:g} stopped: {result.reason}"


class HeldShapes:
    """Copies of y at the end of the holds, by the hold's record step.

    They are checkpoint fields (``held_<step>``, their steps in the driver's state), so that a
    resumed run draws the holds before its interruption too (the box's ``at_switch.png``).
    """

    def __init__(self, space: dolfinx.fem.FunctionSpace[np.float64]) -> None:
        self.space = space
        self.shapes: dict[int, dolfinx.fem.Function[np.float64]] = {}

    def keep(self, step: int, y: dolfinx.fem.Function[np.float64]) -> None:
        """A copy of ``y`` as the shape held at ``step``."""
        self.shapes[step] = dolfinx.fem.Function(self.space)
        self.shapes[step].x.array[:] = y.x.array

    def get(self, step: int) -> dolfinx.fem.Function[np.float64] | None:
        """The shape held at ``step`` (None: no hold ended there)."""
        return self.shapes.get(step)

    def steps(self) -> list[int]:
        """The steps of the holds kept, in order."""
        return sorted(self.shapes)

    def fields(self) -> dict[str, dolfinx.fem.Function[np.float64]]:
        """The shapes as checkpoint fields, ``held_<step>``."""
        return {f"held_{step}": shape for step, shape in self.shapes.items()}

    def expect(self, steps: Sequence[int]) -> None:
        """Empty shapes for ``steps``, filled from a checkpoint's fields by ``resume_from``."""
        self.shapes = {int(step): dolfinx.fem.Function(self.space) for step in steps}


def _safety(result: FlowResult) -> dict[str, float]:
    """A relaxation's safety net (self-avoidance): steps redone, least distance on the way.

    {} without nonlocal terms. ``least_distance`` is the least of the steps' least distances
    of non-neighbouring points; the distance of the final shape is a measure's ``min_distance``.
    """
    safety = [info.safety for info in result.history if info.safety]
    if not safety:
        return {}
    return {
        "redone": float(sum(s["redone"] for s in safety)),
        "least_distance": min(s["min_distance"] for s in safety),
    }


__all__ = ["HeatStepRecord", "Measure", "Schedule", "ThermalBilayer", "ThermalEnergy"]
