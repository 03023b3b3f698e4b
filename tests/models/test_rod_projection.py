"""The rod flow's projection step and the link of closed rods (docs/rods.md).

The flow imposes |u′|² = 1, u′·b = 0 (two moments per cell: for degree 2 the values at the two
Gauss points) and |b|² = 1 (at the nodes) linearised at the previous state, so after n steps of
τ their defects are n·O(τ²) = O(t·τ): at a fixed pseudo-time they halve when τ halves.
``flow.projection_steps = m`` adds m Newton corrections after every step, which bring them to
round-off. For a closed rod that does not pass through itself the link Lk = Tw + Wr
(Călugăreanu) is conserved while the twist Tw and the writhe Wr exchange.
"""

import csv
import json
import math
from itertools import pairwise
from pathlib import Path

from mpi4py import MPI

import pytest
from helpers import PARITY_RTOL, QUIET

import dgplate
from dgplate.cli import main

PROBLEMS = Path(__file__).resolve().parents[2] / "demos" / "problems"
ARC, TWIST, CLOSED = (PROBLEMS / f"rod_{name}.toml" for name in ("arc", "twist", "closed"))
HALF = PROBLEMS / "rod_half_circle.toml"  # only the model: the rod flow's defaults
#: the constraints at the points where the flow imposes them
POINTWISE = ("max_defect_tangent", "max_defect_orthogonality", "defect_frame")
#: a ring twisted 5 times far above Michell's threshold, perturbed, self-avoiding
RING = {
    "model.cells": 96,
    "model.twist": 10 * math.pi,
    "model.c_t": 0.9,
    "model.saddle": 0.05,
    "model.self_avoidance": {"rho": 0.1},
    "flow.tau": 0.1,
}


def run(tmp_path, overrides, name, path=ARC, comm=MPI.COMM_SELF):
    problem = dgplate.load_problem(path, overrides={**QUIET, **overrides})
    out = comm.bcast(tmp_path / name if comm.rank == 0 else None)
    return dgplate.run(problem, out=out, comm=comm)


def test_defects_are_order_tau_without_and_round_off_with_projection(tmp_path):
    """The arc to the pseudo-time 0.8 with τ = 0.02 and 0.01.

    Measured without projection: ratios 1.94–1.97 (defects 9.7·10⁻³, 1.9·10⁻⁶, 1.0·10⁻² at
    τ = 0.02); with two corrections ≤ 3·10⁻¹⁴.
    """
    plain, projected = {}, {}
    for tau, steps in ((0.02, 40), (0.01, 80)):
        settings = {"flow.tau": tau, "flow.max_steps": steps}
        plain[tau] = run(tmp_path, settings, f"plain{steps}")
        projected[tau] = run(tmp_path, {**settings, "flow.projection_steps": 2}, f"proj{steps}")
    for key in POINTWISE:
        assert 1.8 < plain[0.02][key] / plain[0.01][key] < 2.2, key
        assert plain[0.01][key] > 1e-7, key  # far above round-off
        assert projected[0.02][key] < 1e-10 and projected[0.01][key] < 1e-10, key
    for result in (*plain.values(), *projected.values()):
        assert result["energy_increases"] == []
    # the projection moves the state by O(τ²) per step: the same flow to O(τ)
    assert projected[0.01]["energy"] == pytest.approx(plain[0.01]["energy"], rel=0.01)


@pytest.mark.parametrize(
    "path,overrides",
    [
        (TWIST, {}),
        (ARC, {"model.ends": "free-free"}),
        (CLOSED, {"model.kappa": 3.0}),
        (
            CLOSED,
            {
                "model.saddle": 0.5,
                "model.twist": 2 * math.pi,
                "model.confinement": {"radius": 0.1464, "epsilon": 1e-6},
            },
        ),
        (CLOSED, {**RING, "model.cells": 48}),
    ],
    ids=["clamped-guided", "free-free", "closed", "sphere", "self-avoiding"],
)
def test_projection_keeps_every_rod_on_the_constraints(tmp_path, path, overrides):
    """Every end condition, the confinement and the self-avoidance (safe steps): round-off.

    The start is projected too (the interpolated start meets the constraints at the nodes
    only), so the first step is compared with the projected start and the energy falls at
    every step.
    """
    settings = {"flow.max_steps": 20, "flow.projection_steps": 2, **overrides}
    result = run(tmp_path, settings, "out", path=path)
    assert result["energy_increases"] == []
    for key in POINTWISE:
        assert result[key] < 1e-10, key
    rows = list(csv.DictReader((tmp_path / "out" / "history.csv").open()))
    assert all(abs(float(row["energy_change_by_projection"])) < 0.01 for row in rows)


def test_projected_run_resumes_exactly(tmp_path):
    """Interrupted after 10 steps and resumed: the 20-step run's state (checkpoint and resume)."""
    common = [str(CLOSED), "--set=model.kappa=3.0", "--set=flow.projection_steps=2"]
    common += ["--set=output.vtx=false", "--set=output.png=false", "--set=output.progress=0"]
    reference, out = tmp_path / "reference", tmp_path / "resumed"
    assert main(["run", *common, "--out", str(reference), "--set=flow.max_steps=20"]) == 1
    assert main(["run", *common, "--out", str(out), "--set=flow.max_steps=10"]) == 1
    assert main(["run", *common, "--out", str(out), "--set=flow.max_steps=20", "--resume"]) == 1
    expected, resumed = (json.loads((p / "summary.json").read_text()) for p in (reference, out))
    assert resumed["steps"] == expected["steps"] == 20
    for key in ("energy", "link", *POINTWISE):
        assert resumed[key] == pytest.approx(expected[key], rel=1e-10, abs=1e-14), key


def test_adaptive_run_resumes_with_its_tau(tmp_path):
    """The half circle at the defaults stopped after 20 steps and resumed to 40: the 40-step
    run's τ, redone steps and energy (the checkpoint holds the grown τ)."""
    common = [str(HALF), "--set=output.vtx=false", "--set=output.png=false"]
    common += ["--set=output.progress=0"]
    reference, out = tmp_path / "reference", tmp_path / "resumed"
    assert main(["run", *common, "--out", str(reference), "--set=flow.max_steps=40"]) == 1
    assert main(["run", *common, "--out", str(out), "--set=flow.max_steps=20"]) == 1
    stopped = json.loads((out / "summary.json").read_text())
    assert main(["run", *common, "--out", str(out), "--set=flow.max_steps=40", "--resume"]) == 1
    expected, resumed = (json.loads((p / "summary.json").read_text()) for p in (reference, out))
    assert stopped["tau"] < expected["tau"]  # τ grew after step 20
    for key in ("steps", "rejected_steps", "tau"):
        assert resumed[key] == expected[key], key
    # measured: 2.5·10⁻¹⁰ relative (7·10⁻¹² absolute) after 20 resumed steps of τ up to 10³h
    assert resumed["energy"] == pytest.approx(expected["energy"], rel=1e-8)


def test_link_is_conserved_while_twist_turns_into_writhe(tmp_path):
    """A ring twisted 5 times far above Michell's threshold (c_t k = 2.6 √3 c_b), perturbed by
    the saddle a = 0.05, self-avoiding (ρ = 0.1), 96 cells, one projection per step.

    Measured (100 steps of τ = 0.1): Tw 4.909 → 3.999, Wr 0 → 0.946, the largest step of Wr 0.062
    (no crossing, which would change it by ±2), Lk = Tw + Wr within 0.036 of its start
    (without projection the same run drifts by 0.2 over 150 steps).
    """
    overrides = {**RING, "flow.max_steps": 100, "flow.projection_steps": 1}
    result = run(tmp_path, overrides, "ring", path=CLOSED)
    assert result["energy_increases"] == []
    rows = list(csv.DictReader((tmp_path / "ring" / "history.csv").open()))
    twist = [float(row["twist_angle"]) / (2 * math.pi) for row in rows]
    wr = [float(row["writhe"]) for row in rows]
    lk = [float(row["link"]) for row in rows]
    assert max(abs(a - b) for a, b in pairwise(wr)) < 0.2  # no crossing
    assert wr[-1] > 0.8 and twist[0] - twist[-1] > 0.8  # about one turn exchanged
    assert max(abs(value - lk[0]) for value in lk) < 0.05  # while Lk stays
    assert result["link"] == pytest.approx(lk[-1], abs=1e-12)  # summary.json: the last state


def test_negative_projection_steps_is_an_input_error(tmp_path, capsys):
    code = main(
        ["run", str(ARC), "--out", str(tmp_path / "o"), "--set", "flow.projection_steps=-1"]
    )
    err = capsys.readouterr().err
    assert code == 2 and "flow.projection_steps must be >= 0, got -1" in err, err
    assert err.count("\n") == 1 and not (tmp_path / "o").exists()


@pytest.mark.mpi
@pytest.mark.parametrize(
    "path,overrides",
    [
        (ARC, {"model.c_t": 0.3, "model.frame": [0.0, 0.6, 0.8]}),
        (CLOSED, {"model.kappa": 3.0, "model.twist": 2 * math.pi}),
        (HALF, {}),
    ],
    ids=["arc", "closed", "adaptive"],
)
def test_projected_rod_same_on_any_number_of_ranks(tmp_path, path, overrides):
    overrides = {"flow.max_steps": 30, "flow.projection_steps": 2, **overrides}
    serial = run(tmp_path, overrides, "serial", path=path)
    parallel = run(tmp_path, overrides, "parallel", path=path, comm=MPI.COMM_WORLD)
    assert parallel["steps"] == serial["steps"]
    assert parallel.get("rejected_steps") == serial.get("rejected_steps")
    assert parallel["energy"] == pytest.approx(serial["energy"], rel=PARITY_RTOL)
    # the arc's twist angle is 0 up to round-off (~10⁻¹²): hence the absolute tolerance
    for key in ("energy_torsion", "twist_angle", "link", "arc_error"):
        assert parallel.get(key, 0.0) == pytest.approx(serial.get(key, 0.0), rel=1e-8, abs=1e-10)
    for key in POINTWISE:  # round-off on both
        assert serial[key] < 1e-10 and parallel[key] < 1e-10, key
