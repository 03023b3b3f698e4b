"""The six pins that hold a free plate's rigid motions (dgplate.solvers.rigid_pins).

On a 2 × 1 rectangle of 8 × 4 cells and on meshes/plate_with_hole.geo (its centre in the hole): one dG copy per pinned component on all
ranks together, the nodes A (the centre), B (along x₁) and C (along x₂) where the docstring puts
them, and the six rigid motions independent on the pinned components: a rigid motion that
keeps the pins is zero. The pinned nodes and cells do not depend on the number of ranks.
"""

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest

from dgplate.mesh.tagged import load_geo, rectangle
from dgplate.solvers.flow import FlowSpec
from dgplate.solvers.rigid_pins import PINNED_COMPONENTS, rigid_pins
from dgplate.solvers.step_system import mixed_space


def pinned(comm, shape):
    """(component, [(node and its cell's centre, start value)]) of each pin, gathered from
    all ranks' owned copies."""
    mesh = (
        rectangle(comm, [[0.0, 0.0], [2.0, 1.0]], [8, 4]).mesh
        if shape == "rectangle"
        else load_geo(comm, "plate_with_hole", {"h": 0.5}).mesh
    )
    state = dolfinx.fem.Function(mixed_space(mesh, 2, FlowSpec()))
    y = state.sub(0)
    y.interpolate(lambda x: np.vstack([x[0], x[1], 0.1 * x[0] * x[1]]))
    state.x.scatter_forward()
    pins = rigid_pins(state)
    components = [k for ks in PINNED_COMPONENTS for k in ks]
    found = []
    for k, pin in zip(components, pins, strict=True):
        dofs, owned_end = pin.dof_indices()
        owned = dofs[:owned_end]
        collapsed, parent = state.function_space.sub(0).sub(k).collapse()
        parent = np.asarray(parent).reshape(-1)
        x = collapsed.tabulate_dof_coordinates()[:, :2]
        cells = collapsed.dofmap.list
        rows = []
        for dof in owned:
            local = np.flatnonzero(parent == dof)[0]
            cell = np.flatnonzero((cells == local).any(axis=1))[0]
            rows.append(np.concatenate([x[local], x[cells[cell]].mean(axis=0)]))
        values = [float(state.x.array[dof]) for dof in owned]
        every = [item for part in comm.allgather(list(zip(rows, values))) for item in part]
        found.append((k, every))
    return found


#: Each mesh's bounding-box centre, r (a quarter of its smaller side), and how far the nodes
#: A, A + (r, 0), A + (0, r) may lie from the points they are nearest (about a node spacing).
GEOMETRY = {"rectangle": ((1.0, 0.5), 0.25, 1e-12), "holed": ((5.0, 2.0), 1.0, 0.4)}


@pytest.mark.parametrize("shape", ["rectangle", "holed"])
def test_six_pins_hold_the_rigid_motions(shape):
    """One copy per pin; A the node nearest the centre (on the hole's edge when the centre is
    in the hole), B near A + (r, 0), C near A + (0, r); the 6 × 6 matrix of the rigid
    motions' pinned components is regular."""
    pins = pinned(MPI.COMM_WORLD, shape)
    assert [k for k, _ in pins] == [0, 1, 2, 1, 2, 2]
    assert all(len(copies) == 1 for _, copies in pins)
    nodes = [copies[0][0][:2] for _, copies in pins]
    a, b, c = nodes[0], nodes[3], nodes[5]
    assert np.allclose(nodes[:3], [a] * 3) and np.allclose(nodes[4], b)
    centre, r, near = GEOMETRY[shape]
    if shape == "rectangle":
        assert np.allclose(a, centre)
    else:
        assert np.linalg.norm(a - centre) == pytest.approx(1.0, abs=0.01)  # the hole's radius
    assert np.linalg.norm(b - a - [r, 0.0]) <= near
    assert np.linalg.norm(c - a - [0.0, r]) <= near
    # the rigid motions' pinned components: e_i, and ω × (x − A) for ω = e_i
    motions = np.zeros((6, 6))
    for row, (k, _) in enumerate(pins):
        x = np.append(nodes[row] - a, 0.0)
        motions[row, :3] = np.eye(3)[k]
        motions[row, 3:] = [np.cross(np.eye(3)[i], x)[k] for i in range(3)]
    assert np.linalg.svd(motions, compute_uv=False).min() > 0.05 * r
    # each pin keeps its start value: y = (x₁, x₂, 0.1 x₁x₂) at its node
    for k, copies in pins:
        (node, value) = copies[0]
        expected = [node[0], node[1], 0.1 * node[0] * node[1]]
        assert value == pytest.approx(expected[k], abs=1e-14)


@pytest.mark.mpi
@pytest.mark.parity
@pytest.mark.parametrize("shape", ["rectangle", "holed"])
def test_same_pins_on_any_number_of_ranks(shape):
    """The pinned nodes, their cells and values are those of one rank."""
    parallel, serial = pinned(MPI.COMM_WORLD, shape), pinned(MPI.COMM_SELF, shape)
    for (k, copies), (k_serial, copies_serial) in zip(parallel, serial, strict=True):
        assert k == k_serial and len(copies) == len(copies_serial) == 1
        assert np.allclose(copies[0][0], copies_serial[0][0], atol=1e-14)
        assert copies[0][1] == pytest.approx(copies_serial[0][1], abs=1e-14)
