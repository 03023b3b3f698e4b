"""Interior-penalty dG building blocks for fourth-order (bending) problems.

Notation (docs/design.md §2): jumps ``[v] = v⁺ − v⁻`` with ``n = n⁺``; averages ``{v}``;
``h_e`` the length scale of the penalties: by default (``penalty_length = "diameter"``) the mean
cell diameter of the two cells of an interior facet and the cell diameter on a boundary facet;
with ``"facet_normal"`` the cell's extent normal to the facet, |T|/|F| (:func:`penalty_lengths`).
On clamped facets the jumps carry the Nitsche data, ``[v] = v − g`` and ``[∇v] = ∇v − Φ``, and
averages are one-sided. Facets tagged ``crease`` keep the value-jump
terms only: the deformation stays continuous there while its gradient may jump.

Everything here works for scalar and vector-valued (ℝ³) unknowns, any degree k ≥ 2, on
triangles and quadrilaterals: the same UFL expressions cover all cases.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypedDict, Unpack

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import compat, mpi, values
from dgplate.compat import Constant, Form, Mesh, MeshTags
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh, local_entities, make_tags
from dgplate.schema import option

#: Facet-set ids of the measures ``FacetSets.dS`` / ``FacetSets.ds``.
SMOOTH, CREASE, CLAMPED, FREE = 1, 2, 3, 4

#: A coefficient of the forms: a number, a Constant, a DG0 field or a UFL expression.
Coefficient = float | Expr


#: The length scales h_e of the penalties (``model.penalty_length``), the default first.
PENALTY_LENGTHS = ("diameter", "facet_normal")
#: The help text of ``model.penalty_length`` in the plate models' schemas.
PENALTY_LENGTH_HELP = (
    f"length h of the penalties: {' or '.join(PENALTY_LENGTHS)} (|T|/|F|, for thin triangles)"
)


@dataclass(frozen=True)
class Penalty:
    """Penalty parameters: γ₀ scales h⁻³[y]·[y], γ₁ scales h⁻ᵖ[∇y]:[∇y].

    ``gradient_power`` p = 1 is the standard interior-penalty method. p > 1 over-penalises the
    gradient jumps: still consistent (smooth solutions have none), and it keeps a one-cell
    layer along free edges from trading metric error for energy (docs/bilayer.md, cylinder).
    In the forms γ₀ and γ₁ are Constants (:meth:`constants`, values: no recompilation when
    they change), p a literal (it chooses the form, see :mod:`dgplate.values`). The limits
    (γ₀, γ₁ > 0 and finite, 1 ≤ p ≤ 3) are declared here for every model's
    ``penalty`` table (:func:`dgplate.schema.from_dict`).
    """

    gamma0: float = option(5000.0, "γ₀, the weight of h⁻³[y]·[y]", gt=0)
    gamma1: float = option(1100.0, "γ₁, the weight of h⁻ᵖ[∇y]:[∇y]", gt=0)
    gradient_power: float = option(
        1.0, "p: 1 is the standard method, p > 1 over-penalises gradient jumps", ge=1, le=3
    )

    def constants(self, mesh: Mesh) -> tuple[Constant, Constant]:
        """γ₀ and γ₁ as Constants of ``mesh``, for the forms."""
        return values.constant(mesh, self.gamma0), values.constant(mesh, self.gamma1)

    def gradient_weight(self, h: Expr, gamma1: Expr) -> Expr:
        """γ₁ h⁻ᵖ, the weight of ½[∇y]:[∇y] on a facet of size h (γ₁ from :meth:`constants`)."""
        power = self.gradient_power
        weight: Expr = gamma1 / (h if power == 1 else h**power)
        return weight


def cell_size(mesh: Mesh) -> Expr:
    """The h of the dG forms: ``ufl.CellDiameter``, or a DG0 field of ``mesh.h`` on curved cells.

    FFCx cannot evaluate CellDiameter on curved cells (gmsh ``order = 2``); the field holds the
    same number as CellDiameter on affine cells. Curved creases need curved cells: see
    docs/creases.md.
    """
    if compat.coordinate_element_degree(mesh) == 1:
        diameter: Expr = ufl.CellDiameter(mesh)
        return diameter
    space = dolfinx.fem.functionspace(mesh, ("DG", 0))
    tdim = mesh.topology.dim
    cells = local_entities(mesh, tdim)
    field: compat.Function = dolfinx.fem.Function(space, name="h")
    field.x.array[space.dofmap.list[cells, 0]] = mesh.h(tdim, cells)
    return field


def penalty_lengths(mesh: Mesh) -> tuple[Expr, Expr]:
    """(c, f) with the facet-normal length h_F = c/f of a cell T at its facet F: |T|/|F|.

    On a cell whose diameter is set by a long edge while its height normal to a facet is small
    (thin triangles, e.g. at the centre of a polar mesh) the diameter overestimates the length
    that the inverse trace inequality needs, and γ/h_e may be too weak for coercivity; |T|/|F|
    is the length of the penalty for simplices of Shahbazi (*An explicit expression for the
    penalty parameter of the interior penalty method*, J. Comput. Phys. 205 (2005)) and of
    Epshteyn & Rivière (J. Comput. Appl. Math. 206 (2007)). On affine triangles c = |T| and
    f = |F| (``ufl.CellVolume``, ``ufl.FacetArea``). UFL lowers those on affine simplices
    only (FFCx has no code for them), so on quadrilaterals and curved cells c is a DG0 field of the cell's smallest such
    length, |T| over its longest facet (|T| integrated, the facet by its vertex distance), and
    f = 1: a cell-wise, more cautious h_F.
    """
    triangle = mesh.topology.cell_type == dolfinx.mesh.CellType.triangle
    if triangle and compat.coordinate_element_degree(mesh) == 1:
        return ufl.CellVolume(mesh), ufl.FacetArea(mesh)
    space = dolfinx.fem.functionspace(mesh, ("DG", 0))
    volumes = dolfinx.fem.assemble_vector(dolfinx.fem.form(ufl.TestFunction(space) * ufl.dx))
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim, tdim - 1)
    volumes.scatter_forward()  # the ghost cells' volumes (cell integrals run on owned cells)
    cells = local_entities(mesh, tdim)
    connectivity = mesh.topology.connectivity(tdim, tdim - 1)
    per_cell = int(connectivity.offsets[1]) if cells.size else 1  # one cell type per mesh
    cell_facets = connectivity.array.reshape(-1, per_cell)
    longest = mesh.h(tdim - 1, cell_facets[cells].ravel()).reshape(cells.size, -1).max(axis=1)
    dofs = space.dofmap.list[cells, 0]
    field: compat.Function = dolfinx.fem.Function(space, name="h_F")
    field.x.array[dofs] = volumes.array[dofs] / longest
    return field, ufl.as_ufl(1.0)


def cell_measure(
    mesh: Mesh, quadrature_degree: int | None = None, subdomain_data: MeshTags | None = None
) -> ufl.Measure:
    """The cell measure dx of ``mesh``, with a quadrature degree and cell tags if given."""
    return ufl.Measure(
        "dx", domain=mesh, subdomain_data=subdomain_data, metadata=_quadrature(quadrature_degree)
    )


def _quadrature(degree: int | None) -> dict[str, int]:
    """The metadata of a measure with the given quadrature degree (None: FFCx's choice)."""
    return {} if degree is None else {"quadrature_degree": degree}


@dataclass
class FacetSets:
    """The facets Γ_h of the dG forms, split into smooth interior, crease and clamped facets.

    The measures ``dS`` and ``ds`` carry the facet-set ids SMOOTH, CREASE, CLAMPED and FREE;
    ``n`` is the facet normal and ``h`` the cell size (:func:`cell_size`); the penalties use
    ``h_interior`` and ``h_boundary``, which depend on ``penalty_length`` (:data:`PENALTY_LENGTHS`).
    The methods that return measures take an optional quadrature degree.
    """

    mesh: Mesh
    tags: MeshTags
    num_clamped: int  # global number of clamped boundary facets
    num_crease: int  # global number of crease facets
    penalty_length: str = "diameter"

    def __post_init__(self) -> None:
        self.dx = ufl.Measure("dx", domain=self.mesh)
        self.dS = ufl.Measure("dS", domain=self.mesh, subdomain_data=self.tags)
        self.ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.tags)
        self.n: Expr = ufl.FacetNormal(self.mesh)
        self.h = cell_size(self.mesh)
        self._normal: tuple[Expr, Expr] | None = None
        if self.penalty_length == "facet_normal":
            self._normal = penalty_lengths(self.mesh)

    @property
    def has_clamped(self) -> bool:
        """Whether any boundary facet is clamped."""
        return self.num_clamped > 0

    @property
    def h_interior(self) -> Expr:
        """h_e on interior facets: the mean of the two cells' diameters, or min(|T±|)/|F|."""
        if self._normal is None:
            mean: Expr = ufl.avg(self.h)
            return mean
        cell, facet = self._normal
        smaller: Expr = ufl.min_value(cell("+"), cell("-")) / facet("+")
        return smaller

    @property
    def h_boundary(self) -> Expr:
        """h_e on boundary facets: the cell's diameter, or |T|/|F|."""
        if self._normal is None:
            return self.h
        cell, facet = self._normal
        length: Expr = cell / facet
        return length

    def _interior(self, degree: int | None) -> ufl.Measure:
        return self.dS if degree is None else self.dS.reconstruct(metadata=_quadrature(degree))

    def dS_smooth(self, degree: int | None = None) -> ufl.Measure:
        """Interior facets that carry gradient-jump terms (all but creases)."""
        smooth: ufl.Measure = self._interior(degree)(SMOOTH)
        return smooth

    def dS_all(self, degree: int | None = None) -> ufl.Measure:
        """All interior facets (value-jump terms)."""
        dS = self._interior(degree)
        all_interior: ufl.Measure = dS(SMOOTH) + dS(CREASE) if self.num_crease else dS(SMOOTH)
        return all_interior

    def ds_clamped(self, degree: int | None = None) -> ufl.Measure:
        """Clamped boundary facets (Nitsche terms)."""
        ds = self.ds if degree is None else self.ds.reconstruct(metadata=_quadrature(degree))
        clamped: ufl.Measure = ds(CLAMPED)
        return clamped


def facet_sets(
    tagged: TaggedMesh,
    clamped: Sequence[str] = (),
    crease: Sequence[str] = (),
    penalty_length: str = "diameter",
) -> FacetSets:
    """Classify the facets of ``tagged`` by the named clamped and crease groups.

    Clamped groups must lie on the boundary, crease groups in the interior: anything else, or
    a name the mesh has no group of, is an ``InputError`` naming the group (and the key,
    ``model.clamped`` or ``model.crease``). ``penalty_length`` chooses h_e (:class:`FacetSets`).
    Collective on the mesh communicator.
    """
    mesh = tagged.mesh
    tdim = mesh.topology.dim
    fdim = tdim - 1
    mesh.topology.create_connectivity(fdim, tdim)
    facets = local_entities(mesh, fdim)
    boundary = np.zeros(facets.size, dtype=bool)
    boundary[dolfinx.mesh.exterior_facet_indices(mesh.topology)] = True
    kinds = np.where(boundary, FREE, SMOOTH).astype(np.int32)
    num_clamped = _mark_groups(tagged, clamped, boundary, kinds, on_boundary=True)
    num_crease = _mark_groups(tagged, crease, boundary, kinds, on_boundary=False)
    tags = make_tags(mesh, fdim, facets, kinds)
    return FacetSets(mesh, tags, num_clamped, num_crease, penalty_length)


def _mark_groups(
    tagged: TaggedMesh,
    names: Sequence[str],
    boundary: np.ndarray,
    kinds: np.ndarray,
    on_boundary: bool,
) -> int:
    """Mark the facets of the named groups CLAMPED (on the boundary) or CREASE (inside).

    ``kinds`` holds the facet-set id of each local facet and is updated; returns the global
    number of facets marked. A group with facets on the wrong side, or none, is an InputError.
    """
    what = "clamped" if on_boundary else "crease"
    num_owned = tagged.mesh.topology.index_map(tagged.mesh.topology.dim - 1).size_local
    total = 0
    for name in names:
        facets = tagged.facets(name, f"model.{what}")
        wrong = facets[boundary[facets] != on_boundary]
        local = [np.count_nonzero(wrong < num_owned), np.count_nonzero(facets < num_owned)]
        wrong_owned, owned = mpi.allreduce_array(tagged.comm, local).astype(int)
        if wrong_owned:
            where = "interior" if on_boundary else "boundary"
            raise InputError(
                f"{what} group '{name}' contains {wrong_owned} {where} facet(s): "
                f"{what} faces must lie {'on the boundary' if on_boundary else 'inside'}"
            )
        if owned == 0:
            raise InputError(f"{what} group '{name}' has no facets in the mesh")
        kinds[facets] = CLAMPED if on_boundary else CREASE
        total += int(owned)
    return total


def hessian(v: Expr) -> Expr:
    """D²v: shape (2, 2) for scalar v, (3, 2, 2) for v in ℝ³."""
    D2: Expr = ufl.grad(ufl.grad(v))
    return D2


def hessian_norm(v: Expr) -> Expr:
    """|D²v|, the Frobenius norm of the broken Hessian (cell-wise)."""
    D2 = hessian(v)
    norm: Expr = ufl.sqrt(ufl.inner(D2, D2))
    return norm


def grad_laplacian(v: Expr) -> Expr:
    """∇Δv: shape (2,) for scalar v, (3, 2) for v in ℝ³."""
    G3: Expr = ufl.grad(ufl.div(ufl.grad(v)))
    return G3


def jump(v: Expr) -> Expr:
    """[v] = v⁺ − v⁻ on interior facets."""
    difference: Expr = v("+") - v("-")
    return difference


class BendingData(TypedDict, total=False):
    """The data of ½ a_h(y, y) besides the penalty, passed by keyword.

    ``mu``: the cell-wise rigidity μ (default 1); ``g`` and ``Phi``: the Nitsche data g, Φ on
    clamped facets (needed when there are any); ``metric``: a target metric G (2×2, SPD) that
    weights the Hessian as G^{-1/2} D²y G^{-1/2} (:func:`metric_weighted`; None: G = I).
    """

    mu: Coefficient | None
    g: Coefficient | None
    Phi: Expr | None
    metric: Expr | None


def bending_energy(
    y: Expr, facets: FacetSets, penalty: Penalty, **data: Unpack[BendingData]
) -> ufl.Form:
    """½ a_h(y, y) of docs/design.md §2 as a UFL functional, Nitsche data g, Φ on clamped facets.

    ``mu`` (cell-wise rigidity, UFL scalar) weights every term; averages use {μ ·} and the
    penalties {μ}. ``ufl.derivative`` of this functional gives the symmetric interior-penalty
    residual and matrix, so no bilinear form is written twice.

    With a target ``metric`` G the broken energy is ½∫μ|G^{-1/2}D²y G^{-1/2}|² and the
    consistency terms are those of ⟨D²y, T⟩ with T = μ 𝒞D²y (:func:`metric_weighted`), the
    symmetric interior-penalty method of the operator with the coefficient 𝒞; the penalties
    are left unweighted (as the stabilisation of the LDG method of Bonito, Guignard, Nochetto
    and Yang, J. Comput. Phys. 2022, which penalises the plain jumps): they vanish for smooth
    y whatever G, and for G near I their weights keep coercivity (they need γ ≳ |G⁻¹|²). The
    integrals then have the quadrature degree :func:`metric_quadrature` (UFL's estimate for a
    formula G is far too high).
    """
    mu = data.get("mu")
    mu = 1.0 if mu is None else mu
    D2 = hessian(y)
    metric = data.get("metric")
    energy: ufl.Form
    if metric is not None:
        degree = metric_quadrature(y)
        T = mu * metric_weighted(D2, metric)
        energy = distributional_hessian(y, T, facets, data.get("g"), data.get("Phi"), degree)
        energy -= 0.5 * ufl.inner(D2, T) * cell_measure(facets.mesh, degree)
    else:
        # ⟨D²y, μD²_h y⟩ − ½∫μ|D²_h y|²: the broken energy and the consistency terms
        # −{μD²y n}·[∇y] + {μ∇Δy·n}·[y] (those of the distributional Hessian D²y)
        energy = distributional_hessian(y, mu * D2, facets, data.get("g"), data.get("Phi"))
        energy -= 0.5 * mu * ufl.inner(D2, D2) * facets.dx
    energy += jump_penalty(y, facets, penalty, **data)
    return energy


def metric_weighted(D2: Expr, metric: Expr) -> Expr:
    """𝒞D²y = G⁻¹ D²y_k G⁻¹ for each component k: then D²y : 𝒞D²y = Σ_k |G^{-1/2}D²y_k G^{-1/2}|².

    For symmetric A = G^{-1/2}: |A H A|² = tr(A H A A H A) = H : G⁻¹HG⁻¹, so the energy of
    the weighted Hessian needs G⁻¹ only (UFL's closed-form inverse), no square root of G.

    Args:
        D2: the Hessian D²y, shape (3, 2, 2).
        metric: the target metric G, a UFL 2×2 expression.

    Returns:
        The tensor (G⁻¹D²y_k G⁻¹)_k, shape (3, 2, 2).
    """
    inverse = ufl.inv(metric)
    k, a, b, i, j = ufl.indices(5)
    weighted: Expr = ufl.as_tensor(inverse[a, i] * D2[k, i, j] * inverse[j, b], (k, a, b))
    return weighted


def explicit_quadrature(degree: int) -> int:
    """3k + 2, the quadrature degree of the nonlinear explicit terms of y of degree k.

    The curvature coupling and the Gauss-curvature penalty hold the unit normal and II,
    rational in ∇y and D²y: FFCx's estimate of their degree is far too high.

    Args:
        degree: the degree k of y.

    Returns:
        The quadrature degree.
    """
    return 3 * degree + 2


def metric_quadrature(y: Expr) -> int:
    """The quadrature degree of the metric-weighted energy of y: 2k + 2 for y of degree k.

    Args:
        y: the deformation (a Function or an Argument of its space).

    Returns:
        The degree (k: the element's embedded superdegree, as :func:`dgplate.measure.analysis.l1_norms`).
    """
    degree: int = y.ufl_function_space().ufl_element().embedded_superdegree  # type: ignore[attr-defined]
    return 2 * degree + 2


def jump_penalty(
    y: Expr, facets: FacetSets, penalty: Penalty, **data: Unpack[BendingData]
) -> ufl.Form:
    """½Σ_e γ₁h⁻ᵖ{μ}|[∇y]|² + ½Σ_e γ₀h⁻³{μ}|[y]|², the penalties of the bending energy.

    Gradient jumps on smooth interior and clamped facets, value jumps on all interior and
    clamped facets; on clamped facets the jumps carry the Nitsche data g, Φ.
    """
    mu = data.get("mu")
    mu = 1.0 if mu is None else mu
    gamma0, gamma1 = penalty.constants(facets.mesh)
    h_e = facets.h_interior
    jgrad, jval = jump(ufl.grad(y)), jump(y)
    energy: ufl.Form = (
        0.5 * penalty.gradient_weight(h_e, gamma1) * ufl.avg(mu) * ufl.inner(jgrad, jgrad)
    ) * facets.dS_smooth()
    energy += 0.5 * gamma0 * ufl.avg(mu) / h_e**3 * ufl.inner(jval, jval) * facets.dS_all()
    if facets.has_clamped:
        g, Phi = _clamped(data)
        h = facets.h_boundary
        bgrad, bval = ufl.grad(y) - Phi, y - g
        energy += (
            0.5 * penalty.gradient_weight(h, gamma1) * mu * ufl.inner(bgrad, bgrad)
            + 0.5 * gamma0 * mu / h**3 * ufl.inner(bval, bval)
        ) * facets.ds_clamped()
    return energy


def _clamped(data: BendingData) -> tuple[Coefficient, Expr]:
    """The Nitsche data (g, Φ) of ``data`` (a model with clamped faces always gives them)."""
    g, Phi = data.get("g"), data.get("Phi")
    assert g is not None and Phi is not None, "clamped faces need boundary data g and Φ"
    return g, Phi


def distributional_hessian(
    y: Expr,
    T: Expr,
    facets: FacetSets,
    g: Coefficient | None = None,
    Phi: Expr | None = None,
    degree: int | None = None,
) -> ufl.Form:
    """⟨D²y, T⟩, the distributional Hessian of the broken field y tested with a broken T.

    ⟨D²y, T⟩ = Σ_T ∫ D²y : T − Σ_e ∫ [∇y] : {T} n + Σ_e ∫ [y] · {div T} n, the gradient-jump
    term on smooth facets only (creases may fold), and on clamped facets the jumps against
    the Nitsche data, [y] = y − g, [∇y] = ∇y − Φ, with one-sided T. For y smooth with the data
    it is ∫ D²y : T. T has the shape of D²y ((3, 2, 2) for y in ℝ³); it is a form linear in T
    and affine in y, with the quadrature degree ``degree`` (None: FFCx's choice).
    """
    n = facets.n
    form: ufl.Form = ufl.inner(hessian(y), T) * cell_measure(facets.mesh, degree)
    form -= ufl.inner(jump(ufl.grad(y)), ufl.dot(ufl.avg(T), n("+"))) * facets.dS_smooth(degree)
    form += ufl.inner(jump(y), ufl.dot(ufl.avg(ufl.div(T)), n("+"))) * facets.dS_all(degree)
    if facets.has_clamped:
        g, Phi = _clamped({"g": g, "Phi": Phi})
        ds = facets.ds_clamped(degree)
        form -= ufl.inner(ufl.grad(y) - Phi, ufl.dot(T, n)) * ds
        form += ufl.inner(y - g, ufl.dot(ufl.div(T), n)) * ds
    return form


def h2_metric(w: Expr, v: Expr, facets: FacetSets, l2: bool = False) -> ufl.Form:
    """The discrete H² inner product (w, v)_* with homogeneous jumps (docs/design.md §3).

    Gradient jumps are left out on creases, as in the energy. ``l2`` adds the L² product,
    needed when nothing is clamped (rigid motions).
    """
    h = facets.h_boundary
    form: ufl.Form = ufl.inner(hessian(w), hessian(v)) * facets.dx
    form += ufl.inner(jump(ufl.grad(w)), jump(ufl.grad(v))) / facets.h_interior * facets.dS_smooth()
    form += ufl.inner(jump(w), jump(v)) / facets.h_interior**3 * facets.dS_all()
    if facets.has_clamped:
        form += (
            ufl.inner(ufl.grad(w), ufl.grad(v)) / h + ufl.inner(w, v) / h**3
        ) * facets.ds_clamped()
    if l2:
        form += ufl.inner(w, v) * facets.dx
    return form


def broken_norms(error: Expr, facets: FacetSets, degree: int | None = None) -> dict[str, float]:
    """Broken H², H¹ and L² (semi)norms of a UFL expression, summed over the communicator."""
    dx = cell_measure(facets.mesh, degree)
    out = {}
    for key, expr in (("H2", hessian(error)), ("H1", ufl.grad(error)), ("L2", error)):
        square = integral(dolfinx.fem.form(ufl.inner(expr, expr) * dx), facets.mesh.comm)
        out[key] = float(np.sqrt(square))
    return out


def integral(form: Form, comm: MPI.Comm) -> float:
    """The value of a compiled scalar form on the whole mesh (collective on ``comm``)."""
    local = dolfinx.fem.assemble_scalar(form)
    return mpi.global_sum(comm, float(np.real(local)))
