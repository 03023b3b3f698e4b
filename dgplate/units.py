"""Physical quantities of problem files: numbers in SI units, or strings with units.

A value is a number, taken in SI units (metres, pascals, 1/K, K), or a string that the units
library pint reads, such as ``"150 um"``, ``"2 GPa"``, ``"1.2e-3 1/K"`` or ``"40 delta_degC"``.
:func:`si` converts it to the SI number of the expected kind; a string that is no quantity,
or one of another kind (``"2 GPa"`` for a length), is a one-line ``InputError`` naming the key.
pint is imported on first use: problems without physical quantities do not load it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

from dgplate.errors import InputError


@dataclass(frozen=True)
class Kind:
    """A kind of quantity: its SI unit (as pint spells it), its name and an example."""

    unit: str
    name: str
    example: str


KINDS = {
    "length": Kind("m", "a length", "150 um"),
    "modulus": Kind("Pa", "a pressure (a modulus)", "2 GPa"),
    "strain": Kind("", "dimensionless (a strain)", "0.01"),
    "expansion": Kind("1/K", "an inverse temperature (an expansion coefficient)", "1.2e-3 1/K"),
    # a temperature *difference*: "40 degC" (an absolute temperature) is refused, "40 K" and
    # "40 delta_degC" are 40 K
    "temperature_change": Kind("delta_degC", "a temperature difference", "40 K"),
}


@functools.cache
def _registry() -> Any:
    import pint

    return pint.UnitRegistry()


def si(value: float | str, kind: str, key: str) -> float:
    """``value`` as a number in the SI unit of ``kind`` (``KINDS``).

    Args:
        value: a number (already SI) or a string with units (``"150 um"``).
        kind: a key of :data:`KINDS`: ``length``, ``modulus``, ``strain``, ``expansion`` or
            ``temperature_change``.
        key: the dotted key, as named in messages.

    Returns:
        The finite SI value.
    """
    expected = KINDS[kind]
    number = value if not isinstance(value, str) else _parse(value, expected, key)
    if not math.isfinite(number):
        raise InputError(f"{key} must be a finite quantity, got {value!r}")
    return float(number)


def _parse(text: str, expected: Kind, key: str) -> float:
    """The SI magnitude of ``text`` (a quantity of the kind ``expected``)."""
    import pint

    hint = f"{expected.name}, e.g. '{expected.example}'"
    try:
        quantity = _registry().Quantity(text)
    except (pint.PintError, ValueError, ArithmeticError, TypeError, SyntaxError) as err:
        raise InputError(f"{key} must be {hint}; cannot read {text!r}: {err}") from None
    try:
        return float(quantity.to(expected.unit).magnitude)
    except pint.DimensionalityError:
        got = str(quantity.dimensionality)
        raise InputError(f"{key} must be {hint}, got {text!r} ({got})") from None
