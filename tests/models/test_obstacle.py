"""Rigid obstacles (docs/obstacle.md): a heavy strip lifting off a table, energy decrease of the
quadratic–concave splitting, every obstacle type, bad input, and 1 vs 2 ranks."""

import math
from pathlib import Path

from mpi4py import MPI

import pytest
from helpers import PARITY_RTOL

import dgplate
from dgplate.reference.obstacle_profiles import lift_off_length, penalised_lift_off

MU, HEIGHT, WEIGHT, LENGTH, WIDTH = 1.0, 0.02, 1.0, 2.0, 0.25
QUIET = {"png": False, "vtx": False, "progress": 0}
STRIP = Path(__file__).resolve().parents[2] / "demos" / "problems" / "obstacle_strip.toml"


def strip(cells: int, epsilon: float, **more: object) -> dgplate.Problem:
    """A strip clamped horizontally at height H above the table y₃ ≥ 0, under its weight."""
    overrides = {"mesh.cells": [cells, 2], "model.obstacle.epsilon": epsilon, **more}
    return dgplate.load_problem(STRIP, overrides | {f"output.{k}": v for k, v in QUIET.items()})


def test_strip_lifts_off_the_table_at_the_penalised_beam_length(tmp_path):
    """Contact starts where the 1D penalised beam leaves the table; the error falls with h.

    ε = 2e−4 keeps the run short (the splitting moves free parts by ~ε·q per step); at this ε
    the penalised lift-off length ℓ_ε is 16 % below the rigid-table ℓ = (72μH/q)^{1/4}, which
    ℓ_ε approaches like ε^{1/4} (docs/obstacle.md, table).
    """
    epsilon = 2e-4
    exact = penalised_lift_off(MU, HEIGHT, WEIGHT, epsilon, LENGTH, n=400)
    assert 0.8 < exact / lift_off_length(MU, HEIGHT, WEIGHT) < 0.9
    errors = []
    for cells in (8, 16):
        result = dgplate.run(strip(cells, epsilon), out=tmp_path / str(cells))
        assert result["converged"] and result["energy_increases"] == []
        errors.append(abs(result["contact_extent"][0] / exact - 1))
        # the strip lies on the table from the lift-off point to its end, across its width
        assert result["contact_extent"][1:] == pytest.approx([LENGTH, 0.0, WIDTH], abs=1e-12)
        assert result["max_penetration"] > 0 and result["contact_cells"] > 0
    assert errors[1] < errors[0] and errors[1] < 0.03, errors


ACTIVE = {"model.obstacle.treatment": "active_set", "flow.projection_steps": 2}


def test_strip_lifts_off_the_table_at_the_closed_form_length(tmp_path):
    """The active-set treatment at ε = 1e−10: lift-off within 3 % of ℓ = (72μH/q)^{1/4}.

    At this ε the penalised beam's ℓ_ε is 0.4 % below ℓ (docs/obstacle.md); the error of the
    plate falls under refinement (8, 16, 32 cells), every step lowers the energy, and the
    contact force is the rigid table's reaction q b (L − 2ℓ/3).
    """
    epsilon, ell = 1e-10, lift_off_length(MU, HEIGHT, WEIGHT)
    assert abs(penalised_lift_off(MU, HEIGHT, WEIGHT, epsilon, LENGTH, n=1600) / ell - 1) < 0.005
    errors = []
    # flow.tol = 1e-10 on the stationarity stop: the reaction (1/ε)∫(s)₋ is the slowest figure
    # at ε = 1e−10. Stopped at ‖P DE_h‖ < 1e-8 the 16-cell strip had E_h and the lift-off point
    # to 1e-9 of the converged state, but a reaction of 0.330 against 0.317 (+4 %).
    for cells in (8, 16, 32):
        problem = strip(cells, epsilon, **ACTIVE, **{"flow.tol": 1e-10})
        result = dgplate.run(problem, out=tmp_path / str(cells))
        assert result["converged"] and result["energy_increases"] == []
        assert result["steps"] < 40 and result["active_set_changes"] < 60
        errors.append(abs(result["contact_extent"][0] / ell - 1))
        assert result["contact_extent"][1:] == pytest.approx([LENGTH, 0.0, WIDTH], abs=1e-12)
        reaction = WEIGHT * WIDTH * (LENGTH - 2 * ell / 3)
        assert result["contact_force"] == pytest.approx(reaction, rel=0.02)
    assert errors[2] < errors[1] < errors[0] and errors[2] < 0.03, errors


def test_active_set_and_splitting_reach_the_same_minimiser(tmp_path):
    """At ε = 1e−3 both treatments stop at the same state (the active set in ~1/4 the steps)."""
    runs = [
        dgplate.run(
            strip(8, 1e-3, **{**ACTIVE, "model.obstacle.treatment": treatment}),
            out=tmp_path / treatment,
        )
        for treatment in ("splitting", "active_set")
    ]
    for result in runs:
        assert result["converged"] and result["energy_increases"] == []
    split, active = runs
    assert active["energy"] == pytest.approx(split["energy"], rel=1e-5)
    assert active["max_penetration"] == pytest.approx(split["max_penetration"], rel=1e-3)
    assert active["contact_force"] == pytest.approx(split["contact_force"], rel=1e-2)
    assert active["contact_extent"] == pytest.approx(split["contact_extent"], abs=1e-12)
    assert active["steps"] < split["steps"] / 2
    assert split["active_set_changes"] == 0 < active["active_set_changes"]


@pytest.mark.parametrize(
    "obstacle",
    [
        {"type": "plane", "normal": [0.0, 0.0, -2.0], "point": [0.0, 0.0, 0.01]},
        {"type": "below", "psi": "0.01 + 0*x"},
        {"type": "sphere", "center": [1.0, 0.0, 1.01], "radius": 1.0, "side": "outside"},
        {"type": "sphere", "center": [0.0, 0.0, 0.0], "radius": 1.41425, "side": "inside"},
    ],
    ids=["plane", "below", "sphere outside", "sphere inside"],
)
@pytest.mark.parametrize("treatment", ["splitting", "active_set"])
def test_energy_decreases_at_every_step_against_any_obstacle(tmp_path, obstacle, treatment):
    """A cantilever pushed up by f = (0, 0, 1) into a ceiling, a ball or a spherical shell.

    The obstacles are close to the flat start: under the splitting the plate rises by at most
    ~ε·f per step while the penalty's (1/ε) mass is in the step matrix (docs/obstacle.md).
    The active-set treatment puts that mass on the contact set only.
    """
    problem = bnn_small({**obstacle, "epsilon": 1e-3, "treatment": treatment}, max_steps=40)
    result = dgplate.run(problem, out=tmp_path / "out")
    assert result["energy_increases"] == []
    assert result["contact_cells"] > 0 and result["max_penetration"] > 0
    # the shell is touched at the free corners first: no quadrature point in contact yet
    if obstacle.get("side") != "inside":
        assert result["contact_force"] > 0 and result["contact_area"] > 0


def bnn_small(obstacle: dict, max_steps: int, **flow) -> dgplate.Problem:
    """BNN §6.2 on 4×4 cells with a larger τ: clamped at x₁ = −1, f = (0, 0, 1)."""
    return dgplate.problem_from_dict(
        {
            "mesh": {
                "corners": [[-1.0, -1.0], [1.0, 1.0]],
                "cells": [4, 4],
                "cell_type": "quadrilateral",
            },
            "model": {"clamped": ["left"], "load": [0.0, 0.0, 1.0], "obstacle": obstacle},
            "flow": {"tau": 0.05, "max_steps": max_steps, **flow},
            "output": QUIET,
        },
        "bnn_small",
    )


@pytest.mark.parametrize(
    "curvature",
    [{"name": "bilayer", "Z": 1.0}, {"name": "lce", "director": "splay", "gamma": -1.0}],
    ids=["bilayer", "lce"],
)
def test_bilayer_rolls_against_a_plane(tmp_path, curvature):
    """A bilayer that would roll up (Z = I), or an LCE plate (splay, A = diag(1, 0)), stopped
    by a tilted plane: contact, no increase."""
    problem = dgplate.problem_from_dict(
        {
            "mesh": {
                "corners": [[0.0, 0.0], [3.0, 1.0]],
                "cells": [6, 2],
                "cell_type": "quadrilateral",
            },
            "model": {
                **curvature,
                "clamped": ["left"],
                "obstacle": {
                    "type": "plane",
                    "normal": [-0.005, 0.0, -1.0],
                    "point": [0.0, 0.0, 0.02],
                    "epsilon": 1e-3,
                },
            },
            "flow": {"tau": 0.1, "max_steps": 30},
            "output": QUIET,
        },
        "bilayer_plane",
    )
    result = dgplate.run(problem, out=tmp_path / "out")
    assert result["energy_increases"] == [] and result["contact_cells"] > 0


@pytest.mark.mpi
@pytest.mark.parametrize("treatment", ["splitting", "active_set"])
def test_two_ranks_agree_with_one(tmp_path, comm, treatment):
    """Energy and contact figures of a whole run on the ranks of ``comm`` and on one rank."""
    obstacle = {"type": "below", "psi": 0.01, "epsilon": 1e-3, "treatment": treatment}
    problem = bnn_small(obstacle, max_steps=40, linear_solver="direct")
    out = comm.bcast(tmp_path / "out" if comm.rank == 0 else None)
    shared = dgplate.run(problem, out=out, comm=comm)
    single = dgplate.run(problem, out=tmp_path / f"single{comm.rank}", comm=MPI.COMM_SELF)
    for key in ("energy", "contact_area", "max_penetration", "contact_force"):
        assert math.isclose(shared[key], single[key], rel_tol=PARITY_RTOL), key
    for key in ("contact_cells", "steps", "active_set_changes", "active_set_redos"):
        assert shared[key] == single[key], key
    assert shared["contact_cells"] > 0


BAD = {
    "unknown type": ({"type": "wall"}, r"model\.obstacle\.type must be one of"),
    "epsilon zero": ({"type": "above", "epsilon": 0.0}, r"model\.obstacle\.epsilon must be"),
    "epsilon text": ({"type": "above", "epsilon": "small"}, r"model\.obstacle\.epsilon must be"),
    "key of another type": ({"type": "above", "radius": 1.0}, r"unknown key model\.obstacle\.radius"),
    "normal of 2": ({"type": "plane", "normal": [0, 1]}, r"model\.obstacle\.normal must have 3 entries"),
    "zero normal": ({"type": "plane", "normal": [0, 0, 0]}, r"model\.obstacle\.normal must not be"),
    "center text": ({"type": "sphere", "center": "origin"}, r"model\.obstacle\.center must be"),
    "radius negative": ({"type": "sphere", "radius": -1.0}, r"model\.obstacle\.radius must be"),
    "side": ({"type": "sphere", "side": "above"}, r"model\.obstacle\.side must be"),
    "treatment": ({"type": "above", "treatment": "newton"}, r"model\.obstacle\.treatment must be one of splitting, active_set"),
    "formula": ({"type": "below", "psi": "0.2 + import(x)"}, r"model\.obstacle\.psi"),
    "not a table": ("ceiling", r"model\.obstacle must be a table or none"),
}  # fmt: skip


@pytest.mark.parametrize("table, message", BAD.values(), ids=BAD.keys())
def test_bad_obstacle_is_one_line_naming_the_key(table, message):
    with pytest.raises(dgplate.InputError, match=message):
        bnn_small(table, max_steps=1)


def test_clamped_data_inside_the_obstacle_is_refused(tmp_path):
    """The clamped edge lies at y₃ = 0, the ceiling at −0.1: nothing is written."""
    problem = bnn_small({"type": "below", "psi": -0.1}, max_steps=1)
    with pytest.raises(dgplate.InputError, match=r"model\.obstacle: the clamped data"):
        dgplate.run(problem, out=tmp_path / "out")
    assert not (tmp_path / "out" / "summary.json").exists()


def test_start_inside_the_obstacle_is_refused(tmp_path):
    """The clamp is above the table, the flat start y₃ = 0 below the floor y₃ ≥ 0.01 + x/10."""
    problem = strip(4, 1e-4)
    problem = dgplate.problem_from_dict(
        {**problem.raw, "model": {**problem.raw["model"], "obstacle": {"type": "above", "psi": "0.01*x"}, "start": "flat"}},
        "strip",
    )  # fmt: skip
    with pytest.raises(dgplate.InputError, match=r"model\.obstacle: the start y⁰ penetrates"):
        dgplate.run(problem, out=tmp_path / "out")
