"""`dgplate converge`: Richardson's arithmetic, the levels' folders and their reuse, bad input."""

import json
import os
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest
from helpers import PROBLEMS, QUIET, ROOT, mpirun

import dgplate
from dgplate.cli import main
from dgplate.measure.richardson import extrapolate
from dgplate.mesh.tagged import rectangle
from dgplate.problems.converge import (
    ConvergenceStudy,
    estimates,
    level_record,
    refinements,
    warm_start,
)
from dgplate.solvers.transfer import MeshStart, interpolate

CYLINDER = PROBLEMS / "bilayer_cylinder.toml"
#: The bilayer cylinder on 4×2, 8×4 and 16×8 cells: a few seconds a level.
SMALL = {"mesh.cells": [4, 2], **QUIET}


@pytest.mark.parametrize("order", [1.0, 2.0])
def test_richardson_recovers_order_and_limit(order):
    values = [1.5 + 0.3 * h**order for h in (1.0, 0.5, 0.25, 0.125)]
    estimate = extrapolate(values)
    assert estimate.reason is None
    assert estimate.order == pytest.approx(order, abs=1e-10)
    assert estimate.limit == pytest.approx(1.5, abs=1e-10)
    assert estimate.error == pytest.approx(0.3 * 0.125**order, abs=1e-10)


@pytest.mark.parametrize(
    ("values", "reason"),
    [
        ([1.0, 1.1, 1.05], "no monotone trend (the differences change sign)"),
        ([1.0, 1.1], "2 level(s): three are needed"),
        ([1.0, 1.5, 1.5 + 0.5 / 2**8], "observed order 8 outside [0.5, 6]"),
        ([1.0, 1.25, 1.5], "observed order 0 outside [0.5, 6]"),
        ([1.0, 1.0, 1.0], "no change between the last two levels (round-off): no order"),
        ([1.0, float("nan"), 1.0], "a value that is not finite"),
    ],
)
def test_richardson_says_why_there_is_no_estimate(values, reason):
    estimate = extrapolate(values)
    assert (estimate.reason, estimate.order, estimate.limit, estimate.error) == (
        reason,
        None,
        None,
        None,
    )


def _levels(energies, converged=(True, True, True)):
    """Level records of three runs with these energies and a radius going 1.4, 1.2, 1.1."""
    summaries = [
        {"energy": e, "converged": ok, "cylinder_fit": {"radius": r}, "cells": 8, "steps": 3}
        for e, ok, r in zip(energies, converged, (1.4, 1.2, 1.1), strict=True)
    ]
    return [level_record(i, "n", s, False) for i, s in enumerate(summaries, 1)]


def test_estimates_of_a_study():
    found = estimates(_levels([1.4, 1.2, 1.1]))
    assert set(found) == {"energy", "cylinder_fit.radius"}
    assert found["cylinder_fit.radius"]["values"] == [1.4, 1.2, 1.1]
    assert found["cylinder_fit.radius"]["order"] == pytest.approx(1.0, abs=1e-12)
    assert found["cylinder_fit.radius"]["limit"] == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize(
    ("energies", "converged", "reason"),
    [
        (
            [1.0, 1.1, 1.5],
            (True,) * 3,
            "E_h jumps: it changes 4 times more from level 2 to 3 "
            "than from 1 to 2 (a different local minimiser?)",
        ),
        ([1.4, 1.2, 1.1], (True, False, True), "level 2 did not converge"),
    ],
    ids=["jump", "not converged"],
)
def test_no_figure_is_extrapolated_past_a_jump_or_a_failed_level(energies, converged, reason):
    found = estimates(_levels(energies, converged))
    assert found["cylinder_fit.radius"]["reason"] == reason
    assert found["cylinder_fit.radius"]["limit"] is None


def test_an_interrupted_level_is_left_out_of_the_estimates():
    """The figures of a study stopped in its last level come from the levels that finished."""
    study = ConvergenceStudy("p", Path("."), levels=_levels([1.4, 1.2, 1.1]), interrupted=15)
    assert [lv["level"] for lv in study.finished_levels()] == [1, 2]
    assert estimates(study.finished_levels())["energy"]["values"] == [1.4, 1.2]
    assert estimates([]) == {}


def test_warm_start_only_for_the_plates_gradient_flow():
    cases = {"bilayer_cylinder": True, "rod_arc": False, "fvk_square": False}
    cases["buckling_strip"] = False  # a continuation in the clamped data: starts at α = 0
    cases["vertical_load"] = False  # the rate test: the end state depends on the start
    cases["turned_strip"] = False  # a path: it starts at λ = 0
    for name, warm in cases.items():
        assert warm_start(dgplate.load_problem(PROBLEMS / f"{name}.toml")) is warm, name


def test_a_rate_stopped_level_is_the_run_at_its_size(tmp_path):
    """The BNN plate (the rate test, D_h uncorrected): level 2 of a study from 2 × 2 cells is
    the plain run on 4 × 4 cells, its E_h, D_h and steps (BNN Table 1's 4 × 4 row)."""
    problem = dgplate.load_problem(PROBLEMS / "vertical_load.toml", {"mesh.cells": [2, 2], **QUIET})
    study = dgplate.converge(problem, levels=2, out=tmp_path / "study")
    finer = dgplate.load_problem(PROBLEMS / "vertical_load.toml", {"mesh.cells": [4, 4], **QUIET})
    run = dgplate.run(finer, out=tmp_path / "run").summary
    level = study.levels[1]
    assert level["steps"] == run["steps"]
    assert level["energy"] == pytest.approx(run["energy"], rel=1e-12)
    assert level["isometry_defect"] == pytest.approx(run["isometry_defect"], rel=1e-12)


@pytest.mark.mpi
def test_a_coarse_shape_is_interpolated_exactly_onto_a_finer_mesh():
    """Q2 on 2×2 cells is Q2 on 4×4: the non-matching interpolation reproduces it (any ranks)."""
    comm = MPI.COMM_WORLD
    quadratic = lambda x: np.vstack([x[0] + x[1] ** 2, x[0] * x[1], 1.0 - x[0] ** 2])  # noqa: E731
    spaces = [
        dolfinx.fem.functionspace(rectangle(comm, [[0, 0], [2, 1]], [n, n]).mesh, ("DG", 2, (3,)))
        for n in (2, 4)
    ]
    coarse, fine, exact = (dolfinx.fem.Function(spaces[i]) for i in (0, 1, 1))
    coarse.interpolate(quadratic)
    exact.interpolate(quadratic)
    interpolate(fine, MeshStart(coarse))
    assert np.max(np.abs(fine.x.array - exact.x.array), initial=0.0) < 1e-12
    with pytest.raises(dgplate.InputError, match="starts a plate's gradient flow only"):
        MeshStart(coarse)(np.zeros((3, 1)))


def test_refinements_double_cells_and_halve_sizes():
    cylinder = dgplate.load_problem(CYLINDER, SMALL)
    assert [size for _, size in refinements(cylinder, 3)] == ["4×2", "8×4", "16×8"]
    assert refinements(cylinder, 3)[2][0].mesh.cells == [16, 8]
    hole = dgplate.load_problem(PROBLEMS / "bilayer_hole.toml")  # hole_h: given as a number
    assert [size for _, size in refinements(hole, 2)] == [
        "h = 0.15, hole_h = 0.1",
        "h = 0.075, hole_h = 0.05",
    ]
    box = dgplate.load_problem(PROBLEMS / "box_folding.toml")  # counts, not sizes
    assert refinements(box, 2)[1][0].mesh.parameters == {
        "w": pytest.approx(np.pi / 24),
        "n": 8,
        "m": 8,
    }
    rod = dgplate.load_problem(PROBLEMS / "rod_arc.toml")
    cells = rod.model.cells
    assert refinements(rod, 2)[1][0].model.cells == 2 * cells


def test_converge_writes_each_level_and_reuses_them(tmp_path, capsys):
    """Three levels of the cylinder: the study's JSON and table, a run folder per level; the
    second call with resume takes no step and gives the same figures."""
    comm = MPI.COMM_WORLD
    out = Path(comm.bcast(str(tmp_path / "study"), root=0))
    problem = dgplate.load_problem(CYLINDER, SMALL)
    study = dgplate.converge(problem, levels=3, out=out)
    printed = capsys.readouterr().out
    assert "level 3/3: 16×8 cells, 5,248 dofs" in printed
    data = json.loads((out / "converge.json").read_text())
    assert [lv["size"] for lv in data["levels"]] == ["4×2", "8×4", "16×8"]
    assert [lv["dofs"] for lv in data["levels"]] == [328, 1312, 5248]
    assert not any(lv["reused"] for lv in data["levels"])
    for index in (1, 2, 3):
        summary = json.loads((out / f"level-{index}" / "summary.json").read_text())
        assert summary["converged"] and summary["input"]["mesh"]["cells"] == [
            4 * 2 ** (index - 1),
            2 * 2 ** (index - 1),
        ]
    energy = data["figures"]["energy"]
    assert energy["values"] == [lv["energy"] for lv in data["levels"]]
    assert set(energy) == {"values", "order", "limit", "error", "reason"}
    assert {"cylinder_fit.radius", "isometry_defect", "extent.z"} <= set(data["figures"])
    assert (out / "converge.md").read_text().startswith("| level | size |")
    again = dgplate.converge(problem, levels=3, out=out, resume=True)
    assert all(lv["reused"] for lv in again.levels)
    assert [lv["steps"] for lv in again.levels] == [lv["steps"] for lv in study.levels]
    assert again.figures == study.figures
    assert "finished earlier, its results are reused" in capsys.readouterr().out


NO_SIZE = """
[mesh]
type = "gmsh"
file = "no_size.geo"

[model]
clamped = ["left"]
"""


@pytest.mark.parametrize(
    ("problem", "args", "message"),
    [
        (CYLINDER, ["--levels", "1"], "dgplate: error: --levels must be an integer ≥ 2, got 1"),
        (
            "no_size.toml",
            [],
            "dgplate: error: mesh.parameters: no_size.geo has no size to refine (a parameter "
            "h, h_*, *_h, n or m with a number)",
        ),
    ],
    ids=["levels", "no size"],
)
def test_bad_input_exits_2_naming_the_key(problem, args, message, tmp_path, capsys, monkeypatch):
    (tmp_path / "no_size.geo").write_text('DefineConstant[ L = {1.0, Name "Parameters/L"} ];\n')
    (tmp_path / "no_size.toml").write_text(NO_SIZE)
    monkeypatch.chdir(tmp_path)
    code = main(["converge", str(problem), "--out", "study", *args])
    err = capsys.readouterr().err
    assert (code, err) == (2, message + "\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["no_size.geo", "no_size.toml"]


@pytest.mark.spawns_mpirun
@pytest.mark.skipif(mpirun() is None, reason="no mpirun")
def test_converge_on_two_ranks(tmp_path):
    """`mpirun -n 2 dgplate converge …`: the levels on two ranks, each progress line once."""
    out = tmp_path / "study"
    sets = [f"--set={key}={json.dumps(value)}" for key, value in SMALL.items()]
    args = [mpirun(), "-n", "2", sys.executable, "-m", "mpi4py", "-m", "dgplate", "converge"]
    paths = [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}
    proc = subprocess.run(
        [*args, str(CYLINDER), "--levels", "2", "--out", str(out), *sets],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.count("level 2/2: 8×4 cells, 1,312 dofs") == 1, proc.stdout
    data = json.loads((out / "converge.json").read_text())
    assert data["figures"]["energy"]["reason"] == "2 level(s): three are needed"
    summary = json.loads((out / "level-2" / "summary.json").read_text())
    assert summary["ranks"] == 2 and summary["converged"]
