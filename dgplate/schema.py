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
import tomllib
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


@dataclasses.dataclass(frozen=True)
class Check:
    """Constraints of a key beyond its type, checked by :func:`from_dict` and documented.

    Bounds (``ge``, ``gt``, ``le``, ``lt``) apply to numbers (a string of a union such as
    ``float | Literal["h"]`` passes them), ``choices`` to any value, ``length`` and
    ``nonzero`` (not all entries zero) to a list, and ``each`` to every entry of a list or
    value of a table.
    """

    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None
    choices: tuple[Any, ...] | None = None
    length: int | None = None
    nonzero: bool = False
    each: Check | None = None
    note: str = ""  # appended to a message about a value in ``retired``
    retired: tuple[Any, ...] = ()

    def validate(self, value: object, key: str) -> None:
        """Raise ``InputError`` (one line naming ``key``) if ``value`` breaks a constraint."""
        broken = self._broken(value)
        if broken:
            note = f" ({self.note})" if value in self.retired else ""
            raise InputError(f"{key} must {broken}, got {value!r}{note}")
        if self.each is not None:
            for where, entry in _entries(value, key):
                self.each.validate(entry, where)

    def _broken(self, value: object) -> str:
        """The constraint ``value`` breaks (``be >= 1``, ``have 3 entries``), or ''."""
        if self.choices is not None and value not in self.choices:
            return f"be one of {_listed(self.choices)}"
        if is_number(value) and not self._within(value):
            return f"be {self._bounds()}"
        if isinstance(value, list) and self.length is not None and len(value) != self.length:
            return f"have {self.length} entries"
        if isinstance(value, list) and self.nonzero and not any(value):
            return "not be the zero vector"
        return ""

    def _within(self, value: float) -> bool:
        return not (
            (self.ge is not None and value < self.ge)
            or (self.gt is not None and value <= self.gt)
            or (self.le is not None and value > self.le)
            or (self.lt is not None and value >= self.lt)
        )

    def _bounds(self) -> str:
        """``>= 1``, ``> 0``, or with two bounds an interval: ``in [1, 3]``, ``in (0, 1]``."""
        low = (">=", self.ge) if self.ge is not None else (">", self.gt)
        high = ("<=", self.le) if self.le is not None else ("<", self.lt)
        if low[1] is not None and high[1] is not None:
            left = "[" if low[0] == ">=" else "("
            right = "]" if high[0] == "<=" else ")"
            return f"in {left}{low[1]:g}, {high[1]:g}{right}"
        op, bound = low if low[1] is not None else high
        return f"{op} {bound:g}"

    def describe(self) -> str:
        """The constraints as documented: ``one of: a, b``, ``>= 1``, ``3 entries, each > 0``."""
        parts = []
        if self.choices is not None:
            parts.append(f"one of: {_listed(self.choices)}")
        if any(b is not None for b in (self.ge, self.gt, self.le, self.lt)):
            parts.append(self._bounds())
        if self.length is not None:
            parts.append(f"{self.length} entries")
        if self.nonzero:
            parts.append("not all 0")
        if self.each is not None and self.each.describe():
            parts.append(f"each {self.each.describe()}")
        return ", ".join(parts)


def _listed(choices: Collection[Any]) -> str:
    """Choices as listed in messages and docs: ``lagged, direct``; ``true, false``."""
    return ", ".join(_toml(c) if isinstance(c, bool) else str(c) for c in choices)


def _entries(value: object, key: str) -> list[tuple[str, object]]:
    """The entries of a list (``key[i]``) or the values of a table (``key.name``)."""
    if isinstance(value, list):
        return [(f"{key}[{i}]", v) for i, v in enumerate(value)]
    if isinstance(value, dict):
        return [(f"{key}.{k}", v) for k, v in value.items()]
    return []


def option(default: Any, doc: str, shown: str = "", **constraints: Any) -> Any:
    """A dataclass field with a default (copied if mutable), a documentation string and checks.

    Args:
        default: the value of a key the problem does not give (a list, table or spec
            dataclass is copied for each instance); :data:`REQUIRED` for a required key.
        doc: what the key means, as printed by ``dgplate schema``.
        shown: the default as documented, when the value is no TOML (e.g. None: not given).
        constraints: the keyword arguments of :class:`Check` (``ge=1``, ``choices=(...)``,
            ``each=Check(gt=0)``, …), checked by :func:`from_dict` and shown in the docs.

    Returns:
        ``Any``, like :func:`dataclasses.field`, so that a field of any type may take it.
    """
    metadata = {"doc": doc, "check": Check(**constraints), "shown": shown}
    if default is REQUIRED:
        return dataclasses.field(metadata=metadata)
    if isinstance(default, list | dict) or dataclasses.is_dataclass(default):
        return dataclasses.field(default_factory=lambda: copy.deepcopy(default), metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


#: The default of a key that must be given (:func:`option`).
REQUIRED: Any = object()


def section(spec: type, name: str) -> Any:
    """A field of a [model] spec that holds a driver's settings, given in their own section.

    :func:`from_dict` builds it from the problem's table ``[name]`` (not from a key of the
    model's table), e.g. FvK's ``[newton]``.

    Args:
        spec: the section's spec dataclass.
        name: the section's name in problem files.

    Returns:
        The field, defaulting to ``spec()``.
    """
    return dataclasses.field(default_factory=spec, metadata={"section": name})


def _field_of(cls: type, name: str) -> str:
    """The field of a [model] spec that holds the section ``name``."""
    return next(f.name for f in dataclasses.fields(cls) if f.metadata.get("section") == name)


def driver_sections(cls: type) -> list[tuple[str, type]]:
    """The sections of a [model] spec's drivers: ``(name, spec dataclass)`` (:func:`section`)."""
    hints = typing.get_type_hints(cls)
    return [
        (f.metadata["section"], hints[f.name])
        for f in dataclasses.fields(cls)
        if "section" in f.metadata
    ]


def _type_name(tp: Any) -> str:
    """A field type as named in messages: ``float or str``, ``list``, ``none``, ``'h'``."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_type_name(a) for a in typing.get_args(tp))
    if origin is typing.Literal:
        return " or ".join(repr(a) for a in typing.get_args(tp))
    if dataclasses.is_dataclass(tp):
        return "a table"
    name = str((tp if origin is None else origin).__name__)
    return "none" if name == "NoneType" else name


def _matches(value: object, tp: Any) -> bool:
    """Whether ``value`` fits the type ``tp`` on its surface.

    An int passes for a float, a bool not; a table for a spec dataclass. The entries of lists
    and tables are checked by :func:`_value`.
    """
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        return any(_matches(value, arg) for arg in typing.get_args(tp))
    if origin is typing.Literal:
        return any(value == a and type(value) is type(a) for a in typing.get_args(tp))
    if tp is Any:
        return True
    if tp is type(None):
        return value is None
    if dataclasses.is_dataclass(tp):
        return isinstance(value, dict)
    if origin is not None:
        tp = origin
    if tp is float:
        return is_number(value)
    if tp is int:
        return is_integer(value)
    return isinstance(value, tp)


def _branch(value: object, tp: Any) -> Any:
    """The member of a union that ``value`` fits (the first one); ``tp`` itself otherwise."""
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        return next(arg for arg in typing.get_args(tp) if _matches(value, arg))
    return tp


def _value(value: object, tp: Any, key: str, base: Any = None) -> Any:
    """``value`` checked against the type ``tp``, entries too.

    A table of a spec dataclass is parsed by :func:`from_dict` (keys it leaves out take the
    values of ``base``, the field's default instance); an int for a float becomes a float.
    ``InputError`` names ``key`` (``key[i]``, ``key.name``).
    """
    if not _matches(value, tp):
        raise InputError(f"{key} must be {_type_name(tp)}, got {value!r} ({type(value).__name__})")
    tp = _branch(value, tp)
    if tp is float:
        if not math.isfinite(value):  # type: ignore[arg-type]
            raise InputError(f"{key} must be a finite number, got {value!r}")
        return float(value)  # type: ignore[arg-type]
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        return from_dict(tp, value, key, base)
    args = typing.get_args(tp)
    origin = typing.get_origin(tp)
    if origin is list and args and isinstance(value, list):
        return [_value(v, args[0], where) for where, v in _entries(value, key)]
    if origin is dict and len(args) == 2 and isinstance(value, dict):
        return {k: _value(v, args[1], f"{key}.{k}") for k, v in value.items()}
    return value


def from_dict(
    cls: type[T],
    data: object,
    section: str,
    base: T | None = None,
    problem: Mapping[str, Any] | None = None,
) -> T:
    """Build ``cls`` from a problem-file table, checking keys, types and constraints.

    Fields whose type is a spec dataclass are parsed recursively from their tables (dotted
    keys in messages: ``model.penalty.gamma0``); for ``Spec | None`` an empty table is None.

    Args:
        cls: the spec dataclass (its fields made by :func:`option`).
        data: the table (None: every default).
        section: the dotted key of the table, as named in messages.
        base: an instance whose values the keys left out take (default: the fields' defaults).
        problem: the whole problem, whose sections fill the fields made by :func:`section`.

    Returns:
        The spec. What involves several keys its ``__post_init__`` checks, or, in a spec that
        may be nested (whose messages need the table's key), its method ``validate(key)``.
    """
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError(f"[{section}] must be a table, got {data!r}")
    fields = {f.name: f for f in dataclasses.fields(cls) if "section" not in f.metadata}
    hints = typing.get_type_hints(cls)
    _check_keys(cls, data, section)
    values = {name: getattr(base, name) for name in fields} if base is not None else {}
    for name, settings in driver_sections(cls):
        values[_field_of(cls, name)] = from_dict(settings, (problem or {}).get(name), name)
    for name, f in fields.items():
        if name not in data and name not in values and _required(f):
            raise InputError(f"{section}.{name} is required")
    for key, value in data.items():
        where = f"{section}.{key}"
        if value == {} and _optional_spec(hints[key]):
            values[key] = None
            continue
        default = _default(fields[key])
        nested = default if dataclasses.is_dataclass(default) else None
        values[key] = _value(value, hints[key], where, nested)
        fields[key].metadata.get("check", Check()).validate(value, where)
    spec = cls(**values)
    validate = getattr(spec, "validate", None)
    if validate is not None:
        validate(section)
    return spec


def _check_keys(cls: type, data: dict[str, Any], section: str) -> None:
    """Every key of ``data`` must be a field of ``cls``, and one its ``type`` takes.

    A spec with variants (``type = 'plane'``, ``'sphere'``, …) names in a class attribute
    ``TYPE_KEYS`` the keys that only some types take: ``{type: (its own keys)}``. A key that
    moved to another section is named in a class attribute ``MOVED``: ``{key: new dotted key}``.
    """
    fields = [f.name for f in dataclasses.fields(cls) if "section" not in f.metadata]
    moved: dict[str, str] = getattr(cls, "MOVED", {})
    for key in data:
        if key in moved:
            raise InputError(f"{section}.{key} moved to {moved[key]}")
        if key not in fields:
            raise InputError(
                f"unknown key {section}.{key} (known keys: {', '.join(sorted(fields))})"
            )
    variants: dict[str, tuple[str, ...]] = getattr(cls, "TYPE_KEYS", {})
    kind = data.get("type")
    if not (isinstance(kind, str) and kind in variants):
        return
    others = {key for keys in variants.values() for key in keys} - set(variants[kind])
    known = [name for name in fields if name not in others]
    for key in data:
        if key in others:
            raise InputError(
                f"unknown key {section}.{key} for type '{kind}' (known: {', '.join(known)})"
            )


def _required(f: dataclasses.Field[Any]) -> bool:
    return f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING


def _optional_spec(tp: Any) -> bool:
    """``Spec | None``: a spec dataclass that an empty table leaves out."""
    args = typing.get_args(tp)
    return type(None) in args and any(dataclasses.is_dataclass(a) for a in args)


def _spec_of(tp: Any) -> type | None:
    """The spec dataclass of a field type (``Spec`` or ``Spec | None``), else None."""
    for arg in (tp, *typing.get_args(tp)):
        if dataclasses.is_dataclass(arg) and isinstance(arg, type):
            return arg
    return None


def options(cls: type, prefix: str = "", given: object = None) -> list[tuple[str, str, str]]:
    """``(key, default as TOML, documentation)`` of each key of a spec dataclass.

    One source for ``dgplate schema`` and the documentation site's problem-file reference.
    The documentation ends with the constraints, e.g. ``(one of: lagged, direct)``. A nested
    spec is given by its keys, dotted (``penalty.gamma0``), with the defaults of the instance
    ``given`` by the outer spec; an optional one (``Spec | None``) by a row ``{}`` first.
    """
    rows = []
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if "section" in f.metadata:
            continue
        default = _default(f) if given is None else getattr(given, f.name)
        doc = str(f.metadata.get("doc", ""))
        constraints = f.metadata.get("check", Check()).describe()
        doc = f"{doc} ({constraints})" if constraints else doc
        nested = _spec_of(hints[f.name])
        given_spec = nested is not None and isinstance(default, nested)
        if not given_spec:  # a key, or a nested spec that is not always there: a row
            shown = "{}" if nested is not None and default is None else _toml(default)
            rows.append((prefix + f.name, f.metadata.get("shown") or shown, doc))
        if nested is not None:
            rows += options(nested, f"{prefix}{f.name}.", default if given_spec else None)
    return rows


def _default(f: dataclasses.Field[Any]) -> Any:
    """A field's default (:data:`REQUIRED` for a required key)."""
    if _required(f):
        return REQUIRED
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return f.default


def describe(
    cls: type, section: str, skip: Collection[str] = (), defaults: Mapping[str, Any] | None = None
) -> str:
    """The section's keys, defaults and documentation, as commented TOML (but ``skip``).

    The keys of a nested spec that is not there by default (``obstacle = {}``,
    ``boundary_data = "flat"``) and defaults that are no TOML value (``(required)``) are
    commented out: the output is a valid problem file. ``defaults``: a model's own defaults
    of some keys, shown instead of the spec's.
    """
    lines, defaults = [f"[{section}]"], defaults or {}
    rows = options(cls)
    given = {key for key, _, _ in rows}
    for key, default, doc in rows:
        if key.split(".")[0] in skip:
            continue
        if key in defaults:
            default = _toml(defaults[key])
        lines.append(f"# {doc}")
        commented = ("." in key and key.rsplit(".", 1)[0] in given) or not _is_toml(default)
        lines.append(f"{'# ' if commented else ''}{key} = {default}")
    return "\n".join(lines)


def _is_toml(text: str) -> bool:
    """Whether ``text`` is a TOML value (a default shown as text, e.g. ``(required)``, is not)."""
    try:
        tomllib.loads(f"v = {text}")
    except tomllib.TOMLDecodeError:
        return False
    return True


def _toml(value: object) -> str:
    """A default value as written in TOML (None, an automatic choice, as ``"auto"``)."""
    if value is REQUIRED:
        return "(required)"
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
