# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # Föppl–von Kármán: a buckled strip snapped by turning its clamps
#
# A strip of span L = 1, width 0.05 and thickness t = 0.005 (E = 1, ν = 0, so exactly a beam)
# is clamped at both ends, and the ends are pushed together by Δ = 0.01: the strip buckles.
# It starts buckled down, the *inverted* state. Then both clamps are turned against it, the
# left one up and the right one down by the slope α: the clamps now favour the arch bulging
# up, the *natural* state. At some angle the inverted state can no longer hold, and the strip
# snaps through: the boundary-driven snap-through of an arch, as in the experiments of Gomez,
# Moulton and Vella (*Critical slowing down in purely elastic 'snap-through' instabilities*,
# Nature Physics 13, 2017).
#
# In the shallow (FvK) beam equations w′′′′ + τ²w′′ = 0, the compression τ² of the inverted
# state grows with α, and the end shortening fixes it through ½∫w′² = Δ − τ²t²/12 (the strip's
# own shortening under the force). Two things happen as α grows
# (`dgplate.reference.fvk.clamped_strip_thresholds`, derived there):
#
# - at τ = 8.9868 (tan(τ/2) = τ/2) the antisymmetric clamped mode costs nothing: a simple
#   bifurcation, at α_b = 2√(Δ − τ²t²/12); beyond it the inverted state is unstable
#   (stability index 1), the strip would snap asymmetrically;
# - a little further the symmetric branch itself turns back, a fold (index 2 after it).
#
# In units of √Δ, the thresholds are μ = α/√Δ = 2 and 2.0119 for a thin strip (t²/Δ → 0);
# here 1.98310 and 1.99409.
#
# The path follows the clamp slope: `path.parameter = "clamp_slope"` makes the load factor λ
# scale `model.clamp_slope` alone, ∇w = (λα(1 − 2x), 0) on the clamps with α = 0.25, while the
# end shortening (`model.membrane`) stays at its full value from the start.
#
# Run: `python demos/fvk_turned_strip.py [--paper] [--out DIR]` (also under mpirun): 32 × 1 Q2
# cells (seconds); `--paper` 128 × 1, the finest level of docs/path_following.md.

# %%
from pathlib import Path

import numpy as np

import dgplate
from dgplate import demo
from dgplate.reference.fvk import clamped_strip_thresholds
from dgplate.reference.turned_elastica import turned_strip_elastica_thresholds

PROBLEM = Path(__file__).parent / "problems" / "fvk_turned_strip.toml"
DELTA, T, ALPHA = 0.01, 0.005, 0.25  # as in the problem file

parser = demo.parser(
    "fvk_turned_strip",
    "FvK: a strip turned by its clamps up to its snap",
    "128 × 1 cells",
    "32 × 1 cells",
)
args = demo.parse(parser)
cells = 128 if args.paper else 32

# %% [markdown]
# ## The path from the inverted state
#
# The problem file starts Newton at λ = 0 near the first clamped Euler mode, buckled down
# (`model.start`), where it finds the inverted state. Arclength steps of at most 0.2 (in load
# factor) carry the path through the bifurcation and the fold; it ends after 16 points.

# %%
problem = dgplate.load_problem(PROBLEM, {"mesh.cells": [cells, 1]})
result = demo.run(problem, args)
demo.copy_figure(Path(args.out), args.figure, "branch.png")

# %% [markdown]
# ## The thresholds against the closed forms
#
# Both converge at second order in h: on 16, 32, 64, 128 and 256 cells the bifurcation is
# off by +3.4, +0.71, +0.17, +0.042 and +0.010 %, the fold by +3.4, +0.72, +0.17, +0.043 and
# +0.011 % (docs/path_following.md). The demo asserts both within 0.8 % on 32 cells and
# 0.05 % on 128, and the indices: 0 before the bifurcation, 1 between it and the fold, 2 after
# the fold.

# %%
exact = [a / ALPHA for a in clamped_strip_thresholds(DELTA, T)]
load, indices, kinds = demo.branch(result)
demo.say(f"{cells} × 1 Q2 cells, {result['dofs']} dofs, {len(load)} points")
for lam, index in zip(load, indices):
    demo.say(f"  λ = {lam:+.6f}   α/√Δ = {lam * ALPHA / np.sqrt(DELTA):.5f}   index {index}")
demo.check("a bifurcation, then a fold", kinds == ["bifurcation", "fold"])
tolerance = 5e-4 if args.paper else 8e-3
demo.check_close("bifurcation λ", result["bifurcations"][0], exact[0], rel=tolerance,
                 source="shallow-beam closed form")  # fmt: skip
demo.check_close("fold λ", result["folds"][0], exact[1], rel=tolerance,
                 source="shallow-beam closed form")  # fmt: skip
at_bifurcation = int(np.flatnonzero(load == result["bifurcations"][0])[0])
at_fold = int(np.flatnonzero(load == result["folds"][0])[0])
demo.check("index 0 before the bifurcation", set(indices[:at_bifurcation]) == {0})
demo.check("index 1 between it and the fold", set(indices[at_bifurcation + 1 : at_fold]) == {1})
demo.check("index 2 after the fold", set(indices[at_fold + 1 :]) == {2})

# %% [markdown]
# ## At finite Δ: the elastica
#
# The closed forms, and the FvK path that converges to them, are shallow: exact as Δ → 0. As
# an elastica (an extensible rod clamped at the angles ±α,
# `dgplate.reference.turned_elastica`), the same strip's thresholds are about 0.1 % higher in
# clamp angle at this Δ, and 1.4 % higher as slopes tan α, the datum `model.clamp_slope`
# prescribes: FvK does not tell an angle from its tangent, an error of order Δ that no mesh
# removes (docs/path_following.md has the table over Δ). The demo prints both and checks the
# angles within 0.2 %.

# %%
rod = turned_strip_elastica_thresholds(DELTA, T, steps=200)
for name, shallow in zip(("bifurcation", "fold"), exact):
    angle = rod[name]
    demo.say(
        f"{name}: elastica angle α/√Δ = {angle / np.sqrt(DELTA):.5f} "
        f"({angle / (shallow * ALPHA) - 1:+.3%} from the shallow one), "
        f"slope tan α/√Δ = {np.tan(angle) / np.sqrt(DELTA):.5f} "
        f"({np.tan(angle) / (shallow * ALPHA) - 1:+.3%})"
    )
    demo.check_close(f"{name} angle, shallow against elastica", shallow * ALPHA, angle, rel=2e-3,
                     source="the elastica at finite Δ")  # fmt: skip
