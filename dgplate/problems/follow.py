"""``dgplate.follow``: a problem's equilibrium path by arclength continuation, as a :class:`Branch`.

The Python face of the ``[path]`` section (docs/path_following.md): ``follow(problem, ds=0.05)``
is ``run`` with ``path.method = "arclength"`` and the given ``path.*`` settings, and returns
the points of the path, its folds and bifurcations and the run's :class:`Result`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mpi4py import MPI

from dgplate.errors import InputError
from dgplate.problems.result import Result
from dgplate.problems.runner import Initial, run
from dgplate.problems.specs import Problem, problem_from_dict, sections


@dataclass
class Branch:
    """What :func:`follow` returns: the followed path and the run that traced it.

    ``points`` are the rows of ``history.csv`` (load factor, energy, stability index, tangent,
    kind, probes); ``folds`` and ``bifurcations`` the load factors of the located special
    points; ``result`` the run's :class:`Result` (summary, final state, folder).
    """

    result: Result

    @property
    def points(self) -> list[dict[str, Any]]:
        """The points of the path in order, one dict per row of ``history.csv``."""
        return self.result.history

    @property
    def load_factors(self) -> list[float]:
        """The load factor λ of every point."""
        return [float(point["load_factor"]) for point in self.points]

    @property
    def stability_indices(self) -> list[int]:
        """The number of negative Hessian eigenvalues at every point (0: stable)."""
        return [int(point["stability_index"]) for point in self.points]

    @property
    def folds(self) -> list[float]:
        """The load factors of the located folds (limit points)."""
        return list(self.result.get("folds", []))

    @property
    def bifurcations(self) -> list[float]:
        """The load factors of the located simple bifurcations."""
        return list(self.result.get("bifurcations", []))

    @property
    def special_points(self) -> list[dict[str, Any]]:
        """The rows of the located special points and of a branch switch."""
        return list(self.result.get("special_points", []))

    def __repr__(self) -> str:
        """One line: the points, the folds and bifurcations, the folder."""
        folder = f", folder={str(self.result.folder)!r}" if self.result.folder else ""
        return (
            f"Branch({self.result.get('problem', '?')}: {len(self.points)} points, "
            f"folds at {_shown(self.folds)}, bifurcations at {_shown(self.bifurcations)}{folder})"
        )

    def _repr_html_(self) -> str:
        """Jupyter's view: the run's table and picture, and the bifurcation diagram."""
        import base64

        out = self.result._repr_html_()
        chart = self.result.folder / "branch.png" if self.result.folder else None
        if chart is not None and chart.is_file():
            data = base64.b64encode(chart.read_bytes()).decode("ascii")
            out += f"<img src='data:image/png;base64,{data}' style='max-width:640px'>"
        return out


def _shown(values: list[float]) -> str:
    return "[" + ", ".join(f"{value:.6g}" for value in values) + "]"


def follow(
    problem: Problem,
    out: str | Path | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    initial: Initial | str | dict[str, Any] | None = None,
    force: bool = False,
    resume: bool = False,
    **path: Any,
) -> Branch:
    """Follow ``problem``'s equilibrium path in its load factor through folds and bifurcations.

    Args:
        problem: a validated problem of a model with a ``[path]`` section (FvK, Kirchhoff, bilayer, foundation).
        out: the output folder (default: ``output.dir``, else ``out/<problem name>``).
        comm: the ranks that solve it (collective).
        initial: the start at λ = 0, as for :func:`dgplate.run`.
        force: write into a folder of a user's files (deleting none of them).
        resume: continue the path from the checkpoint in the output folder.
        **path: settings of the ``[path]`` section (``ds``, ``ds_max``, ``ds_min``, ``steps``,
            ``lambda_max``, ``switch``, ``parameter``; a plate's ``lambda_start``);
            ``method`` is ``"arclength"``.

    Returns:
        The :class:`Branch`: its points, folds, bifurcations and the run's result.

    Raises:
        InputError: a model without path following, a ``method``, or a bad ``[path]`` setting
            (named).
    """
    model = problem.model.name
    if "path" not in [name for name, _ in sections(model)]:
        raise InputError(
            f"dgplate.follow: path following is not available for the {model} model "
            "(it is for fvk, kirchhoff, bilayer and foundation); use dgplate.run"
        )
    if "method" in path:
        raise InputError("path.method: dgplate.follow always follows by arclength; give no method")
    settings = {f"path.{key}": value for key, value in path.items()}
    followed = problem_from_dict(problem.raw, problem.name, settings | {"path.method": "arclength"})
    return Branch(run(followed, out, comm, initial, force=force, resume=resume))
