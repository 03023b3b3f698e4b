"""Newton's method over a schedule of load factors: a driver for any energy (continuation).

In the spirit of dolfiny's continuation and DOLFINx's ``NonlinearProblem``. The caller gives

- a state :class:`dolfinx.fem.Function` u in any space (mixed spaces included),
- an energy Π(u) as a UFL form; the residual DΠ(u)[v] and the Jacobian D²Π(u)[v, δu] are its
  ``ufl.derivative``, nothing is written twice,
- Dirichlet conditions, whose data may be Constants that hold the load factor times a value at
  full load (``bc_values``),
- a load factor: a :class:`dolfinx.fem.Constant` the energy depends on, and a schedule of the
  load factors to solve at.

Each load step starts from the secant extrapolation of the two previous converged states (or
from the last one) and is solved by PETSc SNES with the options under a fixed prefix: by
default ``newtonls`` with the affine-covariant NLEQ-ERR line search (Deuflhard), which damps by
the Newton correction instead of a residual norm that may mix units (membrane and bending),
and takes full steps near the solution, so convergence is quadratic there; the linear systems
are solved by MUMPS LU (:data:`dgplate.solvers.linear.DIRECT_MUMPS`).

:class:`LoadPath` is a :class:`dgplate.solvers.driver.Driver`: ``run`` reports one
:class:`LoadStep` per converged load step to the observers, stops on SIGINT/SIGTERM at a step
boundary (on every rank together), and reports a load step whose Newton iteration fails as
``converged = False`` with the SNES reason, keeping the last converged state. A checkpoint
holds the state, the state before it (the predictor's second point) and the history, so a
resumed run continues the schedule.

The driver composes the Newton solver (:class:`dgplate.solvers.snes.NewtonSolver`), the
stability observer (``stability``, a :class:`Stability`;
:class:`dgplate.solvers.stability.StabilityObserver`: the lowest Hessian eigenvalues after each
load step and the load factors where they cross zero) and the branch leaving
(:class:`dgplate.solvers.branch.BranchLeaving`: ``perturb`` and ``leave`` push an unstable
state off its branch, and ``relaxation``, a :class:`Relaxation`, solves each load step by a
proximal gradient flow that only lowers Π before Newton polishes it).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any, TypeAlias, TypeVar

import dolfinx.fem
import numpy as np
import numpy.typing as npt
import ufl

from dgplate import interrupt
from dgplate.errors import SolverError
from dgplate.solvers.branch import BranchLeaving
from dgplate.solvers.driver import Driver, Observer, RunOutcome, RunResult
from dgplate.solvers.path_options import Leave, Relaxation, Stability
from dgplate.solvers.prefixes import check_prefix, hold_prefix, release_prefix
from dgplate.solvers.snes import NewtonSolver, snes_reason
from dgplate.solvers.stability import LOWEST, StabilityObserver

__all__ = ["Leave", "LoadFactor", "LoadPath", "LoadStep", "Relaxation", "Stability", "record_type"]

# strings: DOLFINx 0.9's Function is not subscriptable at run time
Shape: TypeAlias = (
    "dolfinx.fem.Function[np.float64] | Callable[[], dolfinx.fem.Function[np.float64]]"
)
Probes = Callable[[], Mapping[str, float]]


@dataclass
class LoadStep:
    """One converged load step: a row of ``history.csv``.

    A driver with probes records them in further fields (:func:`record_type`).
    """

    step: int
    load_factor: float
    iterations: int  # Newton iterations
    residual: float  # the residual norm at the last iterate
    energy: float
    seconds: float

    def line(self) -> str:
        """One line of progress output, the probes included."""
        probes = probe_text(self, LoadStep)
        return (
            f"load step {self.step:4d}  load factor {self.load_factor:.4g}  Newton its "
            f"{self.iterations:2d}  energy {self.energy:+.6e}{probes}  {self.seconds:.2f} s"
        )


def record_type(probes: Sequence[str]) -> type[LoadStep]:
    """:class:`LoadStep` with one more float field per probe name (flat history rows)."""
    return with_probes(LoadStep, probes)


Record = TypeVar("Record")


def with_probes(base: type[Record], probes: Sequence[str]) -> type[Record]:
    """The dataclass ``base`` with one more float field per probe name.

    Args:
        base: the record's dataclass.
        probes: the probe names; a ValueError when one is a field of ``base``.

    Returns:
        ``base`` itself without probes, else its subclass ``<base>WithProbes``.
    """
    if not probes:
        return base
    clash = sorted(set(probes) & {f.name for f in dataclasses.fields(base)})  # type: ignore[arg-type]
    if clash:
        raise ValueError(f"probe name {clash[0]!r} is a field of {base.__name__}")
    fields = [(name, float) for name in probes]
    made: type[Record] = dataclasses.make_dataclass(
        f"{base.__name__}WithProbes", fields, bases=(base,)
    )
    return made


def probe_text(record: Any, base: type) -> str:
    """The probes of ``record`` (its fields after those of ``base``) for a progress line.

    Args:
        record: an instance of :func:`with_probes` of ``base``.
        base: the record's dataclass without probes.

    Returns:
        ``"  name value"`` per probe.
    """
    return "".join(
        f"  {f.name} {getattr(record, f.name):.6g}"
        for f in dataclasses.fields(record)[len(dataclasses.fields(base)) :]
    )


class LoadFactor:
    """The load factor λ of an energy and the Dirichlet data that grow with it.

    Args:
        constant: the Constant λ that the energy depends on.
        bc_values: ``(datum, value)`` pairs of Dirichlet data at full load: :meth:`set` makes
            ``datum.value = λ × value``.
    """

    def __init__(
        self,
        constant: dolfinx.fem.Constant[np.float64],
        bc_values: Sequence[tuple[dolfinx.fem.Constant[np.float64], npt.ArrayLike]] = (),
    ) -> None:
        self.constant = constant
        self.bc_values = [(c, np.asarray(v, dtype=float)) for c, v in bc_values]

    @property
    def value(self) -> float:
        """The current load factor."""
        return float(self.constant.value)

    def set(self, factor: float) -> None:
        """Set the load factor and the Dirichlet data at it.

        Args:
            factor: the load factor λ; each datum becomes λ times its value at full load.
        """
        self.constant.value = np.asarray(factor)
        for datum, value in self.bc_values:
            datum.value = np.asarray(factor * value)


class LoadPath(Driver):
    """Newton's method (PETSc SNES) on DΠ(u) = 0 at each load factor of a schedule.

    Args:
        state: the unknown u (any space); its value is the start of the first load step.
        energy: Π(u), a UFL functional of ``state`` (a form of rank 0).
        bcs: Dirichlet conditions on ``state``'s space.
        load_factor: the Constant that ``energy`` depends on; its value is the load factor
            the state belongs to (0 for an unloaded start).
        schedule: the load factors to solve at, in order; consecutive ones must differ.
        prefix: the PETSc options prefix, e.g. ``"dgplate_fvk_"`` (so ``-dgplate_fvk_snes_monitor``
            works); one live driver per prefix.
        options: PETSc options (SNES, KSP, PC) over :data:`dgplate.solvers.snes.NEWTON_DEFAULTS`;
            options that PETSc refuses (an unknown type, a factor package it lacks) are an
            InputError naming ``options_key``, their problem-file key.
        bc_values: ``(constant, value)`` pairs of Dirichlet data at full load: the driver sets
            ``constant.value = load factor × value`` whenever the load factor changes.
        secant: start each step from the secant extrapolation of the last two states.
        observers: told of every load step and of the end of :meth:`run`.
        shape: the deformed surface y: ω → ℝ³, a Function or a callable that updates it.
        probes: numbers of the state added to every record (named as at the start).
        hint: what to try when Newton fails, appended to the reason.
        checkpoint_every: load steps between checkpoints (a load step is expensive: each).
        stability: the lowest Hessian eigenvalue after each step (:class:`Stability`) or None.
        relaxation: a proximal gradient flow (:class:`Relaxation`) before Newton, or None.
        options_key: the problem-file key of ``options``, for errors.

    All methods are collective on the state's communicator.
    """

    def __init__(
        self,
        state: dolfinx.fem.Function[np.float64],
        energy: ufl.Form,
        bcs: Sequence[dolfinx.fem.DirichletBC[np.float64]],
        load_factor: dolfinx.fem.Constant[np.float64],
        schedule: Sequence[float],
        prefix: str,
        options: Mapping[str, Any] | None = None,
        *,
        bc_values: Sequence[tuple[dolfinx.fem.Constant[np.float64], npt.ArrayLike]] = (),
        secant: bool = True,
        observers: Sequence[Observer] = (),
        shape: Shape,
        probes: Probes | None = None,
        hint: str = "",
        checkpoint_every: int = 1,
        stability: Stability | None = None,
        relaxation: Relaxation | None = None,
        options_key: str = "newton.snes",
    ) -> None:
        self.schedule = _checked_schedule(schedule, float(load_factor.value))
        check_prefix(prefix)
        self.state, self.comm = state, state.function_space.mesh.comm
        self.load = LoadFactor(load_factor, bc_values)
        self.secant, self.observers, self.hint = secant, list(observers), hint
        self._shape_source, self._probes = shape, probes
        self.step_count, self._checkpoint_every = 0, checkpoint_every
        self.history: list[LoadStep] = []
        self.residual_norms: list[list[float]] = []
        self.relaxation, self.stability = relaxation, stability
        self._previous: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(
            state.function_space, name="previous"
        )
        # the converged states (load factor, values) of the secant predictor: the last two
        self.states: list[tuple[float, npt.NDArray[np.float64]]] = [
            (self.time, state.x.array.copy())
        ]
        self.initial = state.x.array.copy()  # the deflection scale is measured from it
        self.set_load(self.time)
        self._shape = _shape_of(self._shape_source)
        self.spectrum = StabilityObserver(self, stability.solver if stability else None)
        names = list(probes()) if probes else []
        self._record = record_type([*names, LOWEST] if stability else names)
        self._prefix = prefix
        self.newton = NewtonSolver(state, energy, bcs, prefix, options, options_key)
        self.branches = BranchLeaving(self)
        self._live = True
        hold_prefix(prefix)

    # -- the Driver protocol ----------------------------------------------------------------
    @property
    def checkpoint_every(self) -> int:
        """Load steps between checkpoints."""
        return self._checkpoint_every

    @property
    def time(self) -> float:
        """The load factor of the current state."""
        return self.load.value

    @property
    def shape(self) -> dolfinx.fem.Function[np.float64]:
        """The deformed surface y: ω → ℝ³ of the current state."""
        return self._shape

    @property
    def num_dofs(self) -> int:
        """The global number of unknowns."""
        imap = self.state.function_space.dofmap.index_map
        return int(imap.size_global * self.state.function_space.dofmap.index_map_bs)

    def remaining_steps(self) -> int:
        """Load steps of the schedule not solved yet."""
        return len(self.schedule) - self.step_count

    def path_progress(self) -> tuple[float, str]:
        """The part of the schedule solved and its end, for the progress lines' estimate."""
        return self.step_count / len(self.schedule), f"load factor {self.schedule[-1]:g}"

    def options_prefixes(self) -> list[str]:
        """The options prefix of the SNES (``model.snes``)."""
        return self.newton.prefixes()

    def run(self, max_steps: int | None = None) -> RunResult:
        """Solve the rest of the schedule, at most ``max_steps`` load steps (None: all).

        Ends early when a load step fails (``converged = False``, the SNES reason; the last
        converged state is kept) or on SIGINT/SIGTERM (``interrupted``).
        """
        remaining = self.schedule[self.step_count :]
        budget = len(remaining) if max_steps is None else min(max_steps, len(remaining))
        records: list[LoadStep] = []
        failure, signum = None, 0
        for _ in range(budget):
            try:
                record = self.step()
            except SolverError as err:  # collective: the SNES reason is the same on all ranks
                failure = f"{err}; the last converged state is kept"
                break
            records.append(record)
            for observer in self.observers:
                observer.step(self, record)
            if self.step_count == len(self.schedule):
                break
            signum = interrupt.requested(self.comm)
            if signum:
                break
        converged, reason = _outcome(self, failure, signum)
        result = RunOutcome(converged, reason, len(records), records, interrupted=signum)
        for observer in self.observers:
            observer.finish(self, result)
        return result

    def checkpoint_fields(self) -> dict[str, dolfinx.fem.Function[np.float64]]:
        """The state and the one before it (the secant predictor's two points)."""
        self._previous.x.array[:] = self.states[0][1]
        return {"state": self.state, "previous": self._previous}

    def checkpoint_state(self) -> dict[str, Any]:
        """Load steps done, the load factors of the two states and the history."""
        return {
            "step": self.step_count,
            "load_factors": [factor for factor, _ in self.states],
            "history": [asdict(record) for record in self.history],
            "residual_norms": self.residual_norms,
            **self.spectrum.checkpoint_state(),
            "relaxations": self.branches.relaxations,
        }

    def restore_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state` (the fields are restored first)."""
        self.step_count = int(state["step"])
        self.history = [self._record(**row) for row in state["history"]]
        self.residual_norms = [list(norms) for norms in state["residual_norms"]]
        self.spectrum.restore_state(state)
        self.branches.relaxations = [dict(r) for r in state.get("relaxations", [])]
        factors = [float(factor) for factor in state["load_factors"]]
        for function in (self.state, self._previous):
            function.x.scatter_forward()
        arrays = [self._previous.x.array.copy(), self.state.x.array.copy()]
        self.states = list(zip(factors, arrays[-len(factors) :]))
        self.set_load(factors[-1])
        self._shape = _shape_of(self._shape_source)

    def summary(self) -> dict[str, Any]:
        """Numbers for ``summary.json``: dofs, load factors, Newton iterations, energy.

        ``load_steps`` counts the load steps solved, ``load_steps_scheduled`` the schedule's.

        With :class:`Stability` also :meth:`StabilityObserver.summary`; with a
        :class:`Relaxation`, :meth:`BranchLeaving.summary`.
        """
        summary: dict[str, Any] = {
            "dofs": self.num_dofs,
            "load_factor": self.time,
            "load_steps": self.step_count,
            "load_steps_scheduled": len(self.schedule),
            "load_factors": [record.load_factor for record in self.history],
            "snes_iterations": [record.iterations for record in self.history],
            "residual_norms": self.residual_norms,
            "energy": self.energy_value(),
        }
        if self.stability:
            summary.update(self.spectrum.summary())
        if self.relaxation:
            summary.update(self.branches.summary())
        return summary

    def destroy(self) -> None:
        """Free the PETSc objects and delete this driver's options (idempotent)."""
        if not self._live:
            return
        self._live = False
        self.newton.destroy()
        release_prefix(self._prefix)

    def __enter__(self) -> LoadPath:
        """``with LoadPath(...) as driver:`` destroys the driver at the end."""
        return self

    def __exit__(self, *exc: object) -> None:
        """:meth:`destroy`."""
        self.destroy()

    # -- load steps -------------------------------------------------------------------------
    def step(self) -> LoadStep:
        """Solve at the next load factor of the schedule (see :meth:`solve`)."""
        if self.step_count >= len(self.schedule):
            raise SolverError(f"the schedule of {len(self.schedule)} load steps is done")
        return self.solve(self.schedule[self.step_count])

    def solve(self, factor: float) -> LoadStep:
        """Solve at load factor ``factor`` from the predictor; the record of the step.

        Raises :class:`SolverError` with the SNES reason when Newton fails; the state and the
        load factor are then those of the last converged step (or of the start).
        """
        start = time.perf_counter()
        self._predict(factor)
        self.set_load(factor)
        self.newton.norms = []
        its = self.solve_at(factor)
        self.states = [*self.states[-1:], (factor, self.state.x.array.copy())]
        probes: dict[str, float] = {}
        if self.stability:
            probes[LOWEST], more = self.spectrum.check(factor, self.stability)
            its += more
        self.step_count += 1
        norms = self.newton.norms
        self.residual_norms.append(list(norms))
        self._shape = _shape_of(self._shape_source)
        probes.update(self._probes() if self._probes else {})
        record = self._record(
            step=self.step_count,
            load_factor=factor,
            iterations=its,
            residual=norms[-1] if norms else math.nan,
            energy=self.energy_value(),
            seconds=time.perf_counter() - start,
            **probes,
        )
        self.history.append(record)
        return record

    def solve_at(self, factor: float) -> int:
        """Newton, or the relaxation and then Newton, at ``factor``: the iterations spent."""
        its = self.branches.relax(factor, self.relaxation) if self.relaxation else 0
        return its + self._newton(factor)

    def _newton(self, factor: float) -> int:
        """SNES from the current state at ``factor``: its iterations, or a SolverError."""
        reason, its = self.newton.solve()
        if reason < 0:
            self.take_back()
            hint = f"; {self.hint}" if self.hint else ""
            raise SolverError(
                f"Newton failed at load step {self.step_count + 1} (load factor {factor:g}): "
                f"SNES reason {snes_reason(reason)} after {its} iterations{hint}"
            )
        return int(its)

    def _predict(self, factor: float) -> None:
        """The secant extrapolation of the last two states to ``factor`` (if there are two)."""
        if not self.secant or len(self.states) < 2:
            return
        (f0, x0), (f1, x1) = self.states[-2:]
        self.state.x.array[:] = x1 + (factor - f1) / (f1 - f0) * (x1 - x0)

    def take_back(self) -> None:
        """Back to the last converged state and its load factor."""
        factor, array = self.states[-1]
        self.state.x.array[:] = array
        self.set_load(factor)
        self._shape = _shape_of(self._shape_source)

    def set_load(self, factor: float) -> None:
        """The load factor and the Dirichlet data at it."""
        self.load.set(factor)

    def energy_value(self) -> float:
        """Π of the current state (collective)."""
        return self.newton.energy_value()


def _outcome(driver: LoadPath, failure: str | None, signum: int) -> tuple[bool, str]:
    """(converged, reason) of a run that ended with ``failure`` or signal ``signum``."""
    total = len(driver.schedule)
    if failure:
        return False, failure
    if signum:
        return False, interrupt.reason(signum)
    if driver.step_count == total:
        return True, f"all {total} load steps converged"
    return False, (
        f"step budget spent after {driver.step_count} of {total} load steps "
        f"(load factor {driver.time:g})"
    )


def _shape_of(source: Shape) -> dolfinx.fem.Function[np.float64]:
    """The deformed surface of a driver's ``shape`` argument: the Function, or updated."""
    return source if isinstance(source, dolfinx.fem.Function) else source()


def _checked_schedule(schedule: Sequence[float], start: float) -> list[float]:
    """The schedule as floats: finite, non-empty, no two consecutive factors equal."""
    factors = [float(factor) for factor in schedule]
    if not factors or not all(math.isfinite(f) for f in factors):
        raise ValueError(f"a schedule needs finite load factors, got {list(schedule)!r}")
    if any(a == b for a, b in zip([start, *factors], factors)):
        raise ValueError(f"consecutive load factors must differ, got {factors!r} from {start:g}")
    return factors
