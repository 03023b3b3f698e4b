"""Meshes: named groups, gmsh parameters, ghosting and the face sets of the dG forms."""

from mpi4py import MPI

import dolfinx
import numpy as np
import pytest

from dgplate.dg.forms import CLAMPED, CREASE, SMOOTH, facet_sets
from dgplate.errors import InputError
from dgplate.mesh.tagged import load_geo, rectangle


def test_rectangle_groups_and_counts():
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [4, 1]], [8, 2], "quadrilateral")
    assert tagged.facets("left").size == 2
    assert tagged.facets("bottom").size == 8
    assert tagged.cells("plate").size == 16


def test_unknown_group_lists_available_names():
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [2, 2])
    with pytest.raises(InputError, match=r"unknown facet group 'clampd'.*left"):
        tagged.facets("clampd")


def test_group_function_values_defaults_and_gaps():
    """One value per cell group (scalar or 2×2), a default elsewhere, and a clear error when
    a group is missing and there is no default (annulus: inner_ring and outer_ring)."""
    tagged = load_geo(MPI.COMM_SELF, "annulus_crease", {"h": 0.3})
    inner, outer = tagged.cells("inner_ring"), tagged.cells("outer_ring")
    both = tagged.group_function({"inner_ring": 2.0, "outer_ring": 5.0}, key="model.mu")
    dofs = both.function_space.dofmap.list
    assert np.all(both.x.array[dofs[inner].ravel()] == 2.0)
    assert np.all(both.x.array[dofs[outer].ravel()] == 5.0)
    Z = tagged.group_function({"outer_ring": [[1.0, 2.0], [2.0, 3.0]]}, default=0.0, shape=(2, 2))
    blocks = Z.x.array.reshape(-1, 4)
    assert np.all(blocks[dofs[outer].ravel()] == [1.0, 2.0, 2.0, 3.0])
    assert np.all(blocks[dofs[inner].ravel()] == 0.0)
    with pytest.raises(
        InputError, match=rf"model.mu leaves {inner.size} cell\(s\) without a value"
    ):
        tagged.group_function({"outer_ring": 1.0}, key="model.mu")


def test_gmsh_parameters_and_quads():
    tagged = load_geo(MPI.COMM_SELF, "rectangle", {"Lx": 2, "Ly": 1, "h": 0.25, "quads": 1})
    mesh = tagged.mesh
    assert mesh.topology.cell_type == dolfinx.mesh.CellType.quadrilateral
    x = mesh.geometry.x
    assert np.isclose(x[:, 0].max(), 2.0) and np.isclose(x[:, 1].max(), 1.0)
    assert set(tagged.names(1)) == {"left", "right", "bottom", "top"}


def test_missing_mesh_file():
    with pytest.raises(InputError, match=r"mesh file not found: nosuch\.geo"):
        load_geo(MPI.COMM_SELF, "nosuch.geo")


def test_unknown_gmsh_parameter():
    with pytest.raises(InputError, match=r"width.* not defined in rectangle\.geo"):
        load_geo(MPI.COMM_SELF, "rectangle", {"width": 3})


def test_face_sets_classify_and_validate():
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [4, 4])
    faces = facet_sets(tagged, clamped=["left"])
    values = faces.tags.values
    assert np.count_nonzero(values == CLAMPED) == 4
    assert np.count_nonzero(values == SMOOTH) == 3 * 4 * 2  # interior facets of a 4x4 grid
    with pytest.raises(InputError, match="crease group 'left' contains 4 boundary"):
        facet_sets(tagged, crease=["left"])


def test_crease_facets_are_tagged():
    """A crease group's facets (inside) become CREASE, a clamped group's CLAMPED; a crease
    group used as a clamped one is refused, naming it."""
    tagged = load_geo(MPI.COMM_SELF, "straight_crease", {"h": 0.25, "quads": 1})
    crease = tagged.facets("crease")
    assert crease.size == 4  # the line x = 0 of height 1 in facets of length 0.25
    faces = facet_sets(tagged, clamped=["left"], crease=["crease"])
    values = faces.tags.values
    assert faces.num_crease == crease.size
    assert faces.num_clamped == tagged.facets("left").size == 4
    assert np.count_nonzero(values == CREASE) == crease.size
    assert np.all(values[np.searchsorted(faces.tags.indices, crease)] == CREASE)
    with pytest.raises(InputError, match="clamped group 'crease' contains 4 interior"):
        facet_sets(tagged, clamped=["crease"])


@pytest.mark.mpi
def test_shared_facet_ghosting(comm):
    """Every interior facet owned by a rank sees both of its cells (shared-facet ghosts)."""
    for tagged in (
        rectangle(comm, [[0, 0], [1, 1]], [6, 6]),
        load_geo(comm, "rectangle", {"h": 0.3}),
    ):
        mesh = tagged.mesh
        mesh.topology.create_connectivity(1, 2)
        f2c = mesh.topology.connectivity(1, 2)
        fmap = mesh.topology.index_map(1)
        exterior = set(dolfinx.mesh.exterior_facet_indices(mesh.topology).tolist())
        for f in range(fmap.size_local):
            if f not in exterior:
                assert len(f2c.links(f)) == 2
        if comm.size > 1:
            assert mesh.topology.index_map(2).num_ghosts > 0
