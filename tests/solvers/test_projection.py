"""The closing corrections' Anderson mixing (dgplate/solvers/projection.py)."""

from mpi4py import MPI

import numpy as np

from dgplate.solvers.projection import AndersonMixing


def _iterate(mixing: AndersonMixing | None, steps: int) -> float:
    """``steps`` chord iterations x ← x + c(x) on a linear problem of contraction rate 0.9;
    the error left (the solution is 1)."""
    rng = np.random.default_rng(7)
    q, _ = np.linalg.qr(rng.standard_normal((4, 4)))
    iteration = q @ np.diag([0.9, 0.7, 0.5, -0.8]) @ q.T  # x ← T x + (I − T) 1
    x = np.zeros(4)
    for _ in range(steps):
        correction = iteration @ x + (np.ones(4) - iteration @ np.ones(4)) - x
        state = x.copy()
        x = x + correction
        if mixing is not None:
            x -= mixing.mix(state, correction)
    return float(np.max(np.abs(x - 1.0)))


def test_anderson_mixing_solves_a_linear_chord_iteration_in_dimension_plus_one_steps():
    """On a linear iteration in 4 unknowns, mixing with depth ≥ 4 is GMRES: exact after 6
    corrections (to round-off), where the plain iteration has an error of about 0.9⁶."""
    assert _iterate(AndersonMixing(MPI.COMM_SELF, owned=4, depth=5), 6) < 1e-10
    assert _iterate(None, 6) > 0.3
    assert _iterate(AndersonMixing(MPI.COMM_SELF, owned=4, depth=1), 6) > 1e-6


def test_anderson_mixing_starts_with_the_plain_correction():
    mixing = AndersonMixing(MPI.COMM_SELF, owned=3)
    assert np.all(mixing.mix(np.zeros(3), np.ones(3)) == 0.0)


def test_anderson_mixing_of_a_diverged_correction_falls_back_to_the_plain_one():
    """A correction that is not finite (a diverging closing) is not mixed, and the history
    starts again: no LinAlgError from the fit."""
    mixing = AndersonMixing(MPI.COMM_SELF, owned=2)
    mixing.mix(np.zeros(2), np.ones(2))
    assert np.all(mixing.mix(np.ones(2), np.array([np.nan, 1.0])) == 0.0)
    assert mixing.states == [] and mixing.corrections == []
    assert np.all(mixing.mix(np.zeros(2), np.ones(2)) == 0.0)
