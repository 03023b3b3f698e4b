"""The self-folding box's plate relaxations (its holds) with fixed τ, adaptive τ and the SQP finish.

The box (demos/problems/box_folding.toml) is heated step by step to the switch t = 28.2 with
the problem's own settings, every relaxation stopping at ‖P DE_h[yⁿ]‖_*' < tol
(``flow.stop = 'stationarity'``) or at its budget. At each hold (the closed box at t = 28.2,
the flat net at t = 56.4) the same state is relaxed three times to that stop: with a fixed
τ (``--hold-tau``: by default h, the largest cell diameter, as for the other problems of
benchmarks/adaptive_tau.py), with adaptive τ from it, and with adaptive τ and the SQP finish. The run then goes on from the fixed-τ result, so all three variants of a
hold start from the same state and the path between the holds is the published one. The
record holds, per hold and variant, the accepted and rejected steps, the step solves (each
attempted step and its corrections: the flow's count), E_h, D_h, the steps at which E_h
rose and the wall time.

    python benchmarks/box_relaxation.py --json benchmarks/results/box_relaxation_np1.json
    mpirun -n 2 python benchmarks/box_relaxation.py --tol 1e-4 --hold-tau 0.25
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate.coupling.thermal_driver import ThermalBilayer
from dgplate.dg.geometry import max_cell_diameter
from dgplate.io.output import print0
from dgplate.problems.prepare import build_mesh
from dgplate.problems.registry import MODELS
from dgplate.problems.specs import load_problem

BOX = Path(__file__).resolve().parent.parent / "demos" / "problems" / "box_folding.toml"
VARIANTS = {"fixed": (False, False), "adaptive": (True, False), "newton": (True, True)}


def relax(
    driver: ThermalBilayer, adaptive: bool, newton: bool, budget: int, tau: float
) -> dict[str, Any]:
    """One hold from the driver's current state with the given τ control; its counts."""
    flow = driver.flow
    settings = flow.settings
    settings.adaptive_tau, settings.newton_finish = adaptive, newton
    settings.step_control = "defect_bound"  # that of docs/performance.md's tables
    # the controller's cap and SQP threshold are ratios to the flow's initial τ (the heat
    # steps' τ): rescaled, they are the defaults' ratios to the hold's τ, as for a flow that
    # starts with it (the other problems of benchmarks/adaptive_tau.py)
    ratios = (settings.tau_max_ratio, settings.newton_tau_ratio)
    scale = tau / flow.tau
    settings.tau_max_ratio, settings.newton_tau_ratio = (r * scale for r in ratios)
    counts = flow.counts
    before = (
        counts.rejected_steps,
        counts.newton_steps,
        counts.newton_rejections,
        counts.step_solves,
    )
    t0 = time.perf_counter()
    record = driver.hold(budget, tau)
    wall = time.perf_counter() - t0
    settings.tau_max_ratio, settings.newton_tau_ratio = ratios
    result = driver.last_result
    assert result is not None
    after = (
        counts.rejected_steps,
        counts.newton_steps,
        counts.newton_rejections,
        counts.step_solves,
    )
    rejected, newton_steps, newton_rejections, step_solves = (
        a - b for a, b in zip(after, before, strict=True)
    )
    return {
        "converged": result.converged,
        "reason": result.reason,
        "steps": result.steps,
        "rejected_steps": rejected,
        "newton_steps": newton_steps,
        "newton_rejections": newton_rejections,
        "step_solves": step_solves,
        "energy": record.energy,
        "isometry_defect": record.defect,
        "energy_increases": list(result.energy_increases),
        "taus": [info.tau for info in result.history],
        "stationarity": [info.stationarity for info in result.history],
        "wall_s": wall,
    }


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tol", type=float, default=1e-5, help="the stationarity stop")
    parser.add_argument("--budget", type=int, default=3000, help="steps per hold")
    parser.add_argument(
        "--hold-tau",
        default="h",
        help="τ of the holds: 'h' (the largest cell diameter) or a number",
    )
    parser.add_argument("--set", action="append", default=[], help="key=value for the box")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    texts = [
        # the path between the holds as published: fixed τ and one projection per step (the
        # box's settings before the thermal model took the accurate flow)
        "flow.method='bnn'",
        "flow.projection_steps=1",
        "flow.stop='stationarity'",
        f"flow.tol={args.tol}",
        "flow.checkpoint_every=0",
        *args.set,
    ]
    problem = load_problem(BOX, texts)
    tagged = build_mesh(problem.mesh, comm)
    model = MODELS["thermal"].build(problem.model, tagged)
    model.calibrate(problem.flow)  # model.alpha = "calibrate", as a run does
    driver = model.driver(problem.flow, [], None)
    assert isinstance(driver, ThermalBilayer)
    tau = max_cell_diameter(tagged.mesh) if args.hold_tau == "h" else float(args.hold_tau)
    holds: list[dict[str, Any]] = []
    for t_hold in driver.schedule.holds:
        while driver.heat.time < t_hold - 1e-9 * driver.heat.dt:
            driver.advance()
        start = driver.y.x.array.copy()
        runs: dict[str, Any] = {}
        for name, (adaptive, newton) in reversed(VARIANTS.items()):  # fixed last: it goes on
            driver.y.x.array[:] = start
            runs[name] = relax(driver, adaptive, newton, args.budget, tau)
            print0(comm, f"hold t = {t_hold:g}, {name}: {json.dumps(_brief(runs[name]))}")
        fixed = runs["fixed"]
        for name in ("adaptive", "newton"):
            run = runs[name]
            run["ratio_step_solves"] = fixed["step_solves"] / max(run["step_solves"], 1)
            run["energy_relative_difference"] = abs(run["energy"] - fixed["energy"]) / abs(
                fixed["energy"]
            )
        holds.append({"time": t_hold, "dofs": driver.num_dofs, **runs})
    record = {
        "problem": str(BOX.name),
        "settings": texts,
        "hold_tau": tau,
        "tol": args.tol,
        "ranks": comm.size,
        "holds": holds,
    }
    print0(comm, json.dumps([{k: _brief(v) for k, v in h.items()} for h in holds], indent=1))
    if args.json and comm.rank == 0:
        args.json.write_text(json.dumps(record, indent=2) + "\n")
    driver.destroy()


def _brief(value: Any) -> Any:
    """A run's record without its per-step lists (for the terminal)."""
    if isinstance(value, dict):
        return {k: v for k, v in value.items() if k not in ("taus", "stationarity")}
    return value


if __name__ == "__main__":
    main(sys.argv[1:])
