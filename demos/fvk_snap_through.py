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
# at the fold (the λ-component of the tangent changes sign) and falls, through the flat strip,
# to the second fold at λ = −1 (a = −a*), where it turns again and rises on the inverted arch:
# the snapped state. Under λ = 1 that state has a = −2a* (the cubic λ(a) − 1 has the double
# root a* and its roots sum to 0): the shape the arch jumps to. On the way the path counts the
# negative eigenvalues of the Hessian (the stability index): 0 on the stable arch, 1 on the
# unstable branch between the folds, 0 again on the snapped arch.
#
# Run: `python demos/fvk_snap_through.py [--paper] [--out DIR]` (also under mpirun): 16 × 2 Q2
# cells (seconds); `--paper` 64 × 2, the finest mesh of docs/path_following.md.

# %%
import dataclasses
from pathlib import Path

from mpi4py import MPI

import numpy as np

import dgplate
from dgplate import demo
from dgplate.reference.fvk import sinusoidal_strip_folds, sinusoidal_strip_load

PROBLEM = Path(__file__).parent / "problems" / "fvk_arch.toml"
T = 0.01  # thickness and rise of the natural shape, as in the problem file

parser = demo.parser(
    "fvk_snap_through", "FvK: snap-through of a shallow arch", "64 × 2 cells", "16 × 2 cells"
)
args = demo.parse(parser)
cells = 64 if args.paper else 16

# %% [markdown]
# ## The path from the unloaded arch
#
# The problem file `demos/problems/fvk_arch.toml` follows the path from the flat strip (on the
# unstable middle branch); here it starts near the unloaded arch instead, where Newton at λ = 0
# finds the arch a₀ (`initial=`, a shape x ↦ y(x)). The steps grow from ds = 0.2 to at most 0.4
# (in load factor), and the path ends on the snapped arch once λ passes `lambda_max` = 1.5 (at
# most 40 points).

# %%
overrides = {"mesh.cells": [cells, 2], "path.steps": 40}
# named after the demo, so that its folder is not taken for the problem file's run
problem = dataclasses.replace(dgplate.load_problem(PROBLEM, overrides), name="fvk_snap_through")


def arch(x: np.ndarray) -> np.ndarray:
    """Near the unloaded arch a₀ = √(2/3) t."""
    return np.array([x[0], x[1], 0.8 * T * np.sin(np.pi * x[0])])


result = demo.run(problem, args, initial=arch)

# %% [markdown]
# ## The folds and the whole path against the closed form
#
# The fold's load factor converges at second order in h to the exact 1: −0.95, −0.24, −0.060
# and −0.015 % on 8, 16, 32 and 64 cells (docs/path_following.md), and the second fold is at
# −λ of the first within 10⁻⁷ (the strip is symmetric under w → −w, λ → −λ). Every point of the
# path lies on the exact curve: the largest |λ − λ(w_c)| over the path is 2.1·10⁻², 4.2·10⁻³,
# 1.1·10⁻³ and 2.7·10⁻⁴ on those meshes. The demo asserts the fold within 0.3 % on 16 cells and
# 0.02 % on 64, the centre deflection there within 0.5 % of a*, the path within 5·10⁻³ (16) or
# 3·10⁻⁴ (64) of the curve, the stability indices 0, 1, 0 between the folds, and that the path
# ends on the snapped arch beyond λ = 1.

# %%
_, a_fold = sinusoidal_strip_folds(1.0, T, 1.0, T)
q_fold = sinusoidal_strip_load(a_fold, 1.0, T, 1.0, T)
load, indices, kinds = demo.branch(result)
rise = np.array([row["w_center"] for row in result.history])
exact = np.array([sinusoidal_strip_load(a, 1.0, T, 1.0, T) for a in rise]) / q_fold
demo.say(f"{cells} × 2 Q2 cells, {result['dofs']} dofs, {len(load)} points")
if MPI.COMM_WORLD.rank == 0:  # the path on the exact curve: snap_through.png
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a = np.linspace(rise.min(), rise.max(), 400)
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    ax.plot(a / a_fold, [sinusoidal_strip_load(v, 1.0, T, 1.0, T) / q_fold for v in a], "-",
            color="0.65", lw=3, label="exact: w = a sin(πx), λ(a) = q(a)/q*")  # fmt: skip
    for index, marker in ((0, "o"), (1, "s")):
        on = indices == index
        ax.plot(rise[on] / a_fold, load[on], marker, ms=4, ls="none",
                label=f"path, stability index {index}")  # fmt: skip
    folds = [p for p in result["special_points"] if p["kind"] == "fold"]
    ax.plot([p["w_center"] / a_fold for p in folds], [p["load_factor"] for p in folds], "k^",
            ms=8, label="folds (located)")  # fmt: skip
    ax.axhline(1.0, color="0.8", lw=0.8, zorder=0)
    ax.annotate("snapped arch\nunder λ = 1: a = −2a*", (-2, 1), (-1.6, 1.35),
                arrowprops={"arrowstyle": "->"})  # fmt: skip
    ax.set_xlabel("centre deflection w_c / a*")
    ax.set_ylabel("load factor λ")
    ax.set_title(f"the shallow arch on {cells} × 2 Q2 cells, round both folds")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(Path(args.out) / "snap_through.png", dpi=150)
    plt.close(fig)
demo.copy_figure(Path(args.out), args.figure, "snap_through.png")
for lam, a, index in zip(load, rise, indices):
    demo.say(f"  λ = {lam:+.6f}   w_c/a* = {a / a_fold:+.4f}   stability index {index}")
demo.check("two special points, both folds", kinds == ["fold", "fold"])
fold, second = result["folds"]
first, last = (int(np.flatnonzero(load == f)[0]) for f in (fold, second))
demo.check_close("fold λ", fold, 1.0, rel=2e-4 if args.paper else 3e-3,
                 source="exact one-mode limit load")  # fmt: skip
demo.check_close("w_c at the fold / a*", result["special_points"][0]["w_center"] / a_fold, 1.0,
                 rel=5e-3, source="exact one-mode limit point")  # fmt: skip
demo.check_close("second fold λ", second, -fold, rel=1e-6, source="the symmetry w → −w, λ → −λ")
demo.check_between("largest |λ − λ(w_c)| over the path", np.abs(load - exact).max(),
                   high=3e-4 if args.paper else 5e-3, source="the exact equilibrium curve")  # fmt: skip
demo.check("stability index 0 before the fold", set(indices[:first]) == {0})
demo.check("stability index 1 between the folds", set(indices[first + 1 : last]) == {1})
demo.check("stability index 0 on the snapped arch", set(indices[last + 1 :]) == {0})
demo.check(
    "the path ends on the snapped arch beyond λ = 1", load[-1] > 1 and rise[-1] < -2 * a_fold
)
