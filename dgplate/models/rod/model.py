"""The rod model: :class:`RodModel` and :func:`build_rod`, which make the rod flow of a spec.

The model is described in the docstring of :mod:`dgplate.models.rod`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from dgplate.compat import Array, Function, Mesh
from dgplate.dg.energy import Energy
from dgplate.dg.self_avoidance import CurveTangentPoint
from dgplate.measure.rod_figures import StepFigures, arc_error, link, shape_figures
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import Model
from dgplate.models.rod.energy import RodData, clamp_measure, energy_split, rod_energy
from dgplate.models.rod.spec import RodSpec, _unit, start_of
from dgplate.models.rod.start import RodStart
from dgplate.solvers.driver import Observer
from dgplate.solvers.flow import FlowSpec, Initial
from dgplate.solvers.rod_flow import RodFlow, RodState, tangent


def exact_arc(s: Array, spec: RodSpec) -> Array:
    """The clamped rod's minimiser for κ ≠ 0: the circular arc (sin κs/κ) t + ((1 − cos κs)/κ) b."""
    t, b = _unit(spec.tangent), _unit(spec.frame)
    k = spec.kappa
    return np.outer(t, np.sin(k * s) / k) + np.outer(b, (1.0 - np.cos(k * s)) / k)


@dataclass
class RodModel(Model):
    """A rod: its mesh, energy and start; run by :class:`RodFlow`."""

    spec: RodSpec
    mesh: Mesh
    data: RodData

    def driver(
        self, flow: FlowSpec, observers: Sequence[Observer], initial: Initial | None
    ) -> RodFlow:
        """The constrained gradient flow of the rod energy from the straight rod (or ``initial``)."""
        spec = self.spec
        start, director = start_of(spec)
        if isinstance(initial, RodStart):
            director = initial.frame
        state = RodState(initial or start, director, spec.clamped_nodes, spec.pinned_nodes)

        params = spec.self_avoidance

        def energy(u: Function, director: Function) -> Energy:
            base = rod_energy(u, director, self.data)
            if params is None:
                return base
            return replace(base, nonlocal_terms=[CurveTangentPoint(u, params, tangent)])

        measures = StepFigures() if spec.ends == "closed" else None
        return RodFlow(self.mesh, spec.degree, energy, flow, state, observers, measures)

    def figures(self, driver: RodFlow) -> dict[str, Any]:
        """Energy split (summing to E_h), length, the end point, the arc error (clamped, κ ≠ 0), Lk."""
        out: dict[str, Any] = energy_split(driver.u, driver.b, self.data)
        spec = self.spec
        if spec.ends == "clamped-free" and spec.kappa != 0.0:
            out.update(arc_error(driver.u, lambda s: exact_arc(s, spec), spec.length))
        center = None if spec.sphere is None else spec.sphere.center
        out.update(shape_figures(driver.u, spec.ends == "closed", center))
        if "writhe" in out:
            out["link"] = link(out["twist_angle"], out["writhe"])
        terms = driver.energy.nonlocal_terms
        if terms:
            out["energy_self_avoidance"] = sum(term.update() for term in terms)
            out["min_distance"] = min(term.min_distance for term in terms)
        # What the named parts leave of E_h: round-off (they are all its terms)
        parts = sum(value for key, value in out.items() if key.startswith("energy_"))
        out["energy_rest"] = driver.evaluate_energy() - parts
        return out

    def picture(self, driver: RodFlow, path: Path, title: str) -> bool:
        """final.png: a tube around u with a stripe along b (the twist); a sphere that confines it."""
        ball = self.spec.sphere
        sphere = None if ball is None else (ball.radius, ball.center)
        from dgplate.io.rod_pictures import plot_rod  # pyvista: 1 s to import

        plot_rod(driver.u, driver.b, path, title, sphere=sphere)
        return True

    def lines(self, driver: RodFlow) -> list[Array]:
        """No extra lines: the picture is the centreline itself."""
        return []


def build_rod(spec: RodSpec, tagged: TaggedMesh) -> RodModel:
    """The rod on its own mesh (:func:`rod_mesh`) and its energy data.

    Args:
        spec: the validated ``[model]`` section.
        tagged: the mesh with its named cell and facet groups (built by :func:`rod_mesh`).

    Returns:
        The model: its energy data, start and figures.
    """
    return RodModel(spec, tagged.mesh, RodData.of(spec, tagged.mesh, clamp_measure(spec, tagged)))
