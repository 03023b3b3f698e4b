"""The C compiler's flags for the JIT-compiled forms: compile time and run time, side by side.

Each case runs as a user runs it, ``dgplate.run`` in a process of its own, once with an empty
JIT cache (the forms are compiled: a first run) and once more with the filled one (a later
run), for each set of flags in ``FLAGS``. The flags reach DOLFINx as a user's
``dolfinx_jit_options.json`` in the process's working folder, the way that overrides
dgplate's default (:data:`dgplate.compat.JIT_COMPILE_ARGS`). Compiling is the first run's
time less the later run's.

    python benchmarks/jit_flags.py [--cases cylinder bnn triangles] [--json …]
    python benchmarks/jit_flags.py --table-only

The table of docs/performance.md between ``<!-- jit_flags:begin -->`` and
``<!-- jit_flags:end -->`` is generated from the JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from pages import add_page_options, publish

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "jit_flags.json"
PAGE = ROOT / "docs" / "performance.md"
MARKERS = ("<!-- jit_flags:begin -->", "<!-- jit_flags:end -->")
QUIET = {"output.png": False, "output.vtx": False, "output.frames_every": 0, "output.progress": 0}

#: name → (problem file, overrides, what it is)
CASES: dict[str, tuple[str, dict[str, Any], str]] = {
    "cylinder": (
        "bilayer_cylinder.toml",
        {"mesh.cells": [32, 16]},
        "bilayer cylinder, 32 × 16 Q2",
    ),
    "bnn": ("vertical_load.toml", {"mesh.cells": [32, 32]}, "BNN plate, 32² Q2"),
    "triangles": (
        "vertical_load.toml",
        {"mesh.cells": [16, 16], "mesh.cell_type": "triangle"},
        "BNN plate, 16² × 2 P2 triangles",
    ),
}
#: the flags compared: DOLFINx's default first, then dgplate's
FLAGS = (["-O2", "-g0"], ["-O1", "-g0"])


def child(case: str) -> None:
    """Run ``case`` once (in this process) and print its run's wall time as JSON."""
    import dgplate

    path, overrides, _ = CASES[case]
    problem = dgplate.load_problem(ROOT / "demos" / "problems" / path, {**overrides, **QUIET})
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        result = dgplate.run(problem, out=Path(out) / "run")
        wall = time.perf_counter() - start
    print(json.dumps({"run_s": wall, "energy": result["energy"], "steps": result["steps"]}))


def timed_process(case: str, flags: list[str], cache: Path, cwd: Path) -> dict[str, float]:
    """One process running ``case`` with ``flags`` and the JIT cache in ``cache``."""
    (cwd / "dolfinx_jit_options.json").write_text(json.dumps({"cffi_extra_compile_args": flags}))
    env = {"XDG_CACHE_HOME": str(cache), "PYTHONPATH": f"{ROOT}:{ROOT / 'benchmarks'}"}
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--child", case],
        cwd=cwd,
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        check=True,
    )
    record: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    record["process_s"] = time.perf_counter() - start
    return record


def measure(case: str) -> dict[str, Any]:
    """The first and a later run of ``case`` with each of ``FLAGS``."""
    rows = []
    for flags in FLAGS:
        with tempfile.TemporaryDirectory() as scratch:
            folder = Path(scratch)
            first = timed_process(case, flags, folder / "cache", folder)
            later = timed_process(case, flags, folder / "cache", folder)
        rows.append(
            {
                "flags": flags,
                "first_s": first["process_s"],
                "later_s": later["process_s"],
                "run_s": later["run_s"],
                "compile_s": first["process_s"] - later["process_s"],
                "energy": later["energy"],
                "steps": later["steps"],
            }
        )
        print(f"{case} {' '.join(flags)}: {rows[-1]}", flush=True)
    return {"case": case, "what": CASES[case][2], "rows": rows}


def table(record: dict[str, Any]) -> str:
    """The page's section from the JSON."""
    lines = [
        "Each case run by `dgplate.run` in a process of its own, first with an empty JIT cache, "
        "then again with the filled one (`benchmarks/jit_flags.py`, "
        "`benchmarks/results/jit_flags.json`); compiling is the difference.",
        "",
        "| case | flags | first run (s) | later run (s) | compiling (s) | the run itself (s) |"
        " compiling, against -O2 | run, against -O2 |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for case in record["cases"]:
        base = case["rows"][0]
        for row in case["rows"]:
            lines.append(
                f"| {case['what']} | `{' '.join(row['flags'])}` | {row['first_s']:.1f} | "
                f"{row['later_s']:.1f} | {row['compile_s']:.1f} | {row['run_s']:.2f} | "
                f"{row['compile_s'] / base['compile_s']:.2f} | {row['run_s'] / base['run_s']:.2f} |"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """The command line (``argv``: sys.argv's by default)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=list(CASES))
    parser.add_argument("--child", choices=sorted(CASES), help=argparse.SUPPRESS)
    add_page_options(parser, RESULTS, PAGE)
    args = parser.parse_args(argv)
    if args.child:
        child(args.child)
        return
    record = None
    if not args.table_only:
        record = {"cases": [measure(case) for case in args.cases]}
    publish(MPI.COMM_WORLD, args, record, MARKERS, table)


if __name__ == "__main__":
    main()
