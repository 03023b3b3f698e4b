"""Interior-penalty dG building blocks for fourth-order (bending) problems.

Notation (docs/design.md §2): jumps ``[v] = v⁺ − v⁻`` with ``n = n⁺``; averages ``{v}``;
``h_e`` the mean cell diameter of the two cells of an interior face and the cell diameter on a
boundary face. On clamped faces the jumps carry the Nitsche data, ``[v] = v − g`` and
``[∇v] = ∇v − Φ``, and averages are one-sided. Faces tagged ``crease`` keep the value-jump
terms only: the deformation stays continuous there while its gradient may jump.

Everything here works for scalar and vector-valued (ℝ³) unknowns, any degree k ≥ 2, on
triangles and quadrilaterals: the same UFL expressions cover all cases.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.mesh
import numpy as np
import ufl

from dgplate import values
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh, _make_tags

#: Face-set ids of the measure ``FacetSets.dS`` / ``FacetSets.ds``.
SMOOTH, CREASE, CLAMPED, FREE = 1, 2, 3, 4


#: The keys of a penalty table in a problem file (``model.penalty``).
PENALTY_KEYS = ("gamma0", "gamma1", "gradient_power")


@dataclass(frozen=True)
class Penalty:
    """Penalty parameters: γ₀ scales h⁻³[y]·[y], γ₁ scales h⁻ᵖ[∇y]:[∇y].

    ``gradient_power`` p = 1 is the standard interior-penalty method. p > 1 over-penalises the
    gradient jumps: still consistent (smooth solutions have none), and it keeps a one-cell
    layer along free edges from trading metric error for energy (docs/bilayer.md, cylinder).
    In the forms γ₀ and γ₁ are Constants (:meth:`constants`, values: no recompilation when
    they change), p a literal (it chooses the form, see :mod:`dgplate.values`). The limits
    (γ₀, γ₁ > 0 and finite, 1 ≤ p ≤ 3) are checked here for every model.
    """

    gamma0: float = 5000.0
    gamma1: float = 1100.0
    gradient_power: float = 1.0

    def __post_init__(self) -> None:
        _check_penalty_limits(asdict(self), "penalty")

    @classmethod
    def from_table(
        cls, table: Mapping[str, Any], key: str = "model.penalty", defaults: Penalty | None = None
    ) -> Penalty:
        """The penalty of a problem file's table; missing keys keep ``defaults``' values.

        Unknown keys, values that are no numbers and values out of the limits are one-line
        ``InputError``s naming ``key.<name>``.
        """
        unknown = sorted(set(table) - set(PENALTY_KEYS))
        if unknown:
            raise InputError(f"unknown key {key}.{unknown[0]} (known: {', '.join(PENALTY_KEYS)})")
        for name, value in table.items():
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InputError(f"{key}.{name} must be a number, got {value!r}")
        values = {**asdict(defaults or cls()), **{k: float(v) for k, v in table.items()}}
        _check_penalty_limits(values, key)
        return cls(**values)

    def constants(
        self, mesh: dolfinx.mesh.Mesh
    ) -> tuple[dolfinx.fem.Constant, dolfinx.fem.Constant]:
        """γ₀ and γ₁ as Constants of ``mesh``, for the forms."""
        return values.constant(mesh, self.gamma0), values.constant(mesh, self.gamma1)

    def gradient_weight(self, h: Any, gamma1: Any) -> Any:
        """γ₁ h⁻ᵖ, the weight of ½[∇y]:[∇y] on a face of size h (γ₁ from :meth:`constants`)."""
        power = self.gradient_power
        return gamma1 / (h if power == 1 else h**power)


def _check_penalty_limits(values: Mapping[str, float], key: str) -> None:
    """γ₀, γ₁ > 0 and finite, 1 ≤ p ≤ 3: the one place of the penalty limits."""
    for name in ("gamma0", "gamma1"):
        value = values[name]
        if not (value > 0 and math.isfinite(value)):
            raise InputError(f"{key}.{name} must be a number > 0, got {value!r}")
    power = values["gradient_power"]
    if not 1.0 <= power <= 3.0:
        raise InputError(f"{key}.gradient_power must be in [1, 3], got {power!r}")


def cell_size(mesh):
    """H of the dG forms: ``ufl.CellDiameter``, or on curved cells (gmsh ``order = 2``) a DG0
    field of ``mesh.h``, since FFCx cannot evaluate CellDiameter there (same number on affine
    cells). Curved creases need curved cells: see docs/creases.md.
    """
    geometry = mesh.geometry  # DOLFINx 0.11 deprecates geometry.cmap for cmaps[0]
    cmap = geometry.cmaps[0] if hasattr(geometry, "cmaps") else geometry.cmap
    if cmap.degree == 1:
        return ufl.CellDiameter(mesh)
    import dolfinx.fem

    space = dolfinx.fem.functionspace(mesh, ("DG", 0))
    tdim = mesh.topology.dim
    cell_map = mesh.topology.index_map(tdim)
    cells = np.arange(cell_map.size_local + cell_map.num_ghosts, dtype=np.int32)
    field = dolfinx.fem.Function(space, name="h")
    field.x.array[space.dofmap.list[cells, 0]] = mesh.h(tdim, cells)
    return field


@dataclass
class FacetSets:
    """The faces Γ_h of the dG forms, split into smooth interior, crease and clamped faces."""

    mesh: dolfinx.mesh.Mesh
    tags: dolfinx.mesh.MeshTags
    num_clamped: int  # global number of clamped boundary facets
    num_crease: int  # global number of crease facets

    def __post_init__(self) -> None:
        self.dx = ufl.Measure("dx", domain=self.mesh)
        self.dS = ufl.Measure("dS", domain=self.mesh, subdomain_data=self.tags)
        self.ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.tags)
        self.n = ufl.FacetNormal(self.mesh)
        self.h = cell_size(self.mesh)

    @property
    def has_clamped(self) -> bool:
        return self.num_clamped > 0

    @property
    def h_interior(self):
        return ufl.avg(self.h)

    def dS_smooth(self):
        """Interior faces that carry gradient-jump terms (all but creases)."""
        return self.dS(SMOOTH)

    def dS_all(self):
        """All interior faces (value-jump terms)."""
        return self.dS(SMOOTH) + self.dS(CREASE) if self.num_crease else self.dS(SMOOTH)

    def ds_clamped(self):
        return self.ds(CLAMPED)


def facet_sets(
    tagged: TaggedMesh, clamped: Sequence[str] = (), crease: Sequence[str] = ()
) -> FacetSets:
    """Classify the facets of ``tagged`` by the named clamped and crease groups.

    Clamped groups must lie on the boundary, crease groups in the interior: anything else is an
    ``InputError`` naming the group. Collective on the mesh communicator.
    """
    mesh = tagged.mesh
    comm = mesh.comm
    tdim = mesh.topology.dim
    fdim = tdim - 1
    mesh.topology.create_connectivity(fdim, tdim)
    fmap = mesh.topology.index_map(fdim)
    num_local = fmap.size_local + fmap.num_ghosts
    boundary = np.zeros(num_local, dtype=bool)
    boundary[dolfinx.mesh.exterior_facet_indices(mesh.topology)] = True
    values = np.where(boundary, FREE, SMOOTH).astype(np.int32)

    def check(names: Sequence[str], on_boundary: bool, what: str) -> int:
        total = 0
        for name in names:
            facets = tagged.facets(name)
            wrong = facets[boundary[facets] != on_boundary]
            wrong_owned = int(np.count_nonzero(wrong < fmap.size_local))
            owned = int(np.count_nonzero(facets < fmap.size_local))
            wrong_owned, owned = comm.allreduce(np.array([wrong_owned, owned]), op=MPI.SUM)
            if wrong_owned:
                where = "interior" if on_boundary else "boundary"
                raise InputError(
                    f"{what} group '{name}' contains {wrong_owned} {where} facet(s): "
                    f"{what} faces must lie {'on the boundary' if on_boundary else 'inside'}"
                )
            if owned == 0:
                raise InputError(f"{what} group '{name}' has no facets in the mesh")
            values[facets] = CLAMPED if on_boundary else CREASE
            total += owned
        return int(total)

    num_clamped = check(clamped, True, "clamped")
    num_crease = check(crease, False, "crease")
    tags = _make_tags(mesh, fdim, np.arange(num_local, dtype=np.int32), values)
    return FacetSets(mesh, tags, num_clamped, num_crease)


def hessian(v):
    """D²v: shape (2, 2) for scalar v, (3, 2, 2) for v in ℝ³."""
    return ufl.grad(ufl.grad(v))


def grad_laplacian(v):
    """∇Δv: shape (2,) for scalar v, (3, 2) for v in ℝ³."""
    return ufl.grad(ufl.div(ufl.grad(v)))


def jump(v):
    return v("+") - v("-")


def bending_energy(
    y,
    faces: FacetSets,
    penalty: Penalty,
    mu=None,
    g=None,
    Phi=None,
):
    """½ a_h(y, y) of docs/design.md §2 as a UFL functional, Nitsche data g, Φ on clamped faces.

    ``mu`` (cell-wise rigidity, UFL scalar) weights every term; averages use {μ ·} and the
    penalties {μ}. ``ufl.derivative`` of this functional gives the symmetric interior-penalty
    residual and matrix, so no bilinear form is written twice.
    """
    mu = 1.0 if mu is None else mu
    n, h = faces.n, faces.h
    gamma0, gamma1 = penalty.constants(faces.mesh)
    D2, G3 = hessian(y), grad_laplacian(y)
    energy = 0.5 * mu * ufl.inner(D2, D2) * faces.dx

    # smooth interior faces: gradient-jump consistency and penalty
    jgrad = jump(ufl.grad(y))
    moment_n = ufl.dot(ufl.avg(mu * D2), n("+"))
    weight = penalty.gradient_weight(faces.h_interior, gamma1)
    energy += (
        -ufl.inner(moment_n, jgrad) + 0.5 * weight * ufl.avg(mu) * ufl.inner(jgrad, jgrad)
    ) * faces.dS_smooth()

    # all interior faces (creases included): value-jump consistency and penalty
    jval = jump(y)
    shear_n = ufl.dot(ufl.avg(mu * G3), n("+"))
    energy += (
        ufl.inner(shear_n, jval)
        + 0.5 * gamma0 * ufl.avg(mu) / faces.h_interior**3 * ufl.inner(jval, jval)
    ) * faces.dS_all()

    if faces.has_clamped:
        if g is None or Phi is None:
            raise InputError("clamped faces need boundary data g and Φ")
        bgrad = ufl.grad(y) - Phi
        bval = y - g
        energy += (
            -ufl.inner(mu * ufl.dot(D2, n), bgrad)
            + 0.5 * penalty.gradient_weight(h, gamma1) * mu * ufl.inner(bgrad, bgrad)
            + ufl.inner(mu * ufl.dot(G3, n), bval)
            + 0.5 * gamma0 * mu / h**3 * ufl.inner(bval, bval)
        ) * faces.ds_clamped()
    return energy


def h2_metric(w, v, faces: FacetSets, l2: bool = False):
    """The discrete H² inner product (w, v)_* with homogeneous jumps (docs/design.md §3).

    Gradient jumps are left out on creases, as in the energy. ``l2`` adds the L² product,
    needed when nothing is clamped (rigid motions).
    """
    h = faces.h
    form = ufl.inner(hessian(w), hessian(v)) * faces.dx
    form += ufl.inner(jump(ufl.grad(w)), jump(ufl.grad(v))) / faces.h_interior * faces.dS_smooth()
    form += ufl.inner(jump(w), jump(v)) / faces.h_interior**3 * faces.dS_all()
    if faces.has_clamped:
        form += (
            ufl.inner(ufl.grad(w), ufl.grad(v)) / h + ufl.inner(w, v) / h**3
        ) * faces.ds_clamped()
    if l2:
        form += ufl.inner(w, v) * faces.dx
    return form


def broken_norms(error, faces: FacetSets, degree: int | None = None) -> dict[str, float]:
    """Broken H², H¹ and L² (semi)norms of a UFL expression, summed over the communicator."""
    from dolfinx.fem import assemble_scalar, form

    md = {} if degree is None else {"quadrature_degree": degree}
    dx = ufl.Measure("dx", domain=faces.mesh, metadata=md)
    comm = faces.mesh.comm
    out = {}
    for key, expr in (("H2", hessian(error)), ("H1", ufl.grad(error)), ("L2", error)):
        local = assemble_scalar(form(ufl.inner(expr, expr) * dx))
        out[key] = float(np.sqrt(comm.allreduce(local, op=MPI.SUM)))
    return out
