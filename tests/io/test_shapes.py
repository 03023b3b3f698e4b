"""A run's shape for the lab. The printable solid: closed and consistently oriented (edge use),
its volume area × t (divergence theorem, and pyvista's), binary STL read back, ``dgplate
export``. The comparison with a scan: a known rotation recovered, the noise level reported
(``dgplate compare``)."""

import json
import os
import re
from pathlib import Path

import numpy as np
import pytest
from helpers import PROBLEMS

from dgplate.cli import main
from dgplate.io import solid
from dgplate.io.scan import SurfaceLocator
from dgplate.measure.alignment import align, kabsch
from dgplate.problems.shapes import _surface, compare_scan


def read_stl(path):
    """The triangles' corners of a binary STL file, (m, 3, 3)."""
    raw = path.read_bytes()
    count = int(np.frombuffer(raw, "<u4", 1, 80)[0])
    assert len(raw) == 84 + solid.STL_RECORD.itemsize * count
    return np.frombuffer(raw, solid.STL_RECORD, count, 84)["vertices"].astype(np.float64)


def grid(nx, ny, lift=None):
    """A triangulated [0, 2] × [0, 1] (nx × ny squares, two triangles each), z = lift(x, y)."""
    x, y = np.meshgrid(np.linspace(0, 2, nx + 1), np.linspace(0, 1, ny + 1), indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    if lift is not None:
        points = lift(points)
    index = np.arange(x.size).reshape(nx + 1, ny + 1)
    a, b = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
    c, d = index[:-1, 1:].ravel(), index[1:, 1:].ravel()
    triangles = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    return points, triangles.astype(np.int64)


def rolled(points, radius=1.0):
    """The flat grid rolled, without stretching, onto a cylinder of ``radius`` about x₂."""
    angle = points[:, 0] / radius
    return np.stack([radius * np.sin(angle), points[:, 1], radius * (1 - np.cos(angle))], axis=1)


def test_a_flat_sheet_is_a_closed_box_of_volume_area_times_t():
    points, triangles = grid(6, 3)
    vertices, faces = solid.thicken(points, triangles, 0.1)
    assert len(solid.boundary_edges(triangles)) == 2 * (6 + 3)
    assert len(faces) == 2 * len(triangles) + 2 * 2 * (6 + 3)
    assert solid.is_watertight(faces)
    assert solid.volume(vertices, faces) == pytest.approx(2.0 * 0.1, rel=1e-13)
    assert vertices[:, 2].max() == pytest.approx(0.05) and vertices[:, 2].min() == pytest.approx(
        -0.05
    )


def test_a_rolled_sheet_has_volume_area_times_t():
    """Rolled to nearly a full turn (2 of 2π): the offsets y ± (t/2)ν keep the volume at A t."""
    points, triangles = grid(40, 4, rolled)
    vertices, faces = solid.thicken(points, triangles, 0.05)
    assert solid.is_watertight(faces)
    exact = solid.area(points, triangles) * 0.05
    assert solid.volume(vertices, faces) == pytest.approx(exact, rel=1e-3)


def test_an_open_or_misoriented_surface_is_not_watertight():
    points, triangles = grid(2, 2)
    _, faces = solid.thicken(points, triangles, 0.1)
    assert not solid.is_watertight(faces[1:])  # a hole
    flipped = faces.copy()
    flipped[0] = flipped[0, ::-1]
    assert not solid.is_watertight(flipped)  # one triangle the wrong way round
    assert not solid.is_watertight(triangles)  # the open mid-surface


def test_binary_stl_is_read_back(tmp_path):
    points, triangles = grid(3, 2, rolled)
    vertices, faces = solid.thicken(points, triangles, 0.1)
    path = tmp_path / "sheet.stl"
    solid.write_solid(path, vertices, faces)
    assert path.stat().st_size == 84 + 50 * len(faces)
    np.testing.assert_allclose(read_stl(path), vertices[faces], atol=1e-6)
    assert [p.name for p in tmp_path.iterdir()] == ["sheet.stl"], "no temporary file is left"


@pytest.mark.parametrize("suffix", [".ply", ".vtu"])
def test_ply_and_vtu_hold_the_same_solid(tmp_path, suffix):
    pyvista = pytest.importorskip("pyvista")
    points, triangles = grid(3, 2, rolled)
    vertices, faces = solid.thicken(points, triangles, 0.1)
    path = tmp_path / f"sheet{suffix}"
    solid.write_solid(path, vertices, faces)
    read = pyvista.read(path)
    assert read.n_cells == len(faces) and read.n_points == len(vertices)
    cells = np.asarray(read.faces if suffix == ".ply" else read.cells).reshape(-1, 4)
    assert (cells[:, 0] == 3).all()
    np.testing.assert_allclose(np.asarray(read.points)[cells[:, 1:]], vertices[faces], atol=1e-6)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


@pytest.fixture(scope="module")
def strip(tmp_path_factory):
    """The Timoshenko strip (20 mm × 10 mm, t = 150 µm) run on 8×4 cells."""
    out = tmp_path_factory.mktemp("strip") / "out"
    sets = ["output.png=false", "output.vtx=false", "output.progress=0", "mesh.cells=[8,4]"]
    args = [arg for s in sets for arg in ("--set", s)]
    assert main(["run", str(PROBLEMS / "bilayer_timoshenko.toml"), "--out", str(out), *args]) == 0
    return out


def test_export_writes_a_watertight_solid_in_mm(strip, tmp_path, capsys):
    pyvista = pytest.importorskip("pyvista")
    path = tmp_path / "strip.stl"
    assert main(["export", str(strip), "--solid", str(path)]) == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith(f"dgplate: wrote {path}: 176 triangles, watertight, volume ")
    corners = read_stl(path)
    assert len(corners) == 2 * 2 * 32 + 2 * 2 * (8 + 4)
    mesh = pyvista.read(path).clean()
    assert mesh.is_manifold and mesh.n_open_edges == 0
    # 8×4 cells: −0.59 % from the triangulated mid-surface's area × t, −0.84 % from the
    # plate's (20 mm × 10 mm × 0.15 mm: an isometry keeps the area)
    triangulated = float(line.rsplit("area × thickness ", 1)[1].rstrip(")"))
    assert mesh.volume == pytest.approx(triangulated, rel=0.01)
    assert mesh.volume == pytest.approx(20.0 * 10.0 * 0.15, rel=0.01)
    summary = json.loads((strip / "summary.json").read_text())
    extent = np.ptp(corners.reshape(-1, 3), axis=0)
    bbox = np.ptp(np.array(summary["physical"]["bbox_m"]), axis=0) * 1e3
    assert extent == pytest.approx(bbox, abs=0.2)  # the mid-surface's box, ± t/2 and the mean


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ([], "--solid {path} exists; remove it or name another file"),
        (["obj"], "--solid {new}: the file must end in .stl, .ply, .vtu"),
        (["--thickness", "-1"], "--thickness must be a finite number > 0, got -1.0"),
    ],
    ids=["exists", "obj", "negative-thickness"],
)
def test_export_refusals_are_one_line(strip, tmp_path, capsys, extra, message):
    path = tmp_path / "kept.stl"
    path.write_text("user data")
    new = tmp_path / ("new.obj" if extra == ["obj"] else "new.stl")
    target, extra = (path, extra) if not extra else (new, [e for e in extra if e != "obj"])
    assert main(["export", str(strip), "--solid", str(target), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"dgplate: error: {message.format(path=path, new=new)}"
    assert path.read_text() == "user data"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.stl"]


def test_export_without_material_needs_a_thickness_and_keeps_the_mesh_units(tmp_path, capsys):
    out, path = tmp_path / "plate", tmp_path / "plate.stl"
    sets = ["output.png=false", "output.vtx=false", "output.progress=0", "mesh.cells=[4,4]"]
    args = [arg for s in sets for arg in ("--set", s)]
    assert main(["run", str(PROBLEMS / "vertical_load.toml"), "--out", str(out), *args]) == 0
    capsys.readouterr()
    assert main(["export", str(out), "--solid", str(path)]) == 2
    expected = "--thickness is required: the run has no [material] to take the thickness from"
    assert capsys.readouterr().err.strip() == f"dgplate: error: {expected}"
    assert not path.exists()
    assert main(["export", str(out), "--solid", str(path), "--thickness", "0.01"]) == 0
    line = capsys.readouterr().out.strip()
    assert ", watertight, volume " in line and line.endswith(")")
    volume, area_t = (
        float(v) for v in re.findall(r"volume (\S+) mesh³ \(area × thickness (\S+)\)", line)[0]
    )
    assert volume == pytest.approx(area_t, rel=0.01)


def sorted_corners(path):
    """The STL's triangles as a sorted array: the same solid in any triangle order."""
    corners = read_stl(path).reshape(-1, 9)
    return corners[np.lexsort(np.round(corners, 4).T[::-1])]


def _strip_on_every_rank(tmp_path, shared: str, comm) -> tuple[Path, Path]:
    """The Timoshenko strip at 6×3 run on ``comm`` into one folder every rank sees.

    Returns:
        (that folder, the run's output folder in it)
    """
    base = tmp_path if comm.size == 1 else tmp_path.parent / shared
    base = type(tmp_path)(comm.bcast(str(base), root=0))
    out = base / "strip"
    sets = ["output.png=false", "output.vtx=false", "output.progress=0", "mesh.cells=[6,3]"]
    args = [arg for s in sets for arg in ("--set", s)]
    assert main(["run", str(PROBLEMS / "bilayer_timoshenko.toml"), "--out", str(out), *args]) == 0
    return base, out


@pytest.mark.mpi
def test_export_is_the_same_solid_on_any_number_of_ranks(tmp_path):
    from mpi4py import MPI

    from dgplate.problems.shapes import export_solid

    comm = MPI.COMM_WORLD
    base, out = _strip_on_every_rank(tmp_path, "shared", comm)
    together = export_solid(out, base / "together.stl", None, comm)
    alone = export_solid(out, base / f"alone{comm.rank}.stl", None, MPI.COMM_SELF)
    assert together["watertight"] and alone["watertight"]
    assert together["triangles"] == alone["triangles"]
    assert together["volume"] == pytest.approx(alone["volume"], rel=1e-12)
    np.testing.assert_allclose(
        sorted_corners(base / "together.stl"),
        sorted_corners(base / f"alone{comm.rank}.stl"),
        rtol=0,
        atol=1e-5,  # float32 of millimetres
    )


def rotation(axis, angle):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def sample(points, triangles, count, rng):
    """``count`` points spread uniformly over the triangulated surface (a scanner's)."""
    corner = points[triangles]
    area = np.linalg.norm(
        np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0]), axis=1
    )
    chosen = rng.choice(len(triangles), size=count, p=area / area.sum())
    u, v = rng.random((2, count))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    c = corner[chosen]
    return c[:, 0] + u[:, None] * (c[:, 1] - c[:, 0]) + v[:, None] * (c[:, 2] - c[:, 0])


def test_kabsch_recovers_a_rotation_from_pairs():
    rng = np.random.default_rng(3)
    source = rng.normal(size=(20, 3))
    R0, t0 = rotation([1, -2, 0.5], 2.5), np.array([0.3, -1.0, 4.0])
    R, t = kabsch(source, source @ R0.T + t0)
    assert np.abs(R - R0).max() < 1e-13 and np.abs(t - t0).max() < 1e-13


def rolled_unevenly(points):
    """The flat grid rolled about x₂ by the angle 0.4x + 0.3x², tighter towards x = 2.

    Rolled evenly, the rectangle is symmetric: turned by π about the radius through its
    middle it is itself, and a scan fits it in two ways.
    """
    angle = 0.4 * points[:, 0] + 0.3 * points[:, 0] ** 2
    return np.stack([np.sin(angle), points[:, 1], 1 - np.cos(angle)], axis=1)


def test_align_recovers_a_rotation_of_a_rolled_sheet():
    """A sheet rolled unevenly about x₂ (no symmetry), turned by 40° and moved: found to 1e-6.

    Its two nearest starts end the screening the wrong way round (2.45e-4 against 2.70e-4 for
    the right one): both are refined.
    """
    points, triangles = grid(20, 10, rolled_unevenly)
    R0, t0 = rotation([1, 2, 3], 0.7), np.array([5.0, -3.0, 2.0])
    scan = sample(points, triangles, 2000, np.random.default_rng(0)) @ R0.T + t0
    found = align(scan, points, SurfaceLocator(points, triangles))
    assert np.abs(found.rotation @ R0 - np.eye(3)).max() < 1e-6
    # a shift along the axis keeps every point on the cylinder: only the edges, and the
    # points beside them, pin it down, to about the gap between them
    assert np.abs(found.rotation @ t0 + found.translation).max() < 1e-3
    assert found.rms < 1e-9


def write_xyz(path, points):
    path.write_text("x y z\n" + "\n".join(" ".join(f"{v:.12g}" for v in p) for p in points))


@pytest.mark.parametrize("sigma", [0.0, 0.01, 0.03])
def test_compare_recovers_the_rotation_and_the_noise_of_a_scan(strip, tmp_path, capsys, sigma):
    """The strip's own mid-surface (mm), 3000 points sampled on it, turned by 40° and moved,
    with Gaussian noise of σ per coordinate: the distance to the surface is the normal
    component, so its RMS is σ (within 10 %)."""
    from mpi4py import MPI

    surface, _, _ = _surface(strip, MPI.COMM_SELF)
    points, triangles = surface
    rng = np.random.default_rng(7)
    R0, t0 = rotation([1, 2, 3], 0.7), np.array([5.0, -3.0, 2.0])
    clean = sample(points, triangles, 3000, rng)
    path = tmp_path / "scan.xyz"
    write_xyz(path, clean @ R0.T + t0 + rng.normal(scale=sigma, size=clean.shape))
    found = compare_scan(strip, path, MPI.COMM_SELF)
    if sigma == 0.01:  # the command line's report and picture, once
        picture = tmp_path / "map.png"
        assert main(["compare", str(strip), str(path), "--map", str(picture)]) == 0
        from PIL import Image

        image = np.asarray(Image.open(picture).convert("RGB"), dtype=int)
        assert image.shape == (900, 1200, 3)
        red, blue = image[..., 0] - image[..., 2], image[..., 2] - image[..., 0]
        assert (red > 100).sum() > 50 and (blue > 100).sum() > 50, "points above and below"
        line = capsys.readouterr().out.strip()
        pattern = r"3,000 points, RMS (\S+) mm, max \S+ mm, Hausdorff \S+ mm after a rotation by 40.1° \(\d+ steps\)$"
        assert line.startswith(f"dgplate: {path}: ")
        assert float(re.search(pattern, line).group(1)) == pytest.approx(found["rms"], rel=1e-3)
    assert found["points"] == 3000 and found["units"] == "mm"
    assert found["angle_deg"] == pytest.approx(np.degrees(0.7), abs=0.1)
    if sigma == 0:
        assert np.abs(np.array(found["rotation"]) @ R0 - np.eye(3)).max() < 1e-6
        assert found["rms"] < 1e-6  # the scan's 12 digits
        return
    assert found["rms"] == pytest.approx(sigma, rel=0.1)
    assert found["hausdorff"] >= found["max"] > 2 * sigma


def test_an_existing_map_is_kept(strip, tmp_path, capsys):
    picture = tmp_path / "map.png"
    picture.write_text("user data")
    assert main(["compare", str(strip), str(tmp_path / "scan.xyz"), "--map", str(picture)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"dgplate: error: --map {picture} exists; remove it or name another file"
    assert picture.read_text() == "user data"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("1 2 3\n4 5 6\n", "needs at least 4 finite points, has 2"),
        ("1 2 3\n4 5 six\n", "cannot read its points"),
    ],
    ids=["too-few", "not-numbers"],
)
def test_a_bad_scan_is_one_line(strip, tmp_path, capsys, text, message):
    path = tmp_path / "scan.csv"
    path.write_text(text)
    assert main(["compare", str(strip), str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"dgplate: error: scan {path}: {message}") and "\n" not in err


@pytest.mark.mpi
def test_compare_is_the_same_on_any_number_of_ranks(tmp_path):
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    base, out = _strip_on_every_rank(tmp_path, "shared-compare", comm)
    if comm.rank == 0:
        (points, triangles), _, _ = _surface(out, MPI.COMM_SELF)
        clean = sample(points, triangles, 500, np.random.default_rng(2))
        write_xyz(base / "scan.xyz", clean @ rotation([0, 1, 1], 0.4).T)
    comm.barrier()
    together = compare_scan(out, base / "scan.xyz", comm)
    alone = compare_scan(out, base / "scan.xyz", MPI.COMM_SELF)
    assert together["points"] == alone["points"] == 500
    np.testing.assert_allclose(together["rotation"], alone["rotation"], rtol=0, atol=1e-9)
    assert together["angle_deg"] == pytest.approx(np.degrees(0.4), abs=1e-6)


@pytest.mark.parametrize("cell_type", ["triangle", "quadrilateral"])
def test_mid_surface_of_a_field_on_either_cell_type(cell_type):
    """y = (x₁, x₂, x₁²/10) on 4×2 cells: the vertices' values, triangles oriented along ν."""
    from mpi4py import MPI

    import dolfinx.fem

    from dgplate.mesh.tagged import rectangle

    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [2, 1]], [4, 2], cell_type)
    y = dolfinx.fem.Function(dolfinx.fem.functionspace(tagged.mesh, ("DG", 2, (3,))))
    y.interpolate(lambda x: np.stack([x[0], x[1], 0.1 * x[0] ** 2]))
    points, triangles = solid.mid_surface(y)
    assert len(points) == 15 and len(triangles) == 16
    np.testing.assert_allclose(points[:, 2], 0.1 * points[:, 0] ** 2, atol=1e-14)
    corner = points[triangles]
    normal = np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0])
    assert (normal[:, 2] > 0).all(), "ν = ∂₁y × ∂₂y points up"
    vertices, faces = solid.thicken(points, triangles, 0.05)
    assert solid.is_watertight(faces)
    assert solid.volume(vertices, faces) == pytest.approx(
        solid.area(points, triangles) * 0.05, rel=1e-3
    )


def test_write_solid_keeps_a_file_that_appeared_and_shares_what_it_writes(tmp_path):
    """A file at the path when the solid is placed (made after the command's check) is kept,
    with nothing left beside it; a new file gets the umask's mode, not mkstemp's 0600."""
    from dgplate.errors import InputError

    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    users = tmp_path / "users.stl"
    users.write_text("the user's")
    with pytest.raises(InputError, match=r"users\.stl exists; remove it or name another file"):
        solid.write_solid(users, vertices, triangles)
    assert users.read_text() == "the user's" and sorted(tmp_path.iterdir()) == [users]
    solid.write_solid(tmp_path / "new.stl", vertices, triangles)
    mask = os.umask(0o022)
    os.umask(mask)
    assert (tmp_path / "new.stl").stat().st_mode & 0o777 == 0o666 & ~mask
