"""Arclength continuation of an isometry-constrained plate (dgplate.solvers.constrained_path).

The turned strip of demos/problems/turned_strip.toml (a Kirchhoff plate, benchmarks/plate_path.py
at the finer levels): an inextensible strip buckled down, its clamps turned against the buckle
by angles, bifurcates and folds where the inextensible elastica does, at second order in h.

The bilayer cylinder of demos/problems/bilayer_cylinder.toml (a 2 × 1 rectangle clamped on
its short side, the file's penalties and constraint settings) on 8 × 4 Q2 cells, followed in
the amplitude λ of Z = λI from the flat plate. Each point is the discrete minimiser the flow
reaches at the same Z; the discrete constraint holds to round-off without projections; the
path is stable (index 0) and rolls towards the cylinder E = ½λ²|ω|. Unclamped, the same plate
bifurcates from its nearly flat branch onto a rolled one.
"""

import itertools

from mpi4py import MPI

import pytest
from helpers import PARITY_RTOL, PROBLEMS, assert_same_points, load_benchmark

import dgplate
from dgplate.errors import InputError
from dgplate.solvers.special_points import SECANT_WIDTH

TURNED = load_benchmark("plate_path")

CYLINDER = PROBLEMS / "bilayer_cylinder.toml"
SETTINGS = {"mesh.cells": [8, 4], "output.vtx": False, "output.progress": 0}
AREA = 2.0


def cylinder_path(comm, out, **path):
    """The path of the cylinder on 8 × 4 cells from λ = 0 (ds = 0.25, 6 points)."""
    problem = dgplate.load_problem(CYLINDER, SETTINGS)
    return dgplate.follow(problem, out=out, comm=comm, ds=0.25, steps=6, **path)


@pytest.fixture(scope="module")
def branch(tmp_path_factory):
    """The path on one rank."""
    return cylinder_path(MPI.COMM_SELF, tmp_path_factory.mktemp("cylinder") / "path")


def test_each_point_is_the_flows_minimiser(branch, tmp_path):
    """At the λ of the fourth point (0.556), the flow from the flat plate, stopped at
    ‖P DE_h‖_*' < 1e-10, reaches the same energy (measured: 3·10⁻¹⁴ apart, relatively)."""
    point = branch.points[3]
    flow = {"flow.stop": "stationarity", "flow.tol": 1e-10, "flow.adaptive_tau": True}
    problem = dgplate.load_problem(
        CYLINDER, {**SETTINGS, **flow, "model.Z": point["load_factor"], "output.png": False}
    )
    result = dgplate.run(problem, tmp_path / "flow", MPI.COMM_SELF)
    assert result.summary["converged"]
    assert point["energy"] == pytest.approx(result.summary["energy"], rel=1e-9)


def test_the_path_holds_the_constraint_and_is_stable(branch):
    """Every point: the discrete constraint to round-off (measured ≤ 1.5·10⁻¹⁵), index 0, λ and
    the energy rising; the path ends when λ leaves [−1, 1]."""
    points = branch.points
    assert len(points) == 6 and branch.result.summary["converged"]
    assert "left its range" in branch.result.summary["reason"]
    assert max(p["isometry_defect"] for p in points) < 1e-13
    assert branch.stability_indices == [0] * 6
    assert branch.folds == [] and branch.bifurcations == []
    lams, energies = branch.load_factors, [p["energy"] for p in points]
    assert lams[0] == 0.0 and abs(energies[0]) < 1e-20
    assert all(b > a for a, b in itertools.pairwise(lams))
    assert all(b > a for a, b in itertools.pairwise(energies))
    assert all(p["tangent_load"] > 0 for p in points)


def test_the_rolled_plate_has_the_cylinders_energy(branch):
    """At λ = 1.137 the energy is ½λ²|ω| within 0.5 % (measured −0.11 %; the flow at λ = 1 on
    these cells: −1.25 %, docs/bilayer.md) and the fitted radius 1/λ within 8 % (measured
    +5.3 %: the shape converges more slowly than the energy). Nearer flat the 8 × 4 plate lies far below it
    (−31 % at λ = 0.19): the cell moments of the constraint let a slightly curved plate curve
    in two directions (issue of accuracy, not of the path: the flow finds the same states)."""
    last = branch.points[-1]
    exact = 0.5 * last["load_factor"] ** 2 * AREA
    assert last["load_factor"] > 1.0
    assert last["energy"] == pytest.approx(exact, rel=5e-3)
    radius = branch.result.summary["cylinder_fit"]["radius"]
    assert radius == pytest.approx(1 / last["load_factor"], rel=0.08)


@pytest.mark.mpi
@pytest.mark.parity
def test_same_path_on_any_number_of_ranks(tmp_path):
    """Load factors and energies agree between 1 and 2 ranks to 1e-8 (measured 10⁻¹⁰)."""
    parallel = cylinder_path(MPI.COMM_WORLD, tmp_path / "world")
    serial = cylinder_path(MPI.COMM_SELF, tmp_path / f"self{MPI.COMM_WORLD.rank}")
    assert_same_points(parallel, serial, ("load_factor", "energy"), abs=1e-14)


def free_path(comm, out):
    """The cylinder's bilayer unclamped, on 8 × 4 cells from λ = 0: ds 0.1 to 0.25, the
    switch at the bifurcation, until λ leaves [−1.5, 1.5]."""
    free = {"model.clamped": [], "path.switch": True, "path.lambda_max": 1.5, "path.ds_max": 0.25}
    problem = dgplate.load_problem(CYLINDER, {**SETTINGS, **free})
    return dgplate.follow(problem, out=out, comm=comm, ds=0.1, steps=11)


@pytest.fixture(scope="module")
def free(tmp_path_factory):
    """The free plate's path on one rank."""
    return free_path(MPI.COMM_SELF, tmp_path_factory.mktemp("free") / "path")


def test_a_free_plate_bifurcates_and_rolls_into_the_cylinder(free):
    """A free plate, its rigid motions held by six pins (dgplate.solvers.rigid_pins): stable
    (index 0) throughout; one bifurcation (λ = 0.573 on these cells, 0.657 on 16 × 8: the
    weak discrete constraint lets the nearly flat plate curve both ways until then), switched
    onto the rolled branch, along which λ and the height rise. At λ = 1.5 the energy is ½λ²|ω|
    within 3 % (measured −2.3 %; −0.85 % at λ = 1.62 on 16 × 8 cells) and the fitted radius 1/λ
    within 5 % (measured +2.2 %); the constraint holds to round-off (≤ 2·10⁻¹³)."""
    summary = free.result.summary
    assert summary["converged"] and "left its range" in summary["reason"]
    assert free.stability_indices == [0] * len(free.points)
    assert free.folds == [] and len(free.bifurcations) == 1
    assert 0.5 < free.bifurcations[0] < 0.65
    switched = [p for p in free.points if p["branch"] == 1]
    assert switched[0]["kind"] == "switch" and len(switched) >= 3
    lams, heights = [p["load_factor"] for p in switched], [p["height"] for p in switched]
    assert all(b > a for a, b in itertools.pairwise(lams))
    assert all(b > a for a, b in itertools.pairwise(heights))
    assert max(p["isometry_defect"] for p in free.points) < 1e-12
    last = free.points[-1]
    assert last["energy"] == pytest.approx(0.5 * last["load_factor"] ** 2 * AREA, rel=0.03)
    assert summary["cylinder_fit"]["radius"] == pytest.approx(1 / last["load_factor"], rel=0.05)


@pytest.mark.mpi
@pytest.mark.parity
def test_same_free_path_on_any_number_of_ranks(tmp_path):
    """The pins do not depend on the partition: before the bifurcation the free plate's load
    factors, energies and heights agree between 1 and 2 ranks to 1e-8, and so does the
    bifurcation's λ. The located point's state and the switched branch agree to 1e-6 only
    (measured 1.6·10⁻⁷): the bifurcation lies where the branch is nearly vertical
    (dλ/ds = 1.8·10⁻⁴), the eigenvalue that locates it changes slowly along s, and each
    partition's round-off puts the point elsewhere along s (the height there differs by
    6·10⁻⁸; a secant stopped 1000 times tighter changes the differences by 20 % only)."""
    parallel = free_path(MPI.COMM_WORLD, tmp_path / "world")
    serial = free_path(MPI.COMM_SELF, tmp_path / f"self{MPI.COMM_WORLD.rank}")
    assert parallel.stability_indices == serial.stability_indices
    assert parallel.bifurcations == pytest.approx(serial.bifurcations, rel=PARITY_RTOL)
    kinds = [p["kind"] for p in serial.points]
    assert [p["kind"] for p in parallel.points] == kinds
    located = kinds.index("bifurcation")
    for key in ("load_factor", "energy", "height"):
        got, expected = ([p[key] for p in run.points] for run in (parallel, serial))
        before = slice(0, located)
        assert got[before] == pytest.approx(expected[before], rel=PARITY_RTOL, abs=1e-14), key
        after = slice(located, None)
        assert got[after] == pytest.approx(expected[after], rel=1e-6), key


@pytest.mark.parametrize(
    ("name", "setting", "message"),
    [
        (
            "bilayer_cylinder",
            {"model.clamped": [], "model.load": [0, 0, 1]},
            "model.load: not on a free plate",
        ),
        (
            "turned_strip",
            {"model.clamped": []},
            "path.parameter = 'boundary_data' needs model.clamped",
        ),
        ("bilayer_cylinder", {"model.hessian": "ldg"}, "model.hessian: not with path.method"),
        ("bilayer_cylinder", {"model.space": "c0"}, "model.space: not with path.method"),
        ("bilayer_cylinder", {"path.parameter": "pressure"}, "path.parameter"),
        ("bilayer_cylinder", {"path.ds": 0.0}, "path.ds must be > 0"),
        ("turned_strip", {"path.parameter": "natural_curvature"}, "the kirchhoff model has no Z"),
        ("lce_strip", {}, "the lce model has no path following"),
    ],
)
def test_what_the_path_cannot_follow_is_refused_naming_the_key(name, setting, message):
    """A load on a free plate, moving data without clamps, a lifted Hessian, a continuous y, an
    unknown parameter, a step ≤ 0, a Kirchhoff plate's Z, an LCE plate's path: one InputError
    each."""
    with pytest.raises(InputError, match=message.replace(".", r"\.")):
        dgplate.load_problem(
            PROBLEMS / f"{name}.toml", {**SETTINGS, "path.method": "arclength", **setting}
        )


@pytest.fixture(scope="module")
def turned(tmp_path_factory):
    """The turned strip's study on 16 and 32 cells, one rank (benchmarks/plate_path.py; its
    JSON has the finer levels, tests/app/test_benchmarks.py checks them)."""
    return TURNED.measure(MPI.COMM_SELF, [16, 32])["turned"]


def test_turned_strip_bifurcates_and_folds_where_the_elastica_does(turned):
    """Index 0 → 1 at the bifurcation, 1 → 2 at the fold; both within 0.7 % of the inextensible
    elastica's on 32 cells (measured +0.600 % and +0.611 %), converging at second order
    (measured 2.11 from 16 cells), the constraint to round-off at every corrected point."""
    for level in turned:
        assert level["indices"] == [0, 1, 2] and level["defect"] < 1e-10
    for k in range(2):
        errors = [level["errors"][k] for level in turned]
        assert errors[0] == pytest.approx(0.026, abs=1e-3) and 0 < errors[-1] < 7e-3
        assert turned[1]["orders"][k] > 1.9


@pytest.mark.mpi
@pytest.mark.parity
def test_same_turned_path_on_any_number_of_ranks(tmp_path):
    """The turned strip's points, indices, bifurcation and fold on 1 and 2 ranks to 1e-8."""
    problem = dgplate.load_problem(
        PROBLEMS / "turned_strip.toml", {**TURNED.QUIET, "mesh.cells": [16, 1]}
    )
    parallel = dgplate.follow(problem, out=tmp_path / "world", comm=MPI.COMM_WORLD)
    own = tmp_path / f"self{MPI.COMM_WORLD.rank}"
    serial = dgplate.follow(problem, out=own, comm=MPI.COMM_SELF)
    assert parallel.stability_indices == serial.stability_indices
    assert [p["kind"] for p in parallel.points] == [p["kind"] for p in serial.points]
    assert parallel.bifurcations == pytest.approx(serial.bifurcations, rel=PARITY_RTOL)
    assert parallel.folds == pytest.approx(serial.folds, rel=PARITY_RTOL)
    lams = [run.load_factors for run in (parallel, serial)]
    assert lams[0] == pytest.approx(lams[1], rel=PARITY_RTOL, abs=1e-12)


def test_a_resumed_plate_path_goes_on_to_the_same_points(tmp_path):
    """The turned strip stopped after 8 points and resumed to 14 has the uninterrupted path's
    points, bifurcation and fold.

    The states agree to about 10⁻¹¹, not bit for bit; the secant that locates the bifurcation
    stops within SECANT_WIDTH·ds, and the located λ moved by 1.0·10⁻⁹ (relative 1.2·10⁻⁹) in
    one run. So the points are compared within the secant's width (2·10⁻⁷ here); a point of
    a path resumed from the wrong state differs by a sizeable fraction of ds.
    """
    settings = {**TURNED.QUIET, "mesh.cells": [16, 1]}
    problem = dgplate.load_problem(PROBLEMS / "turned_strip.toml", settings)
    whole = dgplate.follow(problem, out=tmp_path / "whole", comm=MPI.COMM_SELF, steps=14)
    dgplate.follow(problem, out=tmp_path / "part", comm=MPI.COMM_SELF, steps=8)
    resumed = dgplate.follow(
        problem, out=tmp_path / "part", comm=MPI.COMM_SELF, steps=14, resume=True
    )
    width = SECANT_WIDTH * problem.raw["path"]["ds_max"]
    assert resumed.stability_indices == whole.stability_indices
    assert resumed.load_factors == pytest.approx(whole.load_factors, rel=0, abs=width)
    assert resumed.bifurcations == pytest.approx(whole.bifurcations, rel=0, abs=width)
    assert resumed.folds == pytest.approx(whole.folds, rel=0, abs=width)


def test_the_turned_strip_switches_onto_an_unstable_branch(tmp_path):
    """With path.switch the path leaves the bifurcation along the critical mode: onto a branch
    of index 1 on which λ falls (the antisymmetric branch, as the FvK strip's)."""
    settings = {**TURNED.QUIET, "mesh.cells": [16, 1]}
    problem = dgplate.load_problem(PROBLEMS / "turned_strip.toml", settings)
    branch = dgplate.follow(problem, out=tmp_path / "path", comm=MPI.COMM_SELF, switch=True)
    assert [p["kind"] for p in branch.special_points] == ["bifurcation", "switch"]
    after = [p for p in branch.points if p["branch"] == 1]
    assert len(after) >= 3 and {p["stability_index"] for p in after} == {1}
    lams = [p["load_factor"] for p in after]
    assert lams == sorted(lams, reverse=True) and lams[0] < branch.bifurcations[0]
    assert max(p["isometry_defect"] for p in after) < 1e-10
