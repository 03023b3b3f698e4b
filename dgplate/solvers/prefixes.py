"""The PETSc options prefixes held by live drivers (a load path, a followed path).

Two live drivers on one prefix would read each other's options: a driver checks its prefix
before it sets options under it, holds it once built, and releases it when destroyed.
"""

from __future__ import annotations

#: Options prefixes of the live drivers: two at once would read each other's options.
_LIVE_PREFIXES: set[str] = set()


def check_prefix(prefix: str) -> None:
    """A ValueError when a live driver holds the PETSc options prefix ``prefix``.

    A driver checks its prefix before it sets options under it, and holds it
    (:func:`hold_prefix`) once it is built.

    Args:
        prefix: the prefix.
    """
    if prefix in _LIVE_PREFIXES:
        raise ValueError(f"PETSc options prefix {prefix!r} is in use by a live driver")


def hold_prefix(prefix: str) -> None:
    """Mark ``prefix`` as held by a live driver until :func:`release_prefix`.

    Args:
        prefix: the prefix.
    """
    _LIVE_PREFIXES.add(prefix)


def release_prefix(prefix: str) -> None:
    """Free a prefix held by :func:`hold_prefix` (nothing if it is not).

    Args:
        prefix: the prefix.
    """
    _LIVE_PREFIXES.discard(prefix)
