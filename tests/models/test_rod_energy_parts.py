"""The named parts of the rod energy Ĩ_h sum to it (docs/rods.md, "summary.json").

Exact values on a clamped rod (c_b = 1, c_t = 0.5, L = 1, 16 cells, σ = 10, h = 1/16):

- the polygon u = s e₁ (s ≤ ½), ½e₁ + (s − ½)(cos θ e₁ + sin θ e₂) (s > ½), b = e₃: u″ = 0 in
  every cell and one kink at the node s = ½, so only the interior penalty is left,
  ``energy_jumps`` = c_b (σ/2h)|u′⁺ − u′⁻|² = 80 (2 − 2 cos θ);
- the parabola u = s e₁ + (a s²/2) e₃ with b = e₃ (u′·b = a s ≠ 0: off the constraint set):
  bending (c_b/2)a²L, no jumps (u is C¹), torsion (b′·d)² = 0 and the modified torsion
  (c_t/2)(|b′|² − (b·u″)²) = −(c_t/2)a², so ``energy_torsion_defect`` = −(c_t/2)a²L.
"""

import math
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest

import dgplate
from dgplate.models.rod.energy import RodData, clamp_measure, energy_split, rod_mesh
from dgplate.models.rod.spec import RodSpec

THETA, A = 0.7, 2.0


def split(centreline):
    """The energy parts of the clamped rod (16 cells) with u = centreline(s) and b = e₃."""
    spec = RodSpec(cells=16)
    tagged = rod_mesh(spec, MPI.COMM_SELF)
    mesh = tagged.mesh
    u = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("P", 2, (3,))))
    b = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("P", 1, (3,))))
    u.interpolate(lambda x: centreline(x[0]))
    b.interpolate(lambda x: np.vstack([0 * x[0], 0 * x[0], 1 + 0 * x[0]]))
    return energy_split(u, b, RodData.of(spec, mesh, clamp_measure(spec, tagged)))


def kinked(s):
    bent = s > 0.5
    turned = 0.5 + (s - 0.5) * math.cos(THETA)
    return np.vstack(
        [np.where(bent, turned, s), np.where(bent, (s - 0.5) * math.sin(THETA), 0.0), 0 * s]
    )


def test_a_kink_at_a_node_is_all_interior_penalty():
    parts = split(kinked)
    assert parts["energy_jumps"] == pytest.approx(80.0 * (2.0 - 2.0 * math.cos(THETA)), rel=1e-12)
    for key in ("energy_bending", "energy_torsion", "energy_torsion_defect"):
        assert abs(parts[key]) < 1e-12


def test_a_frame_off_the_constraint_set_is_the_torsion_defect():
    parts = split(lambda s: np.vstack([s, 0 * s, 0.5 * A * s**2]))
    assert parts["energy_bending"] == pytest.approx(0.5 * A**2, rel=1e-12)
    assert parts["energy_torsion_defect"] == pytest.approx(-0.25 * A**2, rel=1e-12)
    assert abs(parts["energy_jumps"]) < 1e-12 and abs(parts["energy_torsion"]) < 1e-12


@pytest.mark.parametrize("projection", [0, 1])
def test_the_parts_sum_to_the_energy_in_a_sphere(tmp_path, projection):
    """The demo's saddle in the sphere, 24 cells, 20 steps: energy_rest is round-off."""
    path = Path(__file__).resolve().parents[2] / "demos"
    overrides = {
        "model.cells": 24,
        "flow.max_steps": 20,
        "flow.projection_steps": projection,
        "model.self_avoidance": {"rho": 0.01},
        "output.progress": 0,
        "output.vtx": False,
        "output.png": False,
    }
    problem = dgplate.load_problem(path / "problems" / "rod_sphere.toml", overrides=overrides)
    result = dgplate.run(problem, out=tmp_path / "out", comm=MPI.COMM_SELF)
    assert result["energy_increases"] == []
    assert abs(result["energy_rest"]) < 1e-10 * result["energy"]
    assert result["energy_jumps"] > 0 and result["energy_self_avoidance"] > 0
