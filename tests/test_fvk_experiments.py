"""FvK experiments (docs/fvk_experiments.md): edge data as formulas, the wrinkle wavelength
measure, the indenter; bad input.

The wavelength measure is checked on exact sinusoids (samples, and a DG field on a mesh); the
formula edge data on the exact homogeneous strain u = a (x, y) (in the discrete space).
"""

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest

from dgplate.errors import InputError
from dgplate.measure.wrinkles import dominant_wavelength, wrinkle_profile
from dgplate.mesh.tagged import RECTANGLE_SIDES, rectangle
from dgplate.models.fvk import FvKSpec, build_fvk
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
    spec = FvKSpec(membrane=membrane, load_steps=[0.5, 1.0], stability=False)
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
