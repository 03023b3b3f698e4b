"""How the penalty ε of a rigid obstacle shows in the contact: lift-off length and penetration.

The heavy strip of ``tests/models/test_obstacle.py`` (ω = (0, 2) × (0, 0.25), clamped horizontally at
height H = 0.02 above the table y₃ ≥ 0, weight q = 1, μ = 1) is run from the flat start at the
clamp's height for several ε on one mesh. Reported per ε: the plate's lift-off point (where the
contact starts), the lift-off ℓ_ε of the one-dimensional penalised beam
(:func:`dgplate.reference.obstacle_profiles.penalised_lift_off`), the rigid-table ℓ, the maximal
penetration (also in units of qε, the sinking of the part that the penalty carries alone),
steps and seconds.

    python benchmarks/obstacle_epsilon.py --cells 16 --json benchmarks/results/obstacle_epsilon.json

The 1D reference alone (no plate runs, seconds) for smaller ε: ``--beam-only``. With
``--treatment active_set`` the penalty acts implicitly on the contact set only
(docs/obstacle.md), which makes ε down to 1e-10 affordable; ``--projection-steps 2`` keeps the
isometry defect at round-off:

    python benchmarks/obstacle_epsilon.py --treatment active_set --projection-steps 2 \
        --eps 1e-3 1e-4 1e-5 1e-6 1e-7 1e-8 1e-9 1e-10 \
        --json benchmarks/results/obstacle_epsilon_active_set.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

import dgplate
from dgplate.io.output import print0
from dgplate.reference.obstacle_profiles import lift_off_length, penalised_lift_off

MU, HEIGHT, WEIGHT, LENGTH, WIDTH = 1.0, 0.02, 1.0, 2.0, 0.25
STRIP = Path(__file__).resolve().parent.parent / "demos" / "problems" / "obstacle_strip.toml"


def strip(cells: int, epsilon: float, args: argparse.Namespace) -> dgplate.Problem:
    """The strip problem (demos/problems/obstacle_strip.toml) at penalty ε."""
    return dgplate.load_problem(
        STRIP,
        {
            "mesh.cells": [cells, 2],
            "model.obstacle.epsilon": epsilon,
            "model.obstacle.treatment": args.treatment,
            "flow.projection_steps": args.projection_steps,
            "flow.max_steps": args.max_steps,
            "output.png": False,
            "output.vtx": False,
        },
    )


def main() -> None:
    """Run the strip for each ε and print (and write) the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=16)
    parser.add_argument("--eps", type=float, nargs="+", default=[1e-3, 5e-4, 2e-4, 1e-4, 5e-5])
    parser.add_argument("--max-steps", type=int, default=3000)
    parser.add_argument("--treatment", default="splitting", choices=["splitting", "active_set"])
    parser.add_argument("--projection-steps", type=int, default=0)
    parser.add_argument("--beam-only", action="store_true", help="only the 1D penalised beam")
    parser.add_argument("--out", default="out/obstacle_epsilon")
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    ell = lift_off_length(MU, HEIGHT, WEIGHT)
    rows = []
    for eps in args.eps:
        row: dict[str, object] = {
            "epsilon": eps,
            "ell": ell,
            "ell_eps_beam": penalised_lift_off(MU, HEIGHT, WEIGHT, eps, LENGTH, n=1600),
        }
        if not args.beam_only:
            t0 = time.perf_counter()
            result = dgplate.run(
                strip(args.cells, eps, args),
                out=Path(args.out) / f"eps{eps:g}",
                comm=comm,
                force=True,
            )
            row.update(
                lift_off=result["contact_extent"][0] if result["contact_extent"] else None,
                max_penetration=result["max_penetration"],
                penetration_over_q_eps=result["max_penetration"] / (WEIGHT * eps),
                contact_force=result["contact_force"],
                steps=result["steps"],
                active_set_changes=result["active_set_changes"],
                active_set_redos=result["active_set_redos"],
                tau_changes=result["refactorisations"],
                factorisations=result["factorisations"],
                isometry_defect=result["isometry_defect"],
                converged=result["converged"],
                energy_increases=len(result["energy_increases"]),
                seconds=time.perf_counter() - t0,
            )
        rows.append(row)
        print0(comm, json.dumps(row))
    if args.json and comm.rank == 0:
        settings = {"cells": args.cells, "treatment": args.treatment}
        settings["projection_steps"] = args.projection_steps
        Path(args.json).write_text(json.dumps({**settings, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
