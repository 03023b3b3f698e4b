# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: percent
# ---

# %% [markdown]
# # An I-shaped bilayer plate
#
# An I-shaped plate in a 4 × 4 box (aspect ratio 1, seed 001) — two flanges 1 wide joined by a
# web 1.5 wide — is clamped along the bottom of its lower flange and given $Z = I$. The
# minimiser of
#
# $$E[y] = \tfrac12 \int_\omega |I\!I(y) - Z|^2, \qquad \nabla y^T \nabla y = I_2 ,$$
#
# does not care about the outline: the cylinder of radius 1 about an axis parallel to the
# clamped side has the smallest energy density $\tfrac12$ at every point, so lower flange, web
# and upper flange could all roll onto the same cylinder (4 radians of it, about two thirds of a
# turn), at the energy $\tfrac12|\omega|$.
#
# For $Z = aI$ that cylinder is not the only shape of density $\tfrac12 a^2$: rolling about any
# other axis costs the same, and only the clamp picks the axis — near the clamp. The flow starts
# flat and first bends the plate in all directions at once. With `--paper` (h = 0.125) the whole
# I ends on the one cylinder, 2 % above $\tfrac12|\omega|$. On the coarse default mesh
# (h = 0.25) the upper flange, 4 long, 1 wide and held by the web alone, gets trapped wrapped
# around the *other* axis (along its own short direction), 6 % above $\tfrac12|\omega|$: a
# trap of the coarse discrete flow, not a minimiser of the model.
#
# Run: `python demos/bilayer_i_shape.py` (h = 0.25, a minute or two), `--paper` for h = 0.125
# (about ten minutes).
# Output: `out/bilayer_i_shape/` (VTX, final.png, summary.json).

# %%
from pathlib import Path

from mpi4py import MPI

from dgplate.io.demo_support import copy_figure, demo_arguments, describe_cylinder, report_run
from dgplate.io.output import print0
from dgplate.problems.runner import run_problem
from dgplate.problems.specs import load_problem

PROBLEM = Path(__file__).parent / "problems" / "bilayer_i_shape.toml"

args = demo_arguments(__doc__, "out/bilayer_i_shape", "a finer mesh, h = 0.125")
comm = MPI.COMM_WORLD

# %%
overrides = (
    ["mesh.parameters={W = 4.0, H = 4.0, t = 1.0, w = 1.5, h = 0.125}"] if args.paper else []
)
problem = load_problem(PROBLEM, overrides)
summary = run_problem(problem, args.out, comm)

# %% [markdown]
# ## What to look at
#
# The energy against $\tfrac12|\omega|$ ($|\omega| = 2Wt + w(H - 2t)$), the fitted cylinder's
# radius against 1 and its axis, parallel to the clamped side (the $x_1$ axis, up to sign).

# %%
p = problem.mesh.parameters
area = 2 * p["W"] * p["t"] + p["w"] * (p["H"] - 2 * p["t"])
alpha = float(problem.model.Z)
fit = summary["cylinder_fit"]
report_run(comm, summary, f"cylinder: ½α²|ω| = {0.5 * alpha**2 * area:.4f}")
print0(comm, describe_cylinder(fit, alpha))
copy_figure(comm, args.out, args.figure)
