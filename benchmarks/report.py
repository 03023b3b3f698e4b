"""Turn the benchmark JSON files into a plot and the performance page's tables.

    python benchmarks/report.py [--results benchmarks/results] [--page docs/performance.md]

Reads ``flow_<cells>_np<ranks>.json`` (written by benchmarks/flow.py) and, if present, the
time-to-solution records of ``make bench-tau`` (benchmarks/adaptive_tau.py and
benchmarks/box_relaxation.py), fits the per-step cost
against the number of unknowns on the largest rank count that has three or more sizes, draws
``performance.png`` next to the JSON files and replaces the text between the page's markers
``<!-- performance:begin -->`` and ``<!-- performance:end -->``.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np
from pages import write_between

BEGIN, END = "<!-- performance:begin -->", "<!-- performance:end -->"
PHASES = ("assembly", "factorisation", "solves", "other")


def load(folder: Path) -> list[dict]:
    records = [json.loads(p.read_text()) for p in sorted(folder.glob("flow_*_np*.json"))]
    return sorted(records, key=lambda r: (r["ranks"], r["cells"]))


def growth_fit(records: list[dict]) -> tuple[int, float, list[dict]] | None:
    """(ranks, exponent p in cost ∝ DoFs^p, rows used) from the sizes ≥ 30k DoFs."""
    by_ranks: dict[int, list[dict]] = {}
    for r in records:
        if r["dofs"] >= 30_000:
            by_ranks.setdefault(r["ranks"], []).append(r)
    usable = {k: v for k, v in by_ranks.items() if len(v) >= 2}
    if not usable:
        return None
    ranks = max(usable, key=lambda k: (len(usable[k]), k))
    rows = usable[ranks]
    dofs = np.log([r["dofs"] for r in rows])
    cost = np.log([r["per_step_s"]["optimized"] for r in rows])
    return ranks, float(np.polyfit(dofs, cost, 1)[0]), rows


def scaling(records: list[dict]) -> dict[int, float]:
    """Speed-up of the optimised flow's whole run from 1 to 2 ranks, by cells per side, where
    both were measured (each rank count's run of median wall time when repeated)."""
    walls: dict[int, dict[int, float]] = {}
    for r in records:
        walls.setdefault(r["cells"], {})[r["ranks"]] = r["optimized"]["wall_s"]
    return {n: w[1] / w[2] for n, w in sorted(walls.items()) if 1 in w and 2 in w}


def load_large(folder: Path) -> list[dict]:
    """The runs past Table 1 (``bnn_<cells>_np<ranks>.json``, benchmarks/bnn_large.py)."""
    return [json.loads(p.read_text()) for p in sorted(folder.glob("bnn_*_np*.json"))]


def large_section(large: list[dict], fit: tuple[int, float, list[dict]] | None) -> list[str]:
    """The rows past the published Table 1, and the cost growth with them included."""
    if not large:
        return []
    lines = [
        "",
        "Past the published Table 1 (`make bench-large`, benchmarks/bnn_large.py: the same "
        "problem and stop through `dgplate run`, with checkpoints; LDLᵀ factors with block "
        "low-rank compression, tolerance as given):",
        "",
        "| cells | ranks | DoFs | steps | E_h | D_h | s/step | factorisations | FGMRES iterations "
        "per step | BLR tolerance | peak memory (MB, all ranks) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in large:
        lines.append(
            f"| {r['cells']}² | {r['ranks']} | {r['dofs']:,} | {r['steps']} "
            f"| {r['energy']:.4e} | {r['isometry_defect']:.4e} | {r['per_step_s']:.2f} "
            f"| {r['factorisations']} | {r['mean_iterations']:.1f} | {r['blr_tolerance']:g} "
            f"| {r['peak_memory_mb']['total']:.0f} |"
        )
    if fit:
        ranks, _, rows = fit
        more = [r for r in large if r["ranks"] == ranks and r["converged"]]
        if more:
            dofs = np.log([r["dofs"] for r in rows] + [r["dofs"] for r in more])
            cost = np.log(
                [r["per_step_s"]["optimized"] for r in rows] + [r["per_step_s"] for r in more]
            )
            p = float(np.polyfit(dofs, cost, 1)[0])
            lines += [
                "",
                f"- Cost per step ∝ DoFs^{p:.2f} on {ranks} rank(s) from "
                f"{round(np.exp(dofs.min())):,} to {round(np.exp(dofs.max())):,} DoFs, the rows "
                "above included (their factors are compressed, the table's are not).",
            ]
    return lines


def repeats(records: list[dict], cells: int = 64) -> str:
    """The wall times of the repeated runs at ``cells``², e.g. "1 rank: 92.6–95.9 s (3 runs)"."""
    parts = []
    for r in records:
        walls = r["optimized"].get("repeats_wall_s", [])
        if r["cells"] == cells and len(walls) > 1:
            parts.append(
                f"{r['ranks']} rank(s): {min(walls):.1f}–{max(walls):.1f} s ({len(walls)} runs)"
            )
    return "; ".join(parts)


def plot(records: list[dict], fit, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for ranks in sorted({r["ranks"] for r in records}):
        rows = [r for r in records if r["ranks"] == ranks]
        x = [r["dofs"] for r in rows]
        left.loglog(
            x,
            [r["per_step_s"]["optimized"] for r in rows],
            "o-",
            label=f"optimised, {ranks} rank(s)",
        )
        naive = [(r["dofs"], r["per_step_s"]["naive"]) for r in rows if "naive" in r["per_step_s"]]
        if naive:
            left.loglog(*zip(*naive), "s--", label=f"naive, {ranks} rank(s)")
    if fit:
        ranks, p, rows = fit
        ends = np.array([rows[0]["dofs"], rows[-1]["dofs"]], dtype=float)
        y0 = rows[0]["per_step_s"]["optimized"]
        left.loglog(ends, y0 * (ends / ends[0]) ** p, "k:", label=f"fit: DoFs^{p:.2f}")
    left.set_xlabel("degrees of freedom")
    left.set_ylabel("seconds per step")
    left.grid(True, which="both", alpha=0.3)
    left.legend(fontsize=8)
    rows = [r for r in records if "naive" in r]
    labels, bottoms = [], None
    if rows:
        labels = [
            f"{r['cells']}², {r['ranks']}r\n{kind}" for r in rows for kind in ("naive", "opt.")
        ]
        totals = [r["per_step_s"][kind] for r in rows for kind in ("naive", "optimized")]
        values = {
            ph: [
                r[kind]["breakdown_per_step_s"][ph] / r["per_step_s"][kind]
                for r in rows
                for kind in ("naive", "optimized")
            ]
            for ph in PHASES
        }
        bottoms = np.zeros(len(labels))
        for ph in PHASES:
            right.bar(labels, values[ph], bottom=bottoms, label=ph)
            bottoms += np.array(values[ph])
        for i, total in enumerate(totals):
            right.text(i, 1.01, f"{total:.2g} s", ha="center", va="bottom", fontsize=7)
        right.set_ylim(0, 1.1)
        right.set_ylabel("share of a step's time")
        right.legend(fontsize=8)
        right.tick_params(axis="x", labelsize=7)
    right.set_title("where a step's time goes (s/step on top)")
    left.set_title("cost per step (BNN vertical load, Q2)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def bandwidth_notes(folder: Path) -> list[str]:
    """The machine's memory bandwidth, 2 ranks over 1, measured before and after the flow runs
    (``bandwidth_before.json``, ``bandwidth_after.json``, benchmarks/bandwidth.py)."""
    runs = [folder / f"bandwidth_{when}.json" for when in ("before", "after")]
    ratios = [json.loads(p.read_text())["ratio_two_over_one"] for p in runs if p.exists()]
    if not ratios:
        return []
    read = " and ".join(f"{r['read_gb_per_s']:.2f}×" for r in ratios)
    triad = " and ".join(f"{r['triad_gb_per_s']:.2f}×" for r in ratios)
    return [
        f"- Memory bandwidth, 2 ranks at once over 1 (benchmarks/bandwidth.py, "
        f"{'before and after' if len(ratios) == 2 else 'once in'} this run): read {read}, "
        f"triad {triad}. The substitutions with the factors, most of a step, are bound by "
        "memory traffic, so this is about the ceiling of their 1 → 2-rank speed-up."
    ]


def section(records: list[dict], fit, speedup: dict[int, float], image: str, folder: Path) -> str:
    machine = records[-1]["machine"]
    # records from before the LDLᵀ default name no factorisation: they were measured with LU
    kinds = sorted({r["optimized"].get("factorisation", "LU") for r in records})
    mixed = len(kinds) > 1
    factors = " or ".join(kinds) + (" (by row, in the factorisations column)" if mixed else "")
    lines = [
        BEGIN,
        "",
        f"Measured on {machine['cores']} cores ({machine['cpu']}), DOLFINx {machine['dolfinx']}, "
        f"PETSc {machine['petsc']} with MUMPS; regenerate with `make bench`. The problem is the "
        "BNN vertical-load plate (Q2, τ = h, published Table 1). *Optimised*: the constant block "
        "assembled once, in the pattern of its actual non-zeros, only b_n each step, and one "
        f"{factors} factorisation (in a cell-wise numbering that does not depend on the partition) "
        "reused as the FGMRES preconditioner until the iteration count grows. "
        "*Naive*: the published algorithm, everything reassembled (DOLFINx's pattern) and "
        "factorised afresh every step.",
        "",
        "| cells | ranks | DoFs | steps | s/step optimised | s/step naive | ratio | factorisations "
        "| E_h (published) | D_h (published) | peak memory (MB, all ranks) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in records:
        pub = r.get("published") or {}
        naive = r["per_step_s"].get("naive")
        ratio = f"{r['per_step_s']['optimized'] / naive:.3f}" if naive else "–"
        lines.append(
            f"| {r['cells']}² | {r['ranks']} | {r['dofs']:,} | {r['steps']}"
            f"{' (' + str(pub['steps']) + ')' if pub else ''} "
            f"| {r['per_step_s']['optimized']:.3f} | {f'{naive:.3f}' if naive else '–'} "
            f"| {ratio} "
            f"| {r['optimized']['factorisations']}"
            f"{' ' + r['optimized'].get('factorisation', 'LU') if mixed else ''} "
            f"| {r['energy']:.4e} ({pub.get('energy', '–')}) "
            f"| {r['isometry_defect']:.4e} ({pub.get('isometry_defect', '–')}) "
            f"| {r['peak_memory_mb']['total']:.0f} |"
        )
    lines.append("")
    notes = []
    for r in records:
        if "energy_rel_diff" in r:
            notes.append(
                f"- {r['cells']}², {r['ranks']} rank(s): optimised vs naive E_h differ by "
                f"{r['energy_rel_diff']:.1e} (relative); step counts "
                f"{'agree' if r['steps_agree'] else 'DIFFER'} ({r['steps']} and {r['naive']['steps']})."
            )
    for cells, factor in speedup.items():
        spread = repeats(records, cells)
        notes.append(
            f"- 1 → 2 ranks at {cells}², optimised flow, whole run: {factor:.2f}× faster"
            + (f" (medians; {spread})." if spread else ".")
        )
    notes += bandwidth_notes(folder)
    if fit:
        ranks, p, rows = fit
        notes.append(
            f"- Cost per step ∝ DoFs^{p:.2f} on {ranks} rank(s), from {rows[0]['dofs']:,} to "
            f"{rows[-1]['dofs']:,} DoFs."
        )
    lines += [*notes, "", f"![cost per step]({image})", "", END]
    return "\n".join(lines)


#: The time-to-solution records of ``make bench-tau``: (file, problem as the table names it).
TIME_TO_SOLUTION = (
    ("adaptive_tau_bnn64_newton_np1.json", "BNN 64², 1 projection"),
    ("adaptive_tau_cylinder32x16_newton_np1.json", "bilayer cylinder 32×16, 2 projections"),
)
BOX = "box_relaxation_np1.json"


def _run_cell(run: dict) -> str:
    """'steps (step solves)' of a run, with its rejected steps and the steps that raised E_h."""
    extra = [f"{run['rejected_steps']} rejected"] if run.get("rejected_steps") else []
    if run.get("energy_increases"):
        extra.append(f"E_h rose at {run['energy_increases']}")
    return f"{run['steps']} ({run['step_solves']})" + (f", {', '.join(extra)}" if extra else "")


def _row(name: str, fixed: dict, adaptive: dict, newton: dict) -> str:
    diff = max(
        abs(r["energy"] - fixed["energy"]) / abs(fixed["energy"]) for r in (adaptive, newton)
    )
    return (
        f"| {name} | {_run_cell(fixed)} | {_run_cell(adaptive)} | {_run_cell(newton)} "
        f"| {fixed['step_solves'] / adaptive['step_solves']:.1f} "
        f"| {fixed['step_solves'] / newton['step_solves']:.1f} | {diff:.1e} |"
    )


def time_to_solution(folder: Path) -> list[str]:
    """The table of ``make bench-tau`` (fixed τ against adaptive τ), if its records exist."""
    rows = []
    for name, label in TIME_TO_SOLUTION:
        path = folder / name
        r = json.loads(path.read_text()) if path.exists() else {}
        if r.get("fixed") and r.get("adaptive") and r.get("newton"):  # not a --no-fixed record
            rows.append(_row(f"{label} (tol {r['tol']:g})", r["fixed"], r["adaptive"], r["newton"]))
    box = folder / BOX
    if box.exists():
        r = json.loads(box.read_text())
        for hold in r["holds"]:
            label = f"box, hold at t = {hold['time']:g} ({hold['dofs']:,} DoFs, tol {r['tol']:g})"
            rows.append(_row(label, hold["fixed"], hold["adaptive"], hold["newton"]))
    if not rows:
        return []
    return [
        "",
        "Time to solution (`make bench-tau`, 1 rank): each problem relaxed to the τ-independent "
        "stop ‖P DE_h‖_*' < tol from the same start, with fixed τ = h, with adaptive τ, and with "
        "adaptive τ and the SQP finish (defaults). Steps (step solves: every solve with a step or "
        "SQP matrix, corrections included); the ratios are fixed / adaptive step solves.",
        "",
        "| problem | fixed τ = h | adaptive | adaptive + SQP | ratio adaptive | ratio SQP "
        "| E_h, largest relative difference to fixed |",
        "|---|---|---|---|---|---|---|",
        *rows,
    ]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--results", type=Path, default=Path("benchmarks/results"))
    parser.add_argument("--page", type=Path, default=Path("docs/performance.md"))
    args = parser.parse_args(argv)
    records = load(args.results)
    if not records:
        raise SystemExit(f"no flow_*_np*.json in {args.results}: run `make bench` first")
    fit = growth_fit(records)
    image = args.results / "performance.png"
    plot(records, fit, image)
    picture = os.path.relpath(image, args.page.parent)  # as the page links it
    text = section(records, fit, scaling(records), Path(picture).as_posix(), args.results)
    extra = large_section(load_large(args.results), fit) + time_to_solution(args.results)
    if extra:
        text = text.replace(f"\n\n{END}", "\n" + "\n".join(extra) + f"\n\n{END}")
    write_between(args.page, BEGIN, END, text, heading="Performance")
    print(text)


if __name__ == "__main__":
    main()
