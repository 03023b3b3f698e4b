"""The flow's τ controller: fixed τ, adaptive τ, and the switch to SQP steps.

With ``flow.adaptive_tau`` a step is accepted when E_h did not rise, its linearisation error
(the isometry defect before projection) is at most ``flow.defect_bound`` and the nonlocal terms
accept the state; τ then grows, else the step is redone with τ/2. With ``flow.newton_finish``
the steps are SQP steps (:mod:`dgplate.solvers.sqp`): with ``flow.step_control = 'trust_region'``
(the default) from the first step on, τ acting as a trust radius, with ``'defect_bound'`` once τ
is large enough. The trust region's SQP steps may end off the constraint: they are judged by
the merit E_h + λ·c instead of E_h (:class:`dgplate.solvers.projection.Merit`).
"""

from __future__ import annotations

import math
from typing import Protocol

from dgplate.errors import SolverError
from dgplate.solvers.constraint import IsometryDefect
from dgplate.solvers.projection import SQP_DEFECT_TOL, SQP_STEP_DEFECT, Merit
from dgplate.solvers.safeguard import ActiveSetStep, Redoable, Safeguard, passes, safety
from dgplate.solvers.step_system import StepSystem
from dgplate.solvers.steps import StepInfo, not_raised

#: The [flow] keys of the adaptive τ controller and its SQP switch: they act only with
#: ``flow.adaptive_tau = true``.
ADAPTIVE_ONLY = (
    "defect_bound",
    "tau_growth",
    "tau_growth_max",
    "tau_max_ratio",
    "refactor_factor",
    "step_control",
    "newton_finish",
    "newton_tau_ratio",
)


class TauSettings(Protocol):
    """The [flow] keys of the τ controller (:class:`dgplate.solvers.flow.FlowSpec`)."""

    adaptive_tau: bool
    defect_bound: float
    tau_growth: float
    tau_growth_max: float
    tau_max_ratio: float
    refactor_factor: float
    step_control: str
    newton_finish: bool
    newton_tau_ratio: float


class Stepper(Redoable, Protocol):
    """The flow as the controller sees it: one step, its state and its defect."""

    defect: IsometryDefect
    _last_energy: float
    merit: Merit | None  # the last step's, when it was an SQP step off the constraint

    def step(self, newton: bool = False) -> StepInfo:
        """One step from the current state (``newton``: an SQP step)."""
        ...


class TauController:
    """Chooses τ and the kind of each step of a flow, and redoes refused steps."""

    def __init__(self, flow: Stepper, system: StepSystem, settings: TauSettings, tau: float):
        """The controller of ``flow``, starting from τ = ``tau`` (held in ``system``)."""
        self.flow, self.system, self.counts = flow, system, system.counts
        self.settings = settings
        self.initial = tau
        # the proposal (flow.adaptive_tau); the step matrix holds system.tau, which follows
        # it only when they differ by more than flow.refactor_factor
        self.target = tau
        self.linear_defect = 0.0  # D_h after the last linearised step, before projection
        # the trust region's last SQP step: its D_h over the bound it was held to
        self.bound_used = 0.0
        self.safeguard = Safeguard(flow, system.energy)
        self.active_sets = ActiveSetStep(flow, system, system.counts)

    def set_tau(self, value: float) -> None:
        """τ into the step matrix, and the proposal reset to it."""
        self.target = value
        self.system.put_tau(value)

    def step(self) -> StepInfo:
        """One accepted step: adaptive (``flow.adaptive_tau``) or with a fixed τ, safeguarded."""
        if self.settings.adaptive_tau:
            return self._adaptive_step()
        return self.safeguard.step(self._contact_step)

    def _contact_step(self) -> StepInfo:
        """A plain step, its active sets grown until it does not raise E_h."""
        return self.active_sets.step(self.flow.step)

    def _adaptive_step(self) -> StepInfo:
        """One accepted step with adaptive τ (``flow.adaptive_tau``).

        A step is accepted when E_h did not rise and the isometry defect after the linearised
        step (before projection) is at most ``flow.defect_bound`` and the nonlocal terms
        (self-avoidance) accept the new state; the controller's τ then grows
        (:meth:`_grow_tau`). Otherwise the step is taken back and redone with half the τ it
        was taken with (refactorised at once), down to 10⁻⁶ of the initial τ (below that the
        step is accepted as it is). Rejected steps are counted in ``rejected_steps``.

        With ``flow.newton_finish`` the step is first tried as an SQP step
        (:mod:`dgplate.solvers.sqp`) when :meth:`_newton_due`. With the trust region
        (:meth:`trust_region`) a refused SQP step (or one whose matrix cannot be factorised)
        is retried as an SQP step with τ/2 (``rejected_steps``); otherwise, and below the
        least τ, it is taken back and redone as a plain step with the same τ
        (``newton_rejections``).
        """
        flow = self.flow
        saved = flow.save()
        energy0 = flow._last_energy
        newton = self._newton_due()
        defect0 = flow.defect() if newton else math.inf
        redone = 0
        while True:
            info = self._attempt(newton)
            if info is not None and (
                self._accepted(info, energy0, defect0 if newton else math.inf)
                or (flow.tau / 2 < self._tau_min() and not newton)
            ):
                self.counts.newton_steps += newton
                self._grow_tau()
                terms = [t for t in self.system.energy.nonlocal_terms if t.max_redo > 0]
                if terms:  # the safety net's figures, as a fixed-τ step records them
                    info.safety = safety(terms, redone)
                return info
            flow.restore(saved)
            newton, redone = self._redo(newton), redone + 1

    def _tau_min(self) -> float:
        """The least τ of a redone step: 10⁻⁶ of the initial τ."""
        return 1e-6 * self.initial

    def _redo(self, newton: bool) -> bool:
        """After a refused step (taken back): set the τ of the next attempt, return its kind.

        A refused SQP step is redone as a plain step with the same τ (``newton_rejections``),
        but under the trust region, while τ/2 is above the least τ, as an SQP step with a
        smaller τ (:meth:`_shrink`); a refused plain step is redone with τ/2 (both
        ``rejected_steps``).
        """
        flow = self.flow
        if newton and not (self.trust_region() and flow.tau / 2 >= self._tau_min()):
            self.counts.newton_rejections += 1
            return False
        self.counts.rejected_steps += 1
        flow.tau = max(flow.tau * self._shrink(newton), self._tau_min())
        return newton

    def _shrink(self, newton: bool) -> float:
        """The factor of τ after a refused step: ½, or less for an SQP step far off its bound.

        A trust-region SQP step refused with D_h = u·bound (u > 1) is retried with τ times
        u^(−½) (between 0.1 and 0.5): the corrected step's defect grows at least as τ²
        (as τ^2.7 along the full-turn roll-up), so a step that overshot its bound by far is
        not halved again and again (halved, the full turn from τ = h was refused with u = 29,
        then with u = 10, and accepted at h/4). A step with u ≤ 1 (refused for its merit or by
        the nonlocal terms, or not an SQP step) is halved.
        """
        if not (newton and self.trust_region()) or self.bound_used <= 1.0:
            return 0.5
        return min(0.5, max(0.1, float(self.bound_used**-0.5)))

    def _attempt(self, newton: bool) -> StepInfo | None:
        """A step; an SQP step whose matrix cannot be factorised gives None (to redo it plain)."""
        self.bound_used = 0.0
        if not newton:
            return self._contact_step()
        try:
            return self.flow.step(newton=True)
        except SolverError:
            return None

    def _accepted(self, info: StepInfo, energy0: float, defect0: float = math.inf) -> bool:
        """The adaptive controller's test of a step from the energy ``energy0``.

        An SQP step of the trust region, which may end off the constraint (the flow's
        ``merit``): its merit E_h + λ·c did not rise, and D_h is at most ``SQP_STEP_DEFECT``·|ω|
        or its start's. Otherwise: E_h did not rise, the linearisation error is at most
        ``flow.defect_bound`` (not asked of
        an SQP step under the trust region: its corrections restore the constraint, and the
        test below judges them) and the nonlocal terms accept the state; a non-finite energy or
        defect fails. An SQP step
        (``defect0``: D_h of its start) must also end at most as far off the constraint as it
        started, or at round-off: when its corrections stall, the state lies below the
        constrained energy by about λ·D_h, and every later step, whose projections restore the
        constraint, would count that as a rise of E_h (BNN 64² with τ grown eightfold per step:
        D_h = 2.1·10⁻⁴ after an SQP step that started at 9.7·10⁻⁶, then 29 rejections).

        The nonlocal terms are asked last, only about a step that passed the rest: their
        accept() takes the state as the reference of their next test (self-avoidance: the
        least distance, which may not fall below ``approach`` times it). Asked about every
        attempt, a refused step whose strands flew apart (trefoil ribbon: E_h up by 0.14,
        least distance 0.54 against 0.14) became the reference, and every later step was
        refused down to the least τ (docs/performance.md).
        """
        merit = self.flow.merit
        if merit is not None:  # an SQP step off the constraint: its merit function
            bound = max(defect0, SQP_STEP_DEFECT * self.flow.defect.area)
            self.bound_used = info.defect / bound
            kept = merit.lowered(energy0, info.energy) and self.bound_used <= 1.0
            return passes(kept, self.system.energy.nonlocal_terms)
        lowered = not_raised(energy0, info.energy)
        trusted = math.isfinite(defect0) and self.trust_region()
        close = trusted or self.linear_defect <= self.settings.defect_bound
        on_constraint = info.defect <= max(defect0, SQP_DEFECT_TOL * self.flow.defect.area)
        return passes(lowered and close and on_constraint, self.system.energy.nonlocal_terms)

    def _newton_due(self) -> bool:
        """Whether the next step is an SQP step: ``flow.newton_finish`` and τ large enough.

        Under the trust region every step; otherwise τ (the held one) at least
        ``flow.newton_tau_ratio`` times the initial τ, or at its cap.
        """
        settings = self.settings
        ratio = min(settings.newton_tau_ratio, settings.tau_max_ratio)
        large = self.system.tau >= ratio * self.initial * (1 - 1e-12)
        return settings.newton_finish and (large or self.trust_region())

    def trust_region(self) -> bool:
        """Whether τ is a trust radius of SQP steps (``flow.step_control = 'trust_region'``).

        Only with ``flow.newton_finish`` and without active sets (obstacles, whose sets the
        plain steps grow).
        """
        settings = self.settings
        return (
            settings.newton_finish
            and settings.step_control == "trust_region"
            and not self.system.energy.active_sets
        )

    def _grow_tau(self) -> None:
        """After an accepted step: the proposal grows by :meth:`_growth`, up to its cap.

        The step matrix takes it only when it differs from the τ held there by more than
        ``flow.refactor_factor``; until then the steps are gradient-flow steps with the held τ.
        """
        settings = self.settings
        cap = settings.tau_max_ratio * self.initial
        self.target = min(self._growth() * self.target, cap)
        tau = self.system.tau
        ratio = max(self.target / tau, tau / self.target)
        if ratio > settings.refactor_factor * (1 + 1e-12):
            self.system.put_tau(self.target)

    def _growth(self) -> float:
        """The factor of τ after an accepted step (``flow.tau_growth``, ``flow.tau_growth_max``).

        With the SQP finish and until the run's first rejection, √(defect_bound/D)/2 between
        the two, D the step's defect before projection: the factor that would bring a defect
        ∝ τ² to a quarter of the bound, as an error-based step-size controller does. It takes
        the run to the SQP steps sooner (box, second hold: 10 step solves against 14). Plain
        steps gain nothing from a τ grown fast (BNN 32², plain adaptive τ: 56 step solves
        against 38), and after a rejection a long step may leave the state off the constraint
        by more than the next projection restores: then, and without the finish, the fixed
        growth. Under the trust region the fixed growth when the step's D_h used at most half
        of its bound, else 1 (τ held): doubled from there, the next step overshot the bound
        (the full-turn roll-up: every third attempt refused, 62 step solves against 54).
        """
        settings = self.settings
        if self.trust_region() and self.bound_used > 0.5:
            return 1.0
        fast = settings.newton_finish and not (self.counts.rejected_steps or self.trust_region())
        if not fast or settings.tau_growth_max <= settings.tau_growth:
            return settings.tau_growth
        defect = max(self.linear_defect, 1e-300)
        wanted = 0.5 * math.sqrt(settings.defect_bound / defect)
        return min(max(wanted, settings.tau_growth), settings.tau_growth_max)
