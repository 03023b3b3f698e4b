"""The rod's own mesh, its clamped ends and its energy: implicit and explicit parts, their split.

The model is described in the docstring of :mod:`dgplate.models.rod`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import basix.ufl
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from dgplate import compat, values
from dgplate.compat import Constant, Function, Mesh
from dgplate.dg.energy import Energy
from dgplate.dg.forms import integral
from dgplate.dg.obstacle_penalty import Obstacle
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.rod.spec import RodSpec, _unit
from dgplate.solvers.rod_flow import ip_jumps, ip_product, nitsche_slope, tangent

_START, _END = 1, 2  # the tags of the nodes s = 0 and s = L


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
        t = _unit(spec.tangent)
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
