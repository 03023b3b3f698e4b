"""The pieces of the arclength continuation that need no plate: the step control, the secant."""

import math

import pytest

from dgplate.errors import SolverError
from dgplate.solvers.arclength import StepLength, secant_root


def test_step_grows_after_fast_convergence_and_halves_on_failure():
    step = StepLength(ds=0.1, ds_max=0.2, ds_min=0.03)
    assert step.after(0.1, 4) == pytest.approx(0.15)  # ≤ fast: × 1.5
    assert step.after(0.15, 3) == 0.2  # bounded by ds_max
    assert step.after(0.1, 5) == 0.1  # slow: kept
    assert step.halved(0.1) == 0.05
    with pytest.raises(SolverError, match=r"fell below ds_min = 0\.03"):
        step.halved(0.05)


def test_secant_finds_the_root_and_ends_there():
    calls = []

    def f(s):
        calls.append(s)
        return math.cos(s) - s  # root 0.7390851332

    root = secant_root(f, 0.0, 1.0, 1.0, math.cos(1.0) - 1.0, xtol=1e-12)
    assert root == pytest.approx(0.7390851332151607, abs=1e-12)
    assert calls[-1] == root and len(calls) <= 12
