"""What several test modules share: the repository's folders, quiet outputs, the BNN plate's
flow and the ``mpirun`` beside the interpreter. Fixtures live in ``conftest.py``."""

from __future__ import annotations

import importlib.util
import json
import shutil
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

from mpi4py import MPI

from dgplate.mesh.tagged import rectangle
from dgplate.models.kirchhoff import KirchhoffSpec, build_kirchhoff
from dgplate.reference.bnn import bnn_h
from dgplate.solvers.flow import FlowSpec, GradientFlow

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "dgplate"
DEMOS = ROOT / "demos"
PROBLEMS = DEMOS / "problems"
BENCHMARKS = ROOT / "benchmarks"


def load_benchmark(name: str) -> ModuleType:
    """The script benchmarks/<name>.py as a module (its sibling pages.py importable)."""
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))
    spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCHMARKS / f"{name}.py")
    assert spec is not None and spec.loader is not None  # a .py file always has both
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


#: Overrides for a run whose outputs the test does not look at: no progress, VTX or pictures.
QUIET: dict[str, Any] = {"output.progress": 0, "output.vtx": False, "output.png": False}


def bnn_flow(comm: MPI.Comm, n: int, cell_type: str = "quadrilateral", **flow: Any) -> GradientFlow:
    """The gradient flow of the BNN plate (M3AS 2021, Table 1) on n × n cells.

    ω = (0, 4)² clamped flat on x₁ = 0 and x₂ = 0 under f = (0, 0, 2.5·10⁻²), degree 2;
    ``flow`` are [flow] keys (:class:`FlowSpec`), with τ = h = :func:`bnn_h` by default.
    """
    tagged = rectangle(comm, [[0, 0], [4, 4]], [n, n], cell_type)
    spec = KirchhoffSpec(degree=2, clamped=["left", "bottom"], load=[0, 0, 2.5e-2])
    model = build_kirchhoff(spec, tagged)
    settings = FlowSpec(**{"tau": bnn_h(n), **flow})
    return GradientFlow(model.facets, model.degree, model.energy, settings)


def mpirun() -> str | None:
    """The ``mpirun`` beside the interpreter (the venv's), else the one on PATH; None: none."""
    beside = Path(sys.executable).parent / "mpirun"
    return str(beside) if beside.exists() else shutil.which("mpirun")


# Rank parity of a nonlinear flow. Each step solves a saddle-point system whose condition
# number grows like h^-4 (about 1e6 on the test meshes); a different partition changes the
# summation order and MUMPS' pivot sequence, so the iterates may differ by cond * eps ~ 1e-10
# per step, and a few dozen steps accumulate that. 1e-8 is far below any discretisation
# effect (those are 1e-3 and larger) and still catches a wrong ghost or a missing reduction,
# which show up at 1e-3 and beyond.
PARITY_RTOL = 1e-8


def assert_same_points(
    parallel: Any, serial: Any, keys: tuple[str, ...], rel: float = PARITY_RTOL, abs: float = 0.0
) -> None:
    """Two paths' stability indices equal and their points' ``keys`` within ``rel``, ``abs``."""
    import pytest

    assert parallel.stability_indices == serial.stability_indices
    for key in keys:
        got, expected = ([p[key] for p in run.points] for run in (parallel, serial))
        assert got == pytest.approx(expected, rel=rel, abs=abs), key


def rates(errors: list[float]) -> list[float]:
    """Observed convergence rates for a sequence of errors at halved mesh sizes."""
    import numpy as np

    e = np.asarray(errors)
    return list(np.log2(e[:-1] / e[1:]))


def check_load_is_derivative(term, y, direction, comm, rel_tol: float = 1e-5) -> None:
    """A self-avoidance term's assembled load against central differences of its energy.

    ``term.update()`` returns ρ·TP at the current ``y``; ``term.linearisation`` is the form
    whose derivative in ``y`` is the load. ``direction`` is a Function in ``y``'s space.
    """
    import math

    import dolfinx.fem.petsc
    import ufl

    value = term.update()
    V = y.function_space
    load = dolfinx.fem.petsc.assemble_vector(
        dolfinx.fem.form(ufl.derivative(term.linearisation, y, ufl.TestFunction(V)))
    )
    load.ghostUpdate(addv=True, mode="reverse")  # ADD, REVERSE
    owned = V.dofmap.index_map.size_local * 3
    exact = comm.allreduce(float(load.array[:owned] @ direction.x.array[:owned]))
    eps, base = 1e-6, y.x.array.copy()
    values = []
    for sign in (1, -1):
        y.x.array[:] = base + sign * eps * direction.x.array
        values.append(term.update())
    y.x.array[:] = base
    assert value > 0 and abs(exact) > 0
    assert math.isclose((values[0] - values[1]) / (2 * eps), exact, rel_tol=rel_tol)


def check_pair_sum_derivatives(cloud, q: float, seed: int, rel_tol: float = 1e-6) -> None:
    """∂TP/∂x and ∂TP/∂ν (or ∂TP/∂t of a curve) of the exact sums against central differences."""
    import math

    import numpy as np

    from dgplate.dg import tangent_point as tp

    rng = np.random.default_rng(seed)
    dx, dn = rng.normal(size=cloud.points.shape), rng.normal(size=cloud.normals.shape)
    base = tp.evaluate(cloud, q, theta=0.0)
    eps = 1e-6

    def energy(sign: float) -> float:
        moved = tp.Cloud(
            cloud.points + sign * eps * dx,
            cloud.normals + sign * eps * dn,
            cloud.weights,
            cloud.vertices,
            curve=cloud.curve,
        )
        return tp.evaluate(moved, q, theta=0.0).energy

    fd = (energy(1) - energy(-1)) / (2 * eps)
    exact = np.sum(base.d_points * dx) + np.sum(base.d_normals * dn)
    assert math.isclose(fd, exact, rel_tol=rel_tol)


def summary_of(out: Path) -> dict:
    """The ``summary.json`` of a run's output folder."""
    return json.loads((out / "summary.json").read_text())


def stop_and_resume(problem: Path, tmp_path: Path, options: list[str], max_steps: int):
    """Run ``problem`` to its end, and again stopped at ``max_steps`` (checkpoints every step)
    and then resumed; the two histories must agree in step, time, τ and E_h of every step.

    Returns the summaries of the whole run, of the stopped run and of the resumed run.
    """
    from dgplate.cli import main

    reference, out = tmp_path / "reference", tmp_path / "resumed"
    assert main(["run", str(problem), "--out", str(reference), *options]) == 0
    budget = [f"--set=flow.max_steps={max_steps}", "--set=flow.checkpoint_every=1"]
    assert main(["run", str(problem), "--out", str(out), *options, *budget]) == 1
    stopped = summary_of(out)
    assert main(["run", str(problem), "--out", str(out), *options, "--resume"]) == 0
    rows = [line.split(",")[:4] for line in (out / "history.csv").read_text().splitlines()]
    lines = (reference / "history.csv").read_text().splitlines()
    assert rows == [line.split(",")[:4] for line in lines]
    return summary_of(reference), stopped, summary_of(out)
