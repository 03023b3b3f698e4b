"""The size guard: the unknowns counted before anything is built are the run's, the memory
estimate reproduces the runs it was calibrated on, the memory limit is the least of those
that hold, and ``--allow-large`` (``allow_large=True``) runs what the guard refuses."""

import math
from pathlib import Path

import pytest

import dgplate
from dgplate.cli import main
from dgplate.errors import InputError
from dgplate.problems import sizing

PROBLEMS = Path(__file__).resolve().parents[2] / "demos" / "problems"
VERTICAL = PROBLEMS / "vertical_load.toml"
SMALL = {"mesh.cells": [2, 3], "output.png": False, "output.vtx": False}
C0 = {
    "model.space": "c0",
    "flow.adaptive_tau": True,
    "flow.step_control": "defect_bound",
    "flow.edge_constraint": True,
}


@pytest.mark.mpi
@pytest.mark.parametrize(
    ("name", "sets"),
    [
        ("vertical_load", SMALL),
        ("vertical_load", {**SMALL, "mesh.cell_type": "triangle", "mesh.diagonal": "crossed"}),
        ("vertical_load", {**SMALL, "flow.multiplier_degree": 1, "flow.edge_constraint": True}),
        ("vertical_load", {**SMALL, **C0, "flow.multiplier_degree": 1}),
        ("vertical_load", {**SMALL, **C0, "mesh.cell_type": "triangle"}),
        ("fvk_square", SMALL),
        ("fvk_square", {**SMALL, "mesh.cell_type": "triangle"}),
        ("rod_arc", {"model.cells": 7}),
        ("rod_closed", {"model.cells": 7}),
    ],
)
def test_unknowns_before_the_build_are_the_runs(name, sets, tmp_path, comm):
    """The count from the keys, from the built mesh (the header) and the driver's agree."""
    problem = dgplate.load_problem(PROBLEMS / f"{name}.toml", sets)
    report = dgplate.check(problem, out=comm.bcast(tmp_path / "out", root=0))
    size = sizing.estimate(problem, comm)
    assert size is not None
    assert (size.cells, size.dofs) == (report["cells"], report["dofs"])
    setting = f"{report['cells']:,} cells, {report['dofs']:,} dofs on {comm.size} rank(s)"
    assert setting in report["setting"]


@pytest.mark.parametrize(
    ("model", "cell_type", "cells", "dofs", "ranks", "measured_mb"),
    [
        ("kirchhoff", "quadrilateral", 1024, 30720, 1, 467),  # vertical load, Q2 32×32, a step
        ("kirchhoff", "quadrilateral", 4096, 122880, 1, 1160),  # on 64×64
        ("kirchhoff", "quadrilateral", 16384, 491520, 2, 5067),  # 128×128, docs/guide.md
        ("kirchhoff", "triangle", 2048, 43008, 1, 456),  # P2 on 2×32×32
        ("fvk", "quadrilateral", 1024, 17666, 1, 652),  # fvk_square on 32×32
        ("fvk", "quadrilateral", 2304, 39554, 1, 1132),  # on 48×48
        ("rod", "interval", 80000, 1120007, 1, 3647),  # rod of 80,000 cells, two steps
    ],
)
def test_memory_estimate_reproduces_its_calibration(
    model, cell_type, cells, dofs, ranks, measured_mb
):
    estimate = sizing.memory_mb(cell_type, cells, dofs, ranks, model)
    assert estimate == pytest.approx(measured_mb, rel=0.1)


@pytest.mark.mpi
def test_the_least_memory_limit_holds(monkeypatch, comm):
    """Physical memory, the cgroup's limit and ulimit -v (per rank): the least one counts."""
    monkeypatch.setattr(sizing, "_physical_mb", lambda: 16384.0)
    monkeypatch.setattr(sizing, "_cgroup_mb", lambda: 8192.0)
    node = comm.Split_type(sizing.MPI.COMM_TYPE_SHARED)
    nodes = comm.allreduce(1 if node.rank == 0 else 0)
    node.Free()
    assert sizing.available_mb(comm) == (8192.0 * nodes, "the cgroup memory limit")
    limit = 1024 * 2**20  # 1 GB per rank
    monkeypatch.setattr(sizing.resource, "getrlimit", lambda kind: (limit, limit))
    expected = (1024.0 * comm.size, "the process limit (ulimit -v)")
    assert sizing.available_mb(comm) == expected
    monkeypatch.setattr(sizing, "_cgroup_mb", lambda: None)
    monkeypatch.setattr(sizing.resource, "getrlimit", lambda kind: (-1, -1))
    assert sizing.available_mb(comm) == (16384.0 * nodes, "the machine's memory")


def test_the_cgroup_limit_is_read():
    """This process's cgroup limit, if any, is a positive number of MB."""
    limit = sizing._cgroup_mb()
    assert limit is None or (limit > 0 and math.isfinite(limit))


def test_allow_large_runs_what_the_guard_refuses(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(sizing, "available_mb", lambda comm: (100.0, "the cgroup memory limit"))
    args = ["check", str(VERTICAL), "--out", str(tmp_path / "o"), "--set", "mesh.cells=[2,2]"]
    assert main(args) == 2
    assert capsys.readouterr().err == (
        "dgplate: error: mesh.cells: 4 cells of degree 2 make 120 unknowns, which need about "
        "0.2 GB, more than the cgroup memory limit (0.1 GB on 1 rank(s)); use fewer cells, or "
        "--allow-large to insist\n"
    )
    assert main([*args, "--allow-large"]) == 0
    problem = dgplate.load_problem(VERTICAL, {"mesh.cells": [2, 2]})
    with pytest.raises(InputError, match=r"^mesh\.cells: 4 cells of degree 2"):
        dgplate.check(problem, out=tmp_path / "o")
    assert dgplate.check(problem, out=tmp_path / "o", allow_large=True)["dofs"] == 120
    assert not (tmp_path / "o").exists()


def test_allow_large_lifts_the_degree_limit():
    problem = dgplate.load_problem(VERTICAL, {"model.degree": sizing.MAX_DEGREE + 1})
    with pytest.raises(InputError, match=f"^model.degree = {sizing.MAX_DEGREE + 1} is above"):
        sizing.check_degree(problem.model, allow_large=False)
    sizing.check_degree(problem.model, allow_large=True)


#: A square whose bottom side alone is transfinite (600 nodes): its other curves coarsen.
MIXED_GEO = """DefineConstant[ h = {0.03, Name "Parameters/h"} ];
Point(1) = {0, 0, 0, h}; Point(2) = {1, 0, 0, h}; Point(3) = {1, 1, 0, h}; Point(4) = {0, 1, 0, h};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Transfinite Curve{1} = 600;
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Physical Surface("plate") = {1}; Physical Curve("bottom") = {1};
"""


@pytest.mark.parametrize(
    ("name", "h", "most"),
    # the hole's curves coarsen with the size factor (measured 22,347 for 21,220); the polar
    # disc's cells are transfinite surfaces, its own coarse mesh (exact; the estimate was
    # 3.6 million cells for 2528); the mixed square's free sides coarsen, its bottom does
    # not (measured 32,841 for 20,655): never below, the guard's safe side
    [("plate_with_hole", 0.05, 1.1), ("polar_disc", 0.05, 1.0), ("mixed", 0.03, 2.0)],
)
def test_geo_size_estimates_the_cells_that_load_geo_makes(name, h, most, tmp_path):
    from mpi4py import MPI

    from dgplate.mesh.tagged import geo_size, load_geo

    comm = MPI.COMM_WORLD
    if name == "mixed":
        name = tmp_path / "mixed.geo"
        name.write_text(MIXED_GEO)
    estimate = geo_size(comm, name, {"h": h}, None)
    mesh = load_geo(comm, name, {"h": h}).mesh
    cells = mesh.topology.index_map(2).size_global
    assert estimate is not None and cells <= estimate[0] <= most * cells
