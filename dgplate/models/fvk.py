"""Föppl–von Kármán plates: stretching + bending, solved by Newton's method over load steps.

Model (docs/design.md §1). In-plane displacement u: ω → ℝ², deflection w: ω → ℝ, and the energy

    Π(u, w) = ½∫ N(ε):ε + ½ a_h(w, w) − ∫ p w,     ε = sym∇u + ½∇w⊗∇w − ε₀ I,
    N = A[(1−ν)ε + ν tr(ε) I],  A = E t/(1−ν²),  M = D[(1−ν)κ + ν tr(κ) I],  D = E t³/(12(1−ν²)).

Residual and Jacobian are ``ufl.derivative`` of Π; nothing else is written by hand.

Bending. ½a_h(w, w) is :func:`dgplate.dg.forms.bending_energy` on the scalar w with μ = D (clamped
faces: Nitsche data w = 0, ∇w = 0; crease faces: no gradient-jump terms), plus the Poisson part
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

Load schedule. Pressure p, prestrain ε₀ (thermal expansion: ε₀ > 0 compresses a held plate)
and prescribed edge displacements are multiplied by a load factor. ``load_steps = n`` means
the load factors 1/n, 2/n, …, 1; a list gives the factors (increasing, in (0, 1]). The
schedule is solved by the generic driver :class:`dgplate.solvers.newton.Continuation` (secant
predictor, SNES newtonls with the NLEQ-ERR line search, MUMPS LU; ``model.snes`` overrides any
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

The driver's shape is the deformation y = (x₁ + u₁, x₂ + u₂, w) in [DG_k]³, written and drawn
like every other model's; its records carry ``w_center`` (w at ``model.probe``) and ``w_max``.
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any, TypeAlias

from mpi4py import MPI

import basix.ufl
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from dgplate import compat, expressions, values
from dgplate.dg.forms import (
    FREE,
    PENALTY_LENGTH_HELP,
    FacetSets,
    Penalty,
    bending_energy,
    check_penalty_length,
    facet_sets,
    grad_laplacian,
    hessian,
    jump,
)
from dgplate.errors import InputError
from dgplate.measure.probes import PointProbe, signed_extreme
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import Initial
from dgplate.mpi import allreduce_array, bounds
from dgplate.schema import option
from dgplate.solvers import eigen
from dgplate.solvers.driver import Observer
from dgplate.solvers.newton import Continuation, Leave, Relaxation, Stability

#: Facet-set id of simply supported boundary facets (beside dg.SMOOTH … dg.FREE = 1 … 4).
SIMPLY_SUPPORTED = 5

#: Default penalties, used for the results in docs/fvk.md (Q2 and P3 cells).
PENALTY = Penalty(gamma0=100.0, gamma1=100.0)

#: PETSc options prefix of the FvK driver: ``-dgplate_fvk_snes_monitor`` on the command line.
PREFIX = "dgplate_fvk_"

_HINT = "try more model.load_steps or other model.snes options"
_OPTION = re.compile(r"^[A-Za-z0-9_]+$")
_CONDITIONS = ("fixed", "normal", "free")


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _names(value: object) -> bool:
    return isinstance(value, list | tuple) and all(isinstance(n, str) for n in value)


@dataclass
class FvKSpec:
    """[model] of a Föppl–von Kármán plate (name = "fvk"); every key is checked once, here.

    Group names are checked against the mesh when the model is built (:func:`build_fvk`).
    """

    name: str = option("fvk", "the model")
    E: float = option(1.0, "Young's modulus E > 0")
    nu: float = option(0.3, "Poisson's ratio, −1 < ν < 0.5")
    thickness: float = option(0.01, "plate thickness t > 0")
    pressure: float | str = option(
        0.0, "pressure p at full load (along +z): a number or a formula in x, y"
    )
    prestrain: float = option(0.0, "isotropic in-plane prestrain ε₀ at full load (expansion > 0)")
    natural_shape: float | str = option(
        0.0, "natural shape w₀(x, y), a number or formula: strain ½(∇w⊗∇w − ∇w₀⊗∇w₀) + sym∇u"
    )
    clamped: list[Any] = option([], "facet groups with w = 0 and ∇w = 0")
    simply_supported: list[Any] = option([], "facet groups with w = 0, rotation free")
    crease: list[Any] = option([], "interior facet groups where ∇w may jump (hinges)")
    membrane: dict[str, Any] = option(
        {}, "{group: 'fixed' | 'normal' | 'free' | [ux, uy]} in-plane BCs"
    )
    degree: int = option(2, "degree k >= 2 of w (DG_k) and u (CG_k)")
    penalty: dict[str, Any] = option(
        {"gamma0": PENALTY.gamma0, "gamma1": PENALTY.gamma1},
        "IP penalties γ₀ (h⁻³[w]²) and γ₁ (h⁻ᵖ[∇w]²); gradient_power p (default 1, at most 3) over-penalises gradient jumps",
    )
    penalty_length: str = option("diameter", PENALTY_LENGTH_HELP)
    load_steps: int | list[Any] = option(10, "n uniform load steps, or a list of load factors")
    probe: list[Any] | None = option(
        None, "point [x, y] for w_center (default: bounding-box centre)"
    )
    snes: dict[str, Any] = option({}, "PETSc options for SNES/KSP/PC, e.g. {snes_rtol = 1e-8}")
    stability: bool = option(
        True, "report the lowest Hessian eigenvalue after each load step (and its zero crossing)"
    )
    stability_modes: int = option(
        3, "eigenvalues nearest 0 computed per step; the lowest is reported"
    )
    perturb_unstable: float = option(
        0.0,
        "amplitude (a deflection) of the push along the unstable mode when the lowest eigenvalue turns negative; 0: none",
    )
    eigensolver: str = option("auto", "'auto' (SLEPc when importable), 'slepc' or 'lanczos'")
    leave_unstable: bool = option(
        False,
        "leave every state whose lowest eigenvalue is negative: push along the unstable mode, relax by the energy-decreasing flow (first τ relaxation_tau), repeat until the lowest eigenvalue is >= -1e-3 × its path scale",
    )
    leave_unstable_push: float = option(
        0.05,
        "push of leave_unstable: this fraction (0 < a <= 1) of the largest change of the state since the start",
    )
    relaxation: bool = option(
        False,
        "solve each load step (and each solve after a push) by an energy-decreasing proximal gradient flow, then Newton",
    )
    relaxation_tau: float = option(
        1.0, "first pseudo-time step τ > 0 of the relaxation (adapted: doubled or quartered)"
    )
    indenter: str | None = option(
        None, "cell group pushed down rigidly by the indentation (w − w₀ = −λδ there, penalty)"
    )
    indentation: float = option(0.0, "indentation depth δ ≥ 0 of the indenter at full load")
    indenter_stiffness: float = option(
        1e4, "penalty k of the indenter: ½ k E t ∫_indenter (w − w₀ + λδ)², k > 0"
    )

    def __post_init__(self) -> None:
        """Check every key once: one-line InputErrors naming ``model.<key>``."""
        if self.name != "fvk":
            raise InputError(f"model.name must be 'fvk' for FvKSpec, got {self.name!r}")
        self._check_material()
        self._check_groups()
        self._penalty = Penalty.from_table(self.penalty, "model.penalty", PENALTY)
        check_penalty_length(self.penalty_length, "model.penalty_length")
        self._load_factors = _load_factors(self.load_steps)
        if self.probe is not None and not (
            isinstance(self.probe, list | tuple) and len(self.probe) == 2
        ):
            raise InputError(f"model.probe must be a point [x, y], got {self.probe!r}")
        _check_options(self.snes, "model.snes")
        self._check_stability()
        self._check_relaxation()
        expressions.check(self.natural_shape, "model.natural_shape")
        self._check_indenter()

    def _check_indenter(self) -> None:
        if self.indenter is not None and not isinstance(self.indenter, str):
            raise InputError(f"model.indenter must be a cell group name, got {self.indenter!r}")
        if not (_number(self.indentation) and 0 <= self.indentation < math.inf):
            raise InputError(f"model.indentation must be a number >= 0, got {self.indentation!r}")
        stiffness = self.indenter_stiffness
        if not (_number(stiffness) and 0 < stiffness < math.inf):
            raise InputError(f"model.indenter_stiffness must be > 0, got {stiffness!r}")
        if self.indentation and self.indenter is None:
            raise InputError("model.indentation needs model.indenter (the cell group pushed)")

    def _check_material(self) -> None:
        for key in ("E", "thickness"):
            value = getattr(self, key)
            if not (_number(value) and value > 0 and math.isfinite(value)):
                raise InputError(f"model.{key} must be > 0, got {value!r}")
        if not (_number(self.nu) and self.nu < 0.5):
            raise InputError(f"model.nu must be < 0.5, got {self.nu!r}")
        if not self.nu > -1:
            raise InputError(f"model.nu must be > -1, got {self.nu!r}")
        if not _number(self.prestrain):
            raise InputError(f"model.prestrain must be a number, got {self.prestrain!r}")
        expressions.check(self.pressure, "model.pressure")
        if not (_number(self.degree) and isinstance(self.degree, int) and self.degree >= 2):
            raise InputError(f"model.degree must be an integer >= 2, got {self.degree!r}")

    def _check_stability(self) -> None:
        if not isinstance(self.stability, bool):
            raise InputError(f"model.stability must be true or false, got {self.stability!r}")
        modes = self.stability_modes
        if not (isinstance(modes, int) and not isinstance(modes, bool) and modes >= 1):
            raise InputError(f"model.stability_modes must be an integer >= 1, got {modes!r}")
        if not (_number(self.perturb_unstable) and math.isfinite(self.perturb_unstable)):
            raise InputError(
                f"model.perturb_unstable must be a number, got {self.perturb_unstable!r}"
            )
        if self.eigensolver not in eigen.SOLVERS:
            raise InputError(
                f"model.eigensolver must be one of {', '.join(eigen.SOLVERS)}, "
                f"got {self.eigensolver!r}"
            )
        if self.eigensolver == "slepc" and not eigen.have_slepc():
            raise InputError("model.eigensolver = 'slepc' but slepc4py cannot be imported")
        if self.perturb_unstable and not self.stability:
            raise InputError("model.perturb_unstable needs model.stability = true")
        self._check_leave()

    def _check_leave(self) -> None:
        if not isinstance(self.leave_unstable, bool):
            raise InputError(
                f"model.leave_unstable must be true or false, got {self.leave_unstable!r}"
            )
        push = self.leave_unstable_push
        if not (_number(push) and 0 < push <= 1):
            raise InputError(f"model.leave_unstable_push must be in (0, 1], got {push!r}")
        if self.leave_unstable and not self.stability:
            raise InputError("model.leave_unstable needs model.stability = true")

    def _check_relaxation(self) -> None:
        if not isinstance(self.relaxation, bool):
            raise InputError(f"model.relaxation must be true or false, got {self.relaxation!r}")
        tau = self.relaxation_tau
        if not (_number(tau) and 0 < tau < math.inf):
            raise InputError(f"model.relaxation_tau must be a number > 0, got {tau!r}")

    @property
    def stability_options(self) -> Stability | None:
        """The driver's :class:`Stability` (None with ``stability = false``)."""
        if not self.stability:
            return None
        leave = Leave(
            fraction=float(self.leave_unstable_push),
            relaxation=Relaxation(tau=self.relaxation_tau, rtol=1e-4, max_steps=300, stall=10),
        )
        return Stability(
            modes=self.stability_modes,
            perturb=float(self.perturb_unstable),
            solver=self.eigensolver,
            leave=leave if self.leave_unstable else None,
        )

    def _check_groups(self) -> None:
        for key in ("clamped", "simply_supported", "crease"):
            if not _names(getattr(self, key)):
                raise InputError(
                    f"model.{key} must be a list of facet group names, got {getattr(self, key)!r}"
                )
        both = sorted(set(self.clamped) & set(self.simply_supported))
        if both:
            raise InputError(f"model.clamped and model.simply_supported both list {both[0]!r}")
        for group, condition in self.membrane.items():
            if not _membrane_condition(condition):
                raise InputError(
                    f"model.membrane.{group} must be 'fixed', 'normal', 'free' or [ux, uy] "
                    f"(numbers, formulas in x, y or 'free'), got {condition!r}"
                )
            if not isinstance(condition, str):
                for i, component in enumerate(condition):
                    if component != "free":
                        expressions.check(component, f"model.membrane.{group}[{i}]")

    @property
    def penalty_params(self) -> Penalty:
        """The penalty table with the FvK defaults for missing keys (:data:`PENALTY`)."""
        return self._penalty

    @property
    def load_factors(self) -> list[float]:
        """The load factors of the schedule (module docstring)."""
        return list(self._load_factors)

    @property
    def D(self) -> float:
        """The bending stiffness E t³/(12(1 − ν²))."""
        return float(self.E * self.thickness**3 / (12 * (1 - self.nu**2)))


def _membrane_condition(condition: object) -> bool:
    if isinstance(condition, str):
        return condition in _CONDITIONS
    return (
        isinstance(condition, list | tuple)
        and len(condition) == 2
        and all(_number(c) or isinstance(c, str) for c in condition)
    )


def _load_factors(steps: object) -> list[float]:
    """``n`` → 1/n … 1; an increasing list in (0, 1] as it is; anything else an InputError."""
    if _number(steps) and isinstance(steps, int):
        if steps < 1:
            raise InputError(f"model.load_steps must be >= 1, got {steps}")
        return [(i + 1) / steps for i in range(steps)]
    factors: list[float] = []
    if isinstance(steps, list | tuple) and steps and all(map(_number, steps)):
        factors = [float(s) for s in steps]
    if not (factors and 0 < factors[0] and factors[-1] <= 1 and np.all(np.diff(factors) > 0)):
        raise InputError(
            "model.load_steps must be a positive integer or an increasing list of load "
            f"factors in (0, 1], got {steps!r}"
        )
    return factors


def _check_options(options: dict[Any, Any], key: str) -> None:
    """PETSc option names (without '-') mapped to strings or numbers."""
    for name, value in options.items():
        if not (isinstance(name, str) and _OPTION.match(name)):
            raise InputError(
                f"{key}.{name} is not a PETSc option name (letters, digits and _, without the "
                "leading '-', e.g. snes_rtol)"
            )
        if not isinstance(value, str | int | float):
            raise InputError(f"{key}.{name} must be a string or a number, got {value!r}")


# -- the energy --------------------------------------------------------------------------------
def membrane_strain(u: Any, w: Any, prestrain: Any = 0.0, natural: Any = None) -> Any:
    """ε = sym∇u + ½(∇w⊗∇w − ∇w₀⊗∇w₀) − ε₀ I (element-wise gradient of a dG deflection).

    ``natural`` is the natural shape w₀ as a UFL expression (None: flat).
    """
    gw = ufl.grad(w)
    eps = ufl.sym(ufl.grad(u)) + 0.5 * ufl.outer(gw, gw) - prestrain * ufl.Identity(2)
    if natural is not None:
        g0 = ufl.grad(natural)
        eps -= 0.5 * ufl.outer(g0, g0)
    return eps


def natural_shape(spec: FvKSpec, mesh: dolfinx.mesh.Mesh[np.float64]) -> Any:
    """w₀ of ``model.natural_shape`` as a UFL expression, None for a flat (constant) w₀."""
    shape = expressions.parse(spec.natural_shape, mesh, "model.natural_shape")
    return None if isinstance(shape, float) else shape


def plane_stress(eps: Any, stiffness: Any, nu: Any) -> Any:
    """stiffness·[(1−ν)ε + ν tr(ε) I]: N for stiffness A, M (with ε = κ) for stiffness D."""
    return stiffness * ((1 - nu) * eps + nu * ufl.tr(eps) * ufl.Identity(2))


def _cofactor(A: Any) -> Any:
    return ufl.tr(A) * ufl.Identity(2) - A


def fvk_bending_energy(
    w: Any, faces: FacetSets, penalty: Penalty, D: Any, nu: Any, simply_supported: bool
) -> ufl.Form:
    """½a_h(w, w) with the Poisson part and simply supported facets (module docstring)."""
    n, h = faces.n, faces.h_boundary
    gamma0, gamma1 = penalty.constants(faces.mesh)
    H = hessian(w)
    zero = ufl.as_vector((0.0, 0.0))
    energy: ufl.Form = bending_energy(w, faces, penalty, mu=D, g=0.0, Phi=zero)
    energy += nu * D * ufl.det(H) * faces.dx
    energy -= (
        nu
        * D
        * ufl.inner(ufl.dot(ufl.avg(_cofactor(H)), n("+")), jump(ufl.grad(w)))
        * faces.dS_smooth()
    )
    if faces.has_clamped:
        energy -= nu * D * ufl.inner(ufl.dot(_cofactor(H), n), ufl.grad(w)) * faces.ds_clamped()
    if simply_supported:
        tgrad = ufl.dot(ufl.Identity(2) - ufl.outer(n, n), ufl.grad(w))
        moment_n = ufl.dot(plane_stress(H, D, nu), n)
        energy += (
            -ufl.inner(moment_n, tgrad)
            + 0.5 * penalty.gradient_weight(h, gamma1) * D * ufl.inner(tgrad, tgrad)
            + D * ufl.inner(ufl.dot(grad_laplacian(w), n), w)
            + 0.5 * gamma0 * D / h**3 * w * w
        ) * faces.ds(SIMPLY_SUPPORTED)
    return energy


def fvk_energy(
    state: dolfinx.fem.Function[np.float64],
    faces: FacetSets,
    spec: FvKSpec,
    load_factor: dolfinx.fem.Constant[np.float64],
    tip: Any = None,
) -> ufl.Form:
    """Π(u, w) of the state (w, u) ∈ DG_k × [CG_k]² at the load factor of ``load_factor``.

    E, ν, t, p and ε₀ enter as Constants (:mod:`dgplate.values`). ``tip`` is the cell measure
    of the indenter's cell group (``model.indenter``), where the penalty
    ½ k E t ∫(w − w₀ + λδ)² pushes the plate down rigidly by λδ from its natural shape.
    """
    mesh = faces.mesh
    E, nu, t, prestrain = (
        values.constant(mesh, v) for v in (spec.E, spec.nu, spec.thickness, spec.prestrain)
    )
    pressure = expressions.parse(spec.pressure, mesh, "model.pressure")
    if isinstance(pressure, float):
        pressure = values.constant(mesh, pressure)
    D = E * t**3 / (12 * (1 - nu**2))
    A = E * t / (1 - nu**2)
    w, u = ufl.split(state)
    natural = natural_shape(spec, mesh)
    eps = membrane_strain(u, w, load_factor * prestrain, natural)
    energy: ufl.Form = 0.5 * ufl.inner(plane_stress(eps, A, nu), eps) * faces.dx
    simply_supported = bool(spec.simply_supported)
    energy += fvk_bending_energy(w, faces, spec.penalty_params, D, nu, simply_supported)
    energy -= load_factor * pressure * w * faces.dx
    if spec.indenter is not None and tip is not None:
        depth, stiffness = (
            values.constant(mesh, v) for v in (spec.indentation, spec.indenter_stiffness)
        )
        w0 = natural if natural is not None else 0.0
        gap = w - w0 + load_factor * depth
        energy += 0.5 * stiffness * E * t * tip * gap * gap * faces.dx
    return energy


# -- facets, spaces and in-plane conditions ----------------------------------------------------
def fvk_facet_sets(tagged: TaggedMesh, spec: FvKSpec) -> FacetSets:
    """dg.facet_sets plus the simply supported facets (id SIMPLY_SUPPORTED), all in one tag."""
    facets = facet_sets(tagged, spec.clamped, spec.crease, spec.penalty_length)
    if not spec.simply_supported:
        return facets
    mesh, fdim = tagged.mesh, tagged.mesh.topology.dim - 1
    fmap = mesh.topology.index_map(fdim)
    tags = facets.tags.values.copy()
    position = np.full(fmap.size_local + fmap.num_ghosts, -1, dtype=np.int64)
    position[facets.tags.indices] = np.arange(facets.tags.indices.size)
    for group in spec.simply_supported:
        indices = tagged.facets(group)
        is_owned = indices < fmap.size_local
        wrong = np.count_nonzero(tags[position[indices]][is_owned] != FREE)
        owned = np.count_nonzero(is_owned)
        wrong, owned = allreduce_array(mesh.comm, [wrong, owned]).astype(int)
        if wrong or not owned:
            raise InputError(
                f"model.simply_supported: group '{group}' must be non-empty boundary facets "
                f"that are not clamped ({wrong} of {owned} are not)"
            )
        tags[position[indices]] = SIMPLY_SUPPORTED
    meshtags = dolfinx.mesh.meshtags(mesh, fdim, facets.tags.indices, tags)
    return FacetSets(mesh, meshtags, facets.num_clamped, facets.num_crease, spec.penalty_length)


def fvk_space(
    mesh: dolfinx.mesh.Mesh[np.float64], degree: int
) -> dolfinx.fem.FunctionSpace[np.float64]:
    """W = DG_k × [CG_k]²: the deflection w and the in-plane displacement u."""
    cell = mesh.basix_cell()
    elements = [
        basix.ufl.element("DG", cell, degree),
        basix.ufl.element("Lagrange", cell, degree, shape=(2,)),
    ]
    return dolfinx.fem.functionspace(mesh, basix.ufl.mixed_element(elements))


def _edge_axis(tagged: TaggedMesh, group: str) -> int:
    """Component of u normal to an axis-parallel edge group: 0 for x = const, 1 for y = const."""
    mesh = tagged.mesh
    facets = tagged.facets(group)
    x = mesh.geometry.x[compat.entities_to_geometry(mesh, mesh.topology.dim - 1, facets)]
    spread = np.ptp(x[:, :, :2], axis=1) if facets.size else np.zeros((0, 2))
    scale = np.ptp(mesh.geometry.x[:, :2], axis=0).max()
    flags = np.array([np.all(spread[:, 0] < 1e-10 * scale), np.all(spread[:, 1] < 1e-10 * scale)])
    flags = allreduce_array(mesh.comm, flags, op=MPI.MIN).astype(int)
    if flags.sum() != 1:
        raise InputError(
            f"model.membrane.{group} = 'normal' needs a straight edge parallel to the x or y axis"
        )
    return int(np.argmax(flags))


def _component_values(tagged: TaggedMesh, group: str, condition: Any) -> list[Any]:
    """[u_x, u_y] at full load of one group's condition, "free" for a free component."""
    if condition == "fixed":
        return [0.0, 0.0]
    if condition == "free":
        return ["free", "free"]
    if condition == "normal":
        components: list[Any] = ["free", "free"]
        components[_edge_axis(tagged, group)] = 0.0
        return components
    return list(condition)


# a string: DOLFINx 0.9's Constant is not subscriptable at run time
BCValues: TypeAlias = "list[tuple[Any, Any]]"  # (Constant or ScaledData, value at full load)


def membrane_bcs(
    space: dolfinx.fem.FunctionSpace[np.float64], tagged: TaggedMesh, spec: FvKSpec
) -> tuple[list[dolfinx.fem.DirichletBC[np.float64]], BCValues]:
    """Dirichlet conditions on u, and their (Constant, value at full load) pairs."""
    conditions: dict[str, Any] = dict.fromkeys([*spec.clamped, *spec.simply_supported], "fixed")
    conditions.update(spec.membrane)
    fdim = tagged.mesh.topology.dim - 1
    bcs: list[dolfinx.fem.DirichletBC[np.float64]] = []
    bc_values: BCValues = []
    for group, condition in conditions.items():
        facets = tagged.facets(group)
        for component, value in enumerate(_component_values(tagged, group, condition)):
            if value == "free":
                continue
            sub = space.sub(1).sub(component)
            key = f"model.membrane.{group}[{component}]"
            data = expressions.parse(value, tagged.mesh, key)
            if isinstance(data, float):
                dofs = dolfinx.fem.locate_dofs_topological(sub, fdim, facets)
                constant = values.constant(tagged.mesh, 0.0)
                bcs.append(dolfinx.fem.dirichletbc(constant, dofs, sub))
                bc_values.append((constant, data))
            else:
                bc, scaled = _formula_bc(sub, fdim, facets, data)
                bcs.append(bc)
                bc_values.append(scaled)
    if not bcs:
        raise InputError(
            "model.membrane: no edge holds the in-plane displacement (rigid in-plane "
            "motions); clamp, simply support or fix at least one edge"
        )
    return bcs, bc_values


class ScaledData:
    """Dirichlet data g = λ·g₁ given by a formula: a Function whose ``value`` is set like a Constant's.

    The continuation driver scales every Dirichlet datum with the load factor by assigning
    ``datum.value = λ·(value at full load)``; here the value at full load is the array of g₁ at the
    degrees of freedom of the collapsed subspace, and the assignment writes λ·g₁ into g.
    """

    def __init__(self, function: dolfinx.fem.Function[np.float64]) -> None:
        self.function = function

    @property
    def value(self) -> np.ndarray:
        """The current nodal values of g."""
        return self.function.x.array

    @value.setter
    def value(self, array: np.ndarray) -> None:
        self.function.x.array[:] = array


def _formula_bc(
    sub: dolfinx.fem.FunctionSpace[np.float64], fdim: int, facets: np.ndarray, data: Any
) -> tuple[dolfinx.fem.DirichletBC[np.float64], Any]:
    """U_i = λ·f(x, y) on ``facets`` for a formula f: the condition and its (datum, full load)."""
    collapsed, _ = sub.collapse()
    full: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(collapsed)
    full.interpolate(dolfinx.fem.Expression(data, compat.interpolation_points(collapsed.element)))
    function: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(collapsed)
    dofs = dolfinx.fem.locate_dofs_topological((sub, collapsed), fdim, facets)
    bc: dolfinx.fem.DirichletBC[np.float64] = dolfinx.fem.dirichletbc(function, dofs, sub)
    return bc, (ScaledData(function), full.x.array.copy())


def _check_group_names(spec: FvKSpec, tagged: TaggedMesh) -> None:
    for key in ("clamped", "simply_supported", "crease", "membrane"):
        for group in getattr(spec, key):
            tagged.facets(group, f"model.{key}")


def _probe(spec: FvKSpec, mesh: dolfinx.mesh.Mesh[np.float64]) -> PointProbe:
    """The probe of w_center: ``model.probe``, or the centre of the mesh's bounding box."""
    if spec.probe is None:
        lo, hi = bounds(mesh.comm, mesh.geometry.x[:, :2])
        point = [float(c) for c in (lo + hi) / 2]
    else:
        point = [float(c) for c in spec.probe]
    try:
        return PointProbe(mesh, point)
    except ValueError:
        raise InputError(f"model.probe {point} lies outside the mesh") from None


# -- hooks of the driver -------------------------------------------------------------------------
class Deformation:
    """The shape hook: y = (x₁ + u₁, x₂ + u₂, w) ∈ [DG_k]³ of a state (w, u)."""

    def __init__(self, state: dolfinx.fem.Function[np.float64], degree: int) -> None:
        mesh = state.function_space.mesh
        space = dolfinx.fem.functionspace(mesh, ("DG", degree, (3,)))
        w, u = ufl.split(state)
        x = ufl.SpatialCoordinate(mesh)
        y = ufl.as_vector([x[0] + u[0], x[1] + u[1], w])
        self.y: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(space, name="deformation")
        self._expr: dolfinx.fem.Expression[np.float64] = dolfinx.fem.Expression(
            y, compat.interpolation_points(space.element)
        )

    def __call__(self) -> dolfinx.fem.Function[np.float64]:
        """Y of the current state."""
        self.y.interpolate(self._expr)
        return self.y


class DeflectionProbes:
    """The probes hook: ``w_max`` (signed extreme nodal value) and ``w_center`` (at a point)."""

    def __init__(self, state: dolfinx.fem.Function[np.float64], probe: PointProbe) -> None:
        self.state, self.probe = state, probe
        space, self._dofs = compat.collapse(state.function_space.sub(0))
        self.w: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(space, name="w")

    def __call__(self) -> dict[str, float]:
        """The two numbers of the current state (collective)."""
        self.w.x.array[:] = self.state.x.array[self._dofs]
        return {"w_max": signed_extreme(self.w), "w_center": self.probe(self.w)}


def start_from(state: dolfinx.fem.Function[np.float64], initial: Initial) -> None:
    """W = y₃ and u = (y₁, y₂) − x of a deformation x ↦ y(x), as the first iterate."""
    parts: list[Callable[[np.ndarray], np.ndarray]] = [
        lambda x: initial(x)[2],
        lambda x: initial(x)[:2] - x[:2],
    ]
    for index, part in enumerate(parts):
        space, dofs = compat.collapse(state.function_space.sub(index))
        function = dolfinx.fem.Function(space)
        function.interpolate(part)
        state.x.array[dofs] = function.x.array
    state.x.scatter_forward()


# -- the model -----------------------------------------------------------------------------------
@dataclass
class FvKModel:
    """An FvK plate on a mesh: facets, the mixed space, in-plane conditions and the probe.

    One driver at a time (the conditions' Constants and the options prefix are shared).
    """

    spec: FvKSpec
    facets: FacetSets
    space: dolfinx.fem.FunctionSpace[np.float64]
    bcs: list[dolfinx.fem.DirichletBC[np.float64]]
    bc_values: BCValues
    probe: PointProbe
    tip: dolfinx.fem.Function[np.float64] | None = None

    def driver(
        self, flow: object, observers: Sequence[Observer], initial: Initial | None
    ) -> Continuation:
        """Newton over the load schedule, from the unloaded flat plate or from ``initial``.

        ``flow`` (the problem's [flow] section) is ignored: FvK is not a gradient flow.
        """
        state: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(self.space, name="state")
        if initial is not None:
            start_from(state, initial)
        load_factor = values.constant(self.facets.mesh, 0.0)
        return Continuation(
            state,
            fvk_energy(state, self.facets, self.spec, load_factor, self.tip),
            self.bcs,
            load_factor,
            self.spec.load_factors,
            PREFIX,
            self.spec.snes,
            bc_values=self.bc_values,
            observers=observers,
            shape=Deformation(state, self.spec.degree),
            probes=DeflectionProbes(state, self.probe),
            hint=_HINT,
            stability=self.spec.stability_options,
            relaxation=Relaxation(tau=self.spec.relaxation_tau) if self.spec.relaxation else None,
        )

    def figures(self, driver: Continuation) -> dict[str, Any]:
        """The FvK numbers of the last converged load step (None before the first)."""
        spec = self.spec
        last = asdict(driver.history[-1]) if driver.history else {}
        w_center = last.get("w_center")
        return {
            "load": last["load_factor"] * spec.pressure
            if last and not isinstance(spec.pressure, str)
            else None,
            "pressure": spec.pressure,
            "w_max": last.get("w_max"),
            "w_center": w_center,
            "probe": [float(c) for c in self.probe.point[0, :2]],
            "w_center_over_thickness": None if w_center is None else w_center / spec.thickness,
            "D": spec.D,
        }

    def lines(self, driver: Continuation) -> list[np.ndarray]:
        """No lines are drawn on an FvK plate."""
        return []


def build_fvk(spec: FvKSpec, tagged: TaggedMesh) -> FvKModel:
    """The FvK model of ``spec`` on ``tagged`` (checks the group names on the mesh)."""
    _check_group_names(spec, tagged)
    facets = fvk_facet_sets(tagged, spec)
    space = fvk_space(tagged.mesh, spec.degree)
    bcs, bc_values = membrane_bcs(space, tagged, spec)
    tip = None
    if spec.indenter is not None:
        tip = tagged.group_function({spec.indenter: 1.0}, 0.0, key="model.indenter")
        _check_indentation(spec, tagged.mesh)
    return FvKModel(spec, facets, space, bcs, bc_values, _probe(spec, tagged.mesh), tip)


def _check_indentation(spec: FvKSpec, mesh: dolfinx.mesh.Mesh[np.float64]) -> None:
    """Warn (rank 0, stderr) when the indentation exceeds the height of the natural shape.

    The height is max w₀ − min w₀ over the mesh nodes: pushed further, the cone would invert.
    """
    shape = spec.natural_shape
    points = mesh.geometry.x[:, :2]
    local = (
        expressions.evaluate(shape, points, "model.natural_shape")
        if isinstance(shape, str)
        else np.full(len(points), float(shape))
    )
    local = np.broadcast_to(np.asarray(local, dtype=float), (len(points),))
    lo, hi = bounds(mesh.comm, local[:, None])
    height = float(hi[0] - lo[0])
    if spec.indentation > height and mesh.comm.rank == 0:
        print(
            f"dgplate: warning: model.indentation = {spec.indentation:g} exceeds the height "
            f"{height:g} of model.natural_shape: the cone would invert",
            file=sys.stderr,
            flush=True,
        )


__all__ = [
    "PENALTY",
    "SIMPLY_SUPPORTED",
    "FvKModel",
    "FvKSpec",
    "build_fvk",
    "fvk_bending_energy",
    "fvk_energy",
    "fvk_facet_sets",
    "membrane_strain",
    "plane_stress",
]
