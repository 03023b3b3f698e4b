"""The public API documents its arguments and results (Google style ``Args:``/``Returns:``).

The list is the API a user calls from Python or a notebook: the package's functions, the
models' build functions and the drivers. A parameter missing from ``Args:`` or a result
without ``Returns:`` fails with the name of the callable.
"""

import importlib
import inspect
from collections.abc import Callable
from typing import Any

import pytest

PUBLIC = [
    "dgplate.problems.runner:run",
    "dgplate.problems.runner:check",
    "dgplate.problems.specs:load_problem",
    "dgplate.problems.specs:problem_from_dict",
    "dgplate.problems.results:load_result",
    "dgplate.models.kirchhoff:build_kirchhoff",
    "dgplate.models.bilayer:build_bilayer",
    "dgplate.models.foundation:build_foundation",
    "dgplate.models.lce:build_lce",
    "dgplate.models.fvk:build_fvk",
    "dgplate.models.rod:build_rod",
    "dgplate.models.thermal:build_thermal",
    "dgplate.solvers.flow:GradientFlow",
    "dgplate.solvers.rod_flow:RodFlow",
    "dgplate.solvers.newton:LoadPath",
    "dgplate.solvers.moving_clamp:MovingClampFlow",
    "dgplate.coupling.thermal_driver:ThermalBilayer",
]


def resolve(name: str) -> Callable[..., Any]:
    module, attr = name.split(":")
    return getattr(importlib.import_module(module), attr)


def missing(obj: Callable[..., Any]) -> list[str]:
    """What the docstring of ``obj`` (a class: its own or its ``__init__``'s) leaves out."""
    target = obj.__init__ if inspect.isclass(obj) else obj
    doc = inspect.getdoc(obj) or ""
    if inspect.isclass(obj):
        doc += "\n" + (inspect.getdoc(target) or "")
    parameters = [
        p.name
        for p in inspect.signature(target).parameters.values()
        if p.name not in ("self", "cls") and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
    ]
    gaps = []
    if parameters and "Args:" not in doc:
        gaps.append("no Args: section")
    args = doc.split("Args:", 1)[1] if "Args:" in doc else ""
    gaps += [
        f"parameter {p!r} not in Args:"
        for p in parameters
        if f"{p}:" not in args and f"{p} (" not in args
    ]
    returns = inspect.signature(obj).return_annotation if not inspect.isclass(obj) else None
    if returns not in (None, "None", inspect.Signature.empty) and "Returns:" not in doc:
        gaps.append("no Returns: section")
    return gaps


@pytest.mark.parametrize("name", PUBLIC)
def test_public_callable_documents_its_arguments_and_result(name):
    gaps = missing(resolve(name))
    assert not gaps, f"{name}: " + "; ".join(gaps)


def test_a_gap_is_caught():
    def undocumented(a: int, b: int) -> int:
        """Add."""
        return a + b

    def documented(a: int) -> int:
        """Twice.

        Args:
            a: a number.

        Returns:
            2a.
        """
        return 2 * a

    assert missing(undocumented) == [
        "no Args: section",
        "parameter 'a' not in Args:",
        "parameter 'b' not in Args:",
        "no Returns: section",
    ]
    assert missing(documented) == []
