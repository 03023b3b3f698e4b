# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: percent
# ---

# %% [markdown]
# # A curved fold driven by a load
#
# The sheet ω = (−1, 1) × (0, 1) carries a crease C along a circular arc, r = |x − c| = R with
# c = (−1.5, 0.5), R = 1.5: it runs from the bottom edge to the top edge and bulges towards +x.
# The left edge is clamped flat and a downward load f = (0, 0, −0.5) acts on the flap beyond C.
#
# A straight crease would be a free hinge: the flap could turn about it rigidly. A curved
# crease cannot: the image of C is a space curve whose curvature κ splits on each side into the
# geodesic curvature of C in the sheet (1/R, fixed by the isometry) and a normal curvature,
# κ² = 1/R² + κ_n², and the fold angle φ between the two sides ties their normal curvatures
# together. So the flap can only fold if both sides bend — the load folds the sheet as far as
# the bending it costs allows. (The same holds for paper: a curved fold is never flat.)
#
# Discretely, the faces of C keep the value-jump terms and drop the gradient-jump terms. The
# gradient flow must then also see rotations about C: its H² metric no longer does, so the
# problem adds the L² product (`flow.l2_metric = true`).
#
# Curved creases need curved cells: gmsh's `order = 2` puts the mesh nodes along C on the arc.
# With straight cell edges (chords, `order = 1`) the traces of the two sides along a chord
# cannot follow the curved fold without a value jump, the γ₀h⁻³ penalty resists and the fold
# comes out far too small (`--chords` runs that variant for comparison; docs/creases.md).
#
# The demo runs two mesh levels with τ = h/2 and reports the fold angle along C and the
# isometry defect D_h, which decreases with h (D_h = O(τ)).
#
# Run: `python demos/curved_fold.py` (h = 0.2 and 0.1, about a minute), `--paper` for h = 0.1
# and 0.05, `--out DIR`; `mpirun -n 2 python demos/curved_fold.py` in parallel.
# `dgplate run demos/problems/curved_fold.toml` runs the problem with straight chords (its
# comment shows the `--set` for curved cells).

# %%
import argparse
import copy
import tomllib
from pathlib import Path

from mpi4py import MPI

from dgplate.io.output import print0
from dgplate.problems.runner import run_problem
from dgplate.problems.specs import problem_from_dict

PROBLEM = Path(__file__).parent / "problems" / "curved_fold.toml"

parser = argparse.ArgumentParser(description="a curved fold driven by a load")
parser.add_argument("--paper", action="store_true", help="finer meshes, h = 0.1 and 0.05")
parser.add_argument("--chords", action="store_true", help="also run straight cell edges on C")
parser.add_argument("--out", default="out/curved_fold", help="output directory")
args, _ = parser.parse_known_args()
comm = MPI.COMM_WORLD
data = tomllib.loads(PROBLEM.read_text())


def run(h: float, order: int) -> dict:
    """One level: mesh size h, τ = h/2, cells of geometric order 1 (chords) or 2 (curved)."""
    level = copy.deepcopy(data)
    level["mesh"]["parameters"].update(h=h, order=order)
    level["flow"]["tau"] = h / 2
    name = f"curved_fold_h{h:g}_order{order}"
    return run_problem(problem_from_dict(level, name), Path(args.out) / name, comm)


# %% [markdown]
# ## Two mesh levels with curved cells along C

# %%
levels = [0.1, 0.05] if args.paper else [0.2, 0.1]
runs = [(h, 2, run(h, 2)) for h in levels]
if args.chords:
    runs += [(h, 1, run(h, 1)) for h in levels]

# %% [markdown]
# ## What to look at
#
# The energy decreases at every step (`energy_increases` is empty in `summary.json`), the
# fold angle along C is about 39° with a spread of 1–2° along the arc (h = 0.2: 38.4°–39.8°,
# h = 0.1: 38.0°–39.9°), and D_h halves with h (3.2e−2 → 1.6e−2). With straight chords
# (`--chords`) the fold angle is about half as large and creeps up only slowly under
# refinement (21.0° → 23.6°).

# %%
print0(comm, "\n   h  order  dofs   steps  E_h          D_h        fold angle min / mean / max")
for h, order, s in runs:
    fold = s["fold_angle_deg"]
    print0(
        comm,
        f"{h:5.3f}  {order}  {s['dofs']:6d}  {s['steps']:5d}  {s['energy']:+.5e}  "
        f"{s['isometry_defect']:.3e}  {fold['min']:.2f}° / {fold['mean']:.2f}° / {fold['max']:.2f}°"
        + ("" if s["converged"] and not s["energy_increases"] else "  (check the run!)"),
    )
