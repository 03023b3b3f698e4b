"""Run outputs: the output folder, history.csv and summary.json (progress: :mod:`.progress`).

Results are written into a staging folder inside the output folder and moved into place at
the end, so an output folder is never half-written: bad input creates nothing, and a failed,
stalled or interrupted solve still leaves a complete record of what it computed (with
``converged = false``). A folder is reused only if dgplate wrote it (its marker file), and
files dgplate did not write are never deleted. File writes happen on rank 0; every decision is
taken on rank 0 and broadcast, so that all ranks raise the same error or none.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from mpi4py import MPI

import numpy as np

from dgplate import mpi
from dgplate.errors import InputError

if TYPE_CHECKING:
    from dgplate.compat import Function


def print0(comm: MPI.Comm, *args: object, file: TextIO | None = None) -> None:
    """Print on rank 0 only, flushed (progress on long runs).

    A closed pipe (``dgplate run … | head``) ends the printing, not the run: the stream
    goes to the null device from there on (see :func:`printing_ends_on_closed_pipe`).
    """
    if comm.rank == 0:
        stream = file or sys.stdout
        try:
            print(*args, file=stream, flush=True)
        except BrokenPipeError:
            silence(stream)


def silence(stream: TextIO) -> None:
    """Send what is still written to ``stream`` (whose reader went away) to the null device.

    Also what Python flushes at exit, which would otherwise report the closed pipe again.
    """
    os.dup2(os.open(os.devnull, os.O_WRONLY), stream.fileno())


@contextmanager
def printing_ends_on_closed_pipe() -> Iterator[None]:
    """While active, a write to a closed pipe raises ``BrokenPipeError`` (no signal).

    PETSc installs a SIGPIPE handler that aborts the process (Python ignores SIGPIPE): the
    reader of a run's output going away (``dgplate run … | head``) would end the run and
    leave its outputs half-written. Ignored, a write fails instead, and :func:`print0` then
    stops printing while the run goes on. Python's own disposition is restored afterwards.
    Outside the main thread (where signals cannot be set) it does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGPIPE, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGPIPE, previous)


MARKER = ".dgplate-output"
"""The file that marks a folder as written by dgplate: it may be replaced by a later run."""
CHECKPOINT = "checkpoint"
_STAGING = ".staging-"


def _decide(comm: MPI.Comm, check: Callable[[], str | None]) -> None:
    """Run ``check`` on rank 0 and raise its message as an ``InputError`` on every rank.

    File-system checks then give the same answer on every rank (no rank waits in a collective
    for one that raised), whatever each rank's view of a shared file system.
    """
    message = None
    if comm.rank == 0:
        try:
            message = check()
        except OSError as err:
            message = f"output directory: {err.strerror or err}: {err.filename}"
    message = comm.bcast(message, root=0)
    if message:
        raise InputError(message)


def is_dgplate_output(path: Path) -> bool:
    """True for a folder that a dgplate run wrote (it holds the marker file)."""
    return (path / MARKER).is_file()


def target_problem(
    target: Path, force: bool = False, resume: bool = False, key: str = "--out"
) -> str | None:
    """Why ``target`` cannot receive a run's outputs (None when it can). Reads, never writes.

    A missing or empty folder, or a previous dgplate output, may be used; any other folder
    holds a user's files and is refused unless ``force`` (dgplate then adds its files and
    deletes none of the others); a file is always refused. ``resume`` needs a checkpoint.
    ``key`` begins the messages: how the user named the folder (``--out``, ``output.dir``).
    """
    unusable = _not_a_folder(target, key)
    if unusable:
        return unusable
    if resume:
        if not is_dgplate_output(target):
            return f"--resume: {target} is not a dgplate output directory"
        if not (target / CHECKPOINT / "state.npz").is_file():
            return f"--resume: {target} holds no checkpoint (set flow.checkpoint_every)"
        return None
    if target.is_dir() and any(target.iterdir()) and not is_dgplate_output(target) and not force:
        return (
            f"{key} {target} is a non-empty folder that dgplate did not write; "
            "choose another or pass --force (force=True from Python; dgplate then adds its files "
            "and deletes none)"
        )
    parent = target
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        return f"{key} {target}: {parent} is a file, not a directory"
    if not os.access(parent, os.W_OK | os.X_OK):
        return f"{key} {target}: no permission to write in {parent}"
    return None if target.exists() else _no_storage(key, target, parent)


def _no_storage(key: str, target: Path, parent: Path) -> str | None:
    """Why no folder can be made in ``parent`` (None: one can).

    A read-only file system, or one without storage: a kernel's pseudo file system such as
    /proc, where even root makes no folders.
    """
    try:
        stats = os.statvfs(parent)
    except OSError:
        return None
    if stats.f_flag & os.ST_RDONLY:
        return f"{key} {target}: {parent} is on a read-only file system"
    if stats.f_blocks == 0:
        return f"{key} {target}: {parent} is on a file system that stores no folders (as /proc)"
    return None


def _not_a_folder(target: Path, key: str) -> str | None:
    """Why ``target`` (or its ``checkpoint``) cannot be a folder: a file, a broken link."""
    if target.is_symlink() and not target.exists():
        return f"{key} {target} is a link to {os.readlink(target)}, which does not exist"
    if target.exists() and not target.is_dir():
        return f"{key} {target} is a file, not a directory"
    kept = target / CHECKPOINT
    if (kept.exists() or kept.is_symlink()) and not kept.is_dir():
        return f"{key} {target}: {kept} is a file; dgplate keeps its checkpoints in that name"
    return None


def write_marker(
    folder: Path, files: list[str], inside: dict[str, list[str]] | None = None
) -> None:
    """Mark ``folder`` as dgplate's, listing the ``files`` a later run may replace (rank 0).

    ``inside``: for each of those that is a folder, the files in it (relative paths) that
    dgplate wrote; a later run replaces such a folder only if it holds nothing else.
    """
    record = {"written_by": "dgplate", "files": sorted(files), "inside": inside or {}}
    tmp = folder / f"{MARKER}.tmp"
    tmp.write_text(json.dumps(record, indent=1) + "\n")
    os.replace(tmp, folder / MARKER)


class OutputDir:
    """An output folder whose results appear together, at ``commit()``.

    Collective. ``check`` (done first, on every rank, before anything is written) refuses a
    file, a folder of a user's files (unless ``force``) and, with ``resume``, a folder without
    a checkpoint; the constructor then creates the folder with dgplate's marker and a staging
    folder inside it, where the results are written. ``commit()`` moves them in (summary.json
    last, so that a complete summary means a complete output) and removes what an earlier
    dgplate run wrote there and this one did not; files dgplate did not write are never
    deleted. Checkpoints are written straight into ``checkpoint/``, where a killed run leaves
    them for ``--resume``.
    """

    def __init__(
        self, comm: MPI.Comm, target: Path, force: bool = False, resume: bool = False
    ) -> None:
        self.comm, self.target = comm, Path(target).absolute()
        self.check(comm, self.target, force, resume)
        staging: list[str] = []
        _decide(comm, lambda: self._create(staging))
        self.path = Path(comm.bcast(staging[0] if staging else None, root=0))
        self.checkpoint_dir = self.target / CHECKPOINT

    def _create(self, staging: list[str]) -> None:
        """Make the folder, its checkpoint folder, the marker and the staging folder (rank 0).

        The marker comes after what can fail (a folder that cannot be made, e.g. no space or
        no permission): a folder of a user's refused that way is not left marked as dgplate's.
        """
        self.target.mkdir(parents=True, exist_ok=True)
        (self.target / CHECKPOINT).mkdir(exist_ok=True)
        staging.append(tempfile.mkdtemp(prefix=_STAGING, dir=self.target))
        os.chmod(staging[0], 0o755)  # mkdtemp makes it private; outputs are for everyone
        if is_dgplate_output(self.target):
            for stale in self.target.glob(f"{_STAGING}*"):  # left by a killed run of ours
                if stale.name != Path(staging[0]).name:
                    shutil.rmtree(stale, ignore_errors=True)
        else:
            self._write_marker([])

    @staticmethod
    def check(
        comm: MPI.Comm, target: Path, force: bool = False, resume: bool = False, key: str = "--out"
    ) -> None:
        """Raise ``InputError`` (on every rank) if ``target`` may not receive outputs.

        ``key``: how the user named the folder, which begins the message.
        """
        _decide(comm, lambda: target_problem(Path(target).absolute(), force, resume, key))

    def _write_marker(self, files: list[str], inside: dict[str, list[str]] | None = None) -> None:
        write_marker(self.target, files, inside)

    def _previous(self) -> tuple[list[str], dict[str, list[str]] | None]:
        """The names the marker lists as dgplate's, and the files in those that are folders.

        None for the second: a marker of an older dgplate, which did not describe folders.
        """
        try:
            record = json.loads((self.target / MARKER).read_text())
            inside = record.get("inside")
            return list(record.get("files", [])), None if inside is None else dict(inside)
        except (OSError, ValueError, AttributeError, TypeError):
            return [], {}

    def commit(self) -> Path:
        """Move the staged results into the folder (collective); returns the folder.

        What an earlier dgplate run wrote is replaced or removed. Anything else in the way —
        a user's file where an output goes, or a folder of dgplate's into which a user has
        put files — is renamed ``<name>.kept-<k>`` (with a warning), never deleted.
        """
        self.comm.barrier()
        if self.comm.rank == 0:
            new = sorted(p.name for p in self.path.iterdir())
            previous, inside = self._previous()
            ours = {name for name in previous if _still_ours(self.target / name, inside)}
            for name in sorted(set(previous) - set(new) - {CHECKPOINT}):
                if name in ours:  # an earlier run's output that this one does not replace
                    _remove(self.target / name)
            for name in sorted(new, key=lambda n: n == "summary.json"):
                dest = self.target / name
                if name in ours:
                    _remove(dest)
                elif dest.exists() or dest.is_symlink():
                    _keep_aside(dest)
                os.replace(self.path / name, dest)
            written = {n: _files_in(self.target / n) for n in new if (self.target / n).is_dir()}
            self._write_marker([*new, CHECKPOINT], written)
            self.path.rmdir()
        self.comm.barrier()
        return self.target

    def discard(self) -> None:
        """Remove the staged results (an aborted run); the folder keeps its checkpoints.

        Not collective: an error on one rank must not wait for the others (they may be in
        a collective of the run); rank 0 removes, another rank's error leaves the staging
        folder, which the next run into this folder removes.
        """
        if self.comm.rank == 0:
            shutil.rmtree(self.path, ignore_errors=True)


def _files_in(folder: Path) -> list[str]:
    """Everything below ``folder`` (files, folders, links), as sorted relative paths."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def _still_ours(path: Path, inside: dict[str, list[str]] | None) -> bool:
    """Whether ``path``, listed in the marker, still holds only what dgplate wrote there.

    A name dgplate wrote as a file must still be a file (not a user's folder put in its
    place), a folder must still be a folder holding no file the marker does not list.
    ``inside`` None (an older marker, which did not describe folders): the name counts as
    dgplate's as it is.
    """
    if inside is None or not (path.exists() or path.is_symlink()):
        return True
    if path.name not in inside:  # written as a file
        return not path.is_dir() or path.is_symlink()
    if not path.is_dir() or path.is_symlink():
        return False
    known = set(inside[path.name])
    return all(name in known for name in _files_in(path))


def _keep_aside(path: Path) -> None:
    """Rename a user's ``path`` that an output would replace to ``<name>.kept-<k>``."""
    k = 1
    while (aside := path.with_name(f"{path.name}.kept-{k}")).exists() or aside.is_symlink():
        k += 1
    os.replace(path, aside)
    print(
        f"dgplate: warning: {path} was not written by dgplate (or holds files it did not "
        f"write): kept as {aside.name}",
        file=sys.stderr,
        flush=True,
    )


def count_of(n: int, noun: str) -> str:
    """``1 step``, ``2 steps``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def _remove(path: Path) -> None:
    """Remove a file, a link or a folder with its contents."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


def write_json(comm: MPI.Comm, path: Path, data: dict[str, Any]) -> None:
    """Write ``data`` as indented JSON, atomically, on rank 0 (NumPy values as plain ones)."""
    if comm.rank == 0:
        tmp = path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(_jsonable(data), indent=2) + "\n")
        os.replace(tmp, path)


def _jsonable(value: object) -> object:
    """``value`` with NumPy arrays and scalars as lists and numbers, and inf/NaN as strings."""
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


def write_history(comm: MPI.Comm, path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    """history.csv: one row per step (rank 0); the columns are the keys of the rows."""
    if comm.rank != 0:
        return
    columns = list(dict.fromkeys(key for row in rows for key in row))
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)


def bounding_box(y: Function) -> list[list[float]]:
    """[[xmin, ymin, zmin], [xmax, ymax, zmax]] of the deformed surface (nodal values)."""
    space = y.function_space
    owned = space.dofmap.index_map.size_local
    lo, hi = mpi.bounding_box(space.mesh.comm, y.x.array.reshape(-1, 3)[:owned])
    return [lo.tolist(), hi.tolist()]
