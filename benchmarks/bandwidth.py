"""Memory bandwidth of this machine on 1 and on 2 ranks at once: the ceiling of the 1 → 2-rank
speed-up for phases bound by memory traffic (the substitutions with the LDLᵀ factors).

Each rank streams through arrays much larger than the caches, STREAM-style: a read-only sum
(what a substitution does with the factors: read each entry once) and a triad a = b + s·c.
On 2 ranks both do it at the same time, so the aggregate is what the two cores share.

    python benchmarks/bandwidth.py --json benchmarks/results/bandwidth.json

Run it without mpirun: it launches ``mpirun -n 1`` and ``mpirun -n 2`` itself.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from dgplate.io.output import write_json

MB = 1024**2


def child(megabytes: int, repeat: int, out: Path) -> None:
    """Time the kernels on every rank at once; rank 0 writes the aggregate GB/s (best of repeat)."""
    comm = MPI.COMM_WORLD
    n = megabytes * MB // 8
    a, b, c = np.ones(n), np.full(n, 2.0), np.full(n, 3.0)
    kernels = {
        "read": (lambda: float(np.add.reduce(b)), 8 * n),
        "triad": (lambda: np.add(b, np.multiply(c, 3.0, out=a), out=a), 5 * 8 * n),
    }
    record: dict = {"ranks": comm.size, "megabytes_per_array": megabytes}
    for name, (kernel, nbytes) in kernels.items():
        best = float("inf")
        for _ in range(repeat):
            comm.Barrier()
            start = time.perf_counter()
            kernel()
            elapsed = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
            best = min(best, elapsed)
        record[f"{name}_gb_per_s"] = comm.size * nbytes / best / 1e9
    write_json(comm, out, record)


def run(ranks: int, megabytes: int, repeat: int) -> dict:
    """Launch :func:`child` on ``ranks`` ranks in a fresh process."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "record.json"
        mpirun = shutil.which("mpirun", path=str(Path(sys.executable).parent)) or "mpirun"
        script = [mpirun, "-n", str(ranks), sys.executable, "-m", "mpi4py", __file__, "--child"]
        script += ["--megabytes", str(megabytes), "--repeat", str(repeat), "--json", str(out)]
        subprocess.run(script, check=True, env=os.environ.copy())
        record: dict = json.loads(out.read_text())
        return record


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--megabytes", type=int, default=512, help="per array and rank")
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        child(args.megabytes, args.repeat, args.json)
        return
    one, two = (run(ranks, args.megabytes, args.repeat) for ranks in (1, 2))
    record = {
        "one_rank": one,
        "two_ranks": two,
        "ratio_two_over_one": {
            key: two[key] / one[key] for key in one if key.endswith("_gb_per_s")
        },
    }
    print(json.dumps(record, indent=2))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        write_json(MPI.COMM_SELF, args.json, record)


if __name__ == "__main__":
    main(sys.argv[1:])
