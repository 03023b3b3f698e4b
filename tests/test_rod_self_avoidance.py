"""Self-avoiding rods (docs/rods.md): the tangent-point energy of a curve and the rod flow.

For a curve the tangent-point radius r(x, y) = |y − x|²/(2|P_t^⊥(y − x)|) is the radius of the
circle through y tangent at x. On a round circle of radius R that circle is the curve itself:
r ≡ R, so TP = (2^(−q)/q)L²/R^q exactly, and the discrete sum, which leaves out the pairs of
the same and of neighbouring segments (3h of the L around each point), is (2^(−q)/q)R^(−q)·L(L − 3h).
"""

import itertools
import math

import numpy as np
import pytest

from dgplate.dg import tangent_point as tp


def trefoil_cloud(segments: int, per: int = 2) -> tuple[tp.Cloud, float]:
    """Gauss points of a (2, 3) torus knot polygon's parameter cells, unit tangents, ids."""
    g, w = np.polynomial.legendre.leggauss(per)
    s = ((np.arange(segments)[:, None] + (g[None, :] + 1) / 2) / segments).reshape(-1)
    a = 2 * np.pi * s
    x = np.c_[(2 + np.cos(3 * a)) * np.cos(2 * a), (2 + np.cos(3 * a)) * np.sin(2 * a)]
    x = np.c_[x, np.sin(3 * a)]
    dx = np.c_[
        -3 * np.sin(3 * a) * np.cos(2 * a) - 2 * (2 + np.cos(3 * a)) * np.sin(2 * a),
        -3 * np.sin(3 * a) * np.sin(2 * a) + 2 * (2 + np.cos(3 * a)) * np.cos(2 * a),
        3 * np.cos(3 * a),
    ]
    speed = np.linalg.norm(dx, axis=1)
    weights = np.tile(w / 2, segments) * 2 * np.pi * speed / segments
    k = np.repeat(np.arange(segments), per)
    cloud = tp.Cloud(x, dx / speed[:, None], weights, np.c_[k, (k + 1) % segments], curve=True)
    return cloud, float(weights.max() * 2)


def circle_cloud(segments: int, radius: float = 1.0) -> tuple[tp.Cloud, float]:
    """Two Gauss points per segment of the circle of radius R, exact tangents."""
    length = 2 * np.pi * radius
    g, w = np.polynomial.legendre.leggauss(2)
    phi = ((np.arange(segments)[:, None] + (g[None, :] + 1) / 2) / segments).reshape(-1) * 2 * np.pi
    x = radius * np.c_[np.cos(phi), np.sin(phi), 0 * phi]
    t = np.c_[-np.sin(phi), np.cos(phi), 0 * phi]
    k = np.repeat(np.arange(segments), 2)
    weights = np.tile(w / 2, segments) * length / segments
    return tp.Cloud(x, t, weights, np.c_[k, (k + 1) % segments], curve=True), length


@pytest.mark.parametrize("q", [3.0, 4.5])
def test_circle_value_is_exact_up_to_the_left_out_neighbours(q):
    """TP_h = (2^-q/q) R^-q L(L − 3h) to round-off, so TP_h → (2^-q/q) L²/R^q like 3h/L."""
    radius = 0.7
    errors = []
    for n in (16, 32, 64, 128):
        cloud, length = circle_cloud(n, radius)
        value = tp.evaluate(cloud, q, theta=0.0).energy
        exact = 2**-q / q * length**2 / radius**q
        assert value == pytest.approx(exact * (1 - 3 / n), rel=1e-12)
        errors.append(abs(value - exact) / exact)
    assert all(math.isclose(a / b, 2.0) for a, b in itertools.pairwise(errors))


def test_curve_pair_is_the_tangent_line_distance():
    """Two points, tangents t_i: (2^-q/q) w_i w_j Σ r^-q with r = |d|²/(2|d − (t·d)t|)."""
    x = np.array([[0.0, 0.0, 0.0], [0.3, 0.1, 0.5]])
    t = np.array([[1.0, 0.0, 0.0], [0.6, 0.0, 0.8]])
    w = np.array([0.2, 0.7])
    q = 3.0
    value = tp.evaluate(tp.Cloud(x, t, w, np.array([[0, 1], [2, 3]]), curve=True), q, 0.0)
    d = x[1] - x[0]
    r = [d @ d / (2 * np.linalg.norm(d - (t[k] @ d) * t[k])) for k in (0, 1)]
    assert math.isclose(value.energy, 2**-q / q * w[0] * w[1] * sum(ri**-q for ri in r))


def test_curve_tree_approaches_exact_sums_as_theta_falls():
    """A trefoil of 2000 points: the tree's errors fall with θ (rods use θ = 0 by default).

    Measured (relative): θ = 1: TP 4.9e-3, ∂/∂x 8.5e-2; θ = 0.5: 2.8e-3, 4.5e-2; θ = 0.25:
    4.5e-4, 2.0e-2. On a curve the far field is a larger share of the forces than on the
    plates' spiral, and the monopole spreads a box's force over its points by weight only.
    """
    cloud, reach = trefoil_cloud(1000)
    exact = tp.evaluate(cloud, 3.0, theta=0.0)
    errors = []
    for theta in (1.0, 0.5, 0.25):
        tree = tp.evaluate(cloud, 3.0, theta=theta, reach=3 * reach)
        assert tree.pairs_far > 0 and tree.pairs_exact < exact.pairs_exact / 2
        gradient = np.linalg.norm(tree.d_points - exact.d_points) / np.linalg.norm(exact.d_points)
        errors.append((abs(tree.energy - exact.energy) / exact.energy, gradient))
    assert errors[0][0] > errors[1][0] > errors[2][0] and errors[2][0] < 1e-3
    assert errors[0][1] > errors[1][1] > errors[2][1] and errors[2][1] < 3e-2


def test_curve_derivatives_by_finite_differences():
    """∂TP/∂x and ∂TP/∂t of the exact sums against central differences."""
    cloud, _ = trefoil_cloud(40)
    rng = np.random.default_rng(3)
    dx, dt = rng.normal(size=cloud.points.shape), rng.normal(size=cloud.normals.shape)
    base = tp.evaluate(cloud, 3.0, theta=0.0)
    eps = 1e-6

    def energy(sign: float) -> float:
        moved = tp.Cloud(
            cloud.points + sign * eps * dx,
            cloud.normals + sign * eps * dt,
            cloud.weights,
            cloud.vertices,
            curve=True,
        )
        return tp.evaluate(moved, 3.0, theta=0.0).energy

    fd = (energy(1) - energy(-1)) / (2 * eps)
    assert math.isclose(fd, np.sum(base.d_points * dx) + np.sum(base.d_normals * dt), rel_tol=1e-6)
