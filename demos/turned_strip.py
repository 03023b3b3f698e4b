# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # An inextensible strip snapped by turning its clamps: path following on a constrained plate
#
# A strip of span L = 1 and width 0.05 is clamped at both ends, and the ends are pushed
# together by Δ = 0.01: the strip buckles. It starts buckled down, the *inverted* state. Then
# both clamps turn against it, the left one up and the right one down by the angle α: they now
# favour the arch bulging up, and at some angle the inverted state can no longer hold. This is
# the boundary-driven snap-through of Gomez, Moulton and Vella (*Critical slowing down in purely
# elastic 'snap-through' instabilities*, Nature Physics 13, 2017), here on the
# isometry-constrained Kirchhoff plate: the strip cannot stretch, so it is an inextensible
# elastica, at a finite Δ, not a shallow arch.
#
# Along the path, as α grows (`dgplate.reference.turned_elastica`, derived there):
#
# - the inverted state meets the antisymmetric mode, a simple bifurcation: beyond it the
#   state is unstable (stability index 1), the strip would snap asymmetrically;
# - a little further the symmetric branch itself turns back, a fold (index 2 after it).
#
# In units of √Δ the elastica's angles are α/√Δ = 2.00190 and 2.01402 at this Δ (the shallow
# limit Δ → 0: 2 and 2.0119).
#
# The clamped data are g = (0.99x, y, 0) and Φ = [[cos θ, 0], [0, 1], [sin θ, 0]], θ =
# 0.25λ(1 − 2x): `path.parameter = "boundary_data"` makes the load factor λ the `alpha` of
# those formulas. The path solves the plate's Lagrangian by Newton's method
# (`dgplate.solvers.constrained_path`): each point holds the discrete isometry constraint to
# round-off, and the stability index is the inertia of the constrained Hessian.
#
# Run: `python demos/turned_strip.py [--paper] [--out DIR]` (also under mpirun): 32 × 1 Q2
# cells (seconds); `--paper` 256 × 1, the finest level of docs/path_following.md.

# %%
from pathlib import Path

import numpy as np

import dgplate
from dgplate import demo
from dgplate.reference.turned_elastica import turned_strip_elastica_thresholds

PROBLEM = Path(__file__).parent / "problems" / "turned_strip.toml"
DELTA, ALPHA = 0.01, 0.25  # as in the problem file: the end shortening, the full clamp angle

parser = demo.parser(
    "turned_strip",
    "A constrained plate: a strip turned by its clamps up to its snap",
    "256 × 1 cells",
    "32 × 1 cells",
)
args = demo.parse(parser)
cells = 256 if args.paper else 32

# %% [markdown]
# ## The path from the inverted state
#
# The problem file starts Newton at λ = 0 near the clamped elastica's first mode, buckled
# down (`model.start`), where it finds the inverted state. Arclength steps of at most 0.2 (in
# load factor) carry the path through the bifurcation and the fold; it ends after 16 points.

# %%
problem = dgplate.load_problem(PROBLEM, {"mesh.cells": [cells, 1]})
result = demo.run(problem, args)
demo.copy_figure(Path(args.out), args.figure, "branch.png")

# %% [markdown]
# ## The thresholds against the elastica
#
# Both converge at second order in h: on 16, 32, 64, 128 and 256 cells the bifurcation is
# off by +2.6, +0.60, +0.15, +0.037 and +0.010 %, the fold likewise (the table in
# docs/path_following.md, `benchmarks/plate_path.py`). The demo asserts both within 0.7 % on 32
# cells and 0.02 % on 256, the indices (0 before the bifurcation, 1 between it and the fold,
# 2 after it) and the constraint at every point.

# %%
exact = turned_strip_elastica_thresholds(DELTA)
load, indices, kinds = demo.branch(result)
demo.say(f"{cells} × 1 Q2 cells, {result['dofs']} dofs, {len(load)} points")
for lam, index in zip(load, indices):
    demo.say(f"  λ = {lam:+.6f}   α/√Δ = {lam * ALPHA / np.sqrt(DELTA):.5f}   index {index}")
demo.check("a bifurcation, then a fold", kinds == ["bifurcation", "fold"])
tolerance = 2e-4 if args.paper else 7e-3
for name, found in (("bifurcation", result["bifurcations"][0]), ("fold", result["folds"][0])):
    demo.check_close(f"{name} angle", found * ALPHA, exact[name], rel=tolerance,
                     source="the inextensible elastica at Δ = 0.01")  # fmt: skip
at_bifurcation = int(np.flatnonzero(load == result["bifurcations"][0])[0])
at_fold = int(np.flatnonzero(load == result["folds"][0])[0])
demo.check("index 0 before the bifurcation", set(indices[:at_bifurcation]) == {0})
demo.check("index 1 between it and the fold", set(indices[at_bifurcation + 1 : at_fold]) == {1})
demo.check("index 2 after the fold", set(indices[at_fold + 1 :]) == {2})
defects = [point["isometry_defect"] for point in result.history]
demo.check("the isometry constraint at every point", max(defects) < 1e-10)
