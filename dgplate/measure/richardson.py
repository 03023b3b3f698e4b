"""Richardson extrapolation of a figure computed on meshes refined by a factor 2 each time.

For a figure that behaves like f_h = f∞ + C hᵖ, three successive levels f₁, f₂, f₃ (h, h/2,
h/4) give the observed order p = log₂(|f₁ − f₂| / |f₂ − f₃|) and the extrapolated value
f∞ ≈ f₃ + (f₃ − f₂)/(2ᵖ − 1), whose distance from f₃ is the error estimate of the finest
level. Pure arithmetic: :func:`extrapolate` either gives these or says why none can be given.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

#: The orders believed: outside them the differences are noise or a change of regime.
MIN_ORDER, MAX_ORDER = 0.5, 6.0

#: Differences at or below this multiple of the figure's size are round-off.
ROUND_OFF = 1e-12


@dataclass(frozen=True)
class Estimate:
    """A figure's observed order and extrapolated value, or the reason there is none.

    ``order``, ``limit`` and ``error`` are None exactly when ``reason`` is not.
    """

    order: float | None = None
    limit: float | None = None
    error: float | None = None
    reason: str | None = None

    def as_dict(self) -> dict[str, float | str | None]:
        """The estimate as a JSON object."""
        return {
            "order": self.order,
            "limit": self.limit,
            "error": self.error,
            "reason": self.reason,
        }


def extrapolate(values: Sequence[float], ratio: float = 2.0) -> Estimate:
    """Observed order and Richardson limit from the last three of ``values`` (coarse first).

    Args:
        values: the figure on successively refined meshes, each ``ratio`` times finer.
        ratio: the refinement ratio between levels (> 1).

    Returns:
        The :class:`Estimate`; its ``reason`` says why none can be given: fewer than three
        levels, a value that is not finite, no change between the last levels, differences
        that change sign (no monotone trend), or an order outside [MIN_ORDER, MAX_ORDER].
    """
    if len(values) < 3:
        return Estimate(reason=f"{len(values)} level(s): three are needed")
    f1, f2, f3 = (float(v) for v in values[-3:])
    if not all(math.isfinite(v) for v in (f1, f2, f3)):
        return Estimate(reason="a value that is not finite")
    d12, d23 = f2 - f1, f3 - f2
    scale = max(abs(f1), abs(f2), abs(f3), 1e-300)
    if abs(d23) <= ROUND_OFF * scale:
        return Estimate(reason="no change between the last two levels (round-off): no order")
    if d12 * d23 <= 0:
        return Estimate(reason="no monotone trend (the differences change sign)")
    order = math.log(abs(d12) / abs(d23)) / math.log(ratio)
    if not MIN_ORDER <= order <= MAX_ORDER:
        return Estimate(reason=f"observed order {order:.3g} outside [{MIN_ORDER:g}, {MAX_ORDER:g}]")
    limit = f3 + d23 / (ratio**order - 1.0)
    return Estimate(order=order, limit=limit, error=abs(limit - f3))
