"""The Gaussian curvature K = det(II)/det(∇yᵀ∇y) and the L¹ norms of K and of the isometry defect.

Surfaces with known answers: a sheet rolled onto the unit cylinder (K = 0: its second
derivatives along x₂ vanish exactly, so det(II) = 0 to roundoff), a sphere cap of radius R
(K = 1/R², up to the interpolation error), a stretch y = (2x₁, x₂, 0) (|∇yᵀ∇y − I| = 3), a flat plate (a cylinder of radius ∞); and
a run of the BNN plate that writes K into its VTX series, summary.json and final.png.
"""

import json
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import ffcx.codegeneration.jit
import ffcx.naming
import numpy as np
import pytest
from helpers import PROBLEMS

from dgplate.errors import InputError
from dgplate.io.vtx import bp_variables
from dgplate.measure.analysis import curvature_summary, l1_norms
from dgplate.measure.fields import gauss_density
from dgplate.mesh.tagged import rectangle
from dgplate.problems.runner import run
from dgplate.problems.specs import load_problem

R = 2.0


def deformation(comm, cell_type: str, degree: int, corners, cells, y):
    mesh = rectangle(comm, corners, cells, cell_type).mesh
    space = dolfinx.fem.functionspace(mesh, ("DG", degree, (3,)))
    u = dolfinx.fem.Function(space)
    u.interpolate(y)
    return u


def cylinder(x):
    return np.vstack([np.sin(x[0]), x[1], 1.0 - np.cos(x[0])])


def sphere(x):
    return np.vstack([x[0], x[1], np.sqrt(R**2 - x[0] ** 2 - x[1] ** 2)])


@pytest.mark.mpi
@pytest.mark.parametrize("cell_type", ["quadrilateral", "triangle"])
def test_cylinder_has_zero_gauss_curvature(comm, cell_type):
    y = deformation(comm, cell_type, 2, [[0, 0], [2, 1]], [4, 2], cylinder)
    assert np.max(np.abs(gauss_density(y)), initial=0.0) < 1e-12
    norms = l1_norms(y)
    assert norms["gauss_curvature_l1"] < 1e-12
    # an isometry up to interpolation: ∇yᵀ∇y − I = O(h²) on 2 × 1
    assert 0 < norms["isometry_defect_l1"] < 0.05


@pytest.mark.mpi
def test_flat_plate_fits_a_cylinder_of_infinite_radius(comm):
    """A plane (a rigid plate: E_h = 0 to round-off) is the cylinder of radius ∞, fitted exactly.

    Its points lie on a line of the plane normal to the axis, so the circle's normal
    equations are singular.
    """
    y = deformation(comm, "quadrilateral", 2, [[0, 0], [2, 1]], [4, 2], lambda x: x)
    fit = curvature_summary(y)["cylinder_fit"]
    assert fit["radius"] == float("inf") and fit["rms_residual"] == 0.0


def rolled(angle: float):
    """The sheet bent along the in-plane direction at ``angle`` onto the unit cylinder, whose
    axis is the direction across it, (−sin angle, cos angle, 0)."""
    along, across = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])  # fmt: skip

    def y(x):
        s, t = along @ x[:2], across @ x[:2]
        return np.vstack([np.sin(s) * along[0] + t * across[0],
                          np.sin(s) * along[1] + t * across[1], 1.0 - np.cos(s)])  # fmt: skip

    return y


def test_the_cylinder_fit_of_another_shape_compiles_nothing(monkeypatch):
    """Two sheets rolled about different directions fit the unit cylinder with the same compiled
    expressions: a number of the shape (its direction of least bending) written into an
    expression would compile a new one for every shape, in every run."""
    compiled: list[str] = []
    compile_expressions = ffcx.codegeneration.jit.compile_expressions

    def spy(expressions, *args, **kwargs):
        compiled.append(ffcx.naming.compute_signature(expressions, ""))
        return compile_expressions(expressions, *args, **kwargs)

    monkeypatch.setattr(ffcx.codegeneration.jit, "compile_expressions", spy)
    signatures = []
    for angle in (0.0, 0.5):
        compiled.clear()
        y = deformation(
            MPI.COMM_SELF, "quadrilateral", 2, [[-1, -1], [1, 1]], [6, 6], rolled(angle)
        )
        fit = curvature_summary(y)["cylinder_fit"]
        assert fit["radius"] == pytest.approx(1.0, rel=0.02)
        axis = np.array([-np.sin(angle), np.cos(angle), 0.0])
        assert abs(np.dot(fit["axis"], axis)) == pytest.approx(1.0, abs=1e-6)
        signatures.append(set(compiled))
    assert signatures[0] and signatures[1] == signatures[0]


@pytest.mark.mpi
@pytest.mark.parametrize("cell_type", ["quadrilateral", "triangle"])
def test_sphere_cap_has_gauss_curvature_one_over_r_squared(comm, cell_type):
    y = deformation(comm, cell_type, 3, [[-0.5, -0.5], [0.5, 0.5]], [4, 4], sphere)
    K = gauss_density(y)
    assert np.allclose(K, 1 / R**2, rtol=1e-2)
    norms = l1_norms(y)
    assert norms["gauss_curvature_l1"] == pytest.approx(1.0 / R**2, rel=5e-3)  # |ω| = 1
    # the graph parametrisation is no isometry: ∇yᵀ∇y − I = ∇z ⊗ ∇z, |∇z ⊗ ∇z| = |∇z|²
    assert norms["isometry_defect_l1"] == pytest.approx(_defect_of_sphere_graph(), rel=1e-3)


def _defect_of_sphere_graph() -> float:
    """∫ over (−½, ½)² of |∇z|² = r²/(R² − r²) for z = √(R² − r²), by a fine midpoint rule."""
    n = 2000
    t = (np.arange(n) + 0.5) / n - 0.5
    x1, x2 = np.meshgrid(t, t)
    r2 = x1**2 + x2**2
    return float(np.sum(r2 / (R**2 - r2)) / n**2)


@pytest.mark.mpi
def test_stretch_has_defect_three_per_area(comm):
    y = deformation(
        comm,
        "triangle",
        2,
        [[0, 0], [2, 1]],
        [2, 2],
        lambda x: np.vstack([2 * x[0], x[1], 0 * x[0]]),
    )
    norms = l1_norms(y)
    assert norms["isometry_defect_l1"] == pytest.approx(3.0 * 2.0, rel=1e-12)
    assert norms["gauss_curvature_l1"] < 1e-14


def test_color_by_gauss_is_accepted_and_a_typo_named(tmp_path):
    problem = load_problem(PROBLEMS / "vertical_load.toml", {"output.color_by": "gauss"})
    assert problem.output.color_by == "gauss"
    with pytest.raises(
        InputError, match=r"^output\.color_by must be one of curvature, defect, gauss, got 'gaus'"
    ):
        load_problem(PROBLEMS / "vertical_load.toml", {"output.color_by": "gaus"})


def test_run_writes_gauss_curvature(tmp_path):
    """A short BNN run: K in the VTX series, the L¹ norms in summary.json, final.png by K."""
    overrides = {
        "mesh.cells": [4, 4],
        "flow.max_steps": 3,
        "output.progress": 0,
        "output.color_by": "gauss",
    }
    out = tmp_path / "run"
    run(load_problem(PROBLEMS / "vertical_load.toml", overrides), out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["gauss_curvature_l1"] > 0
    # the cell-wise |∫_T δI| of D_h never exceeds ∫_T |δI|
    assert summary["isometry_defect_l1"] >= summary["isometry_defect"] > 0
    series = Path(out / "deformation_gauss_curvature.bp")
    assert bp_variables(series) == {"gauss_curvature"}
    assert (out / "final.png").stat().st_size > 0
