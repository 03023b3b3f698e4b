"""What a gradient flow reports: one record per step, and how a run ended."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol


@dataclass
class StepInfo:
    """What one step did: the row of ``history.csv``."""

    step: int
    time: float
    tau: float
    energy: float
    defect: float
    increment: float  # max |δy| over the degrees of freedom
    rate: float  # (E_h[yⁿ⁻¹] − E_h[yⁿ]) / τ; of E_h + λ·c after an SQP step off the constraint
    seconds: float
    assembly_s: float
    factor_s: float  # factorisation (0 when the lagged solver reused its factors)
    solve_s: float  # triangular solves and Krylov iterations
    iterations: int  # Krylov iterations of the step solve (1 for a direct solve)
    fallbacks: int = 0  # failed lagged solves redone (fresh factors, then direct LU)
    safety: dict[str, float] = field(default_factory=dict)  # nonlocal terms: min_distance, redone
    stationarity: float = math.nan  # ‖P DE_h[yⁿ]‖_*' (flow.stop = 'stationarity'; else nan)

    def line(self) -> str:
        """One line of progress output."""
        return (
            f"step {self.step:5d}  t = {self.time:9.4f}  τ = {self.tau:.3e}  "
            f"E_h = {self.energy:+.6e}  D_h = {self.defect:.3e}  "
            f"ΔE/τ = {self.rate:.2e}  {per_step(self.seconds)}"
        )


def not_raised(before: float, after: float) -> bool:
    """Whether an energy went from ``before`` to ``after`` without rising (to a relative 10⁻¹²).

    Args:
        before: the energy (or merit) before a step.
        after: the same after it.

    Returns:
        True when it did not rise beyond round-off.
    """
    return after <= before + 1e-12 * max(1.0, abs(before))


class StopRule(Protocol):
    """The [flow] keys of the stopping test (:class:`dgplate.solvers.flow.FlowSpec`)."""

    stop: str
    tol: float
    adaptive_tau: bool


def measured(settings: StopRule) -> bool:
    """Whether the stopping test needs ‖P DE_h[yⁿ]‖_*' after every step.

    With ``flow.stop = 'stationarity'``, and with the rate stop while τ is adaptive
    (:func:`stopping_value`).
    """
    return settings.stop == "stationarity" or settings.adaptive_tau


def stopping_value(settings: StopRule, rate: float, stationarity: float) -> tuple[float, str]:
    """The stopping test's value after a step and its name (``flow.stop``).

    'stationarity': ‖P DE_h[yⁿ]‖_*'. 'rate': |E_h[yⁿ⁻¹] − E_h[yⁿ]|/τ with a fixed τ. With
    adaptive τ the rate falls as τ grows, whatever the state (a run with τ grown a
    thousandfold stopped far from its tolerance), so the rate test then takes the rate's
    limit τ → 0, ‖P DE_h[yⁿ]‖_*'²: a small step is τ times the projected gradient, and lowers
    E_h by τ‖P DE_h‖_*'².

    Args:
        settings: the [flow] keys ``stop``, ``tol`` and ``adaptive_tau``.
        rate: the step's (E_h[yⁿ⁻¹] − E_h[yⁿ])/τ.
        stationarity: ‖P DE_h[yⁿ]‖_*' (nan when not :func:`measured`).

    Returns:
        The value compared with ``flow.tol`` and its name.
    """
    if settings.stop == "stationarity":
        return stationarity, "‖P DE_h[yⁿ]‖_*'"
    if settings.adaptive_tau:
        return stationarity**2, "‖P DE_h[yⁿ]‖_*'² (the rate's limit τ → 0: τ is adaptive)"
    return abs(rate), "(E_h[yⁿ⁻¹] − E_h[yⁿ])/τ"


def stopping_column(settings: StopRule) -> tuple[float, str]:
    """The tolerance and the history.csv column of the stopping test, to draw them together.

    With adaptive τ the rate test is ‖P DE_h‖_*'² < tol, i.e. the column ``stationarity``
    below √tol.
    """
    if settings.stop == "rate" and settings.adaptive_tau:
        return math.sqrt(settings.tol), "stationarity"
    return settings.tol, settings.stop


def stop_reason(settings: StopRule, rate: float, stationarity: float) -> str:
    """Why the flow stops converged after a step ('' to go on): :func:`stopping_value` < tol."""
    value, name = stopping_value(settings, rate, stationarity)
    return f"{name} = {value:.3e} < {settings.tol:g}" if value < settings.tol else ""


def per_step(seconds: float) -> str:
    """The time of a step for a progress line: ``1.23 s/step``, or ``4.2 ms/step``."""
    return f"{seconds:.2f} s/step" if seconds >= 0.1 else f"{1e3 * seconds:.3g} ms/step"


@dataclass
class FlowResult:
    """How a run of the flow ended, and the records of its steps."""

    converged: bool
    reason: str
    steps: int
    energy: float
    defect: float
    history: list[StepInfo]
    energy_increases: list[int]  # steps at which the energy went up
    interrupted: int = 0  # the signal (SIGINT, SIGTERM) that stopped the run; 0: none

    @classmethod
    def of(
        cls,
        outcome: tuple[bool, str, int],
        history: list[Any],
        increases: list[int],
        energy: float,
        defect: float,
    ) -> FlowResult:
        """The result of a run: (converged, reason, signal), its records and final figures."""
        converged, reason, signum = outcome
        return cls(converged, reason, len(history), energy, defect, history, increases, signum)
