"""The tangent-point potential (docs/self_avoidance.md): pair sums, tree, derivatives, flow."""

import importlib.util
import itertools
import math
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import pytest
from helpers import PARITY_RTOL, check_load_is_derivative, check_pair_sum_derivatives

import dgplate
from dgplate.dg import tangent_point as tp
from dgplate.dg import tp_kernel
from dgplate.dg.self_avoidance import PlateTangentPoint, SelfAvoidance


def _benchmark():
    """benchmarks/tangent_point.py, whose rolled strip the accuracy tests share."""
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "tangent_point.py"
    spec = importlib.util.spec_from_file_location("bench_tangent_point", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


spiral = _benchmark().spiral


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def test_tree_matches_exact_sum_at_theta_half():
    """2000 points on a spiral: TP and its derivatives within 1e-3 of the all-pairs sums."""
    cloud, h = spiral(100, 20)
    exact = tp.evaluate(cloud, 4.5, theta=0.0)
    tree = tp.evaluate(cloud, 4.5, theta=0.5, reach=3 * h)
    assert tree.pairs_far > 0 and tree.pairs_exact < exact.pairs_exact / 2
    assert abs(tree.energy - exact.energy) <= 1e-3 * exact.energy
    assert relative(tree.d_points, exact.d_points) <= 1e-3
    assert relative(tree.d_normals, exact.d_normals) <= 1e-3


def test_pair_sum_is_the_formula_and_skips_neighbours():
    """Two points of cells without a common vertex: (2^-q/q) w_i w_j (r_ij^-q + r_ji^-q)."""
    x = np.array([[0.0, 0.0, 0.0], [0.3, 0.1, 0.5]])
    nu = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    w = np.array([0.2, 0.7])
    q = 5.0
    apart = tp.evaluate(tp.Cloud(x, nu, w, np.array([[0, 1], [2, 3]])), q, theta=0.0)
    d = x[1] - x[0]
    r = [d @ d / (2 * abs(nu[k] @ d)) for k in (0, 1)]
    assert math.isclose(apart.energy, 2**-q / q * w[0] * w[1] * sum(ri**-q for ri in r))
    touching = tp.evaluate(tp.Cloud(x, nu, w, np.array([[0, 1], [1, 3]])), q, theta=0.0)
    assert touching.energy == 0.0


def test_derivatives_by_finite_differences():
    """∂TP/∂x and ∂TP/∂ν of the exact sums against central differences."""
    check_pair_sum_derivatives(spiral(12, 3)[0], 4.5, seed=1)


def test_min_distance_is_the_brute_force_minimum():
    cloud, h = spiral(60, 6)
    i, j = np.triu_indices(len(cloud.points), 1)
    shared = (cloud.vertices[i][:, :, None] == cloud.vertices[j][:, None, :]).any(axis=(1, 2))
    brute = np.linalg.norm(cloud.points[i] - cloud.points[j], axis=1)[~shared].min()
    assert math.isclose(tp.min_distance(cloud, h), brute)
    assert math.isclose(tp.min_distance(cloud, 1e-3 * h), brute)


def rolled(x: np.ndarray) -> np.ndarray:
    """A square of side 1 bent over a cylinder of radius 0.4 (a curved, non-touching start)."""
    return np.vstack([0.4 * np.sin(x[0] / 0.4), x[1], 0.4 * (1 - np.cos(x[0] / 0.4))])


@pytest.mark.mpi
def test_plate_load_is_the_derivative_of_the_plate_energy(comm):
    """The assembled load ∫G·v + H·Dν[y](v) against central differences of ρ·TP[y]."""
    mesh = dolfinx.mesh.create_unit_square(comm, 6, 3, dolfinx.mesh.CellType.triangle)
    V = dolfinx.fem.functionspace(mesh, ("DG", 2, (3,)))
    y = dolfinx.fem.Function(V)
    y.interpolate(rolled)
    params = SelfAvoidance(rho=2.0, theta=0.0)
    term = PlateTangentPoint(y, params)
    direction = dolfinx.fem.Function(V)
    direction.interpolate(lambda x: np.vstack([np.sin(3 * x[1]), x[0] * x[1], np.cos(2 * x[0])]))
    check_load_is_derivative(term, y, direction, comm)


def strip_problem(**self_avoidance: float) -> dict:
    return {
        "mesh": {"type": "rectangle", "corners": [[0, 0], [8.0, 1.0]], "cells": [16, 2]},
        "model": {
            "name": "bilayer",
            "clamped": ["left"],
            "Z": 1.0,
            "penalty": {"gamma0": 5000.0, "gamma1": 86.0, "gradient_power": 3},
            "self_avoidance": {"rho": 1e-4, **self_avoidance},
        },
        "flow": {
            "tau": 0.1,
            "max_steps": 6,
            "multiplier_degree": 1,
            "projection_steps": 2,
            "linear_solver": "direct",
        },
        "output": {"vtx": False, "png": False, "progress": 0},
    }


BAD = {
    "rho negative": ({"rho": -1.0}, r"model\.self_avoidance\.rho must be >= 0"),
    "q too small": ({"q": 2.0}, r"model\.self_avoidance\.q must be > 2"),
    "unknown key": ({"p": 2.0}, r"unknown key model\.self_avoidance\.p \(known keys: "),
    "theta text": ({"theta": "fast"}, r"model\.self_avoidance\.theta must be float, got 'fast'"),
    "approach": ({"approach": 1.5}, r"model\.self_avoidance\.approach must be in"),
}  # fmt: skip


@pytest.mark.parametrize("table, message", BAD.values(), ids=BAD.keys())
def test_bad_self_avoidance_is_one_line_naming_the_key(table, message):
    with pytest.raises(dgplate.InputError, match=message):
        dgplate.problem_from_dict(strip_problem(**table), "bad")


def test_q_at_most_four_warns_that_it_is_not_self_avoiding(tmp_path):
    """A dgplate warning line before the run (not a Python warning at validation)."""
    report = dgplate.check(dgplate.problem_from_dict(strip_problem(q=4.0), "weak"), tmp_path / "o")
    assert any("model.self_avoidance.q = 4 <= 4" in w for w in report["warnings"])
    report = dgplate.check(dgplate.problem_from_dict(strip_problem(), "strong"), tmp_path / "o")
    assert not any("self_avoidance" in w for w in report["warnings"])


def test_a_self_intersecting_start_is_refused(tmp_path):
    """The strip folded flat onto itself at x₁ = 4: the two halves' points coincide."""
    problem = dgplate.problem_from_dict(strip_problem(), "folded")
    with pytest.raises(dgplate.InputError, match="initial state intersects itself"):
        dgplate.run(
            problem,
            out=tmp_path / "out",
            initial=lambda x: np.vstack([4 - abs(x[0] - 4), x[1], 0 * x[0]]),
        )


@pytest.mark.mpi
def test_short_run_decreases_energy_and_ranks_agree(tmp_path, comm):
    """A few steps of the rolling strip: E_h + ρTP decreases, min distance > 0, parity."""
    problem = dgplate.problem_from_dict(strip_problem(), "strip")
    out = comm.bcast(tmp_path / "out" if comm.rank == 0 else None)
    shared = dgplate.run(problem, out=out, comm=comm)
    assert shared["energy_increases"] == [] and shared["min_distance"] > 0
    assert all(row["min_distance"] > 0 for row in shared.history)
    if comm.size > 1:
        single = dgplate.run(problem, out=tmp_path / f"single{comm.rank}", comm=MPI.COMM_SELF)
        for key in ("energy", "self_avoidance_energy", "min_distance"):
            assert math.isclose(shared[key], single[key], rel_tol=PARITY_RTOL), key


def test_the_safety_net_redoes_steps_that_approach_too_fast(tmp_path):
    """The demo's strip with τ = 1 and approach = 0.97: the first steps close the gap by ~8 %,
    so they are redone with τ/2 (recorded in history.csv), and the energy still decreases."""
    problem = dgplate.load_problem(
        Path(__file__).resolve().parents[2] / "demos" / "problems" / "self_avoiding_strip.toml",
        {"flow.tau": 1.0, "flow.max_steps": 3, "model.self_avoidance.approach": 0.97,
         "output.png": False, "output.vtx": False, "output.progress": 0},
    )  # fmt: skip
    result = dgplate.run(problem, out=tmp_path / "out")  # from the file's arc (model.start)
    first = result.history[0]
    assert first["redone"] >= 1 and first["tau"] == 1.0 / 2 ** first["redone"]
    assert result["energy_increases"] == []
    distances = [row["min_distance"] for row in result.history]
    assert all(b > 0.97 * a for a, b in itertools.pairwise(distances))


@pytest.mark.parametrize("half", [False, True])
def test_exact_sums_report_the_least_distance(half):
    """With θ = 0 the sums meet every pair: their least distance is min_distance's."""
    cloud, h = spiral(60, 6)
    targets = np.arange(len(cloud.points)) % 2 == 0 if half else None
    result = tp.evaluate(cloud, 4.5, theta=0.0, reach=3 * h, targets=targets)
    assert math.isclose(result.min_distance, tp.min_distance(cloud, h, targets))


@pytest.mark.parametrize("curve", [False, True])
def test_exact_sums_do_not_depend_on_leaf_or_block_size(curve, monkeypatch):
    """The dense blocks (centred coordinates, batched products) give the same sums for any tiling.

    Leaves of 4 and 64 points and blocks of 2^8 or 2^17 pairs cut the same pairs differently;
    the least distance and the pair count are the same, TP and its derivatives to round-off.
    """
    cloud, h = spiral(40, 8)
    if curve:  # the same points with the normals read as tangents
        cloud = tp.Cloud(cloud.points, cloud.normals, cloud.weights, cloud.vertices, True)
    results = []
    for leaf, block in ((64, 1 << 17), (4, 1 << 8)):
        monkeypatch.setattr(tp_kernel, "BLOCK", block)
        results.append(tp.evaluate(cloud, 4.5, theta=0.0, reach=3 * h, leaf=leaf))
    a, b = results
    assert a.pairs_exact == b.pairs_exact and a.min_distance == pytest.approx(b.min_distance)
    assert b.energy == pytest.approx(a.energy, rel=1e-12)
    assert relative(b.d_points, a.d_points) < 1e-12
    assert relative(b.d_normals, a.d_normals) < 1e-12


@pytest.mark.parametrize("q", [2.5, 3.0, 4.5, 5.0, 4.3])
def test_power_by_products_is_pow(q):
    """x**q by products and one square root (half-integer q), ``pow`` otherwise."""
    x = np.linspace(0.0, 3.0, 31)
    assert np.allclose(tp_kernel._power(x, q), x**q, rtol=1e-14, atol=0)
