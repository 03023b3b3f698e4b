"""A director whose metric jumps along a line is bad input (``model.director.angle``).

G = R(θ) diag(λ², λ^{−2ν}) R(θ)ᵀ depends on θ modulo π, so the azimuthal angle's 2π jump, and
a defect of charge ±1/2 or ±1, leave G continuous away from the defect's point. An angle that
jumps by other than a multiple of π along a curve (``where(x > 0, 0, pi/2)``) makes G jump
there: no smooth surface realises it (docs/prestrain.md). The test, on each cell's segments
from its geometry nodes to its midpoint:

1. segments across which G changes by more than ``JUMP`` of its anisotropy |λ² − λ^{−2ν}|;
2. bisection of each to a point (``BISECTIONS`` halvings): a jump stays, a steep smooth G
   does not;
3. a small circle about each point that keeps a jump: a line of discontinuity crosses the
   circle, so G jumps between two of its neighbouring samples, by as much on a ten times finer
   sampling; about a defect's point (of any charge) G turns continuously, and the change
   between neighbours falls tenfold with the sampling.
"""

from __future__ import annotations

import numpy as np

from dgplate import expressions
from dgplate.compat import Array, Mesh, geometry_dofmap
from dgplate.errors import InputError
from dgplate.models.director import Director

#: a change of G, relative to its anisotropy, that counts as a jump
JUMP = 0.05
#: halvings of a segment (2⁻⁴⁰ of a cell: far below any smooth variation)
BISECTIONS = 40
#: samples on the circle about a jump point (and ten times as many), its radius relative to
#: the cell size
CIRCLE_SAMPLES, CIRCLE_RADIUS = 720, 1e-4
#: most distinct jump points tested on the circle per rank (the first ones found)
MOST_POINTS = 64

KEY = "model.director.angle"


def check_smooth(director: Director, mesh: Mesh) -> None:
    """InputError on every rank when the director's G jumps along a line (collective).

    Args:
        director: the validated ``model.director`` (a constant angle passes at once).
        mesh: the plate's mesh.
    """
    anisotropy = abs(director.stretch**2 - director.stretch ** (-2 * director.nu))
    local = None
    if isinstance(director.angle, str) and anisotropy > 0:
        local = _line_jump(director, mesh, anisotropy)
    found = [item for item in mesh.comm.allgather(local) if item is not None]
    if found:
        x, y, size = found[0]
        raise InputError(
            f"{KEY}: the director is not smooth: its metric G jumps by {size:.3g} (relative to "
            f"|λ² − λ^(-2ν)|) along a line through (x, y) = ({x:.6g}, {y:.6g}); an angle may "
            "jump by multiples of π only (docs/prestrain.md)"
        )


def _line_jump(director: Director, mesh: Mesh, scale: float) -> tuple[float, float, float] | None:
    """(x, y, relative jump) of a line jump on this rank's cells, else None."""
    nodes = mesh.geometry.x[geometry_dofmap(mesh)][:, :, :2]  # (cells, nodes, 2)
    midpoints = np.broadcast_to(nodes.mean(axis=1, keepdims=True), nodes.shape)
    size = float(np.max(np.linalg.norm(nodes - midpoints, axis=2), initial=0.0))
    a, b = nodes.reshape(-1, 2), midpoints.reshape(-1, 2)
    across = _change(director, a, b) / scale > JUMP
    a, b = a[across], b[across]
    for _ in range(BISECTIONS):
        if not len(a):
            return None
        middle = 0.5 * (a + b)
        first = _change(director, a, middle) >= _change(director, middle, b)
        b = np.where(first[:, None], middle, b)
        a = np.where(first[:, None], a, middle)
    kept = a[_change(director, a, b) / scale > JUMP / 2]
    radius = CIRCLE_RADIUS * size
    # one test per point: the segments of all the cells about a defect lead to its point
    _, distinct = np.unique(np.round(kept / radius), axis=0, return_index=True)
    for point in kept[np.sort(distinct)][:MOST_POINTS]:
        coarse = _circle_jump(director, point, radius, CIRCLE_SAMPLES) / scale
        fine = _circle_jump(director, point, radius, 10 * CIRCLE_SAMPLES) / scale
        if fine > JUMP / 2 and fine > coarse / 2:
            return float(point[0]), float(point[1]), float(fine)
    return None


def _circle_jump(director: Director, centre: Array, radius: float, samples: int) -> float:
    """The largest change of G between neighbouring samples on a circle about ``centre``."""
    phi = np.linspace(0.0, 2 * np.pi, samples, endpoint=False)
    circle = centre + radius * np.column_stack([np.cos(phi), np.sin(phi)])
    return float(np.max(_change(director, circle, np.roll(circle, -1, axis=0))))


def _change(director: Director, p: Array, q: Array) -> Array:
    """The largest over G's entries of |G(p) − G(q)|, pointwise for points p, q of shape (n, 2)."""
    if not len(p):
        return np.zeros(0)
    entries = director.metric().entries()
    out = np.zeros(len(p))
    for name, text in entries.items():
        assert isinstance(text, str)  # a formula angle gives formula entries
        key = f"{KEY} ({name} of G)"
        gp = np.broadcast_to(np.asarray(expressions.evaluate(text, p, key), dtype=float), len(p))
        gq = np.broadcast_to(np.asarray(expressions.evaluate(text, q, key), dtype=float), len(q))
        out = np.maximum(out, np.abs(gp - gq))
    return out
