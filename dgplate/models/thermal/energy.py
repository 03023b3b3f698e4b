"""The thermal bilayer's energy (pure UFL): Z = −αθI, the anchor spring, the hinge penalties.

The model is described in the docstring of :mod:`dgplate.models.thermal`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from mpi4py import MPI

import numpy as np
import ufl

from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets, Penalty
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import flat_identity
from dgplate.models.bilayer import bilayer_energy
from dgplate.values import constant


def region_coefficient(tagged: TaggedMesh, values: Any, key: str, default: float = 0.0) -> Any:
    """A coefficient that may vanish: a number or {cell group: number}.

    A coefficient that may vanish: a number (everywhere, a Constant), or {cell group: number}
    with ``default`` on the cells of no listed group (a DG0 field). Unlike μ it may be 0 or < 0.
    """
    if not isinstance(values, dict):
        return constant(tagged.mesh, values)
    return tagged.group_function(values, default=default, key=key)


def thermal_curvature(theta: Any, alpha: Any) -> Any:
    """Z = −α θ I₂ (a UFL 2×2 expression; θ a Function, α a number or a DG0 field)."""
    return -alpha * theta * ufl.Identity(2)


def anchor_energy(y: Any, tagged: TaggedMesh, region: str, stiffness: float) -> ufl.Form:
    """½k∫_region |y − (x₁, x₂, 0)|²: a weak spring holding a panel in its reference place."""
    mesh = tagged.mesh
    # an indicator field rather than dx(tag): DOLFINx 0.9 wants one subdomain_data per
    # integral type in a form, and the bending energy's dx carries none
    indicator = tagged.group_function({region: 1.0}, default=0.0, key="model.anchor")
    g, _ = flat_identity(mesh)
    k = constant(mesh, stiffness)
    form: ufl.Form = 0.5 * k * indicator * ufl.inner(y - g, y - g) * ufl.dx(domain=mesh)
    return form


def thermal_energy(
    y: Any,
    facets: FacetSets,
    penalty: Penalty,
    theta: Any,
    alpha: Any,
    mu: Any = None,
    degree: int | None = None,
    anchor: ufl.Form | None = None,
) -> Energy:
    """The bilayer energy with Z = −αθI, plus an optional anchor term.

    The bilayer energy with Z = −αθI (flat clamped data where facets are clamped), plus an
    optional anchor term (``anchor`` a UFL form from :func:`anchor_energy`, implicit).
    """
    g, Phi = flat_identity(facets.mesh)
    Z = thermal_curvature(theta, alpha)
    energy = bilayer_energy(y, facets, penalty, Z, mu, None, g, Phi, True, degree)
    if anchor is not None:
        energy.implicit = energy.implicit + anchor
    return energy


def hinge_penalty(width: float, n: int, m: int, base: Penalty | None = None) -> Penalty:
    """IP penalties for hinge strips of m cells across (width/m) and 1/n along.

    The dG forms take h_e as the cell diameter, which on a thin hinge cell is its long side
    1/n, not the width w/m across which the hinge bends: the value-jump penalty γ₀h_e⁻³ is then
    (aspect)³ too weak and the coupling term −∫[y]·{div T·n} (which rewards value jumps
    linearly) makes the discrete hinge fold far too much (108° instead of 90° on a strip with
    m = 8, n = 4). Scaling γ₀ by A³ and γ₁ by A, A = (1/n)/(w/m), restores the penalties a
    facet-normal h_e would give. On the square panels this only stiffens the jumps more.
    """
    return aspect_penalty(max(1.0, (1.0 / n) / (width / m)), base)


def aspect_penalty(aspect: float, base: Penalty | None = None) -> Penalty:
    """γ₀ scaled by A³ and γ₁ by A (see :func:`hinge_penalty`)."""
    base = base or Penalty()
    return replace(base, gamma0=base.gamma0 * aspect**3, gamma1=base.gamma1 * aspect)


def cell_aspect_ratio(tagged: TaggedMesh) -> float:
    """The largest ratio of a cell's longest to its shortest edge (collective)."""
    mesh = tagged.mesh
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim, 1)
    owned = mesh.topology.index_map(tdim).size_local
    edges = mesh.topology.connectivity(tdim, 1)
    cell_edges = edges.array[: edges.offsets[owned]].reshape(owned, -1)  # one cell type
    lengths = mesh.h(1, cell_edges.reshape(-1).astype(np.int32)).reshape(owned, -1)
    ratio = float((lengths.max(axis=1) / lengths.min(axis=1)).max(initial=1.0))
    return float(mesh.comm.allreduce(ratio, op=MPI.MAX))
