# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # A compressed strip that does not touch itself
#
# A Kirchhoff strip $\omega = (-2, 2) \times (0, 1)$ clamped flat at both ends buckles into
# Euler's clamped–clamped elastica when its ends are pushed together by $\Delta$
# (docs/continuation.md). With growing $\Delta/L$ the two flanks of the loop overhang and
# come towards each other below its top; at $\Delta/L \approx 0.85$ they touch (the neck
# closes), and beyond that the elastica passes through itself. With the tangent-point
# potential (Bartels, Meyer and Palus, "Simulating self-avoiding isometric plate bending";
# docs/self_avoidance.md)
#
# $$ I[y] = I_{bend}[y] + \rho\, \mathrm{TP}[y], \qquad
#    \mathrm{TP}[y] = \frac{2^{-q}}{q} \int_\omega \int_\omega r(y(x), y(\tilde x))^{-q}
#    \, dx\, d\tilde x, $$
#
# $q = 4.5 > 4$, the plate cannot touch itself: the neck stays open and the loop is squeezed
# instead.
#
# The flow starts from the exact clamped elastica at $\Delta/L = 0.7$ (an isometry that
# matches the clamped data there), and the clamped ends are moved on by continuation,
# $g = (x_1 \mp c(\alpha), x_2, 0)$, $c = 1.4 + 0.36\alpha$, to $\Delta/L = 0.88$ (α grows by
# 0.01 per flow step). TP is explicit; after every step the least distance of points of
# non-neighbouring cells is measured and a step that halves it, or raises $I$, is redone
# with $\tau/2$.
#
# Run: `python demos/self_avoiding_compressed_strip.py` (16×2 cells, seconds), `--paper`
# for 64×8 cells and δα = 2·10⁻³ (long). Output: `out/self_avoiding_compressed_strip/`, with
# `self_avoiding_compressed_strip.gif` (a picture every 6 steps, the least distance in its title).

# %%
from pathlib import Path

import dgplate
from dgplate import demo

PROBLEM = Path(__file__).parent / "problems" / "self_avoiding_compressed_strip.toml"
args = demo.arguments(
    "self_avoiding_compressed_strip",
    "a compressed strip that does not touch itself",
    "64×8 cells, δα = 2e-3",
)


# %% [markdown]
# ## The start: the clamped elastica
#
# With $\sin(\theta/2) = k \sin\varphi$ the tangent angle of the elastica's centre line
# (docs/continuation.md) has $\lambda\, ds = d\varphi / \sqrt{1 - k^2 \sin^2\varphi}$, and
#
# $$ s = F(\varphi, k)/\lambda, \qquad x = \big(2E(\varphi, k) - F(\varphi, k)\big)/\lambda,
#    \qquad z = 2k(1 - \cos\varphi)/\lambda, \qquad \varphi \in [0, 2\pi], $$
#
# with the incomplete elliptic integrals F, E (computed by the trapezoidal rule on a fine grid
# in φ, `dgplate.reference.elastica.clamped_elastica_curve`). The plate is
# $y = (x(s), x_2, z(s))$, $s = x_1 + 2$: an isometry. The problem file says so,
# `model.start = {type = "elastica", length = 4.0, shortening = 2.8, at = -2.0}`, so that
# `dgplate run` on it starts there too.


# %%
overrides: dict[str, object] = {}
if args.paper:
    overrides = {
        "mesh.cells": [64, 8],
        "model.continuation": {"rate": 2e-3, "stage_steps": 500},
        "flow.max_steps": 1000,
        "output.frames_every": 25,
    }
problem = dgplate.load_problem(PROBLEM, overrides)
result = demo.run(problem, args)  # from the file's model.start: the elastica
demo.copy_figure(args.out, args.figure)

# %% [markdown]
# ## What to look at
#
# The least distance of non-neighbouring points (history.csv, `min_distance`) falls as the
# neck closes, and stays positive; the energy rises with the moving data (work done on the
# plate) but no flow step raised it at fixed data (`energy_increases`).

# %%
distances = demo.check_self_avoiding(
    result, "the ends come together; the neck of the loop stays open"
)
demo.check("the path reached α = 1", result["alpha"] == 1.0)
demo.check_between("least distance against its start", min(distances) / distances[0], high=0.5,
                   source="the neck of the loop closed in")  # fmt: skip
