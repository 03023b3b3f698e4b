"""Pictures and ParaView output of a deformed plate: a sheet rolled onto the unit cylinder.

y(x) = (sin x₁, x₂, 1 − cos x₁) is an isometry with |D²y| = 1, so the gathered surface, the
curvature field and the written files all have known answers.
"""

from pathlib import Path

import basix.ufl
import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
from PIL import Image

from dgplate import compat
from dgplate.errors import InputError
from dgplate.io.images import frames_to_gif
from dgplate.io.montage import montage
from dgplate.io.plotting import (
    COLOR_LABELS,
    REFERENCE,
    height_factor,
    plot_deformation,
    render_png,
    surface_grid,
)
from dgplate.io.vtx import DeformationWriter, bp_variables
from dgplate.measure.fields import bending_density, cell_field, defect_density, dg0_dofs_to_cells
from dgplate.mesh.tagged import rectangle
from dgplate.solvers.constraint import multiplier_element

CELL_TYPES = ["quadrilateral", "triangle"]
SMALL = (400, 300)


def cylinder(x):
    return np.vstack([np.sin(x[0]), x[1], 1.0 - np.cos(x[0])])


def rolled(comm, cell_type: str, degree: int = 2, cells=(4, 2)):
    """y in the collapsed [DG_k]³ subspace of the flow's mixed space, as the flow keeps it."""
    mesh = rectangle(comm, [[0, 0], [2, 1]], list(cells), cell_type).mesh
    ve = basix.ufl.element("DG", mesh.basix_cell(), degree, shape=(3,))
    mixed = basix.ufl.mixed_element([ve, multiplier_element(mesh)])
    V, _ = compat.collapse(dolfinx.fem.functionspace(mesh, mixed).sub(0))
    y = dolfinx.fem.Function(V, name="deformation")
    y.interpolate(cylinder)
    return y


def global_cells(mesh) -> int:
    return mesh.topology.index_map(mesh.topology.dim).size_global


@pytest.fixture
def shared_dir(tmp_path, comm) -> Path:
    """One directory for all ranks (pytest's tmp_path differs per process)."""
    return Path(comm.bcast(str(tmp_path), root=0))


def assert_png(path: Path, size=SMALL) -> None:
    with Image.open(path) as image:
        assert image.format == "PNG" and image.size == size
        pixels = np.asarray(image.convert("L"), dtype=float)
    assert pixels.std() > 5.0, "the picture is blank"
    assert not list(path.parent.glob(f".{path.stem}-*")), "a temporary file was left behind"


@pytest.mark.mpi
@pytest.mark.parametrize("cell_type", CELL_TYPES)
def test_surface_grid_gathers_nodal_positions(comm, cell_type):
    y = rolled(comm, cell_type)
    owned = y.function_space.mesh.topology.index_map(2).size_local
    grid = surface_grid(y, cell_values={"rank": np.full(owned, comm.rank)})
    if comm.rank != 0:
        assert grid is None
        return
    assert grid.n_cells == global_cells(y.function_space.mesh)
    assert sorted(np.unique(grid.cell_data["rank"])) == list(range(comm.size))
    assert set(np.unique(grid.celltypes)) == {70 if cell_type == "quadrilateral" else 69}
    assert grid.n_points == grid.n_cells * (9 if cell_type == "quadrilateral" else 6)
    exact = cylinder(np.asarray(grid.point_data[REFERENCE]).T).T
    assert np.max(np.abs(grid.points - exact)) < 1e-12
    lo, hi = np.asarray(grid.bounds)[0::2], np.asarray(grid.bounds)[1::2]
    assert np.allclose(lo, [0.0, 0.0, 0.0], atol=1e-12)
    assert np.allclose(hi[1:], [1.0, 1.0 - np.cos(2.0)], atol=1e-12)
    assert hi[0] == pytest.approx(exact[:, 0].max(), abs=1e-12) and hi[0] <= 1.0


@pytest.mark.mpi
def test_surface_grid_cubic_and_scalar(comm):
    y = rolled(comm, "triangle", degree=3)
    mesh = y.function_space.mesh
    theta = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("Lagrange", 1)))
    theta.interpolate(lambda x: 1.0 + x[0] - x[1])
    grid = surface_grid(y, point_values={"y": y, "theta": theta})
    if comm.rank == 0:
        reference = np.asarray(grid.point_data[REFERENCE])
        exact = cylinder(reference.T).T
        assert grid.n_points == grid.n_cells * 10
        assert np.max(np.abs(grid.points - exact)) < 1e-3  # cubic interpolation error
        assert np.array_equal(grid.point_data["y"], grid.points)
        assert np.allclose(grid.point_data["theta"], 1.0 + reference[:, 0] - reference[:, 1])
    y2 = rolled(comm, "quadrilateral", degree=2)  # collapsed space: its own dof numbering
    theta2 = dolfinx.fem.Function(dolfinx.fem.functionspace(y2.function_space.mesh, ("DG", 2)))
    theta2.interpolate(lambda x: x[0] * x[1])
    grid = surface_grid(y2, point_values={"theta": theta2})
    if comm.rank == 0:
        reference = np.asarray(grid.point_data[REFERENCE])
        assert np.allclose(grid.point_data["theta"], reference[:, 0] * reference[:, 1])
    w = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("DG", 2)))
    w.interpolate(lambda x: x[0] * x[1])
    grid = surface_grid(w)
    if comm.rank == 0:
        ref = np.asarray(grid.point_data[REFERENCE])
        assert np.allclose(grid.points[:, :2], ref[:, :2], atol=1e-14)
        assert np.allclose(grid.points[:, 2], ref[:, 0] * ref[:, 1], atol=1e-12)


@pytest.mark.mpi
@pytest.mark.parametrize(
    "cell_type,degree,tol", [("quadrilateral", 2, 0.03), ("triangle", 3, 0.01)]
)
def test_bending_density_of_cylinder_is_one(comm, cell_type, degree, tol):
    y = rolled(comm, cell_type, degree)
    values = bending_density(y)
    mesh = y.function_space.mesh
    assert values.shape == (mesh.topology.index_map(2).size_local,)
    assert np.max(np.abs(values - 1.0), initial=0.0) < tol
    defect = defect_density(y)
    assert defect.shape == values.shape and np.all(defect >= 0) and np.max(defect) < 0.05


@pytest.mark.mpi
@pytest.mark.parametrize("cell_type", CELL_TYPES)
def test_cell_values_follow_owned_cell_order(comm, cell_type):
    mesh = rolled(comm, cell_type).function_space.mesh
    owned = np.arange(mesh.topology.index_map(2).size_local, dtype=np.int32)
    midpoints = dolfinx.mesh.compute_midpoints(mesh, 2, owned)
    import ufl

    x = ufl.SpatialCoordinate(mesh)
    assert np.allclose(cell_field(x[0] + 10 * x[1], mesh), midpoints[:, 0] + 10 * midpoints[:, 1])
    space = dolfinx.fem.functionspace(mesh, ("DG", 0))
    f = dolfinx.fem.Function(space)
    f.interpolate(lambda p: p[0] + 10 * p[1])
    assert np.allclose(dg0_dofs_to_cells(f.x.array, space), midpoints[:, 0] + 10 * midpoints[:, 1])


@pytest.mark.mpi
def test_render_png(comm, shared_dir):
    y = rolled(comm, "quadrilateral")
    grid = surface_grid(y, cell_values={"bending |D²y|": bending_density(y)})
    path = shared_dir / "cylinder.png"
    crease = np.array([[np.sin(1.0), t, 1 - np.cos(1.0)] for t in np.linspace(0, 1, 5)])
    render_png(grid, path, "bending |D²y|", "rolled", show_edges=True, lines=[crease])
    comm.barrier()
    assert_png(path, (1200, 900))


@pytest.mark.mpi
def test_plot_deformation_and_gif(comm, shared_dir):
    y = rolled(comm, "triangle")
    frames = []
    views = [("curvature", "iso"), ("defect", "top"), ("gauss", "xz"), (None, "yz")]
    for i, (color_by, camera) in enumerate(views):
        frames.append(shared_dir / f"frame{i}.png")
        plot_deformation(y, frames[-1], f"frame {i}", color_by, camera, window_size=SMALL)
    comm.barrier()
    for frame in frames:
        assert_png(frame)
    frames_to_gif(frames, shared_dir / "roll.gif", fps=5)
    comm.barrier()
    with Image.open(shared_dir / "roll.gif") as gif:
        assert gif.format == "GIF" and gif.n_frames == 4 and gif.size == SMALL
    with pytest.raises(ValueError, match="color_by"):
        plot_deformation(y, shared_dir / "bad.png", color_by="energy")


@pytest.mark.mpi
def test_a_nearly_flat_shape_is_drawn_with_its_heights_exaggerated(comm, monkeypatch, tmp_path):
    """An arch a two-hundredth of its span high: final.png multiplies its heights by 20 (to at
    most 0.15 of the span) and says so; a rolled plate and the frames (no ``exaggerate``) keep
    the true scale."""
    import dgplate.io.plotting as plotting

    assert height_factor(np.array([[0, 0, 0], [1, 0.1, 0.01], [0.5, 0, -0.002]])) == 10
    assert height_factor(np.array([[0, 0, 0], [4, 0, 0.003]])) == 200  # 0.6 / 0.003
    assert height_factor(np.array([[0, 0, 0], [1, 0, 0.3]])) == height_factor(np.zeros((2, 3))) == 1
    # just below a power of ten (log10 rounds up to 3: 1000 would be too much), not finite, none
    assert height_factor(np.array([[0, 0, 0], [1, 0, 0.15 / 999.9999999999999]])) == 500
    assert height_factor(np.array([[0, 0, np.nan], [1, 0, 0.01]])) == 1
    assert height_factor(np.zeros((0, 3))) == 1
    drawn = []
    monkeypatch.setattr(plotting, "render_png", lambda grid, path, scalars, title, *a, **k: drawn.append(
        (title, np.ptp(grid.points[:, 2]) if grid is not None else None)))  # fmt: skip
    y = rolled(comm, "quadrilateral")
    flat = dolfinx.fem.Function(y.function_space)
    flat.interpolate(lambda x: np.array([x[0], x[1], 0.01 * np.sin(np.pi * x[0] / 2)]))
    for shape, exaggerate in ((flat, True), (flat, False), (y, True)):
        plotting.plot_deformation(shape, tmp_path / "a.png", "t", exaggerate=exaggerate)
    if comm.rank == 0:
        (arch, high), (true, low), (plate, _) = drawn
        assert arch == "t  (heights × 20)" and high == pytest.approx(20 * low, rel=1e-12)
        assert true == plate == "t" and low == pytest.approx(0.01, rel=1e-3)


@pytest.mark.parametrize(("color_by", "label", "factor"), [
    ("curvature", "bending |D²y| (1/mm)", 0.1), ("gauss", "Gaussian curvature K (1/mm^2)", 0.01),
    ("defect", "isometry defect density", 1.0),
])  # fmt: skip
def test_colours_in_physical_units(color_by, label, factor, comm, monkeypatch, tmp_path):
    """With a mesh unit of 10 mm a curvature is shown in 1/mm (÷ 10), K in 1/mm² (÷ 100)."""
    import dgplate.io.plotting as plotting

    drawn = []
    monkeypatch.setattr(plotting, "render_png", lambda grid, path, scalars, *a, **k: drawn.append(
        (scalars, np.asarray(grid.cell_data[scalars]))))  # fmt: skip
    y = rolled(comm, "triangle")
    plotting.plot_deformation(y, tmp_path / "a.png", color_by=color_by)
    plotting.plot_deformation(y, tmp_path / "b.png", color_by=color_by, length_mm=10.0)
    (plain, values), (scaled, physical) = drawn
    assert plain == COLOR_LABELS[color_by] and scaled == label
    assert np.abs(values).max() > 0  # |D²y| = 1; K and the defect are round-off here
    assert np.allclose(physical, factor * values, rtol=1e-14, atol=0)


def test_montage_of_pictures(tmp_path):
    panels = []
    for i, colour in enumerate(["red", "blue", "green"]):
        panels.append(tmp_path / f"panel{i}.png")
        Image.new("RGB", (120, 90), colour).save(panels[-1])
    grid = tmp_path / "sub" / "grid.png"
    montage(
        [panels[:2], [panels[2], None]],
        grid,
        captions=[["a", "b"], ["c", ""]],
        row_labels=["row 1", "row 2"],
        column_labels=["left", "right"],
        title="a grid",
        note="small print " * 20,
    )
    with Image.open(grid) as image:
        assert image.format == "PNG" and image.size[0] > image.size[1] > 300
    assert sorted(p.name for p in grid.parent.iterdir()) == ["grid.png"]  # no temporary left
    with pytest.raises(ValueError, match="at least one"):
        montage([], tmp_path / "empty.png")


@pytest.mark.mpi
@pytest.mark.skipif(not dolfinx.common.has_adios2, reason="DOLFINx without ADIOS2")
@pytest.mark.parametrize("cell_type,degree", [("quadrilateral", 2), ("triangle", 3)])
def test_vtx_writer(comm, shared_dir, cell_type, degree):
    y = rolled(comm, cell_type, degree)
    mesh = y.function_space.mesh
    theta = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("Lagrange", 1)), name="theta")
    with DeformationWriter(shared_dir / "flow", y, [theta]) as writer:
        for t in (0.0, 0.5):
            writer.write(t)
        y_written = writer.y_out.x.array.copy()
    main, extra = shared_dir / "flow.bp", shared_dir / "flow_theta.bp"
    gauss = shared_dir / "flow_gauss_curvature.bp"
    assert writer.paths == [main, extra, gauss]
    comm.barrier()
    for path in writer.paths:
        assert path.is_dir() and (path / "data.0").stat().st_size > 0
    assert bp_variables(main) == {"deformation", "displacement"}
    assert bp_variables(extra) == {"theta"}
    assert bp_variables(gauss) == {"gauss_curvature"}
    assert y_written.tobytes() in (main / "data.0").read_bytes()  # the last step, this rank
    u = writer.u_out.x.array.reshape(-1, 3)
    x = writer.u_out.function_space.tabulate_dof_coordinates()
    assert np.allclose(u + x, y_written.reshape(-1, 3), atol=1e-14)


@pytest.mark.mpi
@pytest.mark.skipif(not dolfinx.common.has_adios2, reason="DOLFINx without ADIOS2")
def test_vtx_in_millimetres(comm, shared_dir):
    """With a material's length (here 1 mesh unit = 10 mm): the mesh, y and u in mm and K in
    1/mm² in the file, the mesh's own coordinates untouched after the write."""
    y = rolled(comm, "quadrilateral")
    y.interpolate(lambda x: np.vstack([x[0], x[1], 0.25 * (x[0] ** 2 + x[1] ** 2)]))  # K > 0
    mesh = y.function_space.mesh
    x = mesh.geometry.x.copy()
    with DeformationWriter(shared_dir / "plain", y) as plain:
        plain.write(0.0)
    with DeformationWriter(shared_dir / "mm", y, length_mm=10.0) as writer:
        writer.write(0.0)
    assert mesh.geometry.x.tobytes() == x.tobytes()  # restored bit for bit
    assert np.array_equal(writer.y_out.x.array, 10.0 * y.x.array)
    assert np.array_equal(writer.u_out.x.array, 10.0 * plain.u_out.x.array)
    (K,), (K_plain,) = ([f.function.x.array for f in w._cell_fields] for w in (writer, plain))
    assert np.allclose(K, K_plain / 100.0, rtol=1e-14, atol=0) and np.abs(K_plain).max() > 0.1
    # VTX writes a DG field's nodes as its mesh: y's dof coordinates, here from the mesh in mm
    space = writer.y_out.function_space
    owned = space.dofmap.index_map.size_local
    plain_nodes = space.tabulate_dof_coordinates()[:owned]
    mesh.geometry.x[:] *= 10.0
    nodes = space.tabulate_dof_coordinates()[:owned]
    mesh.geometry.x[:] = x
    comm.barrier()
    data = b"".join(p.read_bytes() for p in sorted((shared_dir / "mm.bp").glob("data.*")))
    assert nodes.tobytes() in data and plain_nodes.tobytes() not in data
    assert writer.y_out.x.array[: 3 * owned].tobytes() in data


@pytest.mark.mpi
def test_xdmf_fallback(comm, shared_dir):
    y = rolled(comm, "triangle")
    cells = dolfinx.fem.Function(dolfinx.fem.functionspace(y.function_space.mesh, ("DG", 0)))
    cells.name = "cells"
    with DeformationWriter(shared_dir / "flow.bp", y, [cells], backend="xdmf") as writer:
        writer.write(0.0)
        writer.write(1.0)
    comm.barrier()
    assert writer.paths == [shared_dir / "flow.xdmf", shared_dir / "flow.h5"]
    assert all(path.stat().st_size > 0 for path in writer.paths)
    text = (shared_dir / "flow.xdmf").read_text()
    names = ("deformation", "displacement", "cells", "gauss_curvature")
    assert all(name in text for name in names)
    with pytest.raises(InputError, match="unique"):
        DeformationWriter(shared_dir / "x", y, [writer.y_out])


@pytest.mark.mpi
def test_xdmf_in_millimetres(comm, shared_dir):
    """The XDMF fallback with a material's length: its mesh (in the .h5) and y in mm."""
    y = rolled(comm, "triangle")
    mesh = y.function_space.mesh
    x = mesh.geometry.x.copy()
    with DeformationWriter(shared_dir / "mm", y, backend="xdmf", length_mm=10.0) as writer:
        writer.write(0.0)
    assert mesh.geometry.x.tobytes() == x.tobytes()  # restored bit for bit
    comm.barrier()
    data = (shared_dir / "mm.h5").read_bytes()
    nodes = x[: mesh.geometry.index_map().size_local, : mesh.geometry.dim]  # as XDMF stores them
    assert (10.0 * nodes).tobytes() in data and nodes.tobytes() not in data
    assert np.allclose(writer.y_out.x.array.reshape(-1, 3)[:, 2].max(), 10 * y.x.array[2::3].max())
