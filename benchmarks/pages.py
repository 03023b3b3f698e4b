"""Generated sections of the documentation pages: the text between a page's two markers."""

from __future__ import annotations

from pathlib import Path


def write_between(page: Path, begin: str, end: str, text: str, heading: str = "") -> None:
    """Replace the page's text from ``begin`` to ``end`` (both markers included) by ``text``.

    Args:
        page: the Markdown page.
        begin: the opening marker, e.g. ``<!-- accuracy:begin -->``.
        end: the closing marker.
        text: the new section, markers included.
        heading: if given, a page without the markers gets ``## heading`` and the section
            appended; if not, such a page is an error.

    Raises:
        SystemExit: the page lacks a marker and no ``heading`` is given (the page is left as
            it was).
    """
    content = page.read_text()
    if begin not in content or end not in content:
        if not heading:
            raise SystemExit(f"{page} has no {begin} … {end} markers")
        page.write_text(content.rstrip("\n") + f"\n\n## {heading}\n\n{text}\n")
        return
    head, rest = content.split(begin, 1)
    page.write_text(head + text + rest.split(end, 1)[1])
