# ---
# jupyter:
#   jupytext:
#     text_representation:
#       format_name: percent
# ---

# %% [markdown]
# # A self-folding box: a heat-driven thermal bilayer
#
# Seed 001 ("Thermal Actuation", "Self-Assembling Composite-Material Box"; Bartels, Bonito,
# Nochetto): six unit squares in a cross-shaped net are joined by thin *bilayer hinges*. A
# bilayer is two bonded layers that expand differently when heated: the mismatch of thermal
# strains cannot be relieved in the plane, so the plate bends. In the thin-plate limit this is
# a **spontaneous curvature** Z proportional to the temperature θ, and the plate minimises
#
# $$E[y] = \tfrac12 \int_\omega \mu\, |II(y) - Z|^2, \qquad Z = -\alpha\,\theta\, I_2,
#   \qquad \nabla y^T \nabla y = I_2 ,$$
#
# among isometries y of the flat net ω (it bends but cannot stretch). The hinges are soft
# bilayers (μ = 1, α > 0); the six faces are stiff single-layer panels (μ = 20, α = 0): they
# have no reason to bend and stay flat, while each hinge strip rolls up to a piece of a
# cylinder of curvature c = αθ. A strip of width w bent to curvature c turns by the angle c·w,
# so with w = π/24 a hinge folds its face by 90° when αθ = 12: the five hinges fold the
# four walls up from the base and the lid over the top, and the net closes to a box.
#
# The temperature solves the heat equation θ_t − κΔθ = s on the flat net (insulated edges)
# with the seed's κ = 5 and a heater under the base: s = 5 there until t = 28.2, then −5
# (cooling). Heat spreads over the net within a fraction of a time unit, so all hinges see
# nearly the same temperature; θ rises linearly, peaks at the switch and falls again, and
# the box folds shut and opens again. The coupling is quasi-static: after each heat step the
# plate is relaxed by the constrained H² gradient flow (dG Q2, interior penalty), warm-started
# from the previous shape.
#
# Run: `python demos/box_folding.py` (serial) or `mpirun -n 2 python demos/box_folding.py`
# (`make demo`), a few minutes; `--out DIR` chooses the output directory, `--paper` runs a
# finer mesh with the seed's small heat step (hours).

# %%
import argparse
import atexit
import csv
import math
import shutil
import sys
import time
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from dgplate import compat, interrupt
from dgplate.coupling.heat import HeatSolver, HeatSource
from dgplate.io import checkpoint
from dgplate.io.output import OutputDir, bounding_box, print0, write_json
from dgplate.io.vtx import DeformationWriter
from dgplate.measure.hinges import FoldAngles, Hinge, RegionFrame, edge_nodes
from dgplate.mesh.tagged import load_geo
from dgplate.models.thermal import (
    ThermalBilayer,
    ThermalSettings,
    anchor_energy,
    calibrate_alpha,
    hinge_penalty,
)
from dgplate.solvers.flow import FlowSpec

parser = argparse.ArgumentParser(description="Self-folding box driven by heat (seed 001).")
parser.add_argument("--out", default="out/box_folding", help="output directory")
parser.add_argument("--paper", action="store_true", help="finer mesh, seed's heat step (hours)")
parser.add_argument("--n", type=int, help="cells per face side (default 4, paper 8)")
parser.add_argument("--m", type=int, help="cells across a hinge (default 4, paper 8)")
parser.add_argument("--dt", type=float, help="heat time step (default 2.35, paper 0.1)")
parser.add_argument("--t-end", type=float, default=56.4, help="final time (default 56.4)")
parser.add_argument("--tau", type=float, default=0.05, help="gradient-flow step τ")
parser.add_argument("--flow-steps", type=int, help="flow step budget per heat step (60)")
parser.add_argument("--hold-steps", type=int, help="flow budget at the switch and at the end (300)")
parser.add_argument("--hold-tau", type=float, default=0.25, help="τ of those holds (0.25)")
parser.add_argument(
    "--projection-steps", type=int, default=1, help="constraint projections per flow step (1)"
)
parser.add_argument(
    "--alpha",
    default="calibrated",
    help="coupling α in Z = −αθI: a number, 'cw' (c·w = π/2 at the switch) or 'calibrated'",
)
parser.add_argument(
    "--frames", type=int, help="a picture every N heat steps (1, paper 24; 0: none)"
)
parser.add_argument("--force", action="store_true", help="write into a folder of other files")
parser.add_argument("--resume", action="store_true", help="continue from the last checkpoint")
args, _ = parser.parse_known_args()
comm = MPI.COMM_WORLD
wall0 = time.perf_counter()
committed = False
OutputDir.check(comm, Path(args.out), args.force, args.resume)  # before any computation
# the run's parameters: a checkpoint of other parameters is refused by --resume
parameters = {k: v for k, v in vars(args).items() if k not in ("out", "force", "resume", "frames")}
FINGERPRINT = checkpoint.fingerprint({"box_folding": parameters})
stop = interrupt.StopOnSignal().__enter__()  # SIGINT/SIGTERM: stop after a step, keep outputs


def discard_unless_committed(out) -> None:
    """On an error, remove the staging directory (rank 0, not collective): no half output."""
    if not committed and comm.rank == 0:
        shutil.rmtree(out.path, ignore_errors=True)


paper = dict(n=8, m=8, dt=0.1, flow_steps=20, hold_steps=2000, frames=24)
default = dict(n=4, m=4, dt=2.35, flow_steps=60, hold_steps=300, frames=1)
opts = {
    k: (paper if args.paper else default)[k] if getattr(args, k) is None else getattr(args, k)
    for k in default
}

# %% [markdown]
# ## The net and its regions
#
# `meshes/box_net.geo` builds the cross of six unit squares (base in the middle, north, south,
# east and west around it, the lid beyond north) with hinge strips of width w = π/24. The mesh
# is structured: n × n cells per face and m cells across each hinge. A hinge must bend
# smoothly across its width, so m ≥ 2 (the default m = 4 puts 22.5° of fold into each cell).

# %%
W = math.pi / 24  # hinge width (seed)
KAPPA, SOURCE, T_SWITCH = 5.0, 5.0, 28.2  # heat: seed 001
MU_HINGE, MU_FACE = 1.0, 20.0
FACES = ["base", "north", "south", "east", "west", "lid"]
HINGES = [Hinge(f"hinge_{f}", "north" if f == "lid" else "base", f) for f in FACES[1:]]

tagged = load_geo(comm, "box_net", {"w": W, "n": opts["n"], "m": opts["m"]})
num_cells = tagged.mesh.topology.index_map(2).size_global
print0(comm, f"box net: {num_cells} cells (n = {opts['n']}, m = {opts['m']}), {comm.size} rank(s)")

# %% [markdown]
# ## How hot do the hinges get, and what coupling closes the box?
#
# The heat equation does not depend on the shape (the coupling is one-way), so we can first
# run it alone to the switch. The seed gives s = 5 but not where it acts. On the whole net
# (insulated) it would give θ = 5t = 141 at t = 28.2; the seed reports "θ ≈ 23 everywhere at the
# switch", which is what a heater under one face gives: the mean temperature then grows like
# 5t·|base|/|ω| = 5t/6.65 (net area 6 + 5w), θ ≈ 21 at t = 28.2 (23.5 on a net of area 6).
# So the source heats the base, and diffusion (κ = 5) spreads it within a fraction of a time
# unit: at the switch the hinges differ by 1.6 % (the lid's hinge, farthest away, is coolest).
#
# With the seed's literal spontaneous curvature Z = −θ (α = 1), a hinge would reach the
# curvature c = 21 and turn by c·w = 21 · π/24 ≈ 2.8 rad ≈ 160°: the walls would fold through
# each other. A 90° fold needs c = π/(2w) = 12, i.e. α_cw = 12/θ̄_h, with θ̄_h the mean hinge
# temperature at the switch. We keep every other parameter of the seed and choose α.
# The discrete hinge (m cells across) folds slightly less than c·w (an O(h) error at the hinge
# edges, where the curvature jumps from 12 to 0), so by default α is calibrated once on a
# single hinge strip of the same mesh so that it folds exactly 90° (`--alpha cw` skips that).

# %%
source = HeatSource.switched(SOURCE, -SOURCE, T_SWITCH, regions=("base",))
probe = HeatSolver(tagged, KAPPA, opts["dt"], source)
probe.advance_to(T_SWITCH)
theta_hinges = {h.name: probe.mean(h.name) for h in HINGES}
theta_h = float(np.mean(list(theta_hinges.values())))
probe.destroy()
alpha_cw = (math.pi / 2) / (W * theta_h)
literal_deg = math.degrees(theta_h * W)
print0(
    comm,
    f"θ at the switch t = {T_SWITCH}: hinges "
    + ", ".join(f"{k[6:]} {v:.3f}" for k, v in theta_hinges.items())
    + f"; seed's Z = −θ would fold {literal_deg:.0f}°; c·w = π/2 needs α_cw = {alpha_cw:.4f}",
)

flow_settings = FlowSpec(
    tau=args.tau,
    tol=1e-6,
    l2_metric=False,
    multiplier_degree=0,
    projection_steps=args.projection_steps,
)
calibration = None
if args.alpha == "calibrated":
    alpha, calibration = calibrate_alpha(
        comm, W, opts["n"], opts["m"], theta_h, flow_settings, MU_HINGE, MU_FACE
    )
    print0(
        comm,
        f"calibration: one hinge strip folds {calibration['strip_fold_deg']:.2f}° at α_cw "
        f"({calibration['strip_flow_steps']} flow steps) → α = {alpha:.4f}",
    )
elif args.alpha == "cw":
    alpha = alpha_cw
else:
    alpha = float(args.alpha)

# %% [markdown]
# ## The coupled model
#
# Rigid motions: nothing is clamped (clamping the base's edges would pin the hinges' roots,
# which is harmless, but those edges are interior facets). Instead the base is held by a weak
# spring ½k∫_base |y − (x, 0)|² (k = 1000): the base is flat and in place in every folded
# state, so the spring carries no load at equilibrium and biases no fold. With the spring the
# flow needs no L² term in its metric (which would slow the far faces, the lid above all,
# by their lever arm). The multiplier is the published cell-mean one (degree 0): the stronger
# first-moment constraint locks the few, strongly bent cells of a hinge.
#
# Penalties: the hinge cells are long and thin (1/n by w/m), and the dG forms measure h_e as
# the cell diameter, so γ₀ and γ₁ are raised by the aspect ratio (`hinge_penalty`).

# %%
heat = HeatSolver(tagged, KAPPA, opts["dt"], source)
settings = ThermalSettings(
    alpha={h.name: alpha for h in HINGES},
    mu={**{f: MU_FACE for f in FACES}, **{h.name: MU_HINGE for h in HINGES}},
    flow_steps=opts["flow_steps"],
    anchor="base",
    anchor_stiffness=1000.0,
    penalty=hinge_penalty(W, opts["n"], opts["m"]),
)
model = ThermalBilayer(tagged, heat, flow_settings, settings)
if args.resume:
    model.restore(checkpoint.load(Path(args.out) / "checkpoint", comm, FINGERPRINT))
    print0(comm, f"resumed at t = {heat.time:.2f} (heat step {heat.steps})")
angles = FoldAngles(model.y, tagged, HINGES, sense=-1 if alpha > 0 else 1)
base_frame = RegionFrame(model.y, tagged, "base")

# %% [markdown]
# ## When is the box closed?
#
# Fold angles are signed (positive towards the side the box closes to) and measured between
# the area-weighted mean normals of the two faces a hinge joins. Closure: in the ideal box
# every hinge is a quarter cylinder of radius r = 2w/π, the walls stand at distance r outside
# the base's edges and the lid lies at height 1 + 2r with its free edge exactly over the
# base's opposite (south) edge, at (x₁, 0, ±(1 + 2r)) in the base's frame. The **closure gap**
# is the largest distance of a node of the lid's free edge from that place (the box folds
# towards −ν for α > 0, i.e. below the base: the sign is −). For reference, the south wall's
# free edge is at (x₁, −r, −(1 + r)), √2·r ≈ 0.118 from it, as at every edge of the ideal box.

# %%
R_HINGE = 2 * W / math.pi
SIDE = -1.0 if alpha > 0 else 1.0


def closure_gap() -> float:
    ref, pos = edge_nodes(model.y, tagged, "lid_edge")
    c, Q, c_ref = base_frame()
    local = (pos - c) @ Q + c_ref  # into the base's reference frame
    target = np.column_stack(
        [ref[:, 0], np.zeros(len(ref)), np.full(len(ref), SIDE * (1 + 2 * R_HINGE))]
    )
    gap = float(np.max(np.linalg.norm(local - target, axis=1), initial=0.0))
    return float(comm.allreduce(gap, op=MPI.MAX))


def measure(_model) -> dict:
    figures = {f"angle_{k}": v for k, v in angles.degrees().items()}
    figures["closure_gap"] = closure_gap()
    return figures


model.measure = measure

# %% [markdown]
# ## Output: VTX series, pictures, history
#
# The VTX series holds the deformation (and u = y − x for ParaView's "Warp By Vector") and the
# temperature. Pictures show the box in the base's frame, turned upside down (the box folds
# below the base) and coloured by θ, with one camera for all frames.

# %%
out = OutputDir(comm, Path(args.out), args.force, args.resume)
atexit.register(discard_unless_committed, out)
writer = DeformationWriter(out.path / "box.bp", model.y, extras=(model.theta,), comm=comm)
frames: list[Path] = []


def picture(path: Path, title: str) -> None:
    """Collective: gather the surface with θ, render on rank 0 with a fixed camera."""
    from dgplate.measure.fields import surface_grid

    grid = surface_grid(model.y, point_values={"temperature": model.theta})
    c, Q, c_ref = base_frame()  # collective: before the rank-0 branch
    if comm.rank != 0:
        return
    import pyvista

    from dgplate.io.plotting import _headless

    _headless()
    flip = np.diag([1.0, -1.0, -1.0]) if SIDE < 0 else np.eye(3)
    grid.points = ((np.asarray(grid.points) - c) @ Q + c_ref) @ flip.T
    try:
        surface = grid.extract_surface(nonlinear_subdivision=2, algorithm="dataset_surface")
    except TypeError:  # pyvista < 0.47
        surface = grid.extract_surface(nonlinear_subdivision=2)
    plotter = pyvista.Plotter(off_screen=True, window_size=[900, 720])
    plotter.set_background("white")
    plotter.add_mesh(
        surface,
        scalars="temperature",
        cmap="coolwarm",
        clim=(0.0, 1.05 * theta_max_expected),
        smooth_shading=True,
        scalar_bar_args={"title": "temperature", "color": "black", "vertical": True},
    )
    plotter.add_text(title, position="upper_edge", font_size=12, color="black")
    plotter.camera_position = [(5.0, -7.0, 5.0), (0.5, -1.0, 0.2), (0.0, 0.0, 1.0)]
    plotter.camera.view_angle = 30.0
    plotter.screenshot(str(path))
    plotter.close()


theta_max_expected = 1.02 * max(theta_hinges.values()) + 0.5
rows: list[dict] = [record.row() for record in model.records]  # those before a resume
t_start = time.perf_counter()


def report(record, label: str = "") -> None:
    row = record.row()
    rows.append(row)
    a = {k[12:]: v for k, v in row.items() if k.startswith("angle_hinge_")}
    print0(
        comm,
        f"t = {record.time:6.2f}  s = {record.source:+.0f}  θ ∈ [{record.theta_min:6.2f}, "
        f"{record.theta_max:6.2f}]  flow {record.flow_steps:4d} steps"
        f"{' (conv.)' if record.flow_converged else '        '}  angles "
        + " ".join(f"{k} {v:6.2f}" for k, v in a.items())
        + f"  gap {row['closure_gap']:.3f}  E = {record.energy:8.3f}  D_h = {record.defect:.2e}"
        f"  [{time.perf_counter() - t_start:5.0f} s]{label}",
    )


def save_checkpoint() -> None:
    checkpoint.save(
        out.checkpoint_dir,
        comm,
        model.checkpoint_fields(),
        {"fingerprint": FINGERPRINT, **model.checkpoint_state()},
    )


def stop_if_interrupted() -> None:
    """After SIGINT/SIGTERM: keep the history, a summary saying so and a checkpoint; exit."""
    signum = model.interrupted
    if not signum:
        return
    if model.records[-1].hold:
        model.records.pop()  # an interrupted hold is done again on --resume
    save_checkpoint()
    writer.close()
    write_history_csv()
    summary = {
        "model": "thermal_bilayer",
        "converged": False,
        "reason": interrupt.reason(signum),
        "interrupted": signum,
        "heat_steps": heat.steps,
        "time": heat.time,
        "steps": model.flow.step_count,
        "energy": model.flow.evaluate_energy(),
        "isometry_defect": model.flow.defect(),
    }
    write_json(comm, out.path / "summary.json", summary)
    out.commit()
    print0(comm, f"{summary['reason']} at t = {heat.time:.2f}: run again with --resume")
    sys.exit(interrupt.exit_code(signum))


def write_history_csv() -> None:
    if comm.rank == 0 and rows:
        with open(out.path / "history.csv", "w", newline="") as handle:
            columns = list(dict.fromkeys(key for row in rows for key in row))
            writer_csv = csv.DictWriter(handle, fieldnames=columns)
            writer_csv.writeheader()
            writer_csv.writerows(rows)


def after_step(_model, record) -> None:
    report(record)
    save_checkpoint()
    writer.write(record.time)
    if opts["frames"] and heat.steps % opts["frames"] == 0:
        path = out.path / "frames" / f"frame_{heat.steps:04d}.png"
        if comm.rank == 0:
            path.parent.mkdir(exist_ok=True)
        picture(path, f"t = {record.time:5.2f}, heat source {record.source:+.0f}")
        frames.append(path)


writer.write(0.0)

# %% [markdown]
# ## Heating: fold
#
# Each heat step raises θ by about 1.8 in the hinges (7.5° of fold); the flow follows with at
# most `flow_steps` steps of τ = 0.05, a few degrees behind. At the switch the plate is held
# at the peak temperature and relaxed (with τ = 0.25: the remaining path is short) until the
# flow's tolerance or the hold budget: that is the closed box.

# %%
holds = [record for record in model.records if record.hold]  # done before a resume
if not holds:
    model.run(T_SWITCH, after_step)
    stop_if_interrupted()
    switch_record = model.hold(opts["hold_steps"], tau=args.hold_tau)
    stop_if_interrupted()
    # the base's spring: ½k∫_base |y − (x, 0)|², zero if the base is flat and in place
    anchor_form = dolfinx.fem.form(
        anchor_energy(model.y, tagged, settings.anchor, settings.anchor_stiffness)
    )
    anchor = comm.allreduce(dolfinx.fem.assemble_scalar(anchor_form), op=MPI.SUM)
    switch_record.figures["anchor_energy"] = anchor
    report(switch_record, "  ← switch: relaxed at the peak temperature")
    writer.write(switch_record.time)
    save_checkpoint()
    picture(out.path / "closed.png", f"closed at the switch, t = {T_SWITCH}")
    frames.append(out.path / "closed.png")
else:
    switch_record = holds[0]
at_switch = {k[6:]: v for k, v in switch_record.figures.items() if k.startswith("angle_")}
anchor_at_switch = switch_record.figures["anchor_energy"]
gap_at_switch = switch_record.figures["closure_gap"]

# %% [markdown]
# ## Cooling: unfold
#
# From t = 28.2 the source is −5: θ falls at the rate it rose and the hinges unfold. At
# t = 56.4 the net is back near θ = 0 and flat.

# %%
model.run(args.t_end, after_step)
stop_if_interrupted()
final_record = model.hold(opts["hold_steps"], tau=args.hold_tau)
stop_if_interrupted()
final = model.last_result
report(final_record, "  ← end: relaxed")
writer.write(final_record.time)
writer.close()
final_angles = {k[6:]: v for k, v in final_record.figures.items() if k.startswith("angle_")}

# %% [markdown]
# ## Results

# %%
picture(out.path / "final.png", f"t = {final_record.time:.1f}: opened again")
if frames:
    from dgplate.io.plotting import frames_to_gif

    frames_to_gif([*frames, out.path / "final.png"], out.path / "folding.gif", 4, comm)
closed = out.path / "closed.png"
cut = frames.index(closed) if closed in frames else 0  # no pictures before a resume
heating, cooling = frames[:cut], frames[cut + 1 :]
if comm.rank == 0 and len(heating) >= 3 and cooling:  # six stills: 3 heating, closed, 2 cooling
    from PIL import Image

    stills = [heating[len(heating) // 6], heating[len(heating) // 2], heating[-2]]
    stills += [frames[cut], cooling[len(cooling) // 2], out.path / "final.png"]
    tiles = [Image.open(p).convert("RGB").resize((450, 360)) for p in stills]
    sheet = Image.new("RGB", (3 * 450, 2 * 360), "white")
    for i, tile in enumerate(tiles):
        sheet.paste(tile, ((i % 3) * 450, (i // 3) * 360))
    sheet.save(out.path / "folding.png")
write_history_csv()
if comm.rank == 0:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        plt = None
        print("matplotlib is not installed: no box_angles.png (the angles are in history.csv)")
    if plt is not None:
        fig, ax = plt.subplots(figsize=(7, 4))
        t = np.array([r["time"] for r in rows])
        order = np.argsort(t, kind="stable")
        for h in HINGES:
            ax.plot(t[order], np.array([r[f"angle_{h.name}"] for r in rows])[order], label=h.name)
        ax.axhline(90, color="gray", lw=0.8, ls="--")
        ax.axvline(T_SWITCH, color="gray", lw=0.8, ls=":")
        ax.set_xlabel("time t")
        ax.set_ylabel("fold angle [°]")
        ax.set_title(f"Self-folding box: hinge angles (α = {alpha:.4f}, heat switched at t = 28.2)")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out.path / "box_angles.png", dpi=120)

summary = {
    "model": "thermal_bilayer",
    "dofs": model.flow.num_dofs,
    "cells": num_cells,
    "ranks": comm.size,
    "steps": model.flow.step_count,
    "heat_steps": heat.steps,
    "converged": bool(switch_record.flow_converged and final.converged),
    "converged_at_switch": switch_record.flow_converged,
    "energy": final.energy,
    "isometry_defect": final.defect,
    "bbox": bounding_box(model.y),
    "wall_time_s": None,
    "dolfinx_version": compat.version_string(),
    "hinge_angles_deg_at_switch": at_switch,
    "hinge_angles_deg_final": final_angles,
    "closure_gap_at_switch": gap_at_switch,
    "closure_gap_definition": "max distance of the lid's free-edge nodes from (x1, 0, ±(1+2r)) "
    "in the base frame, r = 2w/π (the ideal closed box)",
    "energy_at_switch": switch_record.energy,
    "anchor_energy_at_switch": anchor_at_switch,
    "isometry_defect_at_switch": switch_record.defect,
    "alpha": alpha,
    "alpha_cw": alpha_cw,
    "alpha_rule": args.alpha,
    "calibration": calibration,
    "theta_hinges_at_switch": theta_hinges,
    "seed_literal_fold_deg": literal_deg,
    "parameters": {
        "w": W,
        "kappa": KAPPA,
        "source": SOURCE,
        "source_region": "base",
        "t_switch": T_SWITCH,
        "t_end": args.t_end,
        "mu_hinge": MU_HINGE,
        "mu_face": MU_FACE,
        "tau": args.tau,
        **opts,
    },
}
summary["wall_time_s"] = time.perf_counter() - wall0
write_json(comm, out.path / "summary.json", summary)
target = out.commit()
committed = True
print0(
    comm,
    "\nangles at the switch: "
    + ", ".join(f"{k[6:]} {v:.2f}°" for k, v in at_switch.items())
    + f"; closure gap {gap_at_switch:.4f}\nangles at t = {final_record.time:.1f}: "
    + ", ".join(f"{k[6:]} {v:.2f}°" for k, v in final_angles.items())
    + f"\n{summary['dofs']} dofs, {summary['steps']} flow steps, "
    f"{summary['wall_time_s']:.0f} s on {comm.size} rank(s) → {target}",
)
model.destroy()
