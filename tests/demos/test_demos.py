"""Every demo in demos/ runs at its small default size and passes: on 2 ranks one demo for
each model and feature (``NP2``), the others serially; with ``DGPLATE_ALL_DEMOS_NP2=1`` every
demo on 2 ranks as well.

The demos check their own results (published or exact numbers within stated tolerances, see
:mod:`dgplate.demo`): a demo that no longer reproduces its number exits with an error. Here
each one runs as a subprocess with ``--out`` in a temporary folder; the test asserts the exit
code and that the demo wrote a summary.json, a PNG and a VTX series (.bp). New demos are picked
up by the glob.

The 2-rank runs launch ``mpirun -n 2 python -m mpi4py`` themselves from the serial session (as
tests/app/test_reliability.py does), so they are not marked ``mpi``: ``make test-mpi`` runs the
``mpi`` tests under mpirun already, and must not start mpirun inside mpirun.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import mpirun as _mpirun

ROOT = Path(__file__).resolve().parents[2]
DEMOS = sorted((ROOT / "demos").glob("*.py"))


def run_demo(
    demo: Path, out: Path, ranks: int, timeout: float = 900
) -> subprocess.CompletedProcess:
    """``python demo --out out`` (under ``mpirun -n ranks python -m mpi4py`` when ranks > 1).

    The 2-rank runs skip the animation frames (``--no-frames``): the serial runs of the other
    demos draw theirs, and each frame costs about a second of rendering on rank 0 only. PYTHONPATH puts this checkout's dgplate first: the script's own folder is demos/, and an
    installed dgplate may be another checkout's.
    """
    command = [sys.executable, str(demo), "--out", str(out)]
    if ranks > 1:
        launcher = _mpirun()
        assert launcher is not None, "no mpirun"
        command = [launcher, "-n", str(ranks), sys.executable, "-m", "mpi4py", *command[1:]]
        command.append("--no-frames")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=env)


# The demos run on 2 ranks by `make test`: one for each model (Kirchhoff, bilayer, thermal,
# FvK, LCE, rod, the linear biharmonic) and each feature (creases, obstacles, continuation,
# stability, path following, self-avoidance of plates and rods, a target metric), the shortest
# of each. The models' results on 1, 2 and 3 ranks are compared by the `mpi` parity tests;
# running all the demos (32 then) on 2 ranks as well took 7.7 of the suite's 22 minutes on 2 cores.
NP2 = {
    "biharmonic",
    "bilayer_hole",
    "box_folding",  # the demo of `make demo`
    "buckling_strip",
    "fvk_cone",
    "fvk_one_sided",
    "fvk_snap_through",
    "lce_director_pattern",
    "obstacle_bnn",
    "prestrained_discs",  # the edge waves gathered from the ranks (measure.prestrain)
    "rod_sphere",
    "rod_trefoil",
    "self_avoiding_compressed_strip",
    "spherical_cap",
    "straight_fold",
    "vertical_load",
}


def _cases() -> list:
    """(demo, ranks): those in ``NP2`` on 2 ranks, the others serially (every demo both ways
    with ``DGPLATE_ALL_DEMOS_NP2=1``).

    A demo of ``NP2`` checks its figures on 2 ranks; run serially too it checked the same
    figures again (about 70 s of the serial tier on 2 cores), and the models' one-rank runs
    are the parity tests' and the other demos'. The 2-rank runs carry the marker
    ``spawns_mpirun``: ``make test`` runs them after the serial tests, one at a time, so that
    the two ranks have the two cores to themselves (and find the forms compiled by the serial
    tests in the JIT cache).
    """
    every = os.environ.get("DGPLATE_ALL_DEMOS_NP2") == "1"
    cases = []
    for demo in DEMOS:
        if every or demo.stem not in NP2:
            cases.append(pytest.param(demo, 1, id=f"{demo.stem}-serial"))
        if every or demo.stem in NP2:
            marks = [pytest.mark.spawns_mpirun]
            cases.append(pytest.param(demo, 2, id=f"{demo.stem}-np2", marks=marks))
    return cases


def test_every_np2_demo_exists():
    """A renamed demo must not drop out of the 2-rank runs unnoticed."""
    assert NP2 <= {demo.stem for demo in DEMOS}


@pytest.mark.parametrize(("demo", "ranks"), _cases())
def test_demo_runs_and_checks_its_results(demo, ranks, tmp_path):
    if ranks > 1 and _mpirun() is None:
        pytest.skip("no mpirun")
    out = tmp_path / "out"
    done = run_demo(demo, out, ranks)
    tail = "\n".join((done.stdout + done.stderr).splitlines()[-30:])
    assert done.returncode == 0, f"{demo.name} on {ranks} rank(s) failed:\n{tail}"
    for pattern in ("summary.json", "*.png", "*.bp"):
        assert any(out.rglob(pattern)), f"{demo.name} wrote no {pattern} in {out}:\n{tail}"


@pytest.mark.parametrize("name", ["vertical_load", "straight_fold", "fvk_crease"])
def test_demo_refuses_a_users_folder_in_one_line(name, tmp_path):
    """A demo of one run, one of several runs in subfolders and one that writes its own
    results: exit 2, one line, the user's folder as it was, before anything is solved."""
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("user data")
    done = run_demo(ROOT / "demos" / f"{name}.py", mine, ranks=1, timeout=300)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and f"{name}.py: error: --out {mine}" in done.stderr
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]


# -- the helpers of dgplate.demo ------------------------------------------------------------
def test_checks_print_one_line_and_raise_outside_the_tolerance(capsys):
    from dgplate import demo

    demo.check_close("E_h", 1.004, 1.0, rel=5e-3, source="paper")
    demo.check_close("steps", 14, 13, abs=2)
    demo.check_between("D_h", 2e-14, high=1e-10)
    demo.check("converged", True)
    with pytest.raises(AssertionError, match=r"E_h = 1\.01, expected 1 ± 0\.5 %"):
        demo.check_close("E_h", 1.01, 1.0, rel=5e-3)
    with pytest.raises(AssertionError):
        demo.check_close("E_h", float("nan"), 1.0, abs=1.0)
    with pytest.raises(AssertionError, match=r"expected in \[4, 4.2\]"):
        demo.check_between("E_h", 4.3, 4.0, 4.2)
    with pytest.raises(AssertionError):
        demo.check("converged", False)
    with pytest.raises(ValueError):
        demo.check_between("E_h", 1.0)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "ok: E_h = 1.004, expected 1 ± 0.5 % (paper)"
    assert sum(line.startswith("FAILED: ") for line in lines) == 4


def test_arguments_and_axis_angle():
    from dgplate import demo

    args = demo.arguments("cantilever", argv=["--paper", "-f", "kernel.json"])  # Jupyter's -f
    assert args.paper and args.out == "out/cantilever" and not (args.force or args.resume)
    parser = demo.parser("vertical_load")
    parser.add_argument("--cells", type=int, default=16)
    assert demo.parse(parser, ["--cells", "8", "--out", "o"]).cells == 8
    assert demo.axis_angle({"axis": [0.0, -1.0, 0.0]}, (0, 1, 0)) == pytest.approx(0.0)
    assert demo.axis_angle({"axis": [1.0, 1.0, 0.0]}, (0, 1, 0)) == pytest.approx(45.0)


def test_demo_run_resumes_each_run_where_it_stopped(tmp_path):
    import dgplate
    from dgplate import demo

    problem_file = ROOT / "demos" / "problems" / "vertical_load.toml"
    small = {"mesh.cells": [4, 4], "output.png": False, "output.progress": 0}
    args = demo.arguments("vertical_load", argv=["--out", str(tmp_path)])
    stopped = demo.run(
        dgplate.load_problem(problem_file, {**small, "flow.max_steps": 3}), args, "a"
    )
    assert not stopped["converged"] and stopped["steps"] == 3
    args = demo.arguments("vertical_load", argv=["--out", str(tmp_path), "--resume"])
    problem = dgplate.load_problem(problem_file, small)
    resumed = demo.run(problem, args, "a")  # from the checkpoint at step 3
    assert resumed["converged"] and resumed["steps"] > 3
    again = demo.run(problem, args, "a")  # finished: its results, not a second run
    assert again["steps"] == resumed["steps"] and again["energy"] == resumed["energy"]
    assert len(again.history) == again["steps"] and again.shape is not None  # a Result
    # stopped after it converged, before its outputs were in place: the resume writes them
    (tmp_path / "a" / "summary.json").unlink()
    (tmp_path / "a" / "history.csv").unlink()
    written = demo.run(problem, args, "a")
    assert written["converged"] and written["steps"] == resumed["steps"]
    assert written["energy"] == resumed["energy"] and len(written.history) == written["steps"]
    assert (tmp_path / "a" / "history.csv").is_file()
    fresh = demo.run(problem, args, "b")  # nothing to resume yet: it starts
    assert fresh["steps"] == resumed["steps"]


def test_an_interrupted_run_ends_the_demo_with_the_signals_code(tmp_path, monkeypatch, capsys):
    """A demo's later runs and checks do not start after a SIGTERM: SystemExit(143)."""
    import signal

    import dgplate
    from dgplate import demo, interrupt

    monkeypatch.setattr(interrupt, "requested", lambda comm: int(signal.SIGTERM))
    problem_file = ROOT / "demos" / "problems" / "vertical_load.toml"
    small = {"mesh.cells": [4, 4], "output.png": False, "output.progress": 0}
    args = demo.arguments("vertical_load", argv=["--out", str(tmp_path)])
    with pytest.raises(SystemExit) as stop:
        demo.run(dgplate.load_problem(problem_file, small), args, "a")
    assert stop.value.code == 143
    assert "interrupted (SIGTERM)" in capsys.readouterr().out
    assert (tmp_path / "a" / "summary.json").is_file()  # what the run had is written


def test_a_demo_without_checkpoints_says_that_resume_starts_afresh(tmp_path, capsys):
    from dgplate import demo

    args = demo.arguments("fvk_square", argv=["--out", str(tmp_path / "o"), "--resume"])
    folder = demo.output_folder(args)
    assert "keeps no checkpoints; it runs from the start" in capsys.readouterr().err
    folder.discard()


def test_a_demo_refuses_a_number_that_is_not_finite():
    import argparse

    from dgplate import demo
    from dgplate.errors import InputError

    parser = demo.parser("straight_fold")
    parser.add_argument("--angle", type=float, default=60.0)
    parser.add_argument("--ratios", type=float, nargs="+")
    with pytest.raises(InputError, match="--angle must be a finite number, got nan"):
        demo.parse(parser, ["--angle", "nan"])
    with pytest.raises(InputError, match="--ratios must be a finite number"):
        demo.parse(parser, ["--ratios", "1", "inf"])
    assert isinstance(demo.parse(parser, ["--angle", "45"]), argparse.Namespace)
