"""Read a run's output folder back: its summary, its history, and a table of several runs.

This is what ``dgplate show`` prints and what :func:`dgplate.load_result` reads. It reads
files only (no mesh, no solver), so a glance at many finished or still running runs, e.g.
``dgplate show out`` after a parameter study on a cluster, takes a moment. A folder dgplate
did not write is refused with a one-line ``InputError``; a run that is still going (or was
killed before it wrote its summary) is read from its checkpoint.
"""

from __future__ import annotations

import csv
import io
import json
import math
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dgplate.errors import InputError, read_user_text
from dgplate.io.checkpoint import STATE_FILE, read_state
from dgplate.io.output import CHECKPOINT, MARKER, count_of, is_dgplate_output
from dgplate.io.progress import duration

SUMMARY = "summary.json"
HISTORY = "history.csv"

#: The columns of ``dgplate show``'s table: (title, summary key, format).
COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("problem", "problem", "s"),
    ("model", "model", "s"),
    ("cells", "cells", ","),
    ("dofs", "dofs", ","),
    ("ranks", "ranks", "d"),
    ("steps", "steps", "d"),
    ("status", "status", "s"),
    ("E_h", "energy", ".6e"),
    ("D_h", "isometry_defect", ".3e"),
    ("wall", "wall_time_s", "duration"),
)


def read_summary(folder: str | Path) -> dict[str, Any]:
    """The run's ``summary.json``, with ``status`` and ``folder`` added.

    ``status`` is ``converged``, ``not converged`` or ``interrupted`` (``finished`` for a
    demo's own summary, which has no such flag). A run without a summary, or resumed since
    it wrote one, is read from its checkpoint: the step, E_h and D_h of its last record,
    with ``status`` ``checkpoint only`` or ``resumed`` (``stale = True``: the summary's
    figures are older than the checkpoint's). A run that has not written a checkpoint yet
    is ``started``. Raises ``InputError`` (naming the folder) for a folder dgplate did not
    write.
    """
    path = Path(folder)
    if not path.exists():
        raise InputError(f"{path}: no such output folder")
    if not path.is_dir():
        raise InputError(f"{path} is a file, not an output folder")
    if not is_dgplate_output(path):
        raise InputError(f"{path} is not a dgplate output folder (it has no {MARKER})")
    summary_file, state_file = path / SUMMARY, path / CHECKPOINT / STATE_FILE
    summary: dict[str, Any] = {}
    if summary_file.is_file():
        try:
            data = json.loads(read_user_text(summary_file, "summary"))
        except json.JSONDecodeError as err:
            raise InputError(f"{summary_file}: not valid JSON: {err}") from None
        if not isinstance(data, dict):
            raise InputError(f"{summary_file}: not a dgplate summary")
        summary = data
        summary["status"] = _status(summary)
        if not summary_is_current(path):
            summary["summary_steps"] = summary.get("steps")
            summary |= _from_checkpoint(path, "resumed")  # written after the summary
            summary["stale"] = True
    elif state_file.is_file():
        summary = _from_checkpoint(path, "checkpoint only")
    else:
        summary["status"] = "started"
    summary["folder"] = str(path)
    return summary


def summary_is_current(folder: Path) -> bool:
    """Whether ``folder``'s summary.json describes its last checkpoint (one rank's view).

    It must exist and not be older than the checkpoint: a run resumed since, or a later run
    stopped before it wrote its outputs, leaves an older summary beside a newer checkpoint.
    """
    summary_file, state_file = folder / SUMMARY, folder / CHECKPOINT / STATE_FILE
    if not summary_file.is_file():
        return False
    return not state_file.is_file() or state_file.stat().st_mtime <= summary_file.stat().st_mtime


def runs_in(folders: Sequence[str | Path], depth: int = 3) -> list[Path]:
    """The run folders among ``folders``, in the order given.

    A folder that holds runs in its subfolders (a demo's, a parameter study's ``out/``)
    stands for them, in name order, down to ``depth`` levels; a folder with no run in it
    stands for itself (``read_summary`` then says what it is).
    """
    found: list[Path] = []
    for folder in map(Path, folders):
        found += _runs_below(folder, depth) or [folder]
    return found


def _runs_below(folder: Path, depth: int) -> list[Path]:
    """The run folders at or below ``folder`` ([] for none)."""
    if not folder.is_dir() or folder.name == CHECKPOINT or folder.name.startswith("."):
        return []
    if (folder / SUMMARY).is_file() or (folder / CHECKPOINT / STATE_FILE).is_file():
        return [folder]
    inner: list[Path] = []
    if depth > 0:
        try:
            children = sorted(p for p in folder.iterdir() if p.is_dir())
        except OSError:
            children = []
        inner = [run for child in children for run in _runs_below(child, depth - 1)]
    return inner or ([folder] if is_dgplate_output(folder) else [])


def _status(summary: dict[str, Any]) -> str:
    if summary.get("interrupted"):
        return "interrupted"
    if "converged" not in summary:
        return "finished"
    return outcome(summary)


def outcome(summary: Mapping[str, Any]) -> str:
    """How a finished run ended, in words: a path ended or stopped, a flow converged or not.

    A path's summary is the one that counts its ``points``.

    Args:
        summary: the run's ``summary.json`` (with ``converged``).

    Returns:
        ``path ended``, ``path stopped``, ``converged`` or ``not converged``.
    """
    if "points" in summary:
        return "path ended" if summary["converged"] else "path stopped"
    return "converged" if summary["converged"] else "not converged"


def checkpoint_state(folder: Path) -> dict[str, Any]:
    """The JSON state of the checkpoint in ``folder`` (step, history, fingerprint, …)."""
    file = folder / CHECKPOINT / STATE_FILE
    if not file.is_file():
        raise InputError(f"{folder} holds neither {SUMMARY} nor a checkpoint")
    try:
        state = read_state(file)
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
        raise InputError(f"cannot read the checkpoint in {folder}: {err}") from None
    if not isinstance(state, dict):
        raise InputError(f"the checkpoint in {folder} is not a dgplate checkpoint")
    return state


def _from_checkpoint(folder: Path, status: str) -> dict[str, Any]:
    """What a summary would say, from the checkpoint of a run without a current one."""
    state = checkpoint_state(folder)
    history = state.get("history") or [{}]
    last = history[-1] if isinstance(history[-1], dict) else {}
    label = state.get("label")
    label = label if isinstance(label, dict) else {}
    return {
        **label,  # problem, model, cells, dofs, ranks
        "steps": state.get("step"),
        "status": status,
        "energy": last.get("energy"),
        "isometry_defect": last.get("defect"),
    }


def read_history(folder: str | Path) -> list[dict[str, Any]]:
    """The rows of ``history.csv`` as dicts of numbers (empty cells are None).

    A run without a history file yet gives the history its checkpoint holds, or [].
    """
    path = Path(folder)
    file = path / HISTORY
    if not file.is_file():
        try:
            return list(checkpoint_state(path).get("history", []))
        except InputError:
            return []
    reader = csv.DictReader(io.StringIO(read_user_text(file, "history")))
    return [{key: _number(value) for key, value in row.items()} for row in reader]


def _number(text: str | None) -> Any:
    """A CSV cell as the value it was written from: int, float, bool, None or text."""
    if text is None or text == "":
        return None
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def _cell(value: Any, form: str) -> str:
    if value is None:
        return "—"
    if form == "duration":
        return duration(float(value))
    if isinstance(value, bool) or not isinstance(value, int | float) or form == "s":
        return str(value)
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    try:
        return format(value, form)
    except ValueError:  # e.g. a float where an int was expected
        return str(value)


def table(summaries: Sequence[dict[str, Any]]) -> str:
    """The runs as a plain-text table, one row each: folder, problem, …, E_h, D_h, wall time.

    Columns that no run has (D_h of FvK runs, say) are left out. A folder that could not be
    read (its ``error`` says why) is a row with status ``unreadable [k]`` and its reason in
    note k below the table, so that a long message does not widen the table.
    """
    errors = [s for s in summaries if s.get("error")]
    notes = {id(s): k for k, s in enumerate(errors, start=1)}
    summaries = [
        s | {"status": f"unreadable [{notes[id(s)]}]"} if id(s) in notes else s for s in summaries
    ]
    columns = [("folder", "folder", "s")]
    columns += [c for c in COLUMNS if any(s.get(c[1]) is not None for s in summaries)]
    rows = [[title for title, _, _ in columns]]
    rows += [[_cell(_shown(s, key), form) for _, key, form in columns] for s in summaries]
    widths = [max(len(row[i]) for row in rows) for i in range(len(columns))]
    numeric = [form not in ("s",) for _, _, form in columns]
    lines = []
    for row in rows:
        cells = [
            text.rjust(width) if right else text.ljust(width)
            for text, width, right in zip(row, widths, numeric, strict=True)
        ]
        lines.append("  ".join(cells).rstrip())
    for k, summary in enumerate(errors, start=1):
        error, folder = str(summary["error"]), str(summary["folder"])
        lines.append(f"[{k}] " + (error if error.startswith(folder) else f"{folder}: {error}"))
    return "\n".join(lines)


def _shown(summary: dict[str, Any], key: str) -> Any:
    """A summary's value for the table; a resumed run's wall time is not yet known."""
    return None if key == "wall_time_s" and summary.get("stale") else summary.get(key)


def details(summary: dict[str, Any]) -> str:
    """One run in words: what it solved, how it ended, and every figure of its summary."""
    head = f"{summary['folder']}: {summary.get('problem', '?')} ({summary.get('model', '?')})"
    for key, text in (
        ("cells", ", {:,} cells"),
        ("dofs", ", {:,} dofs"),
        ("ranks", " on {} rank(s)"),
    ):
        if isinstance(summary.get(key), int):
            head += text.format(summary[key])
    status, steps = summary.get("status", "?"), summary.get("steps")
    if status == "started":
        ending = f"started: no {SUMMARY} and no checkpoint yet"
    elif status == "checkpoint only":
        ending = f"no {SUMMARY} yet (running, or stopped): checkpoint at step {steps}"
    elif status == "resumed":
        ending = (
            f"resumed after its {SUMMARY} (step {summary.get('summary_steps')}), running or "
            f"stopped: checkpoint at step {steps}"
        )
    else:
        ending = status + (f" after {count_of(steps, 'step')}" if isinstance(steps, int) else "")
    if isinstance(summary.get("wall_time_s"), int | float) and not summary.get("stale"):
        ending += f" in {duration(float(summary['wall_time_s']))}"
    reason = summary.get("reason") if not summary.get("stale") else None
    lines = [head, f"  {ending}" + (f": {reason}" if reason else "")]
    skip = {"folder", "status", "reason", "problem", "model", "cells", "dofs", "ranks", "steps"}
    skip |= {"input", "converged", "interrupted", "wall_time_s", "stale", "summary_steps"}
    shown = {key: _figure(value) for key, value in summary.items() if key not in skip}
    figures = {key: text for key, text in shown.items() if text is not None}
    width = max((len(key) for key in figures), default=0)
    lines += [f"  {key.ljust(width)}  {text}" for key, text in figures.items()]
    return "\n".join(lines)


#: Lists of numbers up to this long are shown whole by :func:`details` (a path's folds,
#: bifurcations); longer ones (every point's load factor) are left to the files.
SHORT_LIST = 8


def _figure(value: Any) -> str | None:
    """A summary value as :func:`details` shows it: a number, a word, a short list of numbers.

    Returns:
        The text, or None for what is not shown (tables, long lists).
    """
    if isinstance(value, float):
        return f"{value:.10g}"
    if value is None or isinstance(value, str | int):
        return str(value)
    numbers = isinstance(value, list) and all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in value
    )
    if numbers and len(value) <= SHORT_LIST:
        return "[" + ", ".join(f"{v:.10g}" for v in value) + "]"
    return None
