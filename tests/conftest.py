"""Shared fixtures and hooks. Tests marked ``mpi`` run serially and again under ``mpirun -n 2``;
those also marked ``parity`` (one rank against all ranks) run only under mpirun.

Shared helpers that are not fixtures (paths, factories, checks) are in ``helpers.py``.
"""

import faulthandler
import os
import signal
from pathlib import Path

from mpi4py import MPI

import pytest


@pytest.fixture
def comm():
    return MPI.COMM_WORLD


#: Under mpirun, a duplicate of this rank's stderr made in pytest_configure, when pytest's
#: capture is suspended: its test-time capture does not redirect it.
STDERR: list[int] = []


@pytest.fixture(autouse=True)
def where_sigterm_ends_a_rank():
    """Under mpirun, a rank ended by SIGTERM first prints where each of its threads was, then
    ends as before (143). Registered again for each test: a run's interrupt handling puts the
    default handler back when it ends."""
    if STDERR:
        faulthandler.unregister(signal.SIGTERM)
        faulthandler.register(signal.SIGTERM, file=STDERR[0], all_threads=True, chain=True)


def pytest_configure(config):
    """Under mpirun every rank gets its own temporary directory tree (no clean-up races) and
    its stderr's duplicate (:data:`STDERR`)."""
    if MPI.COMM_WORLD.size > 1 and not STDERR:
        STDERR.append(os.dup(2))
    if MPI.COMM_WORLD.size > 1 and not config.option.basetemp:
        import tempfile

        config.option.basetemp = (
            Path(tempfile.gettempdir()) / f"pytest-mpi-rank{MPI.COMM_WORLD.rank}"
        )


#: Left out of ``make test-fast`` as wholes: the demos and the runs of shipped files.
SLOW_MODULES = ("demos/", "app/test_problem_files.py", "app/test_tutorial.py")
SLOW_TESTS = Path(__file__).parent / "slow_tests.txt"


def slow_test_ids() -> set[str]:
    """The node ids listed in slow_tests.txt (tests taking 2 s or more)."""
    lines = SLOW_TESTS.read_text().splitlines()
    return {line.strip() for line in lines if line.strip() and not line.startswith("#")}


def pytest_collection_modifyitems(config, items):
    """Mark ``slow`` what ``make test-fast`` leaves out (see slow_tests.txt); skip the ``parity``
    tests on one rank, where the run on all ranks is the one-rank run again."""
    slow = slow_test_ids()
    tests = Path(__file__).parent
    one_rank = pytest.mark.skip(reason="rank parity: run under mpirun")
    for item in items:
        if item.get_closest_marker("parity"):
            if not item.get_closest_marker("mpi"):  # it would run nowhere
                raise pytest.UsageError(f"{item.nodeid} is marked parity but not mpi")
            if MPI.COMM_WORLD.size == 1:
                item.add_marker(one_rank)
        where = Path(item.fspath).relative_to(tests).as_posix()
        node = f"tests/{where}::{item.nodeid.split('::', 1)[1]}" if "::" in item.nodeid else ""
        if where.startswith(SLOW_MODULES) or node in slow:
            item.add_marker(pytest.mark.slow)
    items[:] = longest_modules_first(items)


def longest_modules_first(items: list[pytest.Item]) -> list[pytest.Item]:
    """The modules with the most slow tests first, each module's tests together and in order.

    pytest-xdist splits the tests in this order between its workers (``--dist worksteal``:
    halves at first, then an idle worker takes the back half of the busy one's queue), so the
    long tests start early and short ones fill the end. Keeping a module's tests together
    makes a split inside a module (and a module-scoped fixture built on both workers) rare.
    """
    modules: dict[str, list[pytest.Item]] = {}
    for item in items:
        modules.setdefault(item.nodeid.split("::", 1)[0], []).append(item)
    ranked = sorted(
        modules.values(), key=lambda tests: -sum(bool(t.get_closest_marker("slow")) for t in tests)
    )
    return [item for tests in ranked for item in tests]
