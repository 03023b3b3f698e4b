"""Every picture of docs/img has a command that draws it from a run, or is listed as kept.

docs/_ext/figures.py holds the commands (``--list``); a picture added to docs/img by hand,
without one, fails here. The commands are not run here (minutes each): their scripts and
problem files are checked.
"""

import importlib.util
import sys
from pathlib import Path

from helpers import load_benchmark

ROOT = Path(__file__).resolve().parents[2]


def figures_module():
    spec = importlib.util.spec_from_file_location("figures", ROOT / "docs" / "_ext" / "figures.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # the dataclass looks its module up
    spec.loader.exec_module(module)
    return module


def test_every_picture_is_drawn_by_a_command_or_kept():
    figures = figures_module()
    listed = set(figures.FIGURES) | set(figures.ALSO_DRAWN) | set(figures.KEPT)
    found = set(figures.pictures())
    assert found - listed == set(), "pictures without a command: add them to docs/_ext/figures.py"
    assert listed - found == set(), "docs/_ext/figures.py lists pictures that are not in docs/img"
    assert not set(figures.FIGURES) & set(figures.KEPT)
    assert set(figures.ALSO_DRAWN.values()) <= set(figures.FIGURES)


def test_every_picture_is_shown_by_a_page():
    figures = figures_module()
    pages = "".join(p.read_text() for p in [ROOT / "README.md", *(ROOT / "docs").glob("*.md")])
    for name in figures.pictures():
        assert f"img/{name}" in pages, f"docs/img/{name} is on no page"


def test_commands_name_existing_scripts_and_problem_files():
    figures = figures_module()
    for name, figure in figures.FIGURES.items():
        command = figure.command
        script = command[0] if command[0] != "-m" else None
        if script is not None:
            assert (ROOT / script).is_file(), f"{name}: {script}"
        for arg in command:
            if arg.endswith(".toml"):
                assert (ROOT / arg).is_file(), f"{name}: {arg}"
        assert [a.format(out="OUT", img="IMG") for a in command], name  # no stray braces
        # a picture the command writes itself is named after the picture it is listed for
        written = {a.removeprefix("{img}/") for a in command if a.startswith("{img}/")}
        assert written <= {name}, name
        assert figure.copy == {} or name in figure.copy, name
        if figure.section is not None:
            page, section, _ = figure.section
            begin, end = figures.markers(section)
            text = (ROOT / page).read_text()
            assert text.count(begin) == 1 and text.count(end) == 1, f"{name}: {page}"


def test_paper_sizes_copies_the_pictures_figures_py_names():
    """The pictures drawn by benchmarks/paper_sizes.py's cases are those it copies."""
    figures = figures_module()
    copied = {name for case in load_benchmark("paper_sizes").PICTURES.values() for name in case}
    by_paper_sizes = {
        name
        for name, figure in figures.FIGURES.items()
        if "benchmarks/paper_sizes.py" in figure.command
    }
    also = {k for k, v in figures.ALSO_DRAWN.items() if v in by_paper_sizes}
    assert copied == by_paper_sizes | also
