"""The LDG reconstructed Hessian H_h(y) = D²_h y − R_h([∇y]) + B_h([y]) (dgplate/dg/lifting.py):
exact on polynomials, the lifting of a gradient jump by hand, the split of the energy into the
implicit bound and the concave rest, and ``model.hessian`` in problem files."""

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest
import ufl

from dgplate.dg.forms import Penalty, facet_sets, integral
from dgplate.dg.lifting import LiftedHessian, ldg_energy
from dgplate.errors import InputError
from dgplate.mesh.tagged import rectangle
from dgplate.models.base import flat_identity
from dgplate.models.kirchhoff import KirchhoffSpec, build_kirchhoff
from dgplate.schema import from_dict
from dgplate.solvers.flow import FlowSpec, GradientFlow


def _plate(cells, corners=((0.0, 0.0), (1.0, 1.0)), cell_type="quadrilateral", clamped=()):
    tagged = rectangle(MPI.COMM_WORLD, [list(c) for c in corners], cells, cell_type)
    facets = facet_sets(tagged, clamped=list(clamped))
    space = dolfinx.fem.functionspace(tagged.mesh, ("DG", 2, (3,)))
    return facets, dolfinx.fem.Function(space)


def _quadratic(x):
    """y = (x₁, x₂, x₁² − 3x₁x₂ + ½x₂²): D²y₃ = [[2, −3], [−3, 1]]."""
    return np.vstack([x[0], x[1], x[0] ** 2 - 3 * x[0] * x[1] + 0.5 * x[1] ** 2])


def _cell_values(H, points):
    """H at reference points of every cell: shape (cells, points, 3, 2, 2)."""
    mesh = H.function_space.mesh
    cells = np.arange(mesh.topology.index_map(2).size_local, dtype=np.int32)
    expr = dolfinx.fem.Expression(H, points)
    return expr.eval(mesh, cells).reshape(cells.size, len(points), 3, 2, 2)


@pytest.mark.parametrize("cell_type", ["quadrilateral", "triangle"])
def test_lifted_hessian_of_a_quadratic_is_its_hessian(cell_type):
    """No jumps (a free plate): H_h(y) = D²y at every point, to round-off."""
    facets, y = _plate([3, 2], cell_type=cell_type)
    y.interpolate(_quadratic)
    H = LiftedHessian(y, facets, 2).project()
    values = _cell_values(H, np.array([[0.1, 0.2], [0.3, 0.3], [0.25, 0.5]]))
    expected = np.zeros((3, 2, 2))
    expected[2] = [[2.0, -3.0], [-3.0, 1.0]]
    assert np.abs(values - expected).max() < 1e-10


def test_lifting_of_a_kink_by_hand():
    """Two unit cells, y₃ = β(x₁ − 1)₊: [∇y] = β e₁ on the facet x₁ = 1, [y] = 0, D²_h y = 0.

    r_e is ½β e₃⊗e₁⊗e₁ times the Riesz representer in Q₂ of the trace on the facet, which is
    f(t) = 1 + 3P₁(2t − 1) + 5P₂(2t − 1) in the distance t from the facet's far side (constant
    along the facet): H₃₁₁ = ½βf, 4.5β at the facet and 1.5β at the far sides; all else 0.
    """
    beta = 0.7
    facets, y = _plate([2, 1], corners=((0.0, 0.0), (2.0, 1.0)))
    y.interpolate(lambda x: np.vstack([x[0], x[1], beta * np.maximum(x[0] - 1.0, 0.0)]))
    H = LiftedHessian(y, facets, 2).project()
    mesh = y.function_space.mesh
    points = np.array([[0.0, 0.0], [0.5, 0.5], [1.0, 1.0], [0.2, 0.7]])  # reference points
    values = _cell_values(H, points)
    cells = np.arange(values.shape[0], dtype=np.int32)
    where = dolfinx.fem.Expression(ufl.SpatialCoordinate(mesh), points).eval(mesh, cells)
    x1 = where.reshape(cells.size, len(points), 2)[:, :, 0]
    s = 2 * (1.0 - np.abs(x1 - 1.0)) - 1  # 2t − 1, t the distance from the far side
    f = 1 + 3 * s + 5 * (3 * s**2 - 1) / 2
    assert values[:, :, 2, 0, 0] == pytest.approx(0.5 * beta * f, abs=1e-12)
    rest = values.copy()
    rest[:, :, 2, 0, 0] = 0.0
    assert np.abs(rest).max() < 1e-12
    assert values[:, :, 2, 0, 0].max() == pytest.approx(4.5 * beta, abs=1e-12)


def _ldg_value(energy):
    """E_h: the implicit form's value plus the nonlocal term's."""
    mesh = energy.implicit.ufl_domain().ufl_cargo()
    value = integral(dolfinx.fem.form(energy.implicit), mesh.comm)
    return value + sum(term.update() for term in energy.nonlocal_terms)


def test_energy_of_a_polynomial_is_half_its_squared_hessian():
    """Without jumps E_h = ½∫|D²y|² (= ½(4 + 18 + 1) on the unit square): the bound in the
    implicit part and in the nonlocal rest cancel."""
    facets, y = _plate([3, 3])
    y.interpolate(_quadratic)
    energy = ldg_energy(y, facets, Penalty(1.0, 1.0), 2)
    assert _ldg_value(energy) == pytest.approx(11.5, rel=1e-10)


def test_energy_of_a_clamped_cylinder():
    """The cylinder of radius 1/a rolled about x₂ from the clamped side x₁ = 0, with its exact
    data: E_h → ½a²|ω| at order 1.8 (the interpolation error; 1.6 %, 0.46 % at 4², 8² Q2)."""
    a = 2.0
    exact = lambda x: np.vstack(  # noqa: E731
        [np.sin(a * x[0]) / a, x[1], (1 - np.cos(a * x[0])) / a]
    )
    errors = []
    for n in (4, 8):
        facets, y = _plate([n, n], clamped=["left"])
        y.interpolate(exact)
        g, Phi = flat_identity(facets.mesh)  # the cylinder is flat at x₁ = 0
        energy = ldg_energy(y, facets, Penalty(1.0, 1.0), 2, g=g, Phi=Phi)
        errors.append(_ldg_value(energy) / (0.5 * a * a) - 1)
    assert errors == pytest.approx([1.5819e-2, 4.5991e-3], abs=1e-6)


@pytest.mark.parametrize(
    "cell_type,perturb", [("quadrilateral", 0.0), ("quadrilateral", 0.4), ("triangle", 0.0)]
)
def test_the_rest_is_concave(cell_type, perturb):
    """½∫|R_h − B_h|² ≤ the bound (lifting_bound): the nonlocal term is ≤ 0 at random
    fields, clamped data included, on uniform, perturbed and triangular meshes."""
    facets, y = _plate([4, 4], cell_type=cell_type, clamped=["left"])
    x = facets.mesh.geometry.x
    inner = (x[:, 0] > 1e-9) & (x[:, 0] < 1 - 1e-9) & (x[:, 1] > 1e-9) & (x[:, 1] < 1 - 1e-9)
    rng = np.random.default_rng(1)
    x[inner, :2] += perturb / 4 * (rng.random((int(inner.sum()), 2)) - 0.5)
    g, Phi = flat_identity(facets.mesh)
    term = LiftedHessian(y, facets, 2, g=g, Phi=Phi)
    values = []
    for _ in range(5):
        y.x.array[:] = rng.standard_normal(y.x.array.size)
        values.append(term.update())
    assert max(values) < 0.0


def test_model_hessian_key():
    """'ldg' gives the lifting degree k; anything else is a one-line error naming the key."""
    assert KirchhoffSpec(hessian="ldg", degree=3).ldg_degree == 3
    assert KirchhoffSpec().ldg_degree is None
    with pytest.raises(InputError, match=r"^model.hessian must be one of broken, ldg, got 'lgd'$"):
        from_dict(KirchhoffSpec, {"hessian": "lgd"}, "model")


def test_derivative_of_the_rest_is_exact():
    """The rest's linearisation has the derivative of its value (a difference quotient)."""
    facets, y = _plate([2, 2], clamped=["left"])
    g, Phi = flat_identity(facets.mesh)
    term = LiftedHessian(y, facets, 2, g=g, Phi=Phi)
    rng = np.random.default_rng(2)
    y.x.array[:] = rng.standard_normal(y.x.array.size)
    direction = dolfinx.fem.Function(y.function_space)
    direction.x.array[:] = rng.standard_normal(y.x.array.size)
    term.update()
    slope = integral(
        dolfinx.fem.form(ufl.derivative(term.linearisation, y, direction)),
        y.function_space.mesh.comm,
    )
    eps = 1e-5
    y.x.array[:] += eps * direction.x.array
    plus = term.update()
    y.x.array[:] -= 2 * eps * direction.x.array
    minus = term.update()
    assert slope == pytest.approx((plus - minus) / (2 * eps), rel=1e-6)


@pytest.mark.parametrize("gamma,energy,steps", [(1100.0, -8.6328e-3, 14), (10.0, -9.6456e-3, 160)])
def test_flow_with_the_ldg_hessian(gamma, energy, steps):
    """The BNN plate on 4 × 4 Q2 cells (flat minimiser, E = 0) with the LDG Hessian, flowed by
    adaptive τ and the SQP finish to ‖P DE_h‖ < 10⁻⁷: with the standard penalties (γ₀ = 5000)
    as with interior penalty (−8.668e−3), with γ₀ = γ₁ = 10 lower (the jumps cost less) and in
    ten times the steps (the implicit bound is stiffer than the LDG Hessian); the energy never
    rises. Figures of benchmarks/results/accuracy_rigid_minimiser_ldg_*.json."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [4, 4]], [4, 4])
    penalty = {"gamma0": 5000.0 if gamma > 1000 else gamma, "gamma1": gamma}
    table = {"clamped": ["left", "bottom"], "load": [0, 0, 2.5e-2], "penalty": penalty}
    spec = from_dict(KirchhoffSpec, {**table, "hessian": "ldg"}, "model")
    model = build_kirchhoff(spec, tagged)
    settings = FlowSpec(
        tau="h", tol=1e-7, adaptive_tau=True, stop="stationarity", projection_steps=2
    )
    result = GradientFlow(model.facets, model.degree, model.energy, settings).run()
    assert result.converged
    assert result.energy == pytest.approx(energy, rel=1e-4)
    assert abs(result.steps - steps) <= 2
    assert not result.energy_increases
