"""angles.png: a run's fold angles over time, from the rows of history.csv.

One line per ``angle_<fold>`` column (the fold angles in degrees of a thermal run's
``model.fold_angles``, e.g. the box's five hinges) against ``time`` (else the step), a dashed
line at 90° and a dotted one where the heat source changes sign (the box's switch from heating
to cooling). Written by the runner beside history.png when the rows hold fold angles.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from itertools import pairwise
from pathlib import Path
from typing import Any

from dgplate.io.images import save_figure

PREFIX = "angle_"


def _number(value: Any) -> float | None:
    """``value`` as a finite float, else None."""
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def switch_time(rows: Sequence[Mapping[str, Any]], axis: str) -> float | None:
    """The first ``axis`` value at which the heat source changes sign (None: it never does)."""
    for a, b in pairwise(rows):
        before, after = _number(a.get("source")), _number(b.get("source"))
        if before is not None and after is not None and before * after < 0:
            return _number(a.get(axis))
    return None


def plot_angles(rows: Sequence[Mapping[str, Any]], path: str | Path, title: str = "") -> bool:
    """Draw the fold angles of the rows into ``path`` (not collective: call on one rank).

    Args:
        rows: the rows of ``history.csv`` (``angle_<fold>`` in degrees, ``time`` or ``step``,
            and ``source`` for the switch).
        path: the picture's file.
        title: the picture's title.

    Returns:
        Whether the picture was written: False (nothing written) for rows without fold angles.
    """
    folds = sorted({key for row in rows for key in row if key.startswith(PREFIX)})
    if not folds:
        return False
    axis = "time" if all(_number(row.get("time")) is not None for row in rows) else "step"
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    for fold in folds:
        points = [(_number(r.get(axis)), _number(r.get(fold))) for r in rows]
        kept = [(x, y) for x, y in points if x is not None and y is not None]
        ax.plot([x for x, _ in kept], [y for _, y in kept], label=fold.removeprefix(PREFIX))
    ax.axhline(90.0, color="grey", ls="--", lw=0.8)
    switch = switch_time(rows, axis)
    if switch is not None:
        ax.axvline(switch, color="grey", ls=":", lw=0.8)
        switched = f"heat switched at {'t =' if axis == 'time' else 'step'} {switch:g}"
        title = f"{title}: {switched}" if title else switched
    ax.set_xlabel("time t" if axis == "time" else "step")
    ax.set_ylabel("fold angle [°]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    return True
