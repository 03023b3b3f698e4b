"""Path following through folds: the arclength continuation as a driver of the runner.

:class:`BranchPath` follows the equilibria of an energy Π(u; λ) by
:class:`dgplate.solvers.arclength.ArcLength` from a start at λ₀ and reports one
:class:`BranchPoint` per point (a row of ``history.csv``): the load factor, the energy, the
probes, the stability index, the tangent's λ-component and the kind of point (``regular``,
``fold``, ``bifurcation``, or ``switch``: the first point on a branch left at a bifurcation).
The special points are located between two points of the path (:mod:`dgplate.solvers.arclength`)
and listed in the summary (``special_points``; their load factors in ``folds`` and
``bifurcations``). A special point that cannot be located is not recorded: the point after it
has the kind ``fold_unlocated`` or ``bifurcation_unlocated``, and its load factor is listed in
``unlocated``, not in ``folds`` or ``bifurcations``. The path ends after ``steps`` points, when λ
leaves [−``lambda_max``, ``lambda_max``], or when a corrector fails at the step ``ds_min``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import dolfinx.fem
import numpy as np
import ufl

from dgplate import interrupt
from dgplate.errors import SolverError
from dgplate.solvers.arclength import ArcLength, Multipliers, Point, StepLength
from dgplate.solvers.driver import Driver, Observer, RunOutcome, RunResult
from dgplate.solvers.newton import LoadFactor, Probes, probe_text, with_probes
from dgplate.solvers.prefixes import check_prefix, hold_prefix, release_prefix
from dgplate.solvers.snes import NewtonSolver
from dgplate.solvers.special_points import SpecialPoints


@dataclass(frozen=True)
class PathSettings:
    """What a path following does (the problem file's ``[path]``, :class:`BranchPath`).

    Attributes:
        step: the step-length control.
        steps: points of the path: no step starts once there are this many (the start and
            the special points count; a last step that finds a special point adds it and the
            point after it, one more).
        lambda_max: the path ends beyond this load factor.
        switch: leave the first bifurcation along the critical eigenvector.
        derivative_step: the step h of the central difference ∂R/∂λ (exact at any h for an
            R at most quadratic in λ, :mod:`dgplate.solvers.arclength`).
    """

    step: StepLength
    steps: int = 50
    lambda_max: float = 1.0
    switch: bool = False
    derivative_step: float = 1.0


@dataclass
class BranchPoint:
    """One point of a followed path: a row of ``history.csv`` (probes in further fields)."""

    step: int
    load_factor: float
    energy: float
    stability_index: int
    tangent_load: float  # the λ-component τ of the unit tangent
    ds: float  # the step that reached the point
    iterations: int  # corrector iterations
    branch: int  # 0, then 1 after a switch
    kind: str  # :data:`dgplate.solvers.arclength.KINDS`
    seconds: float

    @property
    def notable(self) -> bool:
        """Whether the progress output always shows this point: not a regular one."""
        return self.kind != "regular"

    def line(self) -> str:
        """One line of progress output."""
        probes = probe_text(self, BranchPoint)
        return (
            f"point {self.step:4d}  load factor {self.load_factor:.6g}  index "
            f"{self.stability_index}  {self.kind:<11s} ds {self.ds:.3g}  its {self.iterations:2d}"
            f"  energy {self.energy:+.6e}{probes}"
        )


class BranchPath(Driver):
    """Arclength continuation of DΠ(u; λ) = 0 from the state at λ₀, as a runner's driver.

    Args:
        state: the unknown u; its value is the first iterate at the start.
        energy: Π(u; λ), a UFL functional of ``state`` and of the Constant ``load_factor``.
        bcs: Dirichlet conditions on the state's space.
        load_factor: the Constant λ; its value is λ₀.
        settings: the path's settings.
        prefix: the PETSc options prefix (as the load path's: the same SNES options).
        options: PETSc options of the Newton solver at the start (and of its linear solver).
        bc_values: ``(datum, value)`` pairs of Dirichlet data at full load.
        shape: the deformed surface y: ω → ℝ³ of the current state (a callable that updates it).
        probes: numbers of the state added to every record.
        observers: told of every point and of the end of :meth:`run`.
        multipliers: the multipliers of a Lagrangian among the unknowns (None: none).
        prelude: called before the start with whether the path has no points yet (else it
            was resumed); returns the signal that stopped it (0: none, the path starts).
    """

    budget_key = "path.steps"
    outcome_words = ("path ended", "path STOPPED")

    def __init__(
        self,
        state: dolfinx.fem.Function[np.float64],
        energy: ufl.Form,
        bcs: Sequence[dolfinx.fem.DirichletBC[np.float64]],
        load_factor: dolfinx.fem.Constant[np.float64],
        settings: PathSettings,
        prefix: str,
        options: Mapping[str, Any] | None = None,
        *,
        bc_values: Sequence[tuple[Any, Any]] = (),
        shape: Callable[[], dolfinx.fem.Function[np.float64]],
        probes: Probes | None = None,
        observers: Sequence[Observer] = (),
        multipliers: Multipliers | None = None,
        prelude: Callable[[bool], int] | None = None,
    ) -> None:
        check_prefix(prefix)
        self.state, self.comm = state, state.function_space.mesh.comm
        self.settings, self.observers = settings, list(observers)
        self._shape_source, self._probes, self._prelude = shape, probes, prelude
        self.load = LoadFactor(load_factor, bc_values)
        self.newton = NewtonSolver(state, energy, bcs, prefix, options, "newton.snes")
        self.engine = ArcLength(
            self.newton, self.load, f"{prefix}path_", settings.derivative_step, multipliers
        )
        self.special = SpecialPoints(self.engine, settings.step)
        self._record = with_probes(BranchPoint, list(probes()) if probes else [])
        self.history: list[BranchPoint] = []
        self.step_count, self.branch, self.switched = 0, 0, False
        self.current: Point | None = None
        self.ds = settings.step.ds
        self._sigma: float | None = None  # σ of a resumed path (None: set at the start)
        self._clock = time.perf_counter()  # the start of the current step
        self._shape = shape()
        self._prefix: str | None = prefix
        hold_prefix(prefix)

    @property
    def checkpoint_every(self) -> int:
        """A checkpoint at every point, as a load path's.

        The row of a special point is saved with the path still at the point before it; the
        row of the point after it follows with no solve in between and replaces that checkpoint.
        """
        return 1

    @property
    def time(self) -> float:
        """The number of points so far: the time of the VTX series (λ turns at a fold)."""
        return float(self.step_count)

    @property
    def shape(self) -> dolfinx.fem.Function[np.float64]:
        """The deformed surface of the current state."""
        return self._shape

    @property
    def num_dofs(self) -> int:
        """The global number of unknowns."""
        return int(self.state.x.index_map.size_global * self.state.x.block_size)

    def remaining_steps(self) -> int:
        """Points of the path not reached yet."""
        return max(self.settings.steps - self.step_count, 0)

    def options_prefixes(self) -> list[str]:
        """The prefixes of the SNES at the start and of the bordered system's solver."""
        return [*self.newton.prefixes(), self.engine.system.ksp.getOptionsPrefix() or ""]

    def checkpoint_fields(self) -> dict[str, dolfinx.fem.Function[np.float64]]:
        """The state."""
        return {"state": self.state}

    def checkpoint_state(self) -> dict[str, Any]:
        """The points so far, the next step length and the scale σ of the inner product.

        A resumed path starts again from its last point, with this step and this σ: the
        points after it are those of the uninterrupted path.
        """
        return {
            "step": self.step_count,
            "history": [asdict(r) for r in self.history],
            "ds": self.ds,
            # a resume that took no step (it wrote the outputs only) has not started the engine
            "sigma": self.engine.sigma if self.current is not None else self._sigma,
        }

    def restore_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state`: the last point becomes the start."""
        self.history = [self._record(**row) for row in state["history"]]
        self.step_count = int(state["step"])
        self.ds = float(state.get("ds", self.ds))
        self._sigma = state.get("sigma")
        if self.history:
            last = self.history[-1]
            self.load.set(last.load_factor)
            self.branch, self.switched = last.branch, last.branch > 0
        self._shape = self._shape_source()  # of the restored state (a resume may take no step)

    def summary(self) -> dict[str, Any]:
        """The points, the special points and the last load factor."""
        return {
            "dofs": self.num_dofs,
            "load_factor": self.load.value,
            "points": self.step_count,
            **path_figures(self.history),
            "energy": self.newton.energy_value(),
        }

    def destroy(self) -> None:
        """Free the PETSc objects and the options prefix (idempotent)."""
        if self._prefix is None:
            return
        if self.current is not None:
            self.current.destroy()
            self.current = None
        self.engine.destroy()
        self.newton.destroy()
        release_prefix(self._prefix)
        self._prefix = None

    def run(self, max_steps: int | None = None) -> RunResult:
        """Follow the path until ``max_steps`` more points (None: ``steps`` points in all).

        No step starts once the points are that many; a step adds one point, or two at a
        special point. The ``prelude`` runs before the start.

        Args:
            max_steps: the points to add at most in this call, but for that one over.

        Returns:
            The outcome: converged unless a step failed or a signal stopped the path, with
            the reason and this call's records.
        """
        left = self.remaining_steps()
        target = self.step_count + (left if max_steps is None else min(max_steps, left))
        records: list[BranchPoint] = []
        failure, signum = "", 0
        try:
            if self.current is None and self.step_count < target:
                signum = self._prelude(not self.history) if self._prelude else 0
                records += [] if signum else self._start()
            while not signum and self.step_count < target and self._inside(self.current):
                records += self._advance()
                signum = interrupt.requested(self.comm)
                if signum:
                    break
        except SolverError as err:
            failure = str(err)
            if self.current is not None:
                failure += "; the last point is kept"
                self.engine.set_state(self.current)
        converged = not failure and not signum
        reason = failure or (
            interrupt.reason(signum) if signum else self._end() + special_points_text(self.history)
        )
        result = RunOutcome(converged, reason, len(records), records, interrupted=signum)
        for observer in self.observers:
            observer.finish(self, result)
        return result

    def _start(self) -> list[BranchPoint]:
        """The first point: the start, or the last point of a resumed path (not recorded again).

        A resumed path goes on in the direction of λ it had (the sign of the last τ).
        """
        self._clock = time.perf_counter()
        self.current = self.engine.start(self.load.value, self._sigma)
        if not self.history:
            return [self._report(self.current, 0.0, "regular")]
        if self.history[-1].tangent_load < 0:
            self.current.t.scale(-1.0)
            self.current.tau = -self.current.tau
        return []

    def _inside(self, point: Point | None) -> bool:
        """Whether the path goes on from ``point``: λ within its bounds."""
        return point is not None and abs(point.lam) <= self.settings.lambda_max

    def _end(self) -> str:
        if self.current is not None and not self._inside(self.current):
            return f"the load factor left its range at {self.current.lam:g}"
        if self.extendable():
            return (
                f"path.steps = {self.settings.steps} points spent at load factor "
                f"{self.load.value:g}, within ±{self.settings.lambda_max:g} (--resume --set "
                f"path.steps={2 * self.settings.steps} goes on)"
            )
        return f"{self.step_count} points of the path"

    def extendable(self) -> bool:
        """Whether its points are spent, λ inside its range (a resume writing outputs too)."""
        inside = abs(self.load.value) <= self.settings.lambda_max
        return self.remaining_steps() <= 0 and bool(self.history) and inside

    def _advance(self) -> list[BranchPoint]:
        """One arclength step, and the special point before it, if any: their records.

        Nothing is recorded when the step fails (a SolverError): the path stays at its last
        point.
        """
        self._clock = time.perf_counter()
        if (base := self.current) is None:
            raise SolverError("the path has no point to go on from")
        new, ds = self._step(base)
        try:
            records, new, last = self._special(base, new, ds)
        except BaseException:
            new.destroy()
            raise
        self.engine.set_state(new)
        base.destroy()
        self.current = new
        self.ds = self.settings.step.after(ds, new.iterations)
        records.append(self._report(new, ds, last))  # a checkpoint here holds the new point
        return records

    def _special(self, base: Point, new: Point, ds: float) -> tuple[list[BranchPoint], Point, str]:
        """The record of the special point between ``base`` and ``new`` (if any, and located).

        Returns:
            The records, the point to go on from (``new``, or the first point of the branch
            switched to) and the kind of that point: ``"<kind>_unlocated"`` after a special point
            that could not be located.
        """
        kind = self.special.kind(base, new)
        if not kind:
            return [], new, "regular"
        try:
            special = self.special.locate(kind, base, new, ds)
        except SolverError:
            return [], new, f"{kind}_unlocated"
        try:
            if kind != "bifurcation" or not self.settings.switch or self.switched:
                return [self._report(special, ds, kind)], new, "regular"
            switched = self.special.switch(special, ds)
            self.engine.set_state(special)
            record = self._report(special, ds, kind)
            new.destroy()
            self.branch, self.switched = self.branch + 1, True
            return [record], switched, "switch"
        finally:
            special.destroy()

    def _step(self, base: Point) -> tuple[Point, float]:
        """The next point from ``base``: the step halved until the corrector converges."""
        ds = self.ds
        while True:
            corrected = self.engine.correct(base, ds, (base.t, base.tau))
            if corrected is not None:
                lam, its = corrected
                return self.engine.point(lam, (base.t, base.tau), its), ds
            ds = self.settings.step.halved(ds)

    def _report(self, point: Point, ds: float, kind: str) -> BranchPoint:
        """The record of ``point`` (the state is at it), kept and told to the observers."""
        self._shape = self._shape_source()
        record = self._record(
            step=self.step_count + 1,
            load_factor=point.lam,
            energy=self.newton.energy_value(),
            stability_index=point.index,
            tangent_load=point.tau,
            ds=ds,
            iterations=point.iterations,
            branch=self.branch,
            kind=kind,
            seconds=time.perf_counter() - self._clock,
            **(self._probes() if self._probes else {}),
        )
        self.step_count += 1
        self.history.append(record)
        for observer in self.observers:
            observer.step(self, record)
        return record


def path_figures(history: Sequence[BranchPoint]) -> dict[str, Any]:
    """The summary's figures of a path's points.

    Args:
        history: the points in order.

    Returns:
        ``load_factors`` and ``stability_indices`` per point, ``special_points`` (the rows of
        the located ones and of a switch), their load factors ``folds`` and ``bifurcations``,
        the first of each (``first_fold``, ``first_bifurcation``: None without one; numbers
        that ``dgplate converge`` follows over the levels), and ``unlocated`` (the load
        factors of the points after unlocated ones).
    """
    folds = [r.load_factor for r in history if r.kind == "fold"]
    bifurcations = [r.load_factor for r in history if r.kind == "bifurcation"]
    return {
        "load_factors": [r.load_factor for r in history],
        "stability_indices": [r.stability_index for r in history],
        "special_points": [
            asdict(r) for r in history if r.kind != "regular" and not r.kind.endswith("_unlocated")
        ],
        "folds": folds,
        "bifurcations": bifurcations,
        "first_fold": folds[0] if folds else None,
        "first_bifurcation": bifurcations[0] if bifurcations else None,
        "unlocated": [r.load_factor for r in history if r.kind.endswith("_unlocated")],
    }


#: At most this many special points are named in a path's reason (the rest are counted).
NAMED_SPECIAL_POINTS = 6


def special_points_text(history: Sequence[BranchPoint]) -> str:
    """``"; bifurcation at 0.8199 (index 0 → 1), fold at 0.8246 (index 1 → 2)"``, or ``""``.

    Args:
        history: the points of the whole path (a resumed one's too), in order.

    Returns:
        The folds and bifurcations, with the stability indices of the points before and after
        each ("?" where there is none; after a switch, the new branch's), and the unlocated
        ones: the first
        :data:`NAMED_SPECIAL_POINTS`, and how many more.
    """
    named = []
    for i, point in enumerate(history):
        if point.kind in ("fold", "bifurcation"):
            before = history[i - 1].stability_index if i else "?"
            following = history[i + 1] if i + 1 < len(history) else None
            after = "?" if following is None else following.stability_index
            if following is not None and following.branch != point.branch:
                indices = f"index {before}; switched onto a branch of index {after}"
            else:
                indices = f"index {before} → {after}"
            named.append(f"{point.kind} at {point.load_factor:.6g} ({indices})")
        elif point.kind.endswith("_unlocated"):
            named.append(f"{point.kind.replace('_', ' ')} before {point.load_factor:.6g}")
    if len(named) > NAMED_SPECIAL_POINTS:
        more = len(named) - NAMED_SPECIAL_POINTS
        named = [*named[:NAMED_SPECIAL_POINTS], f"{more} more (summary.json: special_points)"]
    return f"; {', '.join(named)}" if named else ""
