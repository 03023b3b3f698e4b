"""Exceptions that carry a one-line message for the user.

The CLI turns ``InputError`` into ``dgplate: error: <message>`` on stderr and exit code 2.
"""


class DgplateError(Exception):
    """Base class of dgplate's own errors."""


class InputError(DgplateError, ValueError):
    """Bad user input: a problem file, a mesh, a parameter. The message names the culprit."""


class UnsupportedVersionError(DgplateError, RuntimeError):
    """The installed DOLFINx is outside the supported range."""


class SolverError(DgplateError, RuntimeError):
    """A solve failed or stalled; the message says why."""
