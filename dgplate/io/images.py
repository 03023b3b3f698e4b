"""Picture files: written atomically, rendered off-screen with pyvista, joined into a GIF.

A picture is written under a temporary name and moved into place, so a reader never sees half a
file. ``start_offscreen`` makes rendering possible without a display; ``offscreen_png`` is a
pyvista plotter whose picture goes to a file; ``save_figure`` writes a matplotlib figure;
``frames_to_gif`` makes an animation (rank 0 only).
"""

from __future__ import annotations

import atexit
import ctypes
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from mpi4py import MPI

import pyvista


@contextmanager
def _plain_text() -> Iterator[None]:
    """Render all text with FreeType.

    Render all text with FreeType: VTK hands strings containing '|' to matplotlib's
    mathtext, which reads '|' as a table-cell separator and drops it ("|D²y|" → "D²y").
    """
    from vtkmodules.vtkRenderingCore import vtkTextRenderer

    renderer = vtkTextRenderer.GetInstance()
    if renderer is None:
        yield
        return
    previous = renderer.GetDefaultBackend()
    renderer.SetDefaultBackend(vtkTextRenderer.FreeType)
    try:
        yield
    finally:
        renderer.SetDefaultBackend(previous)


def start_offscreen() -> None:
    """Make off-screen rendering possible without a display; call before ``pyvista.Plotter``.

    VTK wheels have an EGL window: use it directly (saves an X probe and a warning). X-only VTK
    builds (Debian's) need a virtual X server: start Xvfb when it is installed
    (:func:`start_xvfb`), otherwise fail with a clear message instead of letting VTK abort the
    process. Does nothing when a display is set; safe to call more than once.

    Raises:
        RuntimeError: No display, no EGL and no Xvfb.
    """
    if os.environ.get("DISPLAY") or "VTK_DEFAULT_OPENGL_WINDOW" in os.environ:
        return
    from vtkmodules import vtkRenderingOpenGL2

    if hasattr(vtkRenderingOpenGL2, "vtkEGLRenderWindow"):
        os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
        return
    if shutil.which("Xvfb") is None:
        raise RuntimeError(
            "off-screen rendering needs a display: this VTK has no EGL support and Xvfb is not "
            "installed (apt install xvfb), or set output.png = false"
        )
    start_xvfb()


def _end_with_parent() -> None:
    """In the child before exec: SIGTERM when the parent ends, however it ends (Linux)."""
    ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def start_xvfb(timeout: float = 10.0) -> str:
    """Start a virtual X server for this process and its children; it ends with this process.

    Xvfb runs with ``-noreset``: by default it resets itself whenever its last client
    disconnects, and a client that connects during the reset is dropped. VTK then aborts the
    process ("bad X server connection"). Processes that each open and close a render window
    hit that window: 12–67 of 1,200 connections (1–6 %) failed in four such processes against
    Xvfb's defaults, none with ``-noreset`` (in the test's 600: 2–26 % against none).
    (pyvista's ``start_xvfb``, which recent pyvista no longer has, does not pass the flag and
    always takes display :99.) The server is stopped at exit, and on Linux also when this
    process ends otherwise (a second Ctrl-C, SIGKILL, MPI_Abort).

    Args:
        timeout: seconds to wait for the server to say its display.

    Returns:
        The display, e.g. ``":99"``; also set as ``DISPLAY``.

    Raises:
        RuntimeError: The server did not come up in ``timeout`` seconds.
    """
    read_end, write_end = os.pipe()
    screen = ["-screen", "0", "1280x1024x24", "-nolisten", "tcp", "-noreset"]
    try:
        server = subprocess.Popen(  # -displayfd: the server picks a free display and says it
            ["Xvfb", "-displayfd", str(write_end), *screen],
            pass_fds=(write_end,),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,  # a Ctrl-C meant for the run does not stop its pictures
            preexec_fn=_end_with_parent if sys.platform == "linux" else None,
        )
    except BaseException:
        os.close(read_end)
        raise
    finally:
        os.close(write_end)
    atexit.register(server.terminate)
    with os.fdopen(read_end) as answer:
        ready, _, _ = select.select([answer], [], [], timeout)
        number = answer.readline().strip() if ready else ""
    if not number.isdigit():
        server.terminate()
        raise RuntimeError(f"Xvfb did not start in {timeout:g} s (exit code {server.wait(5)})")
    display = f":{number}"
    os.environ["DISPLAY"] = display
    return display


def _publish(tmp: str, path: Path) -> None:
    """Move a finished temporary file into place with the usual permissions (mkstemp: 0600)."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o666 & ~mask)
    os.replace(tmp, path)


def save_chart(fig: Any, ax: Any, path: str | Path, labels: tuple[str, str], title: str) -> None:
    """Finish a one-panel chart (axis labels, grid, legend, title) and save it at 100 dpi.

    Args:
        fig: the matplotlib figure.
        ax: its one axes.
        path: the picture's file (written atomically, :func:`save_figure`).
        labels: the x and y axis labels.
        title: the title ('' for none).
    """
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)


def save_figure(fig: Any, path: str | Path, dpi: int = 110) -> None:
    """Write a matplotlib figure to the PNG ``path`` atomically, then close it."""
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=".png", dir=path.parent)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=dpi, format="png")
        _publish(tmp, path)
    finally:
        plt.close(fig)
        if os.path.exists(tmp):
            os.unlink(tmp)


@contextmanager
def offscreen_png(path: str | Path, window_size: tuple[int, int]) -> Iterator[Any]:
    """An off-screen pyvista plotter whose picture goes to ``path`` when the block ends.

    The PNG is written under a temporary name and moved into place, so a reader never sees
    half a file; nothing is written if the block raises.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    start_offscreen()
    plotter = pyvista.Plotter(off_screen=True, window_size=list(window_size))
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=".png", dir=path.parent)
    os.close(fd)
    try:
        yield plotter
        with _plain_text():
            plotter.screenshot(tmp)
        _publish(tmp, path)
    finally:
        plotter.close()
        if os.path.exists(tmp):
            os.unlink(tmp)


def frames_to_gif(
    pngs: Sequence[str | Path],
    gif_path: str | Path,
    fps: float = 10.0,
    comm: MPI.Comm | None = None,
) -> None:
    """Assemble PNG frames into a looping GIF (rank 0 of ``comm`` only; written atomically)."""
    if (comm or MPI.COMM_WORLD).rank != 0:
        return
    from PIL import Image

    if not pngs:
        raise ValueError("frames_to_gif needs at least one frame")
    frames = [Image.open(p).convert("RGB") for p in pngs]
    palette = [f.quantize(colors=256, method=Image.Quantize.MEDIANCUT) for f in frames]
    gif_path = Path(gif_path)
    gif_path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{gif_path.stem}-", suffix=".gif", dir=gif_path.parent)
    os.close(fd)
    try:
        palette[0].save(
            tmp, save_all=True, append_images=palette[1:], duration=round(1000 / fps), loop=0
        )
        _publish(tmp, gif_path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
