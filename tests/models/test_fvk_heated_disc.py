"""FvK plates with a natural curvature, mirror edges and a pinned height: the heated disc.

References: a free plate with natural curvature κ₀ I takes w = ½κ₀|x|² in the linear limit
(every moment vanishes), and the exact bowl and bifurcation of the free disc
(:mod:`dgplate.reference.heated_disc`). The heated disc's path against them is the demo's
(demos/fvk_heated_disc.py) and the benchmark's (benchmarks/heated_disc.py).
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest
from helpers import ROOT

import dgplate
from dgplate.errors import InputError
from dgplate.mesh.tagged import load_geo, rectangle
from dgplate.models.fvk.model import build_fvk
from dgplate.models.fvk.spec import FvKSpec, NewtonSpec
from dgplate.reference.heated_disc import (
    bifurcation,
    sphere,
    uniform_bifurcation,
    uniform_cylinder,
    uniform_sphere,
)

DISC = ROOT / "demos" / "problems" / "fvk_heated_disc.toml"
T, NU = 0.01, 0.3


def _linear_plate(tagged, mirror, corner):
    """The plate with κ₀ = 10⁻⁶ (κ₀R²/t = 10⁻⁴: linear), one load step; w at ``corner``."""
    spec = FvKSpec(
        nu=NU,
        thickness=T,
        natural_curvature=1e-6,
        mirror=mirror,
        pin=[0.0, 0.0],
        probe=corner,
        penalty_length="facet_normal",
        newton=NewtonSpec(load_steps=1, stability=False, snes={"snes_rtol": 1e-12}),
    )
    driver = build_fvk(spec, tagged).driver(None, [], None)
    try:
        driver.run()
        return driver.history[-1].w_center
    finally:
        driver.destroy()


@pytest.mark.parametrize("mesh", ["square", "quarter disc"])
def test_a_free_plate_takes_its_natural_curvature(mesh):
    """W = ½κ₀(x² + y²), which Q2 holds: the natural-curvature, mirror and pin terms are
    consistent. Measured: 7·10⁻¹⁰ relative on both (the membrane's share is of order
    (κ₀R²/t)² = 10⁻⁸)."""
    comm = MPI.COMM_WORLD
    if mesh == "square":
        tagged = rectangle(comm, [[0.0, 0.0], [1.0, 1.0]], [3, 2])
        w = _linear_plate(tagged, ["left", "bottom"], [1.0, 1.0])
        assert w == pytest.approx(1e-6, rel=1e-8)
    else:
        tagged = load_geo(comm, "quarter_disc", {"n": 2})
        w = _linear_plate(tagged, ["x_axis", "y_axis"], [1.0, 0.0])
        assert w == pytest.approx(0.5e-6, rel=1e-8)


def test_a_clamped_plate_with_natural_curvature_stays_flat():
    """Clamped all round, the (linear) plate cannot take its natural curvature: w = 0, which
    needs the natural-curvature terms on the clamped facets (without them it would bend)."""
    spec = FvKSpec(
        nu=NU,
        thickness=T,
        natural_curvature=1e-6,
        clamped=["left", "right", "bottom", "top"],
        # the flat start is the solution: its residual is round-off, which no relative
        # tolerance reduces
        newton=NewtonSpec(load_steps=1, stability=False, snes={"snes_atol": 1e-20}),
    )
    tagged = rectangle(MPI.COMM_WORLD, [[0.0, 0.0], [1.0, 1.0]], [3, 2])
    driver = build_fvk(spec, tagged).driver(None, [], None)
    try:
        driver.run()
        assert abs(driver.history[-1].w_max) < 1e-12 * 1e-6
    finally:
        driver.destroy()


def test_a_mirror_edge_must_be_straight_along_x_or_y():
    """The quarter disc's arc as a mirror: one line naming model.mirror and the group."""
    spec = FvKSpec(mirror=["x_axis", "rim"], pin=[0.0, 0.0])
    with pytest.raises(InputError, match=r"model\.mirror: group 'rim' needs a straight edge"):
        build_fvk(spec, load_geo(MPI.COMM_WORLD, "quarter_disc", {"n": 1}))


def test_the_uniform_curvature_model_branches_meet_at_its_bifurcation():
    """The bowl reaches a_b at κ₀_b, where the cylinder's two curvatures are both a_b; past it
    c ab = 1 − ν and a + b = (1 + ν)κ₀ (stationary: the gradient of f vanishes)."""
    kappa_b, a_b = uniform_bifurcation(T, 1.0, NU)
    assert kappa_b * 1.0**2 / T == pytest.approx(8 / (1 + NU) ** 1.5, rel=1e-14)
    assert uniform_sphere(kappa_b, T, 1.0, NU) == pytest.approx(a_b, rel=1e-13)
    assert uniform_cylinder(0.999 * kappa_b, T, 1.0, NU) is None
    a, b = uniform_cylinder(kappa_b * (1 + 1e-12), T, 1.0, NU)
    assert a == pytest.approx(a_b, rel=1e-5) and b == pytest.approx(a_b, rel=1e-5)
    kappa = 1.5 * kappa_b
    a, b = uniform_cylinder(kappa, T, 1.0, NU)
    c = (1 - NU**2) / (16 * T**2)
    gradient = [
        (x - kappa) + NU * (y - kappa) + c * x * y * y for x, y in ((a, b), (b, a))
    ]  # ½∂f/∂a, ½∂f/∂b
    assert np.abs(gradient) == pytest.approx([0, 0], abs=1e-12 * kappa)
    assert a > a_b > b > 0


def test_the_exact_bowl_is_the_linear_plate_when_nearly_flat_and_not_uniformly_curved():
    """At κ₀R²/t = 10⁻³ the rim height is ½κ₀R² to 10⁻⁶. At 5 the bowl is flatter than the
    uniform model's a at its stretched centre and steeper at its compressed rim (mean
    curvature w′(R)/R), and its rim lies lower than the model's ½aR²."""
    small = sphere(1e-3 * T, T, nu=NU)
    assert small.rim_height == pytest.approx(0.5e-3 * T, rel=1e-6)
    assert small.center_curvature == pytest.approx(1e-3 * T, rel=1e-6)
    kappa = 5.0 * T
    bowl, model = sphere(kappa, T, nu=NU), uniform_sphere(kappa, T, 1.0, NU)
    assert bowl.center_curvature < model < bowl.rim_slope
    assert bowl.rim_height < 0.5 * model
    assert bowl.rim_height == pytest.approx(
        sphere(kappa, T, nu=NU, steps=1000).rim_height, rel=1e-10
    )


def test_the_exact_bifurcation_depends_on_curvature_radius_and_thickness_through_k_r2_over_t():
    """κ₀_b R²/t = 5.619216 at ν = 0.3 (3·10⁻⁸ from the value at 2,000 Runge–Kutta steps),
    the same for another thickness and radius, and 4 % above the uniform-curvature model's."""
    value = bifurcation(T, nu=NU, steps=250) / T
    assert value == pytest.approx(5.6192161, rel=1e-7)
    assert bifurcation(2 * T, radius=math.sqrt(2), nu=NU, steps=250) / T == pytest.approx(
        value, rel=1e-6
    )
    assert value / (8 / (1 + NU) ** 1.5) - 1 == pytest.approx(0.0411, abs=5e-4)


@pytest.mark.mpi
@pytest.mark.parity
def test_same_heated_disc_path_on_any_number_of_ranks(tmp_path):
    """The heated disc (n = 4) through its bifurcation and switch (12 points, the switch the 10th): the
    same kinds and indices, load factors and rim heights within 10⁻⁸ on 1 and 2 or 3 ranks."""
    comm = MPI.COMM_WORLD
    folder = comm.bcast(str(tmp_path), root=0)
    problem = dgplate.load_problem(
        DISC,
        {"output.vtx": False, "output.png": False, "output.progress": 0, "path.steps": 12},
    )
    runs = []
    for name, sub in (("parallel", comm), ("serial", MPI.COMM_SELF)):
        if sub is MPI.COMM_SELF and comm.rank != 0:
            continue
        result = dgplate.run(problem, f"{folder}/{name}", comm=sub)
        runs.append(result.history)
    if comm.rank != 0:
        return
    parallel, serial = runs
    assert [r["kind"] for r in parallel] == [r["kind"] for r in serial]
    assert "bifurcation" in [r["kind"] for r in serial]
    assert [r["stability_index"] for r in parallel] == [r["stability_index"] for r in serial]
    for key in ("load_factor", "w_center", "w_rim_y"):
        got, expected = ([r[key] for r in run] for run in (parallel, serial))
        assert got == pytest.approx(expected, rel=1e-8, abs=1e-12), key
