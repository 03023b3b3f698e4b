"""docs/tutorial.md works as written: its files are written and its commands run, in order,
in an empty folder, and the numbers its text quotes are those the runs give.

A fenced block whose first line is a comment ``# file: NAME`` (``// file: NAME`` in a .geo)
is a file to write; every line of a ``bash`` block is a command (``dgplate …`` or
``python …``), expected to exit 0 unless it ends with ``# exits N``. The tutorial's sizes
are small (each run takes seconds), so they are run as they stand.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TUTORIAL = ROOT / "docs" / "tutorial.md"
FENCE = re.compile(r"^```(\S*)\n(.*?)^```$", re.M | re.S)
FILE = re.compile(r"^(?:#|//) file: (\S+)")
EXITS = re.compile(r"#\s*exits (\d+)\s*$")


def _blocks() -> list[tuple[str, str]]:
    """(language, text) of every fenced block of the tutorial."""
    return FENCE.findall(TUTORIAL.read_text(encoding="utf-8"))


def _steps() -> list[tuple[str, str | list[str], int]]:
    """The tutorial in order: ("file", name, 0) with the text after it, or ("run", argv, code)."""
    steps: list[tuple[str, str | list[str], int]] = []
    for language, text in _blocks():
        named = FILE.match(text)
        if named:
            steps.append(("file", named.group(1), 0))
            steps.append(("text", text, 0))
        elif language == "bash":
            for line in text.splitlines():
                if line.strip():
                    code = EXITS.search(line)
                    steps.append(
                        ("run", shlex.split(line, comments=True), int(code[1]) if code else 0)
                    )
    return steps


def _command(argv: list[str]) -> list[str]:
    """``dgplate …`` and ``python …`` as this interpreter runs them."""
    program, *args = argv
    assert program in ("dgplate", "python"), f"the tutorial runs {program!r}"
    return (
        [sys.executable, "-m", "dgplate", *args]
        if program == "dgplate"
        else [sys.executable, *args]
    )


def test_the_tutorial_has_files_and_commands():
    """What the test runs is there: four files, and commands that run dgplate and Python."""
    steps = _steps()
    names = [name for kind, name, _ in steps if kind == "file"]
    assert names == ["strip.toml", "rolled.toml", "lplate.geo", "lplate.toml", "curl.py"]
    runs = [argv for kind, argv, _ in steps if kind == "run"]
    assert len(runs) >= 8 and {argv[0] for argv in runs} == {"dgplate", "python"}
    assert [code for kind, _, code in steps if kind == "run" and code] == [2]


def test_the_tutorial_runs_as_written(tmp_path):
    """Every command as the tutorial gives it, in an empty folder: the exit codes it says,
    every run converged with its outputs, and the figures the text quotes."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
    }
    steps = _steps()
    printed = {}
    for (kind, what, code), after in zip(steps, [*steps[1:], None], strict=True):
        if kind == "file":
            assert after is not None
            (tmp_path / str(what)).write_text(str(after[1]), encoding="utf-8")
        elif kind == "run":
            argv = list(what)
            done = subprocess.run(
                _command(argv), cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900
            )
            assert done.returncode == code, f"{shlex.join(argv)}:\n{done.stdout}\n{done.stderr}"
            printed[shlex.join(argv)] = done
    refused = next(done for line, done in printed.items() if "edge" in line)
    assert refused.stderr.splitlines() == [
        "dgplate: error: model.clamped: unknown facet group 'edge' in mesh lplate.geo "
        "(available: free, wall)"
    ]
    text = TUTORIAL.read_text(encoding="utf-8")
    assert refused.stderr.strip() in text
    outputs = sorted(p.parent for p in (tmp_path / "out").glob("*/summary.json"))
    assert [p.name for p in outputs] == sorted(
        ["strip", "strip_32", "strip_tau", "rolled", "lplate", "rolled_curled"]
    )
    summaries = {p.name: json.loads((p / "summary.json").read_text()) for p in outputs}
    for name, summary in summaries.items():
        assert summary["converged"], name
        assert all((tmp_path / "out" / name / f).exists() for f in ("final.png", "history.csv"))
    strip = summaries["strip"]
    assert f"converged after {strip['steps']} steps" in text
    assert f"E_h ≈ {summaries['rolled']['energy']:.3f}" in text
    curled, flat = summaries["rolled_curled"], summaries["rolled"]
    assert curled["steps"] < flat["steps"]
    assert curled["energy"] == pytest.approx(flat["energy"], rel=1e-6)
    assert f"from the cylinder: {curled['steps']} steps, from flat: {flat['steps']}" in (
        printed["python curl.py"].stdout
    )
