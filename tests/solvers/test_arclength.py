"""The pieces of the arclength continuation that need no plate: the step control, the secant."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from dgplate.errors import SolverError
from dgplate.solvers.arclength import StepLength, secant_root
from dgplate.solvers.eigen import Eigenpairs
from dgplate.solvers.special_points import SpecialPoints


def test_step_grows_after_fast_convergence_and_halves_on_failure():
    step = StepLength(ds=0.1, ds_max=0.2, ds_min=0.03)
    assert step.after(0.1, 4) == pytest.approx(0.15)  # ≤ fast: × 1.5
    assert step.after(0.15, 3) == 0.2  # bounded by ds_max
    assert step.after(0.1, 5) == 0.1  # slow: kept
    assert step.halved(0.1) == 0.05
    with pytest.raises(SolverError, match=r"fell below ds_min = 0\.03"):
        step.halved(0.05)


def test_secant_finds_the_root_and_ends_there():
    calls = []

    def f(s):
        calls.append(s)
        return math.cos(s) - s  # root 0.7390851332

    root = secant_root(f, 0.0, 1.0, 1.0, math.cos(1.0) - 1.0, xtol=1e-12)
    assert root == pytest.approx(0.7390851332151607, abs=1e-12)
    assert calls[-1] == root and len(calls) <= 12


#: ‖K‖_∞ of the free Hessian of the 32 × 32 plate of benchmarks/path_following.py (ε‖K‖_∞ 2.2e-16)
NORM_32 = 1.013


@pytest.mark.parametrize(
    ("index", "values", "norm", "expected"),
    [
        (0, [1.7e-14, 8.8e-9, 2.0e-8], NORM_32, 1.7e-14),  # before the crossing: the lowest
        (1, [-3.1e-11, 8.6e-9, 2.0e-8], NORM_32, -3.1e-11),  # after it: the negative one
        # at it, a round-off sign against the inertia
        (0, [-3.6e-19, 8.8e-9, 2.0e-8], NORM_32, 0.0),
        (1, [3.6e-19, 8.8e-9, 2.0e-8], NORM_32, 0.0),
        # round-off for ‖K‖ (4.5 ε‖K‖_∞), not for the largest computed eigenvalue (5e-8 of it)
        (0, [-1e-15, 8.8e-9, 2.0e-8], NORM_32, 0.0),
        (1, [1e-15, 8.6e-9, 2.0e-8], NORM_32, 0.0),
        # the other way round: ‖K‖ small, 1e-18 is 45 ε‖K‖_∞ but 5e-11 of the largest
        (0, [1e-18, 8.8e-9, 2.0e-8], 1e-4, 1e-18),
    ],
)
def test_the_crossing_eigenvalue_follows_the_inertia_up_to_round_off(index, values, norm, expected):
    """The eigenvalue whose root is a bifurcation (index 0 ↔ 1): at the root its computed sign
    is round-off (of size ε‖K‖), and the next eigenvalue (another mode) must not be taken for
    it. The values are those of the 32 × 32 plate of benchmarks/path_following.py near its first
    bifurcation (mixed unloaded edges), and made-up ones that tell the scale ε‖K‖_∞ from a
    fraction of the largest computed eigenvalue.
    """
    special = SpecialPoints(SimpleNamespace(index=lambda: index), StepLength(0.1, 1.0, 1e-6))
    special._eigenpairs = lambda: (Eigenpairs(np.array(values), [], "slepc"), norm)
    assert special._crossing_eigenvalue(1) == expected


def test_the_residual_is_at_most_quadratic_in_the_load_factor():
    """∂R/∂λ = (R(λ + 1) − R(λ − 1))/2 is exact: the third difference of R in λ vanishes.

    An FvK plate with every load the model scales: pressure, prestrain, a prescribed edge
    displacement (a number and a formula) and an indenter, at a state away from the flat one.
    """
    from mpi4py import MPI

    import dolfinx.fem
    import numpy as np

    from dgplate import values
    from dgplate.mesh.tagged import rectangle
    from dgplate.models.fvk.energy import fvk_energy
    from dgplate.models.fvk.model import build_fvk, start_from
    from dgplate.models.fvk.spec import FvKSpec
    from dgplate.solvers.arclength import Bordered
    from dgplate.solvers.newton import LoadFactor
    from dgplate.solvers.snes import NewtonSolver

    tagged = rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [3, 3])
    spec = FvKSpec(
        pressure="1e-6*(1 + x)",
        prestrain=1e-4,
        clamped=["left"],
        membrane={"right": [-1e-3, "0.001*y"]},
        natural_shape="0.01*x*y",
    )
    model = build_fvk(spec, tagged)
    state = dolfinx.fem.Function(model.space)
    start_from(state, lambda x: np.vstack([x[0] + 1e-3 * x[1], x[1], 0.01 * x[0] ** 2]))
    load_factor = values.constant(tagged.mesh, 0.0)
    energy = fvk_energy(state, model.facets, spec, load_factor, None)
    newton = NewtonSolver(state, energy, model.bcs, "dgplate_test_arclength_", None, "newton.snes")
    system = Bordered(
        newton, LoadFactor(load_factor, model.bc_values), "dgplate_test_arclength_path_"
    )
    try:
        residuals = []
        for lam in (-0.5, 0.5, 1.5, 2.5):
            vector = state.x.petsc_vec.duplicate()
            system.residual(lam, vector)
            residuals.append(vector)
        third = residuals[3].copy()
        for coefficient, vector in zip((-3.0, 3.0, -1.0), residuals[2::-1]):
            third.axpy(coefficient, vector)
        derivative = state.x.petsc_vec.duplicate()
        system.load_derivative(1.0, derivative)
        scale = derivative.norm()
        assert scale > 0 and third.norm() <= 1e-12 * scale
        difference = residuals[2].copy()  # R(1.5) − R(0.5) against the central derivative at 1
        difference.axpy(-1.0, residuals[1])
        difference.axpy(-1.0, derivative)
        assert difference.norm() <= 1e-12 * scale
    finally:
        system.destroy()
        newton.destroy()
