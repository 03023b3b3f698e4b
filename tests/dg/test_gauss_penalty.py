"""The Gauss-curvature penalty (β/2)Σ_T h⁻¹∫_T (det II − K det G)² (dgplate/dg/gauss_penalty.py)."""

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest
import ufl

from dgplate.dg.forms import facet_sets
from dgplate.dg.gauss_penalty import gauss_penalty
from dgplate.mesh.tagged import rectangle
from dgplate.models.metric import MetricSpec, target_metric


def test_gauss_penalty_is_zero_on_surfaces_that_realise_the_metric():
    """Without a metric: zero on a developable surface, (β/2h)∫K² on the paraboloid.

    With G = I + x⊗x, the paraboloid z = |x|²/2's metric (K = (1 + r²)⁻², det G = 1 + r²):
    zero on the paraboloid, and the flat plate (det II = 0) pays (β/2h)∫(1 + r²)⁻², the
    paraboloid's price without a metric.
    """
    tagged = rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [4, 4])
    facets = facet_sets(tagged)
    metric = target_metric(MetricSpec(g11="1 + x*x", g12="x*y", g22="1 + y*y"), tagged.mesh)
    x = ufl.SpatialCoordinate(tagged.mesh)
    flat = ufl.as_vector([x[0], x[1], 0.0 * x[0]])
    bent = ufl.as_vector([x[0], x[1], 0.5 * x[0] ** 2])  # K = 0
    dome = ufl.as_vector([x[0], x[1], 0.5 * (x[0] ** 2 + x[1] ** 2)])

    def value(y, G):
        form = dolfinx.fem.form(gauss_penalty(y, facets, 3.0, 12, G))
        return tagged.mesh.comm.allreduce(dolfinx.fem.assemble_scalar(form))

    points, weights = np.polynomial.legendre.leggauss(40)
    s, w = 0.5 * (points + 1), 0.5 * weights  # on (0, 1)
    exact = np.einsum("i,j,ij", w, w, (1 + s[:, None] ** 2 + s[None, :] ** 2) ** -2.0)
    h = np.sqrt(2) / 4  # the cell diameter
    assert abs(value(bent, None)) < 1e-14
    assert value(dome, None) == pytest.approx(1.5 / h * exact, rel=1e-6)
    assert abs(value(dome, metric)) < 1e-14
    assert value(flat, metric) == pytest.approx(value(dome, None), rel=1e-10)
