"""Command line: ``dgplate run PROBLEM.toml [--out DIR] [--force] [--resume] [--set k=v ...]``.

``dgplate converge PROBLEM.toml [--levels N]`` (and the options of ``run``) runs the problem on
N meshes, each refined by 2, and extrapolates its figures (:mod:`dgplate.problems.converge`).

``dgplate check`` takes the same arguments and validates everything ``run`` would (the output
folder, the mesh, the model, the start) without solving or writing: 0 valid, 2 bad input.
``dgplate show OUT [OUT ...]`` prints finished or running runs from their output folders: one
run in detail, several as a table (a demo's folder of several runs stands for them).

Exit codes: 0 success; 1 the solve did not converge, or failed (outputs are written, with the
reason); 2 bad input (a one-line message on stderr, nothing written), a problem too large for
the job's memory included (``--allow-large`` runs it); 130 and 143 the run was interrupted by
SIGINT or SIGTERM (outputs and a checkpoint are written; ``--resume`` goes on; during the
set-up and the compilation of forms the signal ends the process at once).
Under MPI an error on some ranks ends all of them within seconds (:func:`end_together`).
"""

from __future__ import annotations

import argparse
import signal
import sys
import traceback
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from mpi4py import MPI

from dgplate import interrupt, mpi
from dgplate.errors import InputError, UnsupportedVersionError
from dgplate.io.output import silence

if TYPE_CHECKING:
    from dgplate.problems.specs import Problem

AGREE_SECONDS = 10.0
"""How long ranks that failed wait for the others before aborting the whole job."""


class _Parser(argparse.ArgumentParser):
    """argparse's parser, printing usage, help and errors on rank 0 only (not once per rank)."""

    def _print_message(self, message: str, file: Any = None) -> None:
        if MPI.COMM_WORLD.rank == 0:
            super()._print_message(message, file)


def _parser() -> argparse.ArgumentParser:
    from dgplate import __version__
    from dgplate.problems.sizing import MAX_DEGREE

    parser = _Parser(
        prog="dgplate", description="Large bending deformations of thin plates (IP-dG, DOLFINx)."
    )
    parser.add_argument("--version", action="version", version=f"dgplate {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="solve a problem file and write its outputs")
    check = sub.add_parser(
        "check",
        help="validate a problem file as `run` would (mesh, model, output folder), "
        "without solving or writing",
    )
    converge = sub.add_parser(
        "converge",
        help="run a problem on successively refined meshes; observed orders and "
        "Richardson-extrapolated figures",
    )
    converge.add_argument(
        "--levels", type=int, default=4, help="the number of meshes, each refined by 2 (≥ 2)"
    )
    for command in (run, check, converge):
        command.add_argument("problem", help="a TOML problem file (see `dgplate schema`)")
        command.add_argument("--out", help="output directory (default: output.dir or out/<name>)")
        command.add_argument(
            "--force",
            action="store_true",
            help="write into a non-empty folder that dgplate did not write (its files are kept)",
        )
        command.add_argument(
            "--resume",
            action="store_true",
            help="reuse the finished levels and continue the interrupted one from its checkpoint"
            if command is converge
            else "continue from the checkpoint in the output folder (same problem, any ranks)",
        )
        command.add_argument(
            "--allow-large",
            action="store_true",
            help="run a problem that needs more memory than the job has, or a polynomial "
            f"degree beyond {MAX_DEGREE} (refused otherwise, before anything is built)",
        )
        command.add_argument(
            "--set",
            dest="overrides",
            action="append",
            default=[],
            metavar="KEY=VALUE",
            help="override a problem-file key, e.g. --set mesh.cells=[32,32] --set flow.tau=0.1",
        )
    show = sub.add_parser(
        "show",
        help="print runs from their output folders: one in detail, several as a table",
    )
    show.add_argument("folders", nargs="+", metavar="OUT", help="dgplate output folders")
    export = sub.add_parser(
        "export", help="write a finished run's sheet, thickened, as a printable solid"
    )
    export.add_argument("folder", metavar="OUT", help="the run's output folder")
    export.add_argument(
        "--solid",
        required=True,
        metavar="FILE",
        help="the solid y ± (t/2)ν as binary .stl, .ply or .vtu (in mm with a [material])",
    )
    export.add_argument(
        "--thickness",
        type=float,
        help="the thickness t in the mesh's units (default: the [material]'s)",
    )
    compare = sub.add_parser(
        "compare",
        help="align a measured point cloud to a finished run's shape; RMS and Hausdorff distances",
    )
    compare.add_argument("folder", metavar="OUT", help="the run's output folder")
    compare.add_argument(
        "scan",
        help="the points: .xyz, .txt, .csv (x y z per line), .ply, .stl, .vtp or .vtk, in mm "
        "with a [material]",
    )
    compare.add_argument(
        "--map",
        metavar="FILE.png",
        help="a picture of the aligned scan coloured by its signed distance to the shape",
    )
    schema = sub.add_parser("schema", help="print every problem-file key with its default")
    schema.add_argument(
        "--model", default="kirchhoff", help="the model whose [model] keys to print"
    )
    return parser


class _ArgumentError(Exception):
    """Raised instead of argparse's exit: ``args`` are (exit code, message or None)."""


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (the same on every rank)."""
    parser = _parser()
    parser.exit = _exit  # type: ignore[method-assign]
    comm = MPI.COMM_WORLD
    try:
        args = parser.parse_args(argv)
    except _ArgumentError as err:
        code: int = err.args[0]
        message: str | None = err.args[1]
        if message and comm.rank == 0:
            sys.stderr.write(message)
        return code
    # a separate communicator for the error agreement: it can never match a collective of
    # the run that some rank is still waiting in
    errors = comm.Dup() if comm.size > 1 else comm
    try:
        return _command(args, comm)
    except BrokenPipeError:  # the reader of our output went away (`dgplate show … | head`)
        silence(sys.stdout)  # no error at exit
        return end_together(errors, 1, "")
    except (InputError, UnsupportedVersionError) as err:
        _drop_solver_options()
        return end_together(errors, 2, f"dgplate: error: {err}")
    except KeyboardInterrupt:
        return end_together(errors, 130, "dgplate: interrupted (SIGINT)")
    except Exception as err:
        detail = "".join(traceback.format_exception(err)).rstrip()
        return end_together(errors, 1, f"{detail}\ndgplate: error: {type(err).__name__}: {err}")
    finally:
        if errors is not comm:
            errors.Free()


def _command(args: argparse.Namespace, comm: MPI.Comm) -> int:
    if args.command == "schema":
        return _schema(args.model)
    if args.command in ("show", "export", "compare"):
        return _on_outputs(args, comm)
    from dgplate.problems.runner import run
    from dgplate.problems.specs import load_problem

    problem = load_problem(args.problem, args.overrides)
    # the set-up and the compilation end at once on SIGINT and SIGTERM (nothing to keep yet)
    with interrupt.StopOnSignal(at_once=True):
        if args.command == "check":
            return _check(problem, args, comm)
        options = {"force": args.force, "resume": args.resume, "allow_large": args.allow_large}
        if args.command == "converge":
            return _converge(problem, args, comm, options)
        summary = run(problem, args.out, comm, **options).summary
    if summary.get("interrupted"):
        if comm.rank == 0:
            print(
                f"dgplate: {summary['reason']}: outputs and a checkpoint are in the output "
                "folder; run again with --resume to continue",
                file=sys.stderr,
                flush=True,
            )
        return interrupt.exit_code(summary["interrupted"])
    if not summary["converged"]:
        if comm.rank == 0:
            print(
                f"dgplate: {_failed(summary)}: {summary['reason']}",
                file=sys.stderr,
                flush=True,
            )
        return 1
    return 0


def _failed(summary: dict[str, Any]) -> str:
    """How a run that did not end as it should ended, in words (a path stopped, a flow …)."""
    from dgplate.io.run_reader import outcome

    return "the path stopped" if outcome(summary) == "path stopped" else "the flow did not converge"


def _on_outputs(args: argparse.Namespace, comm: MPI.Comm) -> int:
    """The commands on finished runs' output folders: ``show``, ``export``, ``compare``."""
    if args.command == "show":
        return _show(args.folders, comm)
    if args.command == "export":
        return _export(args, comm)
    return _compare(args, comm)


def _converge(
    problem: Problem, args: argparse.Namespace, comm: MPI.Comm, options: dict[str, bool]
) -> int:
    """``dgplate converge``: the levels, then the table; 1 if a level did not converge."""
    from dgplate.problems.converge import converge, exit_code

    study = converge(problem, args.levels, args.out, comm, **options)
    if study.interrupted and comm.rank == 0:
        print(
            f"dgplate: interrupted: the levels so far are in {study.folder}; run again with "
            "--resume to go on",
            file=sys.stderr,
            flush=True,
        )
    return exit_code(study)


def _check(problem: Problem, args: argparse.Namespace, comm: MPI.Comm) -> int:
    """``dgplate check``: one line saying what the run would be, its warnings, and what it calibrates."""
    from dgplate.problems import advice
    from dgplate.problems.runner import check

    options = {"force": args.force, "resume": args.resume, "allow_large": args.allow_large}
    report = check(problem, args.out, comm, **options)
    advice.warn(comm, report["warnings"])
    if comm.rank == 0:
        resume = report["resume_step"]
        after = f", resumes after step {resume}" if resume is not None else ""
        print(
            f"dgplate: {report['problem']}: valid: {report['setting']}{after}, "
            f"output → {report['output']}",
            flush=True,
        )
        if report["calibration"]:
            print(f"dgplate: {report['calibration']}", flush=True)
    return 0


def _show(folders: list[str], comm: MPI.Comm) -> int:
    """``dgplate show``: the runs' summaries, read on rank 0 (files only, nothing built).

    One folder that cannot be read is bad input (exit 2); in a table it is a row that says
    why, so that one broken folder among many does not hide the others.
    """
    from dgplate.io.run_reader import details, read_summary, runs_in, table

    report: str | InputError | None = None
    if comm.rank == 0:
        try:
            runs = runs_in(folders)
            if len(runs) == 1:
                report = details(read_summary(runs[0]))
            else:
                report = table([_summary_or_error(run) for run in runs])
        except InputError as err:
            report = err
        except Exception as err:  # e.g. no permission: one line, on every rank
            report = InputError(f"{type(err).__name__}: {err}")
    report = comm.bcast(report, root=0)
    if isinstance(report, InputError):
        raise report
    if comm.rank == 0:
        print(report, flush=True)
    return 0


def _export(args: argparse.Namespace, comm: MPI.Comm) -> int:
    """``dgplate export``: the solid, and one line with its triangles and volume."""
    from dgplate.problems.shapes import export_solid

    figures = export_solid(args.folder, args.solid, args.thickness, comm)
    if comm.rank == 0:
        units = figures["units"]
        closed = "watertight" if figures["watertight"] else "NOT watertight"
        print(
            f"dgplate: wrote {args.solid}: {figures['triangles']:,} triangles, {closed}, "
            f"volume {figures['volume']:.6g} {units}³ (area × thickness "
            f"{figures['area_times_thickness']:.6g})",
            flush=True,
        )
    return 0


def _compare(args: argparse.Namespace, comm: MPI.Comm) -> int:
    """``dgplate compare``: one line with the distances left after the alignment."""
    from dgplate.problems.shapes import compare_scan

    found = compare_scan(args.folder, args.scan, comm, args.map)
    if comm.rank == 0:
        units = found["units"]
        print(
            f"dgplate: {args.scan}: {found['points']:,} points, RMS {found['rms']:.4g} {units}, "
            f"max {found['max']:.4g} {units}, Hausdorff {found['hausdorff']:.4g} {units} after "
            f"a rotation by {found['angle_deg']:.4g}° ({found['steps']} steps)",
            flush=True,
        )
    return 0


def _summary_or_error(folder: Path) -> dict[str, object]:
    """The run's summary, or a row whose ``error`` says why it cannot be read."""
    from dgplate.io.run_reader import read_summary

    try:
        return read_summary(folder)
    except Exception as err:
        return {"folder": str(folder), "error": str(err)}


def _drop_solver_options() -> None:
    """Forget the options of solvers that bad input stopped before they ran.

    PETSc would report them as unused at exit (:func:`dgplate.solvers.linear.drop_options`);
    without them the error stays one line.
    """
    if "petsc4py.PETSc" in sys.modules:
        from dgplate.solvers.linear import drop_options

        drop_options()


def end_together(comm: MPI.Comm, code: int, message: str) -> int:
    """End a failed command on every rank with ``code``, printing ``message`` once ('': none).

    Rank 0 prints first: under ``python -m mpi4py`` the first rank that exits non-zero
    aborts the job. When every rank failed (bad input is detected on all of them), they then
    meet in a non-blocking barrier within ``AGREE_SECONDS`` and all return ``code``. When some
    rank did not fail, it waits in a collective of the run that will never complete: the
    failed ranks then abort the whole job with ``code`` (printing the message if rank 0 could
    not), instead of leaving it to hang until a cluster's time limit.
    """
    if comm.rank == 0 and message:
        print(message, file=sys.stderr, flush=True)
    if not mpi.arrive_within(comm, AGREE_SECONDS):
        if comm.rank != 0 and message:
            print(f"{message} (rank {comm.rank})", file=sys.stderr, flush=True)
        comm.Abort(code)
    return code


def _exit(status: int = 0, message: str | None = None) -> NoReturn:
    raise _ArgumentError(2 if status else 0, message)


def _schema(model: str) -> int:
    from dgplate.problems.registry import MODELS
    from dgplate.problems.specs import sections
    from dgplate.schema import describe

    if model not in MODELS:
        raise InputError(f"--model: unknown model {model!r} (known: {', '.join(MODELS)})")
    if MPI.COMM_WORLD.rank == 0:
        # PETSc (imported with the models) catches SIGPIPE and aborts: `dgplate schema | head`
        # should end quietly, with Python's BrokenPipeError (see main)
        previous = signal.signal(signal.SIGPIPE, signal.SIG_IGN)
        try:
            entry = MODELS[model]
            texts = [
                describe(spec, sec, entry.ignored_keys(sec), entry.defaults(sec))
                for sec, spec in sections(model)
            ]
            print("\n\n".join(texts))
        finally:
            signal.signal(signal.SIGPIPE, previous)
    return 0


if __name__ == "__main__":
    sys.exit(main())
