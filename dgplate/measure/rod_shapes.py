"""The shape of a closed rod: a μ-circle or a μ-ν-clew (rods in a sphere, docs/rods.md).

Bartels and Weyer describe the energy minimising closed rods of length L in a ball of radius
R as μ-circles (a circle covered μ times) and μ-ν-clews (curves that wind μ times about a
discrete rotation axis and whose curvature is 2ν-periodic along the arc length). This module
reads both numbers off a closed polygon through the nodes of a rod (rows of an (n, 3) array in
the order of the parameter, e.g. ``dgplate.measure.rod_figures.nodes_in_order``):

- **the axis** a is the direction of the polygon's angular momentum ∮ u × u′ ds (twice its
  vector area), which for a curve winding about an axis points along it;
- **μ** is the winding number about a: the total change of the angle of u − c (c the
  centroid) in the plane normal to a, |∮ dφ|/2π, rounded;
- **the curvature** κ at the nodes is the turning angle of the polygon over the mean length
  of the two edges, resampled at equal arc lengths and smoothed by keeping its Fourier modes
  up to :data:`MODES`;
- **the curvature variation** is (max κ − min κ)/mean κ of the smoothed curvature: below
  ``circle_tolerance`` the shape is a μ-circle (ν = 0);
- otherwise it is a μ-ν-clew with 2ν the number of curvature maxima, counted as the rises of
  the smoothed κ from below m − δ to above m + δ (m the middle of its range, δ
  ``peak_threshold`` times half its range): a peak counts when its prominence exceeds about
  2δ, so discretisation ripples do not.

The distance from the sphere is max | |u − c| − R | / R at the nodes, with the given centre
and radius (by default the centroid and the mean of |u − c|: the best centred sphere). Pure
NumPy, no mesh: the caller gathers the nodes (on every rank or on one).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dgplate.compat import Array

__all__ = ["MODES", "RodShape", "classify", "curvature", "winding"]

#: The Fourier modes of κ(s) kept before counting its maxima (2ν ≤ MODES is resolved).
MODES = 24


@dataclass(frozen=True)
class RodShape:
    """A classified closed curve.

    Attributes:
        kind: 'circle' (μ-circle) or 'clew' (μ-ν-clew).
        mu: The winding number about ``axis``.
        nu: Half the number of curvature maxima (0 for a circle).
        curvature_variation: (max κ − min κ)/mean κ of the smoothed curvature.
        sphere_distance: max | |u − c| − R | / R over the nodes.
        winding: The unrounded winding number |∮ dφ|/2π.
        peaks: The number of curvature maxima counted.
        mode: The dominant Fourier mode of κ(s) (0 for a circle), 2ν for a regular clew.
        axis: The unit axis (direction of ∮ u × u′).
    """

    kind: str
    mu: int
    nu: int
    curvature_variation: float
    sphere_distance: float
    winding: float
    peaks: int
    mode: int
    axis: tuple[float, float, float]

    @property
    def label(self) -> str:
        """'μ-circle' or 'μ-ν clew', e.g. '2-circle', '1-2 clew'."""
        return f"{self.mu}-circle" if self.kind == "circle" else f"{self.mu}-{self.nu} clew"

    def as_dict(self) -> dict[str, object]:
        """The fields and the label, for JSON."""
        return {
            "label": self.label,
            "kind": self.kind,
            "mu": self.mu,
            "nu": self.nu,
            "curvature_variation": self.curvature_variation,
            "sphere_distance": self.sphere_distance,
            "winding": self.winding,
            "peaks": self.peaks,
            "mode": self.mode,
            "axis": list(self.axis),
        }


def _checked(points: Array) -> Array:
    """The nodes as an (n, 3) float array with n ≥ 8 and no two consecutive ones equal."""
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 8:
        raise ValueError(f"a closed curve needs an (n, 3) array with n >= 8, got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("the curve's nodes must be finite")
    if np.min(np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)) <= 0.0:
        raise ValueError("two consecutive nodes of the curve coincide")
    return p


def winding(points: Array) -> tuple[float, Array]:
    """The winding number |∮ dφ|/2π about the axis of ∮ u × u′, and that unit axis.

    The angle φ of u − c (c the centroid) is taken in the plane normal to the axis; each
    edge adds its angle increment in (−π, π].
    """
    p = _checked(points)
    centred = p - p.mean(axis=0)
    momentum = np.sum(np.cross(centred, np.roll(centred, -1, axis=0)), axis=0)
    norm = float(np.linalg.norm(momentum))
    if norm == 0.0:
        raise ValueError("the curve has no angular momentum ∮ u × u′: no axis to wind about")
    axis = momentum / norm
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    angle = np.arctan2(centred @ e2, centred @ e1)
    steps = np.angle(np.exp(1j * (np.roll(angle, -1) - angle)))
    return abs(float(np.sum(steps))) / (2.0 * math.pi), axis


def curvature(points: Array) -> tuple[Array, Array]:
    """The arc length s at the nodes and the polygon's curvature κ there.

    κ_i = (turning angle at node i) / ((|e_{i−1}| + |e_i|)/2), the discrete curvature of
    the closed polygon (exact for a regular polygon inscribed in a circle up to O(h²)).
    """
    p = _checked(points)
    edges = np.roll(p, -1, axis=0) - p
    lengths = np.linalg.norm(edges, axis=1)
    before = np.roll(edges, 1, axis=0)
    turn = np.arctan2(
        np.linalg.norm(np.cross(before, edges), axis=1), np.sum(before * edges, axis=1)
    )
    kappa = turn / (0.5 * (lengths + np.roll(lengths, 1)))
    s = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    return s, kappa


def _smoothed(s: Array, kappa: Array, period: float) -> tuple[Array, int]:
    """κ at 4·MODES equal arc lengths with its modes ≤ MODES, and its dominant mode ≥ 1."""
    grid = np.linspace(0.0, period, max(len(s), 8 * MODES), endpoint=False)
    spectrum = np.fft.rfft(np.interp(grid, s, kappa, period=period))
    spectrum[MODES + 1 :] = 0.0
    dominant = 1 + int(np.argmax(np.abs(spectrum[1 : MODES + 1])))
    return np.fft.irfft(spectrum, n=grid.size), dominant


def count_maxima(signal: Array, threshold: float) -> int:
    """The maxima of a periodic signal whose rise exceeds a share of its range (a Schmitt trigger).

    Walking once around from the global minimum, a maximum is counted each time the signal
    goes above m + δ after being below m − δ (m the middle of its range, δ = threshold times
    half the range).
    """
    start = int(np.argmin(signal))
    walk = np.roll(signal, -start)
    middle = 0.5 * (float(walk.max()) + float(walk.min()))
    delta = threshold * 0.5 * (float(walk.max()) - float(walk.min()))
    count, low = 0, True
    for value in walk:
        if low and value > middle + delta:
            count, low = count + 1, False
        elif not low and value < middle - delta:
            low = True
    return count


def classify(
    points: Array,
    radius: float | None = None,
    center: Sequence[float] | None = None,
    *,
    circle_tolerance: float = 0.1,
    peak_threshold: float = 0.3,
) -> RodShape:
    """Classify the closed polygon through ``points`` (n, 3) as a μ-circle or a μ-ν-clew.

    Args:
        points: The nodes in the order of the parameter (the closing edge is implied).
        radius: R of the sphere (default: the mean distance from ``center``).
        center: The sphere's centre (default: the centroid of the nodes).
        circle_tolerance: The largest (max κ − min κ)/mean κ of a circle.
        peak_threshold: δ/(half the range of κ) of the peak count (0 < threshold < 1).

    Returns:
        The kind, μ, ν and the figures they come from.

    Raises:
        ValueError: Not an (n, 3) array of n ≥ 8 finite distinct consecutive nodes, no axis
            (∮ u × u′ = 0), or a threshold outside (0, 1).
    """
    if not 0.0 < peak_threshold < 1.0:
        raise ValueError(f"peak_threshold must lie in (0, 1), got {peak_threshold}")
    p = _checked(points)
    c = p.mean(axis=0) if center is None else np.asarray(center, dtype=float)
    reach = np.linalg.norm(p - c, axis=1)
    r = float(reach.mean()) if radius is None else float(radius)
    turns, axis = winding(p)
    s, kappa = curvature(p)
    period = float(s[-1] + np.linalg.norm(p[0] - p[-1]))
    smooth, dominant = _smoothed(s, kappa, period)
    variation = float((smooth.max() - smooth.min()) / smooth.mean())
    circle = variation < circle_tolerance
    peaks = 0 if circle else count_maxima(smooth, peak_threshold)
    return RodShape(
        kind="circle" if circle else "clew",
        mu=round(turns),
        nu=0 if circle else (peaks + 1) // 2,
        curvature_variation=variation,
        sphere_distance=float(np.max(np.abs(reach - r)) / r),
        winding=turns,
        peaks=peaks,
        mode=0 if circle else dominant,
        axis=(float(axis[0]), float(axis[1]), float(axis[2])),
    )
