"""Shared fixtures. Tests marked ``mpi`` run serially and again under ``mpirun -n 2``."""

from mpi4py import MPI

import pytest


@pytest.fixture
def comm():
    return MPI.COMM_WORLD


# Rank parity of a nonlinear flow. Each step solves a saddle-point system whose condition
# number grows like h^-4 (about 1e6 on the test meshes); a different partition changes the
# summation order and MUMPS' pivot sequence, so the iterates may differ by cond * eps ~ 1e-10
# per step, and a few dozen steps accumulate that. 1e-8 is far below any discretisation
# effect (those are 1e-3 and larger) and still catches a wrong ghost or a missing reduction,
# which show up at 1e-3 and beyond.
PARITY_RTOL = 1e-8


def rates(errors: list[float]) -> list[float]:
    """Observed convergence rates for a sequence of errors at halved mesh sizes."""
    import numpy as np

    e = np.asarray(errors)
    return list(np.log2(e[:-1] / e[1:]))


def pytest_configure(config):
    """Under mpirun every rank gets its own temporary directory tree (no clean-up races)."""
    if MPI.COMM_WORLD.size > 1 and not config.option.basetemp:
        import tempfile
        from pathlib import Path

        config.option.basetemp = (
            Path(tempfile.gettempdir()) / f"pytest-mpi-rank{MPI.COMM_WORLD.rank}"
        )
