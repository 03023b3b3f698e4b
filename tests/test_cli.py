"""The command line: bad input is a one-line error with exit code 2 and nothing written;
a good problem writes every output."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from dgplate.cli import main

ROOT = Path(__file__).resolve().parent.parent
VERTICAL = ROOT / "demos" / "problems" / "vertical_load.toml"

SMALL = ["--set", "mesh.cells=[4,4]", "--set", "output.png=false", "--set", "output.vtx=false"]

BAD_INPUT = {
    "unknown key": (["--set", "flow.tua=0.1"], "unknown key flow.tua"),
    "wrong type": (["--set", "mesh.cells='many'"], "mesh.cells must be list"),
    "tau zero": (["--set", "flow.tau=0"], "flow.tau must be > 0"),
    "tau negative": (["--set", "flow.tau=-0.5"], "flow.tau must be > 0"),
    "tau word": (["--set", "flow.tau=big"], "flow.tau must be a number > 0 or 'h'"),
    "degree 1": (["--set", "model.degree=1"], "model.degree must be >= 2"),
    "missing mesh file": (
        ["--set", "mesh.type=gmsh", "--set", "mesh.file='nosuch.geo'"],
        "mesh file not found: nosuch.geo",
    ),
    "unknown group": (["--set", "model.clamped=['left','botom']"], "unknown facet group 'botom'"),
    "empty clamped set": (
        ["--set", "model.clamped=[]", "--set", "flow.l2_metric=false"],
        "model.clamped is empty but flow.l2_metric = false",
    ),
    "malformed set, no '='": (["--set", "flow.tau"], "malformed --set 'flow.tau'"),
    "malformed set, bad value": (["--set", "mesh.cells=[4,4"], "malformed --set"),
    "malformed set, bad key": (["--set", "tau=0.1"], "the key must be section.name"),
    "unknown section": (["--set", "solver.type=lu"], "unknown section [solver]"),
    "unknown model": (["--set", "model.name=kirchof"], "model.name must be one of"),
    "bad formula": (["--set", "model.load=[0,0,'__import__(\"os\")']"], "model.load[2]"),
    "penalty not positive": (
        ["--set", "model.penalty={gamma0=-1.0, gamma1=1.0}"],
        "model.penalty.gamma0 must be",
    ),
    "gradient power out of range": (
        ["--set", "model.penalty={gamma0=5000.0, gamma1=1100.0, gradient_power=5}"],
        "model.penalty.gradient_power must be in [1, 3]",
    ),
    "crease on boundary": (["--set", "model.crease=['top']"], "crease group 'top' contains"),
    "mu not positive": (["--set", "model.mu=0"], "model.mu must be > 0"),
    "unknown mu region": (["--set", "model.mu={hinge=1.0}"], "unknown cell group 'hinge'"),
    "unknown step solver": (["--set", "flow.linear_solver='cg'"], "flow.linear_solver must be"),
    "refactor_its zero": (["--set", "flow.refactor_its=0"], "flow.refactor_its must be"),
}


@pytest.mark.parametrize("case", list(BAD_INPUT))
def test_bad_input_is_one_clear_line(case, tmp_path, capsys):
    extra, expected = BAD_INPUT[case]
    out = tmp_path / "out"
    code = main(["run", str(VERTICAL), "--out", str(out), *SMALL, *extra])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("dgplate: error: ") and err.count("\n") == 1, err
    assert expected in err, err
    assert not out.exists()
    assert list(tmp_path.iterdir()) == [], "nothing may be written for bad input"


def test_missing_problem_file_and_bad_toml(tmp_path, capsys):
    assert main(["run", str(tmp_path / "none.toml")]) == 2
    assert "problem file not found" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text("[mesh\ncells = 3")
    assert main(["run", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "invalid TOML" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_existing_output_left_untouched_on_bad_input(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("previous results")
    assert main(["run", str(VERTICAL), "--out", str(out), "--set", "flow.tau=0"]) == 2
    assert (out / "keep.txt").read_text() == "previous results"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_not_converged_exits_1_and_keeps_outputs(tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["run", str(VERTICAL), "--out", str(out), *SMALL, "--set", "flow.max_steps=2"])
    assert code == 1
    assert "did not converge" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is False and summary["steps"] == 2
    assert "step budget" in summary["reason"]


SUMMARY_KEYS = {
    "model",
    "dofs",
    "ranks",
    "steps",
    "converged",
    "energy",
    "isometry_defect",
    "bbox",
    "wall_time_s",
    "dolfinx_version",
}


def test_cli_end_to_end(tmp_path):
    """`python -m dgplate run demos/problems/vertical_load.toml --out DIR` writes every output."""
    out = tmp_path / "x"
    proc = subprocess.run(
        [sys.executable, "-m", "dgplate", "run", str(VERTICAL), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    assert "step    13" in proc.stdout and "converged" in proc.stdout
    for name in ("summary.json", "history.csv", "final.png", "deformation.bp"):
        assert (out / name).exists(), name
    summary = json.loads((out / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(summary)
    assert summary["steps"] == 13 and summary["converged"]
    assert summary["energy"] == pytest.approx(-7.53e-3, rel=5e-3)
    (lo, hi) = summary["bbox"]
    assert lo[0] == pytest.approx(0.0, abs=1e-3) and hi[2] > 0.1  # clamped edge stays, corner lifts
    rows = (out / "history.csv").read_text().strip().splitlines()
    assert rows[0].startswith("step,time,tau,energy,defect") and len(rows) == 14


@pytest.mark.mpi
def test_cli_in_parallel(tmp_path):
    """`mpirun -n 2 dgplate run …`: one output directory, the same summary on every rank."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    out = Path(comm.bcast(str(tmp_path / "par"), root=0))
    assert main(["run", str(VERTICAL), "--out", str(out), "--set", "mesh.cells=[6,6]"]) == 0
    comm.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ranks"] == comm.size
    assert summary["bbox"][1][2] > 0.0
    for name in ("history.csv", "final.png", "deformation.bp"):
        assert (out / name).exists()
