"""What the demos in ``demos/`` share: their command line, their checks and their pictures.

A demo is a literate script that builds or loads a problem, runs it with :func:`dgplate.run`
and compares what it computed with a published or exact value. This module keeps those
scripts to the physics::

    import dgplate
    from dgplate import demo

    args = demo.arguments("vertical_load", paper="the published rows 16², 32², 64²")
    result = demo.run(dgplate.load_problem(PROBLEM, overrides={"mesh.cells": [16, 16]}), args)
    demo.report(result, "BNN 2021, Table 1: −7.53e−3")
    demo.check_close("E_h", result["energy"], -7.53e-3, rel=5e-3, source="BNN 2021, Table 1")

Every demo takes ``--paper`` (the published resolution; the default is small, so that the
test suite can run every demo), ``--out DIR``, ``--force``, ``--resume`` and ``--figure PATH``
(a copy of the final picture, e.g. for the documentation). The checks raise
:class:`AssertionError`, so a demo that no longer reproduces its number fails; they print one
line on rank 0 either way. Pictures beyond each run's final.png are drawn with the public
functions of :mod:`dgplate.io.plotting` (``plot_deformation``, ``render_png``),
:mod:`dgplate.io.montage` (``montage``) and :mod:`dgplate.io.images` (``frames_to_gif``;
``start_offscreen`` before a pyvista plotter of one's own). All functions
here are collective only where they say so. Bad input (an output folder of a user's files, a
wrong override) ends a demo with one line on stderr, as it ends ``dgplate run``.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import shutil
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from mpi4py import MPI

import numpy as np

from dgplate import interrupt
from dgplate.errors import InputError
from dgplate.io.output import OutputDir, print0
from dgplate.problems import folders
from dgplate.problems.specs import Problem


def _one_line_input_errors(
    kind: type[BaseException], error: BaseException, trace: TracebackType | None
) -> None:
    """``sys.excepthook`` of a demo script: bad input is one line on rank 0 and exit code 2.

    The ranks end together as the CLI's do (:func:`dgplate.cli.end_together`, on a
    communicator of its own), then at once (``os._exit``: a hook cannot set the exit code
    otherwise). Other errors, and every error in an interactive session, keep Python's
    handling.
    """
    if not issubclass(kind, InputError) or _ERRORS is None or _interactive():
        sys.__excepthook__(kind, error, trace)
        return
    from dgplate.cli import end_together

    code = end_together(_ERRORS, 2, f"{Path(sys.argv[0]).name}: error: {error}")
    sys.stdout.flush()
    if not MPI.Is_finalized():
        MPI.Finalize()
    os._exit(code)


def _interactive() -> bool:
    """A prompt that an error must not end: ``python -i``, the REPL, IPython, Jupyter."""
    return hasattr(sys, "ps1") or bool(sys.flags.inspect) or "IPython" in sys.modules


_ERRORS: MPI.Comm | None = None
"""The communicator the ranks of a demo script agree on an error with (set by :func:`parse`)."""


def _install_error_hook() -> None:
    """Make bad input one line for a demo run as a script (collective, once)."""
    global _ERRORS
    if _ERRORS is None and not _interactive():
        _ERRORS = MPI.COMM_WORLD.Dup() if MPI.COMM_WORLD.size > 1 else MPI.COMM_WORLD
        sys.excepthook = _one_line_input_errors


__all__ = [
    "arguments",
    "axis_angle",
    "branch",
    "check",
    "check_between",
    "check_close",
    "check_rolled",
    "copy_figure",
    "describe_cylinder",
    "output_folder",
    "parse",
    "parser",
    "report",
    "run",
    "say",
]


def parser(
    name: str,
    description: str | None = None,
    paper: str = "the published resolution",
    small: str | None = None,
) -> argparse.ArgumentParser:
    """The demos' common options; add a demo's own with ``add_argument`` and :func:`parse`.

    Args:
        name: The demo's name; the default output directory is ``out/<name>``.
        description: One line for ``--help``.
        paper: What ``--paper`` runs instead of the small default (its help text).
        small: What runs without ``--paper`` (``--help`` names it when given).

    Returns:
        A parser with ``--paper``, ``--out``, ``--force``, ``--resume``, ``--figure`` and
        ``--no-frames``.
    """
    out = f"out/{name}"
    parser = argparse.ArgumentParser(prog=f"{name}.py", description=description)
    default = f"; the default: {small}" if small else ""
    parser.add_argument("--paper", action="store_true", help=f"{paper} (slower{default})")
    parser.add_argument("--out", default=out, help=f"output directory (default {out})")
    parser.add_argument(
        "--force",
        action="store_true",
        help="write into a non-empty folder that dgplate did not write (its files are kept)",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue the runs from the checkpoints in the output folder",
    )
    parser.add_argument("--figure", default=None, help="also copy the final picture to this path")
    parser.add_argument(
        "--no-frames",
        action="store_true",
        help="skip the animation frames and GIF of output.frames_every (a quicker run)",
    )
    return parser


def parse(parser: argparse.ArgumentParser, argv: Sequence[str] | None = None) -> argparse.Namespace:
    """Parse the command line, ignoring what the parser does not know (Jupyter's arguments).

    Collective: a demo run as a script then ends on bad input with one line and exit code 2.
    """
    args, _ = parser.parse_known_args(argv)
    _install_error_hook()
    for name, value in vars(args).items():  # NaN and inf would reach the formulas unnamed
        numbers = value if isinstance(value, list) else [value]
        if any(isinstance(v, float) and not math.isfinite(v) for v in numbers):
            raise InputError(f"--{name.replace('_', '-')} must be a finite number, got {value}")
    return args


def arguments(
    name: str,
    description: str | None = None,
    paper: str = "the published resolution",
    argv: Sequence[str] | None = None,
) -> argparse.Namespace:
    """:func:`parse` of :func:`parser`: for demos without options of their own."""
    return parse(parser(name, description, paper), argv)


def run(
    problem: Problem,
    args: argparse.Namespace,
    *subfolder: str,
    comm: MPI.Comm = MPI.COMM_WORLD,
    **options: Any,
) -> Any:
    """:func:`dgplate.run` with the demo's ``--out``, ``--force``, ``--resume``, ``--no-frames``.

    Collective.

    With ``--resume``, a run that has a checkpoint in its folder continues from it, one that
    finished there returns its :class:`~dgplate.problems.result.Result` read back
    (:func:`dgplate.load_result`) without running again, and one that has not started yet
    starts: a demo of several runs can be resumed wherever it was stopped.

    Args:
        problem: A validated problem (:func:`dgplate.load_problem`).
        args: The parsed command line (:func:`arguments`).
        subfolder: Where in ``--out`` to write, for demos that run several problems.
        comm: The communicator of the run.
        options: More keywords for :func:`dgplate.run` (``initial``).

    Returns:
        What :func:`dgplate.run` returns; ``result["energy"]`` reads the summary.

    Raises:
        InputError: The output folder is not dgplate's (without ``--force``), or with
            ``--resume`` holds the checkpoint of another problem.
        SystemExit: The run was interrupted (SIGINT/SIGTERM), with 130 or 143: its outputs
            are written (``--resume`` continues it).
    """
    if subfolder:
        folders.claim(Path(args.out), args.force, comm)
    out = Path(args.out).joinpath(*subfolder)
    if getattr(args, "no_frames", False):
        problem = dataclasses.replace(
            problem, output=dataclasses.replace(problem.output, frames_every=0)
        )
    result, _ = folders.run_or_reuse(problem, out, comm, args.force, args.resume, **options)
    signum = result.summary.get("interrupted")
    if signum:  # the run wrote what it had; the demo's later runs and checks do not start
        print0(comm, f"{Path(sys.argv[0]).name}: {result.summary.get('reason', 'interrupted')}")
        raise SystemExit(interrupt.exit_code(signum))
    return result


def say(*text: Any, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """``print`` on rank 0 only, flushed."""
    if comm.rank == 0:
        print(*text, flush=True)


def branch(result: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """A followed path's load factor and stability index at each point, and its special points.

    Args:
        result: the summary of a run with ``path.method = "arclength"``.

    Returns:
        (load factors, stability indices, the kinds of the special points in order).
    """
    load = np.array(result["load_factors"])
    indices = np.array(result["stability_indices"])
    return load, indices, [point["kind"] for point in result["special_points"]]


def report(
    summary: Mapping[str, Any], reference: str = "", comm: MPI.Comm = MPI.COMM_WORLD
) -> None:
    """One line on rank 0: E_h (beside ``reference``, what it compares with), D_h and the steps."""
    beside = f" ({reference})" if reference else ""
    say(
        f"E_h = {summary['energy']:.4f}{beside}, D_h = {summary['isometry_defect']:.3e}, "
        f"steps = {summary['steps']}, converged = {summary['converged']}",
        comm=comm,
    )


def describe_cylinder(fit: Mapping[str, Any], alpha: float | None = None) -> str:
    """The cylinder fitted to the deformed surface: radius (beside 1/α), axis, RMS distance."""
    expected = f" (1/α = {1 / alpha:.4f})" if alpha else ""
    axis = ", ".join(f"{c:+.3f}" for c in fit["axis"])
    return (
        f"fitted radius {fit['radius']:.4f}{expected}, axis ({axis}), "
        f"rms distance {fit['rms_residual']:.2e}"
    )


def axis_angle(fit: Mapping[str, Any], direction: Sequence[float]) -> float:
    """The angle in degrees (0 to 90) between a fitted cylinder's axis and ``direction``.

    Args:
        fit: ``summary["cylinder_fit"]`` of a bilayer run.
        direction: A direction in space, e.g. ``(0, 1, 0)`` for the x₂ axis.
    """
    axis, other = np.asarray(fit["axis"], dtype=float), np.asarray(direction, dtype=float)
    cosine = abs(float(axis @ other)) / (np.linalg.norm(axis) * np.linalg.norm(other))
    return math.degrees(math.acos(min(1.0, cosine)))


def _passed(what: str, ok: bool, text: str, comm: MPI.Comm) -> None:
    say(f"{'ok' if ok else 'FAILED'}: {text}", comm=comm)
    if not ok:
        raise AssertionError(f"{what}: {text}")


def check_close(
    what: str,
    value: float,
    expected: float,
    *,
    rel: float = 0.0,
    abs: float = 0.0,
    source: str = "",
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> None:
    """Check ``|value − expected| ≤ max(rel·|expected|, abs)``; print it on rank 0.

    Args:
        what: The quantity, as printed (e.g. ``"E_h"``).
        value: The computed value (the same on every rank).
        expected: The published or exact value.
        rel: The relative tolerance.
        abs: The absolute tolerance.
        source: Where ``expected`` comes from (printed).
        comm: Rank 0 of it prints.

    Raises:
        AssertionError: Outside the tolerance, or not a finite number.
    """
    tol = max(rel * math.fabs(expected), abs)
    ok = math.isfinite(value) and math.fabs(value - expected) <= tol
    shown = f"± {100 * rel:.3g} %" if rel * math.fabs(expected) >= abs else f"± {abs:.3g}"
    origin = f" ({source})" if source else ""
    _passed(what, ok, f"{what} = {value:.6g}, expected {expected:.6g} {shown}{origin}", comm)


def check_between(
    what: str,
    value: float,
    low: float | None = None,
    high: float | None = None,
    *,
    source: str = "",
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> None:
    """Check ``low ≤ value ≤ high`` (either bound may be left out); print it on rank 0.

    Raises:
        AssertionError: Outside the bounds, or not a finite number.
        ValueError: Neither bound is given.
    """
    if low is None and high is None:
        raise ValueError("check_between needs a lower or an upper bound")
    ok = math.isfinite(value) and (low is None or value >= low) and (high is None or value <= high)
    if low is not None and high is not None:
        bounds = f"in [{low:.6g}, {high:.6g}]"
    else:
        bounds = f"≥ {low:.6g}" if low is not None else f"≤ {high:.6g}"
    origin = f" ({source})" if source else ""
    _passed(what, ok, f"{what} = {value:.6g}, expected {bounds}{origin}", comm)


def check(what: str, ok: bool, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Check a statement ``what`` that ``ok`` says is true; print it on rank 0.

    Raises:
        AssertionError: ``ok`` is false.
    """
    _passed(what, bool(ok), what, comm)


def check_rolled(
    summary: Mapping[str, Any],
    ideal: float,
    *,
    rel: float,
    axis: str,
    max_angle: float,
    source: str,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> None:
    """The checks of a bilayer that rolls into one cylinder about its clamped side.

    The flow converged with a decreasing energy, E_h is within ``rel`` of ``ideal`` (½α²|ω|)
    and the fitted axis within ``max_angle`` degrees of the coordinate axis ``axis``
    (``"x₁"`` or ``"x₂"``), the direction of the clamped ``source``.
    """
    direction = {"x₁": (1, 0, 0), "x₂": (0, 1, 0)}[axis]
    check("the flow converged and E_h decreased at every step",
          summary["converged"] and not summary["energy_increases"], comm)  # fmt: skip
    check_close("E_h", summary["energy"], ideal, rel=rel, source="the cylinder: ½α²|ω|", comm=comm)
    angle = axis_angle(summary["cylinder_fit"], direction)
    check_between(f"angle of the axis to {axis} (°)", angle, high=max_angle,
                  source=f"the {source}'s direction", comm=comm)  # fmt: skip


def check_self_avoiding(result: Any, headline: str, comm: MPI.Comm = MPI.COMM_WORLD) -> list[float]:
    """Report a self-avoiding run and check that no step penetrated or raised the energy.

    Prints E_h beside ``headline``, the least distance of non-neighbouring points at the
    start, its least and final values (history.csv's ``min_distance``), ρTP and the steps
    redone by the safety net; checks that no accepted step raised I + ρTP and that the least
    distance stayed ≥ 10⁻³. Returns the distances, one per step.
    """
    history = result.history
    distances = [float(row["min_distance"]) for row in history]
    redone = int(sum(row["redone"] for row in history))
    report(result, headline, comm)
    say(
        f"min distance: start {distances[0]:.4f}, least {min(distances):.4f}, final "
        f"{distances[-1]:.4f}; ρTP = {result['self_avoidance_energy']:.3e}; "
        f"steps redone: {redone}",
        comm=comm,
    )
    check("no accepted step raised I + ρTP", not result["energy_increases"], comm)
    check_between(
        "least distance of non-neighbouring points",
        min(distances),
        low=1e-3,
        source="no self-penetration",
        comm=comm,
    )
    return distances


def copy_figure(
    out: str | Path,
    figure: str | Path | None,
    name: str = "final.png",
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> None:
    """Copy ``out/name`` to ``figure`` (``--figure``) on rank 0, if one is given.

    Args:
        out: The run's output folder.
        figure: The copy's path, or ``None`` for none.
        name: The picture in ``out``.
        comm: Rank 0 of it copies.
    """
    if figure and comm.rank == 0:
        Path(figure).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(Path(out) / name, figure)


def output_folder(args: argparse.Namespace, comm: MPI.Comm = MPI.COMM_WORLD) -> OutputDir:
    """The ``--out`` folder of a demo that writes its results itself. Collective.

    Checked now, before anything is computed, as a run's is: a folder of a user's files is
    refused without ``--force``, and none of its files is ever deleted. The demo writes into
    ``.path`` (a staging folder) and calls ``commit()`` at the end, so that the results appear
    together, ``summary.json`` last. Such a demo keeps no checkpoints: ``--resume`` starts
    it afresh, with a warning.
    """
    if getattr(args, "resume", False) and comm.rank == 0:
        print(
            "dgplate: warning: --resume: this demo keeps no checkpoints; it runs from the start",
            file=sys.stderr,
            flush=True,
        )
    return OutputDir(comm, Path(args.out), force=args.force)


def save_shape(driver: Any, out: str | Path, title: str = "") -> None:
    """Write a driver's final shape as ``deformation.bp`` (VTX) and ``final.png``. Collective.

    For demos that drive a model themselves (e.g. several meshes or load paths in one
    script) rather than through :func:`run`, so that their states open in ParaView too.

    Args:
        driver: A driver (:class:`dgplate.solvers.driver.Driver`) after its run.
        out: The folder to write into (created if missing).
        title: The picture's title.
    """
    from dgplate.io.plotting import plot_deformation
    from dgplate.io.vtx import DeformationWriter

    folder = Path(out)
    if driver.comm.rank == 0:
        folder.mkdir(parents=True, exist_ok=True)
    driver.comm.barrier()
    writer = DeformationWriter(folder / "deformation.bp", driver.shape, comm=driver.comm)
    writer.write(driver.time)
    writer.close()
    plot_deformation(driver.shape, folder / "final.png", title=title, color_by=None)
