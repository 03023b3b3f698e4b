"""What the problem-file demos share: their command line, their report, their picture.

Each such demo loads a problem file, runs it with :func:`dgplate.problems.runner.run_problem` and prints
what to compare with the theory; these helpers keep those scripts to the physics.
"""

from __future__ import annotations

import argparse
import shutil
from collections.abc import Mapping
from pathlib import Path

from mpi4py import MPI

from dgplate.io.output import print0


def demo_arguments(description: str | None, out: str, paper: str) -> argparse.Namespace:
    """``--paper`` (help text ``paper``), ``--out`` (default ``out``) and ``--figure``.

    Unknown arguments are ignored, so that the scripts also run under Jupyter and pytest.
    """
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--paper", action="store_true", help=paper)
    parser.add_argument("--out", default=out, help=f"output directory (default {out})")
    parser.add_argument("--figure", default=None, help="also copy final.png to this path")
    args, _ = parser.parse_known_args()
    return args


def report_run(comm: MPI.Comm, summary: Mapping, reference: str) -> None:
    """E_h (beside ``reference``, what it should be compared with), D_h and the steps."""
    print0(
        comm,
        f"E_h = {summary['energy']:.4f} ({reference}), "
        f"D_h = {summary['isometry_defect']:.3e}, steps = {summary['steps']}, "
        f"converged = {summary['converged']}",
    )


def describe_cylinder(fit: Mapping, alpha: float | None = None) -> str:
    """The cylinder fitted to the deformed surface: radius (beside 1/α), axis, RMS distance."""
    expected = f" (1/α = {1 / alpha:.4f})" if alpha else ""
    axis = ", ".join(f"{c:+.3f}" for c in fit["axis"])
    return (
        f"fitted radius {fit['radius']:.4f}{expected}, axis ({axis}), "
        f"rms distance {fit['rms_residual']:.2e}"
    )


def copy_figure(comm: MPI.Comm, out: str | Path, figure: str | None) -> None:
    """Copy the run's final.png to ``figure`` (the documentation's pictures), if asked."""
    if figure and comm.rank == 0:
        Path(figure).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(Path(out) / "final.png", figure)
