# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # Föppl–von Kármán: snap-through of a shallow arch, followed through its limit point
#
# A strip of span L = 1, width 0.1 and thickness t = 0.01 (E = 1, ν = 0) is pinned at its short
# edges, which cannot move in-plane either; the long edges are free. Its natural shape is the
# shallow sinusoidal arch w₀ = e sin(πx), rise e = t: the membrane strain is measured from this
# shape (bending from flat, `dgplate.models.fvk`), so the flat strip is a compressed one and the
# unloaded strip stands as an arch. A pressure −λ q* sin(πx) pushes the arch down.
#
# For ν = 0 the strip is exactly a beam, and the one-mode deflection w = a sin(πx) solves the
# FvK equations exactly: the membrane force N = E t π² (a² − e²)/4 is uniform, and equilibrium
# in the mode is
#
#     λ q* = −π⁴ a [D + E t (a² − e²)/4],   D = E t³/12.
#
# The load is cubic in the rise a: it rises from the unloaded arch a₀ = √(e² − t²/3)
# (= √(2/3) t), has its maximum at the limit point a*² = (e² − t²/3)/3, then falls through the
# flat strip (a = 0, an unstable equilibrium) to the inverted arch. The pressure amplitude q* is
# chosen so that the fold is at λ = 1 exactly (`dgplate.reference.fvk.sinusoidal_strip_folds`,
# where this closed form is derived for this FvK strip; it is the low-arch analysis of Fung &
# Kaplan, NACA TN 2840, 1952, with the bending measured from flat). An unsymmetric mode does not
# bifurcate first for e² < 11t²/6, so the symmetric fold is the arch's only critical point.
#
# Under a load that grows past q*, the arch jumps dynamically to the inverted shape: the
# snap-through. Newton over a load schedule cannot pass the fold (there is no equilibrium near
# the arch beyond λ = 1). Pseudo-arclength continuation (`path.method = "arclength"`,
# docs/path_following.md) follows the equilibrium curve by its arclength instead: λ rises, turns
# at the fold (the λ-component of the tangent changes sign) and falls. On the way it counts the
# negative eigenvalues of the Hessian (the stability index): 0 on the rising, stable arch, 1
# on the falling, unstable branch behind the fold.
#
# Run: `python demos/fvk_snap_through.py [--paper] [--out DIR]` (also under mpirun): 16 × 2 Q2
# cells (seconds); `--paper` 64 × 2, the finest mesh of docs/path_following.md.

# %%
from pathlib import Path

import numpy as np

import dgplate
from dgplate import demo
from dgplate.reference.fvk import sinusoidal_strip_folds

PROBLEM = Path(__file__).parent / "problems" / "fvk_arch.toml"
T = 0.01  # thickness and rise of the natural shape, as in the problem file

parser = demo.parser("fvk_snap_through", "FvK: snap-through of a shallow arch", "64 × 2 cells")
args = demo.parse(parser)
cells = 64 if args.paper else 16

# %% [markdown]
# ## The path from the unloaded arch
#
# The problem file `demos/problems/fvk_arch.toml` follows the path from the flat strip (on the
# unstable middle branch); here it starts near the unloaded arch instead, where Newton at λ = 0
# finds the arch a₀ (`initial=`, a shape x ↦ y(x)). The steps grow from ds = 0.2 to at most 0.4
# (in load factor), and the path ends after 14 points.

# %%
overrides = {"mesh.cells": [cells, 2], "path.steps": 14}
problem = dgplate.load_problem(PROBLEM, overrides)


def arch(x: np.ndarray) -> np.ndarray:
    """Near the unloaded arch a₀ = √(2/3) t."""
    return np.array([x[0], x[1], 0.8 * T * np.sin(np.pi * x[0])])


result = demo.run(problem, args, initial=arch)
demo.copy_figure(Path(args.out), args.figure, "branch.png")

# %% [markdown]
# ## The limit point against the closed form
#
# The fold's load factor converges at second order in h to the exact 1: −0.95, −0.24, −0.060
# and −0.015 % on 8, 16, 32 and 64 cells (docs/path_following.md). The demo asserts the fold
# within 0.3 % on 16 cells and 0.02 % on 64, the centre deflection at the fold within 0.5 % of a*,
# and the stability indices: 0 at every point before the fold, 1 at every point after it.

# %%
_, a_fold = sinusoidal_strip_folds(1.0, T, 1.0, T)
load, indices, kinds = demo.branch(result)
demo.say(f"{cells} × 2 Q2 cells, {result['dofs']} dofs, {len(load)} points")
for lam, index in zip(load, indices):
    demo.say(f"  λ = {lam:+.6f}   stability index {index}")
demo.check("one special point, a fold", kinds == ["fold"])
fold = result["folds"][0]
at = int(np.flatnonzero(load == fold)[0])
demo.check_close("fold λ", fold, 1.0, rel=2e-4 if args.paper else 3e-3,
                 source="exact one-mode limit load")  # fmt: skip
demo.check_close("w_c at the fold / a*", result["special_points"][0]["w_center"] / a_fold, 1.0,
                 rel=5e-3, source="exact one-mode limit point")  # fmt: skip
demo.check("stability index 0 at every point before the fold", set(indices[:at]) == {0})
demo.check("stability index 1 at every point after it", set(indices[at + 1 :]) == {1})
