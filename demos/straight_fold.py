# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # A straight fold is exact in the discrete space
#
# A sheet ω = (−1, 1) × (0, 1) carries a crease C along x = 0. Along C the deformation must stay
# continuous but its gradient may jump: the bending energy is ½∫_{ω∖C} |D²y|². In the
# interior-penalty dG method this means that on the faces of C the gradient-jump terms
# (consistency −{D²y n}:[∇y] and penalty γ₁h⁻¹|[∇y]|²) are dropped while the value-jump terms
# stay (docs/design.md §1–§2).
#
# The left and right edges are clamped with the data of the sheet folded by φ about C:
#
#     g = (x, y, 0)  (x < 0),    g = (x cos φ, y, x sin φ)  (x > 0),    Φ = ∇g.
#
# The folded sheet is affine on each side, so it lies in [DG₂]³ as soon as the mesh resolves C.
# It has no curvature, no value jumps, matches the clamped data exactly (the Nitsche data sit
# inside the boundary jumps, so they contribute nothing either) and is an isometry: E_h = 0 and
# D_h = 0 to round-off, and it is a minimiser — the gradient flow started there does not move.
# With the gradient-jump terms kept on C (an ordinary plate, `model.crease = []`) the folded
# state costs ½γ₁ Σ_e |e|/h_e · |[∇y]|² = ½γ₁ Σ_e |e|/h_e · 2(1 − cos φ), and the flow ends at a
# smooth bend with a clearly positive energy instead.
#
# The flow starts from the flat sheet, far from the clamped data (E_h ≈ 1.6·10⁵ at h = 0.25,
# the Nitsche penalty of the mismatch). The published linearised flow leaves the isometry
# constraint on the way for good (D_h ends O(1)); `flow.projection_steps = 2` in the problem
# file keeps each iterate on the discrete constraint, and the flow walks to the fold.
# (`tests/models/test_creases.py` also starts the flow at the fold: it takes one step of size 1e−15.)
#
# Run: `python demos/straight_fold.py` (h = 0.25, seconds), `--paper` for h = 0.125,
# `--angle 90` for another fold, `--out DIR`; in parallel
# `mpirun -n 2 python demos/straight_fold.py`.
# The same problem: `dgplate run demos/problems/straight_fold.toml [--set model.crease=[]]`.

# %%
import math
from pathlib import Path

import dgplate
from dgplate import demo

PROBLEM = Path(__file__).parent / "problems" / "straight_fold.toml"

parser = demo.parser("straight_fold", "a straight fold with clamped data", paper="h = 0.125")
parser.add_argument("--angle", type=float, default=60.0, help="fold angle φ in degrees")
args = demo.parse(parser)

# %% [markdown]
# ## The problem: the problem file with the fold angle written into the clamped data
#
# The clamped data are formulas in x and y (`where(x < 0, a, b)` is a if x < 0, else b).

# %%
phi = math.radians(args.angle)
c, s = math.cos(phi), math.sin(phi)
h = 0.125 if args.paper else 0.25
overrides = {
    "mesh.parameters.h": h,
    "model.boundary_data": {
        "g": [f"where(x < 0, x, {c!r}*x)", "y", f"where(x < 0, 0, {s!r}*x)"],
        "Phi": [[f"where(x < 0, 1, {c!r})", 0.0], [0.0, 1.0], [f"where(x < 0, 0, {s!r})", 0.0]],
    },
}

# %% [markdown]
# ## With the crease: the fold is reproduced exactly

# %%
crease = demo.run(dgplate.load_problem(PROBLEM, overrides=overrides), args, "crease")
demo.copy_figure(Path(args.out, "crease"), args.figure)

# %% [markdown]
# ## Gradient-jump terms kept on C: the fold costs energy, the plate bends instead

# %%
plain = dgplate.load_problem(PROBLEM, overrides={**overrides, "model.crease": []})
kept = demo.run(plain, args, "no_crease")

# %% [markdown]
# ## What to look at
#
# With the crease the flow ends at the fold: E_h and D_h are zero to round-off (E_h ≈ 6e−20,
# D_h ≈ 8e−15) and the fold angle measured along C (the angle between the unit normals of the
# two cells at each crease-facet midpoint) is φ to six digits on every facet. Without the crease
# the flow ends at a smooth bend of positive energy (1.457 at h = 0.25, 1.113 at h = 0.125 for
# φ = 60°; 294.6 for φ = 90°); `no_crease/final.png` shows it.
#
# The demo asserts what `tests/models/test_creases.py` asserts of the same run: the flow converged
# with a decreasing energy, |E_h| and D_h below 10⁻¹⁰ and the mean fold angle φ within 10⁻⁴°;
# and that without the crease the energy stays above 10⁻² (the bend costs energy).

# %%
fold = crease["fold_angle_deg"]
demo.say(f"\nfold angle φ = {args.angle:g}°, h = {h}")
demo.say(
    f"with the crease:      E_h = {crease['energy']:.3e}, D_h = {crease['isometry_defect']:.3e}, "
    f"{crease['steps']} steps; fold angle along C min/mean/max = "
    f"{fold['min']:.6f}° / {fold['mean']:.6f}° / {fold['max']:.6f}°"
)
demo.say(
    f"gradient jumps kept:  E_h = {kept['energy']:.4e}, D_h = {kept['isometry_defect']:.2e}, "
    f"{kept['steps']} steps"
)
demo.check("the flow converged and E_h decreased at every step",
           crease["converged"] and not crease["energy_increases"])  # fmt: skip
demo.check_between("|E_h|", abs(crease["energy"]), high=1e-10, source="the exact fold: 0")
demo.check_between("D_h", crease["isometry_defect"], high=1e-10, source="the exact fold: 0")
demo.check_close("mean fold angle", fold["mean"], args.angle, abs=1e-4, source="φ")
demo.check_between("E_h without the crease", kept["energy"], low=1e-2, source="a smooth bend")
