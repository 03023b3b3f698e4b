"""The shapes a rod starts from: closed curves by arc length, and a warm start from a run.

:func:`dgplate.models.rod.spec.start_of` chooses the start of a spec.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from dgplate.compat import Array, Function

Start = tuple[Callable[[Array], Array], Callable[[Array], Array]]


def _turned_frame(t: Array, share: Array, twist: float) -> Array:
    """e₃ made orthogonal to the unit tangents t (3, n), turned by twist·share about t."""
    b0 = np.outer([0.0, 0.0, 1.0], np.ones(t.shape[1])) - t * t[2]
    b0 /= np.linalg.norm(b0, axis=0)
    psi = twist * share
    frame: Array = np.cos(psi) * b0 + np.sin(psi) * np.cross(t, b0, axis=0)
    return frame


def polygon_share(x: Array) -> Array:
    """The share s/L of a closed rod's polygon points (3, n): their angle over 2π."""
    share: Array = np.mod(np.arctan2(x[1], x[0]), 2.0 * math.pi) / (2.0 * math.pi)
    return share


def curve_start(points: Array, length: float, twist: float) -> Start:
    """The start of ``model.curve``: the table ``points`` (closed, rows) by arc length, length L.

    The arc length is that of the table's polygon (4096 chords); the tangent its central
    difference quotient, interpolated. The frame is e₃ made orthogonal to the tangent, turned
    by twist·s/L about it.
    """
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
    scale = length / arc[-1]
    ring = points[:-1]
    tangents = np.roll(ring, -1, axis=0) - np.roll(ring, 1, axis=0)
    tangents = np.vstack([tangents, tangents[:1]])

    def at(table: Array, x: Array) -> Array:
        s = polygon_share(x) * arc[-1]
        return np.vstack([np.interp(s, arc, column) for column in table.T])

    def centreline(x: Array) -> Array:
        line: Array = scale * at(points, x)
        return line

    def frame(x: Array) -> Array:
        t = at(tangents, x)
        return _turned_frame(t / np.linalg.norm(t, axis=0), polygon_share(x), twist)

    return centreline, frame


def closed_start(length: float, twist: float, saddle: float) -> Start:
    """The closed rod's start: the saddle ρ(cos φ, sin φ, a sin 2φ) of length L, by arc length.

    a = ``saddle`` (0: the circle of length L). The point of angle θ on the polygon has the arc
    length s = Lθ/2π and goes to the φ with s(φ) = s (a table of 4096 intervals, inverted by
    linear interpolation; exact for the circle). The frame is b₀ = e₃ made orthogonal to the
    tangent t and turned by ψ = twist·s/L about t: b = cos ψ b₀ + sin ψ t × b₀ (for the circle
    cos ψ e₃ − sin ψ ν, ν the inward normal); twist is a multiple of 2π.
    """
    grid = np.linspace(0.0, 2.0 * math.pi, 4097)
    speed = np.sqrt(1.0 + (2.0 * saddle * np.cos(2.0 * grid)) ** 2)
    arc = np.r_[0.0, np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(grid))]
    rho = length / arc[-1]

    def angle(x: Array) -> tuple[Array, Array]:
        """(φ, s/L) of the polygon's points."""
        share = polygon_share(x)
        return np.interp(share * arc[-1], arc, grid), share

    def centreline(x: Array) -> Array:
        phi, _ = angle(x)
        curve: Array = rho * np.vstack([np.cos(phi), np.sin(phi), saddle * np.sin(2.0 * phi)])
        return curve

    def binormal(x: Array) -> Array:
        phi, share = angle(x)
        t = np.vstack([-np.sin(phi), np.cos(phi), 2.0 * saddle * np.cos(2.0 * phi)])
        return _turned_frame(t / np.linalg.norm(t, axis=0), share, twist)

    return centreline, binormal


class RodStart:
    """A start (u⁰, b⁰) from the final u and b of an earlier run on the same rod mesh.

    ``initial`` of :func:`dgplate.run` for a warm start (e.g. the stages of a continuation in
    a parameter): calling it gives u at the interpolation points, :meth:`frame` gives b (the
    plates' ``initial`` has no frame). Every rank keeps all nodal values (collective), and a
    point takes the value of the nearest node, which is the point itself on the same mesh.
    """

    def __init__(self, fields: Mapping[str, Function]) -> None:
        self._tables = {key: _nodal_table(fields[key]) for key in ("u", "b")}

    def __call__(self, x: Array) -> Array:
        """The centreline u at the points x (3, n)."""
        return _nearest(self._tables["u"], x)

    def frame(self, x: Array) -> Array:
        """The director b at the points x (3, n)."""
        return _nearest(self._tables["b"], x)


def _nodal_table(f: Function) -> tuple[Array, Array]:
    """The coordinates and values (n, 3) of all owned degrees of freedom of f (collective)."""
    space = f.function_space
    owned = space.dofmap.index_map.size_local
    parts = space.mesh.comm.allgather(
        (space.tabulate_dof_coordinates()[:owned], f.x.array.reshape(-1, 3)[:owned])
    )
    return np.vstack([p[0] for p in parts]), np.vstack([p[1] for p in parts])


def _nearest(table: tuple[Array, Array], x: Array) -> Array:
    """The values of the table's nearest nodes at the points x (3, n)."""
    coords, nodal = table
    distance = sum((x[k][:, None] - coords[None, :, k]) ** 2 for k in range(3))
    found: Array = nodal[np.argmin(distance, axis=1)].T
    return found
