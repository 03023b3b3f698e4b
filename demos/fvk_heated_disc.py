# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # Föppl–von Kármán: a heated disc, from a bowl to a cylinder
#
# A free disc (radius R = 1, thickness t = 0.01, E = 1, ν = 0.3) is heated more on one face
# than on the other: a temperature difference ΔT through the thickness gives it the isotropic
# natural curvature κ₀ = αΔT/t (`model.natural_curvature`; a bilayer with a mismatch strain
# is the same). A little heat bends it into a bowl, the spherical branch. But a bowl's Gaussian
# curvature stretches its centre and compresses its rim along its circumference, and that
# costs more and more: past a critical κ₀ the rim buckles, the disc
# bends more one way than the other, and the bowl gives way to a pair of cylinder-like shapes
# (Mansfield 1962; Freund 2000; Seffen & McMahon 2007). The path follows the natural curvature
# λκ₀ (κ₀ = 0.1, `path.parameter = "natural_curvature"`) through that bifurcation and switches
# onto the new branch (`path.switch`).
#
# Only the quarter x, y > 0 is meshed: the bowl and the shapes bent along x or y are mirror
# symmetric about both axes (`model.mirror`: ∂w/∂n = 0 and u·n = 0 there), and the O-grid
# mesh is symmetric about the diagonal, so neither bending direction is favoured and the
# bifurcation stays a clean pitchfork. Nothing holds the free disc up: its height is held at the
# centre (`model.pin`). w_center is the rim's height over the centre along x, w_rim_y along y.
#
# Run: `python demos/fvk_heated_disc.py [--paper] [--out DIR]` (also under mpirun): n = 4 (48
# Q2 cells, seconds); `--paper` n = 16 (768 cells), the finest level of docs/path_following.md.

# %%
from pathlib import Path

from mpi4py import MPI

import numpy as np

import dgplate
from dgplate import demo
from dgplate.io.images import save_chart
from dgplate.reference.heated_disc import (
    bifurcation,
    sphere,
    uniform_bifurcation,
    uniform_cylinder,
)

PROBLEM = Path(__file__).parent / "problems" / "fvk_heated_disc.toml"
T, NU, KAPPA0 = 0.01, 0.3, 0.1  # as in the problem file

parser = demo.parser(
    "fvk_heated_disc", "FvK: a heated disc from a bowl to a cylinder", "n = 16", "n = 4"
)
args = demo.parse(parser)
n = 16 if args.paper else 4

# %% [markdown]
# ## The path from the flat disc
#
# Arclength steps of at most 0.1 in load factor; the bifurcation is located where the
# Hessian's lowest eigenvalue changes sign, and the path leaves it along the critical
# eigenvector, the mode cos 2θ.

# %%
problem = dgplate.load_problem(PROBLEM, {"mesh.parameters.n": n})
result = demo.run(problem, args)
load, indices, kinds = demo.branch(result)
rim_x = np.array([row["w_center"] for row in result.history])
rim_y = np.array([row["w_rim_y"] for row in result.history])
demo.say(f"n = {n}: {result['dofs']} dofs, {len(load)} points")
for lam, a, b, index in zip(load, rim_x, rim_y, indices):
    demo.say(f"  κ₀R²/t = {lam * KAPPA0 / T:6.3f}   rim heights {a:.6f} {b:.6f}   index {index}")
demo.check("a bifurcation, then the switch", kinds == ["bifurcation", "switch"])

# %% [markdown]
# ## The bowl against the exact axisymmetric solution
#
# On the bowl the curvature is not uniform: the centre is stretched and the rim compressed
# along its circumference.
# `dgplate.reference.heated_disc.sphere` solves the axisymmetric FvK equations of the free
# disc by shooting (derived there). The rim's height over the centre converges at second
# order: its largest error on the bowl is +0.40, +0.10 and +0.025 % for n = 4, 8 and 16. The
# demo asserts it within 0.5 % (n = 4) or 0.04 % (n = 16), and both rim heights equal to
# 10⁻⁸: the bowl is round.

# %%
at = int(np.flatnonzero(load == result["bifurcations"][0])[0])
bowl = slice(1, at + 1)
exact = np.array([sphere(lam * KAPPA0, T, nu=NU).rim_height for lam in load[bowl]])
error = np.max(np.abs(rim_x[bowl] / exact - 1))
demo.say(f"the bowl's rim height: largest error {error:.3%} over {len(exact)} points")
demo.check_between("bowl's rim height error", error, 0.0, 4e-4 if args.paper else 5e-3)
demo.check("the bowl is round", np.allclose(rim_x[bowl], rim_y[bowl], rtol=1e-8, atol=0))
demo.check("index 0 on the bowl", set(indices[: at + 1]) == {0})

# %% [markdown]
# ## The bifurcation and the cylinder-like branch
#
# `dgplate.reference.heated_disc.bifurcation` finds where the exact bowl bifurcates: it
# perturbs the axisymmetric state by (W(r), Φ(r)) cos 2θ and looks for the natural curvature
# where the free rim's four conditions have a solution, κ₀R²/t = 5.6192 at ν = 0.3. The path's
# bifurcation is +0.60, +0.13 and +0.032 % off it for n = 4, 8 and 16 (second order; the
# extrapolation of the three is within 0.003 %, docs/path_following.md). The demo asserts it
# within 0.8 % (n = 4) or 0.05 % (n = 16). The uniform-curvature model, w = ½(ax² + by²),
# puts it at 8/(1 + ν)^{3/2} = 5.397, 4 % lower: the bowl's curvature is not uniform. Past the
# bifurcation the disc is stable again (index 0) and bends one way: one rim height grows, the
# other falls, as in the model, whose ½aR² and ½bR² are printed beside them (at κ₀R²/t = 10
# the model's ½aR² is 15 % higher than the path's, its ½bR² 6 % lower).

# %%
kappa_b = result["bifurcations"][0] * KAPPA0
exact_b = bifurcation(T, nu=NU, steps=250)
model_b, _ = uniform_bifurcation(T, 1.0, NU)
demo.say(f"bifurcation: κ₀R²/t = {kappa_b / T:.5f}; exact {exact_b / T:.5f} "
         f"({kappa_b / exact_b - 1:+.3%}); uniform-curvature model {model_b / T:.4f}")  # fmt: skip
demo.check_close("bifurcation κ₀", kappa_b, exact_b, rel=5e-4 if args.paper else 8e-3,
                 source="exact cos 2θ bifurcation of the bowl")  # fmt: skip
after = slice(at + 1, None)
demo.check("index 0 on the cylinder-like branch", set(indices[after]) == {0})
major, minor = np.maximum(rim_x, rim_y)[after], np.minimum(rim_x, rim_y)[after]
demo.check(
    "one rim rises, the other falls",
    bool(np.all(np.diff(major) > 0) and np.all(np.diff(minor) < 0)),
)
last = uniform_cylinder(load[-1] * KAPPA0, T, 1.0, NU)
assert last is not None
demo.say(f"at κ₀R²/t = {load[-1] * KAPPA0 / T:.3f}: rim heights {major[-1]:.5f}, {minor[-1]:.5f}; "
         f"uniform-curvature model {last[0] / 2:.5f}, {last[1] / 2:.5f}")  # fmt: skip

# %% [markdown]
# ## The bifurcation diagram
#
# The rim heights along x and y against the natural curvature, with the exact bowl and the
# uniform-curvature model's two branches.

# %%
if MPI.COMM_WORLD.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kappa = np.linspace(1e-4, load.max() * KAPPA0, 60)
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    on_bowl = np.linspace(1e-4, kappa_b, 14)
    ax.plot([sphere(k, T, nu=NU, steps=250).rim_height for k in on_bowl], on_bowl / T, "-",
            color="0.65", lw=3, label="exact bowl (axisymmetric)")  # fmt: skip
    model = [(k, uniform_cylinder(k, T, 1.0, NU)) for k in kappa]
    ax.plot([c[0] / 2 for k, c in model if c], [k / T for k, c in model if c], ":", color="k",
            label="uniform-curvature model, ½aR² and ½bR²")  # fmt: skip
    ax.plot([c[1] / 2 for k, c in model if c], [k / T for k, c in model if c], ":", color="k")
    ax.plot(rim_x, load * KAPPA0 / T, "o-", ms=4, label="path: rim height along x")
    ax.plot(rim_y, load * KAPPA0 / T, "s--", ms=4, label="path: rim height along y")
    ax.plot(rim_x[at], kappa_b / T, "k^", ms=8, label="bifurcation (located)")
    ax.axhline(exact_b / T, color="0.8", lw=0.8, zorder=0)
    ax.annotate("exact bifurcation", (0.0, exact_b / T), (0.0, exact_b / T + 0.2), fontsize=8)
    labels = ("rim height over the centre, w(R) − w(0)", "natural curvature κ₀R²/t")
    title = f"the heated disc, n = {n} ({result['dofs']:,} dofs)"
    save_chart(fig, ax, Path(args.out) / "heated_disc.png", labels, title)
demo.copy_figure(Path(args.out), args.figure, "heated_disc.png")
