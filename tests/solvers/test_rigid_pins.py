"""The six pins that hold a free plate's rigid motions (dgplate.solvers.rigid_pins).

On a 2 × 1 rectangle of 8 × 4 cells, on meshes/plate_with_hole.geo (its centre in the hole)
and on a 10 × 1 strip of two cells: one dG copy per pinned component on all
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

MESHES = {
    "rectangle": lambda comm: rectangle(comm, [[0.0, 0.0], [2.0, 1.0]], [8, 4]).mesh,
    "holed": lambda comm: load_geo(comm, "plate_with_hole", {"h": 0.5}).mesh,
    "strip": lambda comm: rectangle(comm, [[0.0, 0.0], [10.0, 1.0]], [2, 1]).mesh,
}


def pinned(comm, shape):
    """(component, [(node and its cell's centre, start value)]) of each pin, gathered from
    all ranks' owned copies; asserts on the way that each rank pins every copy it holds of
    the pinned one (owned or ghost), as DOLFINx's conditions need."""
    mesh = MESHES[shape](comm)
    state = dolfinx.fem.Function(mixed_space(mesh, 2, FlowSpec()))
    y = state.sub(0)
    y.interpolate(lambda x: np.vstack([x[0], x[1], 0.1 * x[0] * x[1]]))
    state.x.scatter_forward()
    pins = rigid_pins(state)
    components = [k for ks in PINNED_COMPONENTS for k in ks]
    found = []
    for k, pin in zip(components, pins, strict=True):
        dofs, owned_end = pin.dof_indices()
        collapsed, parent = state.function_space.sub(0).sub(k).collapse()
        parent = np.asarray(parent).reshape(-1)
        x = collapsed.tabulate_dof_coordinates()[:, :2]
        cells = collapsed.dofmap.list
        centres = x[cells].mean(axis=1)
        copies = []
        for dof in dofs:
            local = np.flatnonzero(parent == dof)[0]
            cell = np.flatnonzero((cells == local).any(axis=1))[0]
            copies.append(np.concatenate([x[local], centres[cell]]))
        every = [c for part in comm.allgather(copies) for c in part]
        assert every and np.allclose(every, every[0], atol=1e-12)  # one copy, on every rank
        held = [  # this rank's copies (owned or ghost) of that node in that cell
            parent[cells[c, j]]
            for c in range(len(cells))
            for j in range(cells.shape[1])
            if np.allclose(x[cells[c, j]], every[0][:2], atol=1e-12)
            and np.allclose(centres[c], every[0][2:], atol=1e-12)
        ]
        assert sorted(held) == sorted(dofs.tolist())
        owned = dofs[:owned_end]
        mine = [(copies[i], float(state.x.array[dof])) for i, dof in enumerate(owned)]
        found.append((k, [item for part in comm.allgather(mine) for item in part]))
    return found


@pytest.mark.parametrize("shape", ["rectangle", "holed", "strip"])
def test_six_pins_hold_the_rigid_motions(shape):
    """One owned copy per pin; A the node nearest the centre (on the hole's edge when the
    centre is in the hole), |(B − A)₁| ≥ ½|B − A| (on the strip of two long cells the node
    nearest A + (r, 0) lies straight below A: the next one along x is taken), C at 30° or more
    from AB; the 6 × 6 matrix of the rigid motions' pinned components is regular."""
    pins = pinned(MPI.COMM_WORLD, shape)
    assert [k for k, _ in pins] == [0, 1, 2, 1, 2, 2]
    assert all(len(copies) == 1 for _, copies in pins)
    nodes = [copies[0][0][:2] for _, copies in pins]
    a, b, c = nodes[0], nodes[3], nodes[5]
    assert np.allclose(nodes[:3], [a] * 3) and np.allclose(nodes[4], b)
    d, e = b - a, c - a
    assert abs(d[0]) >= 0.5 * np.linalg.norm(d) > 0
    assert abs(d[0] * e[1] - d[1] * e[0]) >= 0.5 * np.linalg.norm(d) * np.linalg.norm(e) > 0
    expected = {
        "rectangle": ([1.0, 0.5], [1.25, 0.5], [1.0, 0.75]),  # r = 0.25, nodes 0.125 apart
        "strip": ([5.0, 0.5], [7.5, 0.5], [5.0, 1.0]),
    }
    if shape in expected:
        assert np.allclose([a, b, c], expected[shape])
    else:
        assert np.linalg.norm(a - [5.0, 2.0]) == pytest.approx(1.0, abs=0.01)  # the hole's edge
    # the rigid motions' pinned components: e_i, and ω × (x − A) for ω = e_i
    motions = np.zeros((6, 6))
    for row, (k, _) in enumerate(pins):
        x = np.append(nodes[row] - a, 0.0)
        motions[row, :3] = np.eye(3)[k]
        motions[row, 3:] = [np.cross(np.eye(3)[i], x)[k] for i in range(3)]
    assert np.linalg.svd(motions, compute_uv=False).min() > 0.05 * np.linalg.norm(d)
    # each pin keeps its start value: y = (x₁, x₂, 0.1 x₁x₂) at its node
    for k, copies in pins:
        (node, value) = copies[0]
        expected_value = [node[0], node[1], 0.1 * node[0] * node[1]]
        assert value == pytest.approx(expected_value[k], abs=1e-14)


@pytest.mark.mpi
@pytest.mark.parity
@pytest.mark.parametrize("shape", ["rectangle", "holed", "strip"])
def test_same_pins_on_any_number_of_ranks(shape):
    """The pinned nodes, their cells and values are those of one rank."""
    parallel, serial = pinned(MPI.COMM_WORLD, shape), pinned(MPI.COMM_SELF, shape)
    for (k, copies), (k_serial, copies_serial) in zip(parallel, serial, strict=True):
        assert k == k_serial and len(copies) == len(copies_serial) == 1
        assert np.allclose(copies[0][0], copies_serial[0][0], atol=1e-14)
        assert copies[0][1] == pytest.approx(copies_serial[0][1], abs=1e-14)
