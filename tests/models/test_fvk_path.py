"""Path following of FvK plates through folds and bifurcations ([path] method = "arclength").

References: the buckling shortening of a simply supported square plate, Δ_cr = π²t²/(3(1 − ν²)a)
(Timoshenko & Gere, §9.2, k = 4), Koiter's initial post-buckling slope of the plate with held
unloaded edges (:func:`dgplate.reference.fvk.held_square_plate_postbuckling`), and the exact limit
point of a shallow sinusoidal strip (:func:`dgplate.reference.fvk.sinusoidal_strip_folds`), and
the bifurcation and fold of a buckled strip whose clamps are turned
(:func:`dgplate.reference.fvk.clamped_strip_thresholds`). The cases are those of
benchmarks/path_following.py.
"""

import dataclasses
import itertools
import json
import math
import re
import signal
import types

from mpi4py import MPI

import numpy as np
import pytest
from helpers import ROOT, load_benchmark
from petsc4py import PETSc

import dgplate
from dgplate import expressions, interrupt
from dgplate.cli import main
from dgplate.errors import SolverError
from dgplate.io.run_reader import details, read_summary
from dgplate.mesh.tagged import rectangle
from dgplate.models.fvk.model import build_fvk
from dgplate.models.fvk.spec import FvKSpec, PathSpec
from dgplate.problems.folders import run_or_reuse
from dgplate.reference.elastica import clamped_elastica
from dgplate.reference.fvk import (
    TAU_ANTISYMMETRIC,
    clamped_strip_natural_rise,
    clamped_strip_thresholds,
    held_square_plate_postbuckling,
    turned_strip_slope_factor,
)
from dgplate.reference.turned_elastica import _HalfRod, turned_strip_elastica_thresholds
from dgplate.solvers import special_points
from dgplate.solvers.continuation import BranchPath, BranchPoint, special_points_text
from dgplate.solvers.snes import NewtonSolver
from dgplate.solvers.special_points import SpecialPoints

PATHS = load_benchmark("path_following")  # the cases, shared with the benchmark
E, NU, T = PATHS.E, PATHS.NU, PATHS.T
A_FOLD = PATHS.A_FOLD
ARCH = ROOT / "demos" / "problems" / "fvk_arch.toml"
TURNED = ROOT / "demos" / "problems" / "fvk_turned_strip.toml"
follow, attempt = PATHS.follow, PATHS.attempt


def plate(comm, n, switch, steps, run=follow, held=False):
    """The perfect square plate of demos/fvk_buckling.py shortened by λ Δ_cr, n × n cells
    (``held``: both unloaded edges held, λ in units of that plate's Δ_c)."""
    return run(comm, PATHS.plate_spec(switch, steps, held), [n, n], [[0, 0], [1, 1]])


def arch(comm, n, steps=10):
    """The sinusoidal strip (rise t, ν = 0) from its unloaded arch, pushed down by λ q*."""
    return follow(comm, PATHS.arch_spec(steps), [n, 2], [[0, 0], [1, 0.1]], PATHS.arch_start)


def test_flat_plate_loses_stability_at_the_euler_loads():
    """The flat branch: index 0, 1, 2 past the bifurcations at k = 4 and k = 6.25 (m = 1, 2).

    Timoshenko & Gere §9.2: k = (m + 1/m)² for m half-waves along the load, Δ/Δ_cr = k/4.
    """
    points, summary = plate(MPI.COMM_WORLD, 8, switch=False, steps=8)
    kinds = [p["kind"] for p in points]
    assert kinds.count("bifurcation") == 2 and "fold" not in kinds
    first, second = (i for i, kind in enumerate(kinds) if kind == "bifurcation")
    assert summary["bifurcations"] == [
        pytest.approx(0.99527, abs=2e-5),
        pytest.approx(1.60896, abs=2e-5),
    ]
    assert summary["bifurcations"][0] == pytest.approx(1.0, rel=0.01)  # −0.47 %
    assert summary["bifurcations"][1] == pytest.approx(6.25 / 4, rel=0.04)  # +3.0 %
    indices = [p["stability_index"] for p in points]
    assert indices[:first] == [0] * first
    assert indices[first + 1 : second] == [1] * (second - first - 1)
    assert indices[second + 1 :] == [2] * (len(points) - second - 1)
    assert all(abs(p["w_max"]) < 1e-12 for p in points)  # flat all along
    assert all(p["tangent_load"] > 0 for p in points)  # no fold: λ rises


def test_switching_onto_the_buckled_branch():
    """After the switch the plate deflects, λ rises past λ_c and the index is 0 (stable)."""
    points, summary = plate(MPI.COMM_WORLD, 8, switch=True, steps=12)
    kinds = [p["kind"] for p in points]
    at = kinds.index("switch")
    critical = summary["bifurcations"][0]
    assert kinds[at - 1] == "bifurcation" and critical == pytest.approx(0.99527, abs=2e-5)
    buckled = points[at:]
    assert len(buckled) >= 5 and all(p["branch"] == 1 for p in buckled)
    assert [p["stability_index"] for p in buckled] == [0] * len(buckled)
    deflection = np.array([p["w_center"] for p in buckled])
    load = np.array([p["load_factor"] for p in buckled])
    assert np.all(np.diff(deflection) > 0) and deflection[-1] > 0.1 * T
    assert np.all(load > critical) and np.all(np.diff(load) > 0)
    assert deflection[0] == pytest.approx(0.0212 * T, rel=0.01)  # the first point after it
    # stable symmetric bifurcation: λ − λ_c grows like w², the ratio settles
    ratio = (load - critical) / (deflection / T) ** 2
    assert deflection[-2:] / T == pytest.approx([0.4525, 0.5453], abs=1e-3)
    assert ratio[-2:] == pytest.approx([0.6399, 0.6407], abs=2e-4)


def test_postbuckling_slope_converges_to_koiters():
    """Both unloaded edges held: the buckled branch's λ = 1 + b (w_c/t)² + … has Koiter's exact
    slope b = (3/8)(3 − ν)(1 + ν) = 1.31625 (:func:`held_square_plate_postbuckling`).

    Measured (fit of :func:`postbuckling_slope`): 1.37438 (+4.4 %) on 4 × 4 cells, 1.32434
    (+0.61 %) on 8 × 8, order 2.8; the bifurcation 1.00392 and 1.00117 (exact 1).
    """
    _, slope = held_square_plate_postbuckling(T, 1.0, NU)
    assert slope == pytest.approx(1.31625)
    fits, errors = [], []
    for n in (4, 8):
        points, summary = plate(MPI.COMM_WORLD, n, switch=True, steps=12, held=True)
        at = [p["kind"] for p in points].index("switch")
        assert [p["stability_index"] for p in points[at:]] == [0] * (len(points) - at)
        fit = PATHS.postbuckling_slope(points, T)
        assert fit["lambda0"] == pytest.approx(summary["bifurcations"][0], abs=1e-6)
        assert fit["w_max"] > 0.35  # the fit spans w_c up to a third of t and more
        fits.append(fit["lambda0"])
        errors.append(fit["slope"] / slope - 1)
    assert fits == pytest.approx([1.00392, 1.00117], abs=2e-5)
    assert errors == pytest.approx([0.0442, 0.0061], abs=5e-4)
    assert 0 < errors[1] < 0.01 and math.log2(errors[0] / errors[1]) > 2.5


def test_the_coarsest_plate_bifurcates_below_the_euler_load():
    """On 4 × 4 cells (306 dofs) the first bifurcation is at 0.98755 (−1.24 %)."""
    _, summary = plate(MPI.COMM_WORLD, 4, switch=False, steps=6)
    assert summary["dofs"] == 306
    assert summary["bifurcations"] == [pytest.approx(0.98755, abs=2e-5)]


def test_arch_snaps_through_its_limit_point_onto_the_snapped_arch():
    """16 × 2 cells, from the unloaded arch: λ rises, turns at the fold, falls through the flat
    strip to the second fold at −λ_f, turns and rises on the snapped arch past λ = 1; the index
    is 0, then 1 between the folds, then 0. Every point lies on the exact curve λ(w_c)
    (:func:`dgplate.reference.fvk.sinusoidal_strip_load`) within 4.2·10⁻³."""
    points, summary = arch(MPI.COMM_WORLD, 16, steps=PATHS.ARCH_STEPS)
    kinds = [p["kind"] for p in points]
    assert kinds.count("fold") == 2 and "bifurcation" not in kinds
    first, second = (i for i, kind in enumerate(kinds) if kind == "fold")
    fold = points[first]
    assert summary["folds"] == [fold["load_factor"], points[second]["load_factor"]]
    assert fold["load_factor"] == pytest.approx(0.99760, abs=2e-5)  # exact: 1 (−0.24 %)
    assert points[second]["load_factor"] == pytest.approx(-fold["load_factor"], rel=1e-6)
    assert fold["w_center"] == pytest.approx(A_FOLD, rel=0.002)
    assert points[second]["w_center"] == pytest.approx(-fold["w_center"], rel=1e-4)
    assert abs(fold["tangent_load"]) < 1e-6
    segments = points[:first], points[first + 1 : second], points[second + 1 :]
    for segment, rising, index in zip(segments, (True, False, True), (0, 1, 0), strict=True):
        assert all((p["tangent_load"] > 0) == rising for p in segment)
        assert np.all((np.diff([p["load_factor"] for p in segment]) > 0) == rising)
        assert [p["stability_index"] for p in segment] == [index] * len(segment)
    assert points[0]["w_center"] == pytest.approx(math.sqrt(2 / 3) * T, rel=0.002)  # a₀
    assert points[-1]["load_factor"] > 1 and points[-1]["w_center"] < -2 * A_FOLD  # snapped
    assert PATHS.arch_path_error(points) == pytest.approx(4.2e-3, abs=1e-4)


def test_an_unlocated_fold_is_not_listed_as_a_fold(monkeypatch):
    """When locating fails, the point after the fold is ``fold_unlocated``, listed apart."""

    def fail(*args):
        raise SolverError("the corrector failed while locating a fold")

    monkeypatch.setattr(SpecialPoints, "locate", fail)
    points, summary = arch(MPI.COMM_WORLD, 8, steps=9)
    kinds = [p["kind"] for p in points]
    assert "fold" not in kinds and kinds.count("fold_unlocated") == 1
    after = points[kinds.index("fold_unlocated")]
    assert after["tangent_load"] < 0
    assert summary["folds"] == [] and summary["special_points"] == []
    assert summary["unlocated"] == [after["load_factor"]]


def test_a_failed_switch_keeps_the_path_at_its_last_point(monkeypatch):
    """A switch that fails records nothing: the path ends at the point before the bifurcation."""

    def fail(*args):
        raise SolverError("the arclength step fell below ds_min = 1e-06")

    monkeypatch.setattr(SpecialPoints, "switch", fail)
    outcome, points, summary = plate(MPI.COMM_WORLD, 4, switch=True, steps=6, run=attempt)
    assert not outcome.converged
    assert outcome.reason == "the arclength step fell below ds_min = 1e-06; the last point is kept"
    assert [p["kind"] for p in points] == ["regular"] * len(points)
    assert outcome.steps == len(points) and points[-1]["load_factor"] < 0.99
    assert summary["load_factor"] == points[-1]["load_factor"]
    assert summary["bifurcations"] == []


def test_a_petsc_error_ends_the_path_with_a_reason(monkeypatch):
    """A PETSc error in the stability index ends the run with a reason, not a traceback."""
    points = []

    def fail(self):
        if len(points) == 0:
            points.append(0)  # the start's index is counted
            return hessian(self)
        raise PETSc.Error(73)

    hessian = NewtonSolver.free_hessian
    monkeypatch.setattr(NewtonSolver, "free_hessian", fail)
    outcome, rows, summary = plate(MPI.COMM_WORLD, 4, switch=False, steps=4, run=attempt)
    assert not outcome.converged
    assert outcome.reason.startswith("the Hessian on the free unknowns failed: ")
    assert outcome.reason.endswith("; the last point is kept")
    assert len(rows) == 1 and summary["load_factor"] == rows[0]["load_factor"]


def test_two_live_paths_cannot_share_an_options_prefix():
    """The second path on a live one's prefix is refused; once destroyed, the prefix is free."""
    spec = FvKSpec(
        E=E,
        nu=NU,
        thickness=T,
        simply_supported=["left", "right"],
        path=PathSpec(method="arclength", ds=0.3, steps=2),
    )
    model = build_fvk(spec, rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [2, 2]))
    first = model.driver(None, [], None)
    with pytest.raises(ValueError, match="is in use by a live driver"):
        model.driver(None, [], None)
    first.destroy()
    first.destroy()  # idempotent
    model.driver(None, [], None).destroy()


def test_arch_fold_converges_to_the_exact_limit_load():
    """The fold load factor on 8, 16, 32 cells: error −0.95, −0.24, −0.06 %, O(h²)."""
    folds = [arch(MPI.COMM_WORLD, n, steps=9)[1]["folds"][0] for n in (8, 16, 32)]
    errors = [1.0 - f for f in folds]
    assert errors == pytest.approx([9.45e-3, 2.40e-3, 6.0e-4], rel=0.03)
    assert all(math.log2(a / b) > 1.9 for a, b in itertools.pairwise(errors))


@pytest.mark.mpi
@pytest.mark.parity
def test_same_path_on_any_number_of_ranks():
    """Load factors, indices, kinds and deflections agree between 1 and 2 ranks to 1e-8 (1.2e-10
    measured on 2 and 3 ranks)."""
    parallel, _ = arch(MPI.COMM_WORLD, 16, steps=10)
    serial, _ = arch(MPI.COMM_SELF, 16, steps=10)
    assert [p["kind"] for p in parallel] == [p["kind"] for p in serial]
    assert [p["stability_index"] for p in parallel] == [p["stability_index"] for p in serial]
    for key in ("load_factor", "w_center", "energy"):
        got, expected = ([p[key] for p in run] for run in (parallel, serial))
        assert got == pytest.approx(expected, rel=1e-8, abs=1e-12 * max(map(abs, expected))), key


@pytest.mark.mpi
@pytest.mark.parity
def test_same_switch_on_any_number_of_ranks():
    """The buckled branch after the switch (the critical mode's sign) agrees on 1 and 2 ranks."""
    parallel, _ = plate(MPI.COMM_WORLD, 8, switch=True, steps=8)
    serial, _ = plate(MPI.COMM_SELF, 8, switch=True, steps=8)
    assert [p["kind"] for p in parallel] == [p["kind"] for p in serial]
    assert [p["stability_index"] for p in parallel] == [p["stability_index"] for p in serial]
    for key in ("load_factor", "w_center"):
        got, expected = ([p[key] for p in run] for run in (parallel, serial))
        assert got == pytest.approx(expected, rel=1e-8, abs=1e-12 * T), key


def test_problem_file_writes_the_branch(tmp_path):
    """dgplate run of demos/problems/fvk_arch.toml: from the flat strip (index 1) over the fold."""
    out = tmp_path / "arch"
    sets = ["--set", "output.progress=0", "--set", "output.vtx=false"]
    assert main(["run", str(ARCH), "--out", str(out), *sets]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["folds"] == [pytest.approx(0.99760, abs=2e-5)]
    special = summary["special_points"]
    assert [p["kind"] for p in special] == ["fold"]
    indices = summary["stability_indices"]
    fold = next(i for i, p in enumerate(summary["load_factors"]) if p == summary["folds"][0])
    assert set(indices[:fold]) == {1} and set(indices[fold + 1 :]) == {0}
    header = (out / "history.csv").read_text().splitlines()[0].split(",")
    assert header[:9] == [
        "step", "load_factor", "energy", "stability_index", "tangent_load", "ds",
        "iterations", "branch", "kind",
    ]  # fmt: skip
    assert (out / "branch.png").is_file()


@pytest.mark.parametrize(("stop_at", "crash"), [(4, False), (9, False), (9, True)])
def test_an_interrupted_path_resumes_to_the_same_points(stop_at, crash, tmp_path, monkeypatch):
    """SIGTERM after point 4 (λ rising) or 9 (past the fold, λ falling), or a crash in the step
    after point 9, then ``resume``: the points are those of the uninterrupted path (λ, energy,
    index, kind, step length)."""
    problem = dgplate.load_problem(ARCH, {"output.vtx": False, "output.png": False})
    problem = dataclasses.replace(problem, output=dataclasses.replace(problem.output, progress=0))
    straight = dgplate.run(problem, out=tmp_path / "straight", comm=MPI.COMM_SELF)
    advance = BranchPath._advance

    def advance_then_signal(self):
        if crash and self.step_count >= stop_at:
            self.destroy()  # a dying process takes its PETSc objects and options prefix along
            raise RuntimeError("crash")
        records = advance(self)
        if not crash and self.step_count >= stop_at:
            monkeypatch.setattr(interrupt, "_received", signal.SIGTERM)
        return records

    with monkeypatch.context() as patched:
        patched.setattr(BranchPath, "_advance", advance_then_signal)
        if crash:
            with pytest.raises(RuntimeError, match="crash"):
                dgplate.run(problem, out=tmp_path / "resumed", comm=MPI.COMM_SELF)
        else:
            stopped = dgplate.run(problem, out=tmp_path / "resumed", comm=MPI.COMM_SELF)
            assert stopped["reason"] == "interrupted (SIGTERM)" and stopped["points"] == stop_at
    monkeypatch.setattr(interrupt, "_received", 0)
    resumed = dgplate.run(problem, out=tmp_path / "resumed", comm=MPI.COMM_SELF, resume=True)
    assert resumed["converged"]
    assert resumed["folds"] == pytest.approx(straight["folds"], rel=1e-9)
    rows, expected = resumed.history, straight.history
    assert [r["step"] for r in rows] == list(range(1, len(expected) + 1))
    for key in ("stability_index", "kind", "branch", "iterations"):
        assert [r[key] for r in rows] == [r[key] for r in expected], key
    for key in ("load_factor", "energy", "ds", "w_center"):
        got, want = np.array([[r[key] for r in rows] for rows in (rows, expected)])
        assert np.allclose(got, want, rtol=1e-9, atol=1e-9 * np.abs(want).max()), key


def test_a_path_that_spent_its_points_goes_on_when_resumed_with_more(tmp_path, capsys):
    """The arch with path.steps = 6 ends inside its range: the reason says so and names
    path.steps. --resume without more points is an error naming path.steps; with 10, the path
    goes on to the points of a path run with 10 from the start (over the fold). The progress
    lines show the fold whenever it comes, and the last line names it."""
    sets = {"output.vtx": False, "output.png": False}
    straight = dgplate.run(
        dgplate.load_problem(ARCH, {**sets, "output.progress": 0, "path.steps": 10}),
        out=tmp_path / "straight",
        comm=MPI.COMM_SELF,
    )
    short = dgplate.load_problem(ARCH, {**sets, "path.steps": 6})
    first = dgplate.run(short, out=tmp_path / "path", comm=MPI.COMM_SELF)
    assert first["converged"] and first["points"] == 6 and not first["folds"]
    assert "path.steps = 6 points spent at load factor" in first["reason"]
    with pytest.raises(dgplate.InputError, match=r"raise path\.steps to continue it"):
        dgplate.run(short, out=tmp_path / "path", comm=MPI.COMM_SELF, resume=True)
    capsys.readouterr()
    longer = dgplate.load_problem(ARCH, {**sets, "path.steps": 10})
    resumed = dgplate.run(longer, out=tmp_path / "path", comm=MPI.COMM_SELF, resume=True)
    rows, expected = resumed.history, straight.history
    assert [r["kind"] for r in rows] == [r["kind"] for r in expected] and len(rows) == 10
    assert resumed["folds"] == pytest.approx(straight["folds"], rel=1e-9)
    got, want = ([r["load_factor"] for r in rs] for rs in (rows, expected))
    assert got == pytest.approx(want, rel=1e-9, abs=1e-12)
    lines = capsys.readouterr().out.splitlines()
    fold = resumed["folds"][0]
    assert any(line.startswith("point") and " fold " in line for line in lines)
    assert f"fold at {fold:.6g} (index 1 → 0)" in lines[-1]
    shown = details(read_summary(tmp_path / "path")).splitlines()  # dgplate show
    assert f"fold at {fold:.6g} (index 1 → 0)" in shown[1]
    assert any(re.fullmatch(rf"  folds +\[{fold:.10g}\]", line) for line in shown), shown


def test_a_path_that_spent_its_points_is_extended_not_reused(tmp_path):
    """converge's runner (``run_or_reuse``) reuses a path that spent its points when asked
    for as many, and goes on from it when asked for more; a path stopped after its last
    checkpoint but before its summary goes on when resumed with more points, and keeps its
    budget's reason when resumed with as many (it only writes its outputs)."""
    sets = {"output.vtx": False, "output.png": False, "output.progress": 0, "mesh.cells": [8, 2]}
    short, longer = (dgplate.load_problem(ARCH, {**sets, "path.steps": n}) for n in (4, 6))
    out = tmp_path / "reuse"
    first, _ = run_or_reuse(short, out, MPI.COMM_SELF)
    assert run_or_reuse(short, out, MPI.COMM_SELF, resume=True)[1]  # reused
    more, reused = run_or_reuse(longer, out, MPI.COMM_SELF, resume=True)
    assert not reused and more["points"] == 6 and more.history[:4] == first.history
    out = tmp_path / "unwritten"
    dgplate.run(short, out=out, comm=MPI.COMM_SELF)
    (out / "summary.json").unlink()  # stopped after its checkpoint, before its summary
    again = dgplate.run(short, out=out, comm=MPI.COMM_SELF, resume=True)
    assert again["points"] == 4 and "path.steps = 4 points spent" in again["reason"]
    (out / "summary.json").unlink()
    resumed = dgplate.run(longer, out=out, comm=MPI.COMM_SELF, resume=True)
    assert resumed["points"] == 6 and resumed["load_factors"] == more["load_factors"]


def test_the_special_points_are_named_with_their_indices_six_at_most():
    """The reason's list: the indices of the points on either side ("?" where there is
    none), the unlocated ones, and past six special points how many more."""
    fields = {"energy": 0.0, "tangent_load": 1.0, "ds": 0.1, "iterations": 1, "branch": 0}

    def point(step, kind, index):
        return BranchPoint(step, step / 10, stability_index=index, kind=kind, seconds=0.0, **fields)

    kinds = ["fold", "regular", "bifurcation", "regular", "fold_unlocated"]
    history = [point(i, kind, i) for i, kind in enumerate(kinds)]
    assert special_points_text(history) == (
        "; fold at 0 (index ? → 1), bifurcation at 0.2 (index 1 → 3), fold unlocated before 0.4"
    )
    many = [point(i, "fold" if i % 2 else "regular", i % 2) for i in range(18)]
    text = special_points_text(many)
    assert text.count("fold at") == 6 and text.endswith(", 3 more (summary.json: special_points)")
    assert special_points_text(many[:1]) == ""
    switched = [point(0, "regular", 0), point(1, "bifurcation", 0), point(2, "switch", 0)]
    switched[2] = dataclasses.replace(switched[2], branch=1)
    assert special_points_text(switched) == (
        "; bifurcation at 0.1 (index 0; switched onto a branch of index 0)"
    )


def test_follow_traces_the_arch_through_its_fold(tmp_path):
    """``dgplate.follow``: the shipped arch, its fold at λ = 1 (16 cells: −0.24 %), its indices."""
    problem = dgplate.load_problem(ARCH, {"output.progress": 0, "output.vtx": False})
    branch = dgplate.follow(problem, out=tmp_path / "arch", steps=10)
    assert len(branch.points) == 10 and branch.load_factors[0] == 0.0
    assert len(branch.folds) == 1 and branch.folds[0] == pytest.approx(1.0, rel=5e-3)
    assert branch.stability_indices[0] == 1 and branch.stability_indices[-1] == 0
    assert [p["kind"] for p in branch.special_points] == ["fold"]
    assert "folds at [0.99" in repr(branch) and (tmp_path / "arch" / "branch.png").is_file()


def test_follow_refuses_a_model_without_paths_and_names_a_bad_setting(tmp_path):
    """An lce problem: one clear error; ``ds=0``: the key named, nothing written."""
    plate = dgplate.load_problem(ROOT / "demos" / "problems" / "lce_strip.toml")
    with pytest.raises(dgplate.InputError, match="not available for the lce model"):
        dgplate.follow(plate, out=tmp_path / "plate")
    arch = dgplate.load_problem(ARCH)
    with pytest.raises(dgplate.InputError, match=r"path\.ds must be > 0"):
        dgplate.follow(arch, out=tmp_path / "arch", ds=0)
    with pytest.raises(dgplate.InputError, match=r"path\.method: dgplate\.follow always follows"):
        dgplate.follow(arch, out=tmp_path / "arch", method="load_steps")
    assert not (tmp_path / "plate").exists() and not (tmp_path / "arch").exists()


def turned(comm, n):
    """The buckled strip of demos/problems/fvk_turned_strip.toml, its clamps turned by ±λα."""
    return follow(comm, PATHS.turned_spec(), [n, 1], [[0, 0], [1, 0.05]])


def test_turned_strip_slope_factor_and_thresholds():
    """μ(τ) = α/√(½∫w′²) against quadrature; the thresholds' thin limits μ = 2 and 2.0119."""
    for tau in (6.5, 8.0, 9.2, 11.0):
        M = np.array(
            [
                [1, 0, 1, 0],
                [1, 1, np.cos(tau), np.sin(tau)],
                [0, 1, 0, tau],
                [0, 1, -tau * np.sin(tau), tau * np.cos(tau)],
            ]
        )
        _, b, c, d = np.linalg.solve(M, [0, 0, 1, -1])  # w′(0) = 1 = −w′(1)
        x = np.linspace(0, 1, 200001)
        slope = b - c * tau * np.sin(tau * x) + d * tau * np.cos(tau * x)
        half = 0.5 * np.sum((slope[1:] ** 2 + slope[:-1] ** 2) / 2 * np.diff(x))
        assert turned_strip_slope_factor(tau) == pytest.approx(1 / math.sqrt(half), rel=1e-9)
    assert math.tan(TAU_ANTISYMMETRIC / 2) == pytest.approx(TAU_ANTISYMMETRIC / 2, rel=1e-12)
    assert turned_strip_slope_factor(TAU_ANTISYMMETRIC) == pytest.approx(2.0, rel=1e-12)
    thin = [a / math.sqrt(0.01) for a in clamped_strip_thresholds(0.01, 1e-8)]
    assert thin == pytest.approx([2.0, 2.011905], abs=1e-6)
    with pytest.raises(ValueError, match="too small"):
        clamped_strip_thresholds(1e-4, 0.01)


def test_turned_elastica_tends_to_the_shallow_thresholds_at_first_order_in_the_shortening():
    """The elastica's thresholds differ from the shallow closed forms by O(Δ/L).

    At t²/(12Δ) = the problem file's, Δ = 10⁻⁴ and 10⁻³: the relative differences about 10⁻⁵
    and ten times that; and the unturned inverted state is the clamped elastica's Euler mode.
    """
    differences = []
    for delta in (1e-4, 1e-3):
        t = 0.005 * math.sqrt(delta / 0.01)
        elastica = turned_strip_elastica_thresholds(delta, t, steps=100)
        shallow = clamped_strip_thresholds(delta, t)
        differences.append([elastica[k] / s - 1 for k, s in zip(("bifurcation", "fold"), shallow)])
        assert elastica["tau_bifurcation"] == pytest.approx(TAU_ANTISYMMETRIC, rel=delta)
    assert 0 < differences[0][0] < 2e-5 and 0 < differences[0][1] < 2e-5
    for small, large in zip(*differences, strict=True):
        assert large / small == pytest.approx(10, rel=0.05)
    # α = 0, Δ = 0.1: the inverted state at P = λ² of the clamped elastica has θ(0) = 0
    shape = clamped_elastica(1.0, 0.1)
    height = -shape["height"]  # buckled down
    state = _HalfRod(0.1, 0.0, 200).inverted(shape["lambda"] ** 2, (0.01, 2 * math.pi**2 * height))
    assert abs(state[0]) < 1e-8


def test_turned_strip_bifurcates_then_folds_at_the_closed_forms():
    """32 × 1 cells: the bifurcation (index 0 → 1) and the fold (1 → 2) within 0.8 %."""
    points, summary = turned(MPI.COMM_WORLD, 32)
    kinds = [p["kind"] for p in points]
    assert [k for k in kinds if k != "regular"] == ["bifurcation", "fold"]
    bifurcation, fold = summary["bifurcations"][0], summary["folds"][0]
    assert bifurcation == pytest.approx(0.798850, abs=5e-5)  # +0.71 %, located to ~1e-5
    assert fold == pytest.approx(0.803378, abs=2e-5)  # +0.72 %
    exact = PATHS.TURNED_EXACT
    assert exact == pytest.approx((0.793241, 0.797636), abs=1e-6)
    assert bifurcation == pytest.approx(exact[0], rel=8e-3)
    assert fold == pytest.approx(exact[1], rel=8e-3)
    b, f = kinds.index("bifurcation"), kinds.index("fold")
    indices = [p["stability_index"] for p in points]
    assert (
        set(indices[:b]) == {0} and set(indices[b + 1 : f]) == {1} and set(indices[f + 1 :]) == {2}
    )
    assert points[0]["load_factor"] == 0 and points[0]["w_center"] < 0  # the inverted state


def test_turned_strip_errors_fall_at_second_order():
    """16, 32, 64 cells: both thresholds' errors fall at an observed order ≥ 2."""
    levels = [PATHS.turned_level(MPI.COMM_WORLD, n) for n in (16, 32, 64)]
    for k in range(2):
        errors = [lv["errors"][k] for lv in levels]
        assert errors[0] > errors[1] > errors[2] > 0
        assert all(order >= 2.0 for order in PATHS.orders(errors)[1:])
        assert errors[2] < 2e-3


def test_switched_turned_strip_goes_round_the_closed_form_branch():
    """32 × 1 cells, switched at the bifurcation: the antisymmetric branch, index 1 at every
    point, round through λ = 0 to −λ_b and back; its energy the closed-form parabola Π₀ + kλ²
    (:func:`dgplate.reference.fvk.clamped_strip_antisymmetric_energy`): residual 2.6·10⁻⁵ of
    Π₀, Π₀ +0.87 % and k −0.39 % (second order over the levels of docs/path_following.md)."""
    points, summary = follow(
        MPI.COMM_WORLD, PATHS.turned_spec(30, switch=True), [32, 1], [[0, 0], [1, 0.05]]
    )
    kinds = [p["kind"] for p in points]
    at = kinds.index("switch")
    assert kinds[at - 1] == "bifurcation" and [p["branch"] for p in points[at:]] == [1] * (
        len(points) - at
    )
    branch = PATHS.switched_branch(points)
    assert branch["indices"] == [1]
    assert branch["fit"] < 1e-4
    assert abs(branch["errors"][0]) < 1e-2 and abs(branch["errors"][1]) < 5e-3
    # round to the mirrored bifurcation −λ_b (the points are 0.2 apart along the branch) ...
    bifurcation = summary["bifurcations"][0]
    assert -bifurcation <= branch["lowest"] < -0.99 * bifurcation
    # ... where λ turns (a fold and a crossing at once: reported, not located), and back
    (turn,) = (i for i, kind in enumerate(kinds) if kind.startswith("fold"))
    assert points[turn]["load_factor"] < -0.99 * bifurcation
    after = points[turn:]
    assert all(p["tangent_load"] > 0 for p in after) and after[-1]["load_factor"] > -0.9


def test_turned_strip_natural_state_is_the_closed_form_one():
    """32 × 1 cells from the natural state (buckled up): stable (index 0) at every point, up
    to and past the inverted state's bifurcation λ_b, where that state snaps to it; w_c within
    1.1·10⁻⁴ of :func:`dgplate.reference.fvk.clamped_strip_natural_rise` while compressed."""
    level = PATHS.natural_level(MPI.COMM_WORLD, 32)
    assert level["indices"] == [0] and level["compared"] >= 4
    assert level["last"] > PATHS.TURNED_EXACT[0]
    assert level["error"] == pytest.approx(-1.08e-4, abs=1e-5)
    assert clamped_strip_natural_rise(1e-9, 0.01, 0.005) == pytest.approx(
        2 * math.sqrt(0.01 - (2 * math.pi * 0.005) ** 2 / 12) / math.pi, rel=1e-6
    )  # α → 0: the first clamped Euler mode, w_c = 2A
    with pytest.raises(ValueError, match="no natural state"):
        clamped_strip_natural_rise(0.25, 0.01, 0.005)  # beyond √(6Δ): in tension


def test_a_parameter_holds_the_other_data_at_their_full_values(tmp_path):
    """path.parameter = "clamp_slope": at λ = 0 the end shortening is already applied; a bad
    parameter or a slope without clamps is one line naming the key."""
    points, _ = turned(MPI.COMM_SELF, 16)
    assert points[0]["w_center"] == pytest.approx(-0.06333, rel=1e-3)  # buckled by Δ at λ = 0
    with pytest.raises(dgplate.InputError, match=r"path\.parameter"):
        dgplate.load_problem(TURNED, {"path.parameter": "angle"})
    with pytest.raises(dgplate.InputError, match=r"model\.clamp_slope needs model\.clamped"):
        dgplate.load_problem(TURNED, {"model.clamped": [], "model.membrane": {"left": "fixed"}})
    for name, what in (("pressure", "model.pressure is not set"),
                       ("indentation", "model.indentation is not set"),
                       ("prestrain", "model.prestrain is not set")):  # fmt: skip
        message = f"path.parameter = '{name}' scales nothing: {what}"
        with pytest.raises(dgplate.InputError, match=re.escape(message)):
            dgplate.load_problem(TURNED, {"path.parameter": name})
    with pytest.raises(dgplate.InputError, match=r"model\.membrane has no prescribed displacement"):
        dgplate.load_problem(ARCH, {"path.parameter": "membrane"})
    with pytest.raises(dgplate.InputError, match=r"model\.clamp_slope is not set"):
        dgplate.load_problem(TURNED, {"path.parameter": "clamp_slope", "model.clamp_slope": [0, 0]})
    spec = PATHS.turned_spec()  # the benchmark's constants are the problem file's
    assert (spec.thickness, -spec.membrane["right"][0]) == (PATHS.TURNED_T, PATHS.TURNED_DELTA)
    slope = expressions.evaluate(spec.clamp_slope[0], np.array([[0.0, 0.0], [1.0, 0.0]]), "s")
    assert list(slope) == [PATHS.TURNED_ALPHA, -PATHS.TURNED_ALPHA]
    with pytest.raises(ValueError, match="too thick"):
        clamped_strip_thresholds(0.01, 0.0242)  # t²/(12Δ) = 0.0049: folds first


def test_a_pressure_parameter_follows_the_arch_as_the_load_does():
    """The arch scales only its pressure: path.parameter = "pressure" gives the same path."""
    load = follow(MPI.COMM_SELF, PATHS.arch_spec(6), [8, 2], [[0, 0], [1, 0.1]], PATHS.arch_start)
    spec = dataclasses.replace(
        PATHS.arch_spec(6), path=dataclasses.replace(PATHS.arch_spec(6).path, parameter="pressure")
    )
    pressure = follow(MPI.COMM_SELF, spec, [8, 2], [[0, 0], [1, 0.1]], PATHS.arch_start)
    assert [p["load_factor"] for p in pressure[0]] == [p["load_factor"] for p in load[0]]
    assert [p["energy"] for p in pressure[0]] == [p["energy"] for p in load[0]]


class StandInEngine:
    """A path λ = s along the step s, the state 2s, τ and the crossing eigenvalue
    (0.3 − s)(1 + 2s): a special point at s = 0.3; correctors fail within ``gap`` of it."""

    def __init__(self, gap):
        self.gap, self.s = gap, None
        self.load = types.SimpleNamespace(value=0.0)
        self.load.set = lambda value: setattr(self.load, "value", value)
        vec = PETSc.Vec().createSeq(1, comm=MPI.COMM_SELF)
        self.state = types.SimpleNamespace(
            x=types.SimpleNamespace(petsc_vec=vec, scatter_forward=lambda: None)
        )

    def correct(self, base, s, direction):
        if abs(s - 0.3) < self.gap:
            return None
        self.s, self.load.value = s, s
        self.state.x.petsc_vec.set(2 * s)  # the state along the path: 2s
        return s, 1

    def point(self, lam, direction, iterations):
        return types.SimpleNamespace(lam=lam, x=self.state.x.petsc_vec.getValue(0), index=None)

    def tangent(self, lam, direction):
        return None, (0.3 - self.s) * (1 + 2 * self.s)  # τ: a fold at s = 0.3


def stand_in_eigenvalue(self, k):
    return (0.3 - self.engine.s) * (1 + 2 * self.engine.s)  # the root at s = 0.3


def stand_in_points():
    """The points at s = 0 and 1 of :class:`StandInEngine`'s path: (base, new)."""

    def vector(value):
        return PETSc.Vec().createWithArray([value], comm=MPI.COMM_SELF)

    base = types.SimpleNamespace(t=None, tau=0.3, index=0, lam=0.0, x=vector(0.0))
    new = types.SimpleNamespace(t=None, tau=-2.1, index=1, lam=1.0, x=vector(2.0))
    return base, new


def test_a_bifurcation_is_interpolated_between_its_bracket_when_correctors_fail_beside_it(
    monkeypatch,
):
    """Correctors failing within 10⁻⁶ of the root (the smallest eigenvalue found within
    NEAR_ROOT of the ends'): the root of the eigenvalue interpolated between corrected points
    on its two sides, as near on both (a point corrected across it), stands for it, to 10⁻⁸;
    the state is interpolated alike. Farther off, the failure stands."""
    base, new = stand_in_points()
    monkeypatch.setattr(SpecialPoints, "_crossing_eigenvalue", stand_in_eigenvalue)
    for kind in ("bifurcation", "fold"):
        engine = StandInEngine(1e-6)
        near = SpecialPoints(engine, None).locate(kind, base, new, 1.0)
        assert near.lam != engine.s and near.index == 0  # not the last corrected point
        assert abs(near.lam - 0.3) < 1e-8 and near.x == pytest.approx(2 * near.lam, rel=1e-14)
        with pytest.raises(SolverError, match=f"locating a {kind}"):
            SpecialPoints(StandInEngine(0.2), None).locate(kind, base, new, 1.0)
    # an eigenvalue within round-off of 0 (exactly 0) at the step's end: the root is there
    monkeypatch.setattr(
        SpecialPoints, "_crossing_eigenvalue", lambda self, k: min(self.engine.s - 1, 0.0)
    )
    at_end = SpecialPoints(StandInEngine(0.0), None).locate("bifurcation", new, base, 1.0)
    assert at_end.lam == 1.0 and at_end.x == 2.0


@pytest.mark.parametrize(("tried", "located"), [([0.2999], True), ([], False)])
@pytest.mark.parametrize("kind", ["bifurcation", "fold"])
def test_a_secant_that_spends_its_values_leaves_its_bracket_evened_or_nothing(
    tried, located, kind, monkeypatch
):
    """The secant stops with its bracket wide (here at once): one side near the root (s =
    0.2999 against 1), a point corrected across it evens the bracket, and the root is found to
    10⁻⁷ (taken from the lopsided bracket it would be 5·10⁻⁵ off); both sides far, nothing is
    located."""
    base, new = stand_in_points()
    monkeypatch.setattr(SpecialPoints, "_crossing_eigenvalue", stand_in_eigenvalue)
    monkeypatch.setattr(
        special_points, "secant_root", lambda f, a, fa, b, fb, xtol: [f(s) for s in tried]
    )
    locate = SpecialPoints(StandInEngine(0.0), None).locate
    if located:
        assert abs(locate(kind, base, new, 1.0).lam - 0.3) < 1e-7
    else:
        with pytest.raises(SolverError, match=r"bracket .* wide"):
            locate(kind, base, new, 1.0)


@pytest.mark.mpi
@pytest.mark.parity
def test_same_turned_path_on_any_number_of_ranks():
    """The turned strip's path (16 cells) on 1 and 2 ranks: the same points to 1e-8, the
    located bifurcation too (2.7e-9 in λ measured on 2 and 3 ranks; taken as the nearest
    corrected point instead of interpolated, it differs by 8e-6)."""
    parallel, _ = turned(MPI.COMM_WORLD, 16)
    serial, _ = turned(MPI.COMM_SELF, 16)
    assert [p["kind"] for p in parallel] == [p["kind"] for p in serial]
    assert [p["stability_index"] for p in parallel] == [p["stability_index"] for p in serial]
    for key in ("load_factor", "w_center", "energy"):
        scale = max(abs(p[key]) for p in serial)
        for a, b in zip(parallel, serial, strict=True):
            assert a[key] == pytest.approx(b[key], rel=1e-8, abs=1e-12 * scale), (key, b["kind"])
