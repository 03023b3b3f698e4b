"""Every picture of docs/img and the command that draws it from a run.

    python docs/_ext/figures.py --list            # each picture, its command, its minutes
    python docs/_ext/figures.py NAME [NAME ...]   # run their commands, copy the pictures

The pictures of docs/img/demos are the demos' own, redrawn by ``demo_images.py``. Every
other picture is a key of :data:`FIGURES` (drawn by a run of a demo, a problem file or a
study, whose output is copied into docs/img) or of :data:`KEPT` (an older picture kept with the
reason it has no command yet): ``tests/app/test_docs_figures.py`` fails on a picture in neither,
so no picture is added by hand. A command writes into ``{out}``, a scratch folder; ``copy``
names the files of ``{out}`` that become pictures (a command that writes the picture itself
gets ``{img}``, the docs/img folder, instead).
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
IMG = ROOT / "docs" / "img"


@dataclass(frozen=True)
class Figure:
    """How pictures of docs/img are drawn.

    Args:
        command: the arguments after ``python`` (``{out}``: a scratch folder, ``{img}``:
            docs/img), run from the repository's root.
        copy: picture of docs/img → the file of ``{out}`` copied to it (none: the command
            writes into ``{img}`` itself).
        minutes: about how long the command takes on two cores.
        section: (page, marker, file of ``{out}``): the file's text also replaces the page's
            section between ``<!-- marker:begin -->`` and ``<!-- marker:end -->`` (the tables
            drawn with the picture).
    """

    command: tuple[str, ...]
    copy: dict[str, str] = field(default_factory=dict)
    minutes: float = 1.0
    section: tuple[str, str, str] | None = None


def _words(line: str) -> tuple[str, ...]:
    """The arguments of a command line (no quoting: none of them has spaces)."""
    return tuple(line.split())


def _run(problem: str, *sets: str) -> tuple[str, ...]:
    """``dgplate run demos/problems/<problem>.toml --out {out}`` with ``--set`` overrides."""
    overrides = [arg for value in sets for arg in ("--set", value)]
    return ("-m", "dgplate", "run", f"demos/problems/{problem}.toml", "--out", "{out}", *overrides)


def _demo(name: str, picture: str, *options: str) -> tuple[str, ...]:
    """``demos/<name>.py OPTIONS --out {out} --figure {img}/<picture>`` (its final picture)."""
    return (f"demos/{name}.py", *options, "--out", "{out}", "--figure", "{img}/" + picture)


def _paper_sizes(case: str) -> tuple[str, ...]:
    """``benchmarks/paper_sizes.py --cases <case>``, which copies its pictures into docs/img.

    It also records the run in benchmarks/results/paper_sizes.json and rewrites the tables of
    docs/performance.md and docs/box.md from it.
    """
    return ("benchmarks/paper_sizes.py", "--cases", case, "--pictures", "{img}")


#: name → how it is drawn; a command drawing several pictures is one entry (its first picture)
FIGURES: dict[str, Figure] = {
    "box_angles.png": Figure(_paper_sizes("box_paper"), minutes=7),
    "microcapsule.png": Figure(_paper_sizes("microcapsule_file"), minutes=2),
    "bilayer_i_shape.png": Figure(_paper_sizes("i_shape_paper"), minutes=3),
    "bilayer_i_shape_coarse.png": Figure(
        _run("bilayer_i_shape"), {"bilayer_i_shape_coarse.png": "final.png"}, 1
    ),
    "bilayer_hole.png": Figure(_run("bilayer_hole"), {"bilayer_hole.png": "final.png"}, 2),
    "bilayer_partial_clamp.png": Figure(
        _run("bilayer_partial_clamp"), {"bilayer_partial_clamp.png": "final.png"}, 3
    ),
    "bilayer_corner_clamp.png": Figure(
        _run("bilayer_corner_clamp"), {"bilayer_corner_clamp.png": "final.png"}, 1
    ),
    "bilayer_anisotropic_Z1.png": Figure(
        _run("bilayer_anisotropic"), {"bilayer_anisotropic_Z1.png": "final.png"}, 2
    ),
    "bilayer_anisotropic_Z2.png": Figure(
        _run("bilayer_anisotropic", "model.Z=[[-3, 2], [2, -3]]"),
        {"bilayer_anisotropic_Z2.png": "final.png"},
        2,
    ),
    "bilayer_aspect_ratios.png": Figure(
        _words(
            "demos/bilayer_aspect_ratios.py --ratios 0.5 1 1.75 2.5 --curvatures 1 2 5 "
            "--out {out} --figure {img}/bilayer_aspect_ratios.png"
        ),
        minutes=4,
    ),
    "converge_bilayer_cylinder.png": Figure(
        _words(
            "-m dgplate converge demos/problems/bilayer_cylinder.toml --levels 4 "
            "--set mesh.cells=[8,4] --out {out}"
        ),
        {"converge_bilayer_cylinder.png": "converge.png"},
        3,
        section=("docs/converge.md", "converge_cylinder", "converge.md"),
    ),
    "lce_strip.png": Figure(_demo("lce_strip", "lce_strip.png", "--paper")),
    "obstacle_contact_zone.png": Figure(
        _demo("obstacle_contact_zone", "obstacle_contact_zone.png"), minutes=2
    ),
    "self_avoiding_compressed_strip.png": Figure(
        _demo("self_avoiding_compressed_strip", "self_avoiding_compressed_strip.png")
    ),
    "self_avoiding_compressed_strip_rho0.png": Figure(
        _run(
            "self_avoiding_compressed_strip",
            "model.self_avoidance.rho=0.0",
            "model.self_avoidance.max_redo=0",
        ),
        {"self_avoiding_compressed_strip_rho0.png": "final.png"},
    ),
    "twist_strip.png": Figure(_demo("twist_strip", "twist_strip.png", "--paper")),
    "buckling_strip.png": Figure(
        _demo("buckling_strip", "buckling_strip.png", *_words("--cells 32 4 --rate 1e-3")),
        minutes=3,
    ),
    "self_avoiding_trefoil_ribbon.png": Figure(
        _demo("self_avoiding_trefoil_ribbon", "self_avoiding_trefoil_ribbon.png"), minutes=2
    ),
    "fvk_load_deflection.png": Figure(
        _demo("fvk_square", "fvk_load_deflection.png", "--paper"), minutes=3
    ),
    "creases_straight_fold.png": Figure(_demo("straight_fold", "creases_straight_fold.png")),
    "fvk_turned_strip_branch.png": Figure(
        _demo("fvk_turned_strip", "fvk_turned_strip_branch.png", "--paper")
    ),
    "fvk_snap_through.png": Figure(_demo("fvk_snap_through", "fvk_snap_through.png", "--paper")),
    "turned_strip_branch.png": Figure(_demo("turned_strip", "turned_strip_branch.png", "--paper")),
    "fvk_heated_disc.png": Figure(
        _demo("fvk_heated_disc", "fvk_heated_disc.png", "--paper"), minutes=2
    ),
    "creases_bilayer_cones.png": Figure(
        _words("demos/bilayer_crease.py --out {out}"),
        {
            "creases_bilayer_cones.png": "order2/final.png",
            "creases_bilayer_chords.png": "order1/final.png",
        },
    ),
    "creases_annulus.png": Figure(_demo("annulus_fold", "creases_annulus.png")),
    "rod_trefoil.png": Figure(
        _words("demos/rod_trefoil.py --paper --out {out}"),
        {"rod_trefoil.png": "rho_0.001/final.png", "rod_trefoil_stages.gif": "stages.gif"},
        3,
    ),
}

#: Pictures drawn together with another one (the key of FIGURES whose command draws them).
ALSO_DRAWN = {
    "box_closed.png": "box_angles.png",
    "box_folding.png": "box_angles.png",
    "creases_bilayer_chords.png": "creases_bilayer_cones.png",
    "rod_trefoil_stages.gif": "rod_trefoil.png",
}

_SETTINGS = "a run's picture whose settings are not recorded"
#: name → why it is an older picture without a command yet (each is to get one)
KEPT: dict[str, str] = {
    "creases_curved_fold.png": _SETTINGS,
    "fvk_cone_before.png": "put together from fvk_cone.py runs by hand",
    "fvk_cone_before_after_h0.07.png": "put together from fvk_cone.py runs by hand",
    "fvk_cone_before_after_h0.15.png": "put together from fvk_cone.py runs by hand",
    "fvk_cone_facet_normal_h0.07.png": "put together from fvk_cone.py runs by hand",
    "lce_perversion.png": "the run of docs/lce.md's table (98 steps, E_h 0.4095); the file now "
    "converges in 19 steps at E_h 0.4248, so the table and the picture are to be redone together",
    "rod_twisted_circle.png": "rod_twisted_circle.py's run, its last frame",
    "rod_twisted_circle.gif": "rod_twisted_circle.py --gif (about an hour)",
    "rod_twisted_circle_start.png": _SETTINGS,
    "rod_sphere_study": "rod_sphere_study.py --pictures (hours; docs/rods.md gives each run)",
    "self_avoiding_min_distance.png": "tangent_point.py --plot from the histories of three runs",
}


def pictures() -> list[str]:
    """The pictures of docs/img outside demos/: file names, and folders of pictures by name."""
    found = sorted(p.name for p in IMG.iterdir() if p.name != "demos")
    return found


def markers(name: str) -> tuple[str, str]:
    """The opening and closing markers of a page's section ``name``."""
    return f"<!-- {name}:begin -->", f"<!-- {name}:end -->"


def write_section(out: Path, page: str, name: str, source: str) -> None:
    """Put the text of ``out/source`` between the markers of the section ``name`` of ``page``."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from pages import write_between  # benchmarks/pages.py

    begin, end = markers(name)
    text = (out / source).read_text().strip()
    write_between(ROOT / page, begin, end, f"{begin}\n{text}\n{end}")
    print(f"  {source} → {page} ({name})", flush=True)


def run(name: str) -> None:
    """Run the command of the picture ``name`` and copy what it drew into docs/img."""
    figure = FIGURES[ALSO_DRAWN.get(name, name)]
    # the scripts import this checkout's dgplate, not an installed one
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "out"
        command = [a.format(out=out, img=IMG) for a in figure.command]
        print(f"{name}: python {shlex.join(command)}", flush=True)
        env = dict(os.environ, PYTHONPATH=path)
        subprocess.run([sys.executable, *command], cwd=ROOT, env=env, check=True)
        for picture, source in figure.copy.items():
            shutil.copyfile(out / source, IMG / picture)
            print(f"  {source} → docs/img/{picture}", flush=True)
        if figure.section is not None:
            write_section(out, *figure.section)


def main(argv: list[str]) -> int:
    """``--list`` the pictures, or draw those named."""
    if not argv or argv == ["--list"]:
        for name, figure in FIGURES.items():
            print(f"{name} ({figure.minutes:g} min): python {shlex.join(figure.command)}")
        for name, drawn_by in ALSO_DRAWN.items():
            print(f"{name}: drawn by the command of {drawn_by}")
        for name, reason in KEPT.items():
            print(f"{name}: kept ({reason})")
        return 0
    unknown = [name for name in argv if name not in FIGURES and name not in ALSO_DRAWN]
    if unknown:
        print(f"figures.py: no command draws {', '.join(unknown)} (see --list)", file=sys.stderr)
        return 2
    for name in argv:
        run(name)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
