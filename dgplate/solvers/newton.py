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

:class:`Continuation` is a :class:`dgplate.solvers.driver.Driver`: ``run`` reports one
:class:`LoadStep` per converged load step to the observers, stops on SIGINT/SIGTERM at a step
boundary (on every rank together), and reports a load step whose Newton iteration fails as
``converged = False`` with the SNES reason, keeping the last converged state. A checkpoint
holds the state, the state before it (the predictor's second point) and the history, so a
resumed run continues the schedule.

Stability (``stability``, a :class:`Stability`). After each converged load step the driver
computes the eigenvalues of the Hessian D²Π nearest a shift (default 0), i.e. of the Jacobian
at the converged state restricted to the free unknowns (the rows and columns of the Dirichlet
unknowns removed), by :func:`dgplate.solvers.eigen.nearest_eigenpairs` (SLEPc when importable,
else Lanczos with a MUMPS factorisation). The lowest of them is the record's
``lowest_eigenvalue``; where it changes sign from one step to the next, the load factor of the
crossing is interpolated linearly (``critical_load_factors`` in the summary). With
``perturb = a`` the state of a step whose lowest eigenvalue has just turned negative is moved
by a·φ (φ the unstable mode, max |φ_i| = 1, signed by :mod:`dgplate.solvers.eigen`) and Newton
is run again at the same load factor: the path leaves an unstable (e.g. symmetric) branch for
a stable one. The next step then starts from the new state alone (no secant through the jump).

Leaving an unstable branch (``Stability.leave``, a :class:`Leave`). Newton from a push may fall
back onto the unstable state, and a flow whose stopping test is a small residual may stop on a
saddle. With ``leave`` set, every converged step whose lowest eigenvalue is below −tol (tol =
``eig_rtol`` × the largest |lowest eigenvalue| of the path so far) is left by rounds of
push–relax: the state is moved by a·φ along the unstable mode with a = ``fraction`` × the
deflection scale (the largest change of a free unknown since the start of the path), relaxed by
the proximal flow of :class:`Relaxation` (which only lowers Π, so it cannot return to the
saddle it left), polished by Newton (kept only if it converged without raising Π), and the
eigenvalues computed again; the rounds end when the lowest eigenvalue is ≥ −tol (a stable state,
up to the near-zero modes a broken symmetry leaves) or after ``rounds`` rounds. Rank 0 prints one
line per branch left; ``perturbations`` records each round (amplitude, energies, eigenvalues).

Relaxation (``relaxation``, a :class:`Relaxation`). Newton finds critical points, not minima:
from a small push off an unstable state it often returns to it. With a :class:`Relaxation` each
load step (and each solve after a push) is a proximal gradient flow in pseudo-time instead,
the implicit Euler steps

    vⁿ⁺¹ = argmin Π(v) + 1/(2τ) ‖v − vⁿ‖²,   ‖·‖ the L² norm of all components,

each solved by the same SNES on the residual DΠ(v) + (1/τ) M(v − vⁿ) and its Jacobian (the
proximal term is added to the UFL residual with a Constant 1/τ, zero outside the flow, so the
stability check sees the plain Hessian). A step is accepted only if Π does not increase
(a step that lands on a saddle of the proximal functional, e.g. back on the flat state, raises
Π and is rejected); τ doubles after a step that converged in a few iterations and is quartered
after a rejected or failed one. The flow stops when the residual of the unmodified problem is
below ``rtol`` × its value at the start of the load step (or ``atol``), and plain Newton then
polishes the state to the SNES tolerance. The energies of the accepted steps are recorded
(``relaxations`` in the summary, with the increases, which must be none).
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import logging
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any, TypeAlias, cast

from mpi4py import MPI

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl
from petsc4py import PETSc

from dgplate import interrupt
from dgplate.errors import SolverError
from dgplate.solvers import eigen, linear
from dgplate.solvers.driver import Observer, RunOutcome, RunResult

#: SNES defaults; the ``options`` of a :class:`Continuation` override any key.
NEWTON_DEFAULTS: dict[str, Any] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "nleqerr",
    "snes_rtol": 1e-10,
    "snes_max_it": 30,
    **linear.DIRECT_MUMPS,
}

_REASONS: dict[int, str] = {
    value: name
    for name, value in vars(PETSc.SNES.ConvergedReason).items()
    if isinstance(value, int)
}

_log = logging.getLogger(__name__)

#: Options prefixes of the live drivers: two at once would read each other's options.
_LIVE_PREFIXES: set[str] = set()

# strings: DOLFINx 0.9's Function is not subscriptable at run time
Shape: TypeAlias = (
    "dolfinx.fem.Function[np.float64] | Callable[[], dolfinx.fem.Function[np.float64]]"
)
Probes = Callable[[], Mapping[str, float]]

#: The record field of the lowest Hessian eigenvalue.
LOWEST = "lowest_eigenvalue"


@dataclass(frozen=True)
class Stability:
    """The Hessian eigenvalues computed after each load step (module docstring).

    Attributes:
        modes: how many eigenvalues nearest ``shift`` are computed; the lowest is reported.
            A few (default 3) make it the lowest one also where two modes come close.
        shift: where the eigenvalues are looked for (0: the stability limit).
        perturb: amplitude a of the perturbation a·φ along the unstable mode when the lowest
            eigenvalue turns negative; 0 for none.
        solver: "auto", "slepc" or "lanczos" (:data:`dgplate.solvers.eigen.SOLVERS`).
        tol: relative tolerance of the eigenvalues.
        leave: leave every unstable state by rounds of push and relaxation (:class:`Leave`);
            None: only ``perturb`` (once, where the eigenvalue turns negative).
    """

    modes: int = 3
    shift: float = 0.0
    perturb: float = 0.0
    solver: str = "auto"
    tol: float = 1e-10
    leave: Leave | None = None


@dataclass(frozen=True)
class Relaxation:
    """The proximal gradient flow that replaces Newton per solve (module docstring).

    Attributes:
        tau: the first pseudo-time step τ (in the units of Π per squared L² norm of the state).
        rtol: the flow stops when the plain residual is below rtol × its start value ...
        atol: ... or below atol.
        max_steps: accepted plus rejected steps per solve before the solve fails.
        fast: a step converged in at most this many Newton iterations doubles τ.
        stall: stop also when the residual has not reached a new minimum in this many steps
            (round-off reached); 0: never.
    """

    tau: float = 1.0
    rtol: float = 1e-6
    atol: float = 1e-14
    max_steps: int = 200
    fast: int = 4
    stall: int = 0


@dataclass(frozen=True)
class Leave:
    """Push–relax rounds that leave an unstable state for a stable one (module docstring).

    Attributes:
        fraction: push amplitude / the deflection scale (largest change of a free unknown since
            the start of the path); a fraction, so it scales with the deformation.
        eig_rtol: the state is stable when its lowest eigenvalue is ≥ −eig_rtol × the largest
            |lowest eigenvalue| met on the path (the scale of the Hessian's small eigenvalues).
        rounds: push–relax rounds at most per load step.
        relaxation: the proximal flow after each push (its ``rtol`` relative to the residual of
            the pushed state; ``stall`` accepts a flow that has reached round-off).
    """

    fraction: float = 0.05
    eig_rtol: float = 1e-3
    rounds: int = 4
    relaxation: Relaxation = dataclasses.field(
        default_factory=lambda: Relaxation(tau=1.0, rtol=1e-4, max_steps=300, stall=10)
    )


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
        probes = "".join(
            f"  {f.name} {getattr(self, f.name):.6g}"
            for f in dataclasses.fields(self)[len(dataclasses.fields(LoadStep)) :]
        )
        return (
            f"load step {self.step:4d}  load factor {self.load_factor:.4g}  Newton its "
            f"{self.iterations:2d}  energy {self.energy:+.6e}{probes}  {self.seconds:.2f} s"
        )


def record_type(probes: Sequence[str]) -> type[LoadStep]:
    """:class:`LoadStep` with one more float field per probe name (flat history rows)."""
    if not probes:
        return LoadStep
    clash = sorted(set(probes) & {f.name for f in dataclasses.fields(LoadStep)})
    if clash:
        raise ValueError(f"probe name {clash[0]!r} is a field of LoadStep")
    fields = [(name, float) for name in probes]
    return dataclasses.make_dataclass("LoadStepWithProbes", fields, bases=(LoadStep,))


def snes_reason(code: int) -> str:
    """The name of a SNES converged reason, e.g. ``DIVERGED_MAX_IT``."""
    return _REASONS.get(code, str(code))


class Continuation:
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
        options: PETSc options (SNES, KSP, PC) over :data:`NEWTON_DEFAULTS`; options that PETSc
            refuses (an unknown type, a factor package it lacks) are an InputError naming
            ``options_key``, their problem-file key.
        bc_values: ``(constant, value)`` pairs of Dirichlet data at full load: the driver sets
            ``constant.value = load factor × value`` whenever the load factor changes.
        secant: start each step from the secant extrapolation of the two previous states;
            False: from the previous state.
        observers: told of every load step and of the end of :meth:`run`.
        shape: the deformed surface y: ω → ℝ³ as a Function, or a callable returning it
            updated from the state (called after each step and on a restore).
        probes: numbers of the state (e.g. a centre deflection) added to every record; the
            names are those it returns at the start.
        hint: what to try when Newton fails, appended to the reason.
        checkpoint_every: load steps between checkpoints (a load step is expensive: each).
        stability: compute the lowest Hessian eigenvalue after each step (:class:`Stability`);
            None: not.
        relaxation: solve each step by a proximal gradient flow (:class:`Relaxation`) that
            decreases Π, then Newton; None: Newton alone.

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
        options_key: str = "model.snes",
    ) -> None:
        self.schedule = _checked_schedule(schedule, float(load_factor.value))
        if prefix in _LIVE_PREFIXES:
            raise ValueError(f"PETSc options prefix {prefix!r} is in use by a live Continuation")
        self.state, self.bcs, self.comm = state, list(bcs), state.function_space.mesh.comm
        self._load_factor = load_factor
        self._bc_values = [(c, np.asarray(v, dtype=float)) for c, v in bc_values]
        self.secant, self.observers, self.hint = secant, list(observers), hint
        self._shape_source, self._probes = shape, probes
        self.step_count, self.checkpoint_every = 0, checkpoint_every
        self.history: list[LoadStep] = []
        self.residual_norms: list[list[float]] = []
        self._norms: list[float] = []
        space = state.function_space
        residual = ufl.derivative(energy, state, ufl.TestFunction(space))
        self.relaxation = relaxation
        self.relaxations: list[dict[str, Any]] = []
        self._anchor: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(space)
        self._inv_tau = dolfinx.fem.Constant(space.mesh, 0.0)
        # the proximal term (1/τ) M(v − vⁿ), zero outside the flow; always in the forms, so
        # that ``relaxation`` may be set later (e.g. only for the solve after a push)
        gap, mesh = state - self._anchor, space.mesh
        residual += self._inv_tau * ufl.inner(gap, ufl.TestFunction(space)) * ufl.dx(domain=mesh)
        jacobian = ufl.derivative(residual, state, ufl.TrialFunction(space))
        self._energy = dolfinx.fem.form(energy)
        self._residual = dolfinx.fem.form(residual)
        self._jacobian = dolfinx.fem.form(jacobian)
        self._previous: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(
            space, name="previous"
        )
        self._states: list[tuple[float, npt.NDArray[np.float64]]] = [
            (self.time, state.x.array.copy())
        ]
        self._initial = state.x.array.copy()  # the deflection scale is measured from it
        self._set_load(self.time)
        self._shape = self._update_shape()
        self.stability = stability
        self.eigensolver = eigen.resolve_solver(stability.solver) if stability else None
        self._free = _free_rows(space, self.bcs)
        self.crossings: list[float] = []
        self.perturbations: list[dict[str, float]] = []
        names = list(probes()) if probes else []
        self._record = record_type([*names, LOWEST] if stability else names)
        self._prefix = prefix
        self._options = {**NEWTON_DEFAULTS, **(options or {})}
        self._options_key = options_key
        self._setup_snes()
        self._live = True
        _LIVE_PREFIXES.add(prefix)

    # -- set-up -----------------------------------------------------------------------------
    def _setup_snes(self) -> None:
        opts = PETSc.Options()
        for key, value in self._options.items():
            opts.setValue(f"{self._prefix}{key}", value)
        self._A = dolfinx.fem.petsc.create_matrix(self._jacobian)
        self._b = self.state.x.petsc_vec.duplicate()
        self._x = self.state.x.petsc_vec.duplicate()
        snes = self.snes = PETSc.SNES().create(self.comm)
        snes.setOptionsPrefix(self._prefix)
        snes.setFunction(self._assemble_residual, self._b)
        snes.setJacobian(self._assemble_jacobian, self._A)
        snes.setMonitor(self._monitor)
        try:
            snes.setFromOptions()
            linear.check_factor_package(snes.getKSP().getPC(), self._A)
        except PETSc.Error as err:
            # no driver: its PETSc objects and options go (another driver may take the prefix)
            for obj in (snes, self._A, self._b, self._x):
                obj.destroy()
            for key in self._options:
                opts.delValue(f"{self._prefix}{key}")
            raise linear.refused(self._options_key, err) from None

    def _monitor(self, _snes: PETSc.SNES, _it: int, norm: float) -> None:
        self._norms.append(float(norm))

    def _update(self, x: PETSc.Vec) -> None:
        # SNES updates only the owned entries of x: its ghosts (read by apply_lifting, e.g. the
        # values of load-dependent Dirichlet data on another rank's unknowns) must be refreshed
        x.ghostUpdate(PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD)  # type: ignore[arg-type]
        x.copy(self.state.x.petsc_vec)
        self.state.x.scatter_forward()

    def _assemble_residual(self, _snes: PETSc.SNES, x: PETSc.Vec, b: PETSc.Vec) -> None:
        self._update(x)
        with b.localForm() as local:
            local.set(0.0)
        # DOLFINx's stubs know only the form-first overloads of the assemblers
        dolfinx.fem.petsc.assemble_vector(b, self._residual)  # type: ignore[arg-type]
        dolfinx.fem.petsc.apply_lifting(b, [self._jacobian], [self.bcs], [x], -1.0)
        b.ghostUpdate(PETSc.InsertMode.ADD, PETSc.ScatterMode.REVERSE)  # type: ignore[arg-type]
        dolfinx.fem.petsc.set_bc(b, self.bcs, x, -1.0)

    def _assemble_jacobian(
        self, _snes: PETSc.SNES, x: PETSc.Vec, A: PETSc.Mat, _P: PETSc.Mat
    ) -> None:
        self._update(x)
        A.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(A, self._jacobian, self.bcs)  # type: ignore[arg-type]
        A.assemble()

    # -- the Driver protocol ----------------------------------------------------------------
    @property
    def time(self) -> float:
        """The load factor of the current state."""
        return float(self._load_factor.value)

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
        result = RunOutcome(
            *self._outcome(failure, signum), len(records), records, interrupted=signum
        )
        for observer in self.observers:
            observer.finish(self, result)
        return result

    def _outcome(self, failure: str | None, signum: int) -> tuple[bool, str]:
        """(converged, reason) of a run that ended with ``failure`` or signal ``signum``."""
        total = len(self.schedule)
        if failure:
            return False, failure
        if signum:
            return False, interrupt.reason(signum)
        if self.step_count == total:
            return True, f"all {total} load steps converged"
        return False, (
            f"step budget spent after {self.step_count} of {total} load steps "
            f"(load factor {self.time:g})"
        )

    def checkpoint_fields(self) -> dict[str, dolfinx.fem.Function[np.float64]]:
        """The state and the one before it (the secant predictor's two points)."""
        self._previous.x.array[:] = self._states[0][1]
        return {"state": self.state, "previous": self._previous}

    def checkpoint_state(self) -> dict[str, Any]:
        """Load steps done, the load factors of the two states and the history."""
        return {
            "step": self.step_count,
            "load_factors": [factor for factor, _ in self._states],
            "history": [asdict(record) for record in self.history],
            "residual_norms": self.residual_norms,
            "crossings": self.crossings,
            "perturbations": self.perturbations,
            "relaxations": self.relaxations,
        }

    def restore_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`checkpoint_state` (the fields are restored first)."""
        self.step_count = int(state["step"])
        self.history = [self._record(**row) for row in state["history"]]
        self.residual_norms = [list(norms) for norms in state["residual_norms"]]
        self.crossings = [float(f) for f in state.get("crossings", [])]
        self.perturbations = [dict(p) for p in state.get("perturbations", [])]
        self.relaxations = [dict(r) for r in state.get("relaxations", [])]
        factors = [float(factor) for factor in state["load_factors"]]
        for function in (self.state, self._previous):
            function.x.scatter_forward()
        arrays = [self._previous.x.array.copy(), self.state.x.array.copy()]
        self._states = list(zip(factors, arrays[-len(factors) :]))
        self._set_load(factors[-1])
        self._shape = self._update_shape()

    def summary(self) -> dict[str, Any]:
        """Numbers for ``summary.json``: dofs, load factors, Newton iterations, energy.

        With :class:`Stability`: the lowest eigenvalue per step, the interpolated load factors
        where it crosses zero (the first as ``critical_load_factor``, None if none), the
        perturbations (load factor and the eigenvalue before) and the eigensolver.
        """
        summary: dict[str, Any] = {
            "dofs": self.num_dofs,
            "load_factor": self.time,
            "load_steps": len(self.schedule),
            "load_factors": [record.load_factor for record in self.history],
            "snes_iterations": [record.iterations for record in self.history],
            "residual_norms": self.residual_norms,
            "energy": self.energy_value(),
        }
        if self.stability:
            summary.update(
                lowest_eigenvalues=[getattr(record, LOWEST) for record in self.history],
                critical_load_factors=self.crossings,
                critical_load_factor=self.crossings[0] if self.crossings else None,
                perturbations=self.perturbations,
                eigensolver=self.eigensolver,
            )
        if self.relaxation:
            summary.update(
                relaxations=self.relaxations,
                energy_increases=[
                    (r["load_factor"], i)
                    for r in self.relaxations
                    for i, (a, b) in enumerate(itertools.pairwise(r["energies"]))
                    if b > a
                ],
            )
        return summary

    def destroy(self) -> None:
        """Free the PETSc objects and delete this driver's options (idempotent)."""
        if not self._live:
            return
        self._live = False
        opts = PETSc.Options()
        for key in self._options:
            opts.delValue(f"{self._prefix}{key}")
        for obj in (self.snes, self._A, self._b, self._x, self._free[0]):
            obj.destroy()
        _LIVE_PREFIXES.discard(self._prefix)

    def __enter__(self) -> Continuation:
        """``with Continuation(...) as driver:`` destroys the driver at the end."""
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
        self._set_load(factor)
        self._norms = []
        its = self._solve_at(factor)
        self._states = [*self._states[-1:], (factor, self.state.x.array.copy())]
        probes: dict[str, float] = {}
        if self.stability:
            probes[LOWEST], more = self._check_stability(factor, self.stability)
            its += more
        self.step_count += 1
        self.residual_norms.append(list(self._norms))
        self._shape = self._update_shape()
        probes.update(self._probes() if self._probes else {})
        record = self._record(
            step=self.step_count,
            load_factor=factor,
            iterations=its,
            residual=self._norms[-1] if self._norms else math.nan,
            energy=self.energy_value(),
            seconds=time.perf_counter() - start,
            **probes,
        )
        self.history.append(record)
        return record

    def _solve_at(self, factor: float) -> int:
        """Newton, or the relaxation and then Newton, at ``factor``: the iterations spent."""
        its = self._relax(factor, self.relaxation) if self.relaxation else 0
        return its + self._newton(factor)

    def _snes(self) -> tuple[int, int]:
        """SNES from the current state: (reason, iterations); the state is the last iterate."""
        self.state.x.petsc_vec.copy(self._x)
        self.snes.solve(None, self._x)
        self._update(self._x)
        # an int at run time (petsc4py's stubs say ConvergedReason)
        return cast(int, self.snes.getConvergedReason()), int(self.snes.getIterationNumber())

    def plain_residual_norm(self) -> float:
        """‖DΠ(u)‖ of the current state with the Dirichlet rows as SNES sees them (collective)."""
        scale = float(self._inv_tau.value)
        self._inv_tau.value = np.asarray(0.0)
        self.state.x.petsc_vec.copy(self._x)
        self._assemble_residual(self.snes, self._x, self._b)
        self._inv_tau.value = np.asarray(scale)
        return float(self._b.norm())

    def _relax(self, factor: float, relax: Relaxation) -> int:
        """The proximal gradient flow at ``factor`` until the plain residual is small.

        Records the accepted energies; raises a SolverError (state taken back) when
        ``max_steps`` are spent. Returns the Newton iterations of all proximal steps.
        """
        tau, its = relax.tau, 0
        # the Dirichlet data at ``factor`` first: Π is compared between admissible states
        dolfinx.fem.petsc.set_bc(self.state.x.petsc_vec, self.bcs)
        self.state.x.scatter_forward()
        energies = [self.energy_value()]
        goal = max(relax.rtol * self.plain_residual_norm(), relax.atol)
        best, since = math.inf, 0  # the least residual so far, steps since it
        for _ in range(relax.max_steps):
            residual = self.plain_residual_norm()
            best, since = (residual, 0) if residual < best else (best, since + 1)
            if residual <= goal or 0 < relax.stall <= since:
                break
            self._anchor.x.array[:] = self.state.x.array
            self._inv_tau.value = np.asarray(1.0 / tau)
            reason, more = self._snes()
            self._inv_tau.value = np.asarray(0.0)
            its += more
            energy = self.energy_value() if reason > 0 else math.inf
            if energy <= energies[-1]:
                energies.append(energy)
                tau *= 2.0 if more <= relax.fast else 1.0
            else:  # a failed step or a rise of Π: back to vⁿ with a smaller τ
                self.state.x.array[:] = self._anchor.x.array
                tau /= 4.0
        else:
            self._take_back()
            raise SolverError(
                f"the relaxation did not reach the residual {goal:.3g} in {relax.max_steps} "
                f"steps at load factor {factor:g} (residual {residual:.3g})"
            )
        self.relaxations.append(
            {"load_factor": factor, "energies": energies, "tau": tau, "residual": residual}
        )
        return its

    def _newton(self, factor: float) -> int:
        """SNES from the current state at ``factor``: its iterations, or a SolverError."""
        reason, its = self._snes()
        if reason < 0:
            self._take_back()
            hint = f"; {self.hint}" if self.hint else ""
            raise SolverError(
                f"Newton failed at load step {self.step_count + 1} (load factor {factor:g}): "
                f"SNES reason {snes_reason(reason)} after {its} iterations{hint}"
            )
        return int(its)

    def lowest_eigenpairs(self, stability: Stability) -> eigen.Eigenpairs:
        """The Hessian eigenpairs of the current state nearest ``stability.shift`` (free dofs).

        The eigenvectors live on the free unknowns (:meth:`free_rows`); destroy them after use.
        """
        with self._free_hessian() as free:
            return eigen.nearest_eigenpairs(
                free, stability.modes, stability.shift, stability.solver, stability.tol
            )

    def negative_eigenvalues(self) -> int:
        """The number of negative Hessian eigenvalues of the current state (free dofs; inertia).

        Zero for a stable state; unlike :meth:`lowest_eigenpairs` it cannot miss a negative
        eigenvalue far from the shift (:func:`dgplate.solvers.eigen.negative_count`).
        """
        with self._free_hessian() as free:
            return eigen.negative_count(free)

    @contextlib.contextmanager
    def _free_hessian(self) -> Iterator[PETSc.Mat]:
        """The Hessian of the current state on the free unknowns (destroyed on exit)."""
        self._assemble_jacobian(self.snes, self.state.x.petsc_vec, self._A, self._A)
        free = self._A.createSubMatrix(self._free[0], self._free[0])
        try:
            yield free
        finally:
            free.destroy()

    def _check_stability(self, factor: float, stability: Stability) -> tuple[float, int]:
        """The lowest eigenvalue after the step (and after a perturbation), Newton its spent.

        NaN when the eigensolver fails (a singular Hessian at the shift): the run goes on.
        """
        try:
            pairs = self.lowest_eigenpairs(stability)
        except SolverError as err:
            _log.warning("no lowest eigenvalue at load factor %g: %s", factor, err)
            return math.nan, 0
        lowest = float(pairs.values[0]) if len(pairs.values) else math.nan
        previous = getattr(self.history[-1], LOWEST) if self.history else math.nan
        if previous >= 0 > lowest:
            f0 = self.history[-1].load_factor
            self.crossings.append(f0 + (factor - f0) * previous / (previous - lowest))
        its = 0
        if stability.leave and lowest < -self._stable_tol(stability.leave, lowest):
            return self._leave_branch(factor, stability, stability.leave, pairs)
        if stability.perturb and lowest < 0 and not previous < 0:
            amplitude, its = self._leave_unstable(factor, stability, pairs.vectors[0])
            self.perturbations.append(
                {"load_factor": factor, "eigenvalue": lowest, "amplitude": amplitude}
            )
            pairs.destroy()
            pairs = self.lowest_eigenpairs(stability)
            lowest = float(pairs.values[0]) if len(pairs.values) else math.nan
        pairs.destroy()
        return lowest, its

    def _stable_tol(self, leave: Leave, lowest: float) -> float:
        """−tol is the least lowest eigenvalue of a stable state (:class:`Leave`)."""
        met = [abs(getattr(r, LOWEST)) for r in self.history if math.isfinite(getattr(r, LOWEST))]
        return float(leave.eig_rtol * max([abs(lowest), *met]))

    def _leave_branch(
        self, factor: float, stability: Stability, leave: Leave, pairs: eigen.Eigenpairs
    ) -> tuple[float, int]:
        """Push–relax rounds from an unstable state: (the final lowest eigenvalue, Newton its).

        Takes ownership of ``pairs``. Each round is recorded in ``perturbations``.
        """
        first = float(pairs.values[0])
        tol = self._stable_tol(leave, first)
        its, start_energy = 0, self.energy_value()
        for _ in range(leave.rounds):
            before, lowest = self.energy_value(), float(pairs.values[0])
            amplitude = leave.fraction * self._deflection_scale()
            self._push(pairs.vectors[0], amplitude)
            pairs.destroy()
            its += self._relax(factor, leave.relaxation) + self._polish(factor)
            pairs = self.lowest_eigenpairs(stability)
            after = float(pairs.values[0]) if len(pairs.values) else math.nan
            self.perturbations.append(
                {
                    "load_factor": factor,
                    "eigenvalue": lowest,
                    "amplitude": amplitude,
                    "energy_before": before,
                    "energy_after": self.energy_value(),
                    "eigenvalue_after": after,
                }
            )
            if not after < -tol:
                break
        pairs.destroy()
        self._states = [(factor, self.state.x.array.copy())]
        final_energy = self.energy_value()  # collective: not inside the rank-0 branch
        if self.comm.rank == 0:
            print(
                f"left an unstable state at load factor {factor:g}: lowest eigenvalue "
                f"{first:.3e} -> {after:.3e}, energy {start_energy:.6e} -> {final_energy:.6e}",
                flush=True,
            )
        return after, its

    def _deflection_scale(self) -> float:
        """The largest change of a free unknown since the start of the path (collective)."""
        change = self.state.x.array[self._free[1]] - self._initial[self._free[1]]
        return float(self.comm.allreduce(float(np.abs(change).max(initial=0.0)), op=MPI.MAX))

    def _push(self, mode: PETSc.Vec, amplitude: float) -> None:
        """Move the free unknowns by amplitude × the mode scaled to max |φ_i| = 1."""
        values = eigen.values_of(mode)
        largest = self.comm.allreduce(float(np.abs(values).max(initial=0.0)), op=MPI.MAX)
        self.state.x.array[self._free[1]] += amplitude * values / largest
        self.state.x.scatter_forward()

    def _polish(self, factor: float) -> int:
        """Newton from the relaxed state, kept only if it converges without raising Π."""
        relaxed, energy = self.state.x.array.copy(), self.energy_value()
        reason, its = self._snes()
        if reason < 0 or self.energy_value() > energy + 1e-12 * abs(energy):
            self.state.x.array[:] = relaxed
            self._set_load(factor)
        return its

    def _leave_unstable(
        self, factor: float, stability: Stability, mode: PETSc.Vec
    ) -> tuple[float, int]:
        """Push the state along ``mode`` and solve again at ``factor``: (amplitude, Newton its).

        Newton may fall back to the unstable state when the push is small against the distance
        to the stable branch (near a pitchfork, from inside the inflection point): the push is
        then doubled, at most three times.
        """
        unstable = self.state.x.array.copy()
        amplitude, its = stability.perturb, 0
        for attempt in range(4):
            amplitude = stability.perturb * 2**attempt
            self.state.x.array[:] = unstable
            self._push(mode, amplitude)
            its += self._solve_at(factor)
            pairs = self.lowest_eigenpairs(stability)
            stable = len(pairs.values) > 0 and pairs.values[0] >= 0
            pairs.destroy()
            if stable:
                break
        self._states = [(factor, self.state.x.array.copy())]
        return amplitude, its

    def _predict(self, factor: float) -> None:
        """The secant extrapolation of the last two states to ``factor`` (if there are two)."""
        if not self.secant or len(self._states) < 2:
            return
        (f0, x0), (f1, x1) = self._states[-2:]
        self.state.x.array[:] = x1 + (factor - f1) / (f1 - f0) * (x1 - x0)

    def _take_back(self) -> None:
        """Back to the last converged state and its load factor."""
        factor, array = self._states[-1]
        self.state.x.array[:] = array
        self._set_load(factor)
        self._shape = self._update_shape()

    def _set_load(self, factor: float) -> None:
        self._load_factor.value = np.asarray(factor)
        for constant, value in self._bc_values:
            constant.value = np.asarray(factor * value)

    def _update_shape(self) -> dolfinx.fem.Function[np.float64]:
        source = self._shape_source
        return source if isinstance(source, dolfinx.fem.Function) else source()

    def energy_value(self) -> float:
        """Π of the current state (collective)."""
        local = dolfinx.fem.assemble_scalar(self._energy)
        return float(self.comm.allreduce(local, op=MPI.SUM))


def _free_rows(
    space: dolfinx.fem.FunctionSpace[np.float64],
    bcs: Sequence[dolfinx.fem.DirichletBC[np.float64]],
) -> tuple[PETSc.IS, npt.NDArray[np.int64]]:
    """The owned unknowns without Dirichlet conditions: global rows (an IS) and local indices."""
    imap, bs = space.dofmap.index_map, space.dofmap.index_map_bs
    owned = imap.size_local * bs
    free = np.ones(owned, dtype=bool)
    for bc in bcs:
        dofs = bc.dof_indices()[0]
        free[dofs[dofs < owned]] = False
    local = np.flatnonzero(free).astype(np.int64)
    rows = PETSc.IS().createGeneral(
        (imap.local_range[0] * bs + local).astype(PETSc.IntType), comm=space.mesh.comm
    )
    return rows, local


def _checked_schedule(schedule: Sequence[float], start: float) -> list[float]:
    """The schedule as floats: finite, non-empty, no two consecutive factors equal."""
    factors = [float(factor) for factor in schedule]
    if not factors or not all(math.isfinite(f) for f in factors):
        raise ValueError(f"a schedule needs finite load factors, got {list(schedule)!r}")
    if any(a == b for a, b in zip([start, *factors], factors)):
        raise ValueError(f"consecutive load factors must differ, got {factors!r} from {start:g}")
    return factors
