# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # Bilayer plates: aspect ratio × spontaneous curvature
#
# A bilayer is two thin sheets glued together; when one expands relative to the other (heat,
# swelling, an electric stimulus) the plate wants to bend. Its reduced model (Bartels, Bonito
# and Nochetto; [N15]) minimises
#
# $$E[y] = \tfrac12 \int_\omega |I\!I(y) - Z|^2 \quad\text{subject to}\quad
#   \nabla y^T \nabla y = I_2 ,$$
#
# where $I\!I$ is the second fundamental form of the deformed surface and $Z$ the spontaneous
# curvature. For an isotropic bilayer $Z = aI$: the plate would like to curve by $a$ in every
# direction, i.e. become a sphere of radius $1/a$ — which an isometry cannot do (Gauss:
# zero Gaussian curvature). The best it can do is to bend in one direction only, a cylinder of
# radius $1/a$, at the energy $\tfrac12 a^2 |\omega|$.
#
# Clamping one side of the rectangle fixes the rolling axis parallel to that side. How far the
# free part rolls is set by $a$ times its length: $aL$ radians, i.e. $aL/2\pi$ turns. The published
# grid is the aspect ratios (length/clamped side) 0.5, 1, 7/4 and 10/4 times $a = 1, 2, 5$;
# this demo runs its corner 0.5, 1 × $a$ = 1, 2 by default (`--ratios`, `--curvatures` choose
# others; `--paper` runs the whole grid on a finer mesh).
#
# Two things to know when reading the results. First, the default mesh is coarse (6 cells per
# unit length): the fitted radii come out too large by about $0.45\,a h$ (8–11 % for $a = 1$,
# 12–15 % for $a = 2$, 35–50 % for $a = 5$ with $h = 1/6$; halving $h$ halves it), and a
# multi-turn roll tightens only slowly in the flow. The energies sit within a few percent of
# $\tfrac12 a^2|\omega|$ for $a \le 2$ and 14–18 % above for $a = 5$. Second, the flow starts
# flat and bends in every direction at first; on the coarse mesh the longest plate with $a = 5$
# gets trapped in a state whose free end rolls about its *length* axis (that cylinder has the
# same energy density $\tfrac12 a^2$; the transition costs 30 %). With twice the cells
# (`--cells 12`) it rolls about the clamped side like the others: a trap of the coarse discrete
# flow, not a minimiser of the model.
#
# The rectangles are $(0, rW) \times (0, W)$, clamped on $x_1 = 0$, with the clamped side
# $W = 1$ by default; `--width 4` uses the sides 2, 4, 7, 10 × 4 that the ratios 7/4 and 10/4
# suggest (up to eight turns: fine meshes, long runs). Discretisation: Q2 interior-penalty dG,
# gradient flow with first-moment isometry multipliers (`flow.multiplier_degree = 1`) and
# τ = 0.05/(aW) (the isometry defect D_h grows with τ·aW).
#
# Run: `python demos/bilayer_aspect_ratios.py` (4 small runs), `--ratios 0.5 1 1.75 2.5
# --curvatures 1 2 5` for the published grid (several minutes), `--paper` for that grid on 16 cells
# per unit length with a tighter tolerance (long), `--figure PATH` for the combined image.

# %%
import json
from fractions import Fraction
from pathlib import Path

import dgplate
from dgplate import demo
from dgplate.io.montage import montage

PROBLEM = Path(__file__).parent / "problems" / "bilayer_aspect_ratios.toml"
RATIOS, CURVATURES = (0.5, 1.0, 1.75, 2.5), (1.0, 2.0, 5.0)

parser = demo.parser(
    "bilayer_aspect_ratios", "aspect ratio × Z = aI", "the published grid, 16/unit"
)
parser.add_argument("--ratios", type=float, nargs="+", help="length / W (default 0.5 1)")
parser.add_argument("--curvatures", type=float, nargs="+", help="a in Z = aI (default 1 2)")
parser.add_argument("--width", type=float, default=1.0, help="clamped side W (default 1)")
parser.add_argument("--cells", type=int, default=None, help="cells per unit length (default 6)")
parser.add_argument("--replot", action="store_true", help="only redraw the runs in OUT")
args = demo.parse(parser)
ratios = args.ratios or (RATIOS if args.paper else (0.5, 1.0))
curvatures = args.curvatures or (CURVATURES if args.paper else (1.0, 2.0))
per_unit = args.cells or (16 if args.paper else 6)


def label(ratio: float) -> str:
    frac = Fraction(ratio).limit_denominator(8)
    return str(frac) if frac.denominator > 1 else f"{frac.numerator}"


# %% [markdown]
# ## One run per grid cell
#
# Every run is the problem file with overrides: the rectangle, the mesh (about `per_unit`
# cells per unit length, at least 4 along each side), $Z = aI$, τ = 0.05/(aW) and a tolerance
# relative to the ideal energy $E^* = \tfrac12 a^2 |\omega|$ (the flow stops when
# $(E_h^{n-1} - E_h^n)/\tau < 10^{-3} E^*$, i.e. a remaining energy of about 0.5 %).

# %%
results = {}
for a in curvatures:
    for ratio in ratios:
        W, L = args.width, ratio * args.width
        cells = [max(4, round(per_unit * L)), max(4, round(per_unit * W))]
        ideal = 0.5 * a**2 * L * W
        overrides = {
            "mesh.corners": [[0.0, 0.0], [L, W]],
            "mesh.cells": cells,
            "model.Z": a,
            "flow.tau": 0.05 / (a * W),
            "flow.tol": (1e-4 if args.paper else 1e-3) * ideal,
            "flow.max_steps": 8000 if args.paper else 2500,
        }
        problem = dgplate.load_problem(PROBLEM, overrides=overrides)
        problem.name = f"ratio {label(ratio)}, Z = {a:g}I"
        case = f"ratio{ratio:g}_a{a:g}"
        if args.replot:
            summary = json.loads(Path(args.out, case, "summary.json").read_text())
        else:
            summary = demo.run(problem, args, case)
        results[ratio, a] = (summary, ideal, W / cells[1])

# %% [markdown]
# ## The grid
#
# For each run: the energy against the cylinder's $\tfrac12 a^2|\omega|$, the isometry
# defect, the number of steps, and the fitted cylinder (radius against $1/a$ and the relative
# RMS distance of the surface from it — large when the shape is not one cylinder).

# %%
demo.say(
    f"\n{'ratio':>6} {'a':>4} {'E_h':>10} {'a²|ω|/2':>9} {'D_h':>9} {'steps':>6} "
    f"{'R_fit':>7} {'1/a':>6} {'rms':>7}  converged"
)
for (ratio, a), (s, ideal, _) in sorted(results.items(), key=lambda kv: (kv[0][1], kv[0][0])):
    fit = s.get("cylinder_fit", {})
    demo.say(
        f"{label(ratio):>6} {a:>4g} {s['energy']:>10.4f} {ideal:>9.4f} "
        f"{s['isometry_defect']:>9.2e} {s['steps']:>6d} {fit.get('radius', float('nan')):>7.3f} "
        f"{1 / a:>6.3f} {fit.get('rms_residual', float('nan')):>7.1e}  {s['converged']}"
    )

# %% [markdown]
# ## Combined image
#
# As in the published figure: the aspect ratio grows along a row, the spontaneous curvature from
# the bottom row ($a = 1$) to the top.

# %%
rows = sorted(curvatures, reverse=True)
energy = {key: (s["energy"], s["energy"] / ideal) for key, (s, ideal, _) in results.items()}
montage(
    [[Path(args.out, f"ratio{r:g}_a{a:g}", "final.png") for r in ratios] for a in rows],
    args.figure or Path(args.out, "grid.png"),
    captions=[
        [f"E_h = {energy[r, a][0]:.3g} ({energy[r, a][1]:.2f} E*)" for r in ratios] for a in rows
    ],
    row_labels=[f"Z = {a:g} I" for a in rows],
    column_labels=[f"length/W = {label(r)}" for r in ratios],
    title="Bilayer plates clamped on one side (x₁ = 0): aspect ratio × Z = aI",
    note="E* = a²|ω|/2 (the cylinder). Colour: bending |D²y|, each panel on its own scale; "
    "each panel zoomed to fit (grey: the flat plate).",
)

# %% [markdown]
# ## Checks
#
# Measured on 6 cells per unit length (docs/bilayer.md): E_h/E* from 0.95 to 1.04 for
# $a \le 2$; fitted radii 8–15 % too large, at most 0.69 $a h$; every axis parallel to the
# clamped side. The demo asserts, for every run with $a \le 2$: the flow converged with a
# decreasing energy, E_h within 5 % of E*, the axis within 5° of $x_2$ and a radius between
# $1/a$ and $(1 + 0.75\,a h)/a$. For $a > 2$ with ratios up to 2 (E_h measured 1.14–1.18 E*
# for $a = 5$): the flow converged with a decreasing energy, E_h between 0.95 E* and 1.2 E*
# and the axis within 5° of $x_2$. Longer plates with $a > 2$ are shown, not checked (the trap
# above: 1.30 E*); a run of only those says so.

# %%
checked = 0
for (ratio, a), (s, ideal, h) in sorted(results.items()):
    case, fit = f"ratio {label(ratio)}, a = {a:g}", s["cylinder_fit"]
    if a > 2 and ratio > 2:
        demo.say(f"{case}: shown, not checked (the coarse flow may be trapped)")
        continue
    checked += 1
    demo.check(f"{case}: the flow converged and E_h decreased at every step",
               s["converged"] and not s["energy_increases"])  # fmt: skip
    demo.check_between(f"{case}: angle of the axis to x₂ (°)", demo.axis_angle(fit, (0, 1, 0)),
                       high=5.0, source="the clamped side's direction")  # fmt: skip
    if a > 2:  # measured at a = 5, 6 cells per unit: 1.155, 1.175, 1.138 E* (ratios 1/2, 1, 7/4)
        if args.width == 1.0 and per_unit == 6:
            demo.check_between(f"{case}: E_h", s["energy"], 0.95 * ideal, 1.2 * ideal,
                               source="0.95 to 1.2 E*, E* = ½a²|ω|")  # fmt: skip
        else:
            demo.say(
                f"{case}: E_h = {s['energy'] / ideal:.3f} E* (bounds measured at W = 1, 6/unit)"
            )
        continue
    demo.check_close(f"{case}: E_h", s["energy"], ideal, rel=0.05, source="E* = ½a²|ω|")
    demo.check_between(f"{case}: fitted radius", fit["radius"], 1 / a, (1 + 0.75 * a * h) / a,
                       source="1/a, first order in h")  # fmt: skip
if not checked:
    demo.say("WARNING: no check applies to these runs (a > 2 on plates longer than 2 W)")
