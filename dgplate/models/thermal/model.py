"""The thermal bilayer's model: :class:`ThermalModel`, :func:`build_thermal` and the α calibration.

The model is described in the docstring of :mod:`dgplate.models.thermal`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from dgplate import expressions
from dgplate.compat import Mesh
from dgplate.coupling.heat import HeatSolver
from dgplate.coupling.thermal_driver import Measure, Schedule, ThermalBilayer
from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets, Penalty, explicit_quadrature, facet_sets
from dgplate.errors import InputError
from dgplate.measure.analysis import curvature_summary, l1_norms
from dgplate.measure.hinges import (
    ClosureGap,
    EdgePlacement,
    FoldAngles,
    Hinge,
    edge_segments,
    hinge_geometry,
    hinge_strip,
)
from dgplate.measure.thermal_figures import OnShape
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import Model, piecewise_constant
from dgplate.models.self_avoidance import add_tangent_point
from dgplate.models.thermal.energy import (
    anchor_energy,
    aspect_penalty,
    cell_aspect_ratio,
    hinge_penalty,
    region_coefficient,
    thermal_energy,
)
from dgplate.models.thermal.spec import ThermalSpec, is_plain_number
from dgplate.solvers.driver import Observer
from dgplate.solvers.flow import FlowSpec

Initial = Callable[[np.ndarray], np.ndarray]


def calibrate_alpha(
    comm: MPI.Comm,
    width: float,
    n: int,
    m: int,
    theta: float,
    flow_settings: FlowSpec,
    mu_hinge: float = 1.0,
    mu_face: float = 20.0,
    target: float = np.pi / 2,
    max_steps: int = 2000,
    penalty: Penalty | None = None,
    like: Mesh | None = None,
    penalty_length: str = "diameter",
) -> tuple[float, dict[str, Any]]:
    """The coupling α at which one discrete hinge of this mesh folds by ``target`` at θ.

    c·w = target gives α_cw = target / (w θ) (a hinge of width w bent to curvature c = αθ
    turns by c·w). The discrete hinge (m cells across, n along, between two stiff unit
    squares, one anchored) folds a little less, an O(h) discretisation error of the curvature
    jump at the hinge edges. This relaxes that strip at θ with α_cw and corrects α by one
    secant step (the fold angle is linear in α): α = α_cw · target / φ_h. ``penalty`` defaults
    to :func:`hinge_penalty`; ``like`` is passed on to :func:`hinge_strip` (the strip's forms
    then are the model's, compiled once), ``penalty_length`` to its facets (the model's h_e).
    Returns α and the figures of the calibration.
    """
    t0 = time.perf_counter()
    alpha_cw = target / (width * theta)
    tagged = hinge_strip(comm, width, n, m, like)
    facets = facet_sets(tagged, penalty_length=penalty_length)
    # μ before α, as build_thermal and ThermalModel._energy create them: UFL numbers the
    # coefficients of a form in their order of creation, so this order gives the strip's forms
    # the model's signatures (one JIT compilation for both)
    mu = piecewise_constant(tagged, {"left": mu_face, "hinge": mu_hinge, "right": mu_face}, "mu")
    alpha = region_coefficient(tagged, {"hinge": alpha_cw}, "alpha")
    penalty = penalty or hinge_penalty(width, n, m)

    def energy(
        y: dolfinx.fem.Function[np.float64], theta_: dolfinx.fem.Function[np.float64]
    ) -> Energy:
        anchor = anchor_energy(y, tagged, "left", 1000.0)
        return thermal_energy(y, facets, penalty, theta_, alpha, mu, 8, anchor)

    heat = HeatSolver(tagged, 1.0, 1.0, None, theta0=theta)
    strip = ThermalBilayer(facets, 2, energy, heat, flow_settings, Schedule(1.0, max_steps))
    sense = -1 if alpha_cw * theta > 0 else 1  # Z = −αθI bends towards −ν when αθ > 0
    angles = FoldAngles(strip.y, tagged, [Hinge("hinge", "left", "right")], sense=sense)
    result = strip.relax(max_steps)
    phi = angles()["hinge"]
    strip.destroy()
    info = {
        "alpha_cw": alpha_cw,
        "theta": theta,
        "strip_fold_deg": float(np.degrees(phi)),
        "strip_flow_steps": result.steps,
        "strip_converged": result.converged,
        "factor": float(target / phi),
        "seconds": time.perf_counter() - t0,
    }
    return alpha_cw * target / phi, info


def _closure_target(target: list[Any], key: str) -> Callable[[np.ndarray], np.ndarray]:
    """target(ref) for :class:`ClosureGap` from three numbers or formulas in x, y."""

    def evaluate(ref: np.ndarray) -> np.ndarray:
        columns = []
        for i, entry in enumerate(target):
            if is_plain_number(entry):
                value: Any = float(entry)
            else:
                value = expressions.evaluate(str(entry), ref[:, :2], f"{key}[{i}]")
            columns.append(np.broadcast_to(value, (len(ref),)))
        return np.column_stack(columns) if len(ref) else np.zeros((0, 3))

    return evaluate


@dataclass
class ThermalModel(Model):
    """A thermal bilayer on a tagged mesh: what :func:`build_thermal` makes of a spec.

    :meth:`calibrate` solves for α on the hinges when ``model.alpha = 'calibrate'`` (a run
    does, before the driver; ``dgplate check`` does not); :meth:`driver` builds the heat
    solver and the coupled driver; :meth:`figures` reports hinge angles, the closure gap and
    the holds' numbers. The calibration's numbers are kept in :attr:`calibration`.
    """

    spec: ThermalSpec
    tagged: TaggedMesh
    facets: FacetSets
    penalty: Penalty
    mu: Any
    alpha: float | dict[str, Any] = 0.0
    calibration: dict[str, Any] = field(default_factory=dict)
    #: ``model.self_avoidance``'s figures of the shape (None: no self-avoidance)
    tangent_point: Measure | None = None

    @property
    def hinges(self) -> list[Hinge]:
        """The hinges of the spec."""
        return [Hinge(name, *faces) for name, faces in self.spec.hinges.items()]

    def pending_calibration(self) -> str | None:
        """What :meth:`calibrate` has yet to solve for (``model.alpha = 'calibrate'``), or None."""
        if self.spec.alpha != "calibrate" or self.calibration:
            return None
        return (
            "model.alpha = 'calibrate': α on the hinges will be calibrated at run time (a "
            f"strip like the first hinge, relaxed to fold by {self.spec.fold_angle:g}°)"
        )

    def calibrate(self, flow: FlowSpec) -> None:
        """α on the hinges for ``model.alpha = 'calibrate'``: a coupled solve (collective).

        Args:
            flow: the problem's [flow] section (the strip's flow settings).
        """
        if self.pending_calibration() is not None:
            self.alpha = self._calibrate(flow)

    def driver(
        self, flow: FlowSpec, observers: Sequence[Observer], initial: Initial | None
    ) -> ThermalBilayer:
        """The heat-coupled driver; ``flow`` is the problem's [flow] section.

        With ``model.alpha = 'calibrate'``, :meth:`calibrate` comes first; until then α is 0
        on the hinges, which gives the same forms (what ``dgplate check`` builds).
        """
        spec = self.spec
        if flow.l2_metric is False and not self.facets.has_clamped and not spec.anchor:
            raise InputError(
                "flow.l2_metric = false needs clamped facets or model.anchor: otherwise rigid "
                "motions leave the flow's metric singular"
            )
        if not isinstance(spec.alpha, str):
            self.alpha = spec.alpha
        elif not self.calibration:
            self.alpha = {h.name: 0.0 for h in self.hinges}
        energy = self._energy()
        if spec.self_avoidance is not None:
            energy, self.tangent_point = add_tangent_point(energy, spec.self_avoidance)
        return ThermalBilayer(
            self.facets,
            spec.degree,
            energy,
            self._heat_solver(),
            flow,
            spec.schedule.schedule(),
            self._measures(),
            observers,
            initial,
        )

    def _energy(
        self,
    ) -> Callable[[dolfinx.fem.Function[np.float64], dolfinx.fem.Function[np.float64]], Energy]:
        spec, tagged = self.spec, self.tagged
        alpha = region_coefficient(tagged, self.alpha, "model.alpha")
        degree = explicit_quadrature(spec.degree)

        def energy(
            y: dolfinx.fem.Function[np.float64], theta: dolfinx.fem.Function[np.float64]
        ) -> Energy:
            anchor = None
            if spec.anchor:
                anchor = anchor_energy(y, tagged, spec.anchor, spec.anchor_stiffness)
            return thermal_energy(
                y, self.facets, self.penalty, theta, alpha, self.mu, degree, anchor
            )

        return energy

    def _heat_solver(self) -> HeatSolver:
        spec = self.spec
        source = spec.heat_source()
        return HeatSolver(
            self.tagged, spec.kappa, spec.schedule.heat_step, source, spec.heat_degree, spec.theta0
        )

    def _hinge_temperatures(self) -> dict[str, float]:
        """Each hinge's mean temperature at the first hold (the heat equation alone)."""
        spec = self.spec
        probe = self._heat_solver()
        probe.advance_to(spec.schedule.schedule().holds[0])
        temperatures = {h.name: probe.mean(h.name) for h in self.hinges}
        probe.destroy()
        return temperatures

    def _calibrate(self, flow: FlowSpec) -> dict[str, float]:
        """α on the hinges from :func:`calibrate_alpha` on a strip like the first hinge."""
        temperatures = self._hinge_temperatures()
        theta = float(np.mean(list(temperatures.values())))
        first = self.hinges[0]
        geometry = hinge_geometry(self.tagged, first)
        mu = self.spec.mu
        mu_hinge, mu_panel = (mu[first.name], mu[first.inner]) if isinstance(mu, dict) else (mu, mu)
        target = math.radians(self.spec.fold_angle)
        along = max(1, round(geometry.along / geometry.length))  # cells per unit length
        alpha, info = calibrate_alpha(
            self.tagged.comm,
            geometry.width,
            along,
            geometry.across,
            theta,
            flow,
            mu_hinge,
            mu_panel,
            target,
            penalty=self.penalty,
            like=self.tagged.mesh,
            penalty_length=self.spec.penalty_length,
        )
        self.calibration = {
            "alpha_cw": info["alpha_cw"],
            "calibration": info,
            "theta_hinges_at_first_hold": temperatures,
            "hinge_width": geometry.width,
        }
        return {h.name: alpha for h in self.hinges}

    def _sense(self) -> int:
        """+1 or −1: fold angles count positive the way a heated hinge (θ > 0) folds."""
        alpha = self.alpha
        value = alpha.get(self.hinges[0].name, 0.0) if isinstance(alpha, dict) else alpha
        return -1 if value > 0 else 1  # Z = −αθI bends towards −ν when αθ > 0

    def _measures(self) -> list[Measure]:
        spec, tagged = self.spec, self.tagged
        measures: list[Measure] = []
        if spec.hinges:
            hinges, sense = self.hinges, self._sense()

            def angles(y: dolfinx.fem.Function[np.float64]) -> Callable[[], dict[str, float]]:
                fold = FoldAngles(y, tagged, hinges, sense=sense)
                return lambda: {f"angle_{k}": v for k, v in fold.degrees().items()}

            measures.append(OnShape(angles))
        if spec.closure:
            c = spec.closure
            target = _closure_target(c.target, "model.closure.target")

            def gap(y: dolfinx.fem.Function[np.float64]) -> Callable[[], dict[str, float]]:
                closure = ClosureGap(y, tagged, c.edge, c.panel, target)
                return lambda: {"closure_gap": closure()}

            measures.append(OnShape(gap))
        measures += [OnShape(self._placement(e, p)) for e, p in spec.edges.items()]
        if spec.anchor:
            measures.append(OnShape(self._anchor_energy))
        if self.tangent_point is not None:
            measures.append(self.tangent_point)
        return measures

    def _placement(
        self, edge: str, panel: str
    ) -> Callable[[dolfinx.fem.Function[np.float64]], Callable[[], dict[str, float]]]:
        def make(y: dolfinx.fem.Function[np.float64]) -> Callable[[], dict[str, float]]:
            placement = EdgePlacement(y, self.tagged, edge, panel)

            def measure() -> dict[str, float]:
                height, distance = placement()
                return {f"{edge}_height": height, f"{edge}_distance": distance}

            return measure

        return make

    def _anchor_energy(self, y: dolfinx.fem.Function[np.float64]) -> Callable[[], dict[str, float]]:
        spec = self.spec
        form = dolfinx.fem.form(anchor_energy(y, self.tagged, spec.anchor, spec.anchor_stiffness))
        comm = self.tagged.comm
        return lambda: {
            "anchor_energy": float(comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM))
        }

    # -- results ----------------------------------------------------------------------------
    def _hold_label(self, t: float) -> str:
        switches = self.spec.heat_source().switch_times
        if len(switches) == 1 and math.isclose(t, switches[0], rel_tol=1e-12, abs_tol=1e-12):
            return "switch"
        return f"t{t:g}"

    def figures(self, driver: ThermalBilayer) -> dict[str, Any]:
        """Hinge angles, closure gap and placements of the final shape, and more.

        Hinge angles, closure gap and placements of the final shape, the same at each hold
        before the end (``…_at_switch`` for a hold at the source's one switch time, else
        ``…_at_t<time>``), α and the calibration's numbers, principal curvatures, and the L¹
        norms of the final Gaussian curvature and isometry defect.
        """
        out: dict[str, Any] = {"alpha": self.alpha, "alpha_rule": self.spec.alpha}
        out.update(self.calibration)
        final: dict[str, float] = {}
        for measure in driver.measures:
            final.update(measure(driver.y))
        out.update(_named(final, "final"))
        end = self.spec.schedule.end_time
        for record in driver.records:
            if record.hold and not math.isclose(record.time, end, rel_tol=1e-12):
                label = self._hold_label(record.time)
                out.update(_named(record.figures, f"at_{label}"))
                out[f"energy_at_{label}"] = record.energy
                out[f"isometry_defect_at_{label}"] = record.defect
                out[f"converged_at_{label}"] = record.flow_converged
        out["principal_curvatures"] = curvature_summary(driver.y)["principal_curvatures"]
        out.update(l1_norms(driver.y))
        if self.tangent_point is not None:  # the names of the other models' summary.json
            out.update(self.tangent_point(driver.y))
        return out

    def held_shapes(self, driver: ThermalBilayer) -> dict[str, tuple[np.ndarray, str]]:
        """The shapes at the holds before the end, for pictures besides final.png.

        ``at_<label>`` (``at_switch`` for the source's one switch: the closed box) → (the
        values of y, a title); those of a resumed run's earlier runs from its checkpoint.
        """
        end = self.spec.schedule.end_time
        shapes = {}
        for record in driver.records:
            held = driver.held.get(record.step)
            if held is not None and not math.isclose(record.time, end, rel_tol=1e-12):
                title = f"held at t = {record.time:g}: E_h = {record.energy:.4e}"
                shapes[f"at_{self._hold_label(record.time)}"] = (held.x.array.copy(), title)
        return shapes

    def lines(self, driver: ThermalBilayer) -> list[np.ndarray]:
        """The deformed closure edge and tracked edges, on rank 0 ([] elsewhere)."""
        groups = ([self.spec.closure.edge] if self.spec.closure else []) + list(self.spec.edges)
        lines: list[np.ndarray] = []
        for group in dict.fromkeys(groups):
            gathered = self.tagged.comm.gather(edge_segments(driver.y, self.tagged, group))
            lines += [segment for part in gathered or () for segment in part]
        return lines


def _named(figures: dict[str, float], suffix: str) -> dict[str, Any]:
    """summary.json names: hinge angles as one table, the other figures one by one."""
    out: dict[str, Any] = {}
    angles = {k.removeprefix("angle_"): v for k, v in figures.items() if k.startswith("angle_")}
    if angles:
        out[f"hinge_angles_deg_{suffix}"] = angles
    for key, value in figures.items():
        if not key.startswith("angle_"):
            out[f"{key}_{suffix}"] = value
    return out


def _check_groups(spec: ThermalSpec, tagged: TaggedMesh) -> None:
    """Check that every cell and facet group the spec names exists.

    Every cell and facet group the spec names exists (InputError naming the first that
    does not).
    """
    tdim = tagged.mesh.topology.dim
    # (problem-file key, group name): the key begins the error message
    cells = [("model.source_regions", name) for name in spec.source_regions]
    cells += [("model.hinges", name) for name in spec.hinges]
    cells += [(f"model.hinges.{h}", face) for h, faces in spec.hinges.items() for face in faces]
    cells += [(f"model.edges.{edge}", panel) for edge, panel in spec.edges.items()]
    cells += [("model.anchor", spec.anchor)] if spec.anchor else []
    cells += [("model.closure.panel", spec.closure.panel)] if spec.closure else []
    facets_ = [("model.edges", name) for name in spec.edges]
    facets_ += [("model.closure.edge", spec.closure.edge)] if spec.closure else []
    for key, name in cells:
        tagged.tag(name, tdim, key)
    for key, name in facets_:
        tagged.tag(name, tdim - 1, key)


def build_thermal(spec: ThermalSpec, tagged: TaggedMesh) -> ThermalModel:
    """Facets, μ, penalties and checked group names of a thermal problem (collective).

    Args:
        spec: the validated ``[model]`` section.
        tagged: the mesh with its named cell and facet groups.

    Returns:
        The model: its facets, μ, penalties and heating schedule (α is calibrated
        by the driver when ``model.alpha`` is ``calibrate``).
    """
    _check_groups(spec, tagged)
    facets = facet_sets(tagged, clamped=spec.clamped, penalty_length=spec.penalty_length)
    mu = piecewise_constant(tagged, spec.mu, "model.mu")
    if spec.alpha != "calibrate":
        region_coefficient(tagged, spec.alpha, "model.alpha")  # unknown groups: an error now
    aspect = spec.penalty_aspect
    aspect = cell_aspect_ratio(tagged) if aspect == "mesh" else float(aspect)
    penalty = aspect_penalty(aspect, spec.penalty) if aspect > 1 else spec.penalty
    return ThermalModel(spec, tagged, facets, penalty, mu)
