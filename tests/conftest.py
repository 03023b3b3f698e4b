"""Shared fixtures and hooks. Tests marked ``mpi`` run serially and again under ``mpirun -n 2``;
those also marked ``parity`` (one rank against all ranks) run only under mpirun.

Shared helpers that are not fixtures (paths, factories, checks) are in ``helpers.py``.
"""

import gc
from pathlib import Path

from mpi4py import MPI

import pytest


@pytest.fixture
def comm():
    return MPI.COMM_WORLD


@pytest.fixture(autouse=True, scope="module")
def communicators_freed():
    """Under mpirun, the garbage of each test module is collected after it, on every rank
    together (after each test it cost a minute of the mpi tier).

    Each mesh, index map and form of DOLFINx holds a duplicate of its communicator until the
    Python object is collected; cycles wait for Python's collector, which runs when allocation
    counts say, and MPICH has a fixed number of communicator ids (2048 by default). A whole
    mpi tier without this ran out of them: a rank ended with MPI_Abort(…, 15) (MPI_ERR_OTHER,
    from dolfinx::MPI::check_error) in a constructor, a few tests from the end or in the middle
    (MPICH: "Too many communicators (0/2048 free on this process)").
    """
    yield
    if MPI.COMM_WORLD.size > 1:
        gc.collect()


def pytest_configure(config):
    """Under mpirun every rank gets its own temporary directory tree (no clean-up races)."""
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
