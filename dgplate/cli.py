"""Command line: ``dgplate run PROBLEM.toml [--out DIR] [--set key=value ...]``.

Exit codes: 0 success, 1 the solve did not converge (outputs are written), 2 bad input (a
one-line message on stderr, nothing written).
"""

from __future__ import annotations

import argparse
import sys
import time

from mpi4py import MPI

from dgplate.errors import InputError, UnsupportedVersionError


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="dgplate", description="Large bending deformations of thin plates (IP-dG, DOLFINx)."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="solve a problem file and write its outputs")
    run.add_argument("problem", help="a TOML problem file (see `dgplate schema`)")
    run.add_argument("--out", help="output directory (default: output.dir or out/<name>)")
    run.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a problem-file key, e.g. --set mesh.cells=[32,32] --set flow.tau=0.1",
    )
    schema = sub.add_parser("schema", help="print every problem-file key with its default")
    schema.add_argument(
        "--model", default="kirchhoff", help="the model whose [model] keys to print"
    )
    return parser


class _ArgumentError(Exception):
    pass


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    parser.exit = _exit  # type: ignore[method-assign]
    comm = MPI.COMM_WORLD
    try:
        args = parser.parse_args(argv)
    except _ArgumentError as err:
        code, message = err.args
        if message and comm.rank == 0:
            sys.stderr.write(message)
        return code
    try:
        if args.command == "schema":
            return _schema(args.model)
        from dgplate.problem import load_problem
        from dgplate.runner import run_problem

        problem = load_problem(args.problem, args.overrides)
        summary = run_problem(problem, args.out, comm)
    except (InputError, UnsupportedVersionError) as err:
        if comm.rank == 0:
            print(f"dgplate: error: {err}", file=sys.stderr, flush=True)
        _wait_for_rank0(comm)
        return 2
    if not summary["converged"]:
        if comm.rank == 0:
            print(
                f"dgplate: the flow did not converge: {summary['reason']}",
                file=sys.stderr,
                flush=True,
            )
        return 1
    return 0


def _wait_for_rank0(comm: MPI.Comm, timeout: float = 10.0) -> None:
    """Let rank 0 print its message before any rank exits with an error code.

    Under ``python -m mpi4py`` the first rank that exits non-zero aborts the whole job, which
    can kill rank 0 before it has printed. Input errors are raised on every rank, so a barrier
    would do; a non-blocking one with a deadline also ends if some rank never gets here.
    """
    if comm.size == 1:
        return
    request = comm.Ibarrier()
    deadline = time.monotonic() + timeout
    while not request.Test() and time.monotonic() < deadline:
        time.sleep(0.005)


def _exit(status: int = 0, message: str | None = None):
    raise _ArgumentError(2 if status else 0, message)


def _schema(model: str) -> int:
    from dgplate.models.registry import MODELS
    from dgplate.problem import FlowSpec, MeshSpec, OutputSpec
    from dgplate.schema import describe

    if model not in MODELS:
        print(
            f"dgplate: error: unknown model {model!r} (known: {', '.join(MODELS)})", file=sys.stderr
        )
        return 2
    parts = [
        describe(MeshSpec, "mesh"),
        describe(MODELS[model].spec, "model"),
        describe(FlowSpec, "flow"),
        describe(OutputSpec, "output"),
    ]
    if MPI.COMM_WORLD.rank == 0:
        print("\n\n".join(parts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
