"""Run outputs: staged output directory, progress, history.csv and summary.json.

Files are written into a staging directory next to the target and moved into place at the end,
so an output directory is never half-written: bad input creates nothing, and a failed solve
still leaves a complete record of what it computed (with ``converged = false``). File writes
happen on rank 0; everything collective runs on all ranks.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import sys
import tempfile
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from dgplate.flow import FlowResult, GradientFlow, StepInfo


def print0(comm: MPI.Comm, *args, **kwargs) -> None:
    """Print on rank 0 only, flushed (progress on long runs)."""
    if comm.rank == 0:
        print(*args, **kwargs, flush=True)


class OutputDir:
    """A staging directory that becomes ``target`` on ``commit()``."""

    def __init__(self, comm: MPI.Comm, target: Path):
        self.comm, self.target = comm, Path(target).resolve()
        staging = None
        if comm.rank == 0:
            self.target.parent.mkdir(parents=True, exist_ok=True)
            staging = tempfile.mkdtemp(
                prefix=f".{self.target.name}.partial-", dir=self.target.parent
            )
            os.chmod(staging, 0o755)  # mkdtemp makes it private; outputs are for everyone
        self.path = Path(comm.bcast(staging, root=0))

    def commit(self) -> Path:
        self.comm.barrier()
        if self.comm.rank == 0:
            if self.target.exists():
                shutil.rmtree(self.target)
            os.replace(self.path, self.target)
        self.comm.barrier()
        return self.target

    def discard(self) -> None:
        self.comm.barrier()
        if self.comm.rank == 0:
            shutil.rmtree(self.path, ignore_errors=True)


def write_json(comm: MPI.Comm, path: Path, data: dict[str, Any]) -> None:
    if comm.rank == 0:
        tmp = path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(_jsonable(data), indent=2) + "\n")
        os.replace(tmp, path)


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return str(value)
    return value


class ProgressPrinter:
    """Rank-0 progress lines: step, pseudo-time, τ, energy, defect, decrease rate, time/step."""

    def __init__(self, comm: MPI.Comm, every: int = 1, stream=None):
        self.comm, self.every, self.stream = comm, every, stream or sys.stdout

    def step(self, flow: GradientFlow, info: StepInfo) -> None:
        if self.every and info.step % self.every == 0:
            print0(
                self.comm,
                f"step {info.step:5d}  t = {info.time:9.4f}  τ = {info.tau:.3e}  "
                f"E_h = {info.energy:+.6e}  D_h = {info.defect:.3e}  "
                f"ΔE/τ = {info.rate:.2e}  {info.seconds:.2f} s/step",
                file=self.stream,
            )

    def finish(self, flow: GradientFlow, result: FlowResult) -> None:
        status = "converged" if result.converged else "NOT converged"
        print0(
            self.comm,
            f"flow {status} after {result.steps} steps: {result.reason}",
            file=self.stream,
        )
        if result.energy_increases:
            print0(
                self.comm,
                f"warning: the energy increased at step(s) {result.energy_increases[:10]}",
                file=self.stream,
            )


HISTORY_COLUMNS = [f.name for f in fields(StepInfo)]


def write_history(
    comm: MPI.Comm, path: Path, rows: list[StepInfo], extra: list[dict] | None = None
) -> None:
    """history.csv: one row per step (columns of StepInfo plus model-specific ones)."""
    if comm.rank != 0:
        return
    extra = extra or [{} for _ in rows]
    columns = HISTORY_COLUMNS + sorted({k for row in extra for k in row})
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns)
        writer.writeheader()
        for info, more in zip(rows, extra):
            writer.writerow({**asdict(info), **more})


def bounding_box(y) -> list[list[float]]:
    """[[xmin, ymin, zmin], [xmax, ymax, zmax]] of the deformed surface (nodal values)."""
    space = y.function_space
    owned = space.dofmap.index_map.size_local
    values = y.x.array.reshape(-1, 3)[:owned]
    comm = space.mesh.comm
    lo = values.min(axis=0) if owned else np.full(3, np.inf)
    hi = values.max(axis=0) if owned else np.full(3, -np.inf)
    glo, ghi = np.empty(3), np.empty(3)
    comm.Allreduce(np.ascontiguousarray(lo, dtype=float), glo, op=MPI.MIN)  # element-wise
    comm.Allreduce(np.ascontiguousarray(hi, dtype=float), ghi, op=MPI.MAX)
    return [list(map(float, glo)), list(map(float, ghi))]
