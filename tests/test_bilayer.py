"""Bilayer plates: a rectangle clamped on one short side with Z = αI rolls into a cylinder of
radius 1/α about an axis parallel to the clamped side, with energy ½α²|ω|."""

from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from conftest import PARITY_RTOL

from dgplate.cli import main
from dgplate.flow import FlowSettings, GradientFlow
from dgplate.meshing import rectangle
from dgplate.models.bilayer import BilayerSpec, build_bilayer

CYLINDER = Path(__file__).resolve().parent.parent / "demos" / "problems" / "bilayer_cylinder.toml"


def roll(
    comm,
    alpha,
    n,
    multiplier_degree=1,
    tau=0.05,
    consistent=True,
    projection_steps=2,
    linear_solver="lagged",
    edge_constraint=False,
    gamma1=1100.0,
):
    tagged = rectangle(comm, [[0, 0], [2, 1]], [2 * n, n])
    penalty = {"gamma0": 5000.0, "gamma1": gamma1}
    spec = BilayerSpec(clamped=["left"], Z=alpha, consistent=consistent, penalty=penalty)
    model = build_bilayer(spec, tagged)
    settings = FlowSettings(
        tau=tau,
        max_steps=3000,
        multiplier_degree=multiplier_degree,
        projection_steps=projection_steps,
        linear_solver=linear_solver,
        edge_constraint=edge_constraint,
    )
    flow = GradientFlow(model.faces, 2, model.energy_fn, settings)
    result = flow.run()
    return result, model.extras(flow)


#: the cylinder's acceptance set-up: free-edge metric moments and γ₁ = 11000 (docs/bilayer.md)
ACCEPTANCE = dict(edge_constraint=True, gamma1=11000.0, tau=0.25)


@pytest.mark.parametrize("alpha", [1.0, 2.0])
def test_cylinder_within_two_percent(alpha):
    """Energy within 2 % of ½α²|ω| and radius within 2 % of 1/α at 32×16, both better than at
    16×8; axis parallel to the clamped side; D_h at round-off."""
    exact = 0.5 * alpha**2 * 2.0
    errors = []
    for n in (8, 16):
        result, shape = roll(MPI.COMM_SELF, alpha, n, **ACCEPTANCE)
        fit = shape["cylinder_fit"]
        e_err = result.energy / exact - 1.0
        r_err = fit["radius"] * alpha - 1.0
        errors.append((abs(e_err), abs(r_err)))
        print(
            f"\nZ = {alpha}I, {2 * n}x{n} Q2: E_h = {result.energy:.4f} ({100 * e_err:+.2f} %), "
            f"radius {fit['radius']:.4f} ({100 * r_err:+.2f} %), D_h = {result.defect:.1e}, "
            f"steps {result.steps}"
        )
        assert result.converged
        assert result.defect < 1e-10, "the projection restores the discrete constraint"
        assert abs(fit["axis"][1]) > 0.999, "the rolling axis is parallel to the clamped side"
        assert shape["principal_curvatures"]["kappa1_mean"] > 0  # bends towards +ν
    (e_coarse, r_coarse), (e_fine, r_fine) = errors
    assert e_fine < 0.02 and r_fine < 0.02
    assert e_fine < e_coarse and r_fine < r_coarse


@pytest.mark.parametrize("value", [[[1.0, 2.0], [0.0, 1.0]], [[1.0, "x"], ["y", 1.0]]])
def test_non_symmetric_Z_is_refused(value, tmp_path, capsys):
    rendered = str(value).replace("'", '"')
    code = main(
        ["run", str(CYLINDER), "--out", str(tmp_path / "o"), "--set", f"model.Z={rendered}"]
    )
    err = capsys.readouterr().err
    assert code == 2 and "model.Z must be symmetric: model.Z[0][1]" in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.mpi
@pytest.mark.parametrize("edge_constraint", [False, True])
def test_bilayer_same_on_any_number_of_ranks(edge_constraint):
    # direct solves: parity to round-off (the lagged solver's GMRES tolerance is 1e-12 of |b|)
    tagged_args = dict(
        alpha=1.0, n=4, tau=0.1, linear_solver="direct", edge_constraint=edge_constraint
    )
    serial, _ = roll(MPI.COMM_SELF, **tagged_args)
    parallel, _ = roll(MPI.COMM_WORLD, **tagged_args)
    assert parallel.steps == serial.steps
    assert parallel.energy == pytest.approx(
        serial.energy, rel=1e-10, abs=0
    )  # 4x2 cells: round-off stays tiny
    # with projection D_h is round-off (1e-15): compare it absolutely
    assert parallel.defect == pytest.approx(serial.defect, rel=PARITY_RTOL, abs=1e-12)
    assert np.isfinite(parallel.energy)
