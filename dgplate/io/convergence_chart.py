"""The log–log chart of a convergence study: each figure's distance from its limit vs DoFs."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dgplate.io.plotting import save_figure

#: The most figures drawn (the first in the study's order); the JSON holds them all.
MOST_LINES = 12


def plot_convergence(
    dofs: Sequence[int], lines: Mapping[str, Sequence[float]], path: str | Path, title: str = ""
) -> bool:
    """Draw |f_level − f∞| against the DoFs of each level into ``path`` (one rank only).

    Args:
        dofs: the DoFs of the levels, coarse first.
        lines: per figure, its distance |f_level − f∞| on each level.
        path: the PNG to write.
        title: the chart's title.

    Returns:
        False (and nothing written) when no figure has a positive distance to draw.
    """
    drawn: dict[str, tuple[list[float], list[float]]] = {}
    for name, errors in lines.items():
        kept = [(float(n), float(e)) for n, e in zip(dofs, errors, strict=True) if e > 0]
        if len(kept) >= 2 and len(drawn) < MOST_LINES:
            drawn[name] = ([n for n, _ in kept], [e for _, e in kept])
    if not drawn:
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9.0, 4.8))
    for name, (x, y) in drawn.items():
        ax.loglog(x, y, marker="o", label=name)
    _slopes(ax, drawn)
    ax.set_xlabel("degrees of freedom")
    ax.set_ylabel("|f_level − f∞|")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small", loc="center left", bbox_to_anchor=(1.02, 0.5))
    fig.tight_layout()
    save_figure(fig, path)
    return True


def _slopes(ax: Any, drawn: Mapping[str, tuple[list[float], list[float]]]) -> None:
    """Reference slopes −1/2 and −1 (h¹ and h² on a plate) through the first point."""
    x, y = next(iter(drawn.values()))
    for power, label in ((0.5, "slope −1/2"), (1.0, "slope −1")):
        ax.loglog(
            [x[0], x[-1]],
            [y[0], y[0] * (x[-1] / x[0]) ** -power],
            color="grey",
            linestyle=":",
            linewidth=1,
            label=label,
        )
