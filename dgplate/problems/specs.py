"""Problem descriptions: TOML files with the sections [mesh], [model], [flow], [output].

A model whose driver has settings of its own adds their section (FvK's [newton]); a plate in
physical units adds [material] (:mod:`dgplate.problems.material`).

``load_problem(path, overrides)`` reads a file, applies ``--set dotted.key=value`` overrides and
validates every section before anything is computed or written. The model section is checked
by the model named in ``model.name`` (see :mod:`dgplate.problems.registry`).
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from dgplate.errors import InputError, read_user_text
from dgplate.problems.material import MODELS_WITH_MATERIAL, Material, MaterialSpec, with_material
from dgplate.schema import Check, driver_sections, from_dict, option, require_finite
from dgplate.solvers.flow import FlowSpec

SECTIONS = ("mesh", "model", "flow", "output", "material")


@dataclass
class MeshSpec:
    """The [mesh] section: a built-in rectangle or a gmsh .geo file."""

    type: str = option(
        "rectangle", "'rectangle' (built-in) or 'gmsh' (a .geo file)", choices=("rectangle", "gmsh")
    )
    corners: list[list[float]] = option(
        [[0.0, 0.0], [1.0, 1.0]],
        "rectangle: [[xmin, ymin], [xmax, ymax]]",
        length=2,
        each=Check(length=2),
    )
    cells: list[int] = option(
        [16, 16], "rectangle: number of cells in x and y", length=2, each=Check(ge=1)
    )
    cell_type: str = option(
        "quadrilateral",
        "rectangle: 'quadrilateral' or 'triangle'",
        choices=("quadrilateral", "triangle"),
    )
    diagonal: str = option(
        "right",
        "rectangle with triangles: 'left', 'right' or 'crossed'",
        choices=("left", "right", "crossed"),
    )
    file: str = option("", "gmsh: a .geo file, as a path or a name in meshes/")
    parameters: dict[str, float] = option({}, "gmsh: DefineConstant overrides, e.g. {h = 0.1}")
    recombine: bool = option(False, "gmsh: recombine triangles into quadrilaterals")

    def __post_init__(self) -> None:
        if self.type == "gmsh" and not self.file:
            raise InputError("mesh.file is required when mesh.type = 'gmsh'")
        gmsh_only = {"file": self.file, "parameters": self.parameters, "recombine": self.recombine}
        unused = [key for key, value in gmsh_only.items() if value and self.type == "rectangle"]
        if unused:
            raise InputError(
                f"mesh.{unused[0]} has no effect with mesh.type = 'rectangle' (a gmsh key); "
                "remove it, or set mesh.type = 'gmsh'"
            )
        (x0, y0), (x1, y1) = self.corners
        if self.type == "rectangle" and not (x1 > x0 and y1 > y0):
            raise InputError(
                f"mesh.corners must have xmax > xmin and ymax > ymin, got {self.corners!r}"
            )


@dataclass
class OutputSpec:
    """The [output] section: where results go and which files are written."""

    dir: str = option("", "output directory (default out/<problem name>); --out overrides it")
    vtx: bool = option(True, "write a VTX time series (ParaView) of the deformation")
    every: int = option(1, "write the time series every n steps (the final state always)", ge=1)
    png: bool = option(True, "render final.png off-screen, and history.png (the run step by step)")
    color_by: str = option(
        "curvature",
        "colour of final.png: 'curvature' (|D²y|), 'defect' or 'gauss' (K, the Gaussian curvature)",
        choices=("curvature", "defect", "gauss"),
    )
    progress: int | Literal["auto"] = option(
        "auto",
        "progress lines on rank 0, each with the time elapsed and an estimate of the time left: 'auto' (the first step, then a line once both a second and 10 steps have passed since the last, or 10 s, and the last step), n (every n-th step) or 0 (none); the final converged / NOT converged line (a path's: path ended / path STOPPED) is always printed",
        ge=0,
    )
    frames_every: int = option(
        0,
        "render a picture of the shape (as final.png) at the start, every n steps and at the end into frames/, and assemble them into <name>.gif (0: none)",
        ge=0,
    )


@dataclass
class Problem:
    """A validated problem: every section as a spec, and the input it came from."""

    name: str
    mesh: MeshSpec
    model: Any  # the model's own spec dataclass
    flow: FlowSpec
    output: OutputSpec
    raw: dict[str, Any]  # the validated input, overrides applied (recorded in summary.json)
    material: Material | None = None  # the physical scales, when [material] is given

    def identity(self) -> dict[str, Any]:
        """What ties a checkpoint to this problem (:func:`dgplate.io.checkpoint.identity`).

        With a gmsh mesh it covers the .geo file's text too (its SHA-256): an edited file is
        another mesh, whose cells a checkpoint of the old one does not describe.
        """
        import hashlib

        from dgplate.io.checkpoint import MESH_FILE_HASH, identity

        data = dict(self.raw)
        if self.mesh.type == "gmsh" and "mesh" in data:
            from dgplate.mesh.tagged import resolve_geo

            text = resolve_geo(self.mesh.file).read_bytes()
            data[MESH_FILE_HASH] = hashlib.sha256(text).hexdigest()
        return identity(data)


_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
_BARE = re.compile(r"^[A-Za-z_][A-Za-z0-9_./+-]*$")


def parse_override(text: str) -> tuple[list[str], Any]:
    """``'flow.tau=0.1'`` → (['flow', 'tau'], 0.1). Values are TOML; bare words are strings."""
    key, equals, value = (part.strip() for part in text.partition("="))
    problem = (
        "expected dotted.key=value"
        if not equals
        else "the key must be section.name, e.g. flow.tau"
        if not _KEY.match(key) or "." not in key
        else "no value after '='"
        if value == ""
        else ""
    )
    if problem:
        raise InputError(f"malformed --set {text!r}: {problem}")
    try:
        parsed = tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError as err:
        if _BARE.match(value) and value not in ("true", "false"):
            parsed = value
        else:
            raise InputError(f"malformed --set {text!r}: {err}") from None
    return key.split("."), parsed


Overrides = Sequence[str] | Mapping[str, Any]


def apply_overrides(data: dict[str, Any], overrides: Overrides) -> dict[str, Any]:
    """Set dotted keys of ``data`` from ``--set`` texts or Python values.

    Set dotted keys of ``data``: ``["flow.tau=0.1"]`` (``--set`` texts, values in TOML) or
    ``{"flow.tau": 0.1, "mesh.cells": [32, 32]}`` (Python values).
    """
    if isinstance(overrides, str):  # one --set text
        overrides = [overrides]
    if isinstance(overrides, Mapping):
        items = [(_dotted(key), _plain(value)) for key, value in overrides.items()]
    else:
        items = [parse_override(text) for text in overrides]
    for path, value in items:
        node = data
        for part in path[:-1]:
            child = node.setdefault(part, {})
            if not isinstance(child, dict):
                raise InputError(f"override {'.'.join(path)}: {part} is not a table")
            node = child
        node[path[-1]] = value
    return data


def _plain(value: Any) -> Any:
    """A Python value as TOML would give it (a copy).

    Tuples and NumPy arrays as lists (``(32, 32)`` for cells), NumPy scalars as Python
    numbers (``np.int64(32)`` is an integer, ``np.float64`` a float, ``np.bool_`` a bool).
    """
    import numpy as np

    if isinstance(value, np.ndarray | np.generic):
        value = value.tolist()
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    return value


def _dotted(key: Any) -> list[str]:
    if not isinstance(key, str) or not _KEY.match(key) or "." not in key:
        raise InputError(f"override key {key!r} must be section.name, e.g. 'flow.tau'")
    return key.split(".")


def load_problem(path: str | Path, overrides: Overrides = ()) -> Problem:
    """Read, override and validate a problem file. Raises ``InputError`` on any bad input.

    Args:
        path: the TOML problem file.
        overrides: ``{"mesh.cells": [32, 32]}`` (Python values) or ``["mesh.cells=[32, 32]"]``
            (the CLI's ``--set`` texts).

    Returns:
        The validated problem, named after the file's stem.
    """
    path = Path(path)
    try:
        data = tomllib.loads(read_user_text(path, "problem file"))
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: invalid TOML: {err}") from None
    return problem_from_dict(data, path.stem, overrides)


def problem_from_dict(data: dict[str, Any], name: str, overrides: Overrides = ()) -> Problem:
    """Validate a problem given as a dict (the Python API's entry point).

    Args:
        data: the sections, as a problem file's tables (NumPy scalars are taken as numbers).
        name: the problem's name: a plain name (the default output folder is out/<name>).
        overrides: as for :func:`load_problem`.

    Returns:
        The validated problem.
    """
    if not isinstance(data, Mapping):
        raise InputError(f"a problem is a dict of sections, got {type(data).__name__}")
    _check_name(name)

    from dgplate.problems.registry import MODELS, model_spec

    data = apply_overrides(_plain(data), overrides)
    if not data:
        raise InputError(
            f"the problem {name!r} is empty: give at least [model] (`dgplate schema` prints "
            "every key and its default)"
        )
    for section in data:
        require_finite(data[section], section)
    material, model_table = with_material(data)
    model = model_spec(model_table, data)
    known = [*SECTIONS, *(name for name, _ in driver_sections(type(model)))]
    for section in data:
        if section not in known:
            owners = [
                repr(m)
                for m, entry in MODELS.items()
                if section in (s for s, _ in driver_sections(entry.spec))
                and "" not in entry.ignored_keys(section)
            ]
            whose = f"; [{section}] is for model.name = {' or '.join(owners)}" if owners else ""
            raise InputError(f"unknown section [{section}] (known: {', '.join(known)}){whose}")
    mesh = from_dict(MeshSpec, data.get("mesh"), "mesh")
    flow = from_dict(FlowSpec, MODELS[model.name].flow_table(data.get("flow")), "flow")
    output = from_dict(OutputSpec, data.get("output"), "output")
    if (
        flow.l2 is False
        and not getattr(model, "clamped", True)
        and not getattr(model, "anchor", "")
    ):
        raise InputError(
            "model.clamped is empty but flow.l2_metric = false: without clamped faces (or an "
            "anchor) the metric needs the L² product (rigid motions); set flow.l2_metric = 'auto'"
        )
    _check_space(model, flow)
    return Problem(name, mesh, model, flow, output, data, material)


def _check_space(model: Any, flow: FlowSpec) -> None:
    """A continuous y (``model.space = 'c0'``) only with the flow it converges with.

    Its step systems are singular at a flat state; the fixed-τ flow and the trust region's SQP
    steps then left the cylinder test far from its minimiser (docs/accuracy.md).
    """
    if getattr(model, "continuous", False) and not (
        flow.adaptive_tau and flow.step_control == "defect_bound"
    ):
        raise InputError(
            "model.space = 'c0' needs flow.adaptive_tau = true and flow.step_control = "
            "'defect_bound' (the flows it converges with: docs/accuracy.md)"
        )


def _check_name(name: object) -> None:
    """A problem's name must be a plain file name: it names the folder out/<name>."""
    if (
        not isinstance(name, str)
        or name.strip() in ("", ".", "..")
        or any(char in name for char in "/\\\0")
    ):
        raise InputError(
            f"the problem name must be a plain name (no '/', '\\', not '..'): it names the "
            f"default output folder out/<name>, got {name!r}"
        )


def sections(model: str) -> list[tuple[str, type]]:
    """The sections of a problem file of model ``model`` and their spec dataclasses.

    What ``dgplate schema --model NAME`` prints and the documentation's reference lists.
    """
    from dgplate.problems.registry import MODELS

    entry = MODELS[model]
    mesh = [] if entry.mesh else [("mesh", MeshSpec)]  # a rod builds its own mesh
    drivers = driver_sections(entry.spec)
    every = [*mesh, ("model", entry.spec), *drivers, ("flow", FlowSpec), ("output", OutputSpec)]
    if model in MODELS_WITH_MATERIAL:
        every.append(("material", MaterialSpec))
    # a section the model ignores as a whole (FvK's [flow]) is not part of its files
    return [(name, spec) for name, spec in every if "" not in entry.ignored_keys(name)]
