"""Leaving unstable branches of a load path, and the relaxation that makes it possible.

Relaxation (:class:`dgplate.solvers.path_options.Relaxation`). Newton finds critical points, not
minima: from a small push off an unstable state it often returns to it. With a relaxation
each load step (and each solve after a push) is a proximal gradient flow in pseudo-time
instead, the implicit Euler steps

    vⁿ⁺¹ = argmin Π(v) + 1/(2τ) ‖v − vⁿ‖²,   ‖·‖ the L² norm of all components,

each solved by the same SNES on the residual DΠ(v) + (1/τ) M(v − vⁿ) and its Jacobian
(:class:`dgplate.solvers.snes.NewtonSolver`). A step is accepted only if Π does not increase
(a step that lands on a saddle of the proximal functional, e.g. back on the flat state, raises
Π and is rejected); τ doubles after a step that converged in a few iterations and is quartered
after a rejected or failed one. The flow stops when the residual of the unmodified problem is
below ``rtol`` × its value at the start of the load step (or ``atol``), and plain Newton then
polishes the state to the SNES tolerance. The energies of the accepted steps are recorded
(``relaxations`` in the summary, with the increases, which must be none).

Leaving (``Stability.perturb`` and ``Stability.leave``). With ``perturb = a`` the state of a
step whose lowest eigenvalue has just turned negative is moved by a·φ (φ the unstable mode,
max |φ_i| = 1, signed by :mod:`dgplate.solvers.eigen`) and solved again at the same load
factor. With ``leave`` (:class:`dgplate.solvers.path_options.Leave`) every converged step whose
lowest eigenvalue is below −tol (tol = ``eig_rtol`` × the largest |lowest eigenvalue| of the
path so far) is left by rounds of push–relax: the state is moved by a·φ with a = ``fraction``
× the deflection scale (the largest change of a free unknown since the start of the path),
relaxed (which only lowers Π, so it cannot return to the saddle it left), polished by Newton
(kept only if it converged without raising Π), and the eigenvalues computed again; the rounds
end when the lowest eigenvalue is ≥ −tol or after ``rounds`` rounds. Rank 0 prints one line
per branch left; ``perturbations`` records each round. The next step then starts from the new
state alone (no secant through the jump).
"""

from __future__ import annotations

import itertools
import math
from typing import Any, Protocol

from mpi4py import MPI

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
from petsc4py import PETSc

from dgplate.errors import SolverError
from dgplate.solvers import eigen
from dgplate.solvers.path_options import Leave, Relaxation, Stability
from dgplate.solvers.snes import NewtonSolver
from dgplate.solvers.stability import StabilityObserver

#: Each proximal step of a relaxation is solved to this fraction of the relaxation's goal.
PROXIMAL_ATOL = 1e-3
#: Newton from a relaxed state converges in a few iterations, or stalls at round-off next to a
#: nearly neutral mode (the cone past its onset: 30 iterations at 2·10⁻¹² before this bound);
#: whether it was kept is in ``perturbations`` (``polished``).
POLISH_ITERATIONS = 8


class Path(Protocol):
    """The load path as the branch leaving sees it (:class:`dgplate.solvers.newton.LoadPath`)."""

    comm: MPI.Comm
    state: dolfinx.fem.Function[np.float64]
    initial: npt.NDArray[np.float64]  # the start of the path (the deflection scale)
    states: list[tuple[float, npt.NDArray[np.float64]]]  # the secant predictor's points
    newton: NewtonSolver
    spectrum: StabilityObserver

    def take_back(self) -> None:
        """Back to the last converged state and its load factor."""
        ...

    def set_load(self, factor: float) -> None:
        """The load factor and the Dirichlet data at it."""
        ...

    def solve_at(self, factor: float) -> int:
        """Newton, or the relaxation and then Newton, at ``factor``: the iterations spent."""
        ...


class BranchLeaving:
    """The relaxation of a load path's solves, and the pushes off its unstable states."""

    def __init__(self, path: Path):
        """For the load path ``path`` (its state, its Newton solver and its stability)."""
        self.path, self.newton = path, path.newton
        self.relaxations: list[dict[str, Any]] = []  # the accepted energies of each relaxation

    def relax(self, factor: float, relax: Relaxation) -> int:
        """The proximal gradient flow at ``factor`` until the plain residual is small.

        Records the accepted energies; raises a SolverError (state taken back) when
        ``max_steps`` are spent. Returns the Newton iterations of all proximal steps.
        """
        newton, state = self.newton, self.path.state
        tau, its = relax.tau, 0
        # the Dirichlet data at ``factor`` first: Π is compared between admissible states
        dolfinx.fem.petsc.set_bc(state.x.petsc_vec, newton.bcs)
        state.x.scatter_forward()
        energies = [newton.energy_value()]
        goal = max(relax.rtol * newton.plain_residual_norm(), relax.atol)
        best, since = math.inf, 0  # the least residual so far, steps since it
        for _ in range(relax.max_steps):
            residual = newton.plain_residual_norm()
            best, since = (residual, 0) if residual < best else (best, since + 1)
            if residual <= goal or 0 < relax.stall <= since:
                break
            newton.anchor.x.array[:] = state.x.array
            newton.inv_tau.value = np.asarray(1.0 / tau)
            # each proximal solve to far below the goal, not to round-off: a relative
            # tolerance of a small start residual asks for more than round-off allows
            reason, more = newton.solve(atol=PROXIMAL_ATOL * goal)
            newton.inv_tau.value = np.asarray(0.0)
            its += more
            energy = newton.energy_value() if reason > 0 else math.inf
            if energy <= energies[-1]:
                energies.append(energy)
                tau *= 2.0 if more <= relax.fast else 1.0
            else:  # a failed step or a rise of Π: back to vⁿ with a smaller τ
                state.x.array[:] = newton.anchor.x.array
                tau /= 4.0
        else:
            self.path.take_back()
            raise SolverError(
                f"the relaxation did not reach the residual {goal:.3g} in {relax.max_steps} "
                f"steps at load factor {factor:g} (residual {residual:.3g})"
            )
        self.relaxations.append(
            {
                "load_factor": factor,
                "energies": energies,
                "tau": tau,
                "residual": residual,
                "goal": goal,
            }
        )
        return its

    def leave_branch(
        self, factor: float, stability: Stability, leave: Leave, pairs: eigen.Eigenpairs
    ) -> tuple[float, int]:
        """Push–relax rounds from an unstable state: (the final lowest eigenvalue, Newton its).

        Takes ownership of ``pairs``. Each round is recorded in ``perturbations``.
        """
        spectrum, energy_value = self.path.spectrum, self.newton.energy_value
        first = float(pairs.values[0])
        tol = spectrum.stable_tol(leave, first)
        its, start_energy = 0, energy_value()
        for _ in range(leave.rounds):
            before, lowest = energy_value(), float(pairs.values[0])
            amplitude = leave.fraction * self._deflection_scale()
            self._push(pairs.vectors[0], amplitude)
            pairs.destroy()
            its += self.relax(factor, leave.relaxation)
            polished, more = self._polish(factor, PROXIMAL_ATOL * self.relaxations[-1]["goal"])
            its += more
            pairs = spectrum.lowest_eigenpairs(stability)
            after = float(pairs.values[0]) if len(pairs.values) else math.nan
            spectrum.perturbations.append(
                {
                    "load_factor": factor,
                    "eigenvalue": lowest,
                    "amplitude": amplitude,
                    "energy_before": before,
                    "energy_after": energy_value(),
                    "eigenvalue_after": after,
                    "polished": polished,
                }
            )
            if not after < -tol:
                break
        pairs.destroy()
        self.path.states = [(factor, self.path.state.x.array.copy())]
        final_energy = energy_value()  # collective: not inside the rank-0 branch
        if self.path.comm.rank == 0:
            print(
                f"left an unstable state at load factor {factor:g}: lowest eigenvalue "
                f"{first:.3e} -> {after:.3e}, energy {start_energy:.6e} -> {final_energy:.6e}",
                flush=True,
            )
        return after, its

    def _deflection_scale(self) -> float:
        """The largest change of a free unknown since the start of the path (collective)."""
        free = self.newton.free[1]
        change = self.path.state.x.array[free] - self.path.initial[free]
        return float(self.path.comm.allreduce(float(np.abs(change).max(initial=0.0)), op=MPI.MAX))

    def _push(self, mode: PETSc.Vec, amplitude: float) -> None:
        """Move the free unknowns by amplitude × the mode scaled to max |φ_i| = 1."""
        values = eigen.values_of(mode)
        largest = self.path.comm.allreduce(float(np.abs(values).max(initial=0.0)), op=MPI.MAX)
        self.path.state.x.array[self.newton.free[1]] += amplitude * values / largest
        self.path.state.x.scatter_forward()

    def _polish(self, factor: float, atol: float) -> tuple[bool, int]:
        """Newton from the relaxed state, kept only if it converges without raising Π.

        Returns whether it was kept, and its iterations (at most ``POLISH_ITERATIONS``; it also
        stops at a residual ≤ ``atol``).
        """
        state = self.path.state
        relaxed, energy = state.x.array.copy(), self.newton.energy_value()
        reason, its = self.newton.solve(atol=atol, max_it=POLISH_ITERATIONS)
        kept = reason > 0 and self.newton.energy_value() <= energy + 1e-12 * abs(energy)
        if not kept:
            state.x.array[:] = relaxed
            self.path.set_load(factor)
        return kept, its

    def leave_unstable(
        self, factor: float, stability: Stability, mode: PETSc.Vec
    ) -> tuple[float, int]:
        """Push the state along ``mode`` and solve again at ``factor``: (amplitude, Newton its).

        Newton may fall back to the unstable state when the push is small against the distance
        to the stable branch (near a pitchfork, from inside the inflection point): the push is
        then doubled, at most three times.
        """
        state = self.path.state
        unstable = state.x.array.copy()
        amplitude, its = stability.perturb, 0
        for attempt in range(4):
            amplitude = stability.perturb * 2**attempt
            state.x.array[:] = unstable
            self._push(mode, amplitude)
            its += self.path.solve_at(factor)
            pairs = self.path.spectrum.lowest_eigenpairs(stability)
            stable = len(pairs.values) > 0 and pairs.values[0] >= 0
            pairs.destroy()
            if stable:
                break
        self.path.states = [(factor, state.x.array.copy())]
        return amplitude, its

    def summary(self) -> dict[str, Any]:
        """The relaxations and the rises of Π within them (load factor, step), which must be none."""
        return {
            "relaxations": self.relaxations,
            "energy_increases": [
                (r["load_factor"], i)
                for r in self.relaxations
                for i, (a, b) in enumerate(itertools.pairwise(r["energies"]))
                if b > a
            ],
        }
