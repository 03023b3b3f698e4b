"""Föppl–von Kármán plates: stretching + bending, solved by Newton's method over load steps.

Model (docs/design.md §1). In-plane displacement u: ω → ℝ², deflection w: ω → ℝ, and the energy

    Π(u, w) = ½∫ N(ε):ε + ½ a_h(w, w) − ∫ p w,     ε = sym∇u + ½∇w⊗∇w − ε₀ I,
    N = A[(1−ν)ε + ν tr(ε) I],  A = E t/(1−ν²),  M = D[(1−ν)κ + ν tr(κ) I],  D = E t³/(12(1−ν²)).

Residual and Jacobian are ``ufl.derivative`` of Π; nothing else is written by hand.

Bending. ½a_h(w, w) is :func:`dgplate.dg.forms.bending_energy` on the scalar w with μ = D (clamped
faces: Nitsche data w = 0, ∇w = 0 or ``clamp_slope``; crease faces: no gradient-jump terms),
plus the Poisson part
νD[∫det D²w − Σ_e∫{cof(D²w) n}·[∇w]], cof(H) = tr(H) I − H. Together the cell terms are ½∫M:κ,
and the face terms are the consistent symmetric IP terms of the moment M: div cof(D²w) = 0, so
the shear terms of dg.py stay as they are. ν matters for free edges (the Kirchhoff free-edge
condition) and in the twisting moment on simply supported edges.

Penalty length. ``penalty_length`` chooses the h of the penalties γ₀D/h³ and γ₁D/hᵖ on
interior and boundary facets: "diameter" (default) or "facet_normal", |T|/|F|, which keeps the
energy coercive on meshes with thin triangles (:func:`dgplate.dg.forms.penalty_lengths`).

Simply supported faces: w = 0 with the rotation free. An element-wise integration by parts leaves
M_nt ∂_t v − Q_n v on such a face (M_nn = 0 there is the natural condition), so the Nitsche terms
are −(M n)·P_t∇w + Q_n w + ½γ₁D/hᵖ |P_t∇w|² + ½γ₀D/h³ w², P_t = I − n⊗n: the value jump and its
tangential derivative only, never ∂_n w. Without the twisting-moment term −(M n)·P_t∇w the
method is inconsistent: on 8/16/32 Q2 squares the centre deflection of the simply supported plate
is then off by 0.74/0.23/0.086 % instead of 0.28/0.07/0.02 % (docs/fvk.md).

Unknowns and membrane discretisation. One mixed space W = DG_k × [CG_k]² (k ≥ 2), one Newton
system, one MUMPS factorisation per iteration. The deflection uses the dG core; the in-plane
displacement is continuous Lagrange of the same degree: for this second-order, coercive
membrane problem (Korn, once an edge is held) conforming Lagrange is stable and needs no
penalty, and in-plane boundary conditions are plain Dirichlet conditions on u. The membrane
strain uses the element-wise gradient of w, which is consistent; jumps of w are controlled by
the bending penalty.

In-plane boundary conditions (``membrane`` = {facet group: condition}): "fixed" (u = 0),
"normal" (u·n = 0, u·t free: edges held against pull-in but free to slide; axis-parallel edges
only), "free", or [u_x, u_y] prescribed (numbers, formulas in x, y, or "free" per component;
scaled with the load: a formula's data λ g₁ are written into a boundary function, ScaledData).

Indenter (docs/fvk_experiments.md). ``indenter`` (a cell group) is pushed down rigidly by λδ
(``indentation``) from the natural shape by the penalty ½ k E t ∫_indenter (w − w₀ + λδ)²
(k = ``indenter_stiffness``): a flat punch glued to the tip of a cone w₀ = α(R − r). Clamped and simply supported groups default to "fixed", all other edges are free.

Load schedule. Pressure p, prestrain ε₀ (thermal expansion: ε₀ > 0 compresses a held plate),
prescribed edge displacements, clamp slopes and the indentation are multiplied by a load factor
(``path.parameter``: all of them, or one, the others at their full values). ``load_steps = n`` means
the load factors 1/n, 2/n, …, 1; a list gives the factors (increasing, in (0, 1]). The
schedule is solved by the generic driver :class:`dgplate.solvers.newton.LoadPath` (secant
predictor, SNES newtonls with the NLEQ-ERR line search, MUMPS LU; ``newton.snes`` overrides any
option under the prefix ``dgplate_fvk_``). A load step that does not converge ends the run
with ``converged = false``, the SNES reason and the last converged state.

Natural shape. ``natural_shape = w₀`` (a number or a formula in x, y) sets the plate's natural
metric to that of the surface (x, y, w₀(x, y)): the strain becomes
ε = sym∇u + ½(∇w⊗∇w − ∇w₀⊗∇w₀) − ε₀ I, so (u, w) = (0, w₀) is stretch-free. Bending is still
measured from flat (κ = D²w), as in the energy of indented cones of Conti, Olbermann & Tobasco
(a cone w₀ = −α r has D²w₀ ∉ L²). w₀ is not scaled with the load, and the path starts from the
flat plate as always (Newton from w = w₀ against clamped edges crawls under the NLEQ-ERR
damping); ``[initial]`` gives another start.

Stability. With ``stability = true`` (the default) the driver reports after each load step the
lowest eigenvalue of the Hessian D²Π at the converged state (the Newton Jacobian on the free
unknowns; ``lowest_eigenvalue`` in history.csv, the path and the interpolated load factor where
it crosses zero in summary.json). ``perturb_unstable = a`` moves a state whose lowest eigenvalue
has just turned negative by a·φ (φ the unstable mode, max |φ| = 1, so a is a deflection) and
solves again: a perfect plate then leaves the flat, unstable branch at the first step past
buckling. ``relaxation = true`` solves each load step (and each solve after a push) first by an
energy-decreasing proximal gradient flow (first pseudo-time step ``relaxation_tau``), then by
Newton: Newton alone finds critical points, and from a small push it often returns to the flat
state. ``leave_unstable = true`` leaves every state whose lowest eigenvalue is negative (below
−10⁻³ × the largest |lowest eigenvalue| of the path): it is pushed along the unstable mode by
``leave_unstable_push`` × the largest change of the state since the start, relaxed by that flow
(which lowers Π, so it cannot return to the saddle), and pushed and relaxed again until the
lowest eigenvalue is ≥ that tolerance (at most 4 rounds); rank 0 prints one line per branch left.
See :mod:`dgplate.solvers.newton` and :mod:`dgplate.solvers.eigen`.

Natural curvature. ``natural_curvature = κ₀`` measures bending from κ₀ I: the moment is
M(D²w − κ₀I) (a plate heated through its thickness, κ₀ = αΔT/t). The energy gains
−M₀[Σ_T∫_T tr D²w − Σ_e∫_e n·[∇w]], M₀ = D(1 + ν)κ₀, over smooth interior, clamped ([∇w] =
∇w − Φ) and mirror facets: the IP terms with M − M₀I in place of M, consistent (tested by the
free plate taking w = ½κ₀|x|²). κ₀ is scaled with the load factor.

Mirror edges. ``mirror`` facet groups lie on a mirror plane of a symmetric plate: ∂w/∂n = 0 by
the Nitsche terms −∫M_nn ∂ₙw + ½γ₁D/hᵖ(∂ₙw)² (M_nt and the effective shear vanish there), and
u·n = 0. ``pin = [x, y]`` holds w = 0 at one node of a vertex (the plate's height, which no
edge holds when none is clamped or simply supported).

The driver's shape is the deformation y = (x₁ + u₁, x₂ + u₂, w) in [DG_k]³, written and drawn
like every other model's; its records carry ``w_center`` (w at ``model.probe``), ``w_max`` and
``w_<name>`` at each point of ``model.probes``.
"""

from dgplate.models.fvk.energy import (
    MIRROR,
    SIMPLY_SUPPORTED,
    fvk_bending_energy,
    fvk_energy,
    fvk_facet_sets,
    membrane_strain,
    plane_stress,
)
from dgplate.models.fvk.model import PREFIX, FvKModel, build_fvk
from dgplate.models.fvk.spec import PENALTY, FvKSpec, NewtonSpec

__all__ = [
    "MIRROR",
    "PENALTY",
    "PREFIX",
    "SIMPLY_SUPPORTED",
    "FvKModel",
    "FvKSpec",
    "NewtonSpec",
    "build_fvk",
    "fvk_bending_energy",
    "fvk_energy",
    "fvk_facet_sets",
    "membrane_strain",
    "plane_stress",
]
