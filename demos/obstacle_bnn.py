# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # A plate pushed against a rigid ceiling
#
# The obstacle experiment of Bonito, Nochetto and Ntogkas, *DG approach to large bending plate
# deformations with isometry constraint* (M3AS 2021), §6.2. The plate ω = (−1, 1)² is clamped
# along x₁ = −1 (flat data) and pushed up by f = (0, 0, 1); a rigid ceiling y₃ ≤ 0.2 stops
# it. The constraint is imposed by the penalty
#
# $$P_\varepsilon[y] = \frac{1}{2\varepsilon}\int_\omega (y_3 - 0.2)_+^2 ,$$
#
# and the gradient flow takes the quadratic–concave splitting (s)₊² = s² − (s)₋²: the convex
# s² part is implicit (a constant step matrix), the concave part explicit, so every step is
# a linear problem and the energy decreases unconditionally (docs/obstacle.md).
#
# The paper's "splitting with σ = 3·10⁻⁴" is read as the penalty ε = 3·10⁻⁴; with
# τ = 5·10⁻⁴, γ₀ = γ₁ = 5000 and 1024 cells (32 × 32 Q2) it reports a final D_h ≈ 9·10⁻⁵ and a
# penetration ≈ 0.002.
#
# The splitting puts (1/ε) times an L² mass into the step matrix everywhere, so the free plate
# rises by at most about ε|f| per step: at ε = 3·10⁻⁴ the flow needs thousands of steps. The
# default run is therefore small and uses ε = 3·10⁻³ (6 × 6 cells, τ = 0.02: about 380 steps, 5 s of CPU);
# `--paper` runs the published settings (32 × 32, ε = 3·10⁻⁴, τ = 5·10⁻⁴; 12105 steps, ~36 min
# on one core).
#
# Run: `python demos/obstacle_bnn.py`, `--paper`; under MPI `mpirun -n 2 python demos/obstacle_bnn.py`.

# %%
from pathlib import Path

import dgplate
from dgplate import demo
from dgplate.reference.obstacle_profiles import BNN_OBSTACLE

PROBLEM = Path(__file__).parent / "problems" / "obstacle_bnn.toml"

args = demo.arguments("obstacle_bnn", "BNN 2021, §6.2: obstacle", paper="32×32, ε = 3e-4")

# %% [markdown]
# The problem file holds the published settings on 8 × 8 cells; the small run overrides the
# mesh, ε and τ, `--paper` the mesh and the step budget.

# %%
if args.paper:
    overrides = {"mesh.cells": [32, 32], "flow.max_steps": 20000}
else:
    overrides = {
        "mesh.cells": [6, 6],
        "model.obstacle.epsilon": 3e-3,
        "flow.tau": 0.02,
        "flow.max_steps": 1500,
    }
problem = dgplate.load_problem(PROBLEM, overrides=overrides)
s = demo.run(problem, args)
demo.copy_figure(args.out, args.figure)

# %% [markdown]
# ## Our figures beside the published ones
#
# The penetration is max(y₃ − 0.2)₊ over the plate; the contact force (1/ε)∫(y₃ − 0.2)₊ is
# the total reaction of the ceiling (about 1.4 of ∫f = 4: the clamp carries the rest).

# %%
epsilon = problem.model.obstacle.epsilon
demo.say(f"\nε = {epsilon:g}, τ = {s['tau']:g}, {s['dofs']} dofs, {s['steps']} steps")
demo.say(f"{'':>18} {'ours':>10} {'BNN 2021':>10}")
demo.say(f"{'D_h':>18} {s['isometry_defect']:>10.3e} {BNN_OBSTACLE['isometry_defect']:>10.1e}")
demo.say(f"{'penetration':>18} {s['max_penetration']:>10.3e} {BNN_OBSTACLE['penetration']:>10.1e}")
demo.say(f"{'contact area':>18} {s['contact_area']:>10.4f}")
demo.say(f"{'contact cells':>18} {s['contact_cells']:>10d}")
demo.say(f"{'contact force':>18} {s['contact_force']:>10.4f}")

demo.check("the flow reached its stopping rule", s["converged"])
demo.check("the energy decreased at every step", not s["energy_increases"])
demo.check("the plate touches the ceiling", s["contact_cells"] > 0)
# Measured contact force: 1.4445 by default, 1.415 with --paper (docs/obstacle.md: 1.40–1.49
# over all runs, of ∫f = 4); ± 2 % around the run's own value.
force = 1.415 if args.paper else 1.4445
demo.check_close("contact force", s["contact_force"], force, rel=0.02, source="measured")
# The penetration is of the size ε·|f| = ε where the ceiling carries a pressure, larger at the
# edge of the contact zone; measured 4.3ε by default, 6.6ε with --paper (7.4ε on 8 × 8).
demo.check_between("penetration / ε", s["max_penetration"] / epsilon, 1.0, 10.0,
                   source="ε|f| to 10ε|f|")  # fmt: skip
if args.paper:  # measured: D_h 0.81×, penetration 1.00× the published values (docs/obstacle.md)
    for key in ("isometry_defect", "penetration"):
        published = BNN_OBSTACLE[key]
        value = s["max_penetration" if key == "penetration" else key]
        demo.check_between(key, value, published / 2, 2 * published, source="BNN 2021, factor 2")
