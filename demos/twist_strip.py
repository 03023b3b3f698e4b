# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # A strip twisted by turning its clamped ends against each other
#
# The strip ω = (0, 4) × (−½, ½) is clamped at both ends; the end x₁ = 4 is turned about the
# strip's axis by α·90° while the end x₁ = 0 stays flat. The clamped data are formulas in x, y
# and `alpha` (`demos/problems/twist_strip.toml`):
#
# $$g = (x_1,\; x_2\cos a,\; x_2\sin a),\qquad
#   \Phi = \begin{pmatrix}1&0\\0&\cos a\\0&\sin a\end{pmatrix},\qquad a = \alpha\,\tfrac{\pi}{2}\,\tfrac{x_1}{4},$$
#
# which is the identity on the left end for every α, and a rotation by απ/2 on the right end.
# Φ is given, not ∇g: the data must be an isometric frame on each end (|Φe₁| = 1), which ∇g of
# this g is not. An inextensible strip cannot twist like a helicoid (that stretches its
# edges); it bends and twists into a developable surface, and the bending energy grows along
# the path. α advances in six stages (`model.continuation = {steps = 6}`), each relaxed by the
# flow warm-started from the last; `flow.projection_steps = 2` keeps the isometry defect at
# round-off across the jumps of the data.
#
# Run: `python demos/twist_strip.py` (8 × 2 cells, Q2, seconds), `--paper` for 16 × 4.

# %%
import itertools
from pathlib import Path

import numpy as np

import dgplate
from dgplate import demo
from dgplate.mpi import bounding_box

PROBLEM = Path(__file__).parent / "problems" / "twist_strip.toml"

args = demo.arguments("twist_strip", "a strip twisted by continuation", paper="16 × 4 cells")
overrides = {"mesh.cells": [16, 4]} if args.paper else {}
result = demo.run(dgplate.load_problem(PROBLEM, overrides), args)
demo.copy_figure(Path(args.out), args.figure)

# %% [markdown]
# ## Energy along the path
#
# `summary.json` lists the end of every stage (`alpha_path`). The energy must grow with the
# twist, no flow step may raise it (each new α rebases the decrease test), and the right end
# must have reached its turned place: its nodes (x₁ = 4) span z ∈ [−½, ½] and lie at y₂ = 0.

# %%
path = result["alpha_path"]
demo.say(f"\n{'α':>8} {'twist':>8} {'steps':>6} {'E_h':>12} {'D_h':>10}")
for stage in path:
    demo.say(
        f"{stage['alpha']:>8.4f} {90 * stage['alpha']:>7.1f}° {stage['steps']:>6} "
        f"{stage['energy']:>12.5e} {stage['defect']:>10.2e}"
    )
energies = [stage["energy"] for stage in path]
demo.check("the path reached α = 1 and the flow converged", result["converged"])
demo.check("no flow step raised the energy", not result["energy_increases"])
demo.check("the energy grows with the twist", all(b > a for a, b in itertools.pairwise(energies)))
demo.check_between("D_h", result["isometry_defect"], high=1e-8)
shape = getattr(result, "shape", None)  # None: a finished run reused by --resume
if shape is None:
    demo.say("(summary.json reused: no final state to measure the turned end on)")
else:  # the box around the owned nodes on x₁ = 4, over all ranks
    owned = shape.function_space.dofmap.index_map.size_local
    at_end = np.isclose(shape.function_space.tabulate_dof_coordinates()[:owned, 0], 4.0)
    lo, hi = bounding_box(
        shape.function_space.mesh.comm, shape.x.array.reshape(-1, 3)[:owned][at_end]
    )
    # measured (8 × 2): z within 4e−4 of ∓½ and |y₂| < 5e−4 (the clamp is weak, by penalty)
    source = "the end turned by 90°"
    demo.check_close("lowest z on x₁ = 4", lo[2], -0.5, abs=5e-3, source=source)
    demo.check_close("highest z on x₁ = 4", hi[2], 0.5, abs=5e-3, source=source)
    demo.check_between("largest |y₂| on x₁ = 4", max(-lo[1], hi[1]), high=5e-3, source=source)
