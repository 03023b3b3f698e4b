# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # The classic curved-crease shape: an annulus folded along its mid-circle
#
# Fold a paper annulus along its middle circle and it will not stay flat, nor become two
# coaxial cones: it buckles into a saddle, the crease becomes a closed space curve and the fold
# angle varies along it (Dias, Dudte, Mahadevan & Santangelo, "Geometric mechanics of curved
# crease origami", PRL 2012). The reason is geometric. Folding along a curve of geodesic
# curvature 1/R_c by an angle φ gives the crease the space curvature κ = 1/(R_c cos(φ/2)) —
# more than a flat circle of the same length 2πR_c has — and a closed curve of fixed length
# with more curvature than a circle must leave the plane.
#
# ## What is reproduced, and what differs
#
# The references of this project treat curved creases with the same model: a piecewise
# nonlinear Kirchhoff (or bilayer) plate, continuous across C, whose gradient may jump there
# (Bartels–Bonito–Hornung, "Modeling and simulation of thin sheet folding", Interfaces Free
# Bound. 2022), discretised by dG with the crease resolved by the mesh; Bonito–Nochetto–Yang
# ("Γ-convergent LDG method for large bending deformations of bilayer plates", 2023) extend
# this to bilayers and to *piecewise quadratic* creases, and show a bilayer with a curved
# crease. This demo does not take their set-ups (domains, Z, τ) and claims none of their
# numbers. What it reproduces is the experiment the folding papers illustrate: the annulus 0.8 < |x| < 1.2 creased along
# |x| = 1, free (no clamps, no load), with
#
# - the model of Bonito–Nochetto–Yang: a bilayer plate with a crease, the fold driven by the
#   spontaneous curvature Z = ±(t/r) e_θ⊗e_θ of opposite signs on the two sides of C (t = 3).
#   On a sector this Z folds the sheet into two cones with fold angle 2 atan t ≈ 143° at zero
#   energy (see demos/bilayer_crease.py); the closed annulus cannot close up the cones and
#   buckles instead;
# - curved cells along C (gmsh `order = 2`), the counterpart of their quadratic creases.
#
# It differs from the paper experiment of Dias et al. in how the fold is made: there the crease
# is plastically set to a rest angle and the sheet is otherwise elastic; here the crease is a
# free hinge and the fold angle results from the competition of Z with the isometry constraint.
# So the fold angle is not prescribed but measured: it oscillates along C between roughly 30°
# and 65° (the signature of the broken axial symmetry), far below the 143° of the cones.
#
# Run: `python demos/annulus_fold.py` (h = 0.2, 15 s), `--paper` for h = 0.1 (37 steps, under
# a minute), `--t 1.5`, `--out DIR`; `mpirun -n 2 python demos/annulus_fold.py`.
# `dgplate run demos/problems/annulus_fold.toml` runs it with straight cell edges along C
# (`order = 1` in the file; `order = 2` gives the curved cells of this demo).

# %%
import math
from pathlib import Path

import dgplate
from dgplate import demo

PROBLEM = Path(__file__).parent / "problems" / "annulus_fold.toml"

parser = demo.parser("annulus_fold", "an annulus folded along its mid-circle", paper="h = 0.1")
parser.add_argument("--t", type=float, default=3.0, help="Z = ±(t/r) e_θ⊗e_θ")
args = demo.parse(parser)

# %% [markdown]
# ## The problem: the problem file with curved cells and the chosen t
#
# Z as formulas in x, y; `where(x*x + y*y < 1, a, b)` tells the two sides of C apart.

# %%
sign = f"where(x*x + y*y < 1, {args.t}, {-args.t})"
r3 = "sqrt(x*x + y*y)**3"
Z = [[f"{sign}*y*y/{r3}", f"-{sign}*x*y/{r3}"], [f"-{sign}*x*y/{r3}", f"{sign}*x*x/{r3}"]]
overrides = {"mesh.parameters.h": 0.1 if args.paper else 0.2, "mesh.parameters.order": 2}
problem = dgplate.load_problem(PROBLEM, overrides={**overrides, "model.Z": Z})
summary = demo.run(problem, args)
demo.copy_figure(args.out, args.figure)

# %% [markdown]
# ## What to look at
#
# `final.png`: the annulus has left the plane; the red crease line is a closed space curve.
# The bounding box in `summary.json` shows it (the flat annulus has z = 0 and |x|, |y| ≤ 1.2).
# The fold angle along C has a wide spread between its minimum and maximum: the fold is
# sharpest where the saddle bends most. The energy stays well above zero: the frustration of a
# closed crease. Measured at h = 0.2: E_h = 9.26 against the flat annulus's 11.46, fold angle
# 32.5°–79.9° (mean 61.6°), z from −0.39 to 0.37, 148 steps, D_h = 3.3e−15 (adaptive τ with
# the defect bound, see the problem file; from step 32 on at the largest τ, where E_h falls
# slowly from 9.4526 as the shape leaves a state of nearly zero gradient); at h = 0.1,
# 22.6°–61.7° (mean 45.7°), E_h = 9.73, 37 steps, D_h = 9.6e−15.
#
# The demo asserts these statements: the flow converged with a decreasing energy; the annulus
# left the plane (a height of at least 0.1, a twelfth of its radius); the fold angle spreads over
# at least 0.3 of its mean (0.77 measured; 0.57 with `--t 1.5`); the largest fold angle is below
# the two cones' 2 atan t, the fold of the unfrustrated sheet (measured 0.56 of it at h = 0.2,
# 0.43 at h = 0.1); E_h lies between half the flat annulus's ½∫|Z|² and that energy.

# %%
fold = summary["fold_angle_deg"]
(lo, hi) = summary["bbox"]
p = problem.mesh.parameters
flat = 0.5 * args.t**2 * 2 * math.pi * math.log(p["R_out"] / p["R_in"])  # ½∫|Z|², |Z| = t/r
cones = math.degrees(2 * math.atan(args.t))
demo.say(f"\nt = {args.t:g}: two cones would fold by {cones:.1f}°")
demo.report(summary, f"flat: {flat:.4f}")
demo.say(
    f"fold angle along C: min {fold['min']:.1f}°, mean {fold['mean']:.1f}°, max {fold['max']:.1f}°"
)
demo.say(
    f"bounding box: x {lo[0]:.3f}..{hi[0]:.3f}, y {lo[1]:.3f}..{hi[1]:.3f}, "
    f"z {lo[2]:.3f}..{hi[2]:.3f}"
)
demo.check("the flow converged and E_h decreased at every step",
           summary["converged"] and not summary["energy_increases"])  # fmt: skip
demo.check_between("height", hi[2] - lo[2], low=0.1, source="the annulus leaves the plane")
# measured spread / mean: 0.77 at t = 3 (h = 0.2), 0.57 at t = 1.5 (20.2°–37.9°, mean 31.2°)
demo.check_between("fold angle spread / mean", (fold["max"] - fold["min"]) / fold["mean"],
                   low=0.3, source="the fold angle varies along C")  # fmt: skip
# measured at t = 3: 79.9° (h = 0.2), 61.7° (h = 0.1), against the cones' 143.1°
demo.check_between("largest fold angle", fold["max"], high=cones,
                   source="the two cones' 2 atan t")  # fmt: skip
demo.check_between("E_h", summary["energy"], 0.5 * flat, flat, source="the flat annulus: ½∫|Z|²")
