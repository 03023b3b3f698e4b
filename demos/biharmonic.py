# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: percent
# ---

# %% [markdown]
# # The interior-penalty dG core on a clamped biharmonic problem
#
# Every plate model in dgplate is built on one fourth-order form: the symmetric interior-penalty
# discontinuous Galerkin (IP-dG) discretisation of ½∫|D²u|². Before trusting it with nonlinear
# plates we check it where the answer is known: Δ²u = f on (0,1)², clamped (u and ∇u given),
# with the manufactured solution u = x²(1−x)²y²(1−y)².
#
# The discrete solution minimises ½a_h(u, u) − (f, u), where a_h collects the broken Hessian
# term, the consistency terms on interior and clamped faces and the penalties γ₁h⁻¹|[∇u]|² and
# γ₀h⁻³|[u]|². Theory predicts, for degree k, errors O(h^{k−1}) in the broken H² norm, O(h^k)
# in H¹ and O(h^{k+1}) in L² (k ≥ 3; O(h²) for k = 2).
#
# Run: `python demos/biharmonic.py` (Q2, 5 meshes, seconds), `--degree 3 --cell triangle`,
# or in parallel `mpirun -n 2 python demos/biharmonic.py`: the errors do not change.

# %%
import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

import dolfinx.io
import numpy as np
import ufl

from dgplate import compat
from dgplate.dg.forms import Penalty, facet_sets
from dgplate.io.output import OutputDir, print0, write_json
from dgplate.io.plotting import plot_deformation
from dgplate.mesh.tagged import RECTANGLE_SIDES, rectangle
from dgplate.solvers.biharmonic import solve_biharmonic

parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--degree", type=int, default=2)
parser.add_argument("--cell", default="quadrilateral", choices=["quadrilateral", "triangle"])
parser.add_argument("--paper", action="store_true", help="one more refinement (128×128)")
parser.add_argument("--out", default="out/biharmonic")
args, _ = parser.parse_known_args()
comm = MPI.COMM_WORLD
# Penalties that are stable and reach the asymptotic rates early (see docs/verification.md).
penalty = {2: Penalty(100.0, 100.0), 3: Penalty(1000.0, 50.0)}.get(
    args.degree, Penalty(1000.0, 100.0)
)
if args.cell == "triangle" and args.degree == 2:
    penalty = Penalty(10.0, 10.0)

# %% [markdown]
# ## Convergence study

# %%
levels = [4, 8, 16, 32, 64] + ([128] if args.paper else [])
t0 = time.perf_counter()
rows = []
for n in levels:
    tagged = rectangle(comm, [[0, 0], [1, 1]], [n, n], args.cell)
    faces = facet_sets(tagged, clamped=RECTANGLE_SIDES)
    x = ufl.SpatialCoordinate(tagged.mesh)
    exact = x[0] ** 2 * (1 - x[0]) ** 2 * x[1] ** 2 * (1 - x[1]) ** 2
    result = solve_biharmonic(faces, args.degree, exact, penalty)
    rows.append((n, result.dofs, result.errors))

print0(comm, f"{args.cell} k={args.degree}, γ0={penalty.gamma0}, γ1={penalty.gamma1}")
print0(comm, f"{'mesh':>9} {'dofs':>8} {'H2 err':>10} rate {'H1 err':>10} rate {'L2 err':>10} rate")
rates = {}
for i, (n, dofs, err) in enumerate(rows):
    line = f"{n:>4}x{n:<4} {dofs:>8}"
    for key in ("H2", "H1", "L2"):
        rate = np.log2(rows[i - 1][2][key] / err[key]) if i else float("nan")
        rates.setdefault(key, []).append(rate)
        line += f" {err[key]:10.3e} {rate:4.2f}"
    print0(comm, line)

# %% [markdown]
# ## Outputs
#
# The finest solution is written as a surface (x, y, 50·u) for ParaView and as a PNG.

# %%
out = OutputDir(comm, Path(args.out))
with dolfinx.io.VTXWriter(comm, str(out.path / "solution.bp"), [result.u]) as writer:
    writer.write(0.0)
scaled = result.u.copy()
scaled.x.array[:] *= 50.0
plot_deformation(scaled, out.path / "final.png", title="biharmonic: 50·u_h", color_by="curvature")
summary = {
    "model": "biharmonic",
    "dofs": rows[-1][1],
    "ranks": comm.size,
    "errors": {str(n): err for n, _, err in rows},
    "rates_finest": {key: values[-1] for key, values in rates.items()},
    "wall_time_s": time.perf_counter() - t0,
    "dolfinx_version": compat.version_string(),
}
write_json(comm, out.path / "summary.json", summary)
out.commit()
if comm.rank == 0:
    print(json.dumps(summary["rates_finest"]))
