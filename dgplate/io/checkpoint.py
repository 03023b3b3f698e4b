"""Checkpoints that a run can resume from, on the same or another number of ranks.

A checkpoint is one ``.npz`` file holding, for every saved function, a table with one row per
cell of the mesh, in the mesh's original (input) cell order, of the values of that cell's
unknowns; and, as JSON, the driver's counters, its history so far and the fingerprint of the
problem it solves. The mesh is rebuilt from the problem file, so the original cell index and
the cell's local unknown name every value independently of the partition: a run checkpointed
on 1 rank resumes on 2. Unknowns shared between cells (continuous spaces) appear in each of
their cells' rows, with equal values.

Why not adios4dolfinx: its releases follow DOLFINx minor versions one to one and it needs
ADIOS2's Python bindings, which neither the PyPI DOLFINx wheel nor Debian 13 provides; the
per-cell table needs nothing beyond NumPy and is all that resuming a run takes (the mesh is
not stored: it is a function of the problem file).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from dgplate.errors import InputError

if TYPE_CHECKING:
    from dgplate.compat import Function, FunctionSpace

STATE_FILE = "state.npz"
#: In the .npz file: the driver's JSON state, and the table of each function by name.
_STATE_KEY = "__state__"
_FIELD_PREFIX = "field_"


def _field_key(name: str) -> str:
    """The key of the table of the function ``name`` in the .npz file."""
    return f"{_FIELD_PREFIX}{name}"


def _field_name(key: str) -> str | None:
    """The function name whose table a key of the .npz file holds; None: not a table."""
    return key.removeprefix(_FIELD_PREFIX) if key.startswith(_FIELD_PREFIX) else None


#: The key of a gmsh mesh file's SHA-256 in a problem's :func:`identity`.
MESH_FILE_HASH = "mesh_file_sha256"


def identity(data: Mapping[str, Any]) -> dict[str, Any]:
    """The part of a problem's validated input that decides its states step by step.

    Everything but [output] and the step budget keys (``flow.max_steps``, ``path.steps``): a
    resumed run may change where and how often it writes, or extend its budget, nothing else.
    """
    relevant = {k: v for k, v in data.items() if k != "output"}
    flow = dict(relevant.get("flow", {}))
    for key in ("max_steps", "checkpoint_every"):
        flow.pop(key, None)
    relevant["flow"] = flow
    if isinstance(relevant.get("path"), Mapping):
        relevant["path"] = {k: v for k, v in relevant["path"].items() if k != "steps"}
    return relevant


def fingerprint(data: Mapping[str, Any]) -> str:
    """A hash of :func:`identity`: two problems with the same one compute the same states."""
    text = json.dumps(identity(data), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def differences(old: Any, new: Any, prefix: str = "") -> list[str]:
    """The dotted keys at which two problem inputs differ, with both values (1 and 1.0 agree)."""
    if isinstance(old, Mapping) and isinstance(new, Mapping):
        found: list[str] = []
        for key in sorted(set(old) | set(new)):
            missing = "(not set)"
            a, b = old.get(key, missing), new.get(key, missing)
            found += differences(a, b, f"{prefix}.{key}" if prefix else str(key))
        return found
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        if not any(differences(a, b) for a, b in zip(old, new, strict=True)):
            return []
    elif old == new:  # numbers compare by value
        return []
    if prefix == MESH_FILE_HASH:
        return ["the mesh file's text"]
    return [f"{prefix} (checkpoint: {old!r}, now: {new!r})"]


def _cell_layout(
    space: FunctionSpace, ghosts: bool = False
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Original indices of the owned cells and their unknowns' positions in ``x.array``.

    With ``ghosts``, the ghost cells too, where the mesh records their original indices.
    """
    mesh = space.mesh
    cells = mesh.topology.index_map(mesh.topology.dim)
    count = cells.size_local
    if ghosts and len(mesh.topology.original_cell_index) >= count + cells.num_ghosts:
        count += cells.num_ghosts
    bs = space.dofmap.index_map_bs
    dofs = np.asarray(space.dofmap.list[:count], dtype=np.int64)
    rows = (dofs[:, :, None] * bs + np.arange(bs)).reshape(count, -1)
    original = np.asarray(mesh.topology.original_cell_index[:count], dtype=np.int64)
    return original, rows


def gather_cells(function: Function) -> npt.NDArray[np.float64] | None:
    """The per-cell table of ``function`` on rank 0 (None elsewhere). Collective."""
    space = function.function_space
    comm = space.mesh.comm
    original, rows = _cell_layout(space)
    parts = comm.gather((original, function.x.array[rows]), root=0)
    if parts is None:  # not rank 0
        return None
    cells = sum(len(o) for o, _ in parts)
    table = np.zeros((cells, rows.shape[1]), dtype=function.x.array.dtype)
    for index, values in parts:
        table[index] = values
    return table


def scatter_cells(function: Function, table: npt.NDArray[np.float64], name: str) -> None:
    """Set ``function`` from a per-cell table (on every rank) and update its ghosts.

    Ghost cells are set too: an unknown shared between cells (a continuous space) may be
    owned here but lie in no cell owned here, only in ghost cells (DOLFINx 0.9 does that).
    """
    original, rows = _cell_layout(function.function_space, ghosts=True)
    if table.shape[1] != rows.shape[1] or (len(original) and original.max() >= len(table)):
        raise InputError(
            f"checkpoint field {name!r} does not fit this problem's mesh or space "
            f"({table.shape} against {rows.shape[1]} unknowns per cell)"
        )
    function.x.array[rows] = table[original]
    function.x.scatter_forward()


@dataclass
class Checkpoint:
    """What a checkpoint holds: per-cell tables of functions and the driver's JSON state."""

    tables: dict[str, npt.NDArray[np.float64]]
    state: dict[str, Any]

    def restore(self, functions: Mapping[str, Function]) -> None:
        """Set each named function from its table (collective only in the ghost update)."""
        for name, function in functions.items():
            if name not in self.tables:
                raise InputError(f"the checkpoint holds no field {name!r}")
            scatter_cells(function, self.tables[name], name)


def save(
    directory: Path,
    comm: MPI.Comm,
    functions: Mapping[str, Function],
    state: Mapping[str, Any],
) -> None:
    """Write a checkpoint atomically (a temporary file renamed): collective.

    A run killed while writing keeps its previous checkpoint.
    """
    tables = {name: gather_cells(f) for name, f in functions.items()}
    if comm.rank != 0:
        return
    directory.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()
    meta = np.frombuffer(json.dumps(dict(state), default=_plain).encode(), dtype=np.uint8)
    arrays: dict[str, npt.NDArray[Any]] = {_STATE_KEY: meta}
    arrays.update({_field_key(name): t for name, t in tables.items() if t is not None})
    np.savez(buffer, **arrays)  # type: ignore[arg-type]  # keys are array names, not options
    tmp = directory / f".{STATE_FILE}.tmp"
    with open(tmp, "wb") as handle:
        handle.write(buffer.getvalue())
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, directory / STATE_FILE)


def load(
    directory: Path,
    comm: MPI.Comm,
    expected: Mapping[str, Any] | None = None,
    purpose: str = "--resume",
) -> Checkpoint:
    """Read the checkpoint (rank 0 reads, every rank gets it); refuse another problem's.

    ``purpose`` begins the error messages: what the checkpoint was read for. A file that
    cannot be read, or is damaged (truncated, overwritten, not a dgplate checkpoint), is an
    InputError naming it on every rank: rank 0 alone reads, so no error may stay there.
    """
    data, message = None, None
    if comm.rank == 0:
        file = directory / STATE_FILE
        try:
            data = _read(file)
        except OSError as err:  # missing, unreadable: the file is not at fault
            message = f"{purpose}: cannot read the checkpoint {file}: {err.strerror or err}"
        except Exception as err:  # anything np.load, zipfile or json raise on bad bytes
            message = (
                f"{purpose}: the checkpoint {file} is damaged (truncated or not written by "
                f"dgplate): {type(err).__name__}: {err}"
            )
    data, message = comm.bcast((data, message), root=0)
    if message:
        raise InputError(message)
    assert isinstance(data, Checkpoint)
    if expected is not None and not _same_problem(data.state, expected):
        written = data.state.get("input")
        changed = differences(identity(written), identity(expected)) if written is not None else []
        which = f": {'; '.join(changed[:3])}" if changed else ""
        raise InputError(
            f"{purpose}: the checkpoint in {directory} belongs to another problem{which} "
            "(only [output], flow.max_steps, flow.checkpoint_every and path.steps may change)"
        )
    return data


def _same_problem(state: Mapping[str, Any], expected: Mapping[str, Any]) -> bool:
    """Whether the checkpoint's fingerprint is that of ``expected``.

    The input a checkpoint holds is fingerprinted again, so that a key :func:`identity` has
    come to leave out (``path.steps``) does not refuse it. A checkpoint of an older dgplate
    (no ``input`` in its state) hashed no mesh file: it is compared without the file's hash,
    so that it still resumes.
    """
    found = state.get("fingerprint")
    if found == fingerprint(expected):
        return True
    if isinstance(state.get("input"), Mapping):
        return fingerprint(state["input"]) == fingerprint(expected)
    older = {k: v for k, v in identity(expected).items() if k != MESH_FILE_HASH}
    return "input" not in state and found == fingerprint(older)


#: The first bytes of a .npz file (a zip archive's local file header).
_ZIP_MAGIC = b"PK\x03\x04"


def _archive(path: Path) -> Any:
    """``np.load(path)`` of a zip archive; ValueError for other bytes.

    NumPy takes bytes that are neither a zip archive nor a .npy file for a pickle and refuses
    them with advice about ``allow_pickle``, which would mislead: the file is damaged.
    """
    with path.open("rb") as handle:
        if handle.read(len(_ZIP_MAGIC)) != _ZIP_MAGIC:
            raise ValueError("it is not a .npz (zip) archive")
    return np.load(path)


def read_state(path: Path) -> Any:
    """The JSON state of the checkpoint in the .npz file ``path``, without its tables."""
    with _archive(path) as npz:
        return json.loads(bytes(npz[_STATE_KEY]).decode())


def _read(path: Path) -> Checkpoint:
    """The checkpoint in the .npz file ``path`` (on one rank).

    Raises what NumPy, zipfile and json raise on a damaged file, and ValueError where what
    they read is not a checkpoint's content.
    """
    with _archive(path) as npz:
        names = {key: _field_name(key) for key in npz.files}
        tables = {name: npz[key] for key, name in names.items() if name is not None}
    state = read_state(path)
    if not isinstance(state, dict):
        raise ValueError(f"its state is a JSON {type(state).__name__}, not an object")
    for name, table in tables.items():
        if table.ndim != 2 or table.dtype.kind not in "fc":
            raise ValueError(f"field {name!r} is not a table of numbers ({table.shape})")
    return Checkpoint(tables, state)


def _plain(value: object) -> object:
    """A NumPy value as the plain Python value JSON can write (json.dumps' ``default``)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
