"""The command line: a good problem writes every output (bad input: tests/test_bad_input.py)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import PARITY_RTOL

import dgplate
from dgplate.cli import main

ROOT = Path(__file__).resolve().parent.parent
VERTICAL = ROOT / "demos" / "problems" / "vertical_load.toml"

SMALL = ["--set", "mesh.cells=[4,4]", "--set", "output.png=false", "--set", "output.vtx=false"]


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
    for name in ("summary.json", "history.csv", "history.png", "final.png", "deformation.bp"):
        assert (out / name).exists(), name
    summary = json.loads((out / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(summary)
    assert summary["steps"] == 13 and summary["converged"]
    assert summary["energy"] == pytest.approx(-7.53e-3, rel=5e-3)
    (lo, hi) = summary["bbox"]
    assert lo[0] == pytest.approx(0.0, abs=1e-3) and hi[2] > 0.1  # clamped edge stays, corner lifts
    rows = (out / "history.csv").read_text().strip().splitlines()
    assert rows[0].startswith("step,time,tau,energy,defect") and len(rows) == 14


def test_check_validates_without_writing(tmp_path, capsys, monkeypatch):
    """`dgplate check` builds what `run` would and says what the run would be, writing
    nothing; `dgplate.check` returns it; a checkpoint is reported with its step."""
    out = tmp_path / "out"
    assert main(["check", str(VERTICAL), "--out", str(out), *SMALL]) == 0
    line = capsys.readouterr().out
    assert "vertical_load: valid: model kirchhoff, 16 cells, 480 dofs on 1 rank(s)" in line
    assert not out.exists()
    short = {"mesh.cells": [4, 4], "flow.max_steps": 2, "output.progress": 0}
    report = dgplate.check(dgplate.load_problem(VERTICAL, short), out=out)
    assert report["resume_step"] is None and report["warnings"] == [] and not out.exists()
    result = dgplate.run(dgplate.load_problem(VERTICAL, short), out=out)
    assert (report["dofs"], report["cells"]) == (result["dofs"], 16)
    assert f"vertical_load: {report['setting']}, output → {out}" in capsys.readouterr().out
    view = result._repr_html_()  # a notebook's view: the figures and final.png
    assert (
        result.folder == out.absolute()
        and f"<td style='text-align:left'>{result['energy']:.6g}<" in view
    )
    assert "<img src='data:image/png;base64," in view
    longer = dgplate.load_problem(VERTICAL, {**short, "flow.max_steps": 5})
    before = sorted((p.relative_to(out), p.stat().st_mtime_ns) for p in out.rglob("*"))
    assert dgplate.check(longer, out=out, resume=True)["resume_step"] == 2
    assert sorted((p.relative_to(out), p.stat().st_mtime_ns) for p in out.rglob("*")) == before
    monkeypatch.chdir(tmp_path)  # a relative folder is reported as run reports it: absolute
    assert dgplate.check(longer, out="rel")["output"] == str(tmp_path / "rel")
    assert not (tmp_path / "rel").exists()


def test_result_view_escapes_the_summary():
    view = dgplate.Result({"problem": "p", "reason": "E < tol & steps > 3"})._repr_html_()
    assert "E &lt; tol &amp; steps &gt; 3" in view and "<img" not in view


def test_check_refuses_what_run_refuses(tmp_path, capsys):
    """An obstacle that the clamped data penetrate, found when the model is built, and a
    user's folder: exit 2, one line, nothing written."""
    bad = ["--set", "model.obstacle={type='below', psi=-0.1, epsilon=1e-3}"]
    assert main(["check", str(VERTICAL), "--out", str(tmp_path / "o"), *SMALL, *bad]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "model.obstacle: the clamped data" in err, err
    assert not (tmp_path / "o").exists()
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("user data")
    assert main(["check", str(VERTICAL), "--out", str(tmp_path / "mine"), *SMALL]) == 2
    assert "did not write; choose another or pass --force" in capsys.readouterr().err
    assert [p.name for p in (tmp_path / "mine").iterdir()] == ["notes.txt"]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no /proc")
def test_check_refuses_a_folder_run_cannot_make(capsys):
    """/proc takes no folders, not even root's: check says so as run does, writing nothing."""
    line = "dgplate: error: --out /proc/x: /proc is on a file system that stores no folders"
    for verb in ("check", "run"):
        assert main([verb, str(VERTICAL), "--out", "/proc/x", *SMALL]) == 2
        assert capsys.readouterr().err == f"{line} (as /proc)\n"


def test_header_first_and_no_compile_notice_from_the_cache(tmp_path, capsys):
    """The header is the first line; a run whose forms are cached says nothing of compiling."""
    args = ["run", str(VERTICAL), *SMALL, "--set", "output.progress=0"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0  # compiles on a cold cache
    capsys.readouterr()
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("dgplate: vertical_load: model kirchhoff, 16 cells, 480 dofs on")
    assert not any("compiling" in line for line in lines), lines


@pytest.mark.mpi
def test_cli_in_parallel(tmp_path):
    """`mpirun -n 2 dgplate run …`: one output directory, and the energy and step count of a
    serial run of the same problem."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    out = Path(comm.bcast(str(tmp_path / "par"), root=0))
    checked = dgplate.check(dgplate.load_problem(VERTICAL, {"mesh.cells": [6, 6]}), out=out)
    assert main(["run", str(VERTICAL), "--out", str(out), "--set", "mesh.cells=[6,6]"]) == 0
    comm.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ranks"] == comm.size
    assert summary["bbox"][1][2] > 0.0
    problem = dgplate.load_problem(VERTICAL, {"mesh.cells": [6, 6], "output.progress": 0})
    serial = dgplate.run(problem, out=tmp_path / f"serial{comm.rank}", comm=MPI.COMM_SELF)
    assert summary["steps"] == serial["steps"]
    assert checked["dofs"] == summary["dofs"] == serial["dofs"] and checked["ranks"] == comm.size
    assert summary["energy"] == pytest.approx(serial["energy"], rel=PARITY_RTOL, abs=0)
    for name in ("history.csv", "final.png", "deformation.bp"):
        assert (out / name).exists()


class _PathDriver:
    """A driver on a path of known length: a fifth of it per step."""

    def __init__(self) -> None:
        self.fraction = 0.0

    def path_progress(self) -> tuple[float, str]:
        return self.fraction, "α = 1"


def test_progress_printer_estimates_the_time_left():
    """From the pace after the first step: 0.2 of the path per 10 s, so 0.4 left is 20 s."""
    import io
    from types import SimpleNamespace

    from mpi4py import MPI

    from dgplate.io.output import ProgressPrinter, duration

    ticks = iter([100.0, 110.0, 120.0, 130.0, 140.0])
    stream = io.StringIO()
    printer = ProgressPrinter(MPI.COMM_SELF, 1, stream, clock=lambda: next(ticks))
    driver = _PathDriver()
    for step in range(1, 6):
        driver.fraction = 0.2 * step
        printer.step(driver, SimpleNamespace(step=step, line=lambda: "line"))
    assert stream.getvalue().splitlines() == [
        "line",
        "line  (α = 1 in ~30 s)",
        "line  (α = 1 in ~20 s)",
        "line  (α = 1 in ~10 s)",
        "line",
    ]
    assert [duration(s) for s in (45, 720, 12600)] == ["45 s", "12 min", "3.5 h"]


def test_history_chart_draws_what_the_rows_hold(tmp_path):
    """One panel per quantity with finite values (NaN, bools and zeros on log scales left
    out); nothing to draw: no file."""
    from PIL import Image

    from dgplate.io.history_chart import plot_history

    rows = [
        {"step": n, "energy": 1.0 / n, "rate": 10.0**-n, "stationarity": float("nan"),
         "defect": 0.0 if n == 1 else 1e-3 * n, "alpha": min(1.0, 0.25 * n), "hold": False}
        for n in range(1, 6)
    ]  # fmt: skip
    assert plot_history(rows, tmp_path / "h.png", "title", tol=1e-4)
    width, height = Image.open(tmp_path / "h.png").size
    assert (width, height) == (640, 680)  # three panels: 100 dpi × (2.0 + 1.6 × 3) in
    only_energy = [{"step": n, "energy": float(n)} for n in range(1, 4)]
    assert plot_history(only_energy, tmp_path / "e.png")
    assert Image.open(tmp_path / "e.png").size[1] == 360  # one panel
    assert not plot_history([{"step": 1, "seconds": 0.1}], tmp_path / "none.png")
    assert not (tmp_path / "none.png").exists()


def test_version_and_schema(capsys):
    """--version; a model that ignores a whole section (FvK's [flow]) does not list it; an
    unknown model is one line with exit 2."""
    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"dgplate {dgplate.__version__}\n"
    assert main(["schema", "--model", "fvk"]) == 0
    sections = [line for line in capsys.readouterr().out.splitlines() if line.startswith("[")]
    assert sections == ["[mesh]", "[model]", "[output]"]
    assert main(["schema", "--model", "nosuch"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--model: unknown model 'nosuch'" in err


def test_output_into_a_closed_pipe_ends_quietly(tmp_path):
    """`dgplate show … | head`: the reader has gone; no traceback, exit 1."""
    run = tmp_path / "run"
    run.mkdir()
    (run / ".dgplate-output").write_text('{"files": []}')
    (run / "summary.json").write_text(json.dumps({"converged": True, "note": "x" * 200_000}))
    process = subprocess.Popen(
        [sys.executable, "-m", "dgplate", "show", str(run)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    process.stdout.close()  # before it writes: its output goes nowhere
    _, err = process.communicate(timeout=60)
    assert process.returncode == 1 and err == b"", err
