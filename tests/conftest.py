"""Shared fixtures. Tests marked ``mpi`` run serially and again under ``mpirun -n 2``."""

from mpi4py import MPI

import pytest


@pytest.fixture
def comm():
    return MPI.COMM_WORLD


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
