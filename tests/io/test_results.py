"""Runs read back from their output folders: ``dgplate show`` and ``dgplate.load_result``."""

import json
import math
import os
import shutil
from pathlib import Path

from mpi4py import MPI

import helpers
import numpy as np
import pytest

import dgplate
from dgplate.cli import main

ROOT = Path(__file__).resolve().parents[2]
VERTICAL = ROOT / "demos" / "problems" / "vertical_load.toml"
QUIET = {**helpers.QUIET, "mesh.cells": [4, 4]}


def _older_than_summary(folder: Path) -> None:
    """Date the checkpoint before the summary, as at the end of a run."""
    written = (folder / "summary.json").stat().st_mtime
    os.utime(folder / "checkpoint" / "state.npz", (written - 10, written - 10))


def _same(a, b) -> bool:
    """Equal values, NaN equal to NaN (history rows hold NaN for quantities not computed)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def test_load_result_gives_back_the_run(tmp_path):
    """The summary, every history row and the final state, exactly as `run` returned them."""
    ran = dgplate.run(dgplate.load_problem(VERTICAL, QUIET), out=tmp_path / "o")
    back = dgplate.load_result(tmp_path / "o")
    assert back.folder == ran.folder
    assert back["status"] == "converged" and back["steps"] == ran["steps"] > 1
    for key in ("energy", "isometry_defect", "dofs", "bbox", "reason"):
        assert back[key] == ran[key], key
    assert len(back.history) == len(ran.history) == ran["steps"]
    for row, original in zip(back.history, ran.history, strict=True):
        assert row.keys() == original.keys()
        assert all(_same(row[k], original[k]) for k in row), (row, original)
    assert back.shape is not None and np.array_equal(back.shape.x.array, ran.shape.x.array)
    assert set(back.fields) == set(ran.fields)
    files = dgplate.load_result(tmp_path / "o", state=False)
    assert files.shape is None and files["energy"] == ran["energy"]
    shown = repr(back)  # one line, not the whole summary and history
    assert shown.startswith(f"Result(vertical_load (kirchhoff), converged, steps={ran['steps']}")
    assert "\n" not in shown and len(shown) < 200


def test_show_one_run_and_a_table(tmp_path, capsys):
    """One folder in words, several as a table with one row each; nothing is written."""
    short = dgplate.load_problem(VERTICAL, {**QUIET, "flow.max_steps": 2})
    done = dgplate.run(dgplate.load_problem(VERTICAL, QUIET), out=tmp_path / "a")
    stopped = dgplate.run(short, out=tmp_path / "b")
    capsys.readouterr()
    before = sorted((p, p.stat().st_mtime_ns) for p in tmp_path.rglob("*"))
    assert main(["show", str(tmp_path / "a")]) == 0
    text = capsys.readouterr().out
    assert text.startswith(f"{tmp_path / 'a'}: vertical_load (kirchhoff), 16 cells, 480 dofs")
    assert f"converged after {done['steps']} steps" in text
    assert f"energy {done['energy']:.10g}" in " ".join(text.split())
    assert main(["show", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    header, first, second = capsys.readouterr().out.strip().splitlines()
    assert (
        header.split() == "folder problem model cells dofs ranks steps status E_h D_h wall".split()
    )
    assert f"{done['energy']:.6e}" in first and " converged " in first
    assert f"{stopped['energy']:.6e}" in second and "not converged" in second
    assert sorted((p, p.stat().st_mtime_ns) for p in tmp_path.rglob("*")) == before


def test_show_a_folder_of_runs_shows_each(tmp_path, capsys):
    """A demo's folder holds its runs in subfolders: `show` lists them."""
    from dgplate import demo

    args = demo.arguments("vertical_load", argv=["--out", str(tmp_path / "demo")])
    for name in ("b", "a"):
        demo.run(dgplate.load_problem(VERTICAL, QUIET), args, name)
    capsys.readouterr()
    assert main(["show", str(tmp_path / "demo")]) == 0
    rows = capsys.readouterr().out.strip().splitlines()[1:]
    assert [row.split()[0] for row in rows] == [str(tmp_path / "demo" / n) for n in ("a", "b")]
    # load_result wants one run, and says which the folder holds
    with pytest.raises(dgplate.InputError, match=r"demo holds several runs \(a, b\); load one"):
        dgplate.load_result(tmp_path / "demo", state=False)


def test_show_a_run_without_summary_reads_its_checkpoint(tmp_path, capsys):
    """A run still going (or killed) has a checkpoint but no summary.json yet."""
    ran = dgplate.run(dgplate.load_problem(VERTICAL, QUIET), out=tmp_path / "o")
    (tmp_path / "o" / "summary.json").unlink()
    (tmp_path / "o" / "history.csv").unlink()
    assert main(["show", str(tmp_path / "o")]) == 0
    text = capsys.readouterr().out
    assert f"checkpoint at step {ran['steps']}" in text
    assert "vertical_load (kirchhoff), 16 cells, 480 dofs on 1 rank(s)" in text  # its label
    partial = dgplate.load_result(tmp_path / "o", state=False)
    assert partial["status"] == "checkpoint only" and partial["energy"] == ran["energy"]
    assert len(partial.history) == ran["steps"]
    with pytest.raises(dgplate.InputError, match="has no summary for its last checkpoint"):
        dgplate.load_result(tmp_path / "o")


def test_show_refuses_a_folder_dgplate_did_not_write(tmp_path, capsys):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "summary.json").write_text(json.dumps({"energy": 1.0}))
    assert main(["show", str(mine)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{mine} is not a dgplate output folder" in err
    assert main(["show", str(tmp_path / "missing")]) == 2
    assert "no such output folder" in capsys.readouterr().err
    assert [p.name for p in mine.iterdir()] == ["summary.json"]


def test_load_result_refuses_a_changed_checkpoint(tmp_path):
    """A checkpoint of another problem than the summary's is named, not silently restored."""
    dgplate.run(dgplate.load_problem(VERTICAL, QUIET), out=tmp_path / "a")
    other = {**QUIET, "flow.tau": 0.5}
    dgplate.run(dgplate.load_problem(VERTICAL, other), out=tmp_path / "b")
    shutil.rmtree(tmp_path / "a" / "checkpoint")
    shutil.copytree(tmp_path / "b" / "checkpoint", tmp_path / "a" / "checkpoint")
    _older_than_summary(tmp_path / "a")
    with pytest.raises(dgplate.InputError, match=r"load_result: the checkpoint .* another problem"):
        dgplate.load_result(tmp_path / "a")


@pytest.mark.mpi
def test_load_result_on_other_ranks(tmp_path):
    """A run on one rank read back on every rank of the job: the same deformation."""
    import dolfinx.fem
    import ufl

    comm = MPI.COMM_WORLD
    out = Path(comm.bcast(str(tmp_path / "serial"), root=0))
    norm = None
    if comm.rank == 0:
        ran = dgplate.run(dgplate.load_problem(VERTICAL, QUIET), out=out, comm=MPI.COMM_SELF)
        y = ran.shape
        norm = dolfinx.fem.assemble_scalar(dolfinx.fem.form(ufl.inner(y, y) * ufl.dx))
    norm = comm.bcast(norm, root=0)
    back = dgplate.load_result(out, comm=comm)
    y = back.shape
    local = dolfinx.fem.assemble_scalar(dolfinx.fem.form(ufl.inner(y, y) * ufl.dx))
    assert comm.allreduce(local) == pytest.approx(norm, rel=1e-13)
    from dgplate.io.output import bounding_box

    assert bounding_box(y) == back["bbox"]
    assert main(["show", str(out)]) == 0  # rank 0 reads, every rank returns
    assert main(["show", str(out / "missing")]) == 2


def test_show_a_resumed_run_reads_its_newer_checkpoint(tmp_path, capsys):
    """A run resumed after its summary (and still going, or killed) is read from the
    checkpoint, which is newer; its final state is not paired with the old summary."""
    short = dgplate.load_problem(VERTICAL, {**QUIET, "flow.max_steps": 2})
    dgplate.run(short, out=tmp_path / "o")
    written = (tmp_path / "o" / "summary.json").stat().st_mtime
    os.utime(tmp_path / "o" / "checkpoint" / "state.npz", (written + 10, written + 10))
    capsys.readouterr()
    assert main(["show", str(tmp_path / "o")]) == 0
    assert "resumed after its summary.json (step 2)" in capsys.readouterr().out
    assert dgplate.load_result(tmp_path / "o", state=False)["status"] == "resumed"
    with pytest.raises(dgplate.InputError, match="has no summary for its last checkpoint"):
        dgplate.load_result(tmp_path / "o")


def test_show_a_table_of_mixed_folders(tmp_path, capsys):
    """Every folder is a row, the unreadable ones saying why: a finished run, a demo's own
    summary (no convergence flag), a run not yet checkpointed, a broken summary, a user's
    folder. One broken folder alone is bad input."""
    dgplate.run(dgplate.load_problem(VERTICAL, QUIET), out=tmp_path / "run")
    for name, text in (("study", '{"levy_max_error": 0.01}'), ("started", None), ("bad", "[1]")):
        (tmp_path / name).mkdir()
        (tmp_path / name / ".dgplate-output").write_text('{"files": []}')
        if text is not None:
            (tmp_path / name / "summary.json").write_text(text)
    (tmp_path / "mine").mkdir()
    names = ["run", "study", "started", "bad", "mine"]
    capsys.readouterr()
    assert main(["show", *(str(tmp_path / n) for n in names)]) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = dict(line.split(maxsplit=1) for line in lines[1:6])
    status = {Path(folder).name: row for folder, row in rows.items()}
    assert "converged" in status["run"] and "finished" in status["study"]
    assert "started" in status["started"]
    assert "unreadable [1]" in status["bad"] and "unreadable [2]" in status["mine"]
    assert lines[6] == f"[1] {tmp_path / 'bad' / 'summary.json'}: not a dgplate summary"
    assert lines[7].startswith(f"[2] {tmp_path / 'mine'} is not a dgplate output folder")
    assert len(lines) == 8
    assert main(["show", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a dgplate summary" in err
