"""Time to solution at the published sizes: the demos run with ``--paper``, timed and checked.

Each case runs a literate demo with ``--paper`` (the published resolution) or a problem file
(``dgplate run``) on ``--ranks`` ranks, as a user runs it (``mpirun -n 2 python demos/box_folding.py
--paper``), in a temporary folder, and reads its ``summary.json`` and ``history.csv``. The demo
asserts its own figures (hinge angles at the switch and after cooling, energies); this
records them with the wall time and where it went:

- the box: the heat solves, the flow steps (relaxations and holds) and the rest (start-up,
  mesh, calibration, output, checkpoints), from the per-step seconds of ``history.csv``;
- the bilayers: the flow's steps and step solves.

    python benchmarks/paper_sizes.py [--ranks 2] [--cases box_file box_paper i_shape_paper …]
    python benchmarks/paper_sizes.py --table-only [--json …] [--page docs/performance.md]

The tables of docs/performance.md (between ``<!-- paper_sizes:begin -->`` and
``<!-- paper_sizes:end -->``) and docs/box.md (``<!-- box_runs:… -->``) are generated from the
JSON (``--table-only``: no runs). The docs' pictures of these runs (:data:`PICTURES`: the box's
angles, closed box and folding sequence, the microcapsule, the I-shape) are copied from the
runs into ``--pictures`` (default docs/img; ``--pictures ''``: none). The box also runs its
problem file (4 × 4 cells per face, ``dgplate run``) for docs/box.md.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, publish

from dgplate.io.output import print0

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
BEGIN, END = "<!-- paper_sizes:begin -->", "<!-- paper_sizes:end -->"
BOX_BEGIN, BOX_END = "<!-- box_runs:begin -->", "<!-- box_runs:end -->"
CAPSULE_BEGIN, CAPSULE_END = "<!-- microcapsule_runs:begin -->", "<!-- microcapsule_runs:end -->"
DEMOS, PROBLEMS = ROOT / "demos", ROOT / "demos" / "problems"
#: case → the command's arguments after ``python`` (each takes ``--out``)
I_SHAPE = str(PROBLEMS / "bilayer_i_shape.toml")
I_SHAPE_PAPER = "mesh.parameters={W=4.0,H=4.0,t=1.0,w=1.5,h=0.125}"
PARTIAL_CLAMP = str(PROBLEMS / "bilayer_partial_clamp.toml")
PARTIAL_CLAMP_PAPER = "mesh.parameters={W=4.0,L=10.0,c=2.0,h=0.25}"
CASES = {
    "box_file": ["-m", "dgplate", "run", str(PROBLEMS / "box_folding.toml")],
    "box_paper": [str(DEMOS / "box_folding.py"), "--paper"],
    "microcapsule_file": ["-m", "dgplate", "run", str(PROBLEMS / "microcapsule.toml")],
    # the demo's --paper: the published flow (its problem file's flow.method = "bnn")
    "i_shape_paper": [str(DEMOS / "bilayer_i_shape.py"), "--paper"],
    # the same mesh with the accurate flow (the file's τ as the first τ)
    "i_shape_paper_accurate": ["-m", "dgplate", "run", I_SHAPE, "--set", I_SHAPE_PAPER,
                               "--set", "flow.method='accurate'"],
    # the published plate (its demo's --paper mesh, h = 0.25) with the accurate flow
    "partial_clamp_paper_accurate": ["-m", "dgplate", "run", PARTIAL_CLAMP, "--set",
                                     PARTIAL_CLAMP_PAPER, "--set", "flow.method='accurate'"],
}  # fmt: skip


#: Times of the folding sequence's panels, on the frames of ``--paper`` (every 20 steps): three
#: while heating, the last frame before the switch (t = 28.2), one while cooling and the end
#: (the frame nearest to each time is shown, the earlier one of two as near).
FOLDING_TIMES = (8.0, 16.0, 26.0, 28.0, 45.9, 56.4)


def folding_sequence(run: Path, path: Path) -> None:
    """The box's folding sequence: six of the run's frames, heating, closing, cooling, open.

    Args:
        run: the box run's folder (``frames/frame_<step>.png`` and ``history.csv``).
        path: the picture to write (two rows of three panels).
    """
    from dgplate.io.montage import montage

    with open(run / "history.csv", newline="") as f:
        rows = {int(r["step"]): r for r in csv.DictReader(f)}
    found = sorted((run / "frames").glob("frame_*.png"))
    frames = {int(p.stem.removeprefix("frame_")): p for p in found}
    frames = {step: p for step, p in frames.items() if step in rows}
    if not frames:
        print0(MPI.COMM_WORLD, f"{run}: no frames to show (output.frames_every): {path} not drawn")
        return
    time = {step: float(rows[step]["time"]) for step in frames}
    shown = [min(frames, key=lambda step: abs(time[step] - t)) for t in FOLDING_TIMES]
    heating = {step: float(rows[step]["source"]) > 0 for step in shown}
    captions = [f"t = {time[s]:.1f}, {'heating' if heating[s] else 'cooling'}" for s in shown]
    panels = [frames[s] for s in shown]
    # the frames' titles (the step, t and E_h) and colour bars are left out
    crop = (0.16, 0.82, 0.05, 0.95)
    montage([panels[:3], panels[3:]], path, captions=[captions[:3], captions[3:]], crop=crop)


#: case → {picture in --pictures: its file in the run folder, or a function (run, path)
#: drawing it}
PICTURES: dict[str, dict[str, Any]] = {
    "box_paper": {
        "box_angles.png": "angles.png",
        "box_closed.png": "at_switch.png",
        "box_folding.png": folding_sequence,
    },
    "microcapsule_file": {"microcapsule.png": "final.png"},
    "i_shape_paper": {"bilayer_i_shape.png": "final.png"},
}


def keep_pictures(case: str, run: Path, pictures: Path | None) -> None:
    """Copy (or draw) the docs' pictures of ``case`` from its run folder.

    A picture the run did not write is skipped with a line: the run's record is kept.

    Args:
        case: a key of :data:`CASES`.
        run: the run's output folder.
        pictures: the folder of the copies (made if missing); None: none.
    """
    if pictures is None:
        return
    pictures.mkdir(parents=True, exist_ok=True)
    for name, source in PICTURES.get(case, {}).items():
        if callable(source):
            source(run, pictures / name)
        elif (run / source).is_file():
            shutil.copyfile(run / source, pictures / name)
        else:
            print0(MPI.COMM_WORLD, f"{case}: the run wrote no {source}: {pictures / name} kept")
            continue
        print0(MPI.COMM_WORLD, f"{case}: {pictures / name}")


def run_case(
    ranks: int, case: str, pictures: Path | None = None
) -> tuple[dict[str, Any], list[dict[str, str]], float]:
    """Run a case on ``ranks`` ranks in a temporary folder, removed afterwards.

    Args:
        ranks: the MPI ranks of the run (``mpirun -n ranks``; 1: no mpirun).
        case: a key of :data:`CASES`.
        pictures: where to copy the case's pictures of the docs (:data:`PICTURES`; None: none).

    Returns:
        The run's summary, its history rows and the wall time in seconds (start-up included).

    Raises:
        SystemExit: the run failed (its exit code and the last lines of its output).
    """
    folder = Path(tempfile.mkdtemp(prefix="paper_"))
    command = [sys.executable, *CASES[case], "--out", str(folder / "run")]
    if ranks > 1:  # the MPI of this Python (its venv's mpirun), as the Makefile's MPIRUN
        beside = Path(sys.executable).parent / "mpirun"
        mpirun = str(beside) if beside.is_file() else shutil.which("mpirun") or "mpirun"
        command = [mpirun, "-n", str(ranks), *command]
    try:
        t0 = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, env=os.environ.copy())
        wall = time.perf_counter() - t0
        if done.returncode != 0:
            tail = "\n".join((done.stdout + done.stderr).splitlines()[-15:])
            raise SystemExit(f"{case} exited with {done.returncode}:\n{tail}")
        summary = json.loads((folder / "run" / "summary.json").read_text())
        with open(folder / "run" / "history.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        keep_pictures(case, folder / "run", pictures)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return summary, rows, wall


def box_record(summary: dict[str, Any], rows: list[dict[str, str]], wall: float) -> dict[str, Any]:
    """The box's figures and the split of its wall time.

    Args:
        summary: the run's summary.json.
        rows: the rows of its history.csv.
        wall: its wall time in seconds.

    Returns:
        The case's record.
    """
    heat = sum(float(r["heat_seconds"]) for r in rows)
    steps = sum(float(r["seconds"]) for r in rows)
    return {
        "cells": summary["cells"],
        "dofs": summary["dofs"],
        "heat_step": summary["input"]["schedule"]["heat_step"],
        "ranks": summary["ranks"],
        "heat_steps": summary["heat_steps"],
        "flow_steps": summary["flow_steps"],
        "wall_s": wall,
        "heat_s": heat,
        "flow_s": steps - heat,
        "other_s": wall - steps,
        "calibration_s": summary["calibration"].get("seconds", 0.0),
        "angles_at_switch": summary["hinge_angles_deg_at_switch"],
        "angles_final": summary["hinge_angles_deg_final"],
        "closure_gap_at_switch": summary["closure_gap_at_switch"],
        "energy_at_switch": summary["energy_at_switch"],
        "isometry_defect": summary["isometry_defect"],
        "alpha": summary["alpha"]["hinge_north"],
    }


def bilayer_record(
    summary: dict[str, Any], rows: list[dict[str, str]], wall: float
) -> dict[str, Any]:
    """A bilayer's figures: steps, solves, energy, defect, fitted cylinder (as box_record)."""
    cylinder = summary.get("cylinder_fit", {})
    return {
        "dofs": summary["dofs"],
        "ranks": summary["ranks"],
        "steps": summary["steps"],
        "step_solves": summary.get("step_solves"),
        "wall_s": wall,
        "energy": summary["energy"],
        "isometry_defect": summary["isometry_defect"],
        "radius": cylinder.get("radius"),
        "axis": cylinder.get("axis"),
        "rms_residual": cylinder.get("rms_residual"),
        "method": summary["input"].get("flow", {}).get("method", "accurate"),
    }


def box_table(record: dict[str, Any]) -> str:
    """docs/box.md's table: the box's runs, the hinge angles at the switch and after cooling."""
    rows = []
    for case, label in (("box_file", "problem file"), ("box_paper", "`--paper`")):
        box = record["cases"].get(case)
        if box is None:
            continue
        switch = " | ".join(f"{a:.2f}" for a in box["angles_at_switch"].values())
        final = max(abs(a) for a in box["angles_final"].values())
        rows.append(
            f"| {label} | {box['cells']} | {box['dofs']} | {box['heat_step']:g} "
            f"| {box['heat_steps']} | {box['flow_steps']} | {box['alpha']:.4f} | {switch} "
            f"| {box['closure_gap_at_switch']:.4f} | {final:.2f} | {box['energy_at_switch']:.3f} "
            f"| {box['wall_s']:.0f} |"
        )
    return "\n".join(
        [
            f"Hinge angles (°) at the switch, relaxed (the closed box), the largest |angle| after "
            f"cooling, the closure gap and the energy at the switch; wall time on "
            f"{record['ranks']} rank(s), start-up included (`benchmarks/paper_sizes.py`, "
            "`benchmarks/results/paper_sizes.json`).",
            "",
            "| run | cells | dofs | Δt | heat steps | flow steps | α | north | south | east "
            "| west | lid | closure gap | after cooling | E_h at the switch | wall s |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def capsule_record(
    summary: dict[str, Any], rows: list[dict[str, str]], wall: float
) -> dict[str, Any]:
    """The microcapsule's figures: how far the flaps curled, whether the hold converged (as
    box_record)."""
    curvatures = summary["principal_curvatures"]
    return {
        "cells": summary["cells"],
        "dofs": summary["dofs"],
        "ranks": summary["ranks"],
        "heat_steps": summary["heat_steps"],
        "flow_steps": summary["flow_steps"],
        "converged": summary["converged"],
        "wall_s": wall,
        "energy": summary["energy"],
        "isometry_defect": summary["isometry_defect"],
        "kappa1_mean": curvatures["kappa1_mean"],
        "kappa2_mean": curvatures["kappa2_mean"],
        "tips_height": summary["tips_height_final"],
        "tips_distance": summary["tips_distance_final"],
    }


def capsule_table(record: dict[str, Any]) -> str:
    """docs/box.md's microcapsule table: the problem file's run."""
    r = record["cases"].get("microcapsule_file")
    if r is None:
        return "(not run)"
    return "\n".join(
        [
            f"The problem file's run on {r['ranks']} rank(s), start-up included "
            "(`benchmarks/paper_sizes.py`, `benchmarks/results/paper_sizes.json`).",
            "",
            "| cells | dofs | heat steps | flow steps | final hold converged | κ₁ mean | κ₂ mean "
            "| tips above the centre | tips from its midpoint | E_h | D_h | wall s |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|",
            f"| {r['cells']} | {r['dofs']} | {r['heat_steps']} | {r['flow_steps']} "
            f"| {'yes' if r['converged'] else 'no'} | {r['kappa1_mean']:.2f} "
            f"| {r['kappa2_mean']:.2f} | {r['tips_height']:.3f} | {r['tips_distance']:.3f} "
            f"| {r['energy']:.3f} | {r['isometry_defect']:.1e} | {r['wall_s']:.0f} |",
        ]
    )


def table(record: dict[str, Any]) -> str:
    """docs/performance.md's table: wall time at the published sizes and where it went."""
    rows = []
    for case, r in record["cases"].items():
        if case == "microcapsule_file":
            split = "the final hold " + ("converged" if r["converged"] else "did not converge")
            steps = f"{r['heat_steps']} heat steps, {r['flow_steps']} flow steps"
        elif case.startswith("box"):
            split = f"heat {r['heat_s']:.1f}, flow {r['flow_s']:.0f}, other {r['other_s']:.0f}"
            steps = f"{r['heat_steps']} heat steps, {r['flow_steps']} flow steps"
        else:
            split = (
                f"{r['method']} flow, {r['step_solves']} step solves; E_h {r['energy']:.4f}, "
                f"D_h {r['isometry_defect']:.1e}, fitted radius "
                + (f"{r['radius']:.3f}" if r["radius"] is not None else "none")
            )
            steps = f"{r['steps']} steps"
        rows.append(f"| {case} | {r['dofs']} | {steps} | {r['wall_s']:.0f} | {split} |")
    return "\n".join(
        [
            f"Wall time on {record['ranks']} rank(s), start-up included; the box's split: the "
            "heat solves, the flow steps (relaxations and holds) and the rest (mesh, α's "
            "calibration, output, checkpoints) (`benchmarks/paper_sizes.py`, "
            "`benchmarks/results/paper_sizes.json`).",
            "",
            "| case | dofs | steps | wall s | split (s), or the run's figures |",
            "|---|---|---|---|---|",
            *rows,
        ]
    )


#: a case's record, by the first word of its name (bilayer_record otherwise)
RECORDS = {"box": box_record, "microcapsule": capsule_record}


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=sorted(CASES))
    parser.add_argument("--ranks", type=int, default=2, help="ranks of each demo run")
    add_page_options(parser, RESULTS / "paper_sizes.json", ROOT / "docs" / "performance.md")
    parser.add_argument("--box-page", type=Path, default=ROOT / "docs" / "box.md")
    parser.add_argument(
        "--pictures", default=str(ROOT / "docs" / "img"), help="the docs' pictures ('': none)"
    )
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    if comm.size > 1:
        raise SystemExit("run this benchmark on one rank: it starts each demo with --ranks")
    record: dict[str, Any] | None = None
    if not args.table_only:
        # the cases not run now keep their records (a study run case by case), each written
        # as soon as it is done
        kept = json.loads(args.json.read_text()) if args.json.is_file() else {}
        if kept and kept.get("ranks") != args.ranks:
            raise SystemExit(
                f"{args.json} holds runs on {kept.get('ranks')} rank(s), not --ranks "
                f"{args.ranks}: give another --json"
            )
        cases: dict[str, Any] = kept.get("cases", {})
        pictures = Path(args.pictures) if args.pictures else None
        for case in args.cases:
            summary, rows, wall = run_case(args.ranks, case, pictures)
            make = RECORDS.get(case.split("_")[0], bilayer_record)
            cases[case] = make(summary, rows, wall)
            print0(comm, json.dumps({case: cases[case]}))
            record = {"ranks": args.ranks, "cases": cases}
            args.json.write_text(json.dumps(record, indent=2) + "\n")
    publish(comm, args, record, (BEGIN, END), table)
    box_page = argparse.Namespace(json=args.json, page=args.box_page)
    publish(comm, box_page, None, (BOX_BEGIN, BOX_END), box_table)
    publish(comm, box_page, None, (CAPSULE_BEGIN, CAPSULE_END), capsule_table)


if __name__ == "__main__":
    main(sys.argv[1:])
