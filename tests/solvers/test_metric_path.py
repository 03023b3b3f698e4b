"""A path in the target metric: G_λ = I + λ(G − I) (``path.parameter = "metric"``).

The prestrained disc of demos/problems/spherical_disc.toml (a free disc whose metric is that
of a sphere of radius 2), coarse (h = 0.4, 112 cells), followed in λ from the flow's minimiser
at ``path.lambda_start`` = 0.5: the flat plate at λ = 0 is critical in every curving mode, so
the path cannot start there. Each point is the flow's minimiser for the metric G_λ, the
constraint ∇yᵀ∇y = G_λ holds to round-off, and the cap grows stably.
"""

import itertools

from mpi4py import MPI

import pytest
from helpers import PROBLEMS, assert_same_points

import dgplate
from dgplate.errors import InputError
from dgplate.problems.advice import path_only

DISC = PROBLEMS / "spherical_disc.toml"
SETTINGS = {"mesh.parameters.h": 0.4, "output.vtx": False, "output.png": False}
METRIC_PATH = {"path.parameter": "metric", "path.lambda_start": 0.5}


def metric_path(comm, out):
    """The disc from λ = 0.5, ds = 0.1, 5 points (to λ = 1.13, past the range [−1, 1])."""
    problem = dgplate.load_problem(DISC, {**SETTINGS, **METRIC_PATH})
    return dgplate.follow(problem, out=out, comm=comm, ds=0.1, steps=8)


@pytest.fixture(scope="module")
def grown(tmp_path_factory):
    """The path on one rank."""
    return metric_path(MPI.COMM_SELF, tmp_path_factory.mktemp("metric") / "path")


def scaled_metric(lam: float) -> dict[str, str]:
    """The disc's [model.metric] formulas of G_λ = I + λ(G − I)."""
    given = dgplate.load_problem(DISC).raw["model"]["metric"]
    one = {"g11": 1, "g12": 0, "g22": 1}
    return {key: f"{one[key]} + {lam!r}*(({text}) - {one[key]})" for key, text in given.items()}


def test_the_path_starts_at_the_flows_minimiser_and_grows_stably(grown):
    """The first point at λ₀ = 0.5; every point: index 0, the constraint of G_λ to round-off
    (measured ≤ 5·10⁻¹⁴), λ, the energy and the cap's height rising; the path ends when λ
    leaves [−1, 1]."""
    points = grown.points
    summary = grown.result.summary
    assert summary["converged"] and "left its range" in summary["reason"]
    assert points[0]["load_factor"] == 0.5 and len(points) == 5
    assert grown.stability_indices == [0] * len(points)
    assert grown.folds == [] and grown.bifurcations == []
    assert max(p["isometry_defect"] for p in points) < 1e-12
    for key in ("load_factor", "energy", "height"):
        assert all(b[key] > a[key] for a, b in itertools.pairwise(points)), key


def test_the_start_is_the_flows_minimiser_for_the_metric_written_out(grown, tmp_path):
    """At λ₀ = 0.5, the flow with the metric G_λ₀ written out as formulas (stopped at the
    file's ‖P DE_h‖_*' < 1e-8) reaches the path's first energy (measured 6·10⁻¹⁴ apart,
    relatively): the path scales the metric as I + λ(G − I)."""
    settings = {**SETTINGS, "model.metric": scaled_metric(0.5)}
    result = dgplate.run(dgplate.load_problem(DISC, settings), tmp_path / "flow", MPI.COMM_SELF)
    assert result.summary["converged"]
    assert grown.points[0]["energy"] == pytest.approx(result.summary["energy"], rel=1e-9)


def test_each_point_is_the_flows_minimiser_at_its_load_factor(grown, tmp_path):
    """The third point (λ = 0.684): a path started there, from the flow's minimiser at that λ,
    starts at the same energy (measured 10⁻¹⁴ apart, relatively)."""
    point = grown.points[2]
    problem = dgplate.load_problem(
        DISC, {**SETTINGS, **METRIC_PATH, "path.lambda_start": point["load_factor"]}
    )
    there = dgplate.follow(problem, out=tmp_path / "there", comm=MPI.COMM_SELF, steps=2)
    assert there.points[0]["load_factor"] == point["load_factor"]
    assert there.points[0]["energy"] == pytest.approx(point["energy"], rel=1e-9)


def test_a_resumed_metric_path_goes_on_to_the_same_points(grown, tmp_path, capsys):
    """Stopped after 3 points and resumed, without the flow to the start again and with the
    pins where the path had them: the uninterrupted path's points."""
    problem = dgplate.load_problem(DISC, {**SETTINGS, **METRIC_PATH})
    dgplate.follow(problem, out=tmp_path / "part", comm=MPI.COMM_SELF, ds=0.1, steps=3)
    assert "the flow's minimiser at path.lambda_start" in capsys.readouterr().out
    resumed = dgplate.follow(
        problem, out=tmp_path / "part", comm=MPI.COMM_SELF, ds=0.1, steps=8, resume=True
    )
    assert "the flow's minimiser" not in capsys.readouterr().out
    for key in ("load_factor", "energy"):
        got, expected = ([p[key] for p in run.points] for run in (resumed, grown))
        assert got == pytest.approx(expected, rel=1e-9), key


@pytest.mark.mpi
@pytest.mark.parity
def test_same_metric_path_on_any_number_of_ranks(tmp_path):
    """The points' λ, energies and heights on 1 and 2 ranks to 1e-8."""
    parallel = metric_path(MPI.COMM_WORLD, tmp_path / "world")
    serial = metric_path(MPI.COMM_SELF, tmp_path / f"self{MPI.COMM_WORLD.rank}")
    assert_same_points(parallel, serial, ("load_factor", "energy", "height"))


def test_the_flow_keys_are_read_by_a_path_that_starts_with_the_flow():
    """[flow] has no effect on a path from λ = 0 (its keys are warned about), but the flow to
    a start at λ₀ ≠ 0 reads them all but its checkpoints."""
    flat = dgplate.load_problem(DISC, {"path.method": "arclength", "path.parameter": "load"})
    assert any("flow.tau has no effect" in line for line in path_only(flat))
    started = dgplate.load_problem(DISC, {"path.method": "arclength", **METRIC_PATH})
    assert path_only(started) == []
    path = {"path.method": "arclength", **METRIC_PATH}
    saved = dgplate.load_problem(DISC, {**path, "flow.checkpoint_every": 5})
    (warning,) = path_only(saved)
    assert warning.startswith("flow.checkpoint_every has no effect on the flow to the path's")


@pytest.mark.parametrize(
    ("name", "setting", "message"),
    [
        ("spherical_disc", {"path.parameter": "metric"}, "needs path.lambda_start > 0"),
        ("spherical_disc", {**METRIC_PATH, "path.lambda_start": -0.5}, "lambda_start > 0"),
        ("spherical_disc", {"path.lambda_start": 1.0}, r"path.lambda_start = 1 must lie inside"),
        ("bilayer_cylinder", METRIC_PATH, "needs a target metric"),
    ],
)
def test_bad_metric_paths_are_refused_naming_the_key(name, setting, message):
    with pytest.raises(InputError, match=message.replace("path.", r"path\.")):
        dgplate.load_problem(PROBLEMS / f"{name}.toml", {"path.method": "arclength", **setting})


def test_a_metric_that_is_not_positive_definite_along_the_path_is_refused():
    """The hyperbolic disc's G (eigenvalues up to sinh²1 = 1.38) scaled to λ = −3.5, as far as
    the path can reach with lambda_max = 3 and ds_max = 0.5, is indefinite: refused before
    anything is solved, naming the keys."""
    problem = dgplate.load_problem(
        PROBLEMS / "hyperbolic_disc.toml",
        {**SETTINGS, "path.method": "arclength", **METRIC_PATH, "path.lambda_max": 3.0},
    )
    with pytest.raises(InputError, match=r"ds_max\): G_λ at λ = -3\.5 is not symmetric"):
        dgplate.check(problem, comm=MPI.COMM_SELF)


def test_a_start_whose_flow_does_not_converge_ends_the_path_with_its_reason(tmp_path):
    """A flow to the start stopped by its budget: no point, not converged, the flow's reason."""
    problem = dgplate.load_problem(DISC, {**SETTINGS, **METRIC_PATH, "flow.max_steps": 1})
    branch = dgplate.follow(problem, out=tmp_path / "path", comm=MPI.COMM_SELF, steps=3)
    summary = branch.result.summary
    assert not summary["converged"] and branch.points == []
    assert summary["reason"].startswith("path.lambda_start: the flow to the path's start did not")
    assert "step budget of 1 steps spent" in summary["reason"]
