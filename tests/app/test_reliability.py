"""Runs that never lose data, never hang and can be resumed.

Output folders: a user's folder is refused (its files survive), a file is refused, an earlier
dgplate output is replaced, ``--force`` adds to a user's folder and deletes nothing. Interrupts:
SIGTERM stops at a step boundary with the outputs, a checkpoint and exit 143, serially and
under mpirun. Checkpoints: a run killed with SIGKILL halfway resumes with ``--resume`` to the
uninterrupted run's final state, on the same and on another number of ranks.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import mpirun as _mpirun
from helpers import summary_of
from petsc4py import PETSc

from dgplate import load_problem as dgplate_problem
from dgplate.cli import main
from dgplate.problems.results import load_result

ROOT = Path(__file__).resolve().parents[2]
VERTICAL = ROOT / "demos" / "problems" / "vertical_load.toml"
ROD = ROOT / "demos" / "problems" / "rod_arc.toml"
SMALL = ["--set", "mesh.cells=[4,4]", "--set", "output.png=false", "--set", "output.vtx=false"]
# 8×8 BNN plate with τ = 0.1: 37 steps with direct solves (enough to kill it halfway)
RESUMABLE = [
    "--set",
    "mesh.cells=[8,8]",
    "--set",
    "flow.tau=0.1",
    "--set",
    "output.png=false",
    "--set",
    "flow.checkpoint_every=5",
    "--set",
    "output.progress=0",
]


#: Open MPI's launcher (Debian's route) ends the job itself on SIGTERM instead of leaving the
#: ranks to stop (MPICH's forwards the signal; Slurm's srun signals the ranks directly).
OPEN_MPI = MPI.Get_library_version().startswith("Open MPI")
#: The 2-rank case of a test that launches ``mpirun`` itself (see :mod:`conftest`).
TWO_RANKS = pytest.param(2, marks=pytest.mark.spawns_mpirun, id="2")


def dgplate(*args: str, ranks: int = 1, timeout: float = 300) -> subprocess.CompletedProcess:
    """``dgplate`` in a subprocess (under ``mpirun -n ranks`` when ranks > 1)."""
    command = [sys.executable, "-m", "dgplate", *args]
    if ranks > 1:
        launcher = _mpirun()
        assert launcher is not None, "no mpirun"
        command = [launcher, "-n", str(ranks), sys.executable, "-m", "mpi4py", "-m", "dgplate"]
        command += list(args)
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout)


# -- output folders -------------------------------------------------------------------------
def test_users_folder_is_refused_and_survives(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("precious")
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "dgplate did not write" in err and "--force" in err, err
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    assert (out / "notes.txt").read_text() == "precious"


@pytest.mark.parametrize("where", ["file", "below a file"])
def test_out_as_a_file_is_refused(where, tmp_path, capsys):
    blocker = tmp_path / "results"
    blocker.write_text("keep")
    out = blocker if where == "file" else blocker / "sub"
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL]) == 2
    err = capsys.readouterr().err
    assert err.startswith("dgplate: error: --out") and "is a file" in err, err
    assert blocker.read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]


def test_out_that_cannot_be_made_is_one_line(tmp_path, capsys):
    """A link to nowhere, or a user's file named checkpoint (with --force): exit 2 before
    anything is written, no traceback."""
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "nowhere")
    assert main(["run", str(VERTICAL), "--out", str(link), *SMALL]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "which does not exist" in err, err
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "checkpoint").write_text("my notes")
    assert main(["run", str(VERTICAL), "--out", str(mine), "--force", *SMALL]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "keeps its checkpoints in that name" in err, err
    assert [p.name for p in mine.iterdir()] == ["checkpoint"]
    assert (mine / "checkpoint").read_text() == "my notes"


def test_force_adds_to_a_users_folder_and_deletes_nothing(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("precious")
    assert main(["run", str(VERTICAL), "--out", str(out), "--force", *SMALL]) == 0
    assert (out / "notes.txt").read_text() == "precious"
    assert summary_of(out)["converged"]
    # the folder is now dgplate's: a second run replaces its own files, not the user's
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL]) == 0
    assert (out / "notes.txt").read_text() == "precious"


def test_earlier_output_is_replaced(tmp_path):
    out = tmp_path / "run"
    first = ["--set", "mesh.cells=[4,4]", "--set", "output.png=false"]
    assert main(["run", str(VERTICAL), "--out", str(out), *first]) == 0
    assert (out / "deformation.bp").is_dir()
    (out / "my_plot.py").write_text("# a user's script beside the results")
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL]) == 0
    names = sorted(p.name for p in out.iterdir())
    # deformation.bp was dgplate's and this run wrote none: gone; the user's script stays
    assert names == [".dgplate-output", "checkpoint", "history.csv", "my_plot.py", "summary.json"]


def test_resume_needs_a_checkpoint_of_the_same_problem(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", str(VERTICAL), "--out", str(out), "--resume", *SMALL]) == 2
    assert "is not a dgplate output directory" in capsys.readouterr().err
    assert not out.exists()
    budget = ["--set", "flow.max_steps=2", "--set", "flow.checkpoint_every=1"]
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL, *budget]) == 1
    capsys.readouterr()
    other = ["--set", "model.load=[0,0,0.05]"]
    assert main(["run", str(VERTICAL), "--out", str(out), "--resume", *SMALL, *other]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "belongs to another problem" in err, err
    assert "model.load (checkpoint: [0.0, 0.0, 0.025], now: [0, 0, 0.05])" in err, err
    assert main(["run", str(VERTICAL), "--out", str(out), "--resume", *SMALL, *budget]) == 2
    assert "raise flow.max_steps" in capsys.readouterr().err
    # the driver was built before the budget was found spent: its solver options are gone,
    # else PETSc would list them as unused at exit, below the one-line error
    assert not [key for key in PETSc.Options().getAll() if key.startswith("dgplate_")]


def test_force_keeps_a_users_files_that_outputs_would_replace(tmp_path, capsys):
    """A user's final.png, summary.json and frames/ where dgplate writes its own: renamed
    ``<name>.kept-1`` with a warning, never deleted."""
    out = tmp_path / "mine"
    (out / "frames").mkdir(parents=True)
    (out / "frames" / "holiday.png").write_text("a picture")
    (out / "final.png").write_text("my figure")
    (out / "summary.json").write_text('{"mine": 1}')
    frames = ["--set", "output.frames_every=2", "--set", "output.png=true"]
    assert main(["run", str(VERTICAL), "--out", str(out), "--force", *SMALL, *frames]) == 0
    assert "kept as final.png.kept-1" in capsys.readouterr().err
    assert (out / "frames.kept-1" / "holiday.png").read_text() == "a picture"
    assert (out / "final.png.kept-1").read_text() == "my figure"
    assert (out / "summary.json.kept-1").read_text() == '{"mine": 1}'
    assert summary_of(out)["converged"] and (out / "frames" / "frame_000000.png").is_file()


def test_a_users_folder_in_place_of_an_output_file_survives(tmp_path):
    """history.csv replaced by a user's folder of that name; frames/ by a user's file: both
    kept aside, not deleted. A marker of an older dgplate (no 'inside') still works."""
    out = tmp_path / "run"
    frames = ["--set", "output.frames_every=2", "--set", "output.png=true"]
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL, *frames]) == 0
    (out / "history.csv").unlink()
    (out / "history.csv").mkdir()
    (out / "history.csv" / "analysis.ipynb").write_text("{}")
    shutil.rmtree(out / "frames")
    (out / "frames").write_text("my list of frames")
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL, *frames]) == 0
    assert (out / "history.csv.kept-1" / "analysis.ipynb").read_text() == "{}"
    assert (out / "frames.kept-1").read_text() == "my list of frames"
    assert (out / "history.csv").is_file() and (out / "frames").is_dir()
    marker = out / ".dgplate-output"
    old = json.loads(marker.read_text())
    marker.write_text(json.dumps({"files": old["files"]}))  # as an older dgplate wrote it
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL]) == 0
    assert not (out / "frames").exists() and (out / "history.csv.kept-1").is_dir()


def test_a_users_file_in_an_output_folder_of_dgplate_survives(tmp_path):
    """A file put into dgplate's frames/ keeps the folder: not replaced, not removed. One put
    into checkpoint/ (written in place) stays where it is."""
    out = tmp_path / "run"
    frames = ["--set", "output.frames_every=2", "--set", "output.png=true"]
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL, *frames]) == 0
    (out / "frames" / "sketch.txt").write_text("notes")
    (out / "checkpoint" / "log.txt").write_text("mine")
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL]) == 0  # no frames now
    assert (out / "frames" / "sketch.txt").read_text() == "notes"
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL, *frames]) == 0
    assert (out / "frames.kept-1" / "sketch.txt").read_text() == "notes"
    assert (out / "frames" / "frame_000000.png").is_file()
    # frames/ written by this run holds only dgplate's files: the next run replaces it
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL, *frames]) == 0
    assert not (out / "frames.kept-2").exists()
    assert (out / "checkpoint" / "log.txt").read_text() == "mine"
    assert (out / "checkpoint" / "state.npz").is_file()


def test_a_resumed_run_reports_totals_over_all_its_runs(tmp_path, capsys):
    """After --resume, summary.json counts factorisations, steps and wall time over the whole
    run (the resumed part apart), and the step budget is the flow.max_steps that was set.

    The total may lie below the first run's own wall time (measured 0.276 s against
    0.369 s): the first run's outputs, written after its last checkpoint, are not part of it."""
    out, never = tmp_path / "run", ["--set", "flow.tol=1e-30", "--set", "flow.checkpoint_every=1"]
    assert (
        main(["run", str(VERTICAL), "--out", str(out), *SMALL, *never, "--set", "flow.max_steps=3"])
        == 1
    )
    first = summary_of(out)
    more = ["--set", "flow.max_steps=6", "--resume"]
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL, *never, *more]) == 1
    assert "step budget of 6 steps spent" in capsys.readouterr().err
    whole = summary_of(out)
    assert whole["steps"] == 6 and whole["reason"].startswith("step budget of 6 steps spent")
    assert whole["factorisations"] >= first["factorisations"] + 1  # the resumed run's own
    assert whole["step_solves"] > first["step_solves"]
    # the total: the first run's time up to its last checkpoint, and the resumed run's
    earlier = whole["wall_time_s"] - whole["wall_time_since_resume_s"]
    assert 0 < earlier <= first["wall_time_s"]
    assert 0 < whole["wall_time_since_resume_s"] < whole["wall_time_s"]


def test_a_later_run_stopped_before_its_outputs_is_finished_by_resume(tmp_path):
    """Run A converged and wrote its outputs; run B (another load) converged and was stopped
    before writing them: A's summary is older than B's checkpoint, so --resume writes B's."""
    out = tmp_path / "run"
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL]) == 0
    other = ["--set", "model.load=[0,0,0.05]"]
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL, *other]) == 0
    b = summary_of(out)
    # as if A's summary were still there, older than B's checkpoint: B stopped before writing
    (out / "summary.json").write_text(json.dumps({"converged": True, "steps": 1}))
    os.utime(out / "summary.json", (1e9, 1e9))
    assert main(["run", str(VERTICAL), "--out", str(out), *SMALL, *other, "--resume"]) == 0
    assert summary_of(out)["energy"] == b["energy"] and summary_of(out)["steps"] == b["steps"]


def test_a_checkpoint_of_an_older_dgplate_resumes(tmp_path):
    """Checkpoints written before the mesh file's hash was part of the fingerprint (and
    without the problem's input in their state) still resume on a gmsh mesh."""
    from dgplate.io import checkpoint

    problem, out = _on_gmsh_mesh(tmp_path), tmp_path / "run"
    budget = ["--set", "flow.max_steps=2", "--set", "flow.checkpoint_every=1"]
    assert main(["run", str(problem), "--out", str(out), *SMALL[2:], *budget]) == 1
    file = out / "checkpoint" / "state.npz"
    with np.load(file) as npz:
        arrays = dict(npz)
    state = json.loads(bytes(arrays["__state__"]).decode())
    loaded = dgplate_problem(problem)
    older = {k: v for k, v in loaded.identity().items() if k != checkpoint.MESH_FILE_HASH}
    state["fingerprint"] = checkpoint.fingerprint(older)
    del state["input"]
    arrays["__state__"] = np.frombuffer(json.dumps(state).encode(), dtype=np.uint8)
    np.savez(file, **arrays)
    more = ["--set", "flow.max_steps=4", "--resume"]
    assert main(["run", str(problem), "--out", str(out), *SMALL[2:], *budget[2:], *more]) == 1
    assert summary_of(out)["steps"] == 4


def test_resume_refuses_a_checkpoint_of_an_edited_mesh_file(tmp_path, capsys):
    """The fingerprint covers the .geo file's text: a checkpoint of the old mesh is not
    loaded onto the new one."""
    geo = tmp_path / "square.geo"
    geo.write_text((ROOT / "meshes" / "rectangle.geo").read_text())
    problem, out = _on_gmsh_mesh(tmp_path, str(geo)), tmp_path / "run"
    budget = ["--set", "flow.max_steps=2", "--set", "flow.checkpoint_every=1"]
    assert main(["run", str(problem), "--out", str(out), *SMALL[2:], *budget]) == 1
    geo.write_text(geo.read_text().replace("Lx = {4.0", "Lx = {2.0"))
    more = ["--set", "flow.max_steps=4", "--resume"]
    capsys.readouterr()
    assert main(["run", str(problem), "--out", str(out), *SMALL[2:], *budget[2:], *more]) == 2
    assert "belongs to another problem" in capsys.readouterr().err


@pytest.mark.spawns_mpirun
@pytest.mark.skipif(_mpirun() is None, reason="no mpirun")
@pytest.mark.parametrize("where", ["file", "users folder"])
def test_output_refusals_do_not_hang_under_mpirun(where, tmp_path):
    out = tmp_path / "out"
    if where == "file":
        out.write_text("keep")
    else:
        out.mkdir()
        (out / "keep").write_text("keep")
    done = dgplate("run", str(VERTICAL), "--out", str(out), *SMALL, ranks=2, timeout=60)
    assert done.returncode == 2, done.stderr
    assert sum("dgplate" in line for line in done.stderr.splitlines()) == 1, done.stderr
    assert "Traceback" not in done.stderr
    assert (out if where == "file" else out / "keep").read_text() == "keep"


# -- interrupts -----------------------------------------------------------------------------
def _on_gmsh_mesh(folder: Path, geo: str = "rectangle.geo") -> Path:
    """The vertical-load problem on an unstructured gmsh mesh of the same square."""
    text = VERTICAL.read_text()
    mesh = f'[mesh]\ntype = "gmsh"\nfile = "{geo}"\nparameters = {{ h = 1.0 }}\n\n'
    problem = folder / "vertical_load_gmsh.toml"
    problem.write_text(text[: text.index("[mesh]")] + mesh + text[text.index("[model]") :])
    return problem


@pytest.mark.parametrize("mesh", ["rectangle", "gmsh"])
@pytest.mark.parametrize("ranks", [1, TWO_RANKS])
def test_sigterm_keeps_outputs_and_exits_143(ranks, mesh, tmp_path):
    """Also on a gmsh mesh, whose initialisation resets the signal handlers."""
    if ranks > 1 and (_mpirun() is None or OPEN_MPI):
        pytest.skip("no mpirun, or Open MPI's, which ends the job itself on SIGTERM")
    out = tmp_path / "run"
    never = ["--set", "flow.tol=1e-30", "--set", "flow.max_steps=100000"]
    never += ["--set", "flow.stop=stationarity"]  # no exact zero of the rate ends it early
    # the gmsh mesh has its own size: SMALL without mesh.cells
    problem, small = (
        (VERTICAL, SMALL) if mesh == "rectangle" else (_on_gmsh_mesh(tmp_path), SMALL[2:])
    )
    args = ["run", str(problem), "--out", str(out), *small, *never, "--set", "output.progress=1"]
    command = [sys.executable, "-m", "dgplate", *args]
    if ranks > 1:
        command = [_mpirun(), "-n", "2", sys.executable, "-m", "mpi4py", "-m", "dgplate", *args]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in process.stdout:  # wait until the flow is stepping
            if line.startswith("step     3"):
                break
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 143, err
    assert "interrupted (SIGTERM)" in err and "--resume" in err
    summary = summary_of(out)
    assert summary["converged"] is False and summary["reason"] == "interrupted (SIGTERM)"
    assert summary["steps"] >= 3
    rows = (out / "history.csv").read_text().splitlines()
    assert len(rows) == summary["steps"] + 1
    assert (out / "checkpoint" / "state.npz").is_file()
    assert not list(out.glob(".staging-*"))


def _signalled(command: list[str], wait_for: str, sig: int, env=None) -> tuple[int, str, str]:
    """Start ``command``, send ``sig`` when a line of its output starts with ``wait_for``;
    returns (exit code, stdout, stderr)."""
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
    try:
        seen = []
        assert process.stdout is not None  # stdout=PIPE
        for line in process.stdout:
            seen.append(line)
            if line.startswith(wait_for):
                break
        process.send_signal(sig)
        out, err = process.communicate(timeout=120)
    finally:
        process.kill()
    return process.returncode, "".join(seen) + out, err


@pytest.mark.parametrize("ranks", [1, TWO_RANKS])
def test_sigterm_during_the_set_up_ends_it_at_once(ranks, tmp_path):
    """After its first line a rod of 40,000 cells spends half a minute in compiled code (the
    collapse of its mixed space), where Python handlers do not run; under mpirun a rank also
    waits in a collective. SIGTERM ends it there: 143, one line, nothing written, no PETSc
    report (without the immediate end it would stop only after a step, with outputs)."""
    if ranks > 1 and (_mpirun() is None or OPEN_MPI):
        pytest.skip("no mpirun, or Open MPI's, which ends the job itself on SIGTERM")
    out = tmp_path / "run"
    args = ["run", str(ROD), "--out", str(out), "--set", "model.cells=40000"]
    command = [sys.executable, "-m", "dgplate", *args]
    if ranks > 1:
        command = [_mpirun(), "-n", "2", sys.executable, "-m", "mpi4py", "-m", "dgplate", *args]
    code, stdout, err = _signalled(
        command, "dgplate: rod_arc: model rod, 40,000 cells", signal.SIGTERM
    )
    assert code == 143, err
    assert err == "dgplate: SIGTERM during the set-up: stopped, nothing written\n", err
    assert "PETSc" not in stdout
    assert not out.exists()


def test_sigint_during_the_compilation_ends_it_and_keeps_the_cache_usable(tmp_path):
    """A cold JIT cache: the header, then the notice of the compilation; SIGINT there ends the
    process with 130, and the unfinished form's C file is renamed (as FFCx does after a failed
    compilation), so that the next run compiles it instead of waiting for it."""
    cache = tmp_path / "cache"
    env = {**os.environ, "XDG_CACHE_HOME": str(cache)}
    args = ["run", str(VERTICAL), "--out", str(tmp_path / "run"), *SMALL]
    command = [sys.executable, "-m", "dgplate", *args]
    code, stdout, err = _signalled(command, "dgplate: compiling forms", signal.SIGINT, env)
    assert code == 130, err
    assert err == "dgplate: SIGINT during the set-up: stopped, nothing written\n", err
    header, notice = stdout.splitlines()
    assert header.startswith("dgplate: vertical_load: model kirchhoff, 16 cells, 480 dofs")
    assert (
        notice == "dgplate: compiling forms (first run of this problem shape, cached afterwards)…"
    )
    sources = (cache / "fenics").glob("*.c")
    assert all(c.with_suffix(".c.cached").exists() for c in sources)
    assert list((cache / "fenics").glob("*.c.failed"))
    assert not (tmp_path / "run").exists()


def test_sigterm_during_checks_compilation_keeps_the_cache_usable(tmp_path):
    """`dgplate check` on a cold cache, signalled while FFCx compiles a form: 143, and the
    form's C file renamed, not left for the next run to wait on."""
    fenics = tmp_path / "cache" / "fenics"
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}
    args = ["check", str(VERTICAL), "--out", str(tmp_path / "run"), *SMALL]
    process = subprocess.Popen(
        [sys.executable, "-m", "dgplate", *args], stderr=subprocess.PIPE, text=True, env=env
    )
    try:
        # a C file with code: its compilation is under way (the empty file is FFCx's lock)
        while not any(c.stat().st_size for c in fenics.glob("*.c")) and process.poll() is None:
            time.sleep(0.05)
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 143, err
    assert err == "dgplate: SIGTERM during the set-up: stopped, nothing written\n"
    assert all(c.with_suffix(".c.cached").exists() for c in fenics.glob("*.c"))
    assert list(fenics.glob("*.c.failed"))


def test_a_compilation_in_the_set_up_ends_from_pythons_handlers(tmp_path, monkeypatch):
    """While FFCx compiles a form in the command line's set-up, SIGINT and SIGTERM reach
    Python's handlers, which run between bytecodes: the C library's handler could land inside
    ``malloc`` or in the GIL's hand-over after the wait for the compiler, and wait there
    forever. Once the form is compiled, the C library's handler is back."""
    import ctypes

    import dolfinx
    import ffcx.codegeneration.jit as jit
    import ufl

    from dgplate import compat, interrupt

    end_now = ctypes.cast(interrupt._END_NOW, ctypes.c_void_p).value
    during = []
    compile_objects = jit._compile_objects  # the code, then the C compiler

    def spy(*args, **kwargs):
        during.extend((signal.getsignal(s), _c_handler(s)) for s in interrupt.SIGNALS)
        return compile_objects(*args, **kwargs)

    monkeypatch.setattr(jit, "_compile_objects", spy)
    mesh = dolfinx.mesh.create_unit_interval(MPI.COMM_SELF, 2)
    functional = ufl.SpatialCoordinate(mesh)[0] * ufl.dx
    with interrupt.StopOnSignal(at_once=True), interrupt.setting_up():
        before = [_c_handler(s) for s in interrupt.SIGNALS]
        with compat.on_first_compile(lambda: None):
            dolfinx.fem.form(functional, jit_options={"cache_dir": str(tmp_path)})
        after = [_c_handler(s) for s in interrupt.SIGNALS]
    assert before == after == [end_now, end_now]
    assert len(during) == 2
    assert all(python is interrupt._end_from_python and c != end_now for python, c in during)
    assert list(tmp_path.glob("*.c.cached"))  # it did compile


def _c_handler(signum: int) -> int | None:
    """The address of the C function handling ``signum`` (glibc's ``struct sigaction`` starts
    with it)."""
    import ctypes

    action = ctypes.create_string_buffer(256)
    assert ctypes.CDLL(None).sigaction(signum, None, action) == 0
    return ctypes.c_void_p.from_buffer(action).value


def test_ending_at_once_ends_the_processes_this_one_started():
    """The compiler a form compilation runs, and what it runs in turn, end with the process
    (left running, ``cc1`` reports the C file the clean-up renamed)."""
    from dgplate import interrupt

    shell = subprocess.Popen(["sh", "-c", "sleep 60 & sleep 60 & wait"])
    try:  # the shell's subtree only: this process's other children are pytest's
        deadline = time.monotonic() + 10
        while len(interrupt._descendants(shell.pid)) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        grandchildren = interrupt._descendants(shell.pid)
        assert len(grandchildren) == 2
        interrupt._end_children(shell.pid)
        shell.wait(timeout=10)  # its `wait` returns once its children are gone
        deadline = time.monotonic() + 10
        while any(map(_running, grandchildren)) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert not any(map(_running, grandchildren))
    finally:
        shell.kill()


def _running(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie (its /proc state)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as stat:
            return stat.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except OSError:
        return False


def test_a_failing_solver_ends_with_exit_1_and_no_abort(tmp_path):
    """A PETSc error inside the flow (not a SolverError) with VTX output open: the files are
    closed before the staged outputs go, so the process ends with 1, not with ADIOS2's abort
    at exit (134)."""
    out = tmp_path / "run"
    solver = ["--set", 'flow.solver={ksp_type="cg"}']  # cg refuses the right preconditioning
    done = dgplate("run", str(VERTICAL), "--out", str(out), "--set", "mesh.cells=[4,4]", *solver)
    assert done.returncode == 1, done.stderr
    assert "KSP cg does not support" in done.stderr and "ADIOS2" not in done.stderr
    assert not list(out.glob(".staging-*"))


# -- kill -9 and resume ---------------------------------------------------------------------
KILL_AT_STEP = textwrap.dedent(
    """
    import os, signal, sys
    from mpi4py import MPI
    from dgplate.solvers import flow, newton
    from dgplate.cli import main
    from dgplate.coupling import thermal_driver
    from dgplate.models import fvk

    driver, at = os.environ["DGPLATE_TEST_KILL_AT"].split(":")
    at = int(at)
    step, load_step = flow.GradientFlow.step, newton.LoadPath.step
    def step_then_die(self, *args, **kwargs):
        if self.step_count == at and driver == "flow":
            os.kill(os.getpid(), signal.SIGKILL)  # no clean-up at all, as kill -9
        return step(self, *args, **kwargs)
    def load_step_then_die(self):
        if self.step_count == at and driver == "fvk":
            os.kill(os.getpid(), signal.SIGKILL)
        return load_step(self)
    def advance_then_die(self, max_steps=None):
        if self.heat.steps == at and driver == "heat":
            os.kill(os.getpid(), signal.SIGKILL)
        return advance(self, max_steps)
    flow.GradientFlow.step = step_then_die
    newton.LoadPath.step = load_step_then_die
    advance = thermal_driver.ThermalBilayer.advance
    thermal_driver.ThermalBilayer.advance = advance_then_die
    if sys.argv[1].endswith(".py"):  # a demo script
        import runpy
        sys.argv = sys.argv[1:]
        runpy.run_path(sys.argv[0], run_name="__main__")
    else:
        sys.exit(main(sys.argv[1:]))
    """
)


def killed_then_resumed(
    out: Path,
    extra: list[str],
    ranks_after: int,
    problem: Path = VERTICAL,
    at: int = 18,
    base: list[str] = RESUMABLE,
) -> tuple[dict, str]:
    """Run until SIGKILL after step ``at`` (checkpoint at 15), then ``--resume``: the summary
    and the resumed run's output."""
    args = ["run", str(problem), "--out", str(out), *base, *extra]
    driver = "fvk" if "fvk" in problem.name else "flow"
    env = {**os.environ, "DGPLATE_TEST_KILL_AT": f"{driver}:{at}"}
    killed = subprocess.run(
        [sys.executable, "-c", KILL_AT_STEP, *args], env=env, capture_output=True, timeout=300
    )
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    assert not (out / "summary.json").exists()
    assert (out / "checkpoint" / "state.npz").is_file()
    resumed = dgplate(*args, "--resume", ranks=ranks_after)
    assert resumed.returncode == 0, resumed.stderr
    return summary_of(out), resumed.stdout


@pytest.mark.parametrize("ranks_after", [1, TWO_RANKS])
def test_killed_run_resumes_to_the_same_state(ranks_after, tmp_path):
    if ranks_after > 1 and _mpirun() is None:
        pytest.skip("no mpirun")
    direct = ["--set", "flow.linear_solver=direct"]
    reference = tmp_path / "reference"
    done = dgplate("run", str(VERTICAL), "--out", str(reference), *RESUMABLE, *direct)
    assert done.returncode == 0, done.stderr
    expected = summary_of(reference)
    shown = [*direct, "--set", "output.progress=1000"]  # the last line only
    summary, output = killed_then_resumed(tmp_path / "resumed", shown, ranks_after)
    assert summary["steps"] == expected["steps"] > 18
    # the last line counts every step, as summary.json does, and those since the resume
    assert f"after {summary['steps']} steps ({summary['steps'] - 15} since the resume)" in output
    # same ranks: the same operations (equal to the last bit here); 1 → 2 ranks: only the
    # partition's round-off (2e-13 here)
    rtol = 1e-10
    assert np.isclose(summary["energy"], expected["energy"], rtol=rtol, atol=0)
    assert np.isclose(summary["isometry_defect"], expected["isometry_defect"], rtol=rtol, atol=0)
    history = (tmp_path / "resumed" / "history.csv").read_text().splitlines()
    assert len(history) == expected["steps"] + 1  # every step, before and after the kill


@pytest.mark.parametrize("ranks_after", [1, TWO_RANKS])
def test_killed_fvk_schedule_resumes(ranks_after, tmp_path):
    """FvK load stepping: the checkpoint after each load step holds the load factor and the
    secant predictor's two states; 1 rank killed after 3 of 6 load steps, resumed on 1 or 2."""
    if ranks_after > 1 and _mpirun() is None:
        pytest.skip("no mpirun")
    problem = ROOT / "demos" / "problems" / "fvk_square.toml"
    small = ["--set", "mesh.cells=[6,6]", "--set", "newton.load_steps=6"]
    small += ["--set", "output.progress=0"]
    reference = tmp_path / "reference"
    assert dgplate("run", str(problem), "--out", str(reference), *small).returncode == 0
    expected = summary_of(reference)
    summary, _ = killed_then_resumed(tmp_path / "resumed", [], ranks_after, problem, 3, small)
    assert summary["steps"] == expected["steps"] == 6 and summary["converged"]
    assert np.isclose(summary["w_center"], expected["w_center"], rtol=1e-9, atol=0)
    assert np.isclose(summary["energy"], expected["energy"], rtol=1e-9, atol=0)
    history = (tmp_path / "resumed" / "history.csv").read_text().splitlines()
    assert len(history) == 6 + 1  # every load step, before and after the kill


BOX = ROOT / "demos" / "problems" / "box_folding.toml"
# the box on a short schedule: 4 heat steps to the switch, a hold, 4 back, a hold
SHORT_BOX = ["mesh.parameters.n=2", "mesh.parameters.m=2", "schedule.heat_step=7.05"]
SHORT_BOX += ["schedule.flow_steps=30", "output.png=false"]
SHORT_BOX += ["output.progress=0"]


def _runner_drives_every_model() -> bool:
    """The generic runner (Model.driver, Driver.run) has replaced the per-kind one."""
    from dataclasses import fields

    from dgplate.problems.registry import ModelEntry

    return "kind" not in {f.name for f in fields(ModelEntry)}


@pytest.mark.skipif(
    not _runner_drives_every_model(), reason="the runner does not drive thermal models yet"
)
def test_killed_box_resumes_to_the_same_state(tmp_path):
    """The thermal box on a short schedule (4 heat steps to the switch, 4 back): killed in
    the cooling phase, after the switch's hold, and resumed; the final state is the same."""
    short = [arg for key in SHORT_BOX for arg in ("--set", key)]
    # the first run may compile every form of the thermal model (minutes on a cold JIT cache)
    reference = dgplate("run", str(BOX), "--out", str(tmp_path / "reference"), *short, timeout=900)
    assert reference.returncode == 0, reference.stderr
    expected = summary_of(tmp_path / "reference")
    assert expected["converged"] and expected["holds"] == 2
    out = tmp_path / "resumed"
    args = ["run", str(BOX), "--out", str(out), *short]
    env = {**os.environ, "DGPLATE_TEST_KILL_AT": "heat:6"}
    killed = subprocess.run(
        [sys.executable, "-c", KILL_AT_STEP, *args], env=env, capture_output=True, timeout=600
    )
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    resumed = dgplate(*args, "--resume", timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    summary = summary_of(out)
    assert summary["heat_steps"] == expected["heat_steps"] == 8
    assert summary["steps"] == expected["steps"]
    for key in ("energy", "isometry_defect", "energy_at_switch", "closure_gap_at_switch"):
        assert np.isclose(summary[key], expected[key], rtol=1e-8, atol=1e-14), key
    rows = (out / "history.csv").read_text().splitlines()
    assert len(rows) == len((tmp_path / "reference" / "history.csv").read_text().splitlines())
    # the box held closed at the switch, before the kill, is in the resumed run's checkpoint
    # (its at_switch.png is drawn from it)
    expected_fields = load_result(tmp_path / "reference", MPI.COMM_SELF).fields
    fields = load_result(out, MPI.COMM_SELF).fields
    held = sorted(name for name in expected_fields if name.startswith("held_"))
    assert len(held) == 2 and held == sorted(name for name in fields if name.startswith("held_"))
    for name in held:
        got, want = fields[name].x.array, expected_fields[name].x.array
        assert np.allclose(got, want, rtol=1e-8, atol=1e-12), name


ONE_RANK_FAILS = textwrap.dedent(
    """
    import sys
    from mpi4py import MPI
    from dgplate.solvers import flow
    from dgplate import cli
    from dgplate.cli import main

    cli.AGREE_SECONDS = 1.0  # the agreement's wait, shortened: the mechanism is under test

    step = flow.GradientFlow.step
    def step_or_fail(self, *args, **kwargs):
        if self.step_count == 2 and MPI.COMM_WORLD.rank == 1:
            raise RuntimeError("a failure on rank 1 only")
        return step(self, *args, **kwargs)
    flow.GradientFlow.step = step_or_fail
    sys.exit(main(sys.argv[1:]))
    """
)


@pytest.mark.spawns_mpirun
@pytest.mark.skipif(_mpirun() is None, reason="no mpirun")
def test_error_on_one_rank_ends_every_rank(tmp_path):
    """Rank 0 waits in a collective of step 3 that rank 1 never joins: without the agreement
    of cli.end_together the job would hang until killed; with it, it ends with exit 1."""
    out = tmp_path / "out"
    args = ["run", str(VERTICAL), "--out", str(out), *SMALL, "--set", "output.progress=0"]
    command = [_mpirun(), "-n", "2", sys.executable, "-c", ONE_RANK_FAILS, *args]
    done = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert done.returncode == 1, done.stderr
    assert "RuntimeError: a failure on rank 1 only (rank 1)" in done.stderr
    assert not (out / "summary.json").exists()


@pytest.mark.mpi
@pytest.mark.parametrize("late", [0.0, 0.5])
def test_ranks_agree_whether_every_rank_arrived(comm, late):
    """The error path's agreement (mpi.all_arrive): a rank 0.5 s late for a 0.3 s wait makes
    every rank answer False, not the early ones False and the late one True."""
    import time

    from dgplate import mpi

    agree = comm.Dup()
    if comm.rank == comm.size - 1:
        time.sleep(late)
    outcomes = comm.allgather(mpi.all_arrive(agree, 0.3))
    assert outcomes == [late == 0.0 or comm.size == 1] * comm.size
