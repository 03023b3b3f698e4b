"""Prestrained plates: the constraint ∇yᵀ∇y = G of ``model.metric`` (docs/prestrain.md).

The metric-weighted Hessian, the closed form of the spherical cap, the cap computed from the
flat plate (metric start, then the flow) at two mesh levels, and the isometric limit: G = I
given explicitly is the run without a metric.
"""

import json
import math
import os
import signal
import subprocess
import sys

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest
import ufl
from helpers import PROBLEMS, QUIET, ROOT, mpirun

from dgplate import expressions, interrupt, load_problem, run
from dgplate.dg.forms import hessian, metric_weighted
from dgplate.dg.geometry import metric_gauss_curvature, trace_excess
from dgplate.errors import InputError
from dgplate.io.vtx import bp_variables
from dgplate.measure.analysis import fit_sphere
from dgplate.measure.fields import cell_field, defect_density
from dgplate.measure.prestrain import edge_waves, gauss_curvature_figures
from dgplate.mesh.tagged import rectangle
from dgplate.models.metric import MetricSpec, target_metric
from dgplate.reference import spherical_cap
from dgplate.solvers import metric_start

SPHERICAL = PROBLEMS / "spherical_disc.toml"
VERTICAL = PROBLEMS / "vertical_load.toml"


def test_metric_weighted_hessian_is_the_norm_of_g_inverse_sqrt_hessian():
    """D²y : 𝒞D²y = Σ_k |G^{-1/2}D²y_k G^{-1/2}|² for a constant SPD G and a quadratic y."""
    mesh = rectangle(MPI.COMM_WORLD, [[0, 0], [2, 1]], [2, 2]).mesh
    x = ufl.SpatialCoordinate(mesh)
    H = np.array([[[1.0, 0.3], [0.3, -2.0]], [[0.5, 0.0], [0.0, 0.7]], [[-1.0, 2.0], [2.0, 4.0]]])
    y = ufl.as_vector([0.5 * ufl.dot(x, ufl.dot(ufl.as_matrix(h.tolist()), x)) for h in H])
    G = np.array([[2.0, 0.5], [0.5, 1.0]])
    D2 = hessian(y)
    form = dolfinx.fem.form(ufl.inner(D2, metric_weighted(D2, ufl.as_matrix(G.tolist()))) * ufl.dx)
    value = mesh.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM)
    w, V = np.linalg.eigh(G)
    A = V @ np.diag(w**-0.5) @ V.T  # G^{-1/2}
    expected = 2.0 * sum(np.sum((A @ h @ A) ** 2) for h in H)
    assert value == pytest.approx(expected, rel=1e-13)


def test_trace_excess_is_the_caps_trace_density_less_its_energy_density():
    """F(G) = Σₖ tr(AD²yₖA)² − Σₖ|AD²yₖA|² of the sphere's G: the cap's two densities' difference.

    Integrated over a square off the centre (UFL's F from G's derivatives against the cap's
    closed forms by Gauss–Legendre): equal to 1e-12 (measured 3e-17).
    """
    tagged = rectangle(MPI.COMM_WORLD, [[0.1, 0.2], [0.6, 0.7]], [4, 4])
    metric = target_metric(MetricSpec(**spherical_cap.metric_formulas(2.0)), tagged.mesh)
    form = dolfinx.fem.form(trace_excess(metric) * ufl.dx(metadata={"quadrature_degree": 12}))
    value = tagged.mesh.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM)
    points, weights = np.polynomial.legendre.leggauss(30)
    xs, ys, w = 0.1 + 0.25 * (points + 1), 0.2 + 0.25 * (points + 1), 0.25 * weights
    r = np.hypot(*np.meshgrid(xs, ys, indexing="ij"))
    excess = spherical_cap.trace_density(r, 2.0) - spherical_cap.energy_density(r, 2.0)
    assert value == pytest.approx(np.einsum("i,j,ij", w, w, excess), abs=1e-12)


def test_poisson_without_a_metric_is_the_rigidity_scaled_by_one_over_one_minus_nu(tmp_path):
    """G = I: tr(II)² = |II|² on isometries, so ν scales μ by 1/(1 − ν), to round-off."""
    cantilever = PROBLEMS / "cantilever.toml"
    small = {"mesh.cells": [8, 2], **QUIET}
    nu = run(load_problem(cantilever, {**small, "model.poisson": 0.3}), out=tmp_path / "nu")
    mu = run(load_problem(cantilever, {**small, "model.mu": 1 / 0.7}), out=tmp_path / "mu")
    assert nu["steps"] == mu["steps"]
    assert nu["energy"] == pytest.approx(mu["energy"], rel=1e-12)


def test_spherical_cap_trace_density_is_the_trace_of_the_caps_hessian():
    """Σ_k (G⁻¹ : D²y_k)² by central differences of the cap agrees with the closed form."""
    R, r, eps = 2.0, 0.6, 1e-4
    formulas = spherical_cap.metric_formulas(R)
    p = np.array([r, 0.0])
    G = np.array(
        [
            [expressions.evaluate(formulas["g11"], p[None, :], "g11")[0], 0.0],
            [0.0, expressions.evaluate(formulas["g22"], p[None, :], "g22")[0]],
        ]
    )
    e = np.eye(2)

    def y(q):
        return spherical_cap.cap(q[:, None], R)[:, 0]

    hessians = np.empty((3, 2, 2))
    for i in range(2):
        for j in range(2):
            hessians[:, i, j] = (
                y(p + eps * (e[i] + e[j]))
                - y(p + eps * (e[i] - e[j]))
                - y(p - eps * (e[i] - e[j]))
                + y(p - eps * (e[i] + e[j]))
            ) / (4 * eps**2)
    inverse = np.linalg.inv(G)
    expected = sum(np.sum(inverse * h) ** 2 for h in hessians)
    assert spherical_cap.trace_density(np.array([r]), R)[0] == pytest.approx(expected, rel=1e-6)
    assert spherical_cap.trace_density(np.array([1e-4]), R)[0] == pytest.approx(1.0, rel=1e-7)


def test_spherical_cap_metric_formulas_are_the_caps_metric():
    """The formulas of G are ∇yᵀ∇y of the cap (central differences), at r = 0 too."""
    R = 2.0
    formulas = spherical_cap.metric_formulas(R)
    rng = np.random.default_rng(1)
    points = np.vstack([[0.0, 0.0], [0.25, 0.0], [0.2499, 1e-4], rng.uniform(-0.7, 0.7, (20, 2))])
    G = {k: expressions.evaluate(v, points, k) for k, v in formulas.items()}
    eps = 1e-6
    for i, p in enumerate(points):
        columns = [
            (
                spherical_cap.cap((p + eps * e)[:, None], R)
                - spherical_cap.cap((p - eps * e)[:, None], R)
            )
            / (2 * eps)
            for e in np.eye(2)
        ]
        J = np.hstack(columns)
        metric = J.T @ J
        assert metric[0, 0] == pytest.approx(G["g11"][i], abs=1e-9)
        assert metric[0, 1] == pytest.approx(G["g12"][i], abs=1e-9)
        assert metric[1, 1] == pytest.approx(G["g22"][i], abs=1e-9)


def test_hyperbolic_metric_formulas_are_the_geodesic_polar_metric():
    """G of the hyperbolic plane (K = −1/R²): n⊗n + a²(I − n⊗n) with a = R sinh(r/R)/r, at
    r = 0 and on both sides of the switch to the Taylor series, and det G = a² > 1 off r = 0."""
    R = 1.0
    formulas = spherical_cap.geodesic_polar_formulas(R, -1)
    rng = np.random.default_rng(2)
    points = np.vstack([[1e-9, 0.0], [0.125, 0.0], [0.1249, 1e-4], rng.uniform(-0.7, 0.7, (20, 2))])
    G = {k: expressions.evaluate(v, points, k) for k, v in formulas.items()}
    r = np.hypot(points[:, 0], points[:, 1])
    n = points / r[:, None]
    a2 = (R * np.sinh(r / R) / r) ** 2
    expected = n[:, :, None] * n[:, None, :] * (1 - a2)[:, None, None] + a2[:, None, None] * np.eye(
        2
    )
    assert np.allclose(G["g11"], expected[:, 0, 0], rtol=0, atol=1e-14)
    assert np.allclose(G["g12"], expected[:, 0, 1], rtol=0, atol=1e-14)
    assert np.allclose(G["g22"], expected[:, 1, 1], rtol=0, atol=1e-14)
    assert spherical_cap.geodesic_polar_formulas(2.0, 1) == spherical_cap.metric_formulas(2.0)


def test_spherical_cap_energy_closed_form():
    """The density is 2/R² at the centre (Γ = 0 there); E = ½·2π∫ density r dr of the cap."""
    assert spherical_cap.energy_density(np.array([1e-4]), 2.0)[0] == pytest.approx(0.5, rel=1e-7)
    assert spherical_cap.energy(2.0) == pytest.approx(0.8193806398757774, rel=1e-14)
    # the energy of II alone, ½ · 2/R² · π, is less: the Christoffel part is a function of G
    assert spherical_cap.energy(2.0) > 0.5 * 2 / 4 * math.pi


def spherical_run(h, tmp_path):
    problem = load_problem(SPHERICAL, {"mesh.parameters.h": h, **QUIET})
    return run(problem, out=tmp_path / f"h{h}")


def test_spherical_cap_from_the_flat_disc(tmp_path):
    """The disc under the sphere's metric becomes the cap: radius, energy and K_h converge.

    The file's Gauss-curvature penalty β = 10. Measured (h = 0.2, 0.1: 256 and 736 cells):
    radius 2.00127, 2.00028 (errors 6.4e-4, 1.4e-4); E_h 0.92652, 0.84896 against 0.81938
    (+13.1 %, +3.6 %, from above like the interpolated cap's); the metric start takes 7
    stretching steps and 4 projections to D_h ~ 1e-14. K of G is 1/4 to 1e-14; mean K_h
    0.2449, 0.2474, the largest |K_h − K| 0.019, 0.014. Without the penalty the cells along the
    free edge flatten: largest |K_h − K| 0.046, 0.094, radius errors 1.0e-3, 3.8e-4.
    """
    exact = spherical_cap.energy(2.0)
    radius_errors, energy_errors = [], []
    for h in (0.2, 0.1):
        result = spherical_run(h, tmp_path)
        assert result["converged"]
        start = result["metric_start"]
        assert start["defect"] <= 1e-10 and start["stretching_steps"] >= 1
        assert result["isometry_defect"] <= 1e-10
        fit = fit_sphere(result.shape)
        assert fit["rms"] < 2e-4
        radius_errors.append(abs(fit["radius"] - 2.0) / 2.0)
        gauss = result["metric_gauss_curvature"]
        assert gauss["target_min"] == pytest.approx(0.25, abs=1e-12)
        assert gauss["target_max"] == pytest.approx(0.25, abs=1e-12)
        assert gauss["mean"] == pytest.approx(0.25, abs=0.01) and gauss["error_max"] < 0.025
        energy_errors.append((result["energy"] - exact) / exact)
    assert radius_errors[0] < 8e-4 and radius_errors[1] < 2e-4
    assert 0 < energy_errors[1] < 0.04 and energy_errors[0] < 0.14
    assert radius_errors[1] < radius_errors[0] / 3 and energy_errors[1] < energy_errors[0] / 3


def test_hyperbolic_disc_becomes_a_saddle(tmp_path):
    """demos/problems/hyperbolic_disc.toml (K = −1, h = 0.2): a saddle, K_h near −1.

    Measured: 5 projections of the saddle start, 16 flow steps, D_h 3e-15; K of G −1 to 1e-14;
    mean K_h −0.9696 (error_mean 0.048); two waves along the edge (amplitude 0.49, the next
    mode 4e-4).
    """
    result = run(load_problem(PROBLEMS / "hyperbolic_disc.toml", QUIET), out=tmp_path)
    assert result["converged"] and result["isometry_defect"] <= 1e-10
    assert result["metric_start"]["defect"] <= 1e-10
    gauss = result["metric_gauss_curvature"]
    assert gauss["target_min"] == pytest.approx(-1.0, abs=1e-12)
    assert gauss["target_max"] == pytest.approx(-1.0, abs=1e-12)
    assert gauss["mean"] == pytest.approx(-1.0, abs=0.05)
    waves = edge_waves(result.shape)
    assert waves["waves"] == 2 and waves["amplitudes"][1] > 0.3


def test_the_trace_term_keeps_the_cap_and_converges_to_its_energy(tmp_path):
    """``model.poisson = 0.3``: the cap with c = ν/(1 − ν) is still the minimiser (umbilic).

    Measured (β = 10; h = 0.2, 0.1): E_h 1.65045, 1.54224 against 1.50236 (+9.9 %, +2.7 %;
    +0.43 % at h = 0.05), radius errors 7.0e-4, 1.6e-4; the penalty's value, part of E_h,
    reported on its own and smaller on the finer mesh.
    """
    exact = spherical_cap.energy(2.0, poisson=0.3)
    # the trace part ½∫Σ_k(G⁻¹:D²y_k)² is at least ½∫tr(G⁻¹II)² = ½·(2/R)²·π (the Christoffel
    # part adds a square): 1.59362 against π/2
    trace_part = (exact - spherical_cap.energy(2.0)) / (0.3 / 0.7)
    assert math.pi / 2 < trace_part < 1.05 * math.pi / 2
    energy_errors, radius_errors, penalties = [], [], []
    for h in (0.2, 0.1):
        problem = load_problem(SPHERICAL, {"mesh.parameters.h": h, "model.poisson": 0.3, **QUIET})
        result = run(problem, out=tmp_path / f"h{h}")
        assert result["converged"] and result["isometry_defect"] <= 1e-10
        energy_errors.append((result["energy"] - exact) / exact)
        radius_errors.append(abs(fit_sphere(result.shape)["radius"] - 2.0) / 2.0)
        penalties.append(result["gauss_penalty_energy"])
        assert 0 < result["gauss_penalty_energy"] < result["energy"] - exact
    assert 0 < energy_errors[1] < 0.035 and energy_errors[0] < 0.12
    assert energy_errors[1] < energy_errors[0] / 3 and radius_errors[1] < radius_errors[0] / 3
    assert radius_errors[1] < 3e-4 and penalties[1] < penalties[0]


STRIP = PROBLEMS / "straight_fold.toml"  # straight_crease.geo: side_left | side_right, x ∈ (−1, 1)
#: a free strip whose left half wants to be 1.2 times as long along x: G = diag(1.44, 1) there
GROUPED = {
    "model.clamped": [],
    "model.boundary_data": "flat",
    "model.metric": {"g11": {"side_left": 1.44}},
    "mesh.parameters.quads": 1,
    **QUIET,
}


def test_a_metric_per_cell_group_is_met_with_a_crease_at_its_jump(tmp_path):
    """G = diag(1.44, 1) on the left half, I on the right: flat halves of lengths 1.2 and 1.

    The exact surface is flat with an in-plane kink along the interface x = 0 (t·Gt agrees
    across it), E = 0. With the interface a crease, E_h ~ 1e-24 and the bottom edge's halves
    have the lengths of G to 1e-6 (measured: the two halves meet at a small angle where the
    metric start's bump left them, as a crease lets them).
    """
    problem = load_problem(STRIP, GROUPED)
    result = run(problem, out=tmp_path / "run")
    assert result["converged"] and result["isometry_defect"] <= 1e-10
    assert abs(result["energy"]) < 1e-18
    y = result.shape
    points = y.function_space.tabulate_dof_coordinates()[:, :2]
    values = y.x.array.reshape(-1, 3)

    def at(x):
        i = np.flatnonzero(np.hypot(points[:, 0] - x, points[:, 1]) < 1e-12)
        return values[i].mean(axis=0)

    assert np.linalg.norm(at(0.0) - at(-1.0)) == pytest.approx(1.2, abs=1e-6)
    assert np.linalg.norm(at(1.0) - at(0.0)) == pytest.approx(1.0, abs=1e-6)


def test_the_largest_jump_leaves_out_the_nodes_of_creases():
    """G = diag(1.44, 1) | I jumps by 0.44 at the interface nodes, by nothing off the crease."""
    from dgplate.models.metric import largest_jump
    from dgplate.problems.prepare import build_mesh

    problem = load_problem(STRIP, GROUPED)
    tagged = build_mesh(problem.mesh, MPI.COMM_WORLD)
    spec = MetricSpec(g11={"side_left": 1.44})
    jump, where = largest_jump(spec, tagged.mesh, tagged)
    assert jump == pytest.approx(0.44, abs=1e-12) and abs(where[0]) < 1e-12
    assert largest_jump(spec, tagged.mesh, tagged, ["crease"])[0] == 0.0


def test_a_metric_that_jumps_without_a_crease_is_warned_about(tmp_path, capsys):
    """Without the crease the kink costs gradient-jump energy (E_h 0.40, 1.53 at h = 0.25,
    0.125, quads): a warning names the jump; none with the crease or a continuous table."""
    advice_line = "model.metric: G jumps between cell groups (by 0.44"
    no_crease = load_problem(STRIP, {**GROUPED, "model.crease": [], "flow.max_steps": 1})
    run(no_crease, out=tmp_path / "a")
    assert advice_line in capsys.readouterr().err
    run(load_problem(STRIP, {**GROUPED, "flow.max_steps": 1}), out=tmp_path / "b")
    continuous = {**GROUPED, "model.crease": [], "model.metric": {"g11": {"side_left": 1.0}}}
    run(load_problem(STRIP, {**continuous, "flow.max_steps": 1}), out=tmp_path / "c")
    assert "G jumps" not in capsys.readouterr().err


def test_the_metric_start_says_its_line_in_the_progress_output(tmp_path, capsys):
    """The progress printer (a :class:`Narrator` observer) prints the metric start's line."""
    settings = {"mesh.cells": [2, 2], "flow.max_steps": 1, "model.metric": {"g11": 1.0}}
    run(load_problem(VERTICAL, settings), out=tmp_path / "run")
    assert "metric start: 0 stretching steps" in capsys.readouterr().out


def test_a_constant_metric_gives_a_flat_plate(tmp_path):
    """A constant G: the minimiser is the flat affine map with ∇yᵀ∇y = G, E = 0 and K = 0.

    Measured (h = 0.2): 12 stretching steps reach the flat map (stretching 1e-27), one flow
    step, E_h 4e-23, K_h ~ 1e-28.
    """
    metric = {"g11": 1.3, "g12": 0.2, "g22": 0.8}
    overrides = {**QUIET, "model.metric": metric, "output.vtx": True}
    result = run(load_problem(SPHERICAL, overrides), out=tmp_path)
    cells = bp_variables(tmp_path / "deformation_gauss_curvature.bp")
    assert cells == {"gauss_curvature", "target_gauss_curvature"}  # K_h and K of G per cell
    assert result["converged"] and result["isometry_defect"] <= 1e-10
    assert abs(result["energy"]) < 1e-12
    gauss = result["metric_gauss_curvature"]
    assert gauss["target_min"] == gauss["target_max"] == 0.0
    assert gauss["error_max"] < 1e-10
    points = result.shape.x.array.reshape(-1, 3)
    spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    assert spread[2] / np.sqrt(len(points)) < 1e-9  # in a plane (rms distance)


def test_identity_metric_is_the_isometric_run(tmp_path):
    """``model.metric = {g11 = 1, g12 = 0, g22 = 1}``: E_h and y of the run without one."""
    base = {"mesh.cells": [4, 4], **QUIET}
    plain = run(load_problem(VERTICAL, base), out=tmp_path / "plain")
    identity = {"model.metric": {"g11": 1.0, "g12": 0.0, "g22": 1.0}}
    weighted = run(load_problem(VERTICAL, {**base, **identity}), out=tmp_path / "metric")
    assert weighted["metric_start"]["stretching_steps"] == 0  # the flat plate is admissible
    assert weighted["steps"] == plain["steps"]
    assert weighted["energy"] == pytest.approx(plain["energy"], abs=1e-10)
    assert weighted["isometry_defect"] == pytest.approx(plain["isometry_defect"], abs=1e-10)
    difference = np.abs(weighted.shape.x.array - plain.shape.x.array).max()
    assert difference < 1e-10


@pytest.mark.spawns_mpirun
@pytest.mark.skipif(mpirun() is None, reason="no mpirun")
def test_spherical_cap_on_two_ranks_is_the_serial_run(tmp_path):
    """``mpirun -n 2 dgplate run``: the metric start and the flow give the serial figures."""
    serial = spherical_run(0.2, tmp_path)
    out = tmp_path / "two"
    sets = [
        arg
        for key in ("output.progress=0", "output.vtx=false", "output.png=false")
        for arg in ("--set", key)
    ]
    args = [mpirun(), "-n", "2", sys.executable, "-m", "mpi4py", "-m", "dgplate", "run"]
    paths = [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}
    proc = subprocess.run(
        [*args, str(SPHERICAL), "--out", str(out), *sets],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr
    parallel = json.loads((out / "summary.json").read_text())
    assert parallel["ranks"] == 2 and parallel["steps"] == serial["steps"]
    assert (
        parallel["metric_start"]["stretching_steps"] == serial["metric_start"]["stretching_steps"]
    )
    assert (
        parallel["metric_start"]["projection_steps"] == serial["metric_start"]["projection_steps"]
    )
    assert parallel["energy"] == pytest.approx(serial["energy"], abs=1e-10)
    gauss, serial_gauss = parallel["metric_gauss_curvature"], serial["metric_gauss_curvature"]
    for name in ("target_mean", "mean", "error_mean", "error_max"):
        assert gauss[name] == pytest.approx(serial_gauss[name], abs=1e-8)
    assert parallel["isometry_defect"] <= 1e-10


def test_a_resumed_run_keeps_its_metric_start(tmp_path):
    """--resume continues from the checkpoint: no second metric start, its figures kept."""
    out = tmp_path / "run"
    problem = load_problem(SPHERICAL, {**QUIET, "flow.max_steps": 3})
    first = run(problem, out=out)
    assert not first["converged"] and first["steps"] == 3
    resumed = run(load_problem(SPHERICAL, QUIET), out=out, resume=True)
    assert resumed["converged"] and resumed["steps"] == 6
    assert resumed["metric_start"] == first["metric_start"]
    assert resumed["energy"] == pytest.approx(0.92652107375472, abs=1e-10)


def test_a_failed_metric_start_ends_the_run_with_a_summary(tmp_path, monkeypatch, capsys):
    """No projection allowed: the run ends unconverged with the reason, and prints nothing."""
    monkeypatch.setattr(metric_start, "STRETCH_STEPS", 1)
    monkeypatch.setattr(metric_start, "PROJECTION_STEPS", 0)
    out = tmp_path / "run"
    result = run(load_problem(SPHERICAL, QUIET), out=out)
    assert not result["converged"] and result["steps"] == 0
    assert result["reason"].startswith("metric start failed: the metric start left D_h = ")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reason"] == result["reason"]
    assert "metric start: " not in capsys.readouterr().out  # output.progress = 0: no line


def test_a_signal_stops_the_metric_start(tmp_path, monkeypatch):
    """A SIGTERM before the first Gauss–Newton step: the run ends interrupted, with a summary."""
    monkeypatch.setattr(interrupt, "requested", lambda comm: int(signal.SIGTERM))
    out = tmp_path / "run"
    result = run(load_problem(SPHERICAL, QUIET), out=out)
    assert result["reason"] == "interrupted (SIGTERM)" and result["steps"] == 0
    assert json.loads((out / "summary.json").read_text())["reason"] == "interrupted (SIGTERM)"


def test_a_given_start_is_projected_onto_the_metric(tmp_path, capsys):
    """``initial`` = the interpolated cap: no stretching, projections until D_h ≤ 1e-10."""
    problem = load_problem(SPHERICAL, {**QUIET, "flow.max_steps": 1, "output.progress": 1})
    result = run(problem, out=tmp_path / "run", initial=lambda x: spherical_cap.cap(x, 2.0))
    start = result["metric_start"]
    assert start["stretching_steps"] == 0 and start["projection_steps"] >= 1
    assert start["defect"] <= 1e-10
    assert "metric start: 0 stretching steps" in capsys.readouterr().out  # output.progress = 1


def test_defect_picture_measures_against_the_metric():
    """``color_by = "defect"`` with G: the interpolated cap is near G, far from I."""
    mesh = rectangle(MPI.COMM_WORLD, [[-0.5, -0.5], [0.5, 0.5]], [8, 8]).mesh
    y = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("DG", 2, (3,))))
    y.interpolate(lambda x: spherical_cap.cap(x, 2.0))
    spec = MetricSpec(**spherical_cap.metric_formulas(2.0))
    to_g = defect_density(y, target_metric(spec, mesh))
    to_identity = defect_density(y)
    assert to_g.max() < 1e-6 and to_identity.max() > 0.03  # measured 1.2e-8, 0.0316


def test_a_bad_metric_formula_fails_before_the_mesh():
    """``load_problem`` (no mesh yet) names the entry of a formula that does not parse."""
    with pytest.raises(InputError, match=r"^model\.metric\.g11: "):
        load_problem(SPHERICAL, {"model.metric": {"g11": "x +", "g12": 0.0, "g22": 1.0}})


def test_gauss_curvature_of_the_metric_by_brioschi():
    """K of G: 1/R² for the sphere's metric (r = 0 included), 0 for a constant G, −1 for the
    Poincaré disc's 4|dx|²/(1 − |x|²)², −1/R² for the hyperbolic plane in geodesic polar
    coordinates."""
    mesh = rectangle(MPI.COMM_WORLD, [[-0.7, -0.7], [0.7, 0.7]], [6, 6]).mesh
    sphere = MetricSpec(**spherical_cap.metric_formulas(2.0))
    constant = MetricSpec(g11=1.2, g12=0.1, g22=0.9)
    poincare = MetricSpec(g11="4/(1 - x*x - y*y)**2", g12=0.0, g22="4/(1 - x*x - y*y)**2")
    hyperbolic = MetricSpec(**spherical_cap.geodesic_polar_formulas(2.0, -1))
    for spec, K in ((sphere, 0.25), (constant, 0.0), (poincare, -1.0), (hyperbolic, -0.25)):
        values = cell_field(metric_gauss_curvature(target_metric(spec, mesh)), mesh)
        assert np.abs(values - K).max() < 1e-12


def test_gauss_curvature_of_the_interpolated_cap_converges():
    """K_h of the interpolated cap against K = 1/4 of G: the error falls with an order > 1.8.

    Measured on 4, 8, 16 Q2 cells a side of (−0.7, 0.7)²: error_mean 9.6e-4, 2.4e-4, 6.0e-5
    (order 2.0).
    """
    spec = MetricSpec(**spherical_cap.metric_formulas(2.0))
    errors = []
    for n in (4, 8, 16):
        mesh = rectangle(MPI.COMM_WORLD, [[-0.7, -0.7], [0.7, 0.7]], [n, n]).mesh
        y = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("DG", 2, (3,))))
        y.interpolate(lambda x: spherical_cap.cap(x, 2.0))
        figures = gauss_curvature_figures(y, target_metric(spec, mesh))["metric_gauss_curvature"]
        assert figures["target_mean"] == pytest.approx(0.25, abs=1e-12)
        assert figures["target_min"] == pytest.approx(figures["target_max"], abs=1e-12)
        errors.append(figures["error_mean"])
        assert figures["error_max"] >= figures["error_mean"]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert orders.min() > 1.8, (errors, orders)
