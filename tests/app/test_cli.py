"""The command line: a good problem writes every output (bad input: tests/app/test_bad_input.py)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import PARITY_RTOL

import dgplate
from dgplate.cli import main
from dgplate.solvers.driver import Driver, EnergyFlow

ROOT = Path(__file__).resolve().parents[2]
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
    """... and ``output.progress = 0`` still prints how the run ended."""
    out = tmp_path / "out"
    quiet = ["--set", "flow.max_steps=2", "--set", "output.progress=0"]
    code = main(["run", str(VERTICAL), "--out", str(out), *SMALL, *quiet])
    assert code == 1
    printed = capsys.readouterr()
    assert "did not converge" in printed.err
    assert printed.out.splitlines()[1:] == [
        "NOT converged after 2 steps: step budget of 2 steps spent before "
        "(E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < 1e-06"
    ]
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
    assert report["calibration"] is None  # nothing for a run to calibrate first
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


def test_check_of_the_box_calibrates_nothing_and_run_calibrates_first(
    tmp_path, capsys, monkeypatch
):
    """`model.alpha = 'calibrate'` (the heat-driven box): `dgplate check` builds the driver
    without the calibration, a coupled solve, and says that the run will calibrate; `run`
    calibrates before it builds the driver (stopped there, it has written nothing)."""
    from dgplate.models.thermal.model import ThermalModel

    class Calibrated(Exception):
        pass

    calls: list[str] = []

    def calibrate(self, flow):
        calls.append(type(self).__name__)
        raise Calibrated

    monkeypatch.setattr(ThermalModel, "_calibrate", calibrate)
    box = ROOT / "demos" / "problems" / "box_folding.toml"
    small = {"mesh.parameters.n": 2, "mesh.parameters.m": 2}
    out = tmp_path / "box"
    sets = [f"--set={key}={value}" for key, value in small.items()]
    assert main(["check", str(box), "--out", str(out), *sets]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert "box_folding: valid: model thermal" in printed[0]
    assert printed[1:] == [
        "dgplate: model.alpha = 'calibrate': α on the hinges will be calibrated at run time "
        "(a strip like the first hinge, relaxed to fold by 90°)"
    ]
    assert calls == [] and not out.exists()
    problem = dgplate.load_problem(box, {**small, "output.progress": 0})
    with pytest.raises(Calibrated):
        dgplate.run(problem, out=out)
    assert calls == ["ThermalModel"] and not out.exists()


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


class _NoPath(Driver):
    """A driver with none of the optional capabilities: the protocol's defaults."""


class _PathDriver(Driver):
    """A driver on a path of known length: a fifth of it per step."""

    def __init__(self) -> None:
        self.fraction = 0.0

    def path_progress(self) -> tuple[float, str]:
        return self.fraction, "α = 1"


def _printed(every, driver, records, ticks, result=None):
    """The lines a ProgressPrinter prints for ``records`` at the clock's ``ticks``."""
    import io

    from mpi4py import MPI

    from dgplate.io.progress import ProgressPrinter

    clock = iter(ticks)
    stream = io.StringIO()
    printer = ProgressPrinter(MPI.COMM_SELF, every, stream, clock=lambda: next(clock), start=0.0)
    for record in records:
        if hasattr(driver, "fraction"):
            driver.fraction = 0.2 * record.step
        printer.step(driver, record)
    if result is not None:
        printer.finish(driver, result)
    return stream.getvalue().splitlines()


def _record(step, rate=float("nan")):
    from types import SimpleNamespace

    return SimpleNamespace(
        step=step, rate=rate, stationarity=float("nan"), line=lambda: f"line {step}"
    )


def test_progress_printer_estimates_the_time_left():
    """From the pace after the first step: 0.2 of the path per 10 s, so 0.4 left is 20 s;
    every line has the time since the run's start."""
    from dgplate.io.progress import duration

    records = [_record(step) for step in range(1, 6)]
    lines = _printed(1, _PathDriver(), records, [10.0, 20.0, 30.0, 40.0, 50.0])
    assert lines == [
        "line 1  (10 s)",
        "line 2  (20 s; α = 1 in ~30 s)",
        "line 3  (30 s; α = 1 in ~20 s)",
        "line 4  (40 s; α = 1 in ~10 s)",
        "line 5  (50 s)",
    ]
    assert [duration(s) for s in (4.24, 45, 720, 12600)] == ["4.2 s", "45 s", "12 min", "3.5 h"]


def test_progress_printer_estimates_from_the_decay_of_the_stopping_test():
    """A flow whose ΔE/τ falls tenfold a step, 1 s a step: from 1e-6 to below tol = 1e-9
    takes 3 more steps; the first step (compiling) is left out of the pace. When the step
    budget ends first, the line says so."""
    from types import SimpleNamespace

    records = [_record(step, 10.0 ** (-step)) for step in range(1, 8)]
    ticks = [10.0, 11.0, 12.0, 13.0, 14.0, 15.0, 16.0]
    flow = EnergyFlow()  # its stopping test: ΔE/τ < flow.tol within flow.max_steps
    flow.settings = SimpleNamespace(
        tol=1e-9, stop="rate", adaptive_tau=False, max_steps=100, checkpoint_every=0
    )
    lines = _printed(1, flow, records, ticks)
    assert lines[:5] == [f"line {n}  ({ticks[n - 1]:.0f} s)" for n in range(1, 6)]
    assert lines[5] == "line 6  (15 s; ΔE/τ < 1e-09 in ~3 steps, ~3.0 s)"
    assert lines[6] == "line 7  (16 s; ΔE/τ < 1e-09 in ~2 steps, ~2.0 s)"
    flow.settings.max_steps = 7  # one step left at step 6
    lines = _printed(1, flow, records[:6], ticks)
    assert lines[5] == "line 6  (15 s; step budget spent in ~1 steps, ~1.0 s)"


def test_a_path_that_spends_its_points_ends_as_a_path(tmp_path, capsys):
    """A path that spent ``path.steps`` inside its range of λ ended as asked (exit 0), and
    says so as a path, not as a converged flow; it names how to go on."""
    strip = Path(__file__).parents[2] / "demos" / "problems" / "turned_strip.toml"
    sets = ["mesh.cells=[8,1]", "path.steps=2", "output.png=false", "output.vtx=false"]
    out = tmp_path / "out"
    code = main(["run", str(strip), "--out", str(out), *(a for v in sets for a in ("--set", v))])
    assert code == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert last.startswith("path ended after 2 steps: path.steps = 2 points spent at load factor")
    assert "--resume --set path.steps=4 goes on" in last
    assert main(["show", str(out)]) == 0
    assert "path ended" in capsys.readouterr().out
    assert "path ended" in repr(dgplate.load_result(out, state=False))


def test_progress_printer_auto_prints_a_line_a_second_and_every_ten_steps():
    """``auto``: the first step, then a line when both 1 s and 10 steps have passed since
    the last (or 10 s), the last step's line and the final one. Steps of 0.05 s: every 20th
    step; steps of 1 s: every 10th; steps of 4 s: every 3rd."""
    from dgplate.io.progress import AUTO_STEPS
    from dgplate.solvers.driver import RunOutcome

    records = [_record(step) for step in range(1, 46)]
    done = RunOutcome(True, "tol reached", 45, records)
    fast = _printed("auto", _NoPath(), records, [0.05 * n for n in range(46)], done)
    assert [line.split("  ")[0] for line in fast] == [
        "line 1", "line 21", "line 41", "line 45", "converged after 45 steps: tol reached"
    ]  # fmt: skip
    slow = _printed("auto", _NoPath(), records, [float(n) for n in range(46)], done)
    assert [line.split("  ")[0] for line in slow][1:4] == ["line 11", "line 21", "line 31"]
    assert AUTO_STEPS == 10
    # steps of 4 s: a line at least every 10 s, not only every 10th step (40 s)
    slower = _printed("auto", _NoPath(), records, [4.0 * n for n in range(46)], done)
    assert [line.split("  ")[0] for line in slower][1:4] == ["line 4", "line 7", "line 10"]


def test_progress_printer_every_n_and_none_end_with_the_final_line():
    """``progress = 3``: steps 3, 6, 9 and the final line; ``progress = 0``: the final line
    alone. A thermal driver's counts are named as in summary.json."""
    from dgplate.solvers.driver import RunOutcome

    records = [_record(step) for step in range(1, 11)]
    done = RunOutcome(False, "step budget of 10 steps spent", 10, records)
    three = _printed(3, _NoPath(), records, [float(n) for n in range(11)], done)
    assert [line.split("  ")[0] for line in three] == [
        "line 3", "line 6", "line 9", "NOT converged after 10 steps: step budget of 10 steps spent"
    ]  # fmt: skip

    class Thermal(_NoPath):
        def step_counts(self):
            return {"heat_steps": 8, "holds": 2, "flow_steps": 428}

    none = _printed(0, Thermal(), records, [float(n) for n in range(11)], done)
    assert none == [
        "NOT converged after 10 steps [8 heat steps, 2 holds, 428 flow steps]: "
        "step budget of 10 steps spent"
    ]


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
    assert sections == ["[mesh]", "[model]", "[newton]", "[path]", "[output]"]
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


def test_a_closed_pipe_ends_only_the_printing(tmp_path):
    """`dgplate run … | head -1`: the reader goes after the first line; the run goes on,
    writes its whole output folder (no staging folder left) and exits 0, without PETSc's
    crash report."""
    out = tmp_path / "out"
    errors = tmp_path / "stderr"
    every_step = ["--set", "output.progress=1"]
    with open(errors, "w") as err:
        process = subprocess.Popen(
            [sys.executable, "-m", "dgplate", "run", str(VERTICAL), "--out", str(out), *SMALL,
             *every_step],
            stdout=subprocess.PIPE,
            stderr=err,
        )  # fmt: skip
        assert process.stdout.readline().startswith(b"dgplate: vertical_load:")
        process.stdout.close()  # the reader has gone: the step lines meet a closed pipe
        assert process.wait(timeout=600) == 0, errors.read_text()
    assert errors.read_text() == ""
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] and summary["steps"] > 1
    assert sorted(p.name for p in out.iterdir()) == [
        ".dgplate-output", "checkpoint", "history.csv", "summary.json"
    ]  # fmt: skip
