"""The classification of closed curves as μ-circles and μ-ν-clews on exact curves (no FEM)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dgplate.measure.rod_shapes import classify, count_maxima, curvature, winding


def clew(mu: int, m: int, amplitude: float, radius: float = 1.0, n: int = 400) -> np.ndarray:
    """R(cos θ cos μt, cos θ sin μt, sin θ), θ = a sin(m t): μ turns about e₃, 2m curvature maxima."""
    t = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    theta = amplitude * np.sin(m * t)
    return (
        radius
        * np.c_[np.cos(theta) * np.cos(mu * t), np.cos(theta) * np.sin(mu * t), np.sin(theta)]
    )


def rotated(points: np.ndarray) -> np.ndarray:
    """The points turned by a rotation that moves e₃ off every coordinate axis, and shifted."""
    q, _ = np.linalg.qr(np.array([[1.0, 2.0, 0.5], [-0.3, 1.0, 2.0], [0.7, -1.0, 1.0]]))
    return points @ q.T + np.array([0.3, -0.2, 0.1])


@pytest.mark.parametrize("covered", [1, 2, 3])
def test_covered_circles(covered: int) -> None:
    """A circle covered μ times (odd node count: the turns interleave) is a μ-circle on its sphere."""
    t = np.linspace(0.0, 2.0 * math.pi * covered, 201, endpoint=False)
    shape = classify(0.5 * np.c_[np.cos(t), np.sin(t), np.zeros_like(t)], radius=0.5)
    assert (shape.kind, shape.mu, shape.nu, shape.label) == (
        "circle",
        covered,
        0,
        f"{covered}-circle",
    )
    assert shape.curvature_variation < 1e-10
    assert shape.sphere_distance < 1e-12
    assert abs(shape.winding - covered) < 1e-12
    assert np.allclose(np.abs(shape.axis), [0.0, 0.0, 1.0])


def test_curvature_of_a_circle() -> None:
    """The polygon's curvature at the nodes of a circle of radius 2 is 1/2 to O(h²)."""
    t = np.linspace(0.0, 2.0 * math.pi, 100, endpoint=False)
    s, kappa = curvature(2.0 * np.c_[np.cos(t), np.sin(t), np.zeros_like(t)])
    assert np.allclose(kappa, 0.5, rtol=1e-3)
    assert s[0] == 0.0 and abs(s[-1] - 2.0 * 2.0 * math.pi * 99 / 100) < 1e-2


@pytest.mark.parametrize(
    ("mu", "m", "amplitude"), [(1, 2, 0.5), (1, 3, 0.4), (2, 3, 0.4), (3, 4, 0.6), (2, 5, 0.3)]
)
def test_clews_on_a_sphere(mu: int, m: int, amplitude: float) -> None:
    """μ turns about an axis with m latitude waves: a μ-m clew, in any position (rotated)."""
    points = rotated(clew(mu, m, amplitude, radius=0.3))
    shape = classify(points, radius=0.3, center=[0.3, -0.2, 0.1])
    assert (shape.kind, shape.mu, shape.nu) == ("clew", mu, m), shape
    assert shape.label == f"{mu}-{m} clew"
    assert shape.mode == 2 * m and shape.peaks == 2 * m
    assert shape.sphere_distance < 1e-12
    assert shape.curvature_variation > 0.1


def test_saddle_is_a_one_two_clew_and_a_small_wave_a_circle() -> None:
    """The saddle (cos φ, sin φ, a sin 2φ) is a 1-2 clew; with a = 10⁻³ it is the 1-circle."""
    phi = np.linspace(0.0, 2.0 * math.pi, 300, endpoint=False)
    saddle = np.c_[np.cos(phi), np.sin(phi), 0.5 * np.sin(2.0 * phi)]
    assert classify(saddle).label == "1-2 clew"
    ring = np.c_[np.cos(phi), np.sin(phi), 1e-3 * np.sin(2.0 * phi)]
    shape = classify(ring)
    assert shape.label == "1-circle" and shape.curvature_variation < 0.01
    assert classify(saddle).sphere_distance > 0.05  # the saddle is not on a sphere


def test_winding_of_a_torus_curve_and_maxima() -> None:
    """The (3, 1) torus curve winds 3 times about e₃; a Schmitt trigger ignores small ripples."""
    t = np.linspace(0.0, 2.0 * math.pi, 301, endpoint=False)
    rho = 1.0 + 0.2 * np.cos(t)
    turns, axis = winding(np.c_[rho * np.cos(3 * t), rho * np.sin(3 * t), 0.2 * np.sin(t)])
    assert abs(turns - 3.0) < 1e-9 and abs(abs(axis[2]) - 1.0) < 1e-3
    x = np.linspace(0.0, 2.0 * math.pi, 500, endpoint=False)
    assert count_maxima(np.cos(3 * x) + 0.05 * np.sin(40 * x), 0.3) == 3


def test_bad_curves() -> None:
    """Too few nodes, repeated nodes, no axis and a bad threshold are errors."""
    with pytest.raises(ValueError, match="n >= 8"):
        classify(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="coincide"):
        classify(np.zeros((10, 3)))
    line = np.c_[np.linspace(0.0, 1.0, 10), np.zeros(10), np.zeros(10)]
    with pytest.raises(ValueError, match="angular momentum"):
        classify(np.vstack([line, line[::-1][1:-1]]))
    with pytest.raises(ValueError, match="peak_threshold"):
        classify(clew(1, 2, 0.5), peak_threshold=1.5)
