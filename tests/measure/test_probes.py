"""The centre probe of a plate (dgplate.measure.probes.central_probe) and mpi.least.

On meshes/plate_with_hole.geo the centre (5, 2) lies in the hole of radius 1: the probe sits
at the node nearest it, on the hole's edge, the same node on any number of ranks, and measures
y₃ there.
"""

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest

from dgplate import mpi
from dgplate.measure.probes import central_probe
from dgplate.mesh.tagged import load_geo, rectangle


def probe_on(comm, holed):
    """The central probe's point and its reading of y₃ = x₁ + 10 x₂."""
    mesh = (
        load_geo(comm, "plate_with_hole", {"h": 0.5}).mesh
        if holed
        else rectangle(comm, [[0.0, 0.0], [2.0, 1.0]], [4, 2]).mesh
    )
    V = dolfinx.fem.functionspace(mesh, ("DG", 2, (3,)))
    y = dolfinx.fem.Function(V)
    y.interpolate(lambda x: np.vstack([x[0], x[1], x[0] + 10 * x[1]]))
    probe = central_probe(mesh)
    return np.asarray(probe.point).ravel()[:2], probe(y, component=2)


@pytest.mark.mpi
@pytest.mark.parametrize("holed", [False, True])
def test_the_centre_or_the_node_nearest_it(holed):
    """The box's centre, or in a hole the nearest node (on the hole's edge, within 1 %)."""
    point, value = probe_on(MPI.COMM_WORLD, holed)
    if holed:
        assert np.linalg.norm(point - [5.0, 2.0]) == pytest.approx(1.0, rel=0.01)
    else:
        assert np.allclose(point, [1.0, 0.5])
    assert value == pytest.approx(point[0] + 10 * point[1], rel=1e-12)


@pytest.mark.mpi
@pytest.mark.parity
def test_same_node_on_any_number_of_ranks():
    """In the hole, the node of one rank."""
    parallel, serial = probe_on(MPI.COMM_WORLD, True), probe_on(MPI.COMM_SELF, True)
    assert np.allclose(parallel[0], serial[0], atol=1e-14)
    assert parallel[1] == pytest.approx(serial[1], rel=1e-12)


@pytest.mark.mpi
def test_least_is_the_least_tuple_with_its_rank(comm):
    """Each rank offers (rank mod 2, −rank): the least is (0, −r) of the highest even rank r;
    a rank may offer none, and with none anywhere the answer is None."""
    r = comm.rank
    best = mpi.least(comm, (float(r % 2), float(-r)))
    top = max(k for k in range(comm.size) if k % 2 == 0)
    assert best == (0.0, float(-top), top)
    assert mpi.least(comm, None if r else (1.0,)) == (1.0, 0)
    assert mpi.least(comm, None) is None
