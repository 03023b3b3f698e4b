# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # The elastic trefoil: a knotted rod relaxes towards the doubly covered circle
#
# A closed inextensible rod of length $L$ tied into a trefoil knot cannot become a circle:
# it would have to pass through itself. Its bending energy
# $\frac{c_b}{2}\int_0^L |u''|^2$ is nevertheless bounded below only by the value of the
# *doubly covered circle* of length $L$ (two turns of radius $L/4\pi$):
#
# $$\inf_{\text{trefoils}} \frac{c_b}{2}\int_0^L |u''|^2
#   = \frac{c_b}{2}\Big(\frac{4\pi}{L}\Big)^2 L = \frac{c_b}{2}\,\frac{(4\pi)^2}{L},$$
#
# which is not attained by any embedded curve (Gerlach, Reiter and von der Mosel, *The elastic
# trefoil is the doubly covered circle*, Arch. Ration. Mech. Anal. 225 (2017)). The lower
# bound: a knotted closed curve has total curvature $\int|u''| \ge 4\pi$ (Fáry–Milnor), so by
# Cauchy–Schwarz $\int|u''|^2 \ge (4\pi)^2/L$; the doubly covered circle has $|u''| = 4\pi/L$.
#
# **Elastic knots.** dgplate keeps the knot type with the tangent-point energy $\rho\,TP[u]$
# (`model.self_avoidance`, docs/rods.md), which is infinite on curves that touch themselves.
# The minimisers of $I + \rho\,TP$ are the *elastic knots* as $\rho \to 0$ (Gallotti and
# von der Mosel; Bartels and Reiter 2021 compute them by a flow). This demo relaxes the
# trefoil at a decreasing $\rho$, each stage started from the previous stage's final
# centreline and frame (`dgplate.models.rod.start.RodStart`), and watches the bending energy approach
# the doubly covered circle's from above while the least distance of non-neighbouring
# points stays positive.
#
# **Start.** `model.curve` is the trefoil $t \mapsto (\sin t + 2\sin 2t,\ \cos t - 2\cos 2t,\
# -\sin 3t)$, $t\in[0,2\pi]$, parametrised by arc length and scaled to $L = 1$; its frame is
# $e_3$ made orthogonal to the tangent. $c_b = 1$, $c_t = 0.5$, $q = 3$.
#
# Run: `python demos/rod_trefoil.py` (32 cells, τ = 0.05, ρ = 0.1, 0.03, 0.01, each stage until
# ΔE/τ < 10⁻³ or 400 steps, about 30 s); `--paper`: 96 cells, ρ down to 0.001 (1000 steps at
# most per stage, about 2.5 minutes). Output:
# `out/rod_trefoil/rho_<ρ>/` (VTX, final.png, history.csv, summary.json for every stage) and
# `out/rod_trefoil/stages.gif`.

# %%
import math
from pathlib import Path

import numpy as np

import dgplate
from dgplate import demo
from dgplate.io.images import frames_to_gif
from dgplate.models.rod.start import RodStart

PROBLEM = Path(__file__).parent / "problems" / "rod_trefoil.toml"
LENGTH, C_B = 1.0, 1.0
LIMIT = 0.5 * C_B * (4.0 * math.pi) ** 2 / LENGTH  # the doubly covered circle
args = demo.arguments("rod_trefoil", "The elastic trefoil", "96 cells, ρ down to 0.001")


def start_bending(samples: int = 20000) -> float:
    """(c_b/2)∫κ² ds of the start: the trefoil formula scaled to the length L."""
    t = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
    d1 = np.array(
        [np.cos(t) + 4 * np.cos(2 * t), -np.sin(t) + 4 * np.sin(2 * t), -3 * np.cos(3 * t)]
    )
    d2 = np.array(
        [-np.sin(t) - 8 * np.sin(2 * t), -np.cos(t) + 8 * np.cos(2 * t), 9 * np.sin(3 * t)]
    )
    speed = np.linalg.norm(d1, axis=0)
    curvature2 = np.sum(np.cross(d1, d2, axis=0) ** 2, axis=0) / speed**6
    dt = 2.0 * math.pi / samples
    length = float(np.sum(speed) * dt)
    # scaling the curve by L/length multiplies κ by length/L and ds by L/length
    return 0.5 * C_B * float(np.sum(curvature2 * speed) * dt) * length / LENGTH


# %%
STAGES: tuple[float, ...]
if args.paper:
    STAGES = (0.1, 0.03, 0.01, 0.003, 0.001)
    overrides = {"model.cells": 96, "flow.max_steps": 1000}
else:
    STAGES, overrides = (0.1, 0.03, 0.01), {}
rows, initial, least = [], None, math.inf
for rho in STAGES:
    problem = dgplate.load_problem(
        PROBLEM, overrides={**overrides, "model.self_avoidance": {"rho": rho, "q": 3.0}}
    )
    problem.name = f"trefoil, rho = {rho:g}"
    result = demo.run(problem, args, f"rho_{rho:g}", initial=initial)
    if not isinstance(result, dgplate.Result):
        raise SystemExit("--resume of a finished stage: run the demo again without --resume")
    demo.check(f"ρ = {rho:g}: the energy fell at every step", result["energy_increases"] == [])
    stage_least = min(float(row["min_distance"]) for row in result.history)
    least = min(least, stage_least)
    rows.append((rho, result, stage_least))
    initial = RodStart(result.fields)

# %% [markdown]
# ## Measured
#
# By default (32 cells: 278, 122 and 106 steps) and with `--paper`: docs/rods.md has
# the table. The demo prints, for every stage, ρ, the total energy $I_h + \rho TP_h$, the
# bending energy, its ratio to the doubly covered circle's, the least distance of
# non-neighbouring points over the whole stage and the wall time. It asserts: the energy fell
# at every step of every stage; the least distance stayed above a quarter of the cell length
# (the strands kept apart: 0.024 at 32 cells, h = 0.031, by default) and the
# writhe never jumped (a crossing changes it by ±2); the bending energy fell from stage to
# stage; and the final bending energy lies above the doubly covered circle's
# $(c_b/2)(4\pi)^2/L = 78.96$ (Fáry–Milnor) and within 10 % of it by default (measured
# 1.060 times it after ρ = 0.01; 1.177 after the first stage, 1.43 at the start), within 3 %
# with `--paper` (measured 1.022 after ρ = 0.001).

# %%
bending0 = start_bending()
demo.say(f"start: bending energy {bending0:.3f}; the doubly covered circle: {LIMIT:.3f}")
demo.say("    rho   energy  bending  bending/limit  least distance  wall time")
for rho, result, stage_least in rows:
    demo.say(
        f"{rho:7.3g} {result['energy']:8.3f} {result['energy_bending']:8.3f} "
        f"{result['energy_bending'] / LIMIT:13.4f} {stage_least:15.4e} "
        f"{result['wall_time_s']:8.1f} s"
    )
final = rows[-1][1]
jumps = [
    abs(float(b["writhe"]) - float(a["writhe"]))
    for _, result, _ in rows
    for a, b in zip(result.history, result.history[1:], strict=False)
]
cell_length = problem.model.length / problem.model.cells
demo.check_between("least distance of non-neighbouring points", least, low=0.25 * cell_length)
demo.check_between("largest change of the writhe in one step", max(jumps), high=0.5)
bendings = [result["energy_bending"] for _, result, _ in rows]
demo.check("the bending energy fell from stage to stage", bendings == sorted(bendings)[::-1])
demo.check_between("final bending energy / the doubly covered circle's",
                   final["energy_bending"] / LIMIT, 1.0, 1.03 if args.paper else 1.10,
                   source="measured 1.022 with --paper" if args.paper else "measured 1.060")  # fmt: skip

# %% [markdown]
# The pictures show the rod as a tube with a red stripe along the director $b$: every stage's
# `final.png`, and `stages.gif`, the stages in turn. `--figure PATH` copies the last stage's
# picture.

# %%
pictures = [Path(args.out, f"rho_{rho:g}", "final.png") for rho in STAGES]
if all(picture.is_file() for picture in pictures):
    frames_to_gif(pictures, Path(args.out, "stages.gif"), fps=1.0)
if args.figure:
    demo.copy_figure(Path(args.out, f"rho_{STAGES[-1]:g}"), args.figure)
