"""``output.frames_every``: pictures of the shape during a run, and the GIF made of them.

A tiny Kirchhoff run (the vertical load on 4×4 cells, 5 steps) with ``frames_every = 2`` draws
the start, steps 2 and 4 and the last step 5: four frames, and a GIF of four frames that
Pillow opens. Serially and under ``mpirun -n 2`` (collective drawing, rank 0 writes). A resumed
run copies the frames of the run it continues. The demos' ``--no-frames`` turns them off.
"""

from pathlib import Path

from mpi4py import MPI

import pytest

import dgplate
from dgplate.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
VERTICAL = ROOT / "demos" / "problems" / "vertical_load.toml"
SMALL = {
    "mesh.cells": [4, 4],
    "flow.max_steps": 5,
    "flow.tol": 1e-12,
    "output.vtx": False,
    "output.png": False,
    "output.progress": 0,
}


def _shared_dir(tmp_path: Path) -> Path:
    """One folder for all ranks (rank 0's temporary folder)."""
    return Path(MPI.COMM_WORLD.bcast(str(tmp_path), root=0))


@pytest.mark.mpi
def test_frames_and_gif(tmp_path):
    from PIL import Image

    out = _shared_dir(tmp_path) / "run"
    problem = dgplate.load_problem(VERTICAL, overrides={**SMALL, "output.frames_every": 2})
    result = dgplate.run(problem, out=out)
    assert result["steps"] == 5
    frames = sorted((out / "frames").glob("frame_*.png"))
    assert [f.name for f in frames] == [f"frame_{n:06d}.png" for n in (0, 2, 4, 5)]
    with Image.open(out / f"{problem.name}.gif") as gif:
        assert gif.n_frames == 4
        assert gif.size == (640, 480)
    MPI.COMM_WORLD.barrier()


def test_no_frames_by_default(tmp_path):
    out = tmp_path / "run"
    problem = dgplate.load_problem(VERTICAL, overrides={**SMALL, "flow.max_steps": 1})
    dgplate.run(problem, out=out)
    assert not (out / "frames").exists()
    assert not list(out.glob("*.gif"))


def test_demo_option_no_frames_turns_them_off(tmp_path):
    from dgplate import demo

    out = tmp_path / "run"
    problem = dgplate.load_problem(
        VERTICAL, overrides={**SMALL, "flow.max_steps": 1, "output.frames_every": 1}
    )
    demo.run(problem, demo.arguments("tiny", argv=["--out", str(out), "--no-frames"]))
    assert (out / "summary.json").is_file()
    assert not (out / "frames").exists()
    assert not list(out.glob("*.gif"))


@pytest.mark.parametrize("value", [-1, 1.5, "often"])
def test_bad_frames_every(value):
    with pytest.raises(InputError, match=r"output\.frames_every"):
        dgplate.load_problem(VERTICAL, overrides={"output.frames_every": value})


def test_resumed_run_keeps_the_earlier_frames(tmp_path):
    """A run stopped by its step budget and resumed: the GIF shows both parts."""
    from PIL import Image

    out = tmp_path / "run"
    first = dgplate.load_problem(
        VERTICAL, overrides={**SMALL, "flow.max_steps": 3, "output.frames_every": 2}
    )
    dgplate.run(first, out=out)
    again = dgplate.load_problem(VERTICAL, overrides={**SMALL, "output.frames_every": 2})
    result = dgplate.run(again, out=out, resume=True)
    assert result["steps"] == 5
    frames = sorted(p.name for p in (out / "frames").glob("frame_*.png"))
    assert frames == [f"frame_{n:06d}.png" for n in (0, 2, 3, 4, 5)]
    with Image.open(out / f"{again.name}.gif") as gif:
        assert gif.n_frames == 5
