"""branch.png: the bifurcation diagram of a followed path, from the rows of history.csv.

The load factor against the centre deflection ``w_center`` (a free plate's: its ``height``,
max y₃ − min y₃, its centre being pinned), one line per branch: solid where
the point is stable (stability index 0), dashed where it is not, and the special points marked
(fold ▲, bifurcation ■). Written by the runner beside history.png when the rows come from the
arclength continuation (:mod:`dgplate.solvers.continuation`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from itertools import groupby, pairwise
from pathlib import Path
from typing import Any

from dgplate.io.images import save_chart

#: Markers of the special points.
MARKERS = {"fold": "^", "bifurcation": "s"}

#: The deflections drawn against λ, the first one the rows hold.
DEFLECTIONS = ("w_center", "height")


def plot_branch(rows: Sequence[Mapping[str, Any]], path: str | Path, title: str = "") -> bool:
    """Draw the rows of a followed path into ``path`` (not collective: call on one rank).

    Args:
        rows: the rows of ``history.csv`` (``load_factor``, a deflection of
            :data:`DEFLECTIONS`, ``stability_index``, ``kind``).
        path: the picture's file.
        title: the picture's title.

    Returns:
        Whether the picture was written: False (nothing written) for rows without a stability
        index or a deflection.
    """
    held = [d for d in DEFLECTIONS if rows and all(d in r for r in rows)]
    if not held or not all("stability_index" in r for r in rows):
        return False
    deflection = held[0]
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    before: list[Mapping[str, Any]] = []  # a switched branch starts at the point it left
    for branch, points in groupby(rows, key=lambda r: r.get("branch", 0)):
        drawn = list(points)
        _draw_branch(ax, before + drawn, f"C{branch}", deflection)
        before = drawn[-1:]
    for kind, marker in MARKERS.items():
        special = [r for r in rows if r.get("kind") == kind]
        if special:
            x, y = [r[deflection] for r in special], [r["load_factor"] for r in special]
            ax.plot(x, y, marker, color="k", ms=7, ls="none", label=kind)
    ax.plot([], [], "-", color="grey", label="stable (index 0)")
    ax.plot([], [], "--", color="grey", label="unstable (index ≥ 1)")
    save_chart(fig, ax, path, (deflection, "load factor λ"), title)
    return True


def _draw_branch(ax: Any, rows: list[Mapping[str, Any]], color: str, deflection: str) -> None:
    """One branch, segment by segment: solid between stable points, dashed otherwise."""
    for a, b in pairwise(rows):
        stable = a["stability_index"] == 0 and b["stability_index"] == 0
        ax.plot(
            [a[deflection], b[deflection]],
            [a["load_factor"], b["load_factor"]],
            "-" if stable else "--",
            color=color,
            marker=".",
        )
