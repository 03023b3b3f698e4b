# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # Liquid-crystal-elastomer strips: splay and twist
#
# A nematic elastomer sheet whose director varies through the thickness bends when it is
# actuated (by heat or light): the layers on the two faces want to shrink along different
# directions. Agostiniani and DeSimone (2017) derived the plate limit
#
# $$I_{lce}[y] = \frac12 \int_\omega |I\!I(y) - A|^2 \quad\text{subject to}\quad
#   \nabla y^T \nabla y = I_2, \qquad
#   A = \gamma \begin{cases} \mathrm{diag}(-1, 1) & \text{twist (the director turns by } \pi/2),\\
#   \mathrm{diag}(-1, 0) & \text{splay (in-plane on one face, normal on the other)}, \end{cases}$$
#
# rotated by the in-plane director angle $\theta$: $A = \gamma R(\theta) A_0 R(\theta)^T$
# (`model.name = "lce"`, keys `director`, `gamma`, `theta`). It is the bilayer energy with the
# spontaneous curvature $Z = A$.
#
# **Exact minima** (docs/lce.md). An isometry has $I\!I = \kappa\, e \otimes e$, and
# $\frac12|\kappa\, e\otimes e - A|^2 \ge \frac12 a_{\min}^2$, $a_{\min}$ the eigenvalue of $A$ of
# smaller magnitude, with equality for bending by the other eigenvalue along its eigenvector.
# For constant $A$ a cylinder does that everywhere:
#
# - **splay**: $a_{\min} = 0$, the plate rolls with $\kappa = -\gamma$ along the director
#   $e_1$: energy **0**;
# - **twist**: $A$ is a saddle, which no isometry can follow (frustration). Eigenvalues
#   $\mp\gamma$: the plate rolls *either* with $\kappa = -\gamma$ along $e_1$ *or* with
#   $\kappa = +\gamma$ along $e_2$, both at the energy $\frac12\gamma^2|\omega|$.
#
# The strip $\omega = (0, 3) \times (0, 1)$ is free (nothing clamped: the flow's metric gets the
# L² product), γ = 1, θ = 0. The twist is run twice, from two nearby starts: cylinders of
# curvature −0.1 along $e_1$ and +0.1 along $e_2$ (exact isometries, 10 % of the way). Each
# start leads to its own minimiser.
#
# Discretisation: Q2, DG1 multipliers, two projection steps (D_h at round-off), the edge
# moments and over-penalised gradient jumps (γ₁ = 1000, p = 3): the free-edge layer of the
# bilayer cylinder (docs/bilayer.md) would otherwise lower the twist energy by 3 % at 12 × 4.
#
# Run: `python demos/lce_strip.py` (12 × 4 cells, about a minute), `--paper` for 24 × 8.
# Output: `out/lce_strip/{splay,twist_e1,twist_e2}/` (VTX, final.png, summary.json) and
# `strips.png`, the three final pictures side by side (`--figure PATH` copies it).

# %%
from pathlib import Path

import numpy as np

import dgplate
from dgplate import demo
from dgplate.io.montage import montage

PROBLEM = Path(__file__).parent / "problems" / "lce_strip.toml"
GAMMA, AREA = 1.0, 3.0
args = demo.arguments("lce_strip", "LCE strips: splay and twist", "24 × 8 cells")


def cylinder(kappa: float, along: int):
    """x ↦ the cylinder of curvature κ along e₁ (along = 0) or e₂ (along = 1), an isometry."""

    def y(x: np.ndarray) -> np.ndarray:
        out = x.copy()
        out[along] = np.sin(kappa * x[along]) / kappa
        out[2] = (1.0 - np.cos(kappa * x[along])) / kappa
        return out

    return y


# %%
cells = [24, 8] if args.paper else [12, 4]
CASES = {
    "splay": ({"model.director": "splay"}, None),
    "twist_e1": ({"model.director": "twist"}, cylinder(-0.1 * GAMMA, 0)),
    "twist_e2": ({"model.director": "twist"}, cylinder(0.1 * GAMMA, 1)),
}
summaries = {}
for name, (overrides, initial) in CASES.items():
    problem = dgplate.load_problem(PROBLEM, overrides={"mesh.cells": cells, **overrides})
    problem.name = f"lce {name.replace('_', ' from ')}"
    summaries[name] = demo.run(problem, args, name, initial=initial)

# %% [markdown]
# ## Energies and shapes, measured
#
# For each run: E_h against the exact minimum, D_h, and the area-weighted mean second
# fundamental form $\overline{I\!I}$ (reference coordinates), which is $-\gamma\, e_1\otimes e_1$
# for the roll and $+\gamma\, e_2 \otimes e_2$ for the gutter.
#
# Measured by default (12 × 4): splay E_h = 0.0077 (0.5 % of ½γ²|ω| = 1.5, the flat plate's
# energy), mean II = diag(−0.992, 0.000), 57 steps; twist from $e_1$: E_h = 1.5005
# (+0.03 %), diag(−0.988, 0.004), 58 steps; from $e_2$: E_h = 1.5013 (+0.09 %),
# diag(−0.004, 0.989), 36 steps; D_h ≤ 7·10⁻¹⁵ in all three. docs/lce.md has the 24 × 8 runs.
#
# The demo asserts: every run converged with a decreasing energy and D_h ≤ 10⁻⁸; the splay
# energy within 2 % of ½γ²|ω| of 0, the twist energies within 2 % of ½γ²|ω| and within 1 % of
# each other; the splay and the first twist run bend along $e_1$ with κ ≈ −γ, the second twist
# run along $e_2$ with κ ≈ +γ (mean II within 0.05γ).

# %%
scale = 0.5 * GAMMA**2 * AREA
expected = {
    "splay": (0.0, np.diag([-GAMMA, 0.0])),
    "twist_e1": (scale, np.diag([-GAMMA, 0.0])),
    "twist_e2": (scale, np.diag([0.0, GAMMA])),
}
montage(
    [[Path(args.out, name, "final.png") for name in CASES]],
    Path(args.out, "strips.png"),
    captions=[[f"{name.replace('_', ' from ')}: E_h = {summaries[name]['energy']:.4f} "
               f"(exact {expected[name][0]:g})" for name in CASES]],
    title=f"LCE strip (0, 3) × (0, 1), free, γ = 1, {cells[0]} × {cells[1]} Q2",
)  # fmt: skip
demo.copy_figure(args.out, args.figure, name="strips.png")
for name, summary in summaries.items():
    energy, II = expected[name]
    mean_II = np.array(summary["mean_second_fundamental_form"])
    demo.say(f"\n{name}:")
    demo.report(summary, f"exact {energy:g}")
    demo.say(f"    mean II {mean_II.round(4).tolist()} (exact {II.tolist()})")
    demo.check(f"{name}: converged", summary["converged"])
    demo.check(f"{name}: the energy fell at every step", summary["energy_increases"] == [])
    demo.check_between(f"{name}: D_h", summary["isometry_defect"], high=1e-8)
    demo.check_close(f"{name}: E_h", summary["energy"], energy, abs=0.02 * scale,
                     source="exact isometric minimum, ± 2 % of ½γ²|ω|")  # fmt: skip
    demo.check_between(f"{name}: |mean II − exact|", float(np.abs(mean_II - II).max()), high=0.05)
first, second = (summaries[k]["energy"] for k in ("twist_e1", "twist_e2"))
demo.check_close("twist: E_h(e2) / E_h(e1)", second / first, 1.0, rel=0.01,
                 source="two minimisers of equal energy")  # fmt: skip
