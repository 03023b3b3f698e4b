"""Exceptions that carry a one-line message for the user.

The CLI turns ``InputError`` into ``dgplate: error: <message>`` on stderr and exit code 2.
"""

from __future__ import annotations

import os
from pathlib import Path


class DgplateError(Exception):
    """Base class of dgplate's own errors."""


class InputError(DgplateError, ValueError):
    """Bad user input: a problem file, a mesh, a parameter. The message names the culprit."""


class UnsupportedVersionError(DgplateError, RuntimeError):
    """The installed DOLFINx is outside the supported range."""


class SolverError(DgplateError, RuntimeError):
    """A solve failed or stalled; the message says why."""


def read_user_text(path: str | os.PathLike[str], what: str) -> str:
    """The text of a file the user named (``what``: "problem file", "mesh file", …).

    A missing file, a directory, an unreadable file and bytes that are not UTF-8 are one-line
    InputErrors naming the file, instead of OSError or UnicodeDecodeError tracebacks.
    """
    file = Path(path)
    if file.is_dir():
        raise InputError(f"{what} {file} is a directory, not a file")
    if not file.is_file():
        raise InputError(f"{what} not found: {file}")
    try:
        return file.read_bytes().decode("utf-8")
    except UnicodeDecodeError as err:
        byte = err.object[err.start]
        raise InputError(
            f"{what} {file} is not UTF-8 text (byte 0x{byte:02x} at offset {err.start})"
        ) from None
    except OSError as err:
        raise InputError(f"cannot read {what} {file}: {err.strerror or err}") from None
