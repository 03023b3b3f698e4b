# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: percent
# ---

# %% [markdown]
# # A self-folding microcapsule
#
# Seed 001, "Encapsulation with Self-Folding Microcapsules" (after Stoychev, Puretskiy and
# Ionov, Soft Matter 2011): a star-shaped polymer bilayer — a centre unit square with four
# trapezoidal flaps (base 1, top 3/5, height 1) — curls up when it swells, and the flaps wrap
# over the centre to enclose a cargo. The whole film is one bilayer with rigidity μ = 1 and
# the seed's spontaneous curvature Z = 12 I: a free strip would roll to radius 1/12, so each
# flap of length 1 turns by about 12 rad, almost two turns.
#
# The plate minimises E[y] = ½∫μ|II(y) − Z|² over isometries of the flat star. To follow the
# curling we switch Z on gradually, like the heat-driven box: a uniform heat source raises the
# temperature θ linearly from 0 to 1 (insulated edges, so θ stays uniform) and Z = −αθI with
# α = −12, reaching Z = 12 I at t = 1 (Z = αI with α > 0 bends towards +ν, i.e. upwards). After
# each heat step the plate is relaxed by the constrained gradient flow (dG Q2), warm-started;
# at the end it is relaxed at Z = 12 I. Nothing is clamped: the L² product in the flow's
# metric controls rigid motions (there is no flat face to anchor, every part curls).
#
# Run: `python demos/microcapsule.py` (n = 8 cells per side, minutes) or under
# `mpirun -n 2`; `--out DIR`; `--paper` uses n = 16 (the curl resolved by ~20° per cell).

# %%
import argparse
import atexit
import csv
import shutil
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from dgplate import compat
from dgplate.coupling.heat import HeatSolver, HeatSource
from dgplate.io.output import OutputDir, bounding_box, print0, write_json
from dgplate.io.vtx import DeformationWriter
from dgplate.measure.analysis import curvature_summary
from dgplate.measure.hinges import RegionFrame, edge_nodes
from dgplate.mesh.tagged import load_geo
from dgplate.models.thermal import ThermalBilayer, ThermalSettings
from dgplate.solvers.flow import FlowSpec

parser = argparse.ArgumentParser(description="Self-folding microcapsule (seed 001).")
parser.add_argument("--out", default="out/microcapsule", help="output directory")
parser.add_argument("--paper", action="store_true", help="n = 16 cells per side (slow)")
parser.add_argument("--n", type=int, help="cells per side of each region (default 8)")
parser.add_argument("--Z", type=float, default=12.0, help="final spontaneous curvature (12)")
parser.add_argument("--ramp-steps", type=int, default=12, help="steps of the Z ramp (12)")
parser.add_argument("--tau", type=float, default=0.02, help="gradient-flow step τ")
parser.add_argument("--flow-steps", type=int, default=40, help="flow budget per ramp step")
parser.add_argument("--hold-steps", type=int, default=300, help="flow budget at the end")
parser.add_argument("--frames", type=int, default=1, help="a picture every N steps (0: none)")
args, _ = parser.parse_known_args()
comm = MPI.COMM_WORLD
wall0 = time.perf_counter()
committed = False


def discard_unless_committed(out) -> None:
    """On an error, remove the staging directory (rank 0, not collective): no half output."""
    if not committed and comm.rank == 0:
        shutil.rmtree(out.path, ignore_errors=True)


n = args.n or (16 if args.paper else 8)

# %% [markdown]
# ## Mesh, temperature ramp and the bilayer

# %%
REGIONS = ["centre", "flap_north", "flap_south", "flap_east", "flap_west"]
tagged = load_geo(comm, "microcapsule", {"n": n})
num_cells = tagged.mesh.topology.index_map(2).size_global
dt = 1.0 / args.ramp_steps
heat = HeatSolver(tagged, 5.0, dt, HeatSource(((0.0, 1.0), (1.0, 0.0))))  # θ = t up to t = 1
settings = ThermalSettings(alpha=-args.Z, mu=1.0, flow_steps=args.flow_steps, degree=2)
# L² metric (nothing clamped); one constraint projection per step keeps D_h at round-off
flow_settings = FlowSpec(tau=args.tau, tol=1e-6, multiplier_degree=0, projection_steps=1)
model = ThermalBilayer(tagged, heat, flow_settings, settings)
centre = RegionFrame(model.y, tagged, "centre")
print0(
    comm,
    f"microcapsule: {num_cells} cells (n = {n}), {model.flow.num_dofs} dofs, {comm.size} rank(s)",
)

# %% [markdown]
# ## How far have the flaps curled?
#
# In the frame of the centre square (its mean position and orientation), we follow the free
# tips of the flaps: their mean height above the centre's plane (positive: on the side the
# film curls to) and their horizontal distance from the centre's midpoint (about 1.5 when
# flat; it shrinks as the flaps roll in).

# %%


def measure(_model) -> dict:
    _, pos = edge_nodes(model.y, tagged, "tips")
    c, Q, c_ref = centre()
    local = (pos - c) @ Q + c_ref
    count = comm.allreduce(len(local), op=MPI.SUM)
    height = comm.allreduce(float(np.sum(local[:, 2])), op=MPI.SUM) / count
    radial = np.linalg.norm(local[:, :2] - [0.5, 0.5], axis=1)
    spread = comm.allreduce(float(np.sum(radial)), op=MPI.SUM) / count
    return {"tip_height": height, "tip_distance": spread}


model.measure = measure
out = OutputDir(comm, Path(args.out))
atexit.register(discard_unless_committed, out)
writer = DeformationWriter(out.path / "capsule.bp", model.y, extras=(model.theta,), comm=comm)
frames: list[Path] = []


def picture(path: Path, title: str, close: bool = False) -> None:
    """Collective: gather the surface, render on rank 0 in the centre's frame (``close``:
    a nearer camera for the curled shape; the frames share one camera that fits the star)."""
    from dgplate.measure.fields import bending_density, surface_grid

    grid = surface_grid(model.y, cell_values={"curvature": bending_density(model.y)})
    c, Q, c_ref = centre()  # collective: before the rank-0 branch
    if comm.rank != 0:
        return
    import pyvista

    from dgplate.io.plotting import _headless

    _headless()
    grid.points = (np.asarray(grid.points) - c) @ Q + c_ref
    try:
        surface = grid.extract_surface(nonlinear_subdivision=2, algorithm="dataset_surface")
    except TypeError:  # pyvista < 0.47
        surface = grid.extract_surface(nonlinear_subdivision=2)
    plotter = pyvista.Plotter(off_screen=True, window_size=[900, 720])
    plotter.set_background("white")
    plotter.add_mesh(
        surface,
        scalars="curvature",
        cmap="viridis",
        clim=(0.0, 1.2 * args.Z),
        smooth_shading=True,
        scalar_bar_args={"title": "bending", "color": "black", "vertical": True},
    )
    plotter.add_text(title, position="upper_edge", font_size=12, color="black")
    if close:
        plotter.camera_position = [(2.3, -1.6, 2.4), (0.5, 0.45, 0.1), (0.0, 0.0, 1.0)]
    else:
        plotter.camera_position = [(3.2, -3.4, 3.6), (0.5, 0.5, 0.2), (0.0, 0.0, 1.0)]
    plotter.camera.view_angle = 34.0
    plotter.screenshot(str(path))
    plotter.close()


rows: list[dict] = []
t_start = time.perf_counter()


def report(record, label: str = "") -> None:
    row = record.row()
    row["Z"] = args.Z * record.theta_mean
    rows.append(row)
    print0(
        comm,
        f"t = {record.time:5.3f}  Z = {row['Z']:6.2f} I  flow {record.flow_steps:4d} steps"
        f"{' (conv.)' if record.flow_converged else '        '}  tips: height "
        f"{row['tip_height']:+.3f}, distance {row['tip_distance']:.3f}  E = {record.energy:8.4f}"
        f"  D_h = {record.defect:.2e}  [{time.perf_counter() - t_start:5.0f} s]{label}",
    )


def after_step(_model, record) -> None:
    report(record)
    writer.write(record.time)
    if args.frames and heat.steps % args.frames == 0:
        path = out.path / "frames" / f"frame_{heat.steps:04d}.png"
        if comm.rank == 0:
            path.parent.mkdir(exist_ok=True)
        picture(path, f"Z = {args.Z * record.theta_mean:5.2f} I")
        frames.append(path)


writer.write(0.0)

# %% [markdown]
# ## Curling

# %%
model.run(1.0, after_step)
final_record = model.hold(args.hold_steps)
final = model.last_result
report(final_record, "  ← relaxed at the final Z")
writer.write(final_record.time)
writer.close()

# %% [markdown]
# ## Results: the flaps have curled over the centre

# %%
picture(out.path / "final.png", f"Z = {args.Z:g} I: the flaps curl over the centre", True)
if frames:
    from dgplate.io.plotting import frames_to_gif

    frames_to_gif(frames, out.path / "curling.gif", 4, comm)
if comm.rank == 0:
    with open(out.path / "history.csv", "w", newline="") as handle:
        table = csv.DictWriter(handle, fieldnames=list(rows[0]))
        table.writeheader()
        table.writerows(rows)
curvatures = curvature_summary(model.y)["principal_curvatures"]
summary = {
    "model": "thermal_bilayer",
    "dofs": model.flow.num_dofs,
    "cells": num_cells,
    "ranks": comm.size,
    "steps": model.flow.step_count,
    "converged": final.converged,
    "energy": final.energy,
    "isometry_defect": final.defect,
    "bbox": bounding_box(model.y),
    "wall_time_s": None,
    "dolfinx_version": compat.version_string(),
    "Z": args.Z,
    "mu": 1.0,
    "tip_height_final": final_record.figures["tip_height"],
    "tip_distance_final": final_record.figures["tip_distance"],
    "principal_curvatures": curvatures,
    "parameters": {"n": n, "tau": args.tau, "ramp_steps": args.ramp_steps, **vars(args)},
}
summary["wall_time_s"] = time.perf_counter() - wall0
write_json(comm, out.path / "summary.json", summary)
target = out.commit()
committed = True
print0(
    comm,
    f"\nκ₁ mean {curvatures['kappa1_mean']:.2f}, κ₂ mean {curvatures['kappa2_mean']:.2f} "
    f"(Z = {args.Z:g}); tips {final_record.figures['tip_height']:+.3f} above the centre, "
    f"{final_record.figures['tip_distance']:.3f} from its midpoint\n"
    f"{summary['dofs']} dofs, {summary['steps']} flow steps, {summary['wall_time_s']:.0f} s "
    f"on {comm.size} rank(s) → {target}",
)
model.destroy()
