"""Generated sections of the documentation pages: the text between a page's two markers."""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate.io.output import print0
from dgplate.problems.result import Result
from dgplate.problems.runner import run as run_problem
from dgplate.problems.specs import Problem


def write_between(page: Path, begin: str, end: str, text: str, heading: str = "") -> None:
    """Replace the page's text from ``begin`` to ``end`` (both markers included) by ``text``.

    Args:
        page: the Markdown page.
        begin: the opening marker, e.g. ``<!-- accuracy:begin -->``.
        end: the closing marker.
        text: the new section, markers included.
        heading: if given, a page without the markers gets ``## heading`` and the section
            appended; if not, such a page is an error.

    Raises:
        SystemExit: the page lacks a marker and no ``heading`` is given (the page is left as
            it was).
    """
    content = page.read_text()
    if begin not in content or end not in content:
        if not heading:
            raise SystemExit(f"{page} has no {begin} … {end} markers")
        page.write_text(content.rstrip("\n") + f"\n\n## {heading}\n\n{text}\n")
        return
    head, rest = content.split(begin, 1)
    page.write_text(head + text + rest.split(end, 1)[1])


def add_page_options(parser: argparse.ArgumentParser, results: Path, page: Path) -> None:
    """The options of a benchmark whose JSON makes a table of a page.

    Args:
        parser: the benchmark's parser; it gets ``--json``, ``--page`` and ``--table-only``.
        results: the default JSON file.
        page: the default Markdown page.
    """
    parser.add_argument("--json", type=Path, default=results)
    parser.add_argument("--page", type=Path, default=page)
    parser.add_argument(
        "--table-only", action="store_true", help="rewrite --page's table from --json"
    )


def publish(
    comm: MPI.Comm,
    args: argparse.Namespace,
    record: dict[str, Any] | None,
    markers: tuple[str, str],
    table: Callable[[dict[str, Any]], str],
) -> str:
    """Write ``record`` to ``args.json`` (if given), then ``args.page``'s table from the JSON.

    Args:
        comm: the benchmark's communicator; rank 0 writes and prints.
        args: the parsed options of :func:`add_page_options`.
        record: the results of this run, or None (``--table-only``): the JSON as it is.
        markers: the page's begin and end markers.
        table: the table's Markdown from the JSON's content.

    Returns:
        The table on rank 0, an empty string on the other ranks.
    """
    if comm.rank != 0:
        return ""
    if record is not None:
        args.json.write_text(json.dumps(record, indent=2) + "\n")
    text = table(json.loads(args.json.read_text()))
    begin, end = markers
    write_between(args.page, begin, end, f"{begin}\n{text}\n{end}")
    print(text)
    return text


def run_in_scratch(
    comm: MPI.Comm, problem: Problem, what: str, prefix: str = "bench_"
) -> tuple[Result, float]:
    """Run a problem with its outputs in a temporary folder, removed afterwards (collective).

    Args:
        comm: the run's communicator.
        problem: the validated problem (the size guard is passed: a study chooses its sizes).
        what: the run, as named when it was interrupted (``h = 0.05``).
        prefix: the temporary folder's prefix.

    Returns:
        The run's result (its final y kept) and its wall time in seconds.

    Raises:
        SystemExit: the run was interrupted (:func:`stop_if_interrupted`).
    """
    folder = comm.bcast(tempfile.mkdtemp(prefix=prefix) if comm.rank == 0 else None, root=0)
    try:
        t0 = time.perf_counter()
        result = run_problem(problem, Path(folder) / "run", comm, allow_large=True)
        wall = time.perf_counter() - t0
    finally:
        comm.barrier()  # every rank is done with the folder
        if comm.rank == 0:
            shutil.rmtree(folder, ignore_errors=True)
    stop_if_interrupted(result.summary, what)
    return result, wall


def stop_if_interrupted(summary: dict[str, Any], what: str) -> None:
    """End the study when a run was interrupted (SIGINT/SIGTERM): its next level must not start.

    Args:
        summary: the run's summary.
        what: the run, as named in the message (e.g. ``h = 0.05``).

    Raises:
        SystemExit: with the run's reason, when it was interrupted.
    """
    if summary.get("interrupted"):
        raise SystemExit(f"{what}: {summary.get('reason', 'interrupted')}")


def run_levels(
    comm: MPI.Comm, sizes: list[float], one_level: Callable[[MPI.Comm, float], dict[str, Any]]
) -> list[dict[str, Any]]:
    """``one_level(comm, size)`` for each mesh size, each record printed as JSON (rank 0).

    Args:
        comm: the runs' communicator (collective).
        sizes: the mesh sizes, coarsest first.
        one_level: the record of the benchmark at one size.

    Returns:
        The records, in the order of ``sizes``.
    """
    levels = []
    for size in sizes:
        levels.append(one_level(comm, size))
        print0(comm, json.dumps(levels[-1]))
    return levels
