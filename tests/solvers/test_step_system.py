"""The flow's mixed space (dgplate/solvers/step_system.py): y broken or continuous."""

from mpi4py import MPI

import pytest

from dgplate.compat import collapse
from dgplate.mesh.tagged import rectangle
from dgplate.solvers.flow import FlowSpec
from dgplate.solvers.step_system import mixed_space


@pytest.mark.parametrize(
    ("cell_type", "continuous", "y_dofs", "multipliers"),
    [
        # 4 × 2 cells: 8 cells of 9 Q2 nodes, or the 9 × 5 nodes of the continuous Q2 space
        ("quadrilateral", False, 8 * 9 * 3, 8 * 4 * 3),
        ("quadrilateral", True, 9 * 5 * 3, 8 * 3 * 3),
        # 16 triangles of 6 P2 nodes, or 9 × 5 nodes; P1 multipliers either way
        ("triangle", False, 16 * 6 * 3, 16 * 3 * 3),
        ("triangle", True, 9 * 5 * 3, 16 * 3 * 3),
    ],
)
def test_continuous_y_shares_its_nodes_and_takes_p1_moments(
    cell_type, continuous, y_dofs, multipliers
):
    """A continuous y has one node where the cells meet; its first-moment multipliers are P1
    (3 per entry and cell) on quadrilaterals too, where the broken space keeps Q1 (4)."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [2, 1]], [4, 2], cell_type=cell_type)
    W = mixed_space(tagged.mesh, 2, FlowSpec(multiplier_degree=1), continuous)
    sizes = []
    for sub in range(2):
        space, _ = collapse(W.sub(sub))
        sizes.append(space.dofmap.index_map.size_global * space.dofmap.index_map_bs)
    assert sizes == [y_dofs, multipliers]
