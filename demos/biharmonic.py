# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
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
# This is a linear problem, not a problem file for `dgplate run`: the demo calls the solver
# directly and writes the finest solution itself (VTX, PNG, summary.json).
#
# Run: `python demos/biharmonic.py` (Q2, meshes 4² to 32², seconds), `--paper` for 64² and
# 128² too, `--degree 3 --cell triangle`, or in parallel `mpirun -n 2 python demos/biharmonic.py`:
# the errors do not change.

# %%
import time

from mpi4py import MPI

import dolfinx.io
import numpy as np
import ufl

from dgplate import compat, demo
from dgplate.dg.forms import Penalty, facet_sets
from dgplate.io.output import OutputDir, write_json
from dgplate.io.plotting import plot_deformation
from dgplate.mesh.tagged import RECTANGLE_SIDES, rectangle
from dgplate.solvers.biharmonic import solve_biharmonic

parser = demo.parser("biharmonic", "the IP-dG core on Δ²u = f", paper="meshes up to 128²")
parser.add_argument("--degree", type=int, default=2)
parser.add_argument("--cell", default="quadrilateral", choices=["quadrilateral", "triangle"])
args = demo.parse(parser)
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
levels = [4, 8, 16, 32] + ([64, 128] if args.paper else [])
t0 = time.perf_counter()
rows = []
for n in levels:
    tagged = rectangle(comm, [[0, 0], [1, 1]], [n, n], args.cell)
    faces = facet_sets(tagged, clamped=RECTANGLE_SIDES)
    x = ufl.SpatialCoordinate(tagged.mesh)
    exact = x[0] ** 2 * (1 - x[0]) ** 2 * x[1] ** 2 * (1 - x[1]) ** 2
    result = solve_biharmonic(faces, args.degree, exact, penalty)
    rows.append((n, result.dofs, result.errors))
demo.say(f"{args.cell} k={args.degree}, γ0={penalty.gamma0}, γ1={penalty.gamma1}")
demo.say(f"{'mesh':>9} {'dofs':>8} {'H2 err':>10} rate {'H1 err':>10} rate {'L2 err':>10} rate")
rates: dict[str, list[float]] = {}
for i, (n, dofs, err) in enumerate(rows):
    line = f"{n:>4}x{n:<4} {dofs:>8}"
    for key in ("H2", "H1", "L2"):
        rate = np.log2(rows[i - 1][2][key] / err[key]) if i else float("nan")
        rates.setdefault(key, []).append(rate)
        line += f" {err[key]:10.3e} {rate:4.2f}"
    demo.say(line)

# %% [markdown]
# ## Outputs
#
# The finest solution is written as a surface (x, y, 50·u) for ParaView and as a PNG.

# %%
out = OutputDir(comm, args.out, force=args.force)
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
demo.copy_figure(args.out, args.figure)

# %% [markdown]
# ## The rates
#
# Measured with Q2 (docs/verification.md): H² 1.00, H¹ 1.99, L² 1.91 at 32², L² 1.95 at 64².
# The demo asserts what `tests/dg/test_biharmonic.py` asserts: the rate between the two finest
# meshes within 0.15 of the theory, and errors that decrease at every refinement.

# %%
theory = {
    "H2": args.degree - 1,
    "H1": args.degree,
    "L2": 2 if args.degree == 2 else args.degree + 1,
}
for key, expected in theory.items():
    demo.check_close(f"{key} rate", rates[key][-1], expected, abs=0.15, source="theory")
    errors = [err[key] for _, _, err in rows]
    demo.check(f"the {key} errors decrease", all(np.diff(errors) < 0))
