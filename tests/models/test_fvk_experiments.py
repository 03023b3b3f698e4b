"""FvK experiments (docs/fvk_experiments.md): edge data as formulas, the wrinkle wavelength
measure, the indenter; bad input.

The wavelength measure is checked on exact sinusoids (samples, and a DG field on a mesh); the
formula edge data on the exact homogeneous strain u = a (x, y) (in the discrete space).
"""

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest

from dgplate.compat import geometry_dofmap
from dgplate.errors import InputError
from dgplate.measure.wrinkles import dominant_wavelength, wrinkle_profile
from dgplate.mesh.tagged import RECTANGLE_SIDES, rectangle
from dgplate.models.fvk.model import build_fvk
from dgplate.models.fvk.spec import FvKSpec, NewtonSpec
from dgplate.schema import from_dict


@pytest.mark.parametrize("wavelength", [0.05, 0.13, 0.2, 0.31])
def test_wavelength_of_an_exact_sinusoid(wavelength):
    """0.3 sin(2πs/λ + 0.7) + 0.1 on 300 samples of [0, 1]: λ within 0.1 % (≥ 3 periods)."""
    s = np.linspace(0.0, 1.0, 300)
    found = dominant_wavelength(s, 0.3 * np.sin(2 * np.pi * s / wavelength + 0.7) + 0.1)
    assert found == pytest.approx(wavelength, rel=1e-3)
    assert np.isnan(dominant_wavelength(s, np.ones_like(s)))


@pytest.mark.mpi
def test_wavelength_of_a_field_along_a_line():
    """W = e^{−x} sin(2π y/0.25) as DG2 on 16 × 16 cells: λ = 0.25 within 0.5 % on every
    line x = d, amplitude e^{−d} within 2 % (also on 2 ranks)."""
    tagged = rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [16, 16], cell_type="quadrilateral")
    space = dolfinx.fem.functionspace(tagged.mesh, ("DG", 2))
    w = dolfinx.fem.Function(space)
    w.interpolate(lambda x: np.exp(-x[0]) * np.sin(2 * np.pi * x[1] / 0.25))
    for d in (0.0, 0.3, 0.77):
        profile = wrinkle_profile(w, [d, 0.0], [d, 1.0])
        assert profile["wavelength"] == pytest.approx(0.25, rel=5e-3)
        assert profile["amplitude"] == pytest.approx(np.exp(-d), rel=2e-2)


@pytest.mark.mpi
def test_formula_edge_data_give_the_exact_homogeneous_strain():
    """U = λ a (x, y) prescribed by formulas on all four edges, w = 0: the exact solution is
    the homogeneous strain u = λ a (x, y), in the discrete space; checked at λ = ½ and 1."""
    a = 0.02
    tagged = rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [4, 4])
    membrane = {side: [f"{a}*x", f"{a}*y"] for side in RECTANGLE_SIDES}
    spec = FvKSpec(membrane=membrane, newton=NewtonSpec(load_steps=[0.5, 1.0], stability=False))
    model = build_fvk(spec, tagged)
    driver = model.driver(None, [], None)
    for factor in (0.5, 1.0):
        driver.run(max_steps=1)
        space, dofs = model.space.sub(1).collapse()
        u = driver.state.x.array[dofs].reshape(-1, 2)
        x = space.tabulate_dof_coordinates()[:, :2]
        assert np.abs(u - factor * a * x).max(initial=0.0) < 1e-10
    driver.destroy()


@pytest.mark.parametrize(
    "keys,message",
    [
        ({"membrane": {"left": [0.0, "0.1*y +"]}}, r"model\.membrane\.left\[1\]"),
        ({"membrane": {"left": [0.0, "foo(y)"]}}, r"model\.membrane\.left\[1\]"),
        ({"pressure": "sin(x"}, r"model\.pressure"),
        ({"indentation": -1.0, "indenter": "tip"}, r"model\.indentation"),
        ({"indentation": 0.1}, r"model\.indentation needs model\.indenter"),
        ({"indenter": 3}, r"model\.indenter"),
        ({"indenter_stiffness": 0.0}, r"model\.indenter_stiffness"),
    ],
)
def test_bad_experiment_keys(keys, message):
    with pytest.raises(InputError, match=message):
        from_dict(FvKSpec, keys, "model")


def test_edge_data_on_a_group_that_does_not_exist():
    tagged = rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [2, 2])
    spec = FvKSpec(membrane={"lefty": [0.0, "-0.1*y"]}, clamped=["right"])
    with pytest.raises(InputError, match=r"^model\.membrane: .*lefty"):
        build_fvk(spec, tagged)


# -- the experiments -------------------------------------------------------------------------
def _one_sided(comm, cells=24):
    """The demo's sheet (demos/fvk_one_sided.py): one load step, pushed off the flat state."""
    tagged = rectangle(comm, [[0.0, 0.0], [1.0, 1.0]], [cells, cells])
    spec = FvKSpec(nu=0.0, thickness=0.005, clamped=["right"], membrane={"left": [-0.005, "-0.002*(y - 0.5)"], "right": "fixed"}, newton=NewtonSpec(load_steps=1, perturb_unstable=0.0005))  # fmt: skip
    model = build_fvk(spec, tagged)
    driver = model.driver(None, [], None)
    assert driver.run().converged
    space, dofs = model.space.sub(0).collapse()
    w = dolfinx.fem.Function(space)
    w.x.array[:] = driver.state.x.array[dofs]
    driver.destroy()
    return [wrinkle_profile(w, [d, 0.0], [d, 1.0]) for d in (0.0, 0.1, 0.6)]


def test_one_sided_compression_wrinkles_at_the_compressed_edge():
    """Wrinkles localised at x = 0: amplitude there > t/100 (not the flat state: 0.074 t
    measured) and > 3 × that at x = 0.6; wavelength at the edge in [0.2, 0.35] (0.259 measured
    on 24 × 24), growing from x = 0 to x = 0.1."""
    edge, inside, far = _one_sided(MPI.COMM_WORLD)
    assert edge["amplitude"] > 0.01 * 0.005
    assert edge["amplitude"] > 3 * far["amplitude"]
    assert 0.2 < edge["wavelength"] < 0.35
    assert edge["wavelength"] < inside["wavelength"]


def _cone(comm, h, steps, depth, stability=True):
    from dgplate.mesh.tagged import load_geo

    tagged = load_geo(comm, "annulus_crease.geo", {"R_in": 0.0, "R_out": 1.0, "Rc": 0.15, "h": h},
                      recombine=True)  # fmt: skip
    spec = FvKSpec(nu=0.0, thickness=0.02, natural_shape="0.1*(1 - sqrt(x**2 + y**2))", clamped=["outer"], indenter="inner_ring", indentation=depth, probe=[0.0, 0.0], newton=NewtonSpec(load_steps=steps, stability=stability))  # fmt: skip
    model = build_fvk(spec, tagged)
    cone = lambda x: np.vstack([x[0], x[1], 0.1 * (1 - np.hypot(x[0], x[1]))])  # noqa: E731
    return model, model.driver(None, [], cone)


def test_cone_is_axisymmetric_before_onset_and_its_lowest_eigenvalue_decreases():
    """Indented cone (α = 0.1, t = 0.02, h = 0.2), δ up to 0.04 in 4 steps: w − w₀ₕ on r = ½
    is independent of θ to 25 % of δ at the first step (12 % measured; the coarse punch), the
    tip is pushed down by δ to 2 %, and the lowest Hessian eigenvalue decreases along the path:
    after a rise of 3 % in the second step it falls step by step, to 26 % of its first value."""
    model, driver = _cone(MPI.COMM_WORLD, 0.2, 4, 0.04)
    space, dofs = model.space.sub(0).collapse()
    start, w = dolfinx.fem.Function(space), dolfinx.fem.Function(space)
    start.interpolate(lambda x: 0.1 * (1 - np.hypot(x[0], x[1])))
    angles = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    circle = 0.5 * np.c_[np.cos(angles), np.sin(angles)]
    assert driver.run(max_steps=1).converged is False
    w.x.array[:] = driver.state.x.array[dofs] - start.x.array
    from dgplate.measure.wrinkles import line_values

    assert np.ptp(line_values(w, circle)) < 0.25 * 0.01
    assert driver.history[0].w_center == pytest.approx(0.1 - 0.01, rel=2e-2)
    assert driver.run().converged
    eigenvalues = [step.lowest_eigenvalue for step in driver.history]
    assert all(np.diff(eigenvalues[1:]) < 0) and eigenvalues[-1] < 0.5 * eigenvalues[0]
    driver.destroy()


@pytest.mark.mpi
@pytest.mark.parity
def test_cone_same_path_on_any_number_of_ranks():
    """Two steps of the indented cone (h = 0.3): energies and tip deflections on the world
    communicator equal those on one rank."""
    runs = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        _, driver = _cone(comm, 0.3, 2, 0.02, stability=False)
        assert driver.run().converged
        runs.append([(s.energy, s.w_center, s.iterations) for s in driver.history])
        driver.destroy()
    for parallel, serial in zip(*runs):
        assert parallel[:2] == pytest.approx(serial[:2], rel=1e-6)


def test_indentation_beyond_the_cone_height_warns(capfd):
    _, driver = _cone(MPI.COMM_SELF, 0.4, 1, 0.2, stability=False)
    driver.destroy()
    assert "model.indentation = 0.2 exceeds the height" in capfd.readouterr().err


@pytest.mark.mpi
def test_polar_disc_has_exact_rotational_symmetry():
    """meshes/polar_disc.geo (N = 16, h = 0.15): every cell's vertices rotated by 2π/N are the
    vertices of a cell again (to 10⁻¹⁰), the area is that of the polygon of the rim, and the
    punch group is the cells inside r = 0.15 (on any number of ranks)."""
    from dgplate.mesh.tagged import load_geo

    tagged = load_geo(MPI.COMM_WORLD, "polar_disc.geo", {"h": 0.15, "N": 16, "Rc": 0.15})
    mesh, comm = tagged.mesh, MPI.COMM_WORLD
    owned = mesh.topology.index_map(2).size_local
    x = mesh.geometry.x[:, 0] + 1j * mesh.geometry.x[:, 1]
    cells = np.concatenate(comm.allgather(x[geometry_dofmap(mesh)[:owned]]))

    def key(z):
        return {tuple(sorted(zip(c.real.round(10) + 0.0, c.imag.round(10) + 0.0))) for c in z}

    assert key(cells * np.exp(2j * np.pi / 16)) == key(cells)
    area = np.abs(((cells[:, 1] - cells[:, 0]).conj() * (cells[:, 2] - cells[:, 0])).imag).sum()
    facets = tagged.facets("outer")
    rim = comm.allreduce(int(np.count_nonzero(facets < mesh.topology.index_map(1).size_local)))
    assert area / 2 == pytest.approx(rim / 2 * np.sin(2 * np.pi / rim), rel=1e-12)
    centres = x[geometry_dofmap(mesh)[tagged.cells("inner_ring")]].mean(axis=1)
    assert np.abs(centres).max() < 0.15
