"""Föppl–von Kármán plates (dgplate.models.fvk): linear limit, large deflection, Newton, MPI.

References: Timoshenko & Woinowsky-Krieger, Theory of Plates and Shells (1959), Tables 8 and 35
(simply supported 0.00406 q a⁴/D, clamped 0.00126 q a⁴/D); Levy, NACA Report 740 (1942),
Table 5 (clamped square plate, edges held against normal in-plane displacement but free to slide
along themselves, ν = 0.316); see docs/fvk.md.
"""

import itertools
import json
import re
import signal
import subprocess
import sys
from contextlib import contextmanager
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np
import pytest
from helpers import PARITY_RTOL
from petsc4py import PETSc

from dgplate import interrupt
from dgplate.dg.forms import Penalty
from dgplate.errors import InputError, SolverError
from dgplate.io import checkpoint
from dgplate.mesh.tagged import RECTANGLE_SIDES, load_geo, rectangle
from dgplate.models.fvk.model import PREFIX, build_fvk
from dgplate.models.fvk.spec import PENALTY, FvKSpec, NewtonSpec
from dgplate.problems.registry import MODELS, model_spec
from dgplate.problems.specs import problem_from_dict
from dgplate.reference.fvk import (
    CLAMPED_SERIES,
    LEVY_NU,
    LEVY_Q,
    LEVY_W,
    navier_simply_supported,
    strip_centre_deflection,
)
from dgplate.schema import from_dict

E, NU, T = 1.0, 0.3, 0.01
FVK_SQUARE = Path(__file__).resolve().parents[2] / "demos" / "problems" / "fvk_square.toml"
D = E * T**3 / (12 * (1 - NU**2))


class Recorder:
    """An observer that keeps what it is told."""

    def __init__(self):
        self.steps, self.results = [], []

    def step(self, driver, record):
        self.steps.append(record)

    def finish(self, driver, result):
        self.results.append(result)


NEWTON_KEYS = {f.name for f in fields(NewtonSpec)}


def fvk_spec(**keys: Any) -> FvKSpec:
    """An FvK spec from [model] and [newton] keys alike."""
    newton = {key: keys.pop(key) for key in NEWTON_KEYS & set(keys)}
    return FvKSpec(**keys, newton=NewtonSpec(**newton))


@contextmanager
def newton(tagged, observers=(), **keys):
    """The FvK model of ``keys`` on ``tagged`` and its driver (destroyed on exit)."""
    model = build_fvk(fvk_spec(**keys), tagged)
    driver = model.driver(None, observers, None)
    try:
        yield model, driver
    finally:
        driver.destroy()


def linear_coefficient(comm, n, support, cell_type="quadrilateral", degree=2):
    """w_c D/(q a⁴) under a load so small that the membrane terms are negligible."""
    tagged = rectangle(comm, [[0, 0], [1, 1]], [n, n], cell_type)
    q = 1e-4 * D  # w_c ≈ 4e-7 a = 4e-5 t
    sides = {support: list(RECTANGLE_SIDES)}
    keys = dict(E=E, nu=NU, thickness=T, pressure=q, load_steps=1, degree=degree, **sides)
    with newton(tagged, **keys) as (_, driver):
        record = driver.step()
    return record.w_center * D / q


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
    keys = dict(
        E=E, nu=NU, thickness=T, pressure=q, prestrain=0.5 * eps_cr,
        simply_supported=list(RECTANGLE_SIDES), load_steps=1,
    )  # fmt: skip
    with newton(tagged, **keys) as (_, driver):
        coeff = driver.step().w_center * D / q
    exact = navier_simply_supported(compression=0.5)
    assert exact / navier_simply_supported() == pytest.approx(2.0, rel=0.02)
    assert coeff == pytest.approx(exact, rel=0.01)


@pytest.fixture(scope="module")
def levy_run():
    """Levy's clamped square plate on 16×16 Q2 cells, one load step per tabulated load."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [16, 16])
    keys = dict(
        E=E,
        nu=LEVY_NU,
        thickness=T,
        pressure=LEVY_Q[-1] * E * T**4,
        clamped=list(RECTANGLE_SIDES),
        membrane={side: "normal" for side in RECTANGLE_SIDES},
        load_steps=[q / LEVY_Q[-1] for q in LEVY_Q],
    )
    with newton(tagged, **keys) as (model, driver):
        result = driver.run()
        return {
            "result": result,
            "history": driver.history,
            **driver.summary(),
            **model.figures(driver),
        }


def test_large_deflection_matches_levy(levy_run, capsys):
    assert levy_run["result"].converged
    ours = np.array([record.w_center / T for record in levy_run["history"]])
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


def test_summary_figures(levy_run):
    """What summary.json gets from the driver and the model (the last load step's numbers)."""
    last = levy_run["history"][-1]
    assert levy_run["load_steps"] == len(LEVY_Q) == len(levy_run["load_factors"])
    assert levy_run["load_factor"] == levy_run["load_factors"][-1] == 1.0
    assert levy_run["load"] == pytest.approx(LEVY_Q[-1] * E * T**4)
    assert levy_run["w_center"] == last.w_center and levy_run["w_max"] == last.w_max
    assert levy_run["w_center_over_thickness"] == pytest.approx(last.w_center / T)
    assert levy_run["probe"] == [0.5, 0.5] and levy_run["energy"] == pytest.approx(last.energy)
    assert json.loads(json.dumps(levy_run["load_factors"])) == levy_run["load_factors"]


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
    factors = [1e-4, 0.3, 1.0]
    keys = dict(
        E=E, nu=0.0, thickness=t, pressure=q_max, clamped=["left", "right"],
        crease=["crease"] if crease else [], load_steps=factors, probe=[1.0, 0.25],
    )  # fmt: skip
    with newton(tagged, **keys) as (_, driver):
        assert driver.run().converged
        w = [record.w_center for record in driver.history]
    linear = 1e-4 * q_max * (L**4 / (8 * 16 * D0) if crease else L**4 / (384 * D0))
    assert w[0] == pytest.approx(linear, rel=0.01)
    for factor, value in zip(factors[1:], w[1:]):
        exact = strip_centre_deflection(factor * q_max, L, E, t, hinge=crease)
        assert value == pytest.approx(exact, rel=0.01)


def _parity_run(comm):
    tagged = rectangle(comm, [[0, 0], [1, 1]], [6, 6])
    keys = dict(
        E=E, nu=NU, thickness=T, pressure=200 * E * T**4, clamped=["left", "bottom"],
        simply_supported=["right", "top"], membrane={"top": "normal"}, load_steps=3,
    )  # fmt: skip
    with newton(tagged, **keys) as (model, driver):
        driver.run()
        return {**driver.summary(), **model.figures(driver), "ranks": driver.comm.size}


@pytest.mark.mpi
@pytest.mark.parity
def test_same_deflection_on_any_number_of_ranks():
    parallel, serial = _parity_run(MPI.COMM_WORLD), _parity_run(MPI.COMM_SELF)
    assert parallel["ranks"] == MPI.COMM_WORLD.size
    for key in ("w_max", "w_center", "energy"):
        assert parallel[key] == pytest.approx(serial[key], rel=PARITY_RTOL, abs=0), key
    assert parallel["snes_iterations"] == serial["snes_iterations"]


SMALL = dict(thickness=T, pressure=50 * T**4, clamped=list(RECTANGLE_SIDES), load_steps=4)


@pytest.mark.mpi
def test_driver_shape_records_and_observers():
    """The runner's view: the shape y = (x + u, w), one record per load step, observers."""
    tagged = rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [4, 4])
    recorder = Recorder()
    with newton(tagged, [recorder], **SMALL) as (model, driver):
        assert driver.time == 0.0 and driver.step_count == 0
        result = driver.run(max_steps=2)
        assert not result.converged and "2 of 4 load steps" in result.reason
        assert driver.time == 0.5 and driver.step_count == 2
        result = driver.run()
        assert result.converged and result.reason == "all 4 load steps converged"
        assert result.steps == 2 and [r.step for r in result.history] == [3, 4]
        assert [r.step for r in recorder.steps] == [1, 2, 3, 4] and len(recorder.results) == 2
        record = driver.history[-1]
        assert list(asdict(record)) == [
            "step", "load_factor", "iterations", "residual", "energy", "seconds",
            "w_max", "w_center", "lowest_eigenvalue",
        ]  # fmt: skip
        assert (
            record.line().startswith("load step    4  load factor 1")
            and "w_center" in record.line()
        )
        y = driver.shape
        assert y.ufl_shape == (3,) and y.name == "deformation"
        owned = y.function_space.dofmap.index_map.size_local
        z = y.x.array.reshape(-1, 3)[:owned, 2]
        top = driver.comm.allreduce(float(z.max(initial=-np.inf)), op=MPI.MAX)
        assert top == pytest.approx(record.w_max, rel=1e-12) and record.w_max > 0
        assert set(driver.checkpoint_fields()) == {"state", "previous"}
        assert model.lines(driver) == []
        assert driver.run().steps == 0  # nothing left: converged at once
    assert not any(k.startswith(PREFIX) for k in PETSc.Options().getAll())


def test_initial_shape_is_the_first_iterate():
    """``initial`` (x ↦ y) starts the state at w = y₃, u = (y₁, y₂) − x."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [2, 2])
    model = build_fvk(fvk_spec(**SMALL), tagged)

    def initial(x):
        return np.vstack([x[0] + 1e-3, x[1], 2e-3 + 0 * x[0]])

    driver = model.driver(None, [], initial)
    try:
        y = driver.shape.x.array.reshape(-1, 3)
        x = driver.shape.function_space.tabulate_dof_coordinates()
        assert np.allclose(y[:, 0], x[:, 0] + 1e-3) and np.allclose(y[:, 1], x[:, 1])
        assert np.allclose(y[:, 2], 2e-3)
        assert driver.run().converged  # the clamped data pull it back
    finally:
        driver.destroy()


def test_failed_step_keeps_the_last_converged_state():
    """A Newton failure ends the run with converged = false and the SNES reason; the state
    and the load factor are those of the last converged step."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [4, 4])
    keys = dict(
        thickness=T, pressure=400 * T**4, clamped=list(RECTANGLE_SIDES), load_steps=[0.01, 1.0],
        snes={"snes_max_it": 3},
    )  # fmt: skip
    with newton(tagged, **keys) as (_, driver):
        with pytest.raises(SolverError, match="DIVERGED_MAX_IT"):
            driver.solve(1.0)  # Newton needs more than 3 iterations from the flat plate
        assert driver.time == 0.0 and not driver.state.x.array.any()
    with newton(tagged, **keys) as (model, driver):
        result = driver.run()
        assert result.converged is False and result.steps == 1
        assert "load step 2 (load factor 1)" in result.reason
        assert "DIVERGED_MAX_IT" in result.reason and "newton.load_steps" in result.reason
        assert driver.time == 0.01 and driver.step_count == 1
        figures = model.figures(driver)
        assert figures["load"] == pytest.approx(0.01 * 400 * T**4) and figures["w_max"] > 0
        assert driver.summary()["load_steps"] == 1  # solved, of
        assert driver.summary()["load_steps_scheduled"] == 2


def test_interrupt_stops_at_a_step_boundary(monkeypatch):
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [4, 4])
    recorder = Recorder()
    monkeypatch.setattr(interrupt, "_received", signal.SIGTERM)
    with newton(tagged, [recorder], **SMALL) as (_, driver):
        result = driver.run()
    assert result.interrupted == signal.SIGTERM and not result.converged
    assert result.reason == "interrupted (SIGTERM)" and result.steps == 1
    assert recorder.results == [result] and len(recorder.steps) == 1


@pytest.mark.mpi
def test_checkpoint_continues_the_schedule(tmp_path):
    """Stopped after 2 of 4 load steps and checkpointed, a new driver goes on from the
    checkpoint (secant predictor included) to the uninterrupted run's state."""
    comm = MPI.COMM_WORLD
    tagged = rectangle(comm, [[0, 0], [1, 1]], [4, 4])
    folder = tmp_path / "checkpoint" if comm.rank == 0 else None
    folder = Path(comm.bcast(str(folder)))
    with newton(tagged, **SMALL) as (_, driver):
        driver.run()
        expected = [record.w_center for record in driver.history], driver.energy_value()
    with newton(tagged, **SMALL) as (_, driver):
        driver.run(max_steps=2)
        problem = {"model": {"name": "fvk"}}
        state = {
            "fingerprint": checkpoint.fingerprint(problem),
            "driver": driver.checkpoint_state(),
        }
        checkpoint.save(folder, comm, driver.checkpoint_fields(), state)
    found = checkpoint.load(folder, comm, problem)
    with newton(tagged, **SMALL) as (_, driver):
        found.restore(driver.checkpoint_fields())
        driver.restore_state(found.state["driver"])
        assert driver.step_count == 2 and driver.time == 0.5
        result = driver.run()
        assert result.converged and result.steps == 2
        assert [record.w_center for record in driver.history] == pytest.approx(
            expected[0], rel=1e-9
        )
        assert driver.energy_value() == pytest.approx(expected[1], rel=1e-9)
        assert len(driver.summary()["residual_norms"]) == 4


def run_fvk_square(out, settings: list[str]) -> subprocess.CompletedProcess:
    """``dgplate run`` of the FvK square problem file with ``--set`` overrides."""
    return subprocess.run(
        [sys.executable, "-m", "dgplate", "run", str(FVK_SQUARE), "--out", str(out)]
        + [arg for s in settings for arg in ("--set", s)],
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_run_writes_the_outputs_of_every_model(tmp_path):
    out = tmp_path / "out"
    settings = ["mesh.cells=[4,4]", "newton.load_steps=2"]
    proc = run_fvk_square(out, settings)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["model"] == "fvk" and summary["load_steps"] == 2 and summary["w_max"] > 0
    assert summary["load"] == pytest.approx(402 * T**4)
    rows = (out / "history.csv").read_text().splitlines()
    assert rows[0].startswith("step,load_factor,") and len(rows) == 3
    assert (out / "deformation.bp").is_dir() and (out / "final.png").stat().st_size > 1000
    # the Gaussian curvature of the deflected surface is written, but FvK is no isometric plate
    assert (out / "deformation_gauss_curvature.bp").is_dir()
    assert "gauss_curvature_l1" not in summary and "isometry_defect_l1" not in summary


def test_cli_failed_fvk_exits_1_with_outputs_and_no_traceback(tmp_path):
    out = tmp_path / "out"
    settings = ["mesh.cells=[4,4]", "newton.load_steps=1", "newton.snes={snes_max_it=1}"]
    proc = run_fvk_square(out, settings)
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr and "DIVERGED_MAX_IT" in proc.stderr, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is False and "DIVERGED_MAX_IT" in summary["reason"]
    assert summary["steps"] == 0 and summary["w_max"] is None
    assert len((out / "history.csv").read_text().splitlines()) <= 1


@pytest.mark.parametrize(
    "data,message",
    [
        ({"nu": 0.5}, "model.nu must be in (-1, 0.5), got 0.5"),
        ({"nu": 0.6}, "model.nu must be in (-1, 0.5), got 0.6"),
        ({"nu": -1.0}, "model.nu must be in (-1, 0.5), got -1.0"),
        ({"thickness": 0.0}, "model.thickness must be > 0, got 0.0"),
        ({"thickness": -0.1}, "model.thickness must be > 0"),
        ({"E": 0}, "model.E must be > 0"),
        ({"degree": 1}, "model.degree must be >= 2"),
        ({"membrane": {"left": "sliding"}}, "model.membrane.left must be"),
        ({"penalty": {"gamma0": -1.0, "gamma1": 1.0}}, "model.penalty.gamma0 must be"),
        ({"penalty": {"gradient_power": 4}}, "model.penalty.gradient_power must be in [1, 3]"),
        ({"penalty": {"gamma2": 1.0}}, "unknown key model.penalty.gamma2"),
        (
            {"penalty_length": "height"},
            "model.penalty_length must be one of diameter, facet_normal, got 'height'",
        ),
        ({"clamped": ["left"], "simply_supported": ["left"]}, "both list 'left'"),
        ({"probe": [0.5]}, "model.probe must have 2 entries"),
        ({"xyz": 1}, "unknown key model.xyz"),
        ({"name": "kirchhoff"}, "model.name must be one of fvk"),
        ({"load_steps": 2}, "model.load_steps moved to newton.load_steps"),
        ({"snes": {}}, "model.snes moved to newton.snes"),
    ],
)
def test_bad_parameters(data, message):
    with pytest.raises(InputError, match=re.escape(message)):
        from_dict(FvKSpec, data, "model")


@pytest.mark.parametrize(
    "data,message",
    [
        ({"load_steps": 0}, "newton.load_steps must be >= 1"),
        ({"load_steps": [0.5, 0.2]}, "newton.load_steps must be a positive integer or"),
        ({"load_steps": [0.5, 1.5]}, "newton.load_steps[1] must be in (0, 1], got 1.5"),
        ({"snes": {"-snes_rtol": 1e-8}}, "newton.snes.-snes_rtol is not a PETSc option name"),
        ({"stability": 1}, "newton.stability must be bool"),
        ({"stability_modes": 0}, "newton.stability_modes must be >= 1"),
        ({"perturb_unstable": "big"}, "newton.perturb_unstable must be"),
        ({"perturb_unstable": 0.1, "stability": False}, "newton.perturb_unstable needs"),
        ({"eigensolver": "arpack"}, "newton.eigensolver must be one of auto, slepc, lanczos"),
    ],
)
def test_bad_newton_settings(data, message):
    with pytest.raises(InputError, match=re.escape(message)):
        from_dict(NewtonSpec, data, "newton")


def test_penalty_defaults_and_gradient_power():
    """Missing penalty keys keep the FvK defaults; gradient_power reaches the penalty."""
    assert FvKSpec().penalty == from_dict(FvKSpec, {"penalty": {}}, "model").penalty == PENALTY
    penalty = from_dict(FvKSpec, {"penalty": {"gamma1": 50.0, "gradient_power": 2}}, "model")
    assert penalty.penalty == Penalty(100.0, 50.0, 2.0)


@pytest.mark.parametrize("key", ["clamped", "simply_supported", "crease", "membrane"])
def test_unknown_boundary_group(key):
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [2, 2])
    data = {"clamped": ["left"], key: {"nowhere": "fixed"} if key == "membrane" else ["nowhere"]}
    with pytest.raises(InputError, match=rf"model.{key}: unknown facet group 'nowhere'"):
        build_fvk(from_dict(FvKSpec, data, "model"), tagged)


def test_misplaced_groups():
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [2, 2])
    with pytest.raises(InputError, match="crease group 'left'"):
        build_fvk(FvKSpec(clamped=["right"], crease=["left"]), tagged)
    with pytest.raises(InputError, match="no edge holds the in-plane displacement"):
        build_fvk(FvKSpec(clamped=["left"], membrane={"left": "free"}), tagged)
    with pytest.raises(InputError, match=r"model.probe \[2.0, 0.5\] lies outside the mesh"):
        build_fvk(FvKSpec(clamped=["left"], probe=[2.0, 0.5]), tagged)


def test_problem_file_is_valid():
    """demos/problems/fvk_square.toml: a valid [model] table and Levy's problem."""
    import tomllib

    data = tomllib.loads(FVK_SQUARE.read_text())
    spec = model_spec(data["model"])
    assert isinstance(spec, FvKSpec)
    assert spec.nu == LEVY_NU and spec.pressure == pytest.approx(LEVY_Q[-1] * T**4)
    assert data["mesh"]["type"] == "rectangle" and set(spec.membrane) == set(spec.clamped)


def test_registered_like_every_model():
    """fvk builds through the registry; [output] applies to it, [flow] does not."""
    assert MODELS["fvk"].spec is FvKSpec and MODELS["fvk"].build is build_fvk
    model = {"name": "fvk", "clamped": ["left"]}
    problem = problem_from_dict({"model": model, "output": {"png": False, "every": 2}}, "p")
    assert problem.output.png is False
    with pytest.raises(InputError, match=r"flow\.tau has no effect with model\.name = 'fvk'"):
        problem_from_dict({"model": model, "flow": {"tau": 0.1}}, "p")


# -- stability along the path ------------------------------------------------------------------
DELTA_CR = 4 * np.pi**2 * D / (E * T)  # N_cr a/(E t), a = 1: Timoshenko & Gere §9.2, k = 4
SHORTENING = [0.9, 0.99, 1.01, 1.1]  # Δ/Δ_cr at the load steps


def buckling_run(comm, n=8, **keys):
    """The perfect plate of demos/fvk_buckling.py (no imperfection) shortened to 1.1 Δ_cr."""
    tagged = rectangle(comm, [[0, 0], [1, 1]], [n, n])
    membrane = {"left": [0.0, "free"], "right": [-SHORTENING[-1] * DELTA_CR, "free"],
                "bottom": "normal", "top": "free"}  # fmt: skip
    factors = [s / SHORTENING[-1] for s in SHORTENING[:-1]] + [1.0]
    spec = dict(E=E, nu=NU, thickness=T, simply_supported=list(RECTANGLE_SIDES),
                membrane=membrane, load_steps=factors, **keys)  # fmt: skip
    with newton(tagged, **spec) as (model, driver):
        assert driver.run().converged
        return {**driver.summary(), **model.figures(driver)}


@pytest.mark.mpi
def test_lowest_eigenvalue_crosses_zero_at_timoshenko_load():
    """The flat plate loses stability within 2 % of N_cr = 4π²D/a² (8×8 Q2: −0.47 %).

    On the flat branch (w = 0) the Hessian is the bending operator minus the compression's
    geometric stiffness; its lowest eigenvalue crosses zero at the discrete buckling load.
    Pushed along the unstable mode (0.5 t), the plate takes the buckled branch, which is stable.
    Also under mpirun: the same numbers on 1 and 2 ranks.
    """
    flat = buckling_run(MPI.COMM_WORLD)
    lowest = flat["lowest_eigenvalues"]
    assert lowest[0] > lowest[1] > 0 > lowest[2] > lowest[3] and flat["w_max"] == 0
    critical = flat["critical_load_factor"] * SHORTENING[-1]  # Δ/Δ_cr at the crossing
    assert critical == pytest.approx(1.0, rel=0.02)
    assert critical == pytest.approx(0.99527, abs=2e-5)  # the measured −0.47 % (docs/fvk.md)
    if MPI.COMM_WORLD.size > 1:
        serial = buckling_run(MPI.COMM_SELF)
        assert flat["lowest_eigenvalues"] == pytest.approx(serial["lowest_eigenvalues"], rel=1e-7)
    pushed = buckling_run(MPI.COMM_WORLD, perturb_unstable=0.5 * T, eigensolver="lanczos")
    assert [p["load_factor"] * SHORTENING[-1] for p in pushed["perturbations"]] == pytest.approx(
        [1.01]
    )
    assert pushed["eigensolver"] == "lanczos" and min(pushed["lowest_eigenvalues"]) > 0
    # post-buckling: w_c ∝ √(Δ/Δ_cr − 1); at 1.1 Δ_cr about 0.57 t on 8×8
    assert 0.3 * T < pushed["w_center"] < 1.0 * T


# -- natural shapes ----------------------------------------------------------------------------
def test_natural_shape_sets_the_metric():
    """A plate whose natural shape is the tilted plane w₀ = a x, clamped and held at x = 0.

    Its natural length along x is that of the tilted plane: ε = sym∇u + ½(∇w⊗∇w − a² eₓ⊗eₓ)
    vanishes for w = 0 and u = (½a² x, 0), which is exact in the discrete space (energy 0).
    Held at both ends (u_x = 0 at x = 1) it is compressed by ½a² instead, as with an equal
    prestrain along x; prescribing u_x = ½a² on the right edge relieves it again.
    """
    a = 0.1
    tagged = rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [4, 4])
    keys = dict(E=E, nu=NU, thickness=T, clamped=["left"], natural_shape=f"{a}*x",
                stability=False, load_steps=1)  # fmt: skip
    for membrane in ({}, {"right": [0.5 * a**2, "free"]}):
        with newton(tagged, membrane=membrane, **keys) as (model, driver):
            assert driver.run().converged
            _, dofs = model.space.sub(1).sub(0).collapse()
            ux = driver.state.x.array[dofs]
            top = driver.comm.allreduce(float(ux.max(initial=-np.inf)), op=MPI.MAX)
            assert top == pytest.approx(0.5 * a**2, rel=1e-8)
            assert abs(driver.history[-1].w_max) < 1e-10 and abs(driver.energy_value()) < 1e-16


@pytest.mark.parametrize(
    "value,message",
    [
        ("0.1*x +", "model.natural_shape: "),
        ("foo(x)", "model.natural_shape"),
        ([1, 2], "model.natural_shape"),
    ],
)
def test_bad_natural_shape(value, message):
    with pytest.raises(InputError, match=message):
        from_dict(FvKSpec, {"natural_shape": value}, "model")


def test_buckling_problem_file_reports_the_crossing(tmp_path):
    """demos/problems/fvk_buckling.toml through `dgplate run` (8×8): history.csv has the
    eigenvalue column, summary.json the crossing within 2 % of Timoshenko's N_cr and the push."""
    problem = FVK_SQUARE.parent / "fvk_buckling.toml"
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "dgplate", "run", str(problem), "--out", str(out),
         "--set", "mesh.cells=[8, 8]"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["critical_load_factor"] * 1.3 == pytest.approx(1.0, rel=0.02)
    assert [round(p["load_factor"] * 1.3, 4) for p in summary["perturbations"]] == [1.02]
    assert summary["lowest_eigenvalues"][-1] > 0 and summary["w_max"] > 0.5 * T
    header = (out / "history.csv").read_text().splitlines()[0]
    assert header.endswith(",lowest_eigenvalue")
