# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # A plate clamped on two sides under a vertical load
#
# This is the first experiment of Bonito, Nochetto and Ntogkas, *DG approach to large bending
# plate deformations with isometry constraint* (M3AS 2021), Table 1. The plate
# ω = (0, 4)² is clamped along {0}×[0, 4] and [0, 4]×{0} with y = (x₁, x₂, 0) and ∇y = [I₂; 0],
# and pushed up by f = (0, 0, 2.5·10⁻²). We minimise
#
# $$E[y] = \tfrac12 \int_\omega |D^2 y|^2 - \int_\omega f\cdot y
#   \quad\text{subject to}\quad \nabla y^T \nabla y = I_2 .$$
#
# Clamping along two perpendicular edges forbids any bending of an H² isometry, so the exact
# minimiser is the flat plate with energy 0. The discrete energies are negative because the
# discrete isometry constraint only holds on cell averages; they approach 0 as h → 0. That
# makes this the benchmark of how close a method gets to the truth at a given cost.
#
# The discretisation is the symmetric interior-penalty dG method with Q2 elements
# (γ₀ = 5000, γ₁ = 1100), and the minimiser is found by the discrete H² gradient flow with
# the linearised isometry constraint and τ = h, the cell diameter (see the README,
# "Mathematics in one page").
#
# Run: `python demos/vertical_load.py` (16×16, seconds), `--cells 32`, or `--paper` for the
# published rows 16², 32², 64² side by side (minutes); `--triangles` for P2 triangles (no
# published row). Under MPI: `mpirun -n 2 python demos/vertical_load.py`.

# %%
from pathlib import Path

import dgplate
from dgplate import demo
from dgplate.reference.bnn import BNN_TABLE1

PROBLEM = Path(__file__).parent / "problems" / "vertical_load.toml"

parser = demo.parser("vertical_load", "BNN 2021, Table 1", paper="the published rows 16, 32, 64")
parser.add_argument("--cells", type=int, default=16, help="cells per side (default 16)")
parser.add_argument("--triangles", action="store_true", help="P2 triangles instead of Q2")
args = demo.parse(parser)

# %% [markdown]
# Each run is the problem file `demos/problems/vertical_load.toml` with the mesh overridden;
# `dgplate run` with `--set mesh.cells=[32,32]` does the same from the shell.

# %%
levels = [16, 32, 64] if args.paper else [args.cells]
rows = []
for n in levels:
    overrides: dict[str, object] = {"mesh.cells": [n, n]}
    if args.triangles:
        overrides["mesh.cell_type"] = "triangle"
    problem = dgplate.load_problem(PROBLEM, overrides=overrides)
    subfolder = [] if len(levels) == 1 else [f"{n}x{n}"]
    rows.append((n, demo.run(problem, args, *subfolder)))
demo.copy_figure(Path(args.out, *subfolder), args.figure)

# %% [markdown]
# ## Comparison with the published table
#
# With Q2 the implementation reproduces the published energies, defects and step counts to the
# digits printed. The demo asserts what `tests/models/test_kirchhoff.py` asserts of each published
# row: E_h within 0.5 %, D_h within 1 % and the step count within 2; and, for any mesh, that
# the flow converged with an energy that decreased at every step.

# %%
demo.say(
    f"\n{'cells':>9} {'dofs':>8} {'E_h':>11} {'paper':>9} {'D_h':>10} {'paper':>9} "
    f"{'steps':>5} {'paper':>5}"
)
for n, s in rows:
    ref = BNN_TABLE1.get(n, (float("nan"),) * 3)
    demo.say(
        f"{n:>4}x{n:<4} {s['dofs']:>8} {s['energy']:>11.4e} {ref[0]:>9.2e} "
        f"{s['isometry_defect']:>10.3e} {ref[1]:>9.2e} {s['steps']:>5} {ref[2]:>5}"
    )
for n, s in rows:
    demo.check(f"{n}×{n}: the flow converged and E_h decreased at every step",
               s["converged"] and not s["energy_increases"])  # fmt: skip
    if n in BNN_TABLE1 and not args.triangles:
        energy, defect, steps = BNN_TABLE1[n]
        source = f"BNN 2021, Table 1, {n}×{n}"
        demo.check_close("E_h", s["energy"], energy, rel=5e-3, source=source)
        demo.check_close("D_h", s["isometry_defect"], defect, rel=1e-2, source=source)
        demo.check_close("steps", s["steps"], steps, abs=2, source=source)
