"""Closed rods of length L = 1 in spheres of decreasing radius R: μ-circles and μ-ν-clews.

The published experiment (Bartels and Weyer): the energy minimising closed rods of length L in a
ball of radius R are μ-circles (a circle covered μ times) or μ-ν-clews (μ turns about a
discrete rotation axis, a 2ν-periodic curvature), and lie on the sphere. Here, for each
L/(2πR) of ``--ratios``, a closed rod (c_b = 1, c_t = 0.5, ``--cells`` cells, degree 2) flows
with the confinement (ε = ``--epsilon``) and the tangent-point self-avoidance (ρ = ``--rho``,
q = 3: it must not pass through itself, or a rod that winds more than once could cross),
with ``--projection`` Newton corrections towards the constraints after every step (1:
without them the constraint defects grow like tτ and the discrete rod kinks at its nodes,
docs/rods.md), until ΔE/τ < ``--tol`` or ``--steps`` steps, from starts that lie in the ball:

- ``clew``: the spherical curve (cos θ cos t, cos θ sin t, sin θ), θ = a sin 2t, a 1-2 clew
  whose amplitude a makes it ``--slack`` times longer than the great circle of the ball it
  is scaled into (so it lies inside; possible while L/(2πR)·slack < 2.04, a < 1.55);
- ``wound``: the (μ₀, 1) torus curve ((1 + r cos t) cos μ₀t, (1 + r cos t) sin μ₀t, r sin t),
  r = 0.15, an unknot that winds μ₀ = ⌊L/(2πR)⌋ + 1 times about e₃, near the μ₀-circle
  (which fits: L/(2πμ₀) < R);
- ``circle`` (only for an integer L/(2πR) = μ ≥ 2, where the μ-circle is a great circle):
  the wavy μ-circle (cos μt, sin μt, A sin (2μ + 1)t), A chosen so that it reaches 0.98 R;
  it crosses itself, so it is meant for ``--rho 0``.

The final shape is classified by :func:`dgplate.measure.rod_shapes.classify` (μ the winding
number about the axis of ∮ u × u′, 2ν the number of curvature maxima, a circle when the
curvature varies by less than 10 %), and drawn (tube, stripe along b, the sphere) into
``--pictures``. Every run's energies (bending, torsion, jumps, torsion defect, confinement, ρ·TP), least distance,
steps and wall time go into ``--json``.

    python benchmarks/rod_sphere_study.py --json benchmarks/results/rod_sphere_study.json \\
        --pictures docs/img/rod_sphere_study

``--fine`` runs 96 cells and 6000 steps instead (not part of the default budget). With
``--rho 0 --starts wound`` the rod may pass through itself: an embedded curve on the sphere
winds at most once about an axis, so clews and circles with μ ≥ 2 on the sphere cross
themselves, and only a rod that may cross can reach them (docs/rods.md). The JSON is written
after every run; ``--append`` keeps the runs of other (ratio, start) pairs already in it, so
that the study can be split over invocations by ``--ratios``.

``--history-every n`` keeps every n-th step's energy, ΔE/τ, redone steps and least distance
in the JSON (how a run approaches the stopping test, or why it does not). ``--keep`` writes
the runs' folders (and checkpoints) there instead of a temporary folder, and ``--resume``
continues each run from its checkpoint in ``--keep`` up to the larger ``--steps``: a run
stopped by SIGTERM writes its checkpoint and can be taken up again.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

import dgplate
from dgplate.io.output import print0
from dgplate.io.rod_pictures import plot_rod
from dgplate.measure.rod_figures import nodes_in_order
from dgplate.measure.rod_shapes import classify

SPHERE = Path(__file__).resolve().parent.parent / "demos" / "problems" / "rod_sphere.toml"
TORUS_R = 0.15  # the tube radius of the wound start, relative to its core radius 1
CIRCLE_REACH = 0.98  # the circle start's largest |u| / R
SKIPPED = {
    "clew": "the 1-2 clew start does not fit",
    "circle": "no μ-circle on the sphere (L/2πR is not an integer μ ≥ 2)",
}
FIGURES = (
    "energy",
    "energy_bending",
    "energy_torsion",
    "energy_confinement",
    "energy_self_avoidance",
    "energy_jumps",
    "energy_torsion_defect",
    "energy_rest",
    "min_distance",
    "max_distance_to_center",
    "writhe",
    "length",
    "defect_tangent",
    "defect_orthogonality",
    "defect_frame",
    "steps",
    "converged",
)
HISTORY = ("step", "energy", "rate", "redone", "min_distance")  # kept by --history-every


def clew_length(amplitude: float, samples: int = 20000) -> float:
    """The length of the unit-sphere 1-2 clew with θ = a sin 2t over 2π."""
    t = np.linspace(0.0, 2.0 * math.pi, samples + 1)
    theta = amplitude * np.sin(2.0 * t)
    p = np.c_[np.cos(theta) * np.cos(t), np.cos(theta) * np.sin(t), np.sin(theta)]
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))) / (2.0 * math.pi)


def clew_amplitude(target: float) -> float | None:
    """The amplitude a ∈ (0, 1.55) whose clew is ``target`` times the great circle (bisection)."""
    low, high = 0.0, 1.55
    if clew_length(high) < target:
        return None
    for _ in range(50):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if clew_length(middle) < target else (low, middle)
    return 0.5 * (low + high)


def wavy_circle(turns: int, amplitude: float, samples: int = 20000) -> float:
    """max|u| · 2π·turns / length of the curve (cos μt, sin μt, A sin((2μ + 1)t)), μ = turns.

    Scaled to the length L = 2π·turns·R, the curve reaches this multiple of R.
    """
    t = np.linspace(0.0, 2.0 * math.pi, samples + 1)
    p = np.c_[np.cos(turns * t), np.sin(turns * t), amplitude * np.sin((2 * turns + 1) * t)]
    length = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
    return float(np.max(np.linalg.norm(p, axis=1))) * 2.0 * math.pi * turns / length


def circle_amplitude(turns: int, reach: float) -> float:
    """The wave amplitude A whose wavy μ-circle reaches ``reach``·R, L = 2πμR (bisection)."""
    low, high = 0.0, 0.5
    for _ in range(50):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if wavy_circle(turns, middle) > reach else (low, middle)
    return 0.5 * (low + high)


def start_curve(kind: str, ratio: float, slack: float) -> list[str] | None:
    """The formulas of the start ``kind`` for L/(2πR) = ratio, or None if it does not fit."""
    if kind == "circle":
        turns = round(ratio)
        if abs(ratio - turns) > 1e-9 or turns < 2:
            return None
        a = circle_amplitude(turns, CIRCLE_REACH)
        return [f"cos({turns}*t)", f"sin({turns}*t)", f"{a:.6f}*sin({2 * turns + 1}*t)"]
    if kind == "clew":
        amplitude = clew_amplitude(ratio * slack)
        if amplitude is None:
            return None
        theta = f"({amplitude:.6f}*sin(2*t))"
        return [f"cos({theta})*cos(t)", f"cos({theta})*sin(t)", f"sin({theta})"]
    turns = math.floor(ratio) + 1
    ring = f"(1 + {TORUS_R}*cos(t))"
    return [f"{ring}*cos({turns}*t)", f"{ring}*sin({turns}*t)", f"{TORUS_R}*sin(t)"]


def settings(args: argparse.Namespace, ratio: float, curve: list[str]) -> dict[str, object]:
    """The overrides of the sphere's problem file for one run."""
    radius = 1.0 / (2.0 * math.pi * ratio)
    return {
        "model.cells": args.cells,
        "model.saddle": 0.0,
        "model.curve": curve,
        "model.confinement": {"radius": radius, "center": [0.0, 0.0, 0.0], "epsilon": args.epsilon},
        "model.self_avoidance": {"rho": args.rho, "q": 3.0},
        "flow.tau": args.tau,
        "flow.tol": args.tol,
        "flow.max_steps": args.steps,
        "flow.projection_steps": args.projection,
        "output.progress": args.progress,
        "output.vtx": False,
        "output.png": False,
    }


def picture(result: Any, radius: float, path: Path, title: str) -> None:
    """The rod as a tube with a stripe along b inside the translucent sphere (collective).

    The tube is at least 0.004 thick, so that it stays visible where strands cross (ρ = 0).
    """
    u, b = result.fields["u"], result.fields["b"]
    plot_rod(
        u,
        b,
        path,
        title,
        min_radius=0.004,
        sphere=(radius, (0.0, 0.0, 0.0)),
        window_size=(600, 540),
    )


def thinned(history: list[dict[str, Any]], every: int) -> dict[str, list[Any]]:
    """Every ``every``-th row of the history (and the last) as columns of :data:`HISTORY`."""
    rows = [row for row in history if row["step"] % every == 0]
    if history and (not rows or rows[-1] is not history[-1]):
        rows.append(history[-1])
    return {key: [row.get(key) for row in rows] for key in HISTORY}


def one_run(args: argparse.Namespace, ratio: float, kind: str, scratch: Path) -> dict[str, Any]:
    """Flow one start in the ball of L/(2πR) = ratio; its figures and shape (collective)."""
    comm = MPI.COMM_WORLD
    curve = start_curve(kind, ratio, args.slack)
    if curve is None:
        print0(comm, f"L/2πR = {ratio:g} ({kind}): skipped, {SKIPPED[kind]}")
        return {"ratio": ratio, "start": kind, "skipped": SKIPPED[kind]}
    radius = 1.0 / (2.0 * math.pi * ratio)
    problem = dgplate.load_problem(SPHERE, settings(args, ratio, curve))
    wall = time.perf_counter()
    result = dgplate.run(problem, out=scratch / f"{kind}_{ratio}", comm=comm, resume=args.resume)
    wall = time.perf_counter() - wall
    shape = classify(nodes_in_order(result.fields["u"]), radius)
    name = f"ratio{ratio:g}_{kind}".replace(".", "_")
    if args.pictures:
        title = f"L/(2 pi R) = {ratio:g}, {kind} start: {shape.label}, E = {result['energy']:.1f}"
        picture(result, radius, Path(args.pictures) / f"{name}.png", title)
    row = {
        "ratio": ratio,
        "start": kind,
        "radius": radius,
        "curve": curve,
        **{key: result[key] for key in FIGURES},
        "energy_increases": len(result["energy_increases"]),
        "reason": result["reason"],
        "shape": shape.as_dict(),
        "picture": f"{name}.png" if args.pictures else None,
        "settings": {
            k: getattr(args, k) for k in ("cells", "tau", "tol", "epsilon", "rho", "projection")
        },
        "wall_time_s": wall,
    }
    if args.resume:  # wall_time_s is this invocation's; the steps' seconds span every one
        row["resumed"] = True
        row["step_seconds"] = sum(r["seconds"] for r in result.history)
    if args.history_every:
        row["history"] = thinned(result.history, args.history_every)
    print0(
        comm,
        f"L/2πR = {ratio:g} ({kind}): {shape.label} (winding {shape.winding:.2f}, "
        f"κ variation {shape.curvature_variation:.2f}, off the sphere "
        f"{shape.sphere_distance:.3f} R), E = {row['energy']:.3f}, bending "
        f"{row['energy_bending']:.3f}, {row['steps']} steps, converged {row['converged']}, "
        f"{wall:.0f} s",
    )
    return row


def main() -> None:
    """Run the study, print a line per run and write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ratios", type=float, nargs="+", default=[1.1, 1.3, 1.6, 2.0, 2.5, 3.0])
    parser.add_argument("--starts", nargs="+", default=["clew", "wound"])
    parser.add_argument("--cells", type=int, default=48)
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--tau", type=float, default=0.02)
    parser.add_argument("--tol", type=float, default=1e-3)
    parser.add_argument("--epsilon", type=float, default=1e-6)
    parser.add_argument("--rho", type=float, default=0.01)
    parser.add_argument("--projection", type=int, default=1, help="flow.projection_steps")
    parser.add_argument("--slack", type=float, default=1.02)
    parser.add_argument("--fine", action="store_true", help="96 cells, 6000 steps (slow)")
    parser.add_argument("--json", default=None)
    parser.add_argument(
        "--append",
        action="store_true",
        help="keep the runs of --json of other (ratio, start) pairs (a study split by --ratios)",
    )
    parser.add_argument("--pictures", default=None, help="a folder for one PNG per run")
    parser.add_argument("--progress", type=int, default=0, help="a progress line every n steps")
    parser.add_argument("--history-every", type=int, default=0, help="0: no history in the JSON")
    parser.add_argument("--keep", default=None, help="a folder for the runs (default: temporary)")
    parser.add_argument(
        "--resume", action="store_true", help="continue every run from its checkpoint in --keep"
    )
    args = parser.parse_args()
    if args.fine:
        args.cells, args.steps = 96, 6000
    comm = MPI.COMM_WORLD
    wall = time.perf_counter()
    rows: list[dict[str, Any]] = []
    if args.resume and not args.keep:
        parser.error("--resume needs --keep")
    with tempfile.TemporaryDirectory() as folder:
        scratch = Path(comm.bcast((args.keep or folder) if comm.rank == 0 else None))
        for ratio in args.ratios:
            for kind in args.starts:
                rows.append(one_run(args, ratio, kind, scratch))
                if args.json and comm.rank == 0:  # after every run: an interrupted study keeps it
                    summary = study(args, comm.size, rows, time.perf_counter() - wall)
                    write(Path(args.json), summary, args.append)
    print0(comm, f"total {time.perf_counter() - wall:.0f} s")


def study(
    args: argparse.Namespace, ranks: int, rows: list[dict[str, Any]], wall: float
) -> dict[str, Any]:
    """The study's JSON: its settings and the runs so far."""
    return {
        **{
            k: v for k, v in vars(args).items() if k not in ("json", "pictures", "keep", "progress")
        },
        "length": 1.0,
        "c_b": 1.0,
        "c_t": 0.5,
        "q": 3.0,
        "ranks": ranks,
        "wall_time_s": wall,
        "runs": rows,
    }


def write(path: Path, summary: dict[str, Any], append: bool) -> None:
    """The study's JSON; with ``append`` the file's runs of other (ratio, start) pairs stay.

    Its settings and wall time are then this invocation's; every run keeps its own
    (``settings``, ``wall_time_s``).
    """
    rows = summary["runs"]
    if append and path.exists():
        old = json.loads(path.read_text(encoding="utf-8"))
        new = {(row["ratio"], row["start"]) for row in rows}
        kept = [row for row in old["runs"] if (row["ratio"], row["start"]) not in new]
        rows = sorted(kept + rows, key=lambda row: (row["ratio"], row["start"]))
        summary = {**summary, "runs": rows}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
