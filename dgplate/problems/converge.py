"""A convergence study: a problem on successively refined meshes, each figure extrapolated.

``converge(problem, levels=4)`` runs ``problem`` on ``levels`` meshes, each refined by a factor
2 from the one before (level 1 is the problem as given): a rectangle's ``mesh.cells`` doubled,
a ``.geo`` file's size parameters halved (``h``, ``h_*`` and ``*_h`` set to a positive
number; the counts ``n`` and ``m`` doubled), a rod's ``model.cells`` doubled. Each level of a
plate's gradient flow starts from the previous level's solution, interpolated onto the finer
mesh (:class:`~dgplate.solvers.transfer.MeshStart`); FvK's Newton, the rod, a continuation
in the clamped data, a path and a flow that does not end at a discrete minimiser start each
level from the problem's own start (:func:`warm_start`). Each level is a normal run folder ``level-1``, ``level-2`` … of the
study's folder, so that with ``resume`` a finished level is reused and an interrupted one
continued (:mod:`dgplate.problems.folders`).

Every numeric figure of the levels' summary.json (E_h, D_h, the bounding box's extent, the
model's own figures) gets its observed order and Richardson limit from the last three levels
(:func:`dgplate.measure.richardson.extrapolate`), or the reason why none can be given. The
study writes ``converge.json``, ``converge.md`` (the table printed) and ``converge.png``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate import interrupt
from dgplate.errors import InputError
from dgplate.io.output import count_of, print0, write_json
from dgplate.measure.richardson import Estimate, extrapolate
from dgplate.mesh.tagged import geo_parameters, resolve_geo
from dgplate.problems import folders, prepare, sizing
from dgplate.problems.registry import MODELS
from dgplate.problems.specs import Problem, problem_from_dict
from dgplate.schema import is_integer, is_number
from dgplate.solvers.transfer import MeshStart

#: Models whose levels start from the problem's own start, not from the coarser solution.
COLD_START = {
    "fvk": "Newton over the load schedule starts from the unloaded plate",
    "rod": "a rod's start needs its frame, which a coarser rod does not carry",
}

#: summary.json's numbers that describe the run, not its solution.
BOOKKEEPING = {"tau", "wall_time_s", "wall_time_since_resume_s", "peak_memory_mb"}

#: E_h "jumps" when it changes by more than this factor more on the last refinement than on
#: the one before: a sign that some level found another local minimiser.
JUMP = 2.0

#: A .geo parameter named so is a cell size (halved per level); one named so, a cell count.
SIZE_NAMES, COUNT_NAMES = ("h",), ("n", "m")


@dataclass
class ConvergenceStudy:
    """What :func:`converge` returns (also ``converge.json``).

    ``levels`` holds one record per level (size, cells, dofs, steps, wall time, E_h, D_h,
    bounding box, the figures, whether it was reused); ``figures`` per figure its values on
    the levels and its estimate (``order``, ``limit``, ``error`` or ``reason``).
    ``study["energy"]`` is the energy's. ``interrupted``: the signal that stopped the study.
    """

    problem: str
    folder: Path
    levels: list[dict[str, Any]] = field(default_factory=list)
    figures: dict[str, dict[str, Any]] = field(default_factory=dict)
    interrupted: int = 0

    def __getitem__(self, figure: str) -> dict[str, Any]:
        return self.figures[figure]

    def finished_levels(self) -> list[dict[str, Any]]:
        """The levels that ran to their end: all but an interrupted last one."""
        return self.levels[:-1] if self.interrupted else self.levels

    def as_dict(self) -> dict[str, Any]:
        """The study as converge.json holds it."""
        return {
            "problem": self.problem,
            "folder": str(self.folder),
            "ratio": 2,
            "interrupted": self.interrupted,
            "levels": self.levels,
            "figures": self.figures,
        }


def converge(
    problem: Problem,
    levels: int = 4,
    out: str | Path | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    force: bool = False,
    resume: bool = False,
    allow_large: bool = False,
) -> ConvergenceStudy:
    """Run ``problem`` on ``levels`` meshes refined by 2 and extrapolate its figures.

    Args:
        problem: a validated problem (:func:`dgplate.load_problem`); level 1 is its mesh.
        levels: the number of meshes (≥ 2; three give the orders and limits).
        out: the study's folder (default: ``out/<problem name>-converge``).
        comm: the ranks of the runs (collective).
        force: write into a folder of a user's files (deleting none of them).
        resume: reuse the finished levels in ``out`` and continue an interrupted one.
        allow_large: run levels larger than the job's memory (refused otherwise).

    Returns:
        The :class:`ConvergenceStudy`, also written to ``converge.json`` and ``converge.md``
        with the chart ``converge.png`` in ``out``.

    Raises:
        InputError: ``levels`` < 2, a problem with no mesh size to refine, a finest level
            too large for the memory, or an output folder that cannot be used.
    """
    folder = prepare.target(problem, out, default="out/{name}-converge")
    if not is_integer(levels) or levels < 2:
        raise InputError(f"--levels must be an integer ≥ 2, got {levels!r}")
    meshes = refinements(problem, levels)
    sizing.guard(meshes[-1][0], comm, allow_large)  # the finest level, before anything runs
    study = ConvergenceStudy(problem.name, folder)
    folders.claim(study.folder, force, comm)
    start: MeshStart | None = None
    for index, (level, size) in enumerate(meshes, 1):
        wall0 = time.perf_counter()
        result, reused = folders.run_or_reuse(
            level, study.folder / f"level-{index}", comm, force, resume,
            initial=start, allow_large=allow_large,
        )  # fmt: skip
        record = level_record(index, size, result.summary, reused)
        study.levels.append(record)
        print0(comm, progress_line(record, levels, time.perf_counter() - wall0))
        study.interrupted = int(result.summary.get("interrupted") or 0)
        if study.interrupted:
            break
        if warm_start(problem) and result.shape is not None:
            start = MeshStart(result.shape)
    study.figures = estimates(study.finished_levels())
    _write(study, comm)
    return study


def warm_start(problem: Problem) -> bool:
    """Whether a level starts from the coarser level's solution (see :data:`COLD_START`).

    A continuation in the clamped data (``model.schedule``) starts at its first α, which the
    coarser level's final shape does not match: it starts from the problem's start too. So
    does a path (``path.method = 'arclength'``), which starts at λ₀, and a flow that does not
    end at a discrete minimiser: one stopped by the rate test (the published method) or
    without projection ends at a state that depends on where it starts (its isometry defect
    grows with each step unless projected), so a warm-started level would not be the run
    that ``dgplate run`` makes at its size. A flow to a discrete minimiser (``stop =
    'stationarity'`` with ``projection_steps`` > 0, the default) ends at the same state
    from either start.
    """
    path = getattr(problem.model, "path", None)
    if problem.model.name in COLD_START or getattr(problem.model, "schedule", None) is not None:
        return False
    if path is not None and path.method == "arclength":
        return False  # a path starts at λ₀, which the coarser level's last point is not at
    flow = problem.flow
    return flow.stop == "stationarity" and flow.projection_steps > 0


def refinements(problem: Problem, levels: int) -> list[tuple[Problem, str]]:
    """The problem on each level, with its size in words: level 1 is ``problem`` itself."""
    if MODELS[problem.model.name].mesh is not None:  # a rod: its own mesh of model.cells
        cells = problem.model.cells
        return [
            (_with(problem, {"model.cells": cells * 2**k}), count_of(cells * 2**k, "cell"))
            for k in range(levels)
        ]
    if problem.mesh.type == "rectangle":
        nx, ny = problem.mesh.cells
        return [
            (_with(problem, {"mesh.cells": [nx * 2**k, ny * 2**k]}), f"{nx * 2**k}×{ny * 2**k}")
            for k in range(levels)
        ]
    params = _geo_sizes(problem)
    out = []
    for k in range(levels):
        scaled = {
            key: value * 2**k if key in COUNT_NAMES else value / 2**k
            for key, value in params.items()
        }
        words = ", ".join(f"{key} = {value:g}" for key, value in scaled.items())
        out.append((_with(problem, {"mesh.parameters": problem.mesh.parameters | scaled}), words))
    return out


def _with(problem: Problem, overrides: dict[str, Any]) -> Problem:
    return problem_from_dict(problem.raw, problem.name, overrides)


def _geo_sizes(problem: Problem) -> dict[str, float]:
    """The .geo file's size parameters and counts with their values (given, else defaults)."""
    path = resolve_geo(problem.mesh.file)
    values: dict[str, Any] = {**geo_parameters(path), **problem.mesh.parameters}
    sizes = {}
    for key, value in values.items():
        named = key in SIZE_NAMES + COUNT_NAMES or key.endswith("_h") or key.startswith("h_")
        number = _number(value)
        if named and number is not None and number > 0:
            sizes[key] = int(number) if key in COUNT_NAMES else number
    if not sizes:
        raise InputError(
            f"mesh.parameters: {path.name} has no size to refine (a parameter h, h_*, *_h, n or "
            "m with a number)"
        )
    return sizes


def _number(value: Any) -> float | None:
    """A parameter's value as a number: a number, or a default written as one; else None."""
    if is_number(value):
        return float(value)
    try:
        return float(str(value))
    except ValueError:  # an expression of other parameters (hole_h = h / 2): follows them
        return None


def figures_of(summary: dict[str, Any]) -> dict[str, float]:
    """The numeric scalars of a summary (one level down in its tables), and the extents."""
    found: dict[str, float] = {}
    for key, value in summary.items():
        if key in BOOKKEEPING or key == "input":
            continue
        inner = value if isinstance(value, dict) else {"": value}
        for name, number in inner.items():
            if isinstance(number, float):
                found[f"{key}.{name}" if name else key] = number
    box = summary.get("bbox")
    if box is not None:
        for axis, lo, hi in zip("xyz", box[0], box[1], strict=True):
            found[f"extent.{axis}"] = float(hi) - float(lo)
    return found


def level_record(index: int, size: str, summary: dict[str, Any], reused: bool) -> dict[str, Any]:
    """One level of the study: its size, cost, outcome and figures."""
    return {
        "level": index,
        "size": size,
        "cells": summary.get("cells"),
        "dofs": summary.get("dofs"),
        "steps": summary.get("steps"),
        "wall_time_s": summary.get("wall_time_s"),
        "reused": reused,
        "converged": bool(summary.get("converged")),
        "reason": summary.get("reason"),
        "energy": summary.get("energy"),
        "isometry_defect": summary.get("isometry_defect"),
        "bbox": summary.get("bbox"),
        "figures": figures_of(summary),
    }


def progress_line(record: dict[str, Any], levels: int, seconds: float) -> str:
    """``level 2/4: 32×32 cells, 30,720 dofs, 71 steps, E_h = 1.0e+00 (12 s)`` (on rank 0)."""
    dofs, cells = record["dofs"], record["cells"]
    if "×" in record["size"] or cells is None:
        parts = [record["size"] + (" cells" if cells is not None else "")]
    else:
        parts = [record["size"], f"{cells:,} cells"]
    if dofs is not None:
        parts.append(f"{dofs:,} dofs")
    parts.append("reused" if record["reused"] else count_of(record["steps"] or 0, "step"))
    if record["energy"] is not None:
        parts.append(f"E_h = {record['energy']:.8e}")
    if not record["converged"]:
        parts.append(f"not converged: {record['reason']}")
    return f"level {record['level']}/{levels}: {', '.join(parts)} ({seconds:.0f} s)"


def estimates(levels: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Each figure's values on the levels and its estimate (or why there is none)."""
    if not levels:
        return {}
    names = [name for name in levels[0]["figures"] if all(name in lv["figures"] for lv in levels)]
    caveat = _caveat(levels)
    found = {}
    for name in names:
        values = [lv["figures"][name] for lv in levels]
        estimate = extrapolate(values)
        if estimate.reason is None and caveat is not None:
            estimate = Estimate(reason=caveat)
        found[name] = {"values": values, **estimate.as_dict()}
    return found


def _caveat(levels: list[dict[str, Any]]) -> str | None:
    """Why no figure can be extrapolated: a level not converged, or E_h that jumps (JUMP)."""
    last = levels[-3:]
    failed = [lv["level"] for lv in last if not lv["converged"]]
    if failed:
        return f"level {failed[0]} did not converge"
    energies = [lv["energy"] for lv in last]
    if len(last) == 3 and all(isinstance(e, float) for e in energies):
        first, second = abs(energies[1] - energies[0]), abs(energies[2] - energies[1])
        if second > JUMP * first:
            n = last[-1]["level"]
            return (
                f"E_h jumps: it changes {second / first:.3g} times more from level {n - 1} to "
                f"{n} than from {n - 2} to {n - 1} (a different local minimiser?)"
            )
    return None


def _write(study: ConvergenceStudy, comm: MPI.Comm) -> None:
    """converge.json, converge.md and converge.png into the study's folder; the table printed."""
    text = table(study)
    write_json(comm, study.folder / "converge.json", study.as_dict())
    if comm.rank == 0:
        (study.folder / "converge.md").write_text(text + "\n")
        _chart(study)
    print0(comm, text)


def table(study: ConvergenceStudy) -> str:
    """The study as Markdown: a row per level, then a row per figure with its estimate."""
    rows = [
        "| level | size | cells | dofs | steps | wall (s) | E_h | D_h | converged |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for lv in study.levels:
        cells = [lv["level"], lv["size"], lv["cells"], lv["dofs"], lv["steps"]]
        cells += [lv["wall_time_s"], lv["energy"], lv["isometry_defect"]]
        rows.append("| " + " | ".join(map(_shown, cells)) + f" | {_converged(lv)} |")
    levels = " | ".join(f"level {lv['level']}" for lv in study.levels)
    rows += ["", f"| figure | {levels} | order p | f∞ | error |"]
    rows.append("|---" * (len(study.levels) + 4) + "|")
    for name, entry in study.figures.items():
        values = " | ".join(_shown(v) for v in entry["values"])
        if entry["reason"] is not None:
            rows.append(f"| {name} | {values} | – | – | {entry['reason']} |")
        else:
            estimate = [entry["order"], entry["limit"], entry["error"]]
            rows.append(f"| {name} | {values} | " + " | ".join(map(_shown, estimate)) + " |")
    return "\n".join(rows)


def _converged(level: dict[str, Any]) -> str:
    return ("yes" if level["converged"] else "no") + (" (reused)" if level["reused"] else "")


def _shown(value: Any) -> str:
    """A table cell: floats to 7 significant digits, counts with thousands separators."""
    if isinstance(value, float):
        return f"{value:.3f}" if abs(value) >= 1e3 else f"{value:.7g}"
    if is_integer(value):
        return f"{value:,}"
    return "–" if value is None else str(value)


def _chart(study: ConvergenceStudy) -> None:
    """converge.png: |f_level − f∞| against the DoFs, for the figures with a limit."""
    from dgplate.io.convergence_chart import plot_convergence

    dofs = [lv["dofs"] for lv in study.levels]
    if any(d is None for d in dofs):
        return
    lines = {
        name: [abs(v - entry["limit"]) for v in entry["values"]]
        for name, entry in study.figures.items()
        if entry["limit"] is not None
    }
    plot_convergence(dofs, lines, study.folder / "converge.png", f"{study.problem}: convergence")


def exit_code(study: ConvergenceStudy) -> int:
    """The command's exit code: 0, 1 (a level did not converge), 130/143 (interrupted)."""
    if study.interrupted:
        return interrupt.exit_code(study.interrupted)
    return 0 if all(lv["converged"] for lv in study.levels) else 1
