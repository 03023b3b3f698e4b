"""Shared fixtures and hooks. Tests marked ``mpi`` run serially and again under ``mpirun -n 2``.

Shared helpers that are not fixtures (paths, factories, checks) are in ``helpers.py``.
"""

from mpi4py import MPI

import pytest


@pytest.fixture
def comm():
    return MPI.COMM_WORLD


def pytest_configure(config):
    """Under mpirun every rank gets its own temporary directory tree (no clean-up races)."""
    if MPI.COMM_WORLD.size > 1 and not config.option.basetemp:
        import tempfile
        from pathlib import Path

        config.option.basetemp = (
            Path(tempfile.gettempdir()) / f"pytest-mpi-rank{MPI.COMM_WORLD.rank}"
        )
