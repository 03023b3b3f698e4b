"""angles.png: a run's fold angles over time, from the rows of history.csv.

One line per ``angle_<hinge>`` column (the fold angles in degrees of a thermal run's
``model.hinges``, e.g. the box's five) against ``time`` (else the step), a dashed line at 90°
and a dotted one where the heat source changes sign (the box's switch from heating to
cooling). Written by the runner beside history.png when the rows hold fold angles.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dgplate.io.history_chart import finite
from dgplate.io.images import save_chart

PREFIX = "angle_"


def switch_time(rows: Sequence[Mapping[str, Any]], axis: str) -> float | None:
    """Where the heat source changes sign: heating to cooling, say.

    Args:
        rows: the rows of ``history.csv`` (``source``, and ``axis``).
        axis: the column to return: ``time`` or ``step``.

    Returns:
        The ``axis`` value of the last row with a non-zero source before the first row whose
        source has the other sign (rows with a zero or no source are passed over); None if the
        sign never changes.
    """
    last: tuple[float, Mapping[str, Any]] | None = None
    for row in rows:
        source = finite(row.get("source"))
        if source is None or source == 0.0:
            continue
        if last is not None and last[0] * source < 0:
            return finite(last[1].get(axis))
        last = (source, row)
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
    axis = "time" if all(finite(row.get("time")) is not None for row in rows) else "step"
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    for fold in folds:
        points = [(finite(r.get(axis)), finite(r.get(fold))) for r in rows]
        kept = [(x, y) for x, y in points if x is not None and y is not None]
        ax.plot([x for x, _ in kept], [y for _, y in kept], label=fold.removeprefix(PREFIX))
    ax.axhline(90.0, color="grey", ls="--", lw=0.8)
    switch = switch_time(rows, axis)
    if switch is not None:
        ax.axvline(switch, color="grey", ls=":", lw=0.8)
        switched = f"heat switched at {'t =' if axis == 'time' else 'step'} {switch:g}"
        title = f"{title}: {switched}" if title else switched
    save_chart(fig, ax, path, ("time t" if axis == "time" else "step", "fold angle [°]"), title)
    return True
