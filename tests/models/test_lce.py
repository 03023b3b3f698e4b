"""Liquid-crystal-elastomer plates: A = γ R(θ) A₀ R(θ)ᵀ on a free 3 × 1 strip (docs/lce.md).

Exact isometric minima for constant θ: splay A₀ = diag(−1, 0) → 0, a cylinder with II = −γ d⊗d,
d = (cos θ, sin θ); twist A₀ = diag(−1, 1) → ½γ²|ω|, reached by two cylinders, II = −γ d⊗d or
II = +γ d⊥⊗d⊥. The flow picks one of them from the start it is given.
"""

from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import PARITY_RTOL, QUIET

import dgplate
from dgplate.cli import main

STRIP = Path(__file__).resolve().parents[2] / "demos" / "problems" / "lce_strip.toml"
AREA = 3.0


def cylinder(kappa, along):
    """x ↦ the cylinder of curvature κ along e₁ (along = 0) or e₂ (1): an exact isometry."""

    def y(x):
        out = x.copy()
        s = x[along]
        out[along] = np.sin(kappa * s) / kappa
        out[2] = (1.0 - np.cos(kappa * s)) / kappa
        return out

    return y


def run(tmp_path, overrides, initial=None, comm=MPI.COMM_SELF, name="out"):
    problem = dgplate.load_problem(STRIP, overrides={**QUIET, **overrides})
    out = comm.bcast(tmp_path / name if comm.rank == 0 else None)
    return dgplate.run(problem, out=out, comm=comm, initial=initial)


def check_isometric(result):
    assert result["converged"]
    assert result["energy_increases"] == []
    assert result["isometry_defect"] < 1e-8


def test_splay_rolls_along_the_director_at_zero_energy(tmp_path):
    theta = 0.5
    result = run(tmp_path, {"model.director": "splay", "model.theta": theta})
    check_isometric(result)
    scale = 0.5 * AREA  # the flat plate's energy ½γ²|ω|
    d = np.array([np.cos(theta), np.sin(theta)])
    mean_II = np.array(result["mean_second_fundamental_form"])
    print(f"\nsplay θ = {theta}: E_h = {result['energy']:.3e}, mean II {mean_II.round(4).tolist()}")
    assert result["lower_bound"] == 0.0
    assert abs(result["energy"]) < 0.02 * scale, "exact minimum 0 (2 % of the flat energy)"
    assert np.abs(mean_II + np.outer(d, d)).max() < 0.03, "II = −γ d⊗d"


@pytest.mark.parametrize("along,kappa", [(0, -1.0), (1, 1.0)])
def test_twist_reaches_either_cylinder(tmp_path, along, kappa):
    """Started from a cylinder of curvature 0.1κ, the flow ends on the cylinder κ: ½γ²|ω|."""
    result = run(tmp_path, {}, initial=cylinder(0.1 * kappa, along))
    check_isometric(result)
    exact = 0.5 * AREA
    mean_II = np.array(result["mean_second_fundamental_form"])
    print(f"\ntwist from e{along + 1}: E_h = {result['energy']:.5f}, mean II {mean_II.tolist()}")
    assert result["lower_bound"] == pytest.approx(exact, rel=1e-12)
    assert result["energy"] == pytest.approx(exact, rel=0.01)
    assert mean_II[along, along] == pytest.approx(kappa, abs=0.03)
    assert abs(mean_II[1 - along, 1 - along]) < 0.02 and abs(mean_II[0, 1]) < 1e-6
    assert result["cylinder_fit"]["rms_residual"] < 1e-3


@pytest.mark.parametrize(
    "setting,message",
    [
        ('model.theta="pi*x/(2"', "model.theta: cannot parse formula"),
        ('model.theta="phi*x"', "model.theta: unknown name 'phi'"),
        ('model.director="bend"', "model.director must be one of splay, twist, got 'bend'"),
        ('model.gamma="strong"', "model.gamma must be float, got 'strong'"),
    ],
)
def test_bad_input_is_one_line_with_exit_2(tmp_path, capsys, setting, message):
    code = main(["run", str(STRIP), "--out", str(tmp_path / "o"), "--set", setting])
    err = capsys.readouterr().err
    assert code == 2 and message in err and err.count("\n") == 1, err
    assert not (tmp_path / "o").exists()


@pytest.mark.mpi
@pytest.mark.parity
def test_lce_same_on_any_number_of_ranks(tmp_path):
    overrides = {
        "mesh.cells": [6, 2],
        "model.theta": 0.5,
        "flow.linear_solver": "direct",
        "flow.max_steps": 30,
    }
    serial = run(tmp_path, overrides, name="serial")
    parallel = run(tmp_path, overrides, comm=MPI.COMM_WORLD, name="parallel")
    assert parallel["steps"] == serial["steps"]
    assert parallel["energy"] == pytest.approx(serial["energy"], rel=PARITY_RTOL)
    assert parallel["isometry_defect"] == pytest.approx(serial["isometry_defect"], abs=1e-12)
    # the shape: nothing is clamped, so the minimisers are a family under rigid motions, which
    # only the flow's L² metric (1/τ) damps; the SQP steps at τ up to 64 moved the 2-rank run
    # by 1.6·10⁻⁶ along it, with II and the curvatures equal to 10⁻¹⁴
    for key in ("mean_second_fundamental_form", "gauss_curvature_l1"):
        np.testing.assert_allclose(parallel[key], serial[key], rtol=0, atol=1e-10)
    assert parallel["cylinder_fit"]["radius"] == pytest.approx(
        serial["cylinder_fit"]["radius"], rel=1e-10
    )
    np.testing.assert_allclose(parallel["bbox"], serial["bbox"], rtol=0, atol=1e-5)
