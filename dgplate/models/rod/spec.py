"""The [model] section of a rod (``model.name = "rod"``): :class:`RodSpec`, its checks, its start.

The model is described in the docstring of :mod:`dgplate.models.rod`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dgplate import expressions
from dgplate.compat import Array
from dgplate.dg.obstacle_penalty import Obstacle
from dgplate.dg.self_avoidance import CurveSelfAvoidance
from dgplate.errors import InputError
from dgplate.models.rod.start import Start, closed_start, curve_start
from dgplate.schema import REQUIRED, option

ENDS = ("clamped-free", "clamped-guided", "free-free", "closed")
#: Keys that do nothing for a rod (an input error, see the registry).
ROD_IGNORES = {
    "mesh": "a rod has its own mesh: model.cells intervals of (0, model.length)",
    **{
        f"flow.{key}": "the rod flow chooses its metric itself (L² products only when no end is "
        "clamped), cell-wise DG1 and nodal multipliers and a direct solve at every step"
        for key in (
            "l2_metric",
            "multiplier_degree",
            "linear_solver",
            "refactor_its",
            "edge_constraint",
        )
    },
    **{
        f"flow.{key}": "the rod flow's adaptive τ has no SQP finish and reassembles its matrix "
        "at every step (its keys: adaptive_tau, defect_bound, tau_growth, tau_max_ratio)"
        for key in (
            "tau_growth_max",
            "refactor_factor",
            "step_control",
            "newton_finish",
            "newton_tau_ratio",
        )
    },
}


def _unit(value: Sequence[float]) -> Array:
    """A non-zero 3-vector (a spec's), normalised."""
    vector = np.asarray(value, dtype=float)
    return vector / float(np.linalg.norm(vector))


@dataclass(frozen=True)
class Confinement:
    """``model.confinement``: the ball |u − c| ≤ R that holds the rod (docs/obstacle.md)."""

    radius: float = option(REQUIRED, "the radius R of the ball", gt=0)
    center: list[float] = option([0.0, 0.0, 0.0], "its centre c", length=3)
    epsilon: float = option(1e-4, "the penalty parameter ε of (1/2ε)∫(R − |u − c|)₋²", gt=0)

    def sphere(self) -> Obstacle:
        """The obstacle 'inside a sphere' of :mod:`dgplate.dg.obstacle_penalty`."""
        return Obstacle(
            type="sphere",
            epsilon=self.epsilon,
            center=self.center,
            radius=self.radius,
            side="inside",
        )


@dataclass
class RodSpec:
    """[model] of an inextensible bending–torsion rod."""

    name: str = option("rod", "the model")
    length: float = option(1.0, "length L of the rod (its parameter interval is (0, L))", gt=0)
    cells: int = option(32, "number of intervals of (0, L)", ge=2)
    degree: int = option(
        2, "polynomial degree k of the centreline (C⁰ interior penalty: k >= 2)", ge=2
    )
    c_b: float = option(1.0, "bending rigidity c_b", gt=0)
    c_t: float = option(0.5, "torsional rigidity 0 < c_t < c_b (coercivity of the energy)", gt=0)
    kappa: float = option(
        0.0, "spontaneous curvature κ towards the director b: the rest shape has u″ = κ b"
    )
    ends: str = option(
        "clamped-free",
        "'clamped-free' (s = 0 clamped), 'clamped-guided' (s = L also has u′ = tangent and a prescribed frame, its position free), 'free-free' or 'closed' (starts as the circle of length L in the x-y plane with b = e₃; tangent and frame unused)",
        choices=ENDS,
    )
    twist: float = option(
        0.0,
        "'clamped-guided': the frame at s = L is turned by this angle (radians) about the tangent, the start spreads it as twist·(s/L)²; 'closed': a multiple of 2π, the start's frame turns uniformly by it about the tangent",
    )
    tangent: list[float] = option(
        [1.0, 0.0, 0.0], "u′ of the straight start (and at a clamp)", length=3, nonzero=True
    )
    frame: list[float] = option(
        [0.0, 1.0, 0.0], "b of the start (and at a clamp), ⟂ tangent", length=3, nonzero=True
    )
    penalty: float = option(10.0, "C⁰-IP penalty σ of the jumps of u′ (times c_b/h)", gt=0)
    saddle: float = option(
        0.0,
        "closed: the start is the saddle ρ(cos φ, sin φ, a sin 2φ) of length L (by arc length) with a = saddle; 0: the circle. A small a perturbs the ring (Michell's instability)",
    )
    curve: list[float | str] | None = option(
        None,
        "closed: the start is the closed curve t ↦ [x(t), y(t), z(t)], t ∈ [0, 2π], three formulas in t (e.g. a trefoil knot), parametrised by arc length and scaled to the length L; its frame is e₃ made orthogonal to the tangent. Not given: the circle or the saddle",
        shown="(none)",
        length=3,
    )
    confinement: Confinement | None = option(
        None,
        "the rod is kept in the ball |u − c| ≤ R by the penalty (1/2ε)∫(R − |u − c|)₋² with the quadratic–concave splitting (docs/obstacle.md): {} none",
    )
    self_avoidance: CurveSelfAvoidance | None = option(
        None,
        "self-avoidance ρ·TP[u] by the tangent-point energy of the centreline (docs/rods.md): {} none",
    )

    def __post_init__(self) -> None:
        if not self.c_t < self.c_b:
            raise InputError(
                f"model.c_t must be < model.c_b (got c_t = {self.c_t}, c_b = {self.c_b}): "
                "the energy with (c_t/2)|b′|² − (c_t/2)(b·u″)² is coercive only for c_t < c_b"
            )
        self._check_shape()
        self._check_start()

    def _check_start(self) -> None:
        """The saddle (closed rods only) and the confinement, which must hold the start."""
        if self.saddle != 0.0 and self.ends != "closed":
            raise InputError(
                f"model.saddle = {self.saddle} needs model.ends = 'closed', got {self.ends!r}"
            )
        self._curve = curve_table(self)
        if self.confinement is None:
            return
        extent = start_extent(self, self.confinement.center)
        if extent > self.confinement.radius:
            raise InputError(
                f"model.confinement.radius = {self.confinement.radius:g} is smaller than the "
                f"rod's initial extent max|u⁰ − center| = {extent:.4g}: the start must lie in "
                "the ball"
            )

    def _check_shape(self) -> None:
        """The twist and the start frame."""
        if self.twist != 0.0 and self.ends not in ("clamped-guided", "closed"):
            raise InputError(
                f"model.twist = {self.twist} needs model.ends = 'clamped-guided' or 'closed', "
                f"got {self.ends!r}"
            )
        turns = self.twist / (2.0 * math.pi)
        if self.ends == "closed" and abs(turns - round(turns)) > 1e-9:
            raise InputError(
                f"model.twist of a closed rod must be a multiple of 2π (the frame closes up), "
                f"got {self.twist} = {turns:.4g}·2π"
            )
        t, b = _unit(self.tangent), _unit(self.frame)
        if abs(float(t @ b)) > 1e-10:
            raise InputError(
                f"model.frame must be orthogonal to model.tangent, got frame·tangent = "
                f"{float(t @ b):.3g} (normalised)"
            )

    @property
    def curve_points(self) -> Array | None:
        """The validated ``curve`` at 4097 values of t ∈ [0, 2π] (rows), or None."""
        return self._curve

    @property
    def sphere(self) -> Obstacle | None:
        """The confinement as an obstacle (None: none)."""
        return None if self.confinement is None else self.confinement.sphere()

    @property
    def clamped(self) -> bool:
        """Whether s = 0 is clamped."""
        return self.ends.startswith("clamped")

    @property
    def clamped_nodes(self) -> tuple[float, ...]:
        """The parameters s of the ends with a prescribed frame and slope."""
        return {"clamped-free": (0.0,), "clamped-guided": (0.0, self.length)}.get(self.ends, ())

    @property
    def pinned_nodes(self) -> tuple[float, ...]:
        """The parameters s of the ends with a prescribed position."""
        return (0.0,) if self.clamped else ()


CURVE_SAMPLES = 4096  # intervals of t ∈ [0, 2π] of a start's table


def curve_table(spec: RodSpec) -> Array | None:
    """``model.curve`` at 4097 values of t ∈ [0, 2π]: closed, regular, never along e₃.

    Raises:
        InputError: Not a closed rod, not closed, not regular, or a
            tangent along e₃ (the start's frame is e₃ made orthogonal to the tangent).
    """
    key, curve = "model.curve", spec.curve
    if curve is None:
        return None
    if spec.ends != "closed" or spec.saddle != 0.0:
        raise InputError(f"{key} needs model.ends = 'closed' and model.saddle = 0")
    t = np.linspace(0.0, 2.0 * math.pi, CURVE_SAMPLES + 1)
    expressions.check(curve, key, {"t": 0.0})
    columns = [expressions.evaluate(str(f), np.zeros((t.size, 2)), key, {"t": t}) for f in curve]
    points = np.column_stack(
        [np.broadcast_to(np.asarray(c, dtype=float), t.shape) for c in columns]
    )
    if not np.all(np.isfinite(points)):
        raise InputError(f"{key} must be finite for t ∈ [0, 2π]")
    size = float(np.ptp(points, axis=0).max())
    gap = float(np.linalg.norm(points[-1] - points[0]))
    if gap > 1e-9 * max(size, 1.0):
        raise InputError(f"{key} must be closed: |u(2π) − u(0)| = {gap:.3g}, not 0")
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    if not chords.min() > 1e-9 * chords.mean():
        raise InputError(f"{key} must be regular (|u′(t)| > 0), got |u′| ≈ 0 at some t")
    along = np.abs(np.diff(points[:, 2])) / chords
    if along.max() > 1.0 - 1e-6:
        raise InputError(f"{key}: the tangent is along e₃ at some t (the start frame is e₃ ⟂ u′)")
    return points


def open_start(spec: RodSpec) -> Start:
    """The straight rod u = s·t, its frame b turned by twist·(s/L)² about t."""
    t, b = _unit(spec.tangent), _unit(spec.frame)
    d, twist, length = np.cross(t, b), spec.twist, spec.length

    def straight(x: Array) -> Array:
        line: Array = np.outer(t, x[0])
        return line

    def frame(x: Array) -> Array:
        angle = twist * (x[0] / length) ** 2
        return np.outer(b, np.cos(angle)) + np.outer(d, np.sin(angle))

    return straight, frame


def start_of(spec: RodSpec) -> Start:
    """The start (u⁰, b⁰) of the flow as callables of the mesh's points (3, n) → (3, n)."""
    if spec.curve_points is not None:
        return curve_start(spec.curve_points, spec.length, spec.twist)
    if spec.ends == "closed":
        return closed_start(spec.length, spec.twist, spec.saddle)
    return open_start(spec)


def start_extent(spec: RodSpec, center: Sequence[float]) -> float:
    """The largest |u⁰(s) − c| over 4096 points of the start (the mesh's points are on it)."""
    theta = np.linspace(0.0, 2.0 * math.pi, 4096, endpoint=False)
    if spec.ends == "closed":  # points of the polygon's angles
        points = np.vstack([np.cos(theta), np.sin(theta), np.zeros_like(theta)])
    else:
        points = np.vstack([np.linspace(0.0, spec.length, 4096), *np.zeros((2, 4096))])
    u = start_of(spec)[0](points)
    return float(np.max(np.linalg.norm(u - np.asarray(center)[:, None], axis=0)))
