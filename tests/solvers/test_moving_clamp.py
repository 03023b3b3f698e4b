"""Clamped data moved along a path in α (model.continuation, docs/continuation.md).

Exact answers: clamped data moved by a rigid motion (a flap turned about its clamped edge and
lifted) keep the plate rigid, E_h = 0 and the flap at the rotated place; a strip whose clamped
ends are pushed together buckles into the clamped–clamped elastica (closed form in elliptic
integrals, :mod:`dgplate.reference.elastica`).
"""

import itertools
import math
import re
import subprocess
import sys

from mpi4py import MPI

import pytest
from helpers import PARITY_RTOL

import dgplate
from dgplate.reference.elastica import clamped_elastica, elliptic_ke

ANGLE = math.pi / 4  # the flap's final rotation about its clamped edge x = 0
LIFT = 0.1  # and its final lift

# A flap (0, 2) × (0, 1) clamped at x = 0 with data turned by α·π/4 about that edge and lifted
# by 0.1·α: a rigid motion for every α, so the minimiser of every stage is the rigid flap.
FLAP = {
    "mesh": {"corners": [[0.0, 0.0], [2.0, 1.0]], "cells": [4, 2]},
    "model": {
        "clamped": ["left"],
        "continuation": {"steps": 4, "stage_steps": 60},
        "boundary_data": {
            "g": [
                "x*cos(0.7853981633974483*alpha)",
                "y",
                "x*sin(0.7853981633974483*alpha) + 0.1*alpha",
            ]
        },
    },
    "flow": {"tau": 0.5, "tol": 1e-8, "projection_steps": 2, "linear_solver": "direct"},
    "output": {"png": False, "vtx": False, "progress": 0},
}


def flap(**overrides: object) -> dgplate.Problem:
    return dgplate.problem_from_dict(FLAP, "flap", overrides)


def out_dir(tmp_path, comm):
    """One output folder for all ranks of ``comm`` (each rank has its own tmp_path)."""
    return comm.bcast(tmp_path / "out" if comm.rank == 0 else None)


def check_rigid_flap(result) -> None:
    """E_h = 0 and the flap turned by π/4 and lifted: the tip at height 2 sin(π/4) + 0.1."""
    assert result["converged"], result["reason"]
    assert result["alpha"] == 1.0
    assert abs(result["energy"]) < 1e-6
    assert result["isometry_defect"] < 1e-8
    assert result["bbox"][1][2] == pytest.approx(2 * math.sin(ANGLE) + LIFT, abs=1e-4)
    assert result["energy_increases"] == []


@pytest.mark.mpi
@pytest.mark.parametrize(
    "model",
    [{}, {"model.name": "bilayer", "model.Z": 0.0}, {"model.name": "lce", "model.gamma": 0.0}],
    ids=["kirchhoff", "bilayer", "lce"],
)
def test_rigid_motion_of_the_data_gives_a_rigid_plate(tmp_path, comm, model):
    """Kirchhoff, and a bilayer or LCE plate without spontaneous curvature: the same rigid
    flap."""
    result = dgplate.run(flap(**model), out=out_dir(tmp_path, comm), comm=comm)
    check_rigid_flap(result)
    # α along the path: every step reports its α, the stages in order, each ending converged
    alphas = [row["alpha"] for row in result.history]
    assert sorted(set(alphas)) == [0.25, 0.5, 0.75, 1.0] and alphas == sorted(alphas)
    path = result["alpha_path"]
    assert [s["alpha"] for s in path] == [0.25, 0.5, 0.75, 1.0]
    assert all(s["converged"] and abs(s["energy"]) < 1e-6 for s in path)
    assert result["continuation_stage"] == result["continuation_stages"] == 4


def test_progress_lines_estimate_when_alpha_reaches_one(tmp_path, capsys):
    """Once a stage has ended (the pace is known), the lines end with the time elapsed and
    left to α = 1 until the last stage starts; the last stage's lines (its length is unknown)
    estimate from the decay of the stopping test instead."""
    dgplate.run(flap(**{"output.progress": 1}), out=tmp_path / "o", comm=MPI.COMM_SELF)
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("α =")]
    alphas = ("0.25", "0.50", "0.75", "1.00")
    stage = {a: [line for line in lines if line.startswith(f"α = {a}")] for a in alphas}
    assert all(stage.values())
    assert not any("α = 1 in" in line for line in stage["0.25"][:-1] + stage["1.00"])
    # the units depend on the machine's pace (a loaded machine may take a minute), not the form
    timed = re.compile(r"\(\d[\d.]* (s|min|h); α = 1 in ~\d[\d.]* (s|min|h)\)$")
    assert all(timed.search(line) for line in stage["0.50"]), stage["0.50"]


@pytest.mark.mpi
def test_resume_keeps_alpha(tmp_path, comm):
    """A run stopped in the second stage resumes there (any number of ranks) and ends where an
    uninterrupted run ends."""
    out = out_dir(tmp_path, comm)
    straight = dgplate.run(flap(), out=tmp_path / "straight", comm=MPI.COMM_SELF)
    stage_one = straight["alpha_path"][0]["steps"]  # then the run stops 2 steps into stage 2
    first = dgplate.run(flap(**{"flow.max_steps": stage_one + 2}), out=out, comm=comm)
    assert not first["converged"] and first["alpha"] == 0.5
    assert first["continuation_stage"] == 2
    resumed = dgplate.run(flap(), out=out, comm=comm, resume=True)
    check_rigid_flap(resumed)
    rows = resumed.history
    assert [row["step"] for row in rows] == list(range(1, len(rows) + 1))
    assert rows[stage_one - 1]["alpha"] == 0.25
    assert rows[stage_one + 1]["alpha"] == rows[stage_one + 2]["alpha"] == 0.5
    assert rows[-1]["alpha"] == 1.0
    assert [row["alpha"] for row in rows] == sorted(row["alpha"] for row in rows)
    assert resumed["steps"] == straight["steps"]
    assert resumed["energy"] == pytest.approx(straight["energy"], abs=1e-12)


# The compressed strip of BNN §6.3 at 30 % compression on a coarse mesh, by their method (fixed
# τ, no projection): ω = (−2, 2) × (0, 1) clamped at x = ±2 with g = (x ∓ 0.6, y, 0), an upward
# force 1e-2, α += δα per flow step.
STRIP = {
    "mesh": {"corners": [[-2.0, 0.0], [2.0, 1.0]], "cells": [16, 2]},
    "model": {
        "clamped": ["left", "right"],
        "load": [0.0, 0.0, 1e-2],
        "penalty": {"gamma0": 1e4, "gamma1": 1e4},
        "continuation": {"rate": 0.005},
        "boundary_data": {"g": ["x - 0.6*where(x > 0, 1, -1)", "y", 0.0]},
    },
    "flow": {"method": "bnn", "tau": 0.05, "max_steps": 2000, "linear_solver": "direct"},
    "output": {"png": False, "vtx": False, "progress": 0},
}


@pytest.mark.mpi
def test_compressed_strip_buckles_into_the_elastica(tmp_path, comm):
    """Height within 2 % of the clamped–clamped elastica at 16 × 2 cells; 1 and 2 ranks agree.

    The energy rises along the path (the data do work on the strip) but no flow step raises
    it: each new α rebases the decrease test.
    """
    problem = dgplate.problem_from_dict(STRIP, "strip")
    serial = dgplate.run(problem, out=tmp_path / "serial", comm=MPI.COMM_SELF)
    height = clamped_elastica(4.0, 1.2)["height"]
    assert serial["converged"], serial["reason"]
    assert serial["bbox"][1][2] == pytest.approx(height, rel=0.02)
    assert serial["energy_increases"] == []
    ends = [row["energy"] for row in serial.history if row["alpha"] < 1.0][::20]
    assert all(b > a for a, b in itertools.pairwise(ends))
    if comm.size > 1:
        parallel = dgplate.run(problem, out=out_dir(tmp_path, comm), comm=comm)
        assert parallel["steps"] == serial["steps"]
        assert parallel["energy"] == pytest.approx(serial["energy"], rel=PARITY_RTOL, abs=0)


def test_elastica_small_shortening_is_the_euler_mode():
    """Δ ≈ k²L and H ≈ 2kL/π for small k; K and E by the AGM match tabulated values."""
    K, E = elliptic_ke(math.sin(math.radians(30)))  # A&S Table 17.1, modulus angle 30°
    assert K == pytest.approx(1.685750354812596, rel=1e-14)
    assert E == pytest.approx(1.467462209339427, rel=1e-14)
    small = clamped_elastica(4.0, 4e-6)
    assert small["height"] == pytest.approx(2 * math.sqrt(1e-6) * 4 / math.pi, rel=1e-5)


@pytest.mark.parametrize(
    "model, message",
    [
        ({"continuation": {"alpha": [0.5, 0.4, 1.0]}}, r"model\.continuation\.alpha must increase"),
        (
            {"continuation": {"alpha": [0.0, 1.0]}},
            r"model\.continuation\.alpha\[0\] must be in \(0, 1\]",
        ),
        (
            {"continuation": {"alpha": [0.5, 1.5]}},
            r"model\.continuation\.alpha\[1\] must be in \(0, 1\]",
        ),
        ({"continuation": {"rate": 0.0}}, r"model\.continuation\.rate must be in \(0, 1\]"),
        ({"continuation": {"steps": 0}}, r"model\.continuation\.steps must be >= 1, got 0"),
        ({"continuation": {"steps": 2, "rate": 0.1}}, r"model\.continuation needs exactly one"),
        ({"continuation": {"step": 2}}, r"unknown key model\.continuation\.step"),
        (
            {"continuation": {"steps": 2}, "boundary_data": {"g": ["x", "y", "alpha*"]}},
            r"model\.boundary_data\.g\[2\]: cannot parse",
        ),
        (
            {"continuation": {"steps": 2}, "boundary_data": {"g": ["x", "y", "beta*x"]}},
            r"model\.boundary_data\.g\[2\]: unknown name 'beta'",
        ),
        (
            {"continuation": {}, "boundary_data": {"g": ["x", "y", "alpha"]}},
            r"uses alpha, which needs model\.continuation",
        ),
        ({"continuation": {"steps": 2}, "boundary_data": "flat"}, r"needs model\.boundary_data"),
        ({"continuation": {"steps": 2}, "clamped": []}, r"model\.clamped is empty"),
    ],
)
def test_bad_input_names_the_key(model, message):
    data = {"model": {**FLAP["model"], **model}}
    with pytest.raises(dgplate.InputError, match=message):
        dgplate.problem_from_dict(data, "bad")


@pytest.mark.parametrize(
    "model, message",
    [
        (
            {"boundary_data": {"g": ["x", "y", "sqrt(-1-x)"]}},
            r"model\.boundary_data\.g\[2\]: formula 'sqrt\(-1-x\)' is not finite on the plate",
        ),
        (
            {"boundary_data": {"g": ["x", "y", "alpha*sqrt(0.7-alpha)"]}},
            r"model\.boundary_data\.g\[2\]: formula .* is not finite.* \(at α = 0\.75\)$",
        ),
        (
            {"boundary_data": {"g": ["x", "y", "0.5"]}, "obstacle": {"type": "below", "psi": 0.3}},
            r"model\.obstacle: the clamped data .* penetrate the obstacle .* \(at α = 0\.75\)$",
        ),
    ],
)
def test_data_along_the_path_are_checked_before_the_run(tmp_path, model, message):
    """The clamped data at every α of the schedule (0.25, …, 1): finite formulas, and outside
    the obstacle (z = 0.5α reaches the ceiling 0.3 at α = 0.75)."""
    problem = flap(**{f"model.{key}": value for key, value in model.items()})
    with pytest.raises(dgplate.InputError, match=message):
        dgplate.check(problem, out=tmp_path / "o")
    assert not (tmp_path / "o").exists()


def test_bad_schedule_exits_2_with_one_line(tmp_path):
    problem = tmp_path / "bad.toml"
    problem.write_text(
        '[model]\nclamped = ["left"]\nboundary_data = {g = ["x", "y", "0.1*x"]}\n'
        "continuation = {alpha = [0.5, 0.2]}\n"
    )
    run = subprocess.run(
        [sys.executable, "-m", "dgplate", "run", str(problem), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode == 2
    assert run.stderr.strip().count("\n") == 0
    assert "model.continuation.alpha must increase" in run.stderr
    assert not (tmp_path / "o").exists()
