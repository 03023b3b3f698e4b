"""The virtual X server for X-only VTK builds (dgplate/io/images.py: ``start_xvfb``)."""

import os
import shutil
import subprocess
import sys

import pytest

from dgplate.io.images import start_xvfb

# Each process opens and closes the display 150 times, as a process drawing pictures does.
_OPEN_AND_CLOSE = """
import ctypes
x11 = ctypes.CDLL("libX11.so.6")
x11.XOpenDisplay.restype = ctypes.c_void_p
x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
failed = 0
for _ in range(150):
    display = x11.XOpenDisplay(None)
    if display:
        x11.XCloseDisplay(display)
    else:
        failed += 1
print(failed)
"""


@pytest.mark.skipif(shutil.which("Xvfb") is None, reason="needs Xvfb (apt install xvfb)")
def test_the_virtual_display_keeps_every_connection_of_processes_that_open_and_close_it(
    monkeypatch,
):
    """Against Xvfb's defaults (it resets when its last client leaves) 2–26 % of these fail."""
    monkeypatch.setenv("DISPLAY", "")  # recorded, so that the server's display is undone
    monkeypatch.delenv("DISPLAY")
    display = start_xvfb()
    assert os.environ["DISPLAY"] == display
    children = [
        subprocess.Popen([sys.executable, "-c", _OPEN_AND_CLOSE], stdout=subprocess.PIPE, text=True)
        for _ in range(4)
    ]
    assert [int(child.communicate()[0]) for child in children] == [0, 0, 0, 0]
