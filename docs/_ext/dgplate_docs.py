"""Pages generated at the start of every build of the site, so that they cannot drift.

- ``_generated/demos/<demo>.py``: each literate demo of demos/ with a closing cell that gives
  the command regenerating it and its picture (docs/img/demos/<demo>.png, written by
  ``docs/_ext/demo_images.py``), and ``_generated/demos.md``, their index;
- ``_generated/problem-files.md``: every key of every section of every model, from the spec
  dataclasses that ``dgplate schema`` prints;
- ``_generated/topics.md``: the pages of docs/ that the landing page does not list itself.
"""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import Any

DOCS = Path(__file__).resolve().parent.parent
ROOT = DOCS.parent
OUT = DOCS / "_generated"
#: Pages of docs/ with a place of their own in the landing page's tables of contents.
LISTED = {
    "index",
    "guide",
    "tutorial",
    "converge",
    "units",
    "design",
    "verification",
    "performance",
    "api",
}


def read_demo(text: str) -> Any:
    """A demo (a jupytext percent script) as a notebook whose code cells are Python."""
    import jupytext

    notebook = jupytext.reads(text, fmt="py:percent")
    notebook.metadata["kernelspec"] = {
        "name": "python3",
        "language": "python",
        "display_name": "Python 3",
    }
    notebook.metadata["language_info"] = {"name": "python", "pygments_lexer": "ipython3"}
    return notebook


def _write(path: Path, text: str) -> None:
    """Write ``text`` unless the file holds it already (keeps Sphinx's incremental build)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _title(demo: Path) -> str:
    """The first Markdown heading of a demo, or its file name."""
    for line in demo.read_text(encoding="utf-8").splitlines():
        if line.startswith("# # "):
            return line[4:].strip()
    return demo.stem


def demo_pages() -> None:
    """The demos as pages, each closing with its command and picture, and their index."""
    demos = sorted((ROOT / "demos").glob("*.py"))
    for demo in demos:
        picture = DOCS / "img" / "demos" / f"{demo.stem}.png"
        cell = [
            "",
            "# %% [markdown]",
            "# ## Run it",
            "#",
            f"# `python demos/{demo.name}` (add `--paper` for the published resolution where the",
            f"# demo has one; `mpirun -n 2 python demos/{demo.name}` in parallel). This page is",
            f"# the script demos/{demo.name} itself, rendered.",
        ]
        if picture.exists():
            cell += [
                "#",
                f"# ![The final shape of {demo.stem}](../../img/demos/{demo.stem}.png)",
                "#",
                f"# The picture: `python docs/_ext/demo_images.py {demo.stem}`.",
            ]
        _write(OUT / "demos" / demo.name, demo.read_text(encoding="utf-8") + "\n".join(cell) + "\n")
    entries = "\n".join(f"demos/{demo.stem}" for demo in demos)
    rows = "\n".join(f"| [{_title(d)}](demos/{d.stem}) | `demos/{d.name}` |" for d in demos)
    _write(
        OUT / "demos.md",
        "# Demos\n\nEvery demo is a literate script: the text explains the physics, the code "
        "runs it small by default and checks its result (the tests run each one serially and "
        "on 2 ranks).\n\n| demo | script |\n|---|---|\n"
        f"{rows}\n\n```{{toctree}}\n:hidden:\n\n{entries}\n```\n",
    )


def problem_file_reference() -> None:
    """Every key of a problem file, per model, from the spec dataclasses."""
    from dgplate.problems.registry import MODELS
    from dgplate.problems.specs import sections
    from dgplate.schema import options

    parts = [
        "# Problem-file reference",
        "",
        "Generated from the same spec dataclasses as `dgplate schema --model NAME`, which prints",
        "the same keys as commented TOML. `--set section.key=value` overrides any of them.",
    ]
    shared: set[str] = set()
    for name in MODELS:
        for section, spec in sections(name):
            if section != "model" and section in shared:
                continue
            shared.add(section)
            heading = (
                f'`[model]` with `name = "{name}"`' if section == "model" else f"`[{section}]`"
            )
            parts += ["", f"## {heading}", "", "| key | default | meaning |", "|---|---|---|"]
            for key, default, doc in options(spec):
                parts.append(f"| `{key}` | `{_cell(default)}` | {_cell(doc)} |")
    _write(OUT / "problem-files.md", "\n".join(parts) + "\n")


def _cell(text: str) -> str:
    """Text that stays inside one cell of a Markdown table."""
    return text.replace("|", "\\|").replace("\n", " ")


def topic_pages() -> None:
    """A table of contents of the pages of docs/ that the landing page does not list."""
    pages = sorted(p.stem for p in DOCS.glob("*.md") if p.stem not in LISTED)
    entries = "\n".join(f"../{page}" for page in pages)
    _write(
        OUT / "topics.md",
        "# Models and experiments\n\n"
        + textwrap.dedent(
            """\
            The experiments behind each model, with the measured figures.

            ```{toctree}
            :maxdepth: 1

            """
        )
        + entries
        + "\n```\n",
    )


def generate(app: Any) -> None:
    """Write every generated page (Sphinx's ``builder-inited``)."""
    demo_pages()
    problem_file_reference()
    topic_pages()


def plain_bars(app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    """Docstrings write norms as |x| (plain text), which reStructuredText reads as substitutions."""
    lines[:] = [line.replace("|", "\\|") for line in lines]


def setup(app: Any) -> dict[str, Any]:
    """Register the generator and the docstring filter with Sphinx."""
    app.connect("builder-inited", generate)
    app.connect("autodoc-process-docstring", plain_bars)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
