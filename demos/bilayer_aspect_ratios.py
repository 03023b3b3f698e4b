# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: percent
# ---

# %% [markdown]
# # Bilayer plates: aspect ratio × spontaneous curvature
#
# A bilayer is two thin sheets glued together; when one expands relative to the other (heat,
# swelling, an electric stimulus) the plate wants to bend. Its reduced model (Bartels, Bonito
# and Nochetto, seed 001) minimises
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
# free part rolls is set by $a$ times its length: $aL$ radians, i.e. $aL/2\pi$ turns. This demo
# runs the seed's grid: aspect ratios (length/clamped side) 0.5, 1, 7/4 and 10/4 times
# $a = 1, 2, 5$.
#
# Two things to know when reading the results. First, the default mesh is coarse: the fitted
# radii come out too large by about $0.45\,a h$ (8–11 % for $a = 1$, 12–15 % for $a = 2$,
# 35–50 % for $a = 5$ with $h = 1/6$; halving $h$ halves it: 17 % for $a = 5$ on the short plate
# with `--cells 12`), and a multi-turn roll tightens only slowly in the flow. The energies sit
# within a few percent of $\tfrac12 a^2|\omega|$ for $a \le 2$ and 14–18 % above for $a = 5$.
# Second, the flow starts flat and bends in every direction at first; on the coarse default
# mesh the longest plate with $a = 5$ gets trapped in a state whose free end rolls about its
# *length* axis (that cylinder has the same energy density $\tfrac12 a^2$; the transition
# costs 30 %). With twice the cells (`--cells 12`) it rolls about the clamped side like the
# others, so this is a trap of the coarse discrete flow, not a minimiser of the model.
#
# The rectangles are $(0, rW) \times (0, W)$, clamped on $x_1 = 0$, with the clamped side
# $W = 1$ by default (up to two turns for $a = 5$); `--width 4` uses the sides 2, 4, 7, 10 × 4
# that the ratios 7/4 and 10/4 suggest (up to eight turns: fine meshes, long runs).
# Discretisation: Q2 interior-penalty dG, gradient flow with first-moment isometry multipliers
# (`flow.multiplier_degree = 1`) and τ = 0.05/(aW) (the isometry defect D_h grows with τ·aW).
#
# Run: `python demos/bilayer_aspect_ratios.py` (12 small runs, 6 cells per unit length, several
# minutes in all), `--ratios 1 2.5 --curvatures 5` for a part of the grid, `--paper` for 16
# cells per unit length and a tighter tolerance (long), `--figure PATH` for the combined image.

# %%
import argparse
import json
from fractions import Fraction
from pathlib import Path

from mpi4py import MPI

from dgplate.io.output import print0
from dgplate.problems.runner import run_problem
from dgplate.problems.specs import load_problem

PROBLEM = Path(__file__).parent / "problems" / "bilayer_aspect_ratios.toml"
RATIOS = (0.5, 1.0, 1.75, 2.5)
CURVATURES = (1.0, 2.0, 5.0)

parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--paper", action="store_true", help="16 cells per unit length, tol/10")
parser.add_argument("--out", default="out/bilayer_aspect_ratios", help="output directory")
parser.add_argument("--figure", default=None, help="combined image (default OUT/grid.png)")
parser.add_argument("--ratios", type=float, nargs="+", default=RATIOS, help="length / W")
parser.add_argument("--curvatures", type=float, nargs="+", default=CURVATURES, help="a in Z = aI")
parser.add_argument("--width", type=float, default=1.0, help="clamped side W (default 1)")
parser.add_argument("--cells", type=int, default=None, help="cells per unit length (default 6)")
parser.add_argument(
    "--replot", action="store_true", help="only redraw the grid from the runs in OUT"
)
args, _ = parser.parse_known_args()
comm = MPI.COMM_WORLD
per_unit = args.cells or (16 if args.paper else 6)
out = Path(args.out)


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
for a in args.curvatures:
    for ratio in args.ratios:
        W, L = args.width, ratio * args.width
        cells = [max(4, round(per_unit * L)), max(4, round(per_unit * W))]
        ideal = 0.5 * a**2 * L * W
        tol = (1e-4 if args.paper else 1e-3) * ideal
        overrides = [
            f"mesh.corners=[[0.0, 0.0], [{L}, {W}]]",
            f"mesh.cells=[{cells[0]}, {cells[1]}]",
            f"model.Z={a}",
            f"flow.tau={0.05 / (a * W)}",
            f"flow.tol={tol}",
            f"flow.max_steps={8000 if args.paper else 2500}",
        ]
        problem = load_problem(PROBLEM, overrides)
        problem.name = f"ratio {label(ratio)}, Z = {a:g}I"
        case = out / f"ratio{ratio:g}_a{a:g}"
        if args.replot:
            summary = json.loads((case / "summary.json").read_text())
        else:
            summary = run_problem(problem, case, comm)
        results[ratio, a] = (summary, case / "final.png", ideal)

# %% [markdown]
# ## The grid
#
# For each run: the energy against the cylinder's $\tfrac12 a^2|\omega|$, the isometry
# defect, the number of steps, and the fitted cylinder (radius against $1/a$ and the relative
# RMS distance of the surface from it — large when the shape is not one cylinder).

# %%
print0(
    comm,
    f"\n{'ratio':>6} {'a':>4} {'E_h':>10} {'a²|ω|/2':>9} {'D_h':>9} {'steps':>6} "
    f"{'R_fit':>7} {'1/a':>6} {'rms':>7}  converged",
)
for (ratio, a), (s, _, ideal) in sorted(results.items(), key=lambda kv: (kv[0][1], kv[0][0])):
    fit = s.get("cylinder_fit", {})
    print0(
        comm,
        f"{label(ratio):>6} {a:>4g} {s['energy']:>10.4f} {ideal:>9.4f} "
        f"{s['isometry_defect']:>9.2e} {s['steps']:>6d} {fit.get('radius', float('nan')):>7.3f} "
        f"{1 / a:>6.3f} {fit.get('rms_residual', float('nan')):>7.1e}  {s['converged']}",
    )

# %% [markdown]
# ## Combined image
#
# As in the seed's figure: the aspect ratio grows along a row, the spontaneous curvature from
# the bottom row ($a = 1$) to the top ($a = 5$).

# %%
if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt

    ratios = sorted({r for r, _ in results})
    curvs = sorted({a for _, a in results}, reverse=True)
    fig, axes = plt.subplots(
        len(curvs), len(ratios), figsize=(3.2 * len(ratios), 2.6 * len(curvs)), squeeze=False
    )
    for i, a in enumerate(curvs):
        for j, ratio in enumerate(ratios):
            ax = axes[i][j]
            ax.set_xticks([])
            ax.set_yticks([])
            for side in ax.spines.values():
                side.set_visible(False)
            if (ratio, a) not in results:
                continue
            s, png, ideal = results[ratio, a]
            image = mpimg.imread(png)
            h, w = image.shape[:2]
            ax.imshow(image[int(0.07 * h) : int(0.80 * h), int(0.05 * w) : int(0.95 * w)])
            ax.set_title(f"E_h = {s['energy']:.3g} ({s['energy'] / ideal:.2f} E*)", fontsize=9)
            if i == len(curvs) - 1:
                ax.set_xlabel(f"length/W = {label(ratio)}", fontsize=11)
            if j == 0:
                ax.set_ylabel(f"Z = {a:g} I", fontsize=11)
    fig.suptitle("Bilayer plates clamped on one side (x₁ = 0): aspect ratio × Z = aI", fontsize=13)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.text(
        0.5,
        0.01,
        "E* = a²|ω|/2 (the cylinder). Colour: bending |D²y|, each panel on its own scale; "
        "each panel zoomed to fit (grey: the flat plate).",
        ha="center",
        fontsize=9,
    )
    figure = Path(args.figure) if args.figure else out / "grid.png"
    figure.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(figure, dpi=110)
    print0(comm, f"combined image → {figure}")
