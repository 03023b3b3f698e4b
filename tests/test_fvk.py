"""Föppl–von Kármán plates (dgplate.models.fvk): linear limit, large deflection, Newton, MPI.

References: Timoshenko & Woinowsky-Krieger, Theory of Plates and Shells (1959), Tables 8 and 35
(simply supported 0.00406 q a⁴/D, clamped 0.00126 q a⁴/D); Levy, NACA Report 740 (1942),
Table 5 (clamped square plate, edges held against normal in-plane displacement but free to slide
along themselves, ν = 0.316); see docs/fvk.md.
"""

import itertools
import json
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from conftest import PARITY_RTOL

from dgplate.errors import InputError, SolverError
from dgplate.mesh.tagged import RECTANGLE_SIDES, load_geo, rectangle
from dgplate.models.fvk import FvKParameters, FvKProblem, run_fvk
from dgplate.models.fvk_output import HISTORY_COLUMNS
from dgplate.reference.fvk import (
    CLAMPED_SERIES,
    LEVY_NU,
    LEVY_Q,
    LEVY_W,
    navier_simply_supported,
    strip_centre_deflection,
)

E, NU, T = 1.0, 0.3, 0.01
FVK_SQUARE = Path(__file__).resolve().parent.parent / "demos" / "problems" / "fvk_square.toml"
D = E * T**3 / (12 * (1 - NU**2))


def linear_coefficient(comm, n, support, cell_type="quadrilateral", degree=2):
    """w_c D/(q a⁴) under a load so small that the membrane terms are negligible."""
    tagged = rectangle(comm, [[0, 0], [1, 1]], [n, n], cell_type)
    q = 1e-4 * D  # w_c ≈ 4e-7 a = 4e-5 t
    params = FvKParameters(E=E, nu=NU, thickness=T, pressure=q, load_steps=1, degree=degree)
    setattr(params, support, list(RECTANGLE_SIDES))
    problem = FvKProblem(tagged, params)
    try:
        record = problem.solve_step(1.0)
    finally:
        problem.close()
    return record["w_center"] * D / q


@pytest.mark.parametrize(
    "support,published,exact",
    [
        ("simply_supported", 0.00406, navier_simply_supported()),
        ("clamped", 0.00126, CLAMPED_SERIES),
    ],
)
def test_linear_limit_and_convergence(support, published, exact, capsys):
    levels = [8, 16, 32] if support == "clamped" else [8, 16]
    coeffs = [linear_coefficient(MPI.COMM_SELF, n, support) for n in levels]
    errors = [abs(c / exact - 1) for c in coeffs]
    with capsys.disabled():
        print(f"\n{support}: w_c D/(q a^4), published {published}, series {exact:.7f}")
        for n, c, e in zip(levels, coeffs, errors):
            print(
                f"  {n:3d}x{n:<3d} {c:.7f}  vs published {c / published - 1:+.3%}  vs series {e:.3%}"
            )
    assert abs(coeffs[-1] / published - 1) < 0.01
    assert all(np.diff(errors) < 0), errors  # converges under refinement


def test_simply_supported_on_p3_triangles():
    """On triangles use k = 3: P2 has a constant Hessian per cell and is far less accurate."""
    coeff = linear_coefficient(MPI.COMM_SELF, 8, "simply_supported", "triangle", degree=3)
    assert coeff == pytest.approx(0.00406, rel=0.01)


def test_prestrain_compression_amplifies_deflection():
    """Held simply supported square, thermal prestrain ε₀ = ½ ε_cr: N = A(1+ν)ε₀ = ½ N_cr.

    Linear theory (Navier series with the membrane compression) about doubles the deflection.
    """
    A = E * T / (1 - NU**2)
    eps_cr = 2 * np.pi**2 * D / (A * (1 + NU))  # N_cr = 2π²D/a² under equal compression
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [12, 12])
    q = 1e-4 * D
    params = FvKParameters(
        E=E, nu=NU, thickness=T, pressure=q, prestrain=0.5 * eps_cr,
        simply_supported=list(RECTANGLE_SIDES), load_steps=1,
    )  # fmt: skip
    problem = FvKProblem(tagged, params)
    coeff = problem.solve_step(1.0)["w_center"] * D / q
    problem.close()
    exact = navier_simply_supported(compression=0.5)
    assert exact / navier_simply_supported() == pytest.approx(2.0, rel=0.02)
    assert coeff == pytest.approx(exact, rel=0.01)


@pytest.fixture(scope="module")
def levy_run():
    """Levy's clamped square plate on 16×16 Q2 cells, one load step per tabulated load."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [16, 16])
    params = FvKParameters(
        E=E,
        nu=LEVY_NU,
        thickness=T,
        pressure=LEVY_Q[-1] * E * T**4,
        clamped=list(RECTANGLE_SIDES),
        membrane={side: "normal" for side in RECTANGLE_SIDES},
        load_steps=[q / LEVY_Q[-1] for q in LEVY_Q],
    )
    return run_fvk(tagged, params)


def test_large_deflection_matches_levy(levy_run, capsys):
    ours = np.array([h["w_center"] / T for h in levy_run["history"]])
    errors = ours / np.array(LEVY_W) - 1
    with capsys.disabled():
        print("\nLevy clamped square (16x16 Q2): Q, w_c/t ours, Levy, error")
        for q, w, ref, e in zip(LEVY_Q, ours, LEVY_W, errors):
            print(f"  {q:7.2f} {w:.4f} {ref:.3f} {e:+.2%}")
    assert np.max(np.abs(errors)) < 0.03


def test_newton_converges_quadratically(levy_run, capsys):
    its = levy_run["snes_iterations"]
    with capsys.disabled():
        print(f"\nNewton iterations per load step: {its}")
        for norms in levy_run["residual_norms"]:
            print("  " + " ".join(f"{r:.1e}" for r in norms))
    assert max(its) <= 5
    for norms in levy_run["residual_norms"]:
        rel = np.array(norms) / norms[0]
        # order log r_{k+1} / log r_k over the contracting part above round-off
        orders = [
            np.log(b) / np.log(a) for a, b in itertools.pairwise(rel[1:]) if a < 0.1 and b > 1e-14
        ]
        assert not orders or max(orders) > 1.8, (rel, orders)


@pytest.mark.parametrize("crease", [True, False])
def test_crease_is_a_hinge(crease):
    """Strip clamped and held at x = 0, 2, crease at x = 1, ν = 0: exact 1D FvK solutions.

    Linear limit: a hinge makes each half a cantilever, w_c = q (L/2)⁴/(8D); without it
    w_c = q L⁴/(384 D). Large loads: tension from the held ends (fvk_reference).
    """
    tagged = load_geo(MPI.COMM_SELF, "creased_rectangle", {"Ly": 0.5, "h": 0.1, "quads": 1})
    t, L = 0.02, 2.0
    D0 = E * t**3 / 12
    q_max = 80 * D0 * t  # linear theory would give w_c = 10 t with the hinge
    params = FvKParameters(
        E=E, nu=0.0, thickness=t, pressure=q_max, clamped=["left", "right"],
        crease=["crease"] if crease else [], load_steps=[1e-4, 0.3, 1.0], probe=[1.0, 0.25],
    )  # fmt: skip
    problem = FvKProblem(tagged, params)
    w = [problem.solve_step(lam)["w_center"] for lam in params.load_factors()]
    problem.close()
    linear = 1e-4 * q_max * (L**4 / (8 * 16 * D0) if crease else L**4 / (384 * D0))
    assert w[0] == pytest.approx(linear, rel=0.01)
    for lam, value in zip(params.load_factors()[1:], w[1:]):
        exact = strip_centre_deflection(lam * q_max, L, E, t, hinge=crease)
        assert value == pytest.approx(exact, rel=0.01)


def _parity_run(comm):
    tagged = rectangle(comm, [[0, 0], [1, 1]], [6, 6])
    params = FvKParameters(
        E=E, nu=NU, thickness=T, pressure=200 * E * T**4, clamped=["left", "bottom"],
        simply_supported=["right", "top"], membrane={"top": "normal"}, load_steps=3,
    )  # fmt: skip
    summary = run_fvk(tagged, params, comm=comm)
    return summary


@pytest.mark.mpi
def test_same_deflection_on_any_number_of_ranks():
    parallel, serial = _parity_run(MPI.COMM_WORLD), _parity_run(MPI.COMM_SELF)
    assert parallel["ranks"] == MPI.COMM_WORLD.size
    for key in ("w_max", "w_center", "energy"):
        assert parallel[key] == pytest.approx(serial[key], rel=PARITY_RTOL, abs=0), key
    assert parallel["snes_iterations"] == serial["snes_iterations"]


def test_run_fvk_writes_outputs(tmp_path):
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [4, 4])
    params = FvKParameters(
        thickness=T, pressure=50 * T**4, clamped=list(RECTANGLE_SIDES), load_steps=2
    )
    summary = run_fvk(tagged, params, out_dir=tmp_path / "out")
    out = tmp_path / "out"
    written = json.loads((out / "summary.json").read_text())
    assert written["model"] == "fvk" and written["load_steps"] == 2
    assert written["w_max"] == pytest.approx(summary["w_max"]) and summary["w_max"] > 0
    assert written["load"] == pytest.approx(50 * T**4)
    rows = (out / "history.csv").read_text().splitlines()
    assert rows[0].startswith("step,load_factor,load,w_max") and len(rows) == 3
    assert (out / "fvk.bp").is_dir() and not (out / "fvk.bp.partial").exists()
    assert (out / "final.png").stat().st_size > 1000


def test_failed_step_keeps_outputs_with_snes_reason(tmp_path):
    """A Newton failure ends the schedule like a flow that does not converge: the outputs
    hold the converged steps, with converged = false and the SNES reason."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [4, 4])
    params = FvKParameters(
        thickness=T, pressure=400 * T**4, clamped=list(RECTANGLE_SIDES), load_steps=[0.01, 1.0],
        snes={"snes_max_it": 3},
    )  # fmt: skip
    with pytest.raises(SolverError, match="DIVERGED_MAX_IT"):
        FvKProblem(tagged, params).solve_step(1.0)  # Newton needs more than 3 iterations
    summary = run_fvk(tagged, params, out_dir=tmp_path / "out")
    out = tmp_path / "out"
    written = json.loads((out / "summary.json").read_text())
    assert written == json.loads(json.dumps(summary))
    assert summary["converged"] is False
    assert "load step 2 (load factor 1)" in summary["reason"]
    assert "DIVERGED_MAX_IT" in summary["reason"]
    assert summary["steps"] == 1 and summary["load_steps"] == 2
    assert summary["load"] == pytest.approx(0.01 * 400 * T**4) and summary["w_max"] > 0
    rows = (out / "history.csv").read_text().splitlines()
    assert len(rows) == 2 and rows[1].startswith("1,0.01,")
    assert (out / "fvk.bp").is_dir() and (out / "final.png").stat().st_size > 1000


def test_cli_failed_fvk_exits_1_with_outputs_and_no_traceback(tmp_path):
    out = tmp_path / "out"
    settings = ["mesh.cells=[4,4]", "model.load_steps=1", "model.snes={snes_max_it=1}"]
    proc = subprocess.run(
        [sys.executable, "-m", "dgplate", "run", str(FVK_SQUARE), "--out", str(out)]
        + [arg for s in settings for arg in ("--set", s)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr and "DIVERGED_MAX_IT" in proc.stderr, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is False and "DIVERGED_MAX_IT" in summary["reason"]
    assert summary["steps"] == 0 and summary["w_max"] is None
    assert (out / "history.csv").read_text().splitlines() == [",".join(HISTORY_COLUMNS)]


@pytest.mark.parametrize(
    "data,message",
    [
        ({"nu": 0.5}, "model.nu must be < 0.5, got 0.5"),
        ({"nu": 0.6}, "model.nu must be < 0.5, got 0.6"),
        ({"nu": -1.0}, "model.nu must be > -1"),
        ({"thickness": 0.0}, "model.thickness must be > 0, got 0.0"),
        ({"thickness": -0.1}, "model.thickness must be > 0"),
        ({"E": 0}, "model.E must be > 0"),
        ({"degree": 1}, "model.degree must be an integer >= 2"),
        ({"load_steps": 0}, "model.load_steps must be >= 1"),
        ({"load_steps": [0.5, 0.2]}, "model.load_steps must be a positive integer or"),
        ({"membrane": {"left": "sliding"}}, "model.membrane.left must be"),
        ({"penalty": {"gamma0": -1.0, "gamma1": 1.0}}, "model.penalty.gamma0 must be"),
        ({"clamped": ["left"], "simply_supported": ["left"]}, "both list 'left'"),
        ({"xyz": 1}, "unknown key model.xyz"),
        ({"name": "kirchhoff"}, "model.name must be 'fvk'"),
    ],
)
def test_bad_parameters(data, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace("[", r"\[")):
        FvKParameters.from_dict(data)


@pytest.mark.parametrize("key", ["clamped", "simply_supported", "crease"])
def test_unknown_boundary_group(key):
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [2, 2])
    data = {"clamped": ["left"]}
    data[key] = ["nowhere"]
    params = FvKParameters.from_dict(data)
    with pytest.raises(InputError, match=rf"model.{key}: unknown facet group 'nowhere'"):
        FvKProblem(tagged, params)


def test_misplaced_groups():
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [2, 2])
    with pytest.raises(InputError, match="crease group 'left'"):
        FvKProblem(tagged, FvKParameters(clamped=["right"], crease=["left"]))
    with pytest.raises(InputError, match="no edge holds the in-plane displacement"):
        FvKProblem(tagged, FvKParameters(clamped=["left"], membrane={"left": "free"}))


def test_problem_file_is_valid():
    """demos/problems/fvk_square.toml: a valid [model] table and Levy's problem."""
    import tomllib

    data = tomllib.loads(FVK_SQUARE.read_text())
    params = FvKParameters.from_dict(data["model"])
    assert params.nu == LEVY_NU and params.pressure == pytest.approx(LEVY_Q[-1] * T**4)
    assert data["mesh"]["type"] == "rectangle" and set(params.membrane) == set(params.clamped)
