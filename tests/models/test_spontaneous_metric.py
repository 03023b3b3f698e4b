"""Bilayer and LCE plates with a target metric G: ½∫μ|G^{-1/2}(II − Z)G^{-1/2}|² on ∇yᵀ∇y = G.

The uniform stretch G = s²I has closed-form minimisers. If ỹ is an isometry, y = sỹ has
∇yᵀ∇y = s²I and II_y = s II_ỹ, so |G^{-1/2}(II_y − Z)G^{-1/2}|² = s⁻⁴|s II_ỹ − Z|²
= s⁻²|II_ỹ − Z/s|²: the plate with G = s²I and Z is s⁻² times the isometric plate with Z/s,
and its minimisers are s times that plate's. A rectangle clamped on one side with Z = aI
(clamped data scaled by s too) rolls into the cylinder of radius s/a in ỹ, so y is the
cylinder of radius s²/a with E = s⁻²·½(a/s)²|ω| = ½a²|ω|/s⁴.

The discrete problems scale the same way but for the penalties, which are not weighted by G
(docs/prestrain.md): the discrete plate with G = s²I is s⁻² times the isometric discrete
plate with Z/s and the penalties γ₀s⁴, γ₁s⁴, and its flow with τ is that plate's flow with
τ/s⁴ (and the rate test's tol s⁶ tol).
"""

from mpi4py import MPI

import numpy as np
import pytest
from helpers import PARITY_RTOL, PROBLEMS, QUIET

from dgplate import load_problem, run
from dgplate.dg.forms import Penalty
from dgplate.mesh.tagged import rectangle
from dgplate.models.base import BoundaryData
from dgplate.models.bilayer import BilayerSpec, build_bilayer
from dgplate.models.metric import MetricSpec
from dgplate.solvers.flow import FlowSpec

S = 1.2  # the stretch of G = s²I
LENGTH, WIDTH = 2.0, 1.0  # ω = (0, 2) × (0, 1), clamped along x = 0


def stretched(s, t=None):
    """The flat plate stretched: x ↦ (s x₁, t x₂, 0) (t = s by default), ∇yᵀ∇y = diag(s², t²)."""
    t = s if t is None else t
    return lambda x: np.vstack([s * x[0], t * x[1], 0.0 * x[0]])


def roll(comm, n, Z, stretch=None, identity=False, scale=1.0, tau=0.25, tol=1e-6, poisson=0.0):
    """The bilayer on 2n × n Q2 cells, γ₁h⁻³: (result, figures, dofs of y).

    ``stretch`` s or (s, t): G = diag(s², t²) with the clamped data g = (s x₁, t x₂, 0),
    Φ = [diag(s, t); 0] and that start; ``identity``: G = I given; ``scale``: the penalties
    times it.
    """
    tagged = rectangle(comm, [[0, 0], [LENGTH, WIDTH]], [2 * n, n])
    keys: dict = {"penalty": Penalty(5000.0 * scale, 86.0 * scale, 3.0), "poisson": poisson}
    initial = None
    if identity:
        keys["metric"] = MetricSpec(g11=1.0, g12=0.0, g22=1.0)
    if stretch is not None:
        s, t = stretch if isinstance(stretch, tuple) else (stretch, stretch)
        keys["metric"] = MetricSpec(g11=s * s, g12=0.0, g22=t * t)
        Phi = [[s, 0.0], [0.0, t], [0.0, 0.0]]
        keys["boundary_data"] = BoundaryData(g=[f"{s!r}*x", f"{t!r}*y", 0.0], Phi=Phi)
        initial = stretched(s, t)
    model = build_bilayer(BilayerSpec(clamped=["left"], Z=Z, **keys), tagged)
    settings = FlowSpec(
        tau=tau,
        tol=tol,
        max_steps=1000,
        multiplier_degree=1,
        projection_steps=2,
        linear_solver="direct",
    )
    flow = model.driver(settings, (), initial)
    result = flow.run()
    return result, model.figures(flow), flow.y.x.array.copy()


def test_identity_metric_is_the_isometric_bilayer():
    """``model.metric = I`` on the bilayer: E_h and y of the run without one (8 × 4, Z = I).

    Measured: 71 steps both, E_h 0.97281320 to 2e-14, y to 8e-11.
    """
    plain, _, y = roll(MPI.COMM_SELF, 4, 1.0)
    given, _, y_given = roll(MPI.COMM_SELF, 4, 1.0, identity=True)
    assert given.converged and given.steps == plain.steps
    assert given.energy == pytest.approx(plain.energy, abs=1e-10)
    assert np.abs(y_given - y).max() < 1e-10


def test_uniform_stretch_rolls_into_the_scaled_cylinder():
    """G = s²I, Z = I (s = 1.2): the cylinder of radius s² = 1.44, E = ½|ω|/s⁴ = 0.48225.

    Measured (8 × 4, 16 × 8): E_h 0.477228, 0.478264 (−1.04 %, −0.83 %, from below like the
    isometric bilayer's free-edge layer); radius 1.52585, 1.47352 (+5.96 %, +2.33 %).
    """
    exact_radius, exact_energy = S**2, 0.5 * LENGTH * WIDTH / S**4
    errors = []
    for n in (4, 8):
        result, figures, _ = roll(MPI.COMM_SELF, n, 1.0, stretch=S)
        fit = figures["cylinder_fit"]
        assert result.converged and result.defect < 1e-10
        assert figures["metric_gauss_curvature"]["target_max"] == 0.0
        assert abs(fit["axis"][1]) > 0.999  # about an axis parallel to the clamped side
        errors.append((result.energy / exact_energy - 1, fit["radius"] / exact_radius - 1))
    (e_coarse, r_coarse), (e_fine, r_fine) = errors
    assert -0.015 < e_coarse < e_fine < 0 and abs(r_fine) < 0.5 * abs(r_coarse)
    assert 0 < r_fine < 0.03


def test_anisotropic_stretch_rolls_with_the_weighted_curvature():
    """G = AᵀA, A = diag(s, t) (s = 1.1, t = 1.2), Z = I on 8 × 4 cells.

    y = ỹ∘A with ỹ an isometry of Aω has II_y = A II_ỹ A, so |G^{-1/2}(II_y − Z)G^{-1/2}|²
    = |II_ỹ − A⁻¹ZA⁻¹|²: the isometric plate on Aω with Z̃ = diag(1/s², 1/t²) (dx = dx̃/det A).
    With 1/s² > 1/t² its minimiser is the cylinder II_ỹ = s⁻² e₁⊗e₁ (the pointwise bound
    |κ d⊗d − Z̃|² ≥ t⁻⁴), so y is the cylinder of radius s² = 1.21 and E = ½t⁻⁴|ω| = 0.48225.
    Measured: E_h 0.482783 (+0.11 %), radius 1.26434 (+4.5 %); a coupling with G⁻¹Z in place
    of G⁻¹ZG⁻¹ would act as Z̃ = I and roll to the radius 1.
    """
    s, t = 1.1, 1.2
    result, figures, _ = roll(MPI.COMM_SELF, 4, 1.0, stretch=(s, t))
    fit = figures["cylinder_fit"]
    print(f"\nG = diag({s}², {t}²): E_h {result.energy:.6f}, radius {fit['radius']:.6f}")
    assert result.converged and result.defect < 1e-10
    assert abs(fit["axis"][1]) > 0.999
    assert result.energy == pytest.approx(0.5 * LENGTH * WIDTH / t**4, rel=0.015)
    assert fit["radius"] == pytest.approx(s**2, rel=0.07)


def test_uniform_stretch_is_the_scaled_isometric_problem():
    """G = s²I with Z is s⁻² × the isometric bilayer with Z/s and the penalties times s⁴.

    Flowed with τ/s⁴ and tol s⁶ the two runs are the same sequence: measured (8 × 4) 99 steps
    both, s⁻²E_h to 3e-14, y = sỹ to 5e-11. With the same penalties they differ as the
    penalties do: E_h is above s⁻²E_h by 3.9 % (8 × 4; 2.0 % at 16 × 8), y differs by 0.020.
    """
    metric, _, y = roll(MPI.COMM_SELF, 4, 1.0, stretch=S)
    plain, _, y_plain = roll(
        MPI.COMM_SELF, 4, 1.0 / S, scale=S**4, tau=0.25 / S**4, tol=1e-6 * S**6
    )
    assert metric.converged and metric.steps == plain.steps
    assert metric.energy == pytest.approx(plain.energy / S**2, abs=1e-10)
    assert np.abs(y - S * y_plain).max() < 1e-9
    same, _, _ = roll(MPI.COMM_SELF, 4, 1.0 / S)  # the penalties not scaled
    assert 0.02 < metric.energy / (same.energy / S**2) - 1 < 0.06


def test_uniform_stretch_on_a_twisted_lce_strip(tmp_path):
    """lce_strip.toml (twist, γ = 1, free) with G = s²I: the cylinder II = γ e₂⊗e₂, E = ½γ²|ω|/s⁴.

    Started from s × the isometric cylinder of curvature 0.1 along e₂. The isometric bound
    ``lower_bound`` is left out with a metric. Measured: E_h 0.722497 against 0.723380
    (−0.12 %), mean II₂₂ 0.9916, II₁₁ −0.0042, fitted radius 1.4557 (s²/γ = 1.44, +1.1 %).
    """
    metric = {"g11": S**2, "g12": 0.0, "g22": S**2}
    overrides = {**QUIET, "model.metric": metric, "flow.edge_constraint": False}

    def start(x):
        y = stretched(S)(x)
        y[1], y[2] = S * np.sin(0.1 * x[1]) / 0.1, S * (1 - np.cos(0.1 * x[1])) / 0.1
        return y

    result = run(load_problem(PROBLEMS / "lce_strip.toml", overrides), out=tmp_path, initial=start)
    exact = 0.5 * 3.0 / S**4
    mean_II = np.array(result["mean_second_fundamental_form"])
    assert result["converged"] and result["isometry_defect"] < 1e-10
    assert "lower_bound" not in result.summary
    assert result["energy"] == pytest.approx(exact, rel=0.01)
    assert mean_II[1, 1] == pytest.approx(1.0, abs=0.03) and abs(mean_II[0, 0]) < 0.02
    print(f"\nlce, G = s²I: E_h {result['energy']:.6f}, mean II {mean_II.round(4).tolist()}")
    assert result["cylinder_fit"]["radius"] == pytest.approx(S**2, rel=0.02)


@pytest.mark.mpi
@pytest.mark.parity
def test_stretched_bilayer_same_on_any_number_of_ranks():
    """G = s²I on 4 × 2 cells: the run on MPI.COMM_WORLD is the serial one."""
    serial, _, _ = roll(MPI.COMM_SELF, 2, 1.0, stretch=S, tau=0.1)
    parallel, _, _ = roll(MPI.COMM_WORLD, 2, 1.0, stretch=S, tau=0.1)
    assert serial.converged and parallel.steps == serial.steps
    assert parallel.energy == pytest.approx(serial.energy, rel=1e-10, abs=0)
    assert parallel.defect == pytest.approx(serial.defect, rel=PARITY_RTOL, abs=1e-12)


def test_poisson_rolls_a_wide_plate_to_one_plus_nu_times_z():
    """``model.poisson = ν``: |II − Z|² + c tr(II − Z)² on a cylinder II = diag(κ, 0), Z = aI
    is least at κ = a(1 + 2c)/(1 + c) = a(1 + ν), Timoshenko's wide plate; with G = s²I the
    radius is s²/(a(1 + ν)) (the scaling of the module docstring, ν unchanged).

    Measured (ν = 0.3; 8 × 4, 16 × 8): the radius with ν = 0 over that with ν is 1.2958,
    1.3017 (G = I) and 1.2902, 1.3004 (G = 1.44 I); the radius with ν is 6.7 %, 2.4 % above
    1/1.3 (G = I) and 6.8 %, 2.3 % above 1.44/1.3; E_h 1.29994, 1.29179 against
    |ω|·½((κ − a)² + a² + c(κ − 2a)²) = 1.3 (G = I).
    """
    nu, a = 0.3, 1.0
    c = nu / (1 - nu)
    kappa = a * (1 + nu)
    exact = 0.5 * ((kappa - a) ** 2 + a**2 + c * (kappa - 2 * a) ** 2) * LENGTH * WIDTH
    radii = {}
    for stretch in (None, S):
        for value in (0.0, nu):
            result, shape, _ = roll(MPI.COMM_SELF, 4, a, stretch=stretch, poisson=value)
            assert result.converged and result.defect < 1e-10
            radii[stretch, value] = shape["cylinder_fit"]["radius"]
            if stretch is None and value:
                assert result.energy == pytest.approx(exact, rel=0.02)
    for stretch in (None, S):
        assert radii[stretch, 0.0] / radii[stretch, nu] == pytest.approx(1 + nu, rel=0.01)
    assert radii[None, nu] == pytest.approx(1 / kappa, rel=0.08)
    assert radii[S, nu] == pytest.approx(S**2 / kappa, rel=0.08)
