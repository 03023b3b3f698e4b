"""Accuracy of the discretisations on cases with an exact answer, over mesh levels.

Cases (the mesh level n sets the cells; h ∝ 1/n):

- ``cylinder``: a 2 × 1 rectangle clamped on ``left``, bilayer Z = aI (a: ``--a``), 2n × n
  cells. The exact minimiser is a cylinder of radius 1/a about the clamped side's direction,
  E = ½a²|ω| = a².
- ``uniaxial``: the same plate with Z = a e₁⊗e₁. The same cylinder is the exact minimiser,
  now with II = Z everywhere: E = 0, no bending moment anywhere, in particular none on the
  free edges x₂ = 0, 1 (a control case: for Z = aI the moment (II − Z)n there is −a n).
- ``rigid``: the BNN Table 1 plate (demos/problems/vertical_load.toml, (0, 4)² clamped on two
  perpendicular sides, vertical load), n × n cells. Its only isometries are rigid: E = 0.

Variants are sets of problem-file overrides (``VARIANTS``); ``ldg_*`` use the LDG
reconstructed Hessian (``model.hessian = "ldg"``) with γ₀ = γ₁ = γ (``ldg_g<γ>``), the
standard penalties (``ldg_std``) or the cylinder file's (``ldg_tuned``). Unless a variant says otherwise,
the flow runs to a discrete minimiser: adaptive τ from τ = h with the SQP finish and the
τ-independent stop ‖P DE_h‖_*' < ``--tol`` (``MINIMISER``); ``*_rate`` variants use the
fixed-τ flow with the rate stop instead, to measure the error of stopping the flow early.

Per run the record holds the DoFs, E_h and its error, the fitted radius and its error, the
isometry defect, the final stationarity measure, steps, SQP steps, wall time and, for the
bilayer cases, the free-edge layer: the mean principal curvatures and ½∫|II − Z|² (cell
midpoints) of the cells on the free sides x₂ = 0, 1 against the others. Observed orders are
log₂ of successive error ratios.

    python benchmarks/accuracy.py --case cylinder --a 2 --variants file --levels 2 4 8 16
    python benchmarks/accuracy.py --case rigid --variants bnn minimiser --levels 4 8 16 32

Each (case, a) writes benchmarks/results/accuracy_<case>[_a<a>]_<variant>.json. The tables of
docs/accuracy.md, between ``<!-- accuracy:begin -->`` and ``<!-- accuracy:end -->``, are
generated from those files (no runs):

    python benchmarks/accuracy.py --table-only [--results benchmarks/results] [--page docs/accuracy.md]
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np
from pages import write_between

from dgplate.io.output import print0
from dgplate.problems.runner import run as run_problem
from dgplate.problems.specs import load_problem

ROOT = Path(__file__).resolve().parent.parent
PROBLEMS = ROOT / "demos" / "problems"
RESULTS = ROOT / "benchmarks" / "results"

#: The flow that ends at a discrete minimiser (to the τ-independent stop), with the step
#: control the tables (and benchmarks/seeds.py's, which imports this) were measured with.
MINIMISER: dict[str, Any] = {
    "flow.tau": "h",
    "flow.adaptive_tau": True,
    "flow.newton_finish": True,
    "flow.stop": "stationarity",
    "flow.projection_steps": 2,
    "flow.step_control": "defect_bound",
}
#: The cylinder file's discretisation (demos/problems/bilayer_cylinder.toml).
TUNED: dict[str, Any] = {
    "model.penalty": {"gamma0": 5000.0, "gamma1": 86.0, "gradient_power": 3},
    "flow.multiplier_degree": 1,
    "flow.edge_constraint": True,
}
STANDARD_PENALTY = {"gamma0": 5000.0, "gamma1": 1100.0, "gradient_power": 1}

#: name → overrides on top of the case's problem file.
VARIANTS: dict[str, dict[str, Any]] = {
    # the cylinder file's settings, flowed to a discrete minimiser
    "file": {**TUNED, **MINIMISER},
    # the same discretisation, the file's fixed-τ flow and rate stop
    "file_rate": {**TUNED, "flow.tau": 0.25, "flow.tol": 1e-6, "flow.projection_steps": 2},
    "file_noedge": {**TUNED, **MINIMISER, "flow.edge_constraint": False},
    "file_dg0": {**TUNED, **MINIMISER, "flow.multiplier_degree": 0},
    "file_tri": {**TUNED, **MINIMISER, "mesh.cell_type": "triangle"},
    "file_q3": {**TUNED, **MINIMISER, "model.degree": 3},
    "file_p3_g1000": {
        **TUNED,
        **MINIMISER,
        "model.penalty": {"gamma0": 5000.0, "gamma1": 1000.0, "gradient_power": 3},
    },
    "file_p3_g10": {
        **TUNED,
        **MINIMISER,
        "model.penalty": {"gamma0": 5000.0, "gamma1": 10.0, "gradient_power": 3},
    },
    # the gradient jumps weighted by γ₁h⁻ᵖ with the powers between the standard and the file's
    **{
        f"p{power:g}_g{gamma:g}": {
            **TUNED,
            **MINIMISER,
            "model.penalty": {"gamma0": 5000.0, "gamma1": gamma, "gradient_power": power},
        }
        for power, gamma in ((1.5, 600.0), (2.0, 300.0))
    },
    # the standard penalty power with the file's constraint
    "p1": {**TUNED, **MINIMISER, "model.penalty": STANDARD_PENALTY},
    # the standard penalty with ten times γ₀
    "p1_gamma0x10": {
        **TUNED,
        **MINIMISER,
        "model.penalty": {"gamma0": 50000.0, "gamma1": 1100.0, "gradient_power": 1},
    },
    # the standard penalty with the Gauss-curvature penalty (β/2)Σ h⁻¹∫K² (model.gauss_penalty)
    "p1_gauss1": {
        **TUNED,
        **MINIMISER,
        "model.penalty": STANDARD_PENALTY,
        "model.gauss_penalty": 1.0,
    },
    "p1_gauss10": {
        **TUNED,
        **MINIMISER,
        "model.penalty": STANDARD_PENALTY,
        "model.gauss_penalty": 10.0,
    },
    # the published method's discretisation (DG0 multipliers, no edge moments), to a minimiser
    "published": {
        "model.penalty": STANDARD_PENALTY,
        "flow.multiplier_degree": 0,
        "flow.edge_constraint": False,
        **MINIMISER,
    },
    # the LDG reconstructed Hessian (model.hessian = "ldg", dgplate/dg/lifting.py) with small
    # penalties γ₀ = γ₁ = γ, the file's constraint, to a minimiser
    **{
        f"ldg_g{gamma:g}": {
            **TUNED,
            **MINIMISER,
            "model.hessian": "ldg",
            "model.penalty": {"gamma0": gamma, "gamma1": gamma, "gradient_power": 1},
        }
        for gamma in (1.0, 10.0, 100.0)
    },
    # the LDG Hessian with the interior-penalty method's penalties (standard, and the file's)
    "ldg_std": {**TUNED, **MINIMISER, "model.hessian": "ldg", "model.penalty": STANDARD_PENALTY},
    "ldg_tuned": {**TUNED, **MINIMISER, "model.hessian": "ldg"},
    "minimiser_ldg_std": {
        **MINIMISER,
        "model.hessian": "ldg",
        "model.penalty": STANDARD_PENALTY,
    },
    # the same on the rigid plate (the published constraint: DG0 multipliers)
    **{
        f"minimiser_ldg_g{gamma:g}": {
            **MINIMISER,
            "model.hessian": "ldg",
            "model.penalty": {"gamma0": gamma, "gamma1": gamma, "gradient_power": 1},
        }
        for gamma in (1.0, 10.0, 100.0)
    },
    # the C⁰ interior-penalty method (continuous y, model.space = "c0"): the standard penalty
    # (its γ₀ term vanishes) with the file's constraint, whose first moments are then P1
    "c0": {**TUNED, **MINIMISER, "model.penalty": STANDARD_PENALTY, "model.space": "c0"},
    "c0_dg0": {
        **TUNED,
        **MINIMISER,
        "model.penalty": STANDARD_PENALTY,
        "model.space": "c0",
        "flow.multiplier_degree": 0,
    },
    "c0_noedge": {
        **TUNED,
        **MINIMISER,
        "model.penalty": STANDARD_PENALTY,
        "model.space": "c0",
        "flow.edge_constraint": False,
    },
    # the same from the exact cylinder's arc (case_setup): the discrete minimiser near it
    "c0_from_arc": {**TUNED, **MINIMISER, "model.penalty": STANDARD_PENALTY, "model.space": "c0"},
    "minimiser_c0": {**MINIMISER, "model.space": "c0"},
    "minimiser_c0_dg1": {**MINIMISER, "model.space": "c0", "flow.multiplier_degree": 1},
    # BNN Table 1 as published: τ = h, no projection, rate stop
    "bnn": {"flow.tau": "h", "flow.tol": 1e-6},
    "minimiser": MINIMISER,
    # the default step control (the trust region's SQP steps, off the constraint between
    # steps) against the defect bound the study pins: the same discrete minimisers
    "file_trust_region": {**TUNED, **MINIMISER, "flow.step_control": "trust_region"},
    "minimiser_trust_region": {**MINIMISER, "flow.step_control": "trust_region"},
    "minimiser_dg1": {**MINIMISER, "flow.multiplier_degree": 1},
    "minimiser_tri": {**MINIMISER, "mesh.cell_type": "triangle"},
    # the rigid plate as a bilayer with Z = 0 and the Gauss-curvature penalty
    "minimiser_gauss1": {
        **MINIMISER,
        "model.name": "bilayer",
        "model.Z": 0.0,
        "model.gauss_penalty": 1.0,
    },
    # ten times the value-jump penalty γ₀ (the in-plane incompatibility the moments leave)
    "minimiser_gamma0x10": {
        **MINIMISER,
        "model.penalty": {"gamma0": 50000.0, "gamma1": 1100.0, "gradient_power": 1},
    },
    "minimiser_gamma0x100": {
        **MINIMISER,
        "model.penalty": {"gamma0": 500000.0, "gamma1": 1100.0, "gradient_power": 1},
    },
    # over-penalised gradient jumps on the rigid plate: γ₁h⁻³ equal to 1100h⁻¹ at 16²
    "minimiser_p3": {
        **MINIMISER,
        "model.penalty": {"gamma0": 5000.0, "gamma1": 137.5, "gradient_power": 3},
    },
}

CASES = ("cylinder", "uniaxial", "rigid")


def case_setup(case: str, a: float, n: int) -> tuple[Path, dict[str, Any], float, float]:
    """(problem file, case overrides, exact energy, exact radius (nan: none)) at level n."""
    if case == "rigid":
        return PROBLEMS / "vertical_load.toml", {"mesh.cells": [n, n]}, 0.0, math.nan
    Z: Any = a if case == "cylinder" else [[a, 0.0], [0.0, 0.0]]
    overrides = {"mesh.corners": [[0.0, 0.0], [2.0, 1.0]], "mesh.cells": [2 * n, n], "model.Z": Z}
    exact = a * a if case == "cylinder" else 0.0
    return PROBLEMS / "bilayer_cylinder.toml", overrides, exact, 1.0 / a


def edge_layer(y: Any, Z: np.ndarray, height: float) -> dict[str, float]:
    """Mean κ₁, κ₂ and ½∫|II − Z|² (midpoint rule) on the cells at x₂ = 0, 1 and on the rest.

    ``height``: the cells' extent in x₂ (the row of cells along each free side).
    """
    import dolfinx.mesh

    from dgplate.measure.analysis import cell_second_fundamental_form
    from dgplate.mesh.tagged import local_entities

    mesh = y.function_space.mesh
    II, areas = cell_second_fundamental_form(y)
    cells = local_entities(mesh, mesh.topology.dim)[: areas.size]
    mid = dolfinx.mesh.compute_midpoints(mesh, mesh.topology.dim, cells)
    edge = (mid[:, 1] < height) | (mid[:, 1] > 1.0 - height)
    kappa = np.linalg.eigvalsh(II)
    density = 0.5 * np.sum((II - Z) ** 2, axis=(1, 2))
    out: dict[str, float] = {}
    for name, mask in (("edge", edge), ("inner", ~edge)):
        w = areas[mask]
        if not w.size:  # one row of cells per side: no inner cells
            continue
        out[f"{name}_area"] = float(w.sum())
        out[f"{name}_kappa1"] = float(np.dot(kappa[mask, 1], w) / w.sum())
        out[f"{name}_kappa2"] = float(np.dot(kappa[mask, 0], w) / w.sum())
        out[f"{name}_energy"] = float(np.dot(density[mask], w))
    return out


def one_run(case: str, a: float, n: int, variant: str, tol: float, steps: int) -> dict[str, Any]:
    """One run of ``case`` at level n with ``variant``; its figures."""
    path, overrides, exact_energy, exact_radius = case_setup(case, a, n)
    overrides = {
        **overrides,
        "flow.tol": tol,
        "flow.max_steps": steps,
        "flow.checkpoint_every": 0,
        "output.vtx": False,
        "output.png": False,
        "output.progress": 0,
        **VARIANTS[variant],
    }
    if variant.endswith("_from_arc"):  # started on the exact cylinder (bilayer cases)
        overrides["model.start"] = {"type": "arc", "radius": 1.0 / a}
    problem = load_problem(path, overrides)
    with tempfile.TemporaryDirectory(prefix="accuracy_") as folder:
        t0 = time.perf_counter()
        result = run_problem(problem, Path(folder) / "run", MPI.COMM_SELF)
        wall = time.perf_counter() - t0
    s = result.summary
    record: dict[str, Any] = {
        "level": n,
        "cells": overrides["mesh.cells"],
        "dofs": s["dofs"],
        "converged": s["converged"],
        "reason": s["reason"],
        "steps": s["steps"],
        "newton_steps": s.get("newton_steps"),
        "rejected_steps": s.get("rejected_steps"),
        "energy": s["energy"],
        "exact_energy": exact_energy,
        "isometry_defect": s["isometry_defect"],
        "stationarity_last": result.history[-1].get("stationarity") if result.history else None,
        "wall_s": wall,
    }
    scale = exact_energy if exact_energy else 1.0
    record["energy_error"] = (s["energy"] - exact_energy) / scale
    if case != "rigid":
        radius = s["cylinder_fit"]["radius"]
        record["radius"] = radius
        record["radius_error"] = radius / exact_radius - 1.0
        record["axis"] = s["cylinder_fit"]["axis"]
        Z = a * np.eye(2) if case == "cylinder" else np.diag([a, 0.0])
        assert result.shape is not None
        record["layer"] = edge_layer(result.shape, Z, 1.0 / n)
    return record


def orders(runs: list[dict[str, Any]], key: str) -> list[float | None]:
    """log₂(e_{i−1}/e_i) of successive levels (levels double); None where undefined."""
    out: list[float | None] = []
    for prev, cur in itertools.pairwise(runs):
        e0, e1 = abs(prev.get(key, math.nan)), abs(cur.get(key, math.nan))
        ratio = prev["level"] / cur["level"]
        ok = e0 > 0 and e1 > 0 and math.isfinite(e0) and math.isfinite(e1)
        out.append(math.log(e1 / e0) / math.log(ratio) if ok else None)
    return out


ERROR_LABEL = {
    "cylinder": "E_h relative error",
    "uniaxial": "E_h (exact 0)",
    "rigid": "E_h (exact 0)",
}
CASE_TITLE = {"cylinder": "Z = aI", "uniaxial": "Z = a e₁⊗e₁", "rigid": "rigid plate"}
BEGIN, END = "<!-- accuracy:begin -->", "<!-- accuracy:end -->"


def table(report: dict[str, Any]) -> str:
    """A Markdown table of one (case, a, variant): a row per level, observed orders alongside."""
    radius = report["case"] != "rigid"
    head = "| cells | DoFs | " + ERROR_LABEL[report["case"]] + " | order |"
    head += " radius error | order |" if radius else ""
    head += " steps | time (s) |"
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    e_orders = [None, *orders(report["runs"], "energy_error")]
    r_orders = [None, *orders(report["runs"], "radius_error")]
    for run, eo, ro in zip(report["runs"], e_orders, r_orders, strict=True):
        row = f"| {'×'.join(str(c) for c in run['cells'])} | {run['dofs']:,} "
        row += f"| {run['energy_error']:+.3e} | {_num(eo)} |"
        if radius:
            row += f" {_num(run.get('radius_error'), '+.3e')} | {_num(ro)} |"
        steps = f"{run['steps']}" + ("" if run["converged"] else " (not converged)")
        lines.append(row + f" {steps} | {run['wall_s']:.0f} |")
    return "\n".join(lines)


def _num(value: float | None, fmt: str = ".2f") -> str:
    """``value`` formatted, or a dash."""
    return "—" if value is None else format(value, fmt)


def load_records(folder: Path) -> dict[tuple[str, float, str], dict[str, Any]]:
    """The records of ``folder``'s accuracy_*.json, one per (case, a, variant).

    Files of the same (case, a, variant) (a ``--tag``ged extra level) are merged, runs sorted by
    level; ``files`` names them.
    """
    merged: dict[tuple[str, float, str], dict[str, Any]] = {}
    for path in sorted(folder.glob("accuracy_*.json")):
        record = json.loads(path.read_text())
        key = (record["case"], record["a"], record["variant"])
        into = merged.setdefault(key, {**record, "runs": [], "files": []})
        into["runs"] = sorted([*into["runs"], *record["runs"]], key=lambda run: run["level"])
        into["files"].append(path.name)
    return merged


def _case_order(key: tuple[str, float, str]) -> tuple[int, float, str]:
    return CASES.index(key[0]), key[1], key[2]


def frontier(records: list[dict[str, Any]]) -> list[str]:
    """The converged runs no run with as few DoFs beats in |error|: "DoFs: error (variant)"."""
    runs = [
        (run["dofs"], abs(run["energy_error"]), record["variant"])
        for record in records
        for run in record["runs"]
        if run["converged"]
    ]
    out, best = [], math.inf
    for dofs, error, variant in sorted(runs):
        if error < best:
            best = error
            out.append(f"{dofs:,}: {error:.2e} (`{variant}`)")
    return out


def page_section(folder: Path) -> str:
    """The accuracy page's generated section: a table per record, a frontier per case."""
    records = load_records(folder)
    lines = [BEGIN]
    cases: dict[tuple[str, float], list[dict[str, Any]]] = {}
    for key in sorted(records, key=_case_order):
        cases.setdefault(key[:2], []).append(records[key])
    for (case, a), group in cases.items():
        title = CASE_TITLE[case] + ("" if case == "rigid" else f", a = {a:g}")
        lines += ["", f"### {title}", ""]
        for record in group:
            files = ", ".join(f"`{name}`" for name in record["files"])
            lines += [f"`{record['variant']}`:", "", table(record), "", f"From {files}.", ""]
        best = "; ".join(frontier(group))
        lines += [f"Frontier (the smallest error at as many DoFs or fewer): {best}."]
    return "\n".join([*lines, "", END])


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", choices=CASES, default="cylinder")
    parser.add_argument("--a", type=float, default=1.0, help="Z = aI (cylinder) or a e₁⊗e₁")
    parser.add_argument("--variants", nargs="+", choices=sorted(VARIANTS), default=["file"])
    parser.add_argument("--levels", type=int, nargs="+", default=[2, 4, 8, 16])
    parser.add_argument("--tol", type=float, default=1e-7, help="stationarity tolerance")
    parser.add_argument("--max-steps", type=int, default=3000)
    parser.add_argument("--tag", default="", help="appended to the JSON file names")
    parser.add_argument("--results", type=Path, default=RESULTS, help="folder of the JSON files")
    parser.add_argument("--table", nargs="+", type=Path, help="print these records' tables only")
    parser.add_argument("--page", type=Path, default=ROOT / "docs" / "accuracy.md")
    parser.add_argument(
        "--table-only", action="store_true", help="rewrite --page's tables from --results"
    )
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    if args.table:
        for path in args.table:
            print0(comm, table(json.loads(path.read_text())) + "\n")
        return
    if args.table_only:
        if comm.rank == 0:
            write_between(args.page, BEGIN, END, page_section(args.results))
        return
    for variant in args.variants:
        runs: list[dict[str, Any]] = []
        name = f"accuracy_{args.case}"
        name += "" if args.case == "rigid" else f"_a{args.a:g}"
        name += f"_{variant}{args.tag}.json"
        for n in args.levels:
            record = one_run(args.case, args.a, n, variant, args.tol, args.max_steps)
            runs.append(record)
            print0(
                comm,
                f"{args.case} a={args.a:g} {variant} n={n} dofs={record['dofs']} "
                f"E_err={record['energy_error']:+.4e} R_err={record.get('radius_error', math.nan):+.4e} "
                f"steps={record['steps']} conv={record['converged']} t={record['wall_s']:.1f}s",
            )
            report = {
                "case": args.case,
                "a": args.a,
                "variant": variant,
                "overrides": VARIANTS[variant],
                "runs": runs,
                "energy_orders": orders(runs, "energy_error"),
                "radius_orders": orders(runs, "radius_error"),
            }
            if comm.rank == 0:
                args.results.mkdir(parents=True, exist_ok=True)
                (args.results / name).write_text(json.dumps(report, indent=1) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
