"""One-sided compression of an FvK sheet: wrinkle wavelength against distance, mesh and thickness.

The unit square (ν = 0, E = 1) is clamped and held at x = 1; the edge x = 0 is pulled out by τ
and shortened by the fraction c (u = (−τ, −c(y − ½)), a formula scaled with the load), the
edges y = 0, 1 are free (docs/fvk_experiments.md). The flat sheet is pushed along its unstable
mode when the lowest Hessian eigenvalue turns negative (``perturb_unstable``); the wrinkle
wavelength is measured by FFT of w along the lines x = d at the last converged load step:

    python benchmarks/fvk_one_sided.py --cells 16 24 32 --thickness 0.005 0.0035 \
        --json benchmarks/results/fvk_one_sided.json

With ``--nested`` (serial) only the first mesh of the first thickness is pushed off the flat
state; every finer mesh starts, at full load, from the previous mesh's state interpolated onto
it, and the first mesh of the next thickness from the first mesh's state of the previous one,
so that all runs follow the branch selected once (Newton then converges to the nearby state of
the other discretisation or thickness instead of picking one of the many coexisting states,
or the flat one, anew):

    python benchmarks/fvk_one_sided.py --nested --cells 24 32 40 --thickness 0.005 0.0035 \
        --json benchmarks/results/fvk_one_sided_nested.json

With ``--relaxation TAU`` every solve is the energy-decreasing proximal gradient flow of
``newton.relaxation`` (first pseudo-time step TAU) followed by Newton, so the push along the
unstable mode slides down to a stable state instead of returning to the flat one:

    python benchmarks/fvk_one_sided.py --relaxation 1e6 --cells 16 24 --thickness 0.005 0.0035 \
        --json benchmarks/results/fvk_one_sided_relaxation.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from dgplate.compat import Function
from dgplate.measure.wrinkles import line_values, wrinkle_profile
from dgplate.mesh.tagged import rectangle
from dgplate.models.fvk.model import build_fvk
from dgplate.models.fvk.spec import FvKSpec, NewtonSpec
from dgplate.solvers.stability import LOWEST

DISTANCES = (0.0, 0.05, 0.1, 0.2, 0.6)


class Interpolated:
    """The deformation (x + u, w) of a converged state, as an ``initial`` for another mesh.

    Serial: the state is evaluated at the other mesh's points by :func:`line_values`.
    """

    def __init__(self, state: dolfinx.fem.Function) -> None:
        self.parts = []
        for sub in (state.function_space.sub(1).sub(0), state.function_space.sub(1).sub(1),
                    state.function_space.sub(0)):  # fmt: skip
            space, dofs = sub.collapse()
            part: Function = dolfinx.fem.Function(space)
            part.x.array[:] = state.x.array[dofs]
            self.parts.append(part)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """(x₁ + u₁, x₂ + u₂, w) at the points x (3 × n)."""
        points = np.clip(x[:2].T, 0.0, 1.0)
        ux, uy, w = (line_values(part, points) for part in self.parts)
        return np.vstack([x[0] + ux, x[1] + uy, w])


def run(
    cells: int,
    thickness: float,
    pull: float,
    shortening: float,
    steps: int,
    push: float = 0.1,
    initial: Interpolated | None = None,
    tau: float = 0.0,
) -> tuple[dict, Interpolated]:
    """One sheet: its path, wavelengths and amplitudes at :data:`DISTANCES` (collective).

    From ``initial`` (at full load, one step, no push) when given; also returns the final
    state as the start of a finer mesh. ``tau`` > 0: the relaxation (``newton.relaxation``)
    with that first pseudo-time step.
    """
    tagged = rectangle(MPI.COMM_WORLD, [[0.0, 0.0], [1.0, 1.0]], [cells, cells])
    spec = FvKSpec(
        E=1.0,
        nu=0.0,
        thickness=thickness,
        clamped=["right"],
        membrane={"left": [-pull, f"-{shortening}*(y - 0.5)"], "right": "fixed"},
        newton=NewtonSpec(
            load_steps=1 if initial else steps,
            perturb_unstable=0.0 if initial else push * thickness,
            relaxation=tau > 0,
            relaxation_tau=tau or 1.0,
        ),
    )
    model = build_fvk(spec, tagged)
    driver = model.driver(None, [], initial)
    start = time.perf_counter()
    result = driver.run()
    seconds = time.perf_counter() - start
    summary = driver.summary()
    space, dofs = model.space.sub(0).collapse()
    w: Function = dolfinx.fem.Function(space)
    w.x.array[:] = driver.state.x.array[dofs]
    profiles = [wrinkle_profile(w, [d, 0.0], [d, 1.0]) for d in DISTANCES]
    final = Interpolated(driver.state)
    lowest = [getattr(step, LOWEST) for step in driver.history]
    driver.destroy()
    return {
        "cells": cells,
        "thickness": thickness,
        "gamma": thickness / np.sqrt(12.0),
        "converged": result.converged,
        "load_factor": driver.history[-1].load_factor if driver.history else 0.0,
        "perturbations": summary.get("perturbations", []),
        "distances": list(DISTANCES),
        "wavelengths": [p["wavelength"] for p in profiles],
        "amplitudes": [p["amplitude"] for p in profiles],
        "seconds": seconds,
        "push": 0.0 if initial else push,
        "started_from_coarser_mesh": initial is not None,
        "lowest_eigenvalues": lowest,
        "energy": summary["energy"],
        "relaxation_tau": tau,
        "relaxation_steps": [len(r["energies"]) - 1 for r in summary.get("relaxations", [])],
        "energy_increases": summary.get("energy_increases", []),
        "ranks": MPI.COMM_WORLD.size,
    }, final


def main() -> None:
    """Run every (mesh, thickness) pair, print and write the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[16, 24, 32])
    parser.add_argument("--thickness", type=float, nargs="+", default=[0.005, 0.0035])
    parser.add_argument("--pull", type=float, default=0.005)
    parser.add_argument("--shortening", type=float, default=0.002)
    parser.add_argument("--steps", type=int, default=1)
    parser.add_argument("--push", type=float, default=0.1, help="perturb_unstable / t")
    parser.add_argument("--nested", action="store_true", help="finer meshes start from coarser")
    parser.add_argument(
        "--relaxation", type=float, default=0.0, help="first τ of the relaxation; 0: Newton"
    )
    parser.add_argument("--json", default="")
    args = parser.parse_args()
    if args.nested and MPI.COMM_WORLD.size > 1:
        raise SystemExit("--nested runs serially")
    runs = []
    seed = None  # --nested: the first mesh's state of the previous thickness
    for thickness in args.thickness:
        start = seed
        for i, cells in enumerate(args.cells):
            entry, final = run(
                cells,
                thickness,
                args.pull,
                args.shortening,
                args.steps,
                args.push,
                start,
                args.relaxation,
            )
            start = final if args.nested else None
            seed = final if args.nested and i == 0 else seed
            runs.append(entry)
            if MPI.COMM_WORLD.rank == 0:
                shown = " ".join(f"{v:.4f}" for v in entry["wavelengths"])
                print(
                    f"t={thickness} {cells}x{cells} λ(d={list(DISTANCES)}) = {shown} "
                    f"load {entry['load_factor']:.3f} {entry['seconds']:.0f} s",
                    flush=True,
                )
                if args.json:
                    Path(args.json).write_text(json.dumps({"runs": runs}, indent=2) + "\n")


if __name__ == "__main__":
    main()
