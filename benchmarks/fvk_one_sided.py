"""One-sided compression of an FvK sheet: wrinkle wavelength against distance, mesh and thickness.

The unit square (ν = 0, E = 1) is clamped and held at x = 1; the edge x = 0 is pulled out by τ
and shortened by the fraction c (u = (−τ, −c(y − ½)), a formula scaled with the load), the
edges y = 0, 1 are free (docs/fvk_experiments.md). The flat sheet is pushed along its unstable
mode when the lowest Hessian eigenvalue turns negative (``perturb_unstable``); the wrinkle
wavelength is measured by FFT of w along the lines x = d at the last converged load step:

    python benchmarks/fvk_one_sided.py --cells 16 24 32 --thickness 0.005 0.0035 \
        --json benchmarks/results/fvk_one_sided.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from dgplate.measure.wrinkles import wrinkle_profile
from dgplate.mesh.tagged import rectangle
from dgplate.models.fvk import FvKSpec, build_fvk

DISTANCES = (0.0, 0.05, 0.1, 0.2, 0.6)


def run(
    cells: int, thickness: float, pull: float, shortening: float, steps: int, push: float = 0.1
) -> dict:
    """One sheet: its path, wavelengths and amplitudes at :data:`DISTANCES` (collective)."""
    tagged = rectangle(MPI.COMM_WORLD, [[0.0, 0.0], [1.0, 1.0]], [cells, cells])
    spec = FvKSpec(
        E=1.0,
        nu=0.0,
        thickness=thickness,
        clamped=["right"],
        membrane={"left": [-pull, f"-{shortening}*(y - 0.5)"], "right": "fixed"},
        load_steps=steps,
        perturb_unstable=push * thickness,
    )
    model = build_fvk(spec, tagged)
    driver = model.driver(None, [], None)
    start = time.perf_counter()
    result = driver.run()
    seconds = time.perf_counter() - start
    summary = driver.summary()
    space, dofs = model.space.sub(0).collapse()
    w = dolfinx.fem.Function(space)
    w.x.array[:] = driver.state.x.array[dofs]
    profiles = [wrinkle_profile(w, [d, 0.0], [d, 1.0]) for d in DISTANCES]
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
        "push": push,
        "ranks": MPI.COMM_WORLD.size,
    }


def main() -> None:
    """Run every (mesh, thickness) pair, print and write the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[16, 24, 32])
    parser.add_argument("--thickness", type=float, nargs="+", default=[0.005, 0.0035])
    parser.add_argument("--pull", type=float, default=0.005)
    parser.add_argument("--shortening", type=float, default=0.002)
    parser.add_argument("--steps", type=int, default=1)
    parser.add_argument("--push", type=float, default=0.1, help="perturb_unstable / t")
    parser.add_argument("--json", default="")
    args = parser.parse_args()
    runs = []
    for thickness in args.thickness:
        for cells in args.cells:
            entry = run(cells, thickness, args.pull, args.shortening, args.steps, args.push)
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
