"""history.png: how a run went, step by step, from the rows of history.csv.

One panel per quantity that the rows hold: the energy E_h (with the continuation parameter α
or the load factor on a second axis), the stopping quantity (|ΔE/τ| against the tolerance,
the τ-independent stationarity, or Newton's residual) and the isometry defect D_h, the last
two on log scales. Written by the runner next to final.png (``output.png``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dgplate.io.images import save_figure

#: Columns drawn on the stopping panel, with their labels (log scale, absolute values).
STOPPING = {"rate": "|ΔE/τ|", "stationarity": "stationarity", "residual": "Newton residual"}
#: Columns of a path parameter, drawn on a second axis of the energy panel.
PATH = {"alpha": "α", "load_factor": "load factor"}


def finite(value: Any) -> float | None:
    """``value`` as a float if it is a finite number (not a bool), else None."""
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def _column(rows: Sequence[Mapping[str, Any]], key: str) -> tuple[list[float], list[float]]:
    """(steps, values) of the rows whose ``key`` is a finite number."""
    steps, values = [], []
    for row in rows:
        value = finite(row.get(key))
        if value is not None:
            steps.append(float(row["step"]))
            values.append(value)
    return steps, values


def _positive(steps: list[float], values: list[float]) -> tuple[list[float], list[float]]:
    """The points a log scale can show: |value| > 0."""
    kept = [(s, abs(v)) for s, v in zip(steps, values, strict=True) if v != 0.0]
    return [s for s, _ in kept], [v for _, v in kept]


def plot_history(
    rows: Sequence[Mapping[str, Any]],
    path: str | Path,
    title: str = "",
    tol: float | None = None,
    stop: str = "rate",
) -> bool:
    """Draw the rows of history.csv into ``path`` (not collective: call on one rank).

    ``tol`` draws the tolerance of the stopping test ``stop`` (a column of ``STOPPING``) on
    the stopping panel. Returns False (and writes nothing) when the rows hold nothing to draw.
    """
    energy = _column(rows, "energy")
    stopping = {label: _positive(*_column(rows, key)) for key, label in STOPPING.items()}
    stopping = {label: points for label, points in stopping.items() if points[0]}
    defect = _positive(*_column(rows, "defect"))
    panels = [
        name
        for name, points in (("energy", energy[0]), ("stopping", stopping), ("defect", defect[0]))
        if points
    ]
    if not panels:
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(panels), 1, figsize=(6.4, 2.0 + 1.6 * len(panels)), sharex=True)
    axes = [axes] if len(panels) == 1 else list(axes)
    for ax, panel in zip(axes, panels, strict=True):
        if panel == "energy":
            ax.plot(*energy, color="#1f77b4")
            ax.set_ylabel("E_h")
            _path_axis(ax, rows)
        elif panel == "stopping":
            for label, points in stopping.items():
                ax.semilogy(*points, label=label)
            if tol is not None and STOPPING.get(stop) in stopping:
                ax.axhline(tol, color="grey", linestyle="--", linewidth=1, label=f"tol {tol:g}")
            ax.legend(fontsize=8, loc="upper right")
        else:
            ax.semilogy(*defect, color="#d62728")
            ax.set_ylabel("D_h")
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("step")
    if title:
        axes[0].set_title(title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    return True


def _path_axis(ax: Any, rows: Sequence[Mapping[str, Any]]) -> None:
    """α or the load factor on a second axis of the energy panel, if the rows have one."""
    for key, label in PATH.items():
        steps, values = _column(rows, key)
        if steps:
            twin = ax.twinx()
            twin.plot(steps, values, color="#7f7f7f", linestyle=":", linewidth=1.2)
            twin.set_ylabel(label, color="#7f7f7f")
            return
