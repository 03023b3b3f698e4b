"""The bound on the defect of the trust region's SQP steps, measured on three cases.

The trust region's SQP steps may end off the constraint; a step is accepted only while
D_h ≤ bound·|ω| or its start's (``SQP_STEP_DEFECT`` in ``dgplate/solvers/projection.py``,
docs/performance.md, "SQP steps off the constraint"). Per variant of the bound this runs:

- ``rollup``: the full-turn roll-up of ``benchmarks/rollup.py`` (96 × 8 Q2, 1 rank);
- ``i_shape``: the I-shaped bilayer at its paper mesh with the accurate flow (2 ranks), whose
  fitted cylinder axis tells its minimisers apart;
- ``straight_fold``: ``demos/problems/straight_fold.toml`` from the flat sheet (1 rank), whose
  exact minimiser has E = 0.

A variant is ``BOUND`` (the default control: τ doubled after an accepted step whose D_h used
at most half of the bound, else held; after a refused one, τ times (D_h/bound)^(−½) between
0.1 and 0.5), ``BOUND:halved`` (the former control: τ doubled after every accepted step and
halved after every refused one) or ``BOUND:cube_root`` (τ grown by 0.9·(bound/D_h)^⅓, between
1 and 2: the factor that would bring a defect ∝ τ³ to 0.9³ of the bound). Each run is a
process of its own, whose module constants the variant sets.

    python benchmarks/sqp_bound.py [--variants 0.1 0.03 0.02 0.01 0.01:halved 0.01:cube_root]
                                   [--cases rollup i_shape straight_fold] [--keep]
    python benchmarks/sqp_bound.py --table-only

``--keep`` keeps the JSON's records of the runs not made now. The table of
docs/performance.md between ``<!-- sqp_bound:begin -->`` and ``<!-- sqp_bound:end -->`` is
generated from the JSON.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, publish, run_in_scratch

from dgplate.problems.specs import Problem, load_problem

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
PROBLEMS = ROOT / "demos" / "problems"
BEGIN, END = "<!-- sqp_bound:begin -->", "<!-- sqp_bound:end -->"
VARIANTS = ("0.1", "0.03", "0.02", "0.01", "0.01:halved", "0.01:cube_root")
#: case → its ranks
CASES = {"rollup": 1, "i_shape": 2, "straight_fold": 1}
QUIET = {"output.vtx": False, "output.png": False, "output.progress": 0}
#: a variant's growth → its name in the table
GROWTHS = {
    "": "",
    "halved": ", τ doubled after every accepted step, halved after every refused one",
    "cube_root": ", τ grown by 0.9·(bound/D_h)^⅓ after an accepted step",
}
I_SHAPE_PAPER = {"W": 4.0, "H": 4.0, "t": 1.0, "w": 1.5, "h": 0.125}


def problem(case: str) -> Problem:
    """The validated problem of ``case`` (a key of :data:`CASES`)."""
    if case == "rollup":
        import rollup

        return rollup.problem(1.0, [96, 8], "trust_region", 1e-6)
    if case == "i_shape":
        overrides = {"mesh.parameters": I_SHAPE_PAPER, "flow.method": "accurate", **QUIET}
        return load_problem(PROBLEMS / "bilayer_i_shape.toml", overrides)
    return load_problem(PROBLEMS / "straight_fold.toml", QUIET)


def apply(variant: str) -> None:
    """Set the bound (and the growth) of ``variant`` in the solver's modules."""
    from dgplate.solvers import projection, tau

    bound, _, growth = variant.partition(":")
    projection.SQP_STEP_DEFECT = float(bound)
    vars(tau)["SQP_STEP_DEFECT"] = float(bound)  # the name tau imported
    if growth == "cube_root":
        tau.TauController._growth = _cube_root_growth  # type: ignore[method-assign]
    elif growth == "halved":
        tau.TauController._shrink = lambda self, newton: 0.5  # type: ignore[method-assign]
        tau.TauController._growth = _doubled(tau.TauController._growth)  # type: ignore[method-assign]
    elif growth:
        raise SystemExit(f"unknown growth {growth!r} in variant {variant!r}")


def _cube_root_growth(self: Any) -> float:
    """τ's factor after an accepted SQP step: 0.9·(bound/D_h)^⅓ between 1 and 2 (collective)."""
    from dgplate.solvers import projection

    defect = max(self.flow.defect() / self.flow.defect.area, 1e-300)
    wanted = 0.9 * (projection.SQP_STEP_DEFECT / defect) ** (1 / 3)
    return float(min(self.settings.tau_growth, max(1.0, wanted)))


def _doubled(growth: Any) -> Any:
    """The growth of τ as it was before the trust region held τ near its bound."""

    def doubled(self: Any) -> float:
        self.bound_used = 0.0
        return float(growth(self))

    return doubled


def one(case: str, variant: str, result: Path) -> None:
    """Run ``case`` with ``variant`` on this process's ranks; rank 0 writes its record."""
    comm = MPI.COMM_WORLD
    apply(variant)
    run, wall = run_in_scratch(comm, problem(case), f"{case} with {variant}", "sqp_bound_")
    s = run.summary
    record = {
        "case": case,
        "variant": variant,
        "ranks": comm.size,
        "converged": s["converged"],
        "steps": s["steps"],
        "attempts": s["steps"] + s["rejected_steps"] + s["newton_rejections"],
        "step_solves": s["step_solves"],
        "energy": s["energy"],
        "isometry_defect": s["isometry_defect"],
        "axis": (s.get("cylinder_fit") or {}).get("axis"),
        "wall_s": wall,
    }
    if comm.rank == 0:
        result.write_text(json.dumps(record))


def launch(case: str, variant: str) -> dict[str, Any]:
    """Run ``case`` with ``variant`` in a process of its own (under mpirun for 2 ranks)."""
    folder = Path(tempfile.mkdtemp(prefix="sqp_bound_"))
    command = [sys.executable, __file__, "--one", case, variant, str(folder / "record.json")]
    if CASES[case] > 1:
        beside = Path(sys.executable).parent / "mpirun"
        mpirun = str(beside) if beside.is_file() else shutil.which("mpirun") or "mpirun"
        command = [mpirun, "-n", str(CASES[case]), *command]
    try:
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            tail = "\n".join((done.stdout + done.stderr).splitlines()[-15:])
            raise SystemExit(f"{case} with {variant} exited with {done.returncode}:\n{tail}")
        record: dict[str, Any] = json.loads((folder / "record.json").read_text())
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print(f"{case} with {variant}: {record}", flush=True)
    return record


def _axis(axis: list[float] | None) -> str:
    """A fitted axis to 3 decimals, its sign fixed by its largest component (−x here)."""
    if axis is None:
        return ""
    sign = -1.0 if max(axis, key=abs) > 0 else 1.0
    return "(" + ", ".join(f"{round(sign * a, 3) + 0.0:.3f}" for a in axis) + ")"


def table(record: dict[str, Any]) -> str:
    """The Markdown table of the JSON: a row per variant, the three cases side by side."""
    runs = {(r["case"], r["variant"]): r for r in record["runs"]}
    rows = []
    for variant in dict.fromkeys(r["variant"] for r in record["runs"]):
        bound, _, growth = variant.partition(":")
        name = bound + GROWTHS[growth]
        cells = [f"**{name}**" if variant == "0.01" else name]
        roll, shape, fold = (runs.get((case, variant)) for case in CASES)
        cells.append(
            f"{roll['attempts']}, {roll['step_solves']}, {roll['wall_s']:.0f} s" if roll else ""
        )
        cells.append(
            f"{shape['steps']}, {shape['step_solves']}, {shape['energy']:.4f}, "
            f"{_axis(shape['axis'])}, {shape['wall_s']:.0f} s"
            if shape
            else ""
        )
        cells.append(f"{fold['energy']:.2g}" if fold else "")
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(
        [
            "The bound on D_h/|ω| of the SQP steps (`benchmarks/sqp_bound.py`, "
            "`benchmarks/results/sqp_bound.json`; the default in bold). Full turn: the roll-up "
            "above, 96×8, 1 rank; I-shape: its paper mesh, accurate flow, 2 ranks, the fitted "
            "cylinder's axis up to sign; straight fold: `straight_fold.toml` from the flat "
            "sheet, 1 rank, whose exact minimiser has E = 0. Wall: the run's, its set-up included.",
            "",
            "| bound on D_h/\\|ω\\| | full turn: attempts, step solves, wall | I-shape: steps, "
            "step solves, E_h, fitted axis, wall | straight fold: E_h |",
            "|---|---|---|---|",
            *rows,
        ]
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS))
    parser.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    parser.add_argument("--keep", action="store_true", help="keep the JSON's other records")
    parser.add_argument(
        "--one", nargs=3, metavar=("CASE", "VARIANT", "RESULT"), help=argparse.SUPPRESS
    )
    add_page_options(parser, RESULTS / "sqp_bound.json", ROOT / "docs" / "performance.md")
    args = parser.parse_args(argv)
    if args.one:
        case, variant, result = args.one
        one(case, variant, Path(result))
        return
    record = None
    if not args.table_only:
        runs = [launch(case, variant) for variant in args.variants for case in args.cases]
        if args.keep and args.json.is_file():
            done = {(r["case"], r["variant"]) for r in runs}
            old = json.loads(args.json.read_text())["runs"]
            runs = [r for r in old if (r["case"], r["variant"]) not in done] + runs
        order = {v: i for i, v in enumerate(VARIANTS)}
        runs.sort(key=lambda r: (order.get(r["variant"], len(order)), list(CASES).index(r["case"])))
        record = {"runs": runs}
    publish(MPI.COMM_WORLD, args, record, (BEGIN, END), table)


if __name__ == "__main__":
    main()
