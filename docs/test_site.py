"""The documentation site, checked in a real browser (``make docs-check``).

Every page of ``docs/_build/html`` (built by ``make docs``) is opened in headless Chromium
(Debian's ``chromium`` and ``chromium-driver``, driven by Selenium): no page may log a console
error or show an image that did not load, and the landing page must show the box. Every
internal link, image, stylesheet and script of every page must resolve to a file, and every
link's ``#anchor`` to an id of its target page. Screenshots of the landing page and of one demo
page are saved in ``docs/_build/screenshots`` for a person to look at.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlsplit

import pytest

DOCS = Path(__file__).resolve().parent
SITE = DOCS / "_build" / "html"
SHOTS = DOCS / "_build" / "screenshots"


class _Page(HTMLParser):
    """The ids of a page and the references it makes (links, images, styles, scripts)."""

    def __init__(self) -> None:
        super().__init__()
        self.ids: set[str] = set()
        self.refs: list[tuple[str, str]] = []  # (tag, url)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = dict(attrs)
        if values.get("id"):
            self.ids.add(str(values["id"]))
        for name in ("href", "src"):
            url = values.get(name)
            if url and tag in ("a", "img", "link", "script"):
                self.refs.append((tag, url))


def _parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def _pages() -> list[Path]:
    return sorted(SITE.rglob("*.html"))


@pytest.fixture(scope="module")
def site() -> Path:
    """The built site (built here when ``make docs`` has not run)."""
    if not (SITE / "index.html").exists():
        command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html"]
        subprocess.run([*command, str(DOCS), str(SITE)], check=True)
    return SITE


def test_every_internal_reference_resolves(site: Path) -> None:
    parsed = {path: _parse(path) for path in _pages()}
    broken = []
    for path, page in parsed.items():
        for tag, url in page.refs:
            parts = urlsplit(url)
            if parts.scheme or parts.netloc or url.startswith(("mailto:", "data:")):
                continue  # external
            target = (path.parent / unquote(parts.path)).resolve() if parts.path else path
            if target.is_dir():
                target = target / "index.html"
            if not target.exists():
                broken.append(f"{path.relative_to(site)}: <{tag}> {url}")
            elif parts.fragment and target.suffix == ".html":
                ids = parsed[target].ids if target in parsed else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    broken.append(f"{path.relative_to(site)}: <{tag}> {url} (no such anchor)")
    assert not broken, f"{len(broken)} broken internal references:\n" + "\n".join(broken[:40])


def test_every_demo_has_a_page_and_the_reference_every_model(site: Path) -> None:
    sys.path.insert(0, str(DOCS.parent))
    from dgplate.problems.registry import MODELS
    from dgplate.problems.specs import sections
    from dgplate.schema import options

    demos = sorted((DOCS.parent / "demos").glob("*.py"))
    missing = [
        d.stem for d in demos if not (site / "_generated" / "demos" / f"{d.stem}.html").exists()
    ]
    assert not missing, f"demos without a page: {missing}"
    reference = (site / "_generated" / "problem-files.html").read_text(encoding="utf-8")
    for name in MODELS:
        for _, spec in sections(name):
            for key, _, _ in options(spec):
                assert (
                    f'<code class="docutils literal notranslate"><span class="pre">{key}</span>'
                    in reference
                ), (name, key)


def _browser() -> Any:  # a selenium WebDriver
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver_path = shutil.which("chromedriver")
    if not (chromium and driver_path):
        pytest.fail("needs Debian's chromium and chromium-driver: `make docs-check` installs them")
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1280,1600"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver_path), options=options)


#: JavaScript: the sources of the images of the page that did not load.
_UNLOADED = """return Array.from(document.images)
    .filter(img => !(img.complete && img.naturalWidth > 0)).map(img => img.src);"""


def test_pages_load_in_chromium_without_errors(site: Path) -> None:
    SHOTS.mkdir(parents=True, exist_ok=True)
    browser = _browser()
    failures = []
    try:
        for path in _pages():
            browser.get(path.as_uri())
            errors = [e["message"] for e in browser.get_log("browser") if e["level"] == "SEVERE"]
            unloaded = browser.execute_script(_UNLOADED)
            if errors or unloaded:
                failures.append(f"{path.relative_to(site)}: console {errors}, images {unloaded}")
            if path == site / "index.html":
                boxes = browser.execute_script(
                    "return Array.from(document.images).filter(i => i.src.includes('box_closed')"
                    " && i.naturalWidth > 0 && i.getBoundingClientRect().width > 100).length;"
                )
                assert boxes == 1, "the landing page does not show the box"
                browser.save_screenshot(str(SHOTS / "landing.png"))
            if path.name == "box_folding.html":
                browser.save_screenshot(str(SHOTS / "demo_box_folding.png"))
    finally:
        browser.quit()
    assert not failures, "\n".join(failures[:40])
    assert (SHOTS / "landing.png").stat().st_size > 10_000
