"""The options of a load path's stability check, its relaxation and its branch leaving."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass


@dataclass(frozen=True)
class Stability:
    """The Hessian eigenvalues computed after each load step (:mod:`dgplate.solvers.stability`).

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
    """The proximal gradient flow that replaces Newton per solve (:mod:`dgplate.solvers.branch`).

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
    """Push–relax rounds that leave an unstable state for a stable one (:mod:`dgplate.solvers.branch`).

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
