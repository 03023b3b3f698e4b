"""Every ``dgplate.…`` name and every ``dgplate/….py`` path that the docs cite exists.

The docs drift when code moves: a page that names ``dgplate.models.base.Energy`` after the class
moved to ``dgplate/dg/energy.py`` sends a reader nowhere. This test reads README.md and
docs/*.md and resolves each dotted name by importing its longest module prefix and looking up
the rest as attributes. A class or function cited through a module (not a package) must be
defined there, so a re-export does not hide where the code lives.
"""

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
DOTTED = re.compile(r"\bdgplate(?:\.[A-Za-z_][A-Za-z0-9_]*)+")
PATH = re.compile(r"\bdgplate/[A-Za-z0-9_/]+\.py\b")


def cited(pattern: re.Pattern[str]) -> list[tuple[str, str]]:
    found = {(page.name, m) for page in PAGES for m in pattern.findall(page.read_text())}
    return sorted(found)


def resolve(dotted: str) -> object:
    """The object ``dotted`` names: its longest importable module prefix, then attributes."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            module = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        obj: object = module
        for name in parts[cut:]:
            obj = getattr(obj, name)
        defined_in = getattr(obj, "__module__", None)
        if cut < len(parts) and not hasattr(module, "__path__") and defined_in is not None:
            if not defined_in.startswith(module.__name__):
                raise AttributeError(f"{'.'.join(parts[cut:])} is defined in {defined_in}")
        return obj
    raise ModuleNotFoundError(dotted)


def test_pages_cite_names_at_all():
    assert len(cited(DOTTED)) >= 10 and len(cited(PATH)) >= 10


@pytest.mark.parametrize(("page", "name"), cited(DOTTED))
def test_cited_name_resolves(page, name):
    try:
        resolve(name)
    except (ImportError, AttributeError) as error:
        pytest.fail(f"{page} cites {name}, which does not resolve: {error}")


@pytest.mark.parametrize(("page", "path"), cited(PATH))
def test_cited_path_exists(page, path):
    assert (ROOT / path).is_file(), f"{page} cites {path}, which does not exist"
