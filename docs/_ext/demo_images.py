"""Run demos at their default (small) size and keep each one's picture for the site.

    python docs/_ext/demo_images.py [DEMO ...]      (default: every demo in demos/)

Each demo runs with ``--out`` in a temporary folder; its picture (a PNG it wrote at the top of
its output folder, else the first ``final.png`` below it) is copied to
``docs/img/demos/<demo>.png``, which the demo's page shows.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
IMAGES = ROOT / "docs" / "img" / "demos"
#: Demos whose page shows a picture of docs/img instead: the box's page shows the closed box
#: of its --paper run (at_switch.png, docs/_ext/figures.py); the demo's final.png is the net
#: open again after cooling.
CURATED = {"box_folding": "box_closed.png"}


def picture(out: Path) -> Path | None:
    """The demo's main picture in its output folder."""
    top = sorted(out.glob("*.png"))
    if top:
        return top[0]
    finals = sorted(out.rglob("final.png"))
    return finals[0] if finals else None


def main(names: list[str]) -> int:
    """Run the demos named (all by default) and copy their pictures."""
    demos = [ROOT / "demos" / f"{n}.py" for n in names] or sorted((ROOT / "demos").glob("*.py"))
    IMAGES.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    failed = []
    for demo in demos:
        if demo.stem in CURATED:
            shutil.copyfile(IMAGES.parent / CURATED[demo.stem], IMAGES / f"{demo.stem}.png")
            continue
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "out"
            done = subprocess.run(
                [sys.executable, str(demo), "--out", str(out)], env=env, capture_output=True
            )
            found = picture(out) if done.returncode == 0 else None
            if found is None:
                failed.append(demo.stem)
                print(f"{demo.stem}: no picture (exit {done.returncode})")
                continue
            shutil.copyfile(found, IMAGES / f"{demo.stem}.png")
            print(f"{demo.stem}: {found.relative_to(out)} → docs/img/demos/{demo.stem}.png")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
