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
keeps the rod in a ball by the sphere obstacle of :mod:`dgplate.dg.obstacle_penalty` (the plates'
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

from dgplate.measure.rod_figures import nodes_in_order, writhe
from dgplate.models.rod.energy import RodData, clamp_measure, energy_split, rod_energy, rod_mesh
from dgplate.models.rod.model import RodModel, build_rod, exact_arc
from dgplate.models.rod.spec import ENDS, ROD_IGNORES, RodSpec, start_extent
from dgplate.models.rod.start import RodStart, closed_start

__all__ = [
    "ENDS",
    "ROD_IGNORES",
    "RodData",
    "RodModel",
    "RodSpec",
    "RodStart",
    "build_rod",
    "clamp_measure",
    "closed_start",
    "energy_split",
    "exact_arc",
    "nodes_in_order",
    "rod_energy",
    "rod_mesh",
    "start_extent",
    "writhe",
]
