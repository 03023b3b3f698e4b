"""Contact with a rigid obstacle: the figures of ``summary.json`` and the feasibility checks.

The contact set is where the penalty acts, {s(y) < 0} (s the signed distance of
:class:`dgplate.dg.obstacle_penalty.Obstacle`). Reported, all reduced over the ranks (owned cells
only, so that they do not depend on the partition):

* ``contact_area``: |{s < 0}| in the reference domain (quadrature of the indicator);
* ``contact_cells``: cells with a sample point in contact;
* ``max_penetration``: max(−s)₊ over the sample points;
* ``contact_force``: (1/ε)∫(s)₋, the total normal reaction of the obstacle (≥ 0), with the
  penalty's quadrature (degree 2k + 2);
* ``contact_extent``: the reference bounding box [x_min, x_max, y_min, y_max] of the sample
  points in contact (None without contact), e.g. the lift-off point of a strip.

Sample points are the nodes of a DG space of degree :data:`SAMPLE_DEGREE` on each cell.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import dolfinx.fem
import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import compat, mpi
from dgplate.compat import Array, Function
from dgplate.dg.energy import Energy
from dgplate.dg.forms import CLAMPED, FacetSets, cell_measure, integral
from dgplate.dg.obstacle_penalty import Obstacle
from dgplate.errors import InputError

#: Degree of the DG nodes at which s(y) is sampled (per cell: (d + 1)² or (d+1)(d+2)/2 points).
SAMPLE_DEGREE = 8
#: Penetration of the start or of the clamped data accepted as round-off.
TOLERANCE = 1e-9


def sample(expr: Expr, facets: FacetSets) -> tuple[Array, Array, int]:
    """A scalar expression at the sample points of the owned cells, and their reference points.

    Returns values (cells, points), coordinates (cells, points, 2) and the number of cells.
    """
    mesh = facets.mesh
    space = dolfinx.fem.functionspace(mesh, ("DG", SAMPLE_DEGREE))
    compiled: compat.Expression = dolfinx.fem.Expression(
        expr, compat.interpolation_points(space.element)
    )
    field: Function = dolfinx.fem.Function(space)
    field.interpolate(compiled)
    cells = mesh.topology.index_map(mesh.topology.dim).size_local
    dofs = space.dofmap.list[:cells]
    coords = space.tabulate_dof_coordinates()[:, :2]
    return field.x.array.real[dofs], coords[dofs], cells


def _sum(a: ufl.Form | None, b: ufl.Form | None) -> ufl.Form | None:
    """The sum of two forms, either of which may be None (no form)."""
    if a is None or b is None:
        return b if a is None else a
    total: ufl.Form = a + b
    return total


class Contact:
    """An obstacle acting on a plate: its energy terms, checks and figures."""

    def __init__(self, obstacle: Obstacle, facets: FacetSets, degree: int) -> None:
        self.obstacle, self.facets, self.degree = obstacle, facets, degree

    def clamped_check(self, g: Expr, key: str = "model.obstacle") -> Callable[[], None]:
        """A check that the clamped data g do not penetrate the obstacle, compiled once.

        It looks at the clamped vertices; run it for each α of a continuation path.
        Collective, like the check it returns.
        """
        if not self.facets.has_clamped:
            return lambda: None
        mesh = self.facets.mesh
        space = dolfinx.fem.functionspace(mesh, ("Lagrange", 1))
        compiled: compat.Expression = dolfinx.fem.Expression(
            self.obstacle.distance(g, mesh, key), compat.interpolation_points(space.element)
        )
        field: Function = dolfinx.fem.Function(space)
        dofs = dolfinx.fem.locate_dofs_topological(
            space, mesh.topology.dim - 1, self.facets.tags.find(CLAMPED)
        )
        owned = dofs[dofs < space.dofmap.index_map.size_local]

        def check() -> None:
            field.interpolate(compiled)
            local = float(np.max(-field.x.array.real[owned], initial=0.0))
            depth = mpi.global_max(mesh.comm, local)
            if depth > TOLERANCE:
                raise InputError(
                    f"{key}: the clamped data model.boundary_data penetrate the obstacle by "
                    f"{depth:.3g}"
                )

        return check

    def check_start(self, y: Function, key: str = "model.obstacle") -> None:
        """The start y⁰ must not penetrate the obstacle (an infeasible start)."""
        values, _, _ = sample(self.obstacle.distance(y, self.facets.mesh, key), self.facets)
        depth = mpi.global_max(self.facets.mesh.comm, float(np.max(-values, initial=0.0)))
        if depth > TOLERANCE:
            raise InputError(
                f"{key}: the start y⁰ penetrates the obstacle by {depth:.3g} "
                "(move the obstacle, or start from an admissible shape)"
            )

    def add_to(self, energy: Energy, y: Function) -> Energy:
        """``energy`` with the obstacle's penalty (implicit and explicit parts) added."""
        penalty = self.obstacle.energy(y, self.facets.mesh, self.degree)
        return replace(
            energy,
            implicit=energy.implicit + penalty.implicit,
            explicit=_sum(energy.explicit, penalty.explicit),
            active_sets=(*energy.active_sets, *penalty.active_sets),
            step_shift=_sum(energy.step_shift, penalty.step_shift),
        )

    def summary(self, y: Function) -> dict[str, Any]:
        """The contact figures of ``y`` (see the module docstring; collective)."""
        mesh = self.facets.mesh
        comm = mesh.comm
        s = self.obstacle.distance(y, mesh)
        gaps, coords, cells = sample(s, self.facets)
        depth = -gaps
        touching = depth > 0.0
        dx = cell_measure(mesh, 4 * self.degree + 4)
        indicator, pressure = self.obstacle.contact_densities(s, mesh)
        inside = coords[touching]
        extent = [
            mpi.global_min(comm, float(np.min(inside[:, 0], initial=np.inf))),
            mpi.global_max(comm, float(np.max(inside[:, 0], initial=-np.inf))),
            mpi.global_min(comm, float(np.min(inside[:, 1], initial=np.inf))),
            mpi.global_max(comm, float(np.max(inside[:, 1], initial=-np.inf))),
        ]
        return {
            "contact_area": integral(dolfinx.fem.form(indicator * dx), comm),
            "contact_cells": mpi.global_count(
                comm, int(np.count_nonzero(touching.any(axis=1))) if cells else 0
            ),
            "max_penetration": mpi.global_max(comm, float(np.max(depth, initial=0.0))),
            # the penalty's own quadrature: the reaction that the plate feels (at small ε the
            # polynomial dips between those points, where a finer rule would count it)
            "contact_force": integral(
                dolfinx.fem.form(pressure * cell_measure(mesh, 2 * self.degree + 2)), comm
            ),
            "contact_extent": extent if np.isfinite(extent[0]) else None,
        }
