"""Inextensible bending–torsion rods (docs/rods.md, docs/design.md §1).

The Mora–Müller rod limit: a centreline u: (0, L) → ℝ³ and a frame [u′, b, d], d = u′ × b,
with |u′| = 1, |b| = 1, u′·b = 0, minimising

    I[u, b] = (c_b/2)∫ |u″ − κ b|² + (c_t/2)∫ (b′·d)²,

κ a spontaneous curvature towards b (κ = 0: the plain rod). Since |b′|² = (b′·u′)² + (b′·d)²
and b′·u′ = −b·u″ on the constraint set, the torsion term equals
(c_t/2)∫|b′|² − (c_t/2)∫(b·u″)² there, and

    I[u, b] ≥ ((c_b − c_t)/2)∫|u″|² + (c_t/2)∫|b′|² − (terms of κ)

is coercive in H² × H¹ when c_t < c_b (Bartels & Reiter 2020): the model uses this form. The
quadratic part (c_b/2)|u″ − κb|² + (c_t/2)|b′|² is implicit in the flow, the quartic
−(c_t/2)(b·u″)² explicit.

The rod has its own 1D mesh (``model.cells`` intervals of (0, ``model.length``), built by
:func:`rod_mesh` from these keys); the [mesh] section does not apply. ``model.confinement``
keeps the rod in a ball by the sphere obstacle of :mod:`dgplate.dg.obstacle` (the plates'
penalty and quadratic–concave splitting, applied to u). Ends: 'clamped-free' (u(0) = 0,
u′(0) = tangent, b(0) = frame), 'clamped-guided' (also u′(L) = tangent and b(L) = the frame
turned by ``model.twist`` about the tangent, u(L) free: clamping u(L) = L·tangent too would
make the straight rod taut, and the linearised length constraints then dependent),
'free-free' or 'closed'. The start is the
straight rod u(s) = s·tangent with b turned by twist·(s/L)² (b = frame without twist); a
closed rod starts as the circle of length L, or the saddle of ``model.saddle``
(:func:`closed_start`), its frame turned twist/2π times. ``model.self_avoidance`` adds
ρ·TP[u], the tangent-point energy of the centreline (:class:`CurveTangentPoint`), as an explicit
nonlocal term of the flow, with its safety net (a step that brings non-neighbouring points too
close too fast is redone with τ/2).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import basix.ufl
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from dgplate import compat, expressions, mpi, values
from dgplate.compat import Array, Constant, Function, Mesh
from dgplate.dg.energy import Energy
from dgplate.dg.forms import integral
from dgplate.dg.obstacle import Obstacle
from dgplate.dg.self_avoidance import CurveTangentPoint, SelfAvoidance
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh
from dgplate.schema import is_integer, is_number, option
from dgplate.solvers.driver import Observer
from dgplate.solvers.flow import FlowSpec, Initial
from dgplate.solvers.rod_flow import (
    RodFlow,
    RodState,
    ip_jumps,
    ip_product,
    nitsche_slope,
    tangent,
)
from dgplate.solvers.tau import ADAPTIVE_ONLY

__all__ = [
    "ENDS",
    "ROD_IGNORES",
    "RodModel",
    "RodSpec",
    "RodStart",
    "build_rod",
    "exact_arc",
    "rod_energy",
    "rod_mesh",
]

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
        f"flow.{key}": "the rod flow has a fixed τ (its self-avoidance safety net halves it for "
        "single steps) and stops at (E[xⁿ⁻¹] − E[xⁿ])/τ < tol"
        for key in ("stop", "adaptive_tau", *ADAPTIVE_ONLY)
    },
}
_START, _END = 1, 2  # the tags of the nodes s = 0 and s = L


def _unit(value: object, key: str) -> Array:
    """A non-zero 3-vector of numbers, normalised."""
    if not (isinstance(value, list) and len(value) == 3 and all(is_number(x) for x in value)):
        raise InputError(f"{key} must be three numbers [x, y, z], got {value!r}")
    vector = np.asarray(value, dtype=float)
    norm = float(np.linalg.norm(vector))
    if not (norm > 0 and math.isfinite(norm)):
        raise InputError(f"{key} must be a non-zero finite vector, got {value!r}")
    return vector / norm


def confinement(table: object) -> Obstacle | None:
    """``model.confinement`` as the obstacle 'inside a sphere' of :mod:`dgplate.dg.obstacle`."""
    key = "model.confinement"
    if isinstance(table, dict):
        for fixed in ("type", "side"):
            if fixed in table:
                raise InputError(
                    f"{key}.{fixed} has no effect: the confinement is the inside of a sphere; "
                    "remove it"
                )
        table = {**table, "type": "sphere", "side": "inside"} if table else table
    return Obstacle.from_table(table, key)


@dataclass
class RodSpec:
    """[model] of an inextensible bending–torsion rod."""

    name: str = option("rod", "the model")
    length: float = option(1.0, "length L of the rod (its parameter interval is (0, L))")
    cells: int = option(32, "number of intervals of (0, L)")
    degree: int = option(2, "polynomial degree k >= 2 of the centreline (C⁰ interior penalty)")
    c_b: float = option(1.0, "bending rigidity c_b > 0")
    c_t: float = option(0.5, "torsional rigidity 0 < c_t < c_b (coercivity of the energy)")
    kappa: float = option(
        0.0, "spontaneous curvature κ towards the director b: the rest shape has u″ = κ b"
    )
    ends: str = option(
        "clamped-free",
        "'clamped-free' (s = 0 clamped), 'clamped-guided' (s = L also has u′ = tangent and a prescribed frame, its position free), 'free-free' or 'closed' (starts as the circle of length L in the x-y plane with b = e₃; tangent and frame unused)",
    )
    twist: float = option(
        0.0,
        "'clamped-guided': the frame at s = L is turned by this angle (radians) about the tangent, the start spreads it as twist·(s/L)²; 'closed': a multiple of 2π, the start's frame turns uniformly by it about the tangent",
    )
    tangent: list[Any] = option([1.0, 0.0, 0.0], "u′ of the straight start (and at a clamp)")
    frame: list[Any] = option([0.0, 1.0, 0.0], "b of the start (and at a clamp), ⟂ tangent")
    penalty: float = option(10.0, "C⁰-IP penalty σ of the jumps of u′ (times c_b/h)")
    saddle: float = option(
        0.0,
        "closed: the start is the saddle ρ(cos φ, sin φ, a sin 2φ) of length L (by arc length) with a = saddle; 0: the circle. A small a perturbs the ring (Michell's instability)",
    )
    curve: list[Any] = option(
        [],
        "closed: the start is the closed curve t ↦ [x(t), y(t), z(t)], t ∈ [0, 2π], three formulas in t (e.g. a trefoil knot), parametrised by arc length and scaled to the length L; its frame is e₃ made orthogonal to the tangent. [] : the circle or the saddle",
    )
    confinement: dict[str, Any] = option(
        {},
        "{} none, or {radius = R, center = [3], epsilon = ε}: the rod is kept in the ball |u − c| ≤ R by the penalty (1/2ε)∫(R − |u − c|)₋² with the quadratic–concave splitting (docs/obstacle.md); ε defaults to 1e-4",
    )
    self_avoidance: dict[str, float] = option(
        {},
        "self-avoidance ρ·TP[u] by the tangent-point energy of the centreline (docs/rods.md): {} none, or {rho = ρ >= 0 (0.1), q = exponent > 2 (3), theta = cluster-tree admissibility (0: exact sums), quadrature_degree = 2, max_redo = halvings of τ per step (8), approach = redo a step when the least distance falls below this fraction (0.5)}",
    )

    def __post_init__(self) -> None:
        for key in ("length", "c_b", "c_t", "penalty"):
            value = getattr(self, key)
            if not (is_number(value) and value > 0 and math.isfinite(value)):
                raise InputError(f"model.{key} must be a finite number > 0, got {value!r}")
        for key, least in (("cells", 2), ("degree", 2)):
            value = getattr(self, key)
            if not (is_integer(value) and value >= least):
                raise InputError(f"model.{key} must be an integer >= {least}, got {value!r}")
        if not self.c_t < self.c_b:
            raise InputError(
                f"model.c_t must be < model.c_b (got c_t = {self.c_t}, c_b = {self.c_b}): "
                "the energy with (c_t/2)|b′|² − (c_t/2)(b·u″)² is coercive only for c_t < c_b"
            )
        self._check_shape()
        self._check_start()
        self._self_avoidance = SelfAvoidance.from_table(self.self_avoidance, curve=True)

    def _check_start(self) -> None:
        """The saddle (closed rods only) and the confinement, which must hold the start."""
        if not (is_number(self.saddle) and math.isfinite(self.saddle)):
            raise InputError(f"model.saddle must be a finite number, got {self.saddle!r}")
        if self.saddle != 0.0 and self.ends != "closed":
            raise InputError(
                f"model.saddle = {self.saddle} needs model.ends = 'closed', got {self.ends!r}"
            )
        self._curve = curve_table(self)
        self._sphere = sphere = confinement(self.confinement)
        if sphere is None:
            return
        extent = start_extent(self, sphere.center)
        if extent > sphere.radius:
            raise InputError(
                f"model.confinement.radius = {sphere.radius:g} is smaller than the rod's "
                f"initial extent max|u⁰ − center| = {extent:.4g}: the start must lie in the ball"
            )

    def _check_shape(self) -> None:
        """κ, the ends, the twist and the start frame."""
        if not (is_number(self.kappa) and math.isfinite(self.kappa)):
            raise InputError(f"model.kappa must be a finite number, got {self.kappa!r}")
        if self.ends not in ENDS:
            raise InputError(f"model.ends must be one of {', '.join(ENDS)}, got {self.ends!r}")
        if not (is_number(self.twist) and math.isfinite(self.twist)):
            raise InputError(f"model.twist must be a finite number, got {self.twist!r}")
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
        t, b = _unit(self.tangent, "model.tangent"), _unit(self.frame, "model.frame")
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
        """The validated confinement (None: none)."""
        return self._sphere

    @property
    def self_avoidance_params(self) -> SelfAvoidance | None:
        """The validated ``self_avoidance`` table (None: none)."""
        return self._self_avoidance

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


def loop(comm: Any, spec: RodSpec) -> Mesh:
    """A closed rod's parameter domain: the regular polygon of perimeter L, cells in turn."""
    n = spec.cells
    radius = spec.length / n / (2.0 * math.sin(math.pi / n))
    angles = 2.0 * math.pi * np.arange(n) / n
    points = radius * np.c_[np.cos(angles), np.sin(angles)]
    cells = np.c_[np.arange(n), (np.arange(n) + 1) % n].astype(np.int64)
    if comm.rank:  # rank 0 holds the whole mesh; the partitioner distributes it
        points, cells = points[:0], cells[:0]
    element = basix.ufl.element("Lagrange", "interval", 1, shape=(2,))
    return compat.create_mesh(
        comm, cells, points, ufl.Mesh(element), compat.shared_facet_partitioner()
    )


Start = tuple[Callable[[Array], Array], Callable[[Array], Array]]


CURVE_SAMPLES = 4096  # intervals of t ∈ [0, 2π] of a start's table


def curve_table(spec: RodSpec) -> Array | None:
    """``model.curve`` at 4097 values of t ∈ [0, 2π]: closed, regular, never along e₃.

    Raises:
        InputError: Not three formulas in t, not a closed rod, not closed, not regular, or a
            tangent along e₃ (the start's frame is e₃ made orthogonal to the tangent).
    """
    key, curve = "model.curve", spec.curve
    if isinstance(curve, list) and not curve:
        return None
    if not (isinstance(curve, list) and len(curve) == 3):
        raise InputError(f"{key} must be three formulas in t [x(t), y(t), z(t)], got {curve!r}")
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


def open_start(spec: RodSpec) -> Start:
    """The straight rod u = s·t, its frame b turned by twist·(s/L)² about t."""
    t, b = _unit(spec.tangent, "model.tangent"), _unit(spec.frame, "model.frame")
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


def rod_mesh(spec: RodSpec, comm: Any) -> TaggedMesh:
    """The rod's own mesh from its keys: ``model.cells`` intervals of (0, ``model.length``).

    Ghosted across shared nodes; the end nodes s = 0 and s = L are the facet groups 'start'
    and 'end'. A closed rod's parameter domain is the regular polygon of perimeter L (no ends).
    """
    if spec.ends == "closed":
        return TaggedMesh(loop(comm, spec), None, None, source="closed rod")
    mesh = dolfinx.mesh.create_interval(
        comm, spec.cells, [0.0, spec.length], partitioner=compat.shared_facet_partitioner()
    )
    mesh.topology.create_connectivity(0, 1)
    ends = [
        dolfinx.mesh.locate_entities_boundary(mesh, 0, lambda x, s=s: np.isclose(x[0], s))
        for s in (0.0, spec.length)
    ]
    nodes = np.concatenate(ends)
    marks = np.concatenate([np.full(ends[0].size, _START), np.full(ends[1].size, _END)])
    order = np.argsort(nodes)
    tags = dolfinx.mesh.meshtags(mesh, 0, nodes[order], marks[order].astype(np.int32))
    groups = {"start": (0, _START), "end": (0, _END)}
    return TaggedMesh(mesh, None, tags, groups, source="rod")


def clamp_measure(spec: RodSpec, tagged: TaggedMesh) -> ufl.Measure:
    """The measure ds on the clamped ends (s = 0, and s = L for a guided end)."""
    ds = ufl.Measure("ds", domain=tagged.mesh, subdomain_data=tagged.facet_tags)
    if spec.ends == "closed":
        return ds
    clamped: ufl.Measure = ds((_START, _END) if spec.ends == "clamped-guided" else _START)
    return clamped


@dataclass
class RodData:
    """The numbers of the energy as Constants of the rod's mesh."""

    c_b: Constant
    c_t: Constant
    kappa: Constant
    penalty: Constant
    tangent: Constant
    clamp: ufl.Measure | None  # ds on the clamped node, None for free ends
    sphere: Obstacle | None  # the confinement
    degree: int  # of the centreline (the penalty's quadrature)

    @staticmethod
    def of(spec: RodSpec, mesh: Mesh, clamp: ufl.Measure) -> RodData:
        """The Constants of ``spec`` on ``mesh``."""
        t = _unit(spec.tangent, "model.tangent")
        return RodData(
            values.constant(mesh, spec.c_b),
            values.constant(mesh, spec.c_t),
            values.constant(mesh, spec.kappa),
            values.constant(mesh, spec.penalty),
            values.constant(mesh, t),
            clamp if spec.clamped else None,
            spec.sphere,
            spec.degree,
        )


def rod_energy(u: Function, b: Function, data: RodData) -> Energy:
    """The modified rod energy: implicit (c_b/2)|u″ − κb|² + (c_t/2)|b′|², explicit −(c_t/2)(b·u″)².

    The bending term is the C⁰-IP form of ½∫|u″|² (and Nitsche's terms for u′(0) at a clamp),
    expanded as ½|u″|² − κ u″·b + ½κ²|b|²: quadratic in (u, b) jointly.
    """
    mesh = u.function_space.mesh
    dx = ufl.dx(domain=mesh)
    d2 = tangent(tangent(u))
    kappa = data.kappa
    bending = (
        0.5 * ip_product(u, u, mesh, data.penalty)
        + (-kappa * ufl.dot(d2, b) + 0.5 * kappa**2 * ufl.dot(b, b)) * dx
    )
    if data.clamp is not None:
        bending += nitsche_slope(u, data.tangent, mesh, data.penalty, data.clamp)
    implicit = data.c_b * bending + 0.5 * data.c_t * ufl.dot(tangent(b), tangent(b)) * dx
    explicit = -0.5 * data.c_t * ufl.dot(b, d2) ** 2 * dx
    if data.sphere is not None:  # (1/2ε)∫|u − c|² implicit, the concave rest explicit
        penalty = data.sphere.energy(u, mesh, data.degree)
        assert penalty.explicit is not None
        implicit, explicit = implicit + penalty.implicit, explicit + penalty.explicit
    return Energy(implicit, explicit)


def energy_split(u: Function, b: Function, data: RodData) -> dict[str, float]:
    """The parts of Ĩ_h (they sum to it), the length ∫|u′| and the twist angle ∫b′·d.

    Bending (c_b/2)Σ_T∫_T|u″ − κb|² (the cell terms); torsion (c_t/2)∫(b′·d)², d = u′ × b,
    the original form; ``energy_jumps``, c_b times the node terms of the C⁰-IP form (and
    Nitsche's at a clamp), which vanish for a C¹ centreline; ``energy_torsion_defect``, the
    modified torsion (c_t/2)∫(|b′|² − (b·u″)²) less the original, which vanishes on the
    constraint set |u′| = |b| = 1, u′·b = 0 and grows with the constraint defects; and in a
    sphere the confinement.
    """
    mesh = u.function_space.mesh
    dx = ufl.dx(domain=mesh)
    d2 = tangent(tangent(u))
    curvature = d2 - data.kappa * b
    twist = ufl.dot(tangent(b), ufl.cross(tangent(u), b))
    jumps = 0.5 * ip_jumps(u, u, mesh, data.penalty)
    if data.clamp is not None:
        jumps += nitsche_slope(u, data.tangent, mesh, data.penalty, data.clamp)
    modified = ufl.dot(tangent(b), tangent(b)) - ufl.dot(b, d2) ** 2
    forms = {
        "energy_bending": 0.5 * data.c_b * ufl.dot(curvature, curvature) * dx,
        "energy_torsion": 0.5 * data.c_t * twist**2 * dx,
        "energy_jumps": data.c_b * jumps,
        "energy_torsion_defect": 0.5 * data.c_t * (modified - twist**2) * dx,
        "length": ufl.sqrt(ufl.dot(tangent(u), tangent(u))) * dx,
        "twist_angle": twist * dx,
    }
    if data.sphere is not None:
        penalty = data.sphere.energy(u, mesh, data.degree)
        assert penalty.explicit is not None
        forms["energy_confinement"] = penalty.implicit + penalty.explicit
    return {key: integral(dolfinx.fem.form(form), mesh.comm) for key, form in forms.items()}


def nodes_in_order(u: Function) -> Array:
    """The nodal values of u (degrees of freedom) in the order of the parameter, on every rank.

    The order is s on an interval and the polygon's angle for a closed rod; each rank sends its
    owned nodes (collective).
    """
    space = u.function_space
    owned = space.dofmap.index_map.size_local
    x = space.tabulate_dof_coordinates()[:owned]
    key = np.arctan2(x[:, 1], x[:, 0]) if space.mesh.geometry.dim > 1 else x[:, 0]
    parts = space.mesh.comm.allgather((key, u.x.array.reshape(-1, 3)[:owned]))
    keys = np.concatenate([part[0] for part in parts])
    points: Array = np.concatenate([part[1] for part in parts])[np.argsort(keys, kind="stable")]
    return points


def writhe(points: Array, part: tuple[int, int] = (0, 1)) -> float:
    """The writhe of the closed polygon through ``points`` (n, 3): Gauss's double integral.

    Wr = (1/4π) ΣΣ_{i≠j} (eᵢ × eⱼ)·(mᵢ − mⱼ)/|mᵢ − mⱼ|³ over the edges eᵢ with midpoints mᵢ,
    the midpoint rule of (1/4π)∬ (u′(s) × u′(σ))·(u(s) − u(σ))/|u(s) − u(σ)|³. A planar curve
    has Wr = 0 exactly (the triple product of three vectors in a plane vanishes).

    The numerators are two matrix products, (eᵢ × eⱼ)·mᵢ = (mᵢ × eᵢ)·eⱼ and
    (eᵢ × eⱼ)·mⱼ = eᵢ·(eⱼ × mⱼ), and the squared distances |mᵢ|² + |mⱼ|² − 2mᵢ·mⱼ a third (the
    midpoints centred first), so that no (n, n, 3) array is formed (it is computed after every
    step of a closed rod). ``part`` = (k, m): only the k-th of m blocks of the rows i, a rank's
    share (the writhe is the sum of the m parts).
    """
    edges = np.roll(points, -1, axis=0) - points
    mids = points + 0.5 * edges
    mids = mids - mids.mean(axis=0)
    rows = np.array_split(np.arange(len(points)), part[1])[part[0]]
    e, m = edges[rows], mids[rows]
    numerator = np.cross(m, e) @ edges.T - e @ np.cross(edges, mids).T
    norms = np.sum(mids**2, axis=1)
    square = norms[rows][:, None] + norms[None, :] - 2.0 * (m @ mids.T)
    square[np.arange(rows.size), rows] = np.inf
    return float(np.sum(numerator / (square * np.sqrt(square))) / (4.0 * math.pi))


def shape_figures(u: Function, spec: RodSpec) -> dict[str, float]:
    """Writhe (closed rods) and, in a sphere, max |u − c| at the nodes (collective)."""
    out: dict[str, float] = {}
    if spec.ends != "closed" and spec.sphere is None:
        return out
    points = nodes_in_order(u)
    if spec.ends == "closed":
        out["writhe"] = writhe(points)
    if spec.sphere is not None:
        reach = np.linalg.norm(points - np.asarray(spec.sphere.center), axis=1)
        out["max_distance_to_center"] = float(np.max(reach))
    return out


def exact_arc(s: Array, spec: RodSpec) -> Array:
    """The clamped rod's minimiser for κ ≠ 0: the circular arc (sin κs/κ) t + ((1 − cos κs)/κ) b."""
    t, b = _unit(spec.tangent, "model.tangent"), _unit(spec.frame, "model.frame")
    k = spec.kappa
    return np.outer(t, np.sin(k * s) / k) + np.outer(b, (1.0 - np.cos(k * s)) / k)


def arc_error(u: Function, spec: RodSpec) -> dict[str, float]:
    """The largest over the nodes of |u − exact arc| / L (clamped rods with κ ≠ 0; collective)."""
    if not (spec.ends == "clamped-free" and spec.kappa != 0.0):
        return {}
    space = u.function_space
    owned = space.dofmap.index_map.size_local
    s = space.tabulate_dof_coordinates()[:owned, 0]
    exact = exact_arc(s, spec).T
    local = float(
        np.max(np.linalg.norm(u.x.array.reshape(-1, 3)[:owned] - exact, axis=1), initial=0.0)
    )
    return {"arc_error": mpi.global_max(space.mesh.comm, local) / spec.length}


class StepFigures:
    """A closed rod's twist angle ∫b′·d and writhe after every step (history.csv).

    Their sum Tw + Wr (Tw = twist angle/2π) is the link, which is conserved while the rod does
    not pass through itself (Călugăreanu); a crossing changes Wr by ±2.
    """

    def __init__(self) -> None:
        self._twist: compat.Form | None = None

    def __call__(self, flow: RodFlow) -> dict[str, float]:
        """The figures of the flow's current state (collective)."""
        u, b = flow.u, flow.b
        if self._twist is None:
            twist = ufl.dot(tangent(b), ufl.cross(tangent(u), b))
            self._twist = dolfinx.fem.form(twist * ufl.dx(domain=u.function_space.mesh))
        twist = integral(self._twist, flow.comm)
        wr = mpi.global_sum(flow.comm, writhe(nodes_in_order(u), (flow.comm.rank, flow.comm.size)))
        return {"twist_angle": twist, "writhe": wr, "link": link(twist, wr)}


def link(twist_angle: float, wr: float) -> float:
    """Lk = Tw + Wr in turns (Călugăreanu): Tw = ∫b′·d / 2π, the writhe ``wr`` in turns."""
    return twist_angle / (2.0 * math.pi) + wr


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


@dataclass
class RodModel:
    """A rod: its mesh, energy and start; run by :class:`RodFlow`."""

    spec: RodSpec
    mesh: Mesh
    data: RodData

    def driver(
        self, flow: FlowSpec, observers: Sequence[Observer], initial: Initial | None
    ) -> RodFlow:
        """The constrained gradient flow of the rod energy from the straight rod (or ``initial``)."""
        spec = self.spec
        start, director = start_of(spec)
        if isinstance(initial, RodStart):
            director = initial.frame
        state = RodState(initial or start, director, spec.clamped_nodes, spec.pinned_nodes)

        params = spec.self_avoidance_params

        def energy(u: Function, director: Function) -> Energy:
            base = rod_energy(u, director, self.data)
            if params is None:
                return base
            return replace(base, nonlocal_terms=[CurveTangentPoint(u, params, tangent)])

        measures = StepFigures() if spec.ends == "closed" else None
        return RodFlow(self.mesh, spec.degree, energy, flow, state, observers, measures)

    def figures(self, driver: RodFlow) -> dict[str, Any]:
        """Energy split (summing to E_h), length, the end point, the arc error (clamped, κ ≠ 0), Lk."""
        out: dict[str, Any] = energy_split(driver.u, driver.b, self.data)
        out.update(arc_error(driver.u, self.spec))
        out.update(shape_figures(driver.u, self.spec))
        if "writhe" in out:
            out["link"] = link(out["twist_angle"], out["writhe"])
        terms = driver.energy.nonlocal_terms
        if terms:
            out["energy_self_avoidance"] = sum(term.update() for term in terms)
            out["min_distance"] = min(term.min_distance for term in terms)
        # What the named parts leave of E_h: round-off (they are all its terms)
        parts = sum(value for key, value in out.items() if key.startswith("energy_"))
        out["energy_rest"] = driver.evaluate_energy() - parts
        return out

    def picture(self, driver: RodFlow, path: Path, title: str) -> None:
        """final.png: a tube around u with a stripe along b (the twist); a sphere that confines it."""
        ball = self.spec.sphere
        sphere = None if ball is None else (ball.radius, ball.center)
        from dgplate.io.rod_pictures import plot_rod  # pyvista: 1 s to import

        plot_rod(driver.u, driver.b, path, title, sphere=sphere)

    def lines(self, driver: RodFlow) -> list[Array]:
        """No extra lines: the picture is the centreline itself."""
        return []


def build_rod(spec: RodSpec, tagged: TaggedMesh) -> RodModel:
    """The rod on its own mesh (:func:`rod_mesh`) and its energy data."""
    return RodModel(spec, tagged.mesh, RodData.of(spec, tagged.mesh, clamp_measure(spec, tagged)))
