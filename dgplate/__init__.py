"""dgplate: large bending deformations of thin plates by interior-penalty dG in DOLFINx.

The Python API in two calls::

    import dgplate

    problem = dgplate.load_problem("demos/problems/vertical_load.toml", {"mesh.cells": [8, 8]})
    result = dgplate.run(problem, out="out/vertical_load")
    result["energy"], result.shape  # summary.json's numbers and the final deformation

``run`` does what ``dgplate run`` does: it validates, writes the same outputs and returns a
:class:`~dgplate.problems.result.Result`. ``check(problem)`` does what ``dgplate check`` does:
it validates everything ``run`` would (output folder, mesh, model, start) without solving.
``converge(problem, levels=4)`` runs it on successively refined meshes and extrapolates its
figures (a :class:`~dgplate.problems.converge.ConvergenceStudy`).
``follow(problem, ds=0.05)`` follows an FvK problem's equilibrium path through folds and
bifurcations by arclength continuation (a :class:`~dgplate.problems.follow.Branch`).
``load_result(folder)`` reads a finished run back (summary, history, final state).
"""

from typing import TYPE_CHECKING, Any

from mpi4py import MPI  # noqa: F401  (MPI must be initialised before dolfinx is imported)

from dgplate.errors import DgplateError, InputError, SolverError, UnsupportedVersionError

if TYPE_CHECKING:
    from dgplate.problems.converge import ConvergenceStudy, converge
    from dgplate.problems.follow import Branch, follow
    from dgplate.problems.result import Result
    from dgplate.problems.results import load_result
    from dgplate.problems.runner import check, run
    from dgplate.problems.specs import Problem, load_problem, problem_from_dict

__version__ = "0.1.0"

_LAZY = {
    "load_problem": "dgplate.problems.specs",
    "problem_from_dict": "dgplate.problems.specs",
    "Problem": "dgplate.problems.specs",
    "run": "dgplate.problems.runner",
    "check": "dgplate.problems.runner",
    "converge": "dgplate.problems.converge",
    "ConvergenceStudy": "dgplate.problems.converge",
    "follow": "dgplate.problems.follow",
    "Branch": "dgplate.problems.follow",
    "Result": "dgplate.problems.result",
    "load_result": "dgplate.problems.results",
}


def __getattr__(name: str) -> Any:
    """Import the API on first use, so that ``import dgplate`` does not load DOLFINx."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'dgplate' has no attribute {name!r}")


__all__ = [
    "Branch",
    "ConvergenceStudy",
    "DgplateError",
    "InputError",
    "Problem",
    "Result",
    "SolverError",
    "UnsupportedVersionError",
    "__version__",
    "check",
    "converge",
    "follow",
    "load_problem",
    "load_result",
    "problem_from_dict",
    "run",
]
