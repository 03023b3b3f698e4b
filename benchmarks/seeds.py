"""Seed 001's closed-form rows: the bilayer aspect-ratio grid, each case through ``converge``.

    python benchmarks/seeds.py [--cases r1_a1 r1.75_a2 …] [--levels 4] [--cells 4]
        [--settings minimiser] [--budget-minutes 60] [--jobs 1] [--out out/seeds]
        [--json benchmarks/results/seeds.json] [--page docs/verification.md]
    python benchmarks/seeds.py --table-only   # the page's table from the JSON, no runs

[N15], experiment 1: rectangles (0, rW) × (0, W) clamped on x₁ = 0, r = length/W = 0.5, 1,
7/4, 10/4, Z = aI with a = 1, 2, 5, for W = 1 and W = 4 (cases ``r<r>_a<a>`` and
``r<r>_a<a>_w4``; the W = 4 rows with a = 2 and 5, ``UNRESOLVED``, only when named). The
minimiser is a cylinder of radius 1/a at the energy ½a²|ω|. Each case runs
``demos/problems/bilayer_aspect_ratios.toml`` with overrides (the rectangle, n·r × n cells on
level 1, Z, and one of ``SETTINGS``) through :func:`dgplate.converge` into
``OUT/<case>/<settings>``, resumably: a rerun reuses the finished levels and continues an
interrupted one. The cases run one after the other; when ``--budget-minutes`` have passed the
running level stops at its next step (as on SIGTERM), the cases left are listed and the exit
status is 3; a rerun goes on from there. A rerun with fewer ``--levels`` keeps a case's record
of more levels.

Level 1 has n = ``--cells`` cells across the clamped side whatever W: the W = 4 plate's mesh is
the W = 1 plate's scaled by 4, so its cylinder, of radius 1/a against 1/(aW) of the plate's
width, is resolved as the W = 1 plate's with Z = aW·I is (the W = 4 row with a equals the
W = 1 row with 4a when the penalties scale with h as h⁻¹; the ``minimiser`` settings' γ₁h⁻³
weighs the W = 4 plate's gradient jumps W⁻² times as much).

``--jobs N`` runs the cases in N processes of this script at once (one case each at a time,
serial: N = 2 uses the two cores of a laptop), the cases shared out by their expected time
(the kept record's, else ∝ r·(aW)²), each process with its own JSON beside ``--json``
(``<stem>.job<k>.json``), merged into ``--json`` when they end; a signal is passed on to them.

The other plates of [N15] with a closed form (``SHAPES``: the I, the partial clamp, the
hole, the anisotropic plate) run with the ``minimiser`` settings on 3 levels whose finest is
the published mesh (``--levels`` and ``--cells`` are the rectangles'); their table has the
markers ``<!-- seed_shapes:begin -->`` and ``<!-- seed_shapes:end -->``. A rerun into an
``--out`` that holds levels of other settings (e.g. the defect-bound control the
``minimiser`` settings had before) is refused by ``converge``: use a fresh folder.

``--json`` keeps, per case and settings, every level's DoFs, steps, wall time, E_h and fitted
radius with their errors against the closed forms, and converge's orders, extrapolated values
and error estimates; a rerun of some ``--cases`` keeps the others. The table between the
page's markers ``<!-- seeds:begin -->`` and ``<!-- seeds:end -->`` is generated from it, with
the targets of the verification: extrapolated energy and radius within 1 %, the finest level
within 2 %.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from fractions import Fraction
from pathlib import Path
from typing import Any, NamedTuple

from mpi4py import MPI

from accuracy import MINIMISER, TUNED
from pages import write_between

from dgplate import interrupt
from dgplate.io.output import print0
from dgplate.problems.converge import converge
from dgplate.problems.specs import load_problem

ROOT = Path(__file__).resolve().parent.parent
PROBLEM = ROOT / "demos" / "problems" / "bilayer_aspect_ratios.toml"
BEGIN, END = "<!-- seeds:begin -->", "<!-- seeds:end -->"
SHAPES_BEGIN, SHAPES_END = "<!-- seed_shapes:begin -->", "<!-- seed_shapes:end -->"
RATIOS, CURVATURES, WIDTHS = (0.5, 1.0, 1.75, 2.5), (1.0, 2.0, 5.0), (1.0, 4.0)

#: The targets: extrapolated figures within 1 %, the finest level within 2 % (relative).
LIMIT_TARGET, FINEST_TARGET = 0.01, 0.02

#: name → (what it is, overrides on top of the problem file given the exact energy E*).
SETTINGS: dict[str, tuple[str, Any]] = {
    "minimiser": (
        "the cylinder test's discretisation (γ₁h⁻³ with γ₁ = 86, edge constraint) flowed to a "
        "discrete minimiser as in `benchmarks/accuracy.py` (adaptive τ from h, two projection "
        "steps, SQP steps, ‖P DE_h‖_*' < 10⁻⁷) with the default step control, the trust "
        "region (the accuracy study's defect bound throttles the rolls: docs/performance.md)",
        lambda ideal: {
            **TUNED,
            **MINIMISER,
            "flow.step_control": "trust_region",
            "flow.tol": 1e-7,
            "flow.max_steps": 3000,
        },
    ),
    "file": (
        "the problem file's own discretisation and flow as the demo runs it (γ₁h⁻¹ with "
        "γ₁ = 1100, no projection (D_h > 0), τ = 0.05/(aW), rate stop at 10⁻⁴·E*)",
        lambda ideal: {"flow.tol": 1e-4 * ideal, "flow.max_steps": 8000},
    ),
}


def case_name(ratio: float, a: float, width: float) -> str:
    """``r1.75_a2`` (W = 1) or ``r1.75_a2_w4``."""
    return f"r{ratio:g}_a{a:g}" + ("" if width == 1.0 else f"_w{width:g}")


#: Every case of the grid, in the table's order.
CASES = {
    case_name(r, a, w): (r, a, w) for w in WIDTHS for a in CURVATURES for r in RATIOS
}  # fmt: skip

#: The W = 4 rows with a = 2 and 5 (the unit plate's a = 8 and 20: rolls of 3 to 8 turns) run
#: only when named: at 32 cells across the width on level 4 a cell spans 0.5 and 1.25 radians
#: of the roll, and by the script's own estimate they take about 23 hours per job.
UNRESOLVED = [case_name(r, a, 4.0) for a in (2.0, 5.0) for r in RATIOS]


class Shape(NamedTuple):
    """A seed plate beside the rectangles: its problem file, level 1 and closed form.

    The finest of its ``levels`` is the published plate and mesh (the demo's ``--paper``).
    """

    file: str
    level1: dict[str, Any]
    energy: float
    radius: float
    levels: int
    words: str


#: The other plates of [N15] with a constant Z, at their published meshes: the minimiser has
#: II = z n⊗n, z the eigenvalue of Z largest in modulus, so E* = ½(|Z|² − z²)|ω| (Z = aI:
#: ½a²|ω|) and the radius 1/|z|, on a free plate or one clamped along a ruling.
SHAPES: dict[str, Shape] = {
    "i_shape": Shape(
        "bilayer_i_shape.toml",
        {"mesh.parameters": {"W": 4.0, "H": 4.0, "t": 1.0, "w": 1.5, "h": 0.5}},
        0.5 * (2 * 4.0 * 1.0 + 1.5 * 2.0),
        1.0,
        3,
        "the I (flanges 4 × 1, web 1.5 × 2), Z = I, clamped at the foot",
    ),
    "partial_clamp": Shape(
        "bilayer_partial_clamp.toml",
        {"mesh.parameters": {"W": 4.0, "L": 10.0, "c": 2.0, "h": 1.0}},
        0.5 * 40.0,
        1.0,
        3,
        "the 4 × 10 plate clamped on 2 of its short side, Z = I",
    ),
    "hole": Shape(
        "bilayer_hole.toml",
        {"mesh.parameters": {"Lx": 10.0, "Ly": 4.0, "R": 1.0, "h": 0.6}},  # hole_h = h/2
        0.5 * 4.0 * (40.0 - math.pi),
        0.5,
        3,
        "the 10 × 4 plate with a hole of radius 1, Z = 2I",
    ),
    "anisotropic": Shape(
        "bilayer_anisotropic.toml",
        {"mesh.corners": [[-2.0, -3.0], [2.0, 3.0]], "mesh.cells": [6, 9]},
        0.5 * 1.0 * 24.0,
        0.2,
        3,
        "the free 4 × 6 plate, Z = diag(−5, −1)",
    ),
}


def exact(case: str) -> tuple[float, float]:
    """The closed-form energy and radius of ``case``."""
    if case in SHAPES:
        return SHAPES[case].energy, SHAPES[case].radius
    ratio, a, width = CASES[case]
    return 0.5 * a**2 * ratio * width**2, 1.0 / a


def problem_file(case: str) -> Path:
    """The problem file ``case`` runs."""
    return ROOT / "demos" / "problems" / SHAPES[case].file if case in SHAPES else PROBLEM


def overrides(case: str, settings: str, cells: int) -> dict[str, Any]:
    """The problem file's overrides for ``case``: its rectangle, level 1's mesh (``cells``
    across the clamped side), Z, τ, flow; a shape's level 1 and flow."""
    quiet = {"flow.checkpoint_every": 0, "output.vtx": False, "output.progress": 0}
    if case in SHAPES:
        if settings != "minimiser":  # the files' flows are tuned to their scaled-down plates
            raise ValueError(f"{case}: the shapes run with the minimiser settings only")
        shape = SHAPES[case]
        return {**shape.level1, **quiet, **SETTINGS[settings][1](shape.energy)}
    ratio, a, width = CASES[case]
    length = ratio * width
    flow = SETTINGS[settings][1](0.5 * a**2 * length * width)
    return {
        "mesh.corners": [[0.0, 0.0], [length, width]],
        "mesh.cells": [round(cells * ratio), cells],
        "model.Z": a,
        "flow.tau": 0.05 / (a * width),
        **quiet,
        **flow,
    }


def relative(value: float | None, exact: float) -> float | None:
    """(value − exact)/exact, or None."""
    return None if value is None else (value - exact) / exact


def estimate(entry: dict[str, Any] | None, exact: float) -> dict[str, Any]:
    """A figure's converge estimate with the extrapolated value's error against ``exact``."""
    if entry is None:
        entry = {"order": None, "limit": None, "error": None, "reason": "not reported"}
    found = {key: entry[key] for key in ("order", "limit", "error", "reason")}
    found["limit_error"] = relative(entry["limit"], exact)
    found["error_estimate"] = None if entry["error"] is None else entry["error"] / abs(exact)
    return found


def record_of(case: str, settings: str, cells: int, study: Any) -> dict[str, Any] | None:
    """The JSON record of one case's study (level 1 with ``cells`` across the clamped side).

    A study stopped by a signal is recorded with its finished levels and their estimates
    (the stopped level continues on a rerun), and ``interrupted`` set; with none, None.
    Its ``wall_s`` is the sum of the levels' own wall times, whichever invocation ran them.
    """
    energy, radius = exact(case)
    finished = study.finished_levels()
    if not finished:
        return None
    figures = study.figures
    levels = []
    for lv in finished:
        r = lv["figures"].get("cylinder_fit.radius")
        levels.append(
            {
                **{key: lv[key] for key in ("level", "size", "dofs", "steps", "converged")},
                **{key: lv[key] for key in ("reason", "reused", "isometry_defect")},
                "wall_s": lv["wall_time_s"],
                "energy": lv["energy"],
                "radius": r,
                "energy_error": relative(lv["energy"], energy),
                "radius_error": relative(r, radius),
            }
        )
    ratio, a, width = CASES.get(case, (None, None, None))
    return {
        "case": case,
        "settings": settings,
        "ratio": ratio,
        "a": a,
        "width": width,
        "cells_across": None if case in SHAPES else cells,
        "exact_energy": energy,
        "exact_radius": radius,
        "interrupted": study.interrupted,
        "wall_s": sum(lv["wall_s"] or 0.0 for lv in levels),
        "levels": levels,
        "energy": estimate(figures.get("energy"), energy),
        "radius": estimate(figures.get("cylinder_fit.radius"), radius),
    }


def misses(record: dict[str, Any]) -> list[str]:
    """The targets the case misses, each with its figure (none: it passes)."""
    finest = record["levels"][-1]
    found = []
    for figure, short in (("energy", "E"), ("radius", "R")):
        limit, last = record[figure]["limit_error"], finest[f"{figure}_error"]
        if limit is None:
            found.append(f"no {short}∞")
        elif abs(limit) > LIMIT_TARGET:
            found.append(f"{short}∞ {percent(limit)}")
        if last is None or abs(last) > FINEST_TARGET:
            found.append(f"{short} finest {percent(last)}")
    return found


def percent(x: float | None, sign: str = "+") -> str:
    """``+0.29 %`` (a relative error; ``sign=""``: ``0.29 %``), or ``–``."""
    return "–" if x is None else f"{100 * x:{sign}.2f} %"


def fraction(x: float) -> str:
    """7/4 for 1.75."""
    return str(Fraction(x).limit_denominator(8))


def row(record: dict[str, Any]) -> str:
    """A table row: the finest level's errors, the extrapolated ones, the orders, pass/fail."""
    finest = record["levels"][-1]
    missed = misses(record)
    if record["case"] in SHAPES:
        cells = [SHAPES[record["case"]].words]
    else:
        cells = [fraction(record["ratio"]), f"{record['width']:g}", f"{record['a']:g}"]
    cells += [
        record["settings"],
        f"{len(record['levels'])} ({finest['size']})"
        + (" + 1 stopped" if record["interrupted"] else ""),
        f"{finest['dofs']:,}",
    ]
    for figure in ("energy", "radius"):
        entry = record[figure]
        cells.append(percent(finest[f"{figure}_error"]))
        if entry["limit_error"] is None:
            cells += [entry["reason"], "–"]
        else:
            cells.append(
                f"{percent(entry['limit_error'])} ± {percent(entry['error_estimate'], '')}"
            )
            cells.append(f"{entry['order']:.2f}")
    cells.append(f"{record['wall_s']:.0f}")
    cells.append("**miss**: " + ", ".join(missed) if missed else "pass")
    return "| " + " | ".join(cells) + " |"


#: The tables' columns after the case's own (the rectangle's r, W, a; a shape's name).
COLUMNS = (
    "settings", "levels (finest)", "DoFs", "E_h error, finest", "E∞ error ± estimate", "order",
    "radius error, finest", "R∞ error ± estimate", "order", "wall (s)", "targets",
)  # fmt: skip


def table(record: dict[str, Any], grid: bool = True) -> str:
    """The page's section from the JSON record: a row per case run, the cases not run listed.

    Args:
        record: the JSON record.
        grid: the rectangles' section; False: the shapes'.

    Returns:
        The section, its markers included.
    """
    studies = record["studies"]
    begin, end = (BEGIN, END) if grid else (SHAPES_BEGIN, SHAPES_END)
    names = [*(("length/W", "W", "a") if grid else ("plate",)), *COLUMNS]
    lines = [begin, "", "| " + " | ".join(names) + " |", "|" + "---|" * len(names)]
    lines += [row(studies[key]) for key in sorted(studies, key=_order) if _grid(key) == grid]
    done = {studies[key]["case"] for key in studies}
    left = [case for case in (CASES if grid else SHAPES) if case not in done]
    if grid:
        settings = "; ".join(f"`{k}`: {v[0]}" for k, v in SETTINGS.items())
        lines += ["", f"Settings: {settings}."]
    if left:
        lines += ["", "Not run: " + ", ".join(f"`{case}`" for case in left) + "."]
    lines += ["", end]
    return "\n".join(lines)


def _grid(key: str) -> bool:
    """Whether the study ``key`` is of a rectangle of the aspect-ratio grid."""
    return key.split(":")[0] in CASES


def _order(key: str) -> tuple[int, str]:
    case, settings = key.split(":")
    return [*CASES, *SHAPES].index(case), settings


def stop_after(seconds: float) -> threading.Timer:
    """SIGTERM to this process after ``seconds``: the running level stops at its next step."""
    timer = threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGTERM))
    timer.daemon = True
    timer.start()
    return timer


def run_cases(args: argparse.Namespace, record: dict[str, Any]) -> list[str]:
    """Run the selected cases in order within the budget; the cases left."""
    comm = MPI.COMM_WORLD
    start = time.perf_counter()
    timer = stop_after(60.0 * args.budget_minutes)
    with interrupt.StopOnSignal():
        for k, case in enumerate(args.cases):
            problem = load_problem(problem_file(case), overrides(case, args.settings, args.cells))
            problem.name = f"{case}-{args.settings}"
            levels = SHAPES[case].levels if case in SHAPES else args.levels
            study = converge(problem, levels, args.out / case / args.settings, comm, resume=True)
            one = record_of(case, args.settings, args.cells, study)
            if one is not None:
                one["ranks"] = comm.size
                key = f"{case}:{args.settings}"
                kept = record["studies"].get(key)
                if supersedes(kept, one):
                    record["studies"][key] = one
                    _write(args.json, record, comm)
                else:
                    print0(comm, f"{key}: kept the record of {len(kept['levels'])} levels")
                print0(comm, progress(one, k + 1, len(args.cases), time.perf_counter() - start))
            if study.interrupted:
                timer.cancel()
                return args.cases[k:]
    timer.cancel()
    return []


def expected_seconds(case: str, settings: str, record: dict[str, Any]) -> float:
    """A case's expected time: its finished record's, else 60 s · r · (aW)²."""
    kept = record["studies"].get(f"{case}:{settings}")
    if kept is not None and not kept["interrupted"]:
        return float(kept["wall_s"])
    if case in SHAPES:
        return 600.0
    ratio, a, width = CASES[case]
    return 60.0 * ratio * (a * width) ** 2


def share_out(cases: list[str], jobs: int, cost: dict[str, float]) -> list[list[str]]:
    """The cases in ``jobs`` groups of about equal cost: the longest first to the least loaded."""
    groups: list[list[str]] = [[] for _ in range(jobs)]
    loads = [0.0] * jobs
    for case in sorted(cases, key=lambda c: -cost[c]):
        k = loads.index(min(loads))
        groups[k].append(case)
        loads[k] += cost[case]
    return [group for group in groups if group]


def run_jobs(args: argparse.Namespace, record: dict[str, Any]) -> list[str]:
    """The cases in ``args.jobs`` processes of this script; their records merged; cases left."""
    cost = {case: expected_seconds(case, args.settings, record) for case in args.cases}
    common = ["--levels", str(args.levels), "--cells", str(args.cells)]
    common += ["--settings", args.settings, "--budget-minutes", str(args.budget_minutes)]
    common += ["--out", str(args.out), "--no-page"]
    parts, children, groups = [], [], share_out(args.cases, args.jobs, cost)
    for k, group in enumerate(groups):
        part = args.json.with_name(f"{args.json.stem}.job{k}.json")
        part.write_text(json.dumps(record, indent=2) + "\n")
        command = [sys.executable, __file__, "--cases", *group, "--json", str(part), *common]
        parts.append(part)
        children.append(subprocess.Popen(command))
        print(f"job {k}: {' '.join(group)} (about {sum(cost[c] for c in group) / 60:.0f} min)")

    def forward(signum: int, frame: object) -> None:
        for child in children:
            child.send_signal(signum)

    previous = {sig: signal.signal(sig, forward) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        codes = [child.wait() for child in children]
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    for part, group in zip(parts, groups, strict=True):
        studies = json.loads(part.read_text())["studies"]
        for key in (f"{case}:{args.settings}" for case in group):  # the job's own cases
            one = studies.get(key)
            if one is not None and supersedes(record["studies"].get(key), one):
                record["studies"][key] = one
        part.unlink()
    args.json.write_text(json.dumps(record, indent=2) + "\n")
    failed = [(k, code) for k, code in enumerate(codes) if code not in (0, 3)]  # 3: budget
    if failed:  # its cases keep their earlier records: say so instead of tabulating them
        k, code = failed[0]
        raise SystemExit(f"seeds.py: job {k} ({' '.join(groups[k])}) exited with {code}")
    studies = record["studies"]
    return [
        case
        for case in args.cases
        if (kept := studies.get(f"{case}:{args.settings}")) is None or kept["interrupted"]
    ]


def supersedes(kept: dict[str, Any] | None, new: dict[str, Any]) -> bool:
    """Whether ``new`` replaces the case's ``kept`` record: it is not a study of fewer levels.

    A rerun with fewer ``--levels`` (or one stopped earlier) reuses the finished levels, so its
    record is a prefix of the kept one at the same level-1 size; it would drop the finest
    levels' figures. Another level-1 size replaces the record.
    """
    if kept is None or kept.get("cells_across") != new["cells_across"]:
        return True
    return len(new["levels"]) >= len(kept["levels"])


def progress(one: dict[str, Any], k: int, total: int, elapsed: float) -> str:
    """``case 2/4 r1_a2 (minimiser): 4 levels, E error …; levels 141 s, elapsed 251 s``.

    The levels' time is their runs' own, also of levels reused from an earlier invocation;
    the elapsed time is this invocation's.
    """
    finest = one["levels"][-1]
    return (
        f"case {k}/{total} {one['case']} ({one['settings']}): {len(one['levels'])} levels, "
        f"E error {percent(finest['energy_error'])} (f∞ {percent(one['energy']['limit_error'])}), "
        f"radius error {percent(finest['radius_error'])} "
        f"(f∞ {percent(one['radius']['limit_error'])}); levels {one['wall_s']:.0f} s, "
        f"elapsed {elapsed:.0f} s" + (" — stopped" if one["interrupted"] else "")
    )


def _write(path: Path, record: dict[str, Any], comm: MPI.Comm) -> None:
    if comm.rank == 0:
        path.write_text(json.dumps(record, indent=2) + "\n")


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the cases (unless ``--table-only``), update the JSON, write the page's table.

    ``record["left"]`` lists the cases a budget stop or a signal left (none: all ran).
    """
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    every = [*CASES, *SHAPES]
    parser.add_argument(
        "--cases",
        nargs="+",
        choices=every,
        default=[case for case in every if case not in UNRESOLVED],
        metavar="CASE",
        help="default: all but the W = 4 rows with a = 2 and 5 (UNRESOLVED)",
    )
    parser.add_argument("--levels", type=int, default=4, help="meshes per case (≥ 2)")
    parser.add_argument(
        "--cells", type=int, default=4, help="level 1's cells across the clamped side"
    )
    parser.add_argument("--settings", choices=list(SETTINGS), default="minimiser")
    parser.add_argument("--budget-minutes", type=float, default=60.0)
    parser.add_argument("--jobs", type=int, default=1, help="processes running cases at once")
    parser.add_argument("--no-page", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, default=Path("out/seeds"))
    parser.add_argument("--json", type=Path, default=ROOT / "benchmarks/results/seeds.json")
    parser.add_argument("--page", type=Path, default=ROOT / "docs/verification.md")
    parser.add_argument("--table-only", action="store_true", help="the page from the JSON")
    args = parser.parse_args(argv)
    if args.levels < 2 or args.cells < 1 or args.budget_minutes <= 0 or args.jobs < 1:
        parser.error("--levels must be ≥ 2, --cells ≥ 1, --budget-minutes > 0 and --jobs ≥ 1")
    if args.settings != "minimiser" and set(args.cases) & set(SHAPES):
        parser.error(
            f"--settings {args.settings}: the shapes ({', '.join(SHAPES)}) run with "
            "the minimiser settings only; name the rectangles with --cases"
        )
    comm = MPI.COMM_WORLD
    if args.jobs > 1 and comm.size > 1:
        parser.error("--jobs runs serial processes: not under mpirun")
    record = json.loads(args.json.read_text()) if args.json.exists() else {"studies": {}}
    left: list[str] = []
    if not args.table_only:
        record["problem"] = PROBLEM.name
        left = run_jobs(args, record) if args.jobs > 1 else run_cases(args, record)
        if left:
            print0(comm, f"stopped: {', '.join(left)} left (the same command continues)")
    if comm.rank == 0 and not args.no_page:
        write_between(args.page, BEGIN, END, table(record))
        if any(not _grid(key) for key in record["studies"]):
            write_between(args.page, SHAPES_BEGIN, SHAPES_END, table(record, grid=False))
    return {**record, "left": left}


if __name__ == "__main__":
    # exit 3 when the budget or a signal left cases: the grid is not complete
    sys.exit(3 if main()["left"] else 0)
