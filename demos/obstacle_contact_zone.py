# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # How far a heavy strip lies on a table
#
# A strip ω = (0, 2) × (0, 0.25) is clamped at x₁ = 0 and pressed onto the table y₃ ≥ 0 by its
# weight q (load (0, 0, −q)); the obstacle is the penalty (1/2ε)∫(y₃)₋² with the
# quadratic–concave splitting (docs/obstacle.md). Two plates:
#
# * a **single-layer plate** clamped horizontally at height H = 0.02 above the table: it lies on
#   the table beyond the lift-off length ℓ = (72μH/q)^{1/4} (small-deflection beam, derived in
#   docs/obstacle.md), so the contact area is b(L − ℓ) and the table carries q b (L − 2ℓ/3)
#   (the weight beyond ℓ and the line force qℓ/3 at ℓ);
# * a **bilayer** (Z = I) clamped flat on the table: it wants to roll up and its weight keeps
#   it down; the free end curls off the table, less so under a heavier weight.
#
# For each weight q we report the contact area and the contact force (1/ε)∫(s)₋ and draw them
# against q. The single layer is compared with the rigid-table theory and with the penalised
# beam at the same ε (`dgplate.reference.obstacle_profiles`); the bilayer has no closed form here.
#
# Run: `python demos/obstacle_contact_zone.py` (8 cells along the strip, three weights each),
# `--paper` (16 cells, more weights).

# %%
from pathlib import Path

from mpi4py import MPI

import numpy as np

import dgplate
from dgplate import demo
from dgplate.io.output import write_json
from dgplate.reference.obstacle_profiles import lift_off_length, penalised_lift_off

args = demo.arguments("obstacle_contact_zone", "contact zone against the load", "16 cells")
comm = MPI.COMM_WORLD
MU, HEIGHT, LENGTH, WIDTH = 1.0, 0.02, 2.0, 0.25
cells = 16 if args.paper else 8
weights_plate = [0.5, 1.0, 2.0, 4.0] if args.paper else [1.0, 2.0, 4.0]
weights_bilayer = [2.0, 3.0, 4.0, 6.0] if args.paper else [3.0, 4.0]
EPS_PLATE, EPS_BILAYER = 2e-4, 1e-3


def strip(model: dict, q: float, epsilon: float, tau: float) -> dgplate.Problem:
    """The strip of demos/problems/obstacle_strip.toml under the weight q, with ``model`` keys."""
    overrides = {
        "mesh.cells": [cells, 2],
        "model.load": [0.0, 0.0, -q],
        "model.obstacle.epsilon": epsilon,
        "flow.tau": tau,
        "flow.tol": 1e-7,
        "flow.max_steps": 2000,
    }
    overrides |= {f"model.{key}": value for key, value in model.items()}
    return dgplate.load_problem(
        Path(__file__).parent / "problems" / "obstacle_strip.toml", overrides
    )


# %% [markdown]
# ## The single-layer plate, clamped above the table
#
# The flat start at the clamp's height (the file's `model.start`) is admissible; the plate falls onto the
# table. The splitting lets the free plate fall by about εq per step, so the lighter strips
# take more steps.

# %%


plate = []
for q in weights_plate:
    problem = strip({}, q, EPS_PLATE, tau=1.0)  # clamped at height H (the problem file)
    s = demo.run(problem, args, f"plate_q{q:g}")
    plate.append((q, s))

demo.say(f"\nsingle layer, ε = {EPS_PLATE:g}, {cells} cells along the strip")
demo.say(
    f"{'q':>5} {'area':>8} {'b(L−ℓ_ε)':>9} {'b(L−ℓ)':>8} {'force':>8} {'qb(L−2ℓ/3)':>11} {'steps':>6}"
)
single_layer = []  # each weight's figures beside the closed forms (contact_zone.json)
for q, s in plate:
    ell = lift_off_length(MU, HEIGHT, q)
    ell_eps = penalised_lift_off(MU, HEIGHT, q, EPS_PLATE, LENGTH, n=400)
    rigid_force = q * WIDTH * (LENGTH - 2 * ell / 3)
    single_layer.append(
        {
            "q": q,
            "contact_area": s["contact_area"],
            "contact_area_penalised_beam": WIDTH * (LENGTH - ell_eps),
            "contact_area_rigid_table": WIDTH * (LENGTH - ell),
            "contact_force": s["contact_force"],
            "contact_force_rigid_table": rigid_force,
        }
    )
    demo.say(
        f"{q:>5g} {s['contact_area']:>8.4f} {WIDTH * (LENGTH - ell_eps):>9.4f} "
        f"{WIDTH * (LENGTH - ell):>8.4f} {s['contact_force']:>8.4f} {rigid_force:>11.4f} "
        f"{s['steps']:>6d}"
    )
    demo.check(
        f"q = {q:g}: converged, energy decreased", s["converged"] and not s["energy_increases"]
    )
    # the lift-off within h/2 of the penalised beam's: the area within b·h/2
    h = LENGTH / cells
    demo.check_close(
        f"contact area (q = {q:g})",
        s["contact_area"],
        WIDTH * (LENGTH - ell_eps),
        abs=WIDTH * h / 2,
        source="1D penalised beam",
    )
    demo.check_close(
        f"contact force (q = {q:g})",
        s["contact_force"],
        rigid_force,
        rel=0.03,
        source="rigid table",
    )

# %% [markdown]
# ## The bilayer, clamped on the table
#
# Z = I bends the free strip upwards with curvature 1; the weight holds it on the table. The
# contact zone starts at the clamp and ends where the strip curls off.

# %%
BILAYER = {"name": "bilayer", "Z": 1.0, "boundary_data": "flat", "start": "flat"}  # on the table
bilayer = []
for q in weights_bilayer:
    problem = strip(BILAYER, q, EPS_BILAYER, tau=0.1)
    bilayer.append((q, demo.run(problem, args, f"bilayer_q{q:g}")))

demo.say(f"\nbilayer Z = I, ε = {EPS_BILAYER:g}")
demo.say(f"{'q':>5} {'area':>8} {'curls off at':>12} {'force':>8} {'steps':>6}")
for q, s in bilayer:
    extent = s["contact_extent"] or [float("nan")] * 4
    demo.say(
        f"{q:>5g} {s['contact_area']:>8.4f} {extent[1]:>12.4f} {s['contact_force']:>8.4f} "
        f"{s['steps']:>6d}"
    )
    demo.check(f"bilayer q = {q:g}: converged, energy decreased", s["converged"] and not s["energy_increases"])  # fmt: skip
areas = [s["contact_area"] for _, s in bilayer]
demo.check("a heavier bilayer lies on a larger area", all(np.diff(areas) > 0))

# %% [markdown]
# ## The picture
#
# Contact area (left) and contact force (right) against the weight, `contact_zone.png`;
# `contact_zone.json` holds every weight's figures beside the closed forms.

# %%
if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(9, 3.6))
    qs = np.linspace(min(weights_plate), max(weights_plate + weights_bilayer), 60)
    ells = np.array([lift_off_length(MU, HEIGHT, q) for q in qs])
    left.plot(qs, WIDTH * (LENGTH - ells), "k--", label="single layer, rigid table")
    right.plot(qs, qs * WIDTH * (LENGTH - 2 * ells / 3), "k--", label="single layer, rigid table")
    beam = [WIDTH * (LENGTH - penalised_lift_off(MU, HEIGHT, q, EPS_PLATE, LENGTH, n=400)) for q in weights_plate]  # fmt: skip
    left.plot(
        weights_plate, beam, "kx", label=f"single layer, 1D penalised beam (ε = {EPS_PLATE:g})"
    )
    for runs, style, name in ((plate, "o-", "single layer"), (bilayer, "s-", "bilayer Z = I")):
        q_values = [q for q, _ in runs]
        left.plot(q_values, [s["contact_area"] for _, s in runs], style, label=name)
        right.plot(q_values, [s["contact_force"] for _, s in runs], style, label=name)
    left.set(xlabel="weight q", ylabel="contact area", title="contact area")
    right.set(xlabel="weight q", ylabel="(1/ε)∫(s)₋", title="contact force")
    left.legend(fontsize=8)
    fig.tight_layout()
    out = Path(args.out)  # taken by the first run (demo.run), as a run's folder is
    fig.savefig(out / "contact_zone.png", dpi=150)
    if args.figure:
        fig.savefig(args.figure, dpi=150)
    study = {
        "single_layer": single_layer,
        "bilayer": [
            {"q": q, "contact_area": s["contact_area"], "contact_force": s["contact_force"]}
            for q, s in bilayer
        ],
        "epsilon": {"single_layer": EPS_PLATE, "bilayer": EPS_BILAYER},
        "cells_along": cells,
    }
    write_json(comm, out / "contact_zone.json", study)
