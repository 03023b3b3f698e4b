"""The length h_e of the dG penalties (``model.penalty_length``): its values on simple meshes, and
that "facet_normal" (|T|/|F|) makes the bending form coercive on the cone's polar mesh
(``meshes/polar_disc.geo``), where the cell diameter of its thin central triangles does not."""

import importlib.util
import json
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest

from dgplate.dg.forms import Penalty, facet_sets, integral
from dgplate.mesh.tagged import load_geo, rectangle
from dgplate.schema import from_dict
from dgplate.solvers.eigen import negative_count

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "dg_coercivity.py"


def _integrals(tagged, length):
    """∫ h_e over the interior facets and over the boundary facets."""
    facets = facet_sets(tagged, penalty_length=length)
    mesh = tagged.mesh
    inside = dolfinx.fem.form(facets.h_interior * facets.dS_all())
    boundary = dolfinx.fem.form(facets.h_boundary * facets.ds)
    return integral(inside, mesh.comm), integral(boundary, mesh.comm)


@pytest.mark.parametrize(
    "cell_type,cells,expected",
    [
        # two triangles of area 1 (the 2 × 1 rectangle cut by its diagonal, length √5):
        # h_F = 1/√5 on the diagonal, 1/2 on the long and 1 on the short edges
        ("triangle", [1, 1], {"facet_normal": (1.0, 4.0), "diameter": (5.0, 6 * np.sqrt(5))}),
        # two 2 × 1 rectangles: the cell-wise fallback |T|/(longest facet) = 1 everywhere
        ("quadrilateral", [2, 1], {"facet_normal": (1.0, 10.0), "diameter": (5**0.5, 10 * 5**0.5)}),
    ],
)
def test_penalty_lengths_on_simple_meshes(cell_type, cells, expected):
    corners = [[0.0, 0.0], [2.0 * cells[0], 1.0]]
    tagged = rectangle(MPI.COMM_WORLD, corners, cells, cell_type)
    for length, values in expected.items():
        assert _integrals(tagged, length) == pytest.approx(values, rel=1e-12), length


def test_facet_normal_makes_the_bending_form_coercive_on_the_polar_mesh():
    """DG_3, γ₀ = γ₁ = 100 (the FvK defaults), clamped disc of radius 1, h = 0.2: with the
    diameter the matrix has negative eigenvalues (70 measured); with |T|/|F| none, and the lowest
    eigenvalue of A x = λ M x lies near that of the clamped plate, (3.1962)⁴ = 104.36 (106.2
    measured): exactly one eigenvalue in [100, 110)."""
    spec = importlib.util.spec_from_file_location("bench_dg_coercivity", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    tagged = load_geo(MPI.COMM_WORLD, "polar_disc.geo", {"R": 1.0, "Rc": 0.15, "N": 16, "h": 0.2})
    penalty = Penalty(100.0, 100.0)
    counts = {}
    for length in ("diameter", "facet_normal"):
        A, M = bench.matrices(tagged, 3, penalty, length, 0.0)
        counts[length] = [negative_count(A, M, shift) for shift in (0.0, 100.0, 110.0)]
        A.destroy()
        M.destroy()
    assert counts["diameter"][0] > 10
    assert counts["facet_normal"] == [0, 0, 1]


def test_kirchhoff_key_runs_and_is_checked(tmp_path):
    """``model.penalty_length`` of the plate models (Kirchhoff, bilayer, LCE share it): a bad
    value is a one-line error naming the key (exit 2, nothing written); with "facet_normal"
    the BNN plate (6×6 quadrilaterals, where |T|/|F| = h < the diameter √2 h: a larger penalty)
    converges to an energy 4.9 % above the diameter's (−8.744·10⁻³ against −9.196·10⁻³), the
    stiffening of a coarse mesh by its penalty."""
    from dgplate.cli import main
    from dgplate.errors import InputError
    from dgplate.models.kirchhoff import KirchhoffSpec

    with pytest.raises(InputError, match=r"model\.penalty_length must be one of"):
        from_dict(KirchhoffSpec, {"penalty_length": "normal"}, "model")
    problem = Path(__file__).resolve().parents[2] / "demos" / "problems" / "vertical_load.toml"
    small = ["--set=mesh.cells=[6,6]", "--set=output.vtx=false", "--set=output.png=false"]
    small += ["--set=output.progress=0"]
    bad = tmp_path / "bad"
    assert main(["run", str(problem), "--out", str(bad), *small,
                 "--set=model.penalty_length='normal'"]) == 2  # fmt: skip
    assert not bad.exists()
    energies = {}
    for length in ("diameter", "facet_normal"):
        out = tmp_path / length
        setting = f"--set=model.penalty_length='{length}'"
        assert main(["run", str(problem), "--out", str(out), *small, setting]) == 0
        summary = json.loads((out / "summary.json").read_text())
        assert summary["converged"]
        energies[length] = summary["energy"]
    assert energies["facet_normal"] != energies["diameter"]  # the key reaches the forms
    assert energies["diameter"] < energies["facet_normal"] < 0.9 * energies["diameter"]


def test_thermal_key_reaches_the_facets():
    """The thermal model has the key too: checked (one-line error naming it), and given to
    the facets of the box's net, whose thin hinge cells make |T|/|F| much smaller than the
    diameter there: ∫h_e over the interior facets falls."""
    from dgplate.errors import InputError
    from dgplate.models.thermal.spec import ThermalSpec
    from dgplate.problems.prepare import build_mesh
    from dgplate.problems.registry import MODELS
    from dgplate.problems.specs import load_problem

    with pytest.raises(InputError, match=r"model\.penalty_length must be one of"):
        from_dict(ThermalSpec, {"penalty_length": "normal"}, "model")
    box = Path(__file__).resolve().parents[2] / "demos" / "problems" / "box_folding.toml"
    inside = {}
    for length in ("diameter", "facet_normal"):
        problem = load_problem(box, [f"model.penalty_length='{length}'"])
        tagged = build_mesh(problem.mesh, MPI.COMM_WORLD)
        model = MODELS["thermal"].build(problem.model, tagged)
        assert model.facets.penalty_length == length
        form = dolfinx.fem.form(model.facets.h_interior * model.facets.dS_all())
        inside[length] = integral(form, tagged.mesh.comm)
    assert inside["facet_normal"] < 0.9 * inside["diameter"]
