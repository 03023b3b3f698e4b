"""A montage: several pictures (e.g. the final.png of several runs) as one grid of panels."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from dgplate.io.images import save_figure


def _blank_panel(ax: Any, xlabel: str | None, ylabel: str | None) -> None:
    """A montage panel without ticks or frame, with its column and row labels if any."""
    ax.set_xticks([])
    ax.set_yticks([])
    for side in ax.spines.values():
        side.set_visible(False)
    if xlabel is not None:
        ax.set_xlabel(xlabel, fontsize=11)
    if ylabel is not None:
        ax.set_ylabel(ylabel, fontsize=11)


def _show_cropped(ax: Any, image: np.ndarray, crop: tuple[float, float, float, float]) -> None:
    """Draw the (top, bottom, left, right) fractions ``crop`` of ``image`` in ``ax``."""
    top, bottom, left, right = crop
    h, w = image.shape[:2]
    ax.imshow(image[int(top * h) : int(bottom * h), int(left * w) : int(right * w)])


def montage(
    images: Sequence[Sequence[str | Path | None]],
    path: str | Path,
    *,
    captions: Sequence[Sequence[str]] | None = None,
    row_labels: Sequence[str] = (),
    column_labels: Sequence[str] = (),
    title: str = "",
    note: str = "",
    crop: tuple[float, float, float, float] = (0.07, 0.80, 0.05, 0.95),
    comm: MPI.Comm | None = None,
) -> None:
    """Put pictures (e.g. several runs' final.png) into one image, as a grid of panels.

    Rank 0 of ``comm`` only (not collective); written atomically. Needs matplotlib.

    Args:
        images: Rows of PNG paths; ``None`` leaves a panel empty.
        path: The PNG to write.
        captions: A caption above each panel (same shape as ``images``).
        row_labels: A label left of each row.
        column_labels: A label below each column of the last row.
        title: The image's title.
        note: A line of small print at the bottom.
        crop: The part of each picture shown, as fractions (top, bottom, left, right): the
            default drops the title and the colour bar of :func:`dgplate.io.plotting.render_png`.
        comm: Rank 0 of it writes (default ``MPI.COMM_WORLD``).
    """
    if (comm or MPI.COMM_WORLD).rank != 0:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt

    rows, cols = len(images), max((len(row) for row in images), default=0)
    if not rows or not cols:
        raise ValueError("montage needs at least one picture")
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.6 * rows), squeeze=False)
    for i, row in enumerate(images):
        for j in range(cols):
            ax = axes[i][j]
            xlabel = column_labels[j] if i == rows - 1 and j < len(column_labels) else None
            _blank_panel(ax, xlabel, row_labels[i] if j == 0 and i < len(row_labels) else None)
            picture = row[j] if j < len(row) else None
            if picture is None:
                continue
            _show_cropped(ax, mpimg.imread(picture), crop)
            if captions is not None:
                ax.set_title(captions[i][j], fontsize=9)
    if title:
        fig.suptitle(title, fontsize=13)
    import textwrap

    note = textwrap.fill(note, width=int(3.2 * cols * 72 / 5.5))  # about 5.5 pt per character
    room = (0.02 + 0.16 * (note.count("\n") + 1) / (2.6 * rows)) if note else 0.0  # 9 pt lines
    fig.tight_layout(rect=(0, room, 1, 1))
    if note:
        fig.text(0.5, 0.01, note, ha="center", va="bottom", fontsize=9)
    save_figure(fig, path, dpi=110)
