"""Self-avoiding rods (docs/rods.md): the tangent-point energy of a curve and the rod flow.

For a curve the tangent-point radius r(x, y) = |y − x|²/(2|P_t^⊥(y − x)|) is the radius of the
circle through y tangent at x. On a round circle of radius R that circle is the curve itself:
r ≡ R, so TP = (2^(−q)/q)L²/R^q exactly, and the discrete sum, which leaves out the pairs of
the same and of neighbouring segments (3h of the L around each point), is (2^(−q)/q)R^(−q)·L(L − 3h).
"""

import itertools
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import PARITY_RTOL, QUIET, check_load_is_derivative, check_pair_sum_derivatives

import dgplate
from dgplate.dg import tangent_point as tp
from dgplate.models.rod.start import RodStart


def trefoil_cloud(segments: int, per: int = 2) -> tuple[tp.Cloud, float]:
    """Gauss points of a (2, 3) torus knot polygon's parameter cells, unit tangents, ids."""
    g, w = np.polynomial.legendre.leggauss(per)
    s = ((np.arange(segments)[:, None] + (g[None, :] + 1) / 2) / segments).reshape(-1)
    a = 2 * np.pi * s
    x = np.c_[(2 + np.cos(3 * a)) * np.cos(2 * a), (2 + np.cos(3 * a)) * np.sin(2 * a)]
    x = np.c_[x, np.sin(3 * a)]
    dx = np.c_[
        -3 * np.sin(3 * a) * np.cos(2 * a) - 2 * (2 + np.cos(3 * a)) * np.sin(2 * a),
        -3 * np.sin(3 * a) * np.sin(2 * a) + 2 * (2 + np.cos(3 * a)) * np.cos(2 * a),
        3 * np.cos(3 * a),
    ]
    speed = np.linalg.norm(dx, axis=1)
    weights = np.tile(w / 2, segments) * 2 * np.pi * speed / segments
    k = np.repeat(np.arange(segments), per)
    cloud = tp.Cloud(x, dx / speed[:, None], weights, np.c_[k, (k + 1) % segments], curve=True)
    return cloud, float(weights.max() * 2)


def circle_cloud(segments: int, radius: float = 1.0) -> tuple[tp.Cloud, float]:
    """Two Gauss points per segment of the circle of radius R, exact tangents."""
    length = 2 * np.pi * radius
    g, w = np.polynomial.legendre.leggauss(2)
    phi = ((np.arange(segments)[:, None] + (g[None, :] + 1) / 2) / segments).reshape(-1) * 2 * np.pi
    x = radius * np.c_[np.cos(phi), np.sin(phi), 0 * phi]
    t = np.c_[-np.sin(phi), np.cos(phi), 0 * phi]
    k = np.repeat(np.arange(segments), 2)
    weights = np.tile(w / 2, segments) * length / segments
    return tp.Cloud(x, t, weights, np.c_[k, (k + 1) % segments], curve=True), length


@pytest.mark.parametrize("q", [3.0, 4.5])
def test_circle_value_is_exact_up_to_the_left_out_neighbours(q):
    """TP_h = (2^-q/q) R^-q L(L − 3h) to round-off, so TP_h → (2^-q/q) L²/R^q like 3h/L."""
    radius = 0.7
    errors = []
    for n in (16, 32, 64, 128):
        cloud, length = circle_cloud(n, radius)
        value = tp.evaluate(cloud, q, theta=0.0).energy
        exact = 2**-q / q * length**2 / radius**q
        assert value == pytest.approx(exact * (1 - 3 / n), rel=1e-12)
        errors.append(abs(value - exact) / exact)
    assert all(math.isclose(a / b, 2.0) for a, b in itertools.pairwise(errors))


def test_curve_pair_is_the_tangent_line_distance():
    """Two points, tangents t_i: (2^-q/q) w_i w_j Σ r^-q with r = |d|²/(2|d − (t·d)t|)."""
    x = np.array([[0.0, 0.0, 0.0], [0.3, 0.1, 0.5]])
    t = np.array([[1.0, 0.0, 0.0], [0.6, 0.0, 0.8]])
    w = np.array([0.2, 0.7])
    q = 3.0
    value = tp.evaluate(tp.Cloud(x, t, w, np.array([[0, 1], [2, 3]]), curve=True), q, 0.0)
    d = x[1] - x[0]
    r = [d @ d / (2 * np.linalg.norm(d - (t[k] @ d) * t[k])) for k in (0, 1)]
    assert math.isclose(value.energy, 2**-q / q * w[0] * w[1] * sum(ri**-q for ri in r))


def test_curve_tree_approaches_exact_sums_as_theta_falls():
    """A trefoil of 2000 points: the tree's errors fall with θ (rods use θ = 0 by default).

    Measured (relative): θ = 1: TP 4.9e-3, ∂/∂x 8.5e-2; θ = 0.5: 2.8e-3, 4.5e-2; θ = 0.25:
    4.5e-4, 2.0e-2. On a curve the far field is a larger share of the forces than on the
    plates' spiral, and the monopole spreads a box's force over its points by weight only.
    """
    cloud, reach = trefoil_cloud(1000)
    exact = tp.evaluate(cloud, 3.0, theta=0.0)
    errors = []
    for theta in (1.0, 0.5, 0.25):
        tree = tp.evaluate(cloud, 3.0, theta=theta, reach=3 * reach)
        assert tree.pairs_far > 0 and tree.pairs_exact < exact.pairs_exact / 2
        gradient = np.linalg.norm(tree.d_points - exact.d_points) / np.linalg.norm(exact.d_points)
        errors.append((abs(tree.energy - exact.energy) / exact.energy, gradient))
    assert errors[0][0] > errors[1][0] > errors[2][0] and errors[2][0] < 1e-3
    assert errors[0][1] > errors[1][1] > errors[2][1] and errors[2][1] < 3e-2


def test_curve_derivatives_by_finite_differences():
    """∂TP/∂x and ∂TP/∂t of the exact sums against central differences."""
    check_pair_sum_derivatives(trefoil_cloud(40)[0], 3.0, seed=3)


PROBLEMS = Path(__file__).resolve().parents[2] / "demos" / "problems"
#: A ring of 48 cells twisted 5 times with c_t = 0.9 c_b: 2.6 times Michell's threshold
#: (c_t k < √3 c_b), perturbed by the saddle a = 0.05. It buckles out of the plane and writhes.
TWISTED = {
    "model.cells": 48,
    "model.twist": 10 * math.pi,
    "model.c_t": 0.9,
    "model.saddle": 0.05,
    "flow.tau": 0.1,
    "flow.tol": 1e-9,
}


def run_ring(tmp_path, overrides, comm=MPI.COMM_SELF, name="out"):
    problem = dgplate.load_problem(
        PROBLEMS / "rod_closed.toml", overrides={**QUIET, **TWISTED, **overrides}
    )
    out = comm.bcast(tmp_path / name if comm.rank == 0 else None)
    return dgplate.run(problem, out=out, comm=comm)


def test_twisted_ring_without_self_avoidance_passes_through_itself(tmp_path):
    """The control: without ρTP the ring unwinds through itself, Wr jumps by ≈ 2 in one step.

    Measured: the largest change of Wr in one step 1.90, Lk = Tw + Wr 4.64 → 1.12.
    """
    result = run_ring(tmp_path, {"flow.max_steps": 120})
    writhes = [row["writhe"] for row in result.history]
    assert max(abs(b - a) for a, b in itertools.pairwise(writhes)) > 1.5


def test_self_avoiding_twisted_ring_never_crosses(tmp_path):
    """With ρ = 0.1, q = 3 the same ring comes into self-contact but never crosses itself.

    Measured (150 steps): least distance of non-neighbouring points 0.0296 → 0.0218 at step
    ~110 (h = 0.021), no step redone, the largest change of Wr in one step 0.058, Wr 0 → 1.35,
    energy 448.3 → 338.6 decreasing at every step.
    """
    result = run_ring(tmp_path, {"flow.max_steps": 150, "model.self_avoidance": {"rho": 0.1}})
    assert result["energy_increases"] == []
    distances = [row["min_distance"] for row in result.history]
    assert min(distances) > 0.5 / 48  # never below half a cell
    assert min(distances) < 0.8 * distances[0]  # but pushed together (self-contact)
    writhes = [row["writhe"] for row in result.history]
    assert max(abs(b - a) for a, b in itertools.pairwise(writhes)) < 0.2  # no jump by ±2
    assert writhes[-1] > 1.0  # it has writhed
    assert result["energy_self_avoidance"] > 0 and result["min_distance"] == distances[-1]


def test_the_rod_safety_net_redoes_steps_that_approach_too_fast(tmp_path):
    """approach = 0.99: a step that closes the least distance by more than 1 % is redone with τ/2.

    Measured: steps 68–83 redone 1–4 times (τ down to 0.1/16), the least distance never falls
    by more than 1 % in one step, and the energy still decreases at every step.
    """
    overrides = {"flow.max_steps": 90, "model.self_avoidance": {"rho": 0.1, "approach": 0.99}}
    result = run_ring(tmp_path, overrides)
    assert result["energy_increases"] == []
    redone = [row for row in result.history if row["redone"] > 0]
    assert len(redone) >= 5 and max(row["redone"] for row in redone) >= 3
    assert all(row["tau"] == 0.1 / 2 ** row["redone"] for row in result.history)
    distances = [row["min_distance"] for row in result.history]
    assert all(b > 0.99 * a for a, b in itertools.pairwise(distances))


def test_rod_self_avoidance_q_must_exceed_two():
    with pytest.raises(dgplate.InputError, match=r"model\.self_avoidance\.q must be > 2"):
        dgplate.load_problem(PROBLEMS / "rod_closed.toml", {"model.self_avoidance": {"q": 2.0}})


@pytest.mark.mpi
def test_self_avoiding_rod_same_on_any_number_of_ranks(tmp_path):
    overrides = {"flow.max_steps": 20, "model.self_avoidance": {"rho": 0.1}}
    serial = run_ring(tmp_path, overrides, name="serial")
    parallel = run_ring(tmp_path, overrides, comm=MPI.COMM_WORLD, name="parallel")
    assert parallel["steps"] == serial["steps"]
    for key in ("energy", "energy_self_avoidance", "min_distance", "writhe", "twist_angle"):
        assert parallel[key] == pytest.approx(serial[key], rel=PARITY_RTOL), key


@pytest.mark.mpi
@pytest.mark.parametrize("ends", ["closed", "free-free"])
def test_rod_load_is_the_derivative_of_the_rod_energy(ends):
    """The assembled load ∫G·v + H·Dt[u](v) (t = u′/|u′|) against central differences of ρTP[u].

    A closed saddle and an open rod bent into a helix arc, on 1 and 2 ranks (the neighbours of
    a closed rod wrap around).
    """
    import dolfinx.fem
    import dolfinx.fem.petsc

    from dgplate.dg.self_avoidance import CurveSelfAvoidance, CurveTangentPoint
    from dgplate.models.rod.energy import rod_mesh
    from dgplate.models.rod.spec import RodSpec
    from dgplate.models.rod.start import closed_start
    from dgplate.solvers.rod_flow import tangent

    comm = MPI.COMM_WORLD
    spec = RodSpec(ends=ends, cells=24, length=4.0)
    mesh = rod_mesh(spec, comm).mesh
    V = dolfinx.fem.functionspace(mesh, ("P", 2, (3,)))
    u = dolfinx.fem.Function(V)
    if ends == "closed":
        u.interpolate(closed_start(4.0, 0.0, 0.3)[0])
    else:
        u.interpolate(lambda x: np.vstack([np.cos(2 * x[0]), np.sin(2 * x[0]), 0.2 * x[0]]))
    term = CurveTangentPoint(u, CurveSelfAvoidance(rho=2.0), tangent)
    direction = dolfinx.fem.Function(V)
    direction.interpolate(lambda x: np.vstack([np.sin(3 * x[0]), x[0] * x[1], np.cos(2 * x[0])]))
    check_load_is_derivative(term, u, direction, comm)


def test_the_twisted_circle_problem_file_starts_the_published_experiment(tmp_path):
    """demos/problems/rod_twisted_circle.toml: 20 steps of τ = h = 1/50 lower the energy."""
    problem = dgplate.load_problem(
        PROBLEMS / "rod_twisted_circle.toml", overrides={**QUIET, "flow.max_steps": 20}
    )
    result = dgplate.run(problem, out=tmp_path / "out", comm=MPI.COMM_SELF)
    assert result["tau"] == pytest.approx(1 / 50) and result["energy_increases"] == []
    assert result["twist_angle"] / (2 * math.pi) == pytest.approx(4.665, abs=1e-3)  # P₁ frame
    assert all(row["min_distance"] > 0.028 for row in result.history)


PROBLEMS = Path(__file__).resolve().parents[2] / "demos" / "problems"
TREFOIL, CLOSED = PROBLEMS / "rod_trefoil.toml", PROBLEMS / "rod_closed.toml"


def test_a_warm_start_continues_the_flow_exactly(tmp_path):
    """20 steps of the trefoil = 10 steps, then 10 from RodStart (u and b) of the first run."""
    quiet = {"output.progress": 0, "output.vtx": False, "output.png": False, "flow.tol": 1e-12}

    def steps(n, name, initial=None):
        problem = dgplate.load_problem(TREFOIL, overrides={**quiet, "flow.max_steps": n})
        return dgplate.run(problem, out=tmp_path / name, comm=MPI.COMM_SELF, initial=initial)

    whole, first = steps(20, "whole"), steps(10, "first")
    second = steps(10, "second", RodStart(first.fields))
    assert second["energy"] == pytest.approx(whole["energy"], rel=1e-10)
    assert second["min_distance"] == pytest.approx(whole["min_distance"], rel=1e-10)
    assert whole["energy_increases"] == [] and whole["min_distance"] > 0


def test_a_circle_formula_starts_as_the_circle(tmp_path):
    """model.curve = the unit circle gives the closed rod's own start (the same energy)."""
    quiet = {"output.progress": 0, "output.vtx": False, "output.png": False}
    energies = []
    for extra in ({}, {"model.curve": ["2*cos(t)", "2*sin(t)", "0"]}):
        problem = dgplate.load_problem(
            CLOSED, overrides={**quiet, "flow.max_steps": 1, "model.cells": 16, **extra}
        )
        energies.append(dgplate.run(problem, out=tmp_path / str(len(energies)))["energy"])
    assert energies[1] == pytest.approx(energies[0], rel=1e-6)
