"""Path following of FvK plates (docs/path_following.md): bifurcations, folds, post-buckling.

Four studies over mesh levels, each against a closed form, and one of the turned strip's
thresholds beyond the shallow model:

- **Euler**: the perfect simply supported square plate of demos/fvk_buckling.py (t = 0.01,
  ν = 0.3, one unloaded edge held straight, the other free) shortened by λΔ_cr, n × n Q2 cells,
  followed on the flat branch: the first and second bifurcation against Δ/Δ_cr = 1 and 1.5625
  (Timoshenko & Gere §9.2, k = (m + 1/m)², m = 1, 2), their errors, the observed orders and the
  stability indices along the path.
- **Slope**: the buckled branch after the switch at the first bifurcation, λ = λ₀ + b (w_c/t)²
  + c (w_c/t)⁴ fitted by least squares (:func:`postbuckling_slope`); b against Koiter's slope
  for the plate with both unloaded edges held straight and immovable
  (:func:`dgplate.reference.fvk.held_square_plate_postbuckling`, λ = Δ/Δ_c), and measured
  for the plate of the Euler study (no closed form).
- **Arch**: the shallow sinusoidal strip on n × 2 cells followed round both folds onto the
  snapped arch: the folds against the exact limit loads λ = ±1
  (:func:`dgplate.reference.fvk.sinusoidal_strip_folds`), w_c at the first over a*, and every
  point against the exact equilibrium curve (:func:`dgplate.reference.fvk.sinusoidal_strip_load`).
- **Turned**: the buckled clamped–clamped strip of demos/problems/fvk_turned_strip.toml on
  n × 1 cells, its clamps turned by ±λα (``path.parameter = "clamp_slope"``): the bifurcation
  and the fold of its inverted state against the closed forms of
  :func:`dgplate.reference.fvk.clamped_strip_thresholds`; switched at that bifurcation, the
  antisymmetric branch round to the mirrored inverted state, its energy against the
  closed-form parabola of :func:`dgplate.reference.fvk.clamped_strip_antisymmetric_energy`;
  and the natural state, where the inverted one snaps to, its w_c against
  :func:`dgplate.reference.fvk.clamped_strip_natural_rise`.
- **Elastica** (no mesh): the turned strip's bifurcation and fold as an extensible elastica at
  finite Δ (:func:`dgplate.reference.turned_elastica.turned_strip_elastica_thresholds`) beside
  the shallow closed forms, for the Δ and t of ``ELASTICA_CASES``: the shallow model's O(Δ)
  error.

Orders are log₂ of the ratio of successive errors (the cells halve). Wall times are per run.

    python benchmarks/path_following.py [--json …] [--page docs/path_following.md]
    python benchmarks/path_following.py --studies arch elastica   # these, the others kept
    python benchmarks/path_following.py --table-only [--json …] [--page …]

The tables between ``<!-- path_following_<study>:begin -->`` and ``…:end -->`` of the page are
generated from the JSON (``--table-only``: no runs).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any, Literal

from mpi4py import MPI

import numpy as np
import numpy.typing as npt
from pages import add_page_options, write_between

from dgplate.io.output import print0
from dgplate.mesh.tagged import rectangle
from dgplate.models import starts
from dgplate.models.fvk.model import build_fvk
from dgplate.models.fvk.spec import FvKSpec, NewtonSpec, PathSpec
from dgplate.problems.specs import load_problem
from dgplate.reference.fvk import (
    clamped_strip_antisymmetric_energy,
    clamped_strip_natural_rise,
    clamped_strip_thresholds,
    held_square_plate_postbuckling,
    sinusoidal_strip_folds,
    sinusoidal_strip_load,
    square_plate_critical_shortening,
)
from dgplate.reference.turned_elastica import turned_strip_elastica_thresholds
from dgplate.solvers.continuation import BranchPath
from dgplate.solvers.driver import RunResult

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
E, NU, T = 1.0, 0.3, 0.01
DELTA_CR = square_plate_critical_shortening(T, 1.0, NU)
DELTA_HELD, SLOPE_HELD = held_square_plate_postbuckling(T, 1.0, NU)
Q_FOLD, A_FOLD = sinusoidal_strip_folds(E, T, 1.0, T)  # rise e = t
EULER = (1.0, 6.25 / 4)  # Δ/Δ_cr at the first two bifurcations, k = (m + 1/m)²/4, m = 1, 2
Initial = Callable[[npt.NDArray[np.float64]], npt.NDArray[np.float64]] | None


def plate_spec(switch: bool, steps: int, held: bool = False) -> FvKSpec:
    """The perfect simply supported square plate, its right edge moved by λΔ.

    Args:
        switch: leave the first bifurcation along the critical mode.
        steps: the points of the path.
        held: both unloaded edges held (v = 0) and Δ = Δ_c of that plate; if not, the plate of
            demos/fvk_buckling.py (the bottom edge held, the top one free) and Δ = Δ_cr.

    Returns:
        The model's spec, followed by arclength from the flat plate.
    """
    delta = DELTA_HELD if held else DELTA_CR
    top: Literal["normal", "free"] = "normal" if held else "free"
    return FvKSpec(
        E=E,
        nu=NU,
        thickness=T,
        simply_supported=["left", "right", "bottom", "top"],
        membrane={"left": [0.0, "free"], "right": [-delta, "free"], "bottom": "normal", "top": top},
        newton=NewtonSpec(stability=False),
        path=PathSpec(
            method="arclength", ds=0.3, ds_max=3.0, steps=steps, switch=switch, lambda_max=1.5
        ),
    )


def arch_spec(steps: int) -> FvKSpec:
    """The sinusoidal strip (rise t, ν = 0) pushed down by λ q*, from its unloaded arch."""
    return FvKSpec(
        E=E,
        nu=0.0,
        thickness=T,
        natural_shape=f"{T}*sin(pi*x)",
        pressure=f"-{Q_FOLD!r}*sin(pi*x)",
        simply_supported=["left", "right"],
        penalty_length="facet_normal",
        newton=NewtonSpec(stability=False),
        path=PathSpec(method="arclength", ds=0.2, ds_max=0.4, steps=steps, lambda_max=1.5),
    )


def arch_start(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Near the arch a₀ = √(2/3) t: Newton at λ = 0 converges to it."""
    return np.array([x[0], x[1], 0.8 * T * np.sin(np.pi * x[0])])


def attempt(
    comm: MPI.Comm, spec: FvKSpec, cells: Sequence[int], corners: Any, initial: Initial = None
) -> tuple[RunResult, list[dict[str, Any]], dict[str, Any]]:
    """The outcome of the path of ``spec`` on a rectangle, its points (dicts) and its summary."""
    tagged = rectangle(comm, corners, list(cells))
    model = build_fvk(spec, tagged)
    driver = model.driver(None, [], starts.resolve(spec, initial, tagged.mesh))
    assert isinstance(driver, BranchPath)  # a spec with path.method = "arclength"
    try:
        outcome = driver.run()
        assert driver.step_count == len(driver.history)
        return outcome, [asdict(r) for r in driver.history], driver.summary()
    finally:
        driver.destroy()


def follow(
    comm: MPI.Comm, spec: FvKSpec, cells: Sequence[int], corners: Any, initial: Initial = None
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The points and the summary of a path that must reach its end."""
    outcome, points, summary = attempt(comm, spec, cells, corners, initial)
    if not outcome.converged:
        raise RuntimeError(outcome.reason)
    return points, summary


def postbuckling_slope(points: list[dict[str, Any]], thickness: float) -> dict[str, float]:
    """The fit λ = λ₀ + b s + c s², s = (w_c/t)², over the points from the switch on.

    Args:
        points: the path's points, a ``switch`` among them.
        thickness: t.

    Returns:
        ``lambda0``, ``slope`` (b), ``quartic`` (c), and ``w_max``: the largest w_c/t fitted.
    """
    at = [p["kind"] for p in points].index("switch")
    w = np.array([p["w_center"] for p in points[at:]]) / thickness
    load = np.array([p["load_factor"] for p in points[at:]])
    basis = np.column_stack([np.ones_like(w), w**2, w**4])
    lambda0, slope, quartic = np.linalg.lstsq(basis, load, rcond=None)[0]
    return {
        "lambda0": float(lambda0),
        "slope": float(slope),
        "quartic": float(quartic),
        "w_max": float(np.abs(w).max()),
    }


def runs(indices: Sequence[int]) -> list[int]:
    """The stability indices along a path without repeats: [0, 0, 1, 1, 2] → [0, 1, 2]."""
    return [k for k, _ in itertools.groupby(indices)]


def euler_level(comm: MPI.Comm, n: int) -> dict[str, Any]:
    """The flat branch of the n × n plate: its bifurcations, errors and indices."""
    t0 = time.perf_counter()
    points, summary = follow(comm, plate_spec(False, 8), [n, n], [[0, 0], [1, 1]])
    wall = time.perf_counter() - t0
    found = summary["bifurcations"]
    return {
        "n": n,
        "dofs": summary["dofs"],
        "bifurcations": found,
        "errors": [f / exact - 1 for f, exact in zip(found, EULER, strict=False)],
        "indices": runs([p["stability_index"] for p in points]),
        "wall_s": wall,
    }


def slope_level(comm: MPI.Comm, n: int, held: bool) -> dict[str, Any]:
    """The buckled branch of the n × n plate after the switch: the fitted slope."""
    t0 = time.perf_counter()
    points, summary = follow(comm, plate_spec(True, 12, held), [n, n], [[0, 0], [1, 1]])
    wall = time.perf_counter() - t0
    at = [p["kind"] for p in points].index("switch")
    fit = postbuckling_slope(points, T)
    return {
        "n": n,
        "dofs": summary["dofs"],
        "bifurcation": summary["bifurcations"][0],
        **fit,
        "error": fit["slope"] / SLOPE_HELD - 1 if held else None,
        "buckled_indices": runs([p["stability_index"] for p in points[at:]]),
        "wall_s": wall,
    }


#: Points of the arch's path: round both folds and onto the snapped arch past λ = 1.
ARCH_STEPS = 40


def arch_path_error(points: list[dict[str, Any]]) -> float:
    """The largest |λ − λ(w_c)| over a path of the arch: λ(a) the exact equilibrium curve.

    Every equilibrium of the strip is w = a sin(πx) at λ(a) = q(a)/q*
    (:func:`dgplate.reference.fvk.sinusoidal_strip_load`), with a = w_c.

    Args:
        points: the path's points.

    Returns:
        The largest difference between a point's load factor and the exact one at its w_c.
    """
    exact = [sinusoidal_strip_load(p["w_center"], E, T, 1.0, T) / Q_FOLD for p in points]
    return max(abs(p["load_factor"] - lam) for p, lam in zip(points, exact, strict=True))


def arch_level(comm: MPI.Comm, n: int) -> dict[str, Any]:
    """The strip on n × 2 cells: round both folds onto the snapped arch.

    Args:
        comm: the communicator (collective).
        n: the cells along the strip.

    Returns:
        The folds, the first's error and w_c over a*, :func:`arch_path_error`, the last load
        factor, the stability indices along the path and the wall time.
    """
    t0 = time.perf_counter()
    points, summary = follow(comm, arch_spec(ARCH_STEPS), [n, 2], [[0, 0], [1, 0.1]], arch_start)
    wall = time.perf_counter() - t0
    fold, second = (p for p in points if p["kind"] == "fold")
    return {
        "n": n,
        "dofs": summary["dofs"],
        "fold": fold["load_factor"],
        "error": fold["load_factor"] - 1.0,
        "w_ratio": fold["w_center"] / A_FOLD,
        "second_fold": second["load_factor"],
        "path_error": arch_path_error(points),
        "last": points[-1]["load_factor"],
        "indices": runs(summary["stability_indices"]),
        "wall_s": wall,
    }


TURNED = ROOT / "demos" / "problems" / "fvk_turned_strip.toml"
#: The turned strip's end shortening, thickness, full clamp slope and width (its problem file's).
TURNED_DELTA, TURNED_T, TURNED_ALPHA, TURNED_WIDTH = 0.01, 0.005, 0.25, 0.05
#: Its bifurcation and fold in load factor: the closed forms over the full clamp slope.
TURNED_EXACT = tuple(a / TURNED_ALPHA for a in clamped_strip_thresholds(TURNED_DELTA, TURNED_T))


#: The natural state's start: buckled up, the way the clamps turn (the file's is down).
NATURAL_START = {"type": "formula", "g": ["x", "y", "0.0317*(1 - cos(2*pi*x))"]}


def turned_spec(steps: int = 16, switch: bool = False, natural: bool = False) -> FvKSpec:
    """The turned strip's [model] with its [path] (demos/problems/fvk_turned_strip.toml).

    ``natural``: from the natural state (buckled up) instead of the inverted one.
    """
    overrides: dict[str, Any] = {"path.steps": steps, "path.switch": switch}
    if natural:
        overrides["model.start"] = NATURAL_START
    spec = load_problem(TURNED, overrides).model
    assert isinstance(spec, FvKSpec)
    return spec


def turned_level(comm: MPI.Comm, n: int) -> dict[str, Any]:
    """The bifurcation and the fold of the turned strip on n × 1 cells."""
    t0 = time.perf_counter()
    points, summary = follow(comm, turned_spec(), [n, 1], [[0, 0], [1, 0.05]])  # model.start
    wall = time.perf_counter() - t0
    (bifurcation,) = (p for p in points if p["kind"] == "bifurcation")
    (fold,) = (p for p in points if p["kind"] == "fold")
    found = (bifurcation["load_factor"], fold["load_factor"])
    return {
        "n": n,
        "dofs": summary["dofs"],
        "bifurcation": found[0],
        "fold": found[1],
        "errors": [f / e - 1 for f, e in zip(found, TURNED_EXACT, strict=True)],
        "indices": runs(summary["stability_indices"]),
        "wall_s": wall,
    }


def switched_exact() -> tuple[float, float]:
    """(Π₀, k) of the antisymmetric branch's closed-form energy Π₀ + kλ² (α = λα₀)."""
    exact0 = clamped_strip_antisymmetric_energy(0.0, TURNED_DELTA, TURNED_T, width=TURNED_WIDTH)
    full = clamped_strip_antisymmetric_energy(
        TURNED_ALPHA, TURNED_DELTA, TURNED_T, width=TURNED_WIDTH
    )
    return exact0, full - exact0


def switched_branch(points: list[dict[str, Any]]) -> dict[str, Any]:
    """The antisymmetric branch after the switch, against its closed-form parabola in λ.

    Π = Π₀ + k λ² is fitted by least squares over the branch's regular points
    (:func:`dgplate.reference.fvk.clamped_strip_antisymmetric_energy` with α = λα₀).

    Args:
        points: the path's points, a ``switch`` among them.

    Returns:
        ``energy0`` and ``curvature`` (Π₀, k) with their ``errors`` against the closed form,
        ``fit`` (the largest residual over Π₀), ``lowest`` (the least λ of the branch) and
        ``indices`` (the stability indices along it, repeats merged).
    """
    at = [p["kind"] for p in points].index("switch")
    branch = [p for p in points[at:] if p["kind"] in ("switch", "regular")]
    load = np.array([p["load_factor"] for p in branch])
    energy = np.array([p["energy"] for p in branch])
    basis = np.column_stack([np.ones_like(load), load**2])
    energy0, curvature = np.linalg.lstsq(basis, energy, rcond=None)[0]
    exact0, exact_k = switched_exact()
    return {
        "energy0": float(energy0),
        "curvature": float(curvature),
        "errors": [float(energy0 / exact0 - 1), float(curvature / exact_k - 1)],
        "fit": float(np.abs(basis @ [energy0, curvature] - energy).max() / energy0),
        "lowest": float(load.min()),
        "indices": runs([p["stability_index"] for p in points[at:]]),
    }


def switched_level(comm: MPI.Comm, n: int) -> dict[str, Any]:
    """The turned strip on n × 1 cells switched at its bifurcation, round its branch.

    Args:
        comm: the communicator (collective).
        n: the cells along the strip.

    Returns:
        n, the located bifurcation, :func:`switched_branch`'s figures and the wall time.
    """
    t0 = time.perf_counter()
    points, summary = follow(comm, turned_spec(30, switch=True), [n, 1], [[0, 0], [1, 0.05]])
    return {
        "n": n,
        "bifurcation": summary["bifurcations"][0],
        **switched_branch(points),
        "wall_s": time.perf_counter() - t0,
    }


def natural_level(comm: MPI.Comm, n: int) -> dict[str, Any]:
    """The turned strip on n × 1 cells from its natural state: w_c against the closed form.

    The closed form (:func:`dgplate.reference.fvk.clamped_strip_natural_rise`) holds while the
    strip is compressed, α < √(6Δ); the points up to 95 % of that are compared.

    Args:
        comm: the communicator (collective).
        n: the cells along the strip.

    Returns:
        n, the largest relative ``error`` of w_c over the ``compared`` points, the ``last``
        load factor, the stability indices along the path and the wall time.
    """
    t0 = time.perf_counter()
    points, summary = follow(comm, turned_spec(7, natural=True), [n, 1], [[0, 0], [1, 0.05]])
    compressed = [
        p
        for p in points
        if 0 < p["load_factor"] * TURNED_ALPHA < 0.95 * math.sqrt(6 * TURNED_DELTA)
    ]
    errors = [
        p["w_center"]
        / clamped_strip_natural_rise(p["load_factor"] * TURNED_ALPHA, TURNED_DELTA, TURNED_T)
        - 1
        for p in compressed
    ]
    return {
        "n": n,
        "error": max(errors, key=abs),
        "compared": len(compressed),
        "last": points[-1]["load_factor"],
        "indices": runs(summary["stability_indices"]),
        "wall_s": time.perf_counter() - t0,
    }


def orders(errors: Sequence[float | None]) -> list[float | None]:
    """log₂ of successive error ratios (None at the first level or a missing error)."""
    out: list[float | None] = [None]
    for a, b in itertools.pairwise(errors):
        out.append(math.log2(abs(a) / abs(b)) if a and b else None)
    return out


def measure_turned(comm: MPI.Comm, levels: list[int]) -> dict[str, Any]:
    """The turned strip's study at its levels (collective): its part of the record."""
    turned = [turned_level(comm, n) for n in levels]
    switched = [switched_level(comm, n) for n in levels]
    natural = [natural_level(comm, n) for n in levels]
    for lv, order in zip(natural, orders([lv["error"] for lv in natural]), strict=True):
        lv["order"] = order
    for study in (turned, switched):
        for k in range(2):
            for lv, order in zip(study, orders([lv["errors"][k] for lv in study]), strict=True):
                lv.setdefault("orders", []).append(order)
    return {
        "turned_ranks": comm.size,
        "turned_exact": list(TURNED_EXACT),
        "turned_setting": {
            "delta": TURNED_DELTA,
            "thickness": TURNED_T,
            "alpha": TURNED_ALPHA,
            "width": TURNED_WIDTH,
        },
        "turned": turned,
        "switched_exact": list(switched_exact()),
        "switched": switched,
        "natural": natural,
    }


def measure(comm: MPI.Comm, levels: dict[str, list[int]]) -> dict[str, Any]:
    """All four studies at their levels (collective); the record of the JSON."""
    euler = [euler_level(comm, n) for n in levels["euler"]]
    for k in range(2):
        errors = [lv["errors"][k] if len(lv["errors"]) > k else None for lv in euler]
        for lv, order in zip(euler, orders(errors), strict=True):
            lv.setdefault("orders", []).append(order)
    held = [slope_level(comm, n, True) for n in levels["slope"]]
    for lv, order in zip(held, orders([lv["error"] for lv in held]), strict=True):
        lv["order"] = order
    return {
        "ranks": comm.size,
        "thickness": T,
        "nu": NU,
        "euler_exact": list(EULER),
        "slope_exact": SLOPE_HELD,
        "euler": euler,
        "slope_held": held,
        "slope_mixed": [slope_level(comm, n, False) for n in levels["slope"]],
        **measure_arch(comm, levels["arch"]),
        **measure_turned(comm, levels["turned"]),
        **measure_elastica(comm, levels["elastica"]),
    }


def measure_arch(comm: MPI.Comm, levels: list[int]) -> dict[str, Any]:
    """The arch's study at its levels: its part of the record.

    Args:
        comm: the communicator (collective).
        levels: the cells along the strip, one path each.

    Returns:
        ``arch_ranks`` and ``arch``: each level's :func:`arch_level` with its orders.
    """
    arch = [arch_level(comm, n) for n in levels]
    for key, name in (("error", "order"), ("path_error", "path_order")):
        for lv, order in zip(arch, orders([lv[key] for lv in arch]), strict=True):
            lv[name] = order
    return {"arch_ranks": comm.size, "arch": arch}


#: The shortenings Δ/L (t = 0) at which the turned strip's elastica is set against its shallow
#: thresholds, then the case of the problem file.
ELASTICA_CASES = [(1e-4, 0.0), (1e-3, 0.0), (1e-2, 0.0), (3e-2, 0.0), (1e-1, 0.0)]
#: Runge–Kutta steps on the half strip: the angles to about 3·10⁻⁹.
ELASTICA_STEPS = 200


def measure_elastica(comm: MPI.Comm, levels: Sequence[int] = (ELASTICA_STEPS,)) -> dict[str, Any]:
    """The turned strip's thresholds as an elastica at finite Δ, against the shallow ones.

    Args:
        comm: the communicator (unused: a reference computation, the same on every rank).
        levels: the Runge–Kutta steps on the half strip, one number (no mesh: the study's
            "level" is its integration's).

    Returns:
        ``elastica``: per case Δ, t, the shallow angles (α_b, α_f) and the elastica's.
    """
    (steps,) = levels
    rows = []
    for delta, t in [*ELASTICA_CASES, (TURNED_DELTA, TURNED_T)]:
        elastica = turned_strip_elastica_thresholds(delta, t, steps=steps)
        shallow = clamped_strip_thresholds(delta, t)
        rows.append({"delta": delta, "thickness": t, "shallow": list(shallow), **elastica})
    return {"elastica": rows}


#: The studies ``--studies`` reruns alone, the JSON's others kept.
STUDIES = {"arch": measure_arch, "turned": measure_turned, "elastica": measure_elastica}


def _order(order: float | None) -> str:
    """An observed order for a table cell ("" where there is none)."""
    return "" if order is None else f"{order:.2f}"


def _sequence(indices: Sequence[int]) -> str:
    """Stability indices as 0 → 1 → 2."""
    return " → ".join(map(str, indices))


def _bifurcation(level: dict[str, Any], k: int) -> str:
    """The k-th bifurcation's cells: λ, error, order (or beyond ``lambda_max``)."""
    if len(level["bifurcations"]) <= k:
        return "(beyond `lambda_max`) | | "
    order = _order(level["orders"][k])
    return f"{level['bifurcations'][k]:.5f} | {level['errors'][k]:+.2%} | {order}"


def markdown_table(caption: str, header: str, rows: list[str]) -> str:
    """A caption line, then a Markdown table of ``header`` (``| a | b |``) and ``rows``."""
    rule = "|" + "---|" * (header.count("|") - 1)
    return "\n".join([caption, "", header, rule, *rows])


def euler_table(record: dict[str, Any]) -> str:
    """The Markdown table of the Euler study."""
    rows = [
        f"| {lv['n']} × {lv['n']} | {lv['dofs']} | {_bifurcation(lv, 0)} | {_bifurcation(lv, 1)} "
        f"| {_sequence(lv['indices'])} | {lv['wall_s']:.1f} |"
        for lv in record["euler"]
    ]
    return markdown_table(
        (
            "Exact: Δ/Δ_cr = 1 and 1.5625; order: log₂ of successive error ratios; indices: the "
            "stability index along the path; wall: seconds for the path "
            f"({record['ranks']} rank(s), `benchmarks/path_following.py`, "
            "`benchmarks/results/path_following.json`)."
        ),
        (
            "| cells | dofs | 1st bifurcation λ | error | order | 2nd bifurcation λ | error "
            "| order | indices | wall s |"
        ),
        rows,
    )


def slope_table(record: dict[str, Any]) -> str:
    """The Markdown table of the post-buckling slopes, held and mixed unloaded edges."""
    rows = [
        f"| {h['n']} × {h['n']} | {h['dofs']} | {h['bifurcation']:.5f} | {h['lambda0']:.5f} "
        f"| {h['slope']:.5f} | {h['error']:+.2%} | {_order(h['order'])} "
        f"| {m['bifurcation']:.5f} | {m['lambda0']:.5f} | {m['slope']:.5f} "
        f"| {h['wall_s']:.1f} + {m['wall_s']:.1f} |"
        for h, m in zip(record["slope_held"], record["slope_mixed"], strict=True)
    ]
    fitted = max(lv["w_max"] for lv in record["slope_held"] + record["slope_mixed"])
    return markdown_table(
        (
            f"b: the coefficient of (w_c/t)² in λ = λ₀ + b (w_c/t)² + c (w_c/t)⁴ fitted by least "
            f"squares to the points of the buckled branch (w_c ≤ {fitted:.2f} t); λ_c: the "
            "located bifurcation the branch leaves; held edges: "
            f"Koiter's exact slope {record['slope_exact']:.5f} = (3/8)(3 − ν)(1 + ν), λ in units "
            "of that plate's Δ_c; mixed (the plate above): no closed form "
            f"({record['ranks']} rank(s), `benchmarks/path_following.py`, "
            "`benchmarks/results/path_following.json`)."
        ),
        (
            "| cells | dofs | held: λ_c | held: λ₀ | held: b | error | order | mixed: λ_c "
            "| mixed: λ₀ | mixed: b | wall s (held + mixed) |"
        ),
        rows,
    )


def arch_table(record: dict[str, Any]) -> str:
    """The Markdown table of the arch's folds and of its whole path."""
    rows = [
        f"| {lv['n']} | {lv['dofs']} | {lv['fold']:.6f} | {lv['error']:+.3%} "
        f"| {_order(lv['order'])} | {lv['w_ratio']:.4f} | {lv['second_fold']:.6f} "
        f"| {lv['path_error']:.1e} | {_order(lv['path_order'])} | {_sequence(lv['indices'])} "
        f"| {lv['wall_s']:.1f} |"
        for lv in record["arch"]
    ]
    return markdown_table(
        (
            "Exact: the folds at λ = ±1, w_c = ±a*; path: the largest |λ − λ(w_c)| over the "
            "path's points, λ(a) the exact equilibrium curve; order: log₂ of successive error "
            f"ratios; indices: along the path ({record.get('arch_ranks', record['ranks'])} rank(s), "
            "`benchmarks/path_following.py`, `benchmarks/results/path_following.json`)."
        ),
        (
            "| n | dofs | fold λ | error | order | w_c at the fold / a* | second fold λ | path "
            "| order | indices | wall s |"
        ),
        rows,
    )


def turned_table(record: dict[str, Any]) -> str:
    """The Markdown table of the turned strip's bifurcation and fold."""
    rows = [
        f"| {lv['n']} × 1 | {lv['dofs']} | {lv['bifurcation']:.6f} | {lv['errors'][0]:+.3%} "
        f"| {_order(lv['orders'][0])} | {lv['fold']:.6f} | {lv['errors'][1]:+.3%} "
        f"| {_order(lv['orders'][1])} | {_sequence(lv['indices'])} | {lv['wall_s']:.1f} |"
        for lv in record["turned"]
    ]
    bifurcation, fold = record["turned_exact"]
    return markdown_table(
        (
            f"Exact: λ = {bifurcation:.6f} (bifurcation) and {fold:.6f} (fold); order: log₂ of "
            "successive error ratios; indices: along the path "
            f"({record['turned_ranks']} rank(s), `benchmarks/path_following.py`, "
            "`benchmarks/results/path_following.json`)."
        ),
        (
            "| cells | dofs | bifurcation λ | error | order | fold λ | error | order | indices "
            "| wall s |"
        ),
        rows,
    )


def switched_table(record: dict[str, Any]) -> str:
    """The Markdown table of the turned strip's antisymmetric branch, after the switch."""
    rows = [
        f"| {lv['n']} × 1 | {lv['energy0']:.6e} | {lv['errors'][0]:+.3%} "
        f"| {_order(lv['orders'][0])} | {lv['curvature']:.6e} | {lv['errors'][1]:+.3%} "
        f"| {_order(lv['orders'][1])} | {lv['fit']:.1e} | {lv['lowest'] / lv['bifurcation']:.4f} "
        f"| {_sequence(lv['indices'])} | {lv['wall_s']:.1f} |"
        for lv in record["switched"]
    ]
    energy0, curvature = record["switched_exact"]
    return markdown_table(
        (
            f"Exact: Π₀ = {energy0:.6e}, k = {curvature:.6e}; fit: the largest residual of "
            "Π = Π₀ + kλ² over Π₀; least λ: the branch's least load factor over the "
            "bifurcation's; indices: on the branch "
            f"({record['turned_ranks']} rank(s), `benchmarks/path_following.py`, "
            "`benchmarks/results/path_following.json`)."
        ),
        (
            "| cells | Π₀ | error | order | k | error | order | fit | least λ / λ_b | indices "
            "| wall s |"
        ),
        rows,
    )


def natural_table(record: dict[str, Any]) -> str:
    """The Markdown table of the turned strip's natural state."""
    rows = [
        f"| {lv['n']} × 1 | {lv['compared']} | {lv['error']:+.2e} | {_order(lv['order'])} "
        f"| {lv['last']:.4f} | {_sequence(lv['indices'])} | {lv['wall_s']:.1f} |"
        for lv in record["natural"]
    ]
    return markdown_table(
        (
            "Error: the largest relative difference of w_c from the closed form over the path's "
            "points with α < 0.95 √(6Δ); last λ: where the path ends, past the bifurcation "
            f"λ_b = {record['turned_exact'][0]:.6f} of the inverted state; order: log₂ of "
            "successive error ratios; indices: along the path "
            f"({record['turned_ranks']} rank(s), `benchmarks/path_following.py`, "
            "`benchmarks/results/path_following.json`)."
        ),
        "| cells | points compared | error | order | last λ | indices | wall s |",
        rows,
    )


def elastica_table(record: dict[str, Any]) -> str:
    """The Markdown table of the turned strip's thresholds, shallow and as an elastica."""
    rows = []
    for row in record["elastica"]:
        root = math.sqrt(row["delta"])
        cells = [f"| {row['delta']:g} | {row['thickness']:g} "]
        for k, name in enumerate(("bifurcation", "fold")):
            shallow, angle = row["shallow"][k], row[name]
            cells.append(
                f"| {shallow / root:.5f} | {angle / root:.5f} | {angle / shallow - 1:+.3%} "
                f"| {math.tan(angle) / root:.5f} "
            )
        rows.append("".join(cells) + "|")
    finest = record["turned"][-1]
    case = record["elastica"][-1]
    fvk = [
        finest[name] * TURNED_ALPHA / math.sqrt(TURNED_DELTA) for name in ("bifurcation", "fold")
    ]
    return markdown_table(
        (
            "μ = α/√Δ: the clamp angle in units of √Δ (L = 1); shallow: the closed forms above; "
            "elastica: `dgplate.reference.turned_elastica.turned_strip_elastica_thresholds`; "
            "difference: of the elastica's angle from the shallow one; tan α: the elastica's "
            "clamp slope. The FvK path on "
            f"{finest['n']} × 1 cells (Δ = {case['delta']:g}, t = {case['thickness']:g}) gives "
            f"μ = {fvk[0]:.5f} and {fvk[1]:.5f} "
            "(`benchmarks/path_following.py`, `benchmarks/results/path_following.json`)."
        ),
        (
            "| Δ/L | t/L | shallow μ_b | elastica μ_b | difference | tan α_b/√Δ | shallow μ_f "
            "| elastica μ_f | difference | tan α_f/√Δ |"
        ),
        rows,
    )


TABLES = {
    "euler": euler_table,
    "slope": slope_table,
    "arch": arch_table,
    "turned": turned_table,
    "switched": switched_table,
    "natural": natural_table,
    "elastica": elastica_table,
}
LEVELS = {
    "euler": [4, 8, 16],
    "slope": [4, 8, 16, 32],
    "arch": [8, 16, 32, 64],
    "turned": [16, 32, 64, 128, 256],
    "elastica": [ELASTICA_STEPS],
}


def write_tables(record: dict[str, Any], page: Path) -> None:
    """Rewrite the page's generated tables from ``record``."""
    for name, table in TABLES.items():
        begin, end = f"<!-- path_following_{name}:begin -->", f"<!-- path_following_{name}:end -->"
        write_between(page, begin, end, f"{begin}\n{table(record)}\n{end}")


def main(argv: list[str]) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for name, default in LEVELS.items():
        what = "Runge–Kutta steps on the half strip" if name == "elastica" else "cells"
        parser.add_argument(f"--{name}", type=int, nargs="+", default=default, help=what)
    parser.add_argument(
        "--studies", nargs="+", choices=list(STUDIES), help="run these only; keep the JSON's others"
    )
    add_page_options(parser, RESULTS / "path_following.json", ROOT / "docs" / "path_following.md")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    if args.table_only:
        record = json.loads(args.json.read_text())
    elif args.studies:
        if not args.json.exists():
            parser.error(f"--studies keeps the other studies of {args.json}, which does not exist")
        record = json.loads(args.json.read_text())
        for study in args.studies:
            record.update(STUDIES[study](comm, getattr(args, study, [])))
        if comm.rank == 0:
            args.json.write_text(json.dumps(record, indent=2) + "\n")
    else:
        record = measure(comm, {name: getattr(args, name) for name in LEVELS})
        print0(comm, json.dumps(record))
        if comm.rank == 0:
            args.json.write_text(json.dumps(record, indent=2) + "\n")
    if comm.rank == 0:
        write_tables(record, args.page)
    return record


if __name__ == "__main__":
    main(sys.argv[1:])
