"""``model.metric``: the target metric G of a prestrained plate (docs/prestrain.md).

A prestrained (non-Euclidean) plate is constrained to ∇yᵀ∇y = G instead of the isometry
∇yᵀ∇y = I, G a symmetric positive definite 2×2 field on ω, the first fundamental form the
plate's material wants (Bonito, Guignard, Nochetto and Yang, J. Comput. Phys. 2022). Its
entries are numbers, formulas in x, y (:mod:`dgplate.expressions`), or tables {cell group =
number or formula} (the entry's default on the cells of no listed group); G must be finite and
positive definite at every geometry node and midpoint of every cell, with the values of that
cell's group, else an ``InputError`` naming ``model.metric`` and the point.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import expressions, values
from dgplate.compat import Array, Indices, Mesh, entities_to_geometry, geometry_dofmap
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh
from dgplate.schema import option

#: One entry of G: a number, a formula, or {cell group = number or formula}.
Entry = float | str | dict[str, float | str]

#: ``dgplate schema``'s line for ``model.metric``.
HELP = (
    "target metric G of a prestrained plate, the constraint ∇yᵀ∇y = G instead of I "
    "(docs/prestrain.md): {g11 = .., g12 = .., g22 = ..}, numbers or formulas in x, y (or r, theta), "
    "or tables {cell group = number or formula}; {} none"
)


@dataclass(frozen=True)
class MetricSpec:
    """``model.metric``: the entries of the symmetric G (each a number or a formula in x, y)."""

    g11: Entry = option(1.0, "G₁₁: a number, a formula in x, y (or r, theta), or {group = ..}")
    g12: Entry = option(0.0, "G₁₂ = G₂₁: a number, a formula, or {group = ..}")
    g22: Entry = option(1.0, "G₂₂: a number, a formula, or {group = ..}")

    def entries(self) -> dict[str, Entry]:
        """The three entries by name.

        Returns:
            ``{"g11": …, "g12": …, "g22": …}``, each a number, a formula or a group table.
        """
        return {"g11": self.g11, "g12": self.g12, "g22": self.g22}

    def groups(self) -> set[str]:
        """The cell groups that the entries' tables name (empty: no entry is a table)."""
        return {group for v in self.entries().values() if isinstance(v, dict) for group in v}

    def validate(self, key: str) -> None:
        """The formulas, without a mesh (syntax, names, constant parts).

        Args:
            key: the table's dotted key (``model.metric``), as named in messages.
        """
        for name, value in self.entries().items():
            for where, text in _pieces(value, f"{key}.{name}"):
                expressions.check(text, where)


#: The entries' defaults, the value of a table's entry on the cells of no listed group.
DEFAULTS: dict[str, float] = {"g11": 1.0, "g12": 0.0, "g22": 1.0}


def _pieces(value: Entry, key: str) -> list[tuple[str, float | str]]:
    """(key, number or formula) of an entry: itself, or each group's value of its table."""
    if isinstance(value, dict):
        return [(f"{key}.{group}", text) for group, text in value.items()]
    return [(key, value)]


def target_metric(
    spec: MetricSpec, mesh: Mesh, key: str = "model.metric", tagged: TaggedMesh | None = None
) -> Expr:
    """G as a UFL 2×2 expression (numbers as Constants), checked SPD on the mesh (collective).

    Args:
        spec: the validated ``model.metric``.
        mesh: the plate's mesh.
        key: the key named in error messages.
        tagged: the mesh's cell groups (needed when an entry is a group table).

    Returns:
        The matrix [[g11, g12], [g12, g22]]; a table's entry is Σ_groups 1_group·value
        + (1 − Σ 1_group)·default, 1_group the group's DG0 indicator.
    """
    if spec.groups() and tagged is None:
        raise InputError(f"{key}: group tables need a mesh with cell groups")
    entries = {
        name: _entry(value, mesh, f"{key}.{name}", DEFAULTS[name], tagged)
        for name, value in spec.entries().items()
    }
    check_positive_definite(spec, mesh, key, tagged)
    matrix: Expr = ufl.as_matrix(
        [[entries["g11"], entries["g12"]], [entries["g12"], entries["g22"]]]
    )
    return matrix


def _entry(value: Entry, mesh: Mesh, key: str, default: float, tagged: TaggedMesh | None) -> Expr:
    """One entry of G in UFL (see :func:`target_metric`)."""
    if not isinstance(value, dict):
        return _piece(value, mesh, key)
    assert tagged is not None
    total: Expr = values.constant(mesh, default)
    for group, text in value.items():
        indicator = tagged.group_function({group: 1.0}, default=0.0, key=key)
        total = total + indicator * (_piece(text, mesh, f"{key}.{group}") - default)
    return total


def _piece(value: float | str, mesh: Mesh, key: str) -> Expr:
    """A number as a Constant, a formula as UFL."""
    if isinstance(value, float | int):
        return values.constant(mesh, float(value))
    built = expressions.formula(value, mesh, key)
    return values.constant(mesh, built) if isinstance(built, float) else built


def check_positive_definite(
    spec: MetricSpec,
    mesh: Mesh,
    key: str = "model.metric",
    tagged: TaggedMesh | None = None,
    factors: Sequence[float] = (),
) -> None:
    """InputError on every rank when G is not finite and SPD at some sample point of the mesh.

    Args:
        spec: the validated ``model.metric``.
        mesh: the plate's mesh: the geometry nodes and the midpoint of each cell, with the
            values of the cell's group.
        key: the key named in the message.
        tagged: the mesh's cell groups (needed when an entry is a group table).
        factors: also check G_λ = I + λ(G − I) at each of these λ, the ends a path in the
            metric can reach (:mod:`dgplate.models.plate_path`): G_λ is affine in λ, so it is
            SPD between them.
    """
    points, cells = _cell_points(mesh)
    g11, g12, g22 = (
        _at(value, points, cells, f"{key}.{name}", DEFAULTS[name], tagged)
        for name, value in spec.entries().items()
    )
    _refuse_indefinite(mesh, points, (g11, g12, g22), f"{key}: G")
    for factor in factors:
        scaled = (1 + factor * (g11 - 1), factor * g12, 1 + factor * (g22 - 1))
        where = f"{key} on the path (path.lambda_max + path.ds_max): G_λ at λ = {factor:g}"
        _refuse_indefinite(mesh, points, scaled, where)


def _refuse_indefinite(
    mesh: Mesh, points: Array, entries: tuple[Array, Array, Array], what: str
) -> None:
    """The InputError of :func:`check_positive_definite` on every rank, if any point fails."""
    g11, g12, g22 = entries
    det = g11 * g22 - g12**2
    bad = np.flatnonzero(~(np.isfinite(det) & (g11 > 0) & (det > 0)))
    local = None
    if bad.size:
        i = bad[0]
        local = (*points[i], g11[i], g12[i], g22[i])
    found = [b for b in mesh.comm.allgather(local) if b is not None]
    if found:
        x, y, a, b, c = found[0]
        raise InputError(
            f"{what} is not symmetric positive definite at (x, y) = ({x:.6g}, {y:.6g}): "
            f"g11 = {a:.6g}, g12 = {b:.6g}, g22 = {c:.6g} (det G = {a * c - b * b:.6g})"
        )


def largest_jump(
    spec: MetricSpec, mesh: Mesh, tagged: TaggedMesh, creases: Sequence[str] = ()
) -> tuple[float, Array]:
    """The largest jump of G's entries between cell groups at a geometry node (collective).

    Args:
        spec: the validated ``model.metric``.
        mesh: the plate's mesh.
        tagged: its cell and facet groups.
        creases: facet groups whose nodes are left out (G may jump across a crease).

    Returns:
        max over the nodes and entries of (largest − least value among the node's cells), and
        the node (x, y) where it is (0 and the origin when G is continuous at every node; a
        node shared across ranks is seen from each rank's local cells only).
    """
    points, cells = _cell_points(mesh)
    nodes = geometry_dofmap(mesh)
    node_of_point = np.concatenate([nodes, np.full((len(nodes), 1), -1)], axis=1).ravel()
    at_nodes = node_of_point >= 0
    jump = np.zeros(len(mesh.geometry.x))
    for name, value in spec.entries().items():
        entry = _at(value, points, cells, f"model.metric.{name}", DEFAULTS[name], tagged)
        high = np.full(len(jump), -np.inf)
        low = np.full(len(jump), np.inf)
        np.maximum.at(high, node_of_point[at_nodes], entry[at_nodes])
        np.minimum.at(low, node_of_point[at_nodes], entry[at_nodes])
        jump = np.maximum(jump, np.where(np.isfinite(high), high - low, 0.0))
    for group in creases:
        facets = tagged.facets(group, "model.crease")
        jump[entities_to_geometry(mesh, mesh.topology.dim - 1, facets).ravel()] = 0.0
    i = int(np.argmax(jump)) if len(jump) else 0
    local = (float(jump[i]) if len(jump) else 0.0, mesh.geometry.x[i, :2] if len(jump) else None)
    best = max(mesh.comm.allgather(local), key=lambda item: item[0])
    return best[0], (np.zeros(2) if best[1] is None else best[1])


def _cell_points(mesh: Mesh) -> tuple[Array, Indices]:
    """Each local cell's geometry nodes and midpoint, shape (n, 2), and their cells, (n,)."""
    nodes = mesh.geometry.x[geometry_dofmap(mesh)]  # (cells, nodes per cell, 3)
    points = np.concatenate([nodes, nodes.mean(axis=1, keepdims=True)], axis=1)
    cells = np.repeat(np.arange(len(nodes), dtype=np.int32), points.shape[1])
    return points.reshape(-1, 3)[:, :2], cells


def _at(
    value: Entry,
    points: Array,
    cells: Indices,
    key: str,
    default: float,
    tagged: TaggedMesh | None,
) -> Array:
    """An entry at ``points`` (of ``cells``), one value per point."""
    if not isinstance(value, dict):
        return _piece_at(value, points, key)
    assert tagged is not None
    out = np.full(len(points), default)
    for group, text in value.items():
        mask = np.isin(cells, tagged.cells(group, key))
        out[mask] = _piece_at(text, points[mask], f"{key}.{group}")
    return out


def _piece_at(value: float | str, points: Array, key: str) -> Array:
    """A number or formula at ``points``."""
    values_at = (
        value if isinstance(value, float | int) else expressions.evaluate(value, points, key)
    )
    return np.broadcast_to(np.asarray(values_at, dtype=np.float64), len(points))
