"""Validated dataclasses for problem-file sections.

Each section of a problem file is a dataclass whose fields carry a default and a ``doc``
string. :func:`from_dict` rejects unknown keys and wrong types with a one-line
``InputError`` that names the dotted key; :func:`describe` prints the documented defaults
(``dgplate schema``).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import types
import typing
from collections.abc import Collection, Mapping
from typing import TYPE_CHECKING, Any, TypeGuard, TypeVar

from dgplate.errors import InputError

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

T = TypeVar("T", bound="DataclassInstance")


def is_number(value: object) -> TypeGuard[int | float]:
    """True for an int or a float, but not a bool (TOML's ``true`` is no number)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def is_integer(value: object) -> TypeGuard[int]:
    """True for an int, but not a bool."""
    return isinstance(value, int) and not isinstance(value, bool)


def is_matrix(value: object, rows: int, cols: int) -> TypeGuard[list[list[object]]]:
    """True for a list of ``rows`` lists of ``cols`` entries each (a matrix in TOML)."""
    return (
        isinstance(value, list)
        and len(value) == rows
        and all(isinstance(row, list) and len(row) == cols for row in value)
    )


def option(default: Any, doc: str) -> Any:
    """A dataclass field with a default (copied if mutable) and a documentation string.

    Returns ``Any`` like :func:`dataclasses.field`, so that a field of any type may take it.
    """
    if isinstance(default, list | dict):
        return dataclasses.field(
            default_factory=lambda: copy.deepcopy(default), metadata={"doc": doc}
        )
    return dataclasses.field(default=default, metadata={"doc": doc})


def _type_name(tp: Any) -> str:
    """A field type as named in messages: ``float or str``, ``list``, ``none``."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_type_name(a) for a in typing.get_args(tp))
    name = str((tp if origin is None else origin).__name__)
    return "none" if name == "NoneType" else name


def _matches(value: object, tp: Any) -> bool:
    """Whether ``value`` fits the field type ``tp`` (an int passes for a float, a bool not)."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        return any(_matches(value, arg) for arg in typing.get_args(tp))
    if tp is Any:
        return True
    if tp is type(None):
        return value is None
    if origin is not None:
        tp = origin
    if tp is float:
        return is_number(value)
    if tp is int:
        return is_integer(value)
    return isinstance(value, tp)


def from_dict(cls: type[T], data: object, section: str) -> T:
    """Build ``cls`` from a problem-file table, checking keys and types."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError(f"[{section}] must be a table, got {data!r}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = typing.get_type_hints(cls)
    for key in data:
        if key not in fields:
            known = ", ".join(sorted(fields))
            raise InputError(f"unknown key {section}.{key} (known keys: {known})")
    values = {}
    for key, value in data.items():
        if not _matches(value, hints[key]):
            raise InputError(
                f"{section}.{key} must be {_type_name(hints[key])}, got {value!r} "
                f"({type(value).__name__})"
            )
        if isinstance(value, float) and typing.get_origin(hints[key]) is None:
            value = float(value)
        values[key] = value
    return cls(**values)


def options(cls: type) -> list[tuple[str, str, str]]:
    """``(key, default as TOML, documentation)`` of each key of a spec dataclass.

    One source for ``dgplate schema`` and the documentation site's problem-file reference.
    """
    rows = []
    for f in dataclasses.fields(cls):
        default = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
        rows.append((f.name, _toml(default), str(f.metadata.get("doc", ""))))
    return rows


def describe(
    cls: type, section: str, skip: Collection[str] = (), defaults: Mapping[str, Any] | None = None
) -> str:
    """The section's keys, defaults and documentation, as commented TOML (but ``skip``).

    ``defaults``: a model's own defaults of some keys, shown instead of the spec's.
    """
    lines, defaults = [f"[{section}]"], defaults or {}
    for key, default, doc in options(cls):
        if key in skip:
            continue
        lines.append(f"# {doc}")
        lines.append(f"{key} = {_toml(defaults[key]) if key in defaults else default}")
    return "\n".join(lines)


def _toml(value: object) -> str:
    """A default value as written in TOML (None, an automatic choice, as ``"auto"``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if value is None:
        return '"auto"'
    return repr(value)


#: Integers in problem files end up in C ints (mesh sizes, PETSc options): larger ones are
#: refused here rather than as an OverflowError deep inside DOLFINx or PETSc.
INT_MAX = 2**31 - 1


def require_finite(value: object, key: str) -> None:
    """Every number in ``value`` (nested tables and lists) must be finite and fit a C int.

    One check for the whole input instead of one per key: NaN and ±inf (TOML's ``nan``,
    ``inf``) would otherwise reach the forms. The message names the dotted key, e.g.
    ``model.load[2]``.
    """
    if isinstance(value, dict):
        for name, entry in value.items():
            require_finite(entry, f"{key}.{name}")
    elif isinstance(value, list | tuple):
        for i, entry in enumerate(value):
            require_finite(entry, f"{key}[{i}]")
    elif isinstance(value, float) and not math.isfinite(value):
        raise InputError(f"{key} must be a finite number, got {value!r}")
    elif is_integer(value) and abs(value) > INT_MAX:
        raise InputError(f"{key} must be at most {INT_MAX} in magnitude, got {value}")
