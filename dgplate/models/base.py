"""The one model shape: what a registered model builds from its spec and the mesh.

A model is an energy written once in UFL plus what its driver needs. :class:`Model` is the
protocol the runner sees; :class:`PlateModel` is the shape of every isometry-constrained plate
(Kirchhoff, bilayer, foundation, …): facets, degree and the energy of the deformation, run by the
constrained gradient flow, or, when its clamped data move along a path in α
(:class:`DataPath`), by the flow staged in α (:mod:`dgplate.solvers.moving_clamp`). Models
with another state or driver (FvK: Newton over a load schedule; thermal: heat steps coupled to
the flow) implement :class:`Model` themselves.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal, Protocol

import numpy as np
import ufl
from ufl.core.expr import Expr

from dgplate import expressions, values
from dgplate.compat import Array, Constant, Function, Mesh
from dgplate.dg.energy import Energy
from dgplate.dg.forms import FacetSets
from dgplate.errors import InputError, SolverError
from dgplate.io.output import print0
from dgplate.measure.alignment import kabsch
from dgplate.measure.analysis import l1_norms
from dgplate.measure.creases import crease_polylines, fold_angle_summary
from dgplate.measure.prestrain import gauss_curvature_figures
from dgplate.measure.probes import central_probe, height
from dgplate.mesh.tagged import TaggedMesh
from dgplate.schema import REQUIRED, Check, option
from dgplate.solvers.constrained_path import (
    ConstrainedProblem,
    constrained_branch_path,
    constrained_problem,
)
from dgplate.solvers.constraint import IsometryDefect
from dgplate.solvers.continuation import BranchPath, PathSettings
from dgplate.solvers.driver import Driver, Observer
from dgplate.solvers.flow import FlowSpec, GradientFlow, Initial
from dgplate.solvers.moving_clamp import AlphaSchedule, MovingClampFlow, MovingClampSpec
from dgplate.solvers.step_system import NULL_PIVOTS

__all__ = [
    "ArcLengthPath",
    "BoundaryData",
    "DataPath",
    "FlowStart",
    "Initial",
    "Model",
    "PlateModel",
    "clamped_data",
    "continuation_path",
    "continuation_schedule",
    "flat_identity",
    "mentions",
    "piecewise_constant",
]


class Model(Protocol):
    """What the runner needs of a model (all methods collective).

    ``figures`` and ``lines`` take the driver that :meth:`driver` returned, whose type each
    model knows (a protocol cannot say "the type of my driver"): hence ``Any``. Every model
    subclasses it, and so inherits the defaults of the optional capabilities at the end (a
    calibration before the driver, a picture of its own, shapes kept besides the final one).
    """

    def driver(
        self, flow: FlowSpec, observers: Sequence[Observer], initial: Initial | None
    ) -> Driver:
        """The driver that solves this model; ``flow`` is the problem's [flow] section."""
        ...

    def figures(self, driver: Any) -> dict[str, Any]:
        """Model-specific numbers for ``summary.json`` (e.g. fold angles)."""
        ...

    def lines(self, driver: Any) -> list[Array]:
        """Polylines drawn on the picture of the final shape (e.g. deformed creases)."""
        ...

    # -- optional capabilities, with their defaults --------------------------------------------
    #: the target metric G of ∇yᵀ∇y = G (None: I); the picture's defect is measured against it
    metric: Expr | None = None

    def pending_calibration(self) -> str | None:
        """What :meth:`calibrate` has yet to solve for, in words; None: nothing.

        ``dgplate check`` solves nothing: it says this instead (the box's α on the hinges).
        """
        return None

    def calibrate(self, flow: FlowSpec) -> None:
        """Solve for the model's calibrated data (a run does, before :meth:`driver`).

        Args:
            flow: the problem's [flow] section (the calibration's flow settings).
        """
        return None  # a body: the protocol's default (nothing to calibrate)

    def picture(self, driver: Any, path: Path, title: str) -> bool:
        """Draw the model's own picture of the current shape into ``path`` (a rod: a tube).

        Args:
            driver: the model's driver.
            path: the PNG file.
            title: the picture's title.

        Returns:
            False (the default) when the model has none: the runner draws the surface.
        """
        return False

    def held_shapes(self, driver: Any) -> dict[str, tuple[Array, str]]:
        """Shapes the run kept besides the final one: ``name → (values of the shape, title)``.

        Each is drawn as ``<name>.png`` (the box closed at the switch). Default: none.
        """
        return {}


@dataclass(frozen=True)
class DataPath:
    """Clamped data on a path: the Constant α of the forms and the schedule that moves it."""

    alpha: Constant
    schedule: AlphaSchedule


@dataclass(frozen=True)
class ArcLengthPath:
    """A plate's equilibria followed in a load factor λ by arclength (``[path]``).

    Attributes:
        factor: the Constant λ that scales the datum ``path.parameter`` in the energy.
        settings: the path's settings.
        start: λ₀, where the path starts: at 0 from the start deformation, else from the
            gradient flow's minimiser at λ₀.
    """

    factor: Constant
    settings: PathSettings
    start: float = 0.0

    def driver(
        self,
        plate: PlateModel,
        flow: FlowSpec,
        observers: Sequence[Observer],
        initial: Initial | None,
    ) -> BranchPath:
        """The path from λ₀ (:mod:`dgplate.solvers.constrained_path`).

        Args:
            plate: the plate whose energy depends on :attr:`factor`.
            flow: the [flow] section (its constraint's keys: multipliers, edge moments; all
                of it for the flow to the start at λ₀ ≠ 0).
            observers: told of every point and of the end of the run.
            initial: the first iterate at λ₀ (None: the flat plate); at λ₀ ≠ 0 the flow's.

        Returns:
            The driver.
        """
        problem = constrained_problem(
            plate.facets, plate.degree, plate.energy, flow, plate.metric, initial
        )
        self.factor.value = np.asarray(self.start)
        defect = IsometryDefect(problem.y, plate.metric)
        free = not plate.facets.has_clamped
        at_centre = None if free else central_probe(plate.facets.mesh)

        def probes() -> dict[str, float]:
            y = problem.deformation()
            if at_centre is None:  # a free plate: its centre is pinned
                return {"height": height(y), "isometry_defect": defect()}
            return {"w_center": at_centre(y, component=2), "isometry_defect": defect()}

        relax = FlowStart(plate, flow, initial, problem) if self.start else None
        return constrained_branch_path(
            problem,
            self.factor,
            self.settings,
            PATH_PREFIX,
            probes=probes,
            observers=observers,
            free=free,
            prelude=relax,
        )


@dataclass(frozen=True)
class FlowStart:
    """The start of a path at λ₀ ≠ 0: the gradient flow's minimiser there (collective).

    Called by the path before its first point (not on a resume), with λ at λ₀: the flow of
    [flow] runs from ``initial`` to its stopping test, and its deformation replaces the
    path's state (its multipliers stay 0; the path's Newton solve at the start corrects them).
    A free plate's minimiser is first moved rigidly as near the start as it goes
    (:func:`place_near`); its pins then hold it there
    (:func:`dgplate.solvers.rigid_pins.hold_in_place`).
    """

    plate: PlateModel
    flow: FlowSpec
    initial: Initial | None
    problem: ConstrainedProblem

    def __call__(self) -> int:
        """Run the flow and take its deformation.

        Returns:
            The signal that stopped the flow (0: none; the path then does not start).

        Raises:
            SolverError: the flow ended without converging.
        """
        plate, comm, y = self.plate, self.plate.facets.mesh.comm, self.problem.y
        start = y.x.array.copy()
        flow = GradientFlow(
            plate.facets, plate.degree, plate.energy, self.flow, (), self.initial, plate.metric
        )
        try:
            print0(comm, "path: its start is the flow's minimiser at path.lambda_start …")
            result = flow.run()
            if result.interrupted:
                return result.interrupted
            if not result.converged:
                raise SolverError(
                    f"path.lambda_start: the flow to the path's start did not converge "
                    f"({result.reason})"
                )
            print0(
                comm,
                f"path: the flow converged after {result.steps} steps, E_h = {result.energy:.6e}",
            )
            y.interpolate(flow.shape)  # the same space: exact
        finally:
            flow.destroy()
        if not plate.facets.has_clamped:
            place_near(y, start)
        self.problem.state.x.array[self.problem.vdofs] = y.x.array
        self.problem.state.x.scatter_forward()
        return 0


def place_near(y: Function, start: Array) -> None:
    """Move ``y`` rigidly to the placement nearest ``start``: least squares over its nodes.

    A free plate's flow leaves it wherever its rigid motions drifted; moved so, a cap or a
    roll keeps the start's centre and mean orientation (its ``height`` is then its own).
    Collective.

    Args:
        y: a deformation in [DG_k]³, moved in place.
        start: the values of y's local dofs at the start.
    """
    owned = y.function_space.dofmap.index_map.size_local
    nodes, at_start = y.x.array.reshape(-1, 3), start.reshape(-1, 3)
    rotation, shift = kabsch(nodes[:owned], at_start[:owned], y.function_space.mesh.comm)
    y.x.array[:] = (nodes @ rotation.T + shift).reshape(-1)
    y.x.scatter_forward()


#: The PETSc options prefix of a plate's path (its Newton solver and bordered systems).
PATH_PREFIX = "dgplate_plate_path_"


@dataclass
class PlateModel(Model):
    """An isometry-constrained plate: the energy of y ∈ [DG_k]³, run by the gradient flow.

    ``measures`` add numbers of the final deformation to ``summary.json``; the L¹ norms of
    the Gaussian curvature and of the isometry defect, and fold angles of crease facets, are
    always reported. With ``continuation`` the clamped data move along α
    and the flow is staged (:class:`~dgplate.solvers.moving_clamp.MovingClampFlow`).
    """

    facets: FacetSets
    degree: int
    energy: Callable[[Function], Energy]
    measures: Sequence[Callable[[Function], dict[str, Any]]] = field(default_factory=tuple)
    continuation: DataPath | None = None
    metric: Expr | None = None  # the target metric G of ∇yᵀ∇y = G (None: I, isometries)
    arclength: ArcLengthPath | None = None  # the equilibria followed in λ instead of a flow
    continuous: bool = False  # y continuous: the C⁰ interior-penalty method (model.space)

    def driver(
        self, flow: FlowSpec, observers: Sequence[Observer], initial: Initial | None
    ) -> GradientFlow | MovingClampFlow | BranchPath:
        """The constrained gradient flow of :attr:`energy` (staged in α with a continuation).

        With :attr:`arclength`: the path of its equilibria in λ instead.
        """
        if self.arclength is not None:
            return self.arclength.driver(self, flow, observers, initial)
        path, facets, energy, metric = self.continuation, self.facets, self.energy, self.metric
        continuous = self.continuous
        if continuous:  # its step systems are singular at a flat state
            flow = replace(flow, solver={**NULL_PIVOTS, **flow.solver})
        if path is None:
            return GradientFlow(
                facets, self.degree, energy, flow, observers, initial, metric, continuous
            )
        plain = GradientFlow(facets, self.degree, energy, flow, (), initial, metric, continuous)
        return MovingClampFlow(plain, path.alpha, path.schedule, observers)

    def figures(self, driver: Driver) -> dict[str, Any]:
        """‖K_h‖_L¹, ‖δI_h‖_L¹, K_h against G's K, crease fold angles, :attr:`measures`."""
        y = driver.shape
        out: dict[str, Any] = l1_norms(y, self.metric)
        if self.metric is not None:
            out.update(gauss_curvature_figures(y, self.metric))
        if self.facets.num_crease:
            out.update(fold_angle_summary(y, self.facets))
        for measure in self.measures:
            out.update(measure(y))
        return out

    def lines(self, driver: Driver) -> list[Array]:
        """The deformed crease lines."""
        return crease_polylines(driver.shape, self.facets) if self.facets.num_crease else []


def flat_identity(mesh: Mesh) -> tuple[Expr, Expr]:
    """The flat reference deformation y⁰(x) = (x₁, x₂, 0) and its gradient [I₂; 0]."""
    x = ufl.SpatialCoordinate(mesh)
    g: Expr = ufl.as_vector([x[0], x[1], 0.0])
    Phi: Expr = ufl.as_matrix([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    return g, Phi


def piecewise_constant(tagged: TaggedMesh, data: float | dict[str, float], key: str) -> Expr:
    """μ-like data: a number (a Constant), or {cell group name: number} as a DG0 function.

    Either way a value of the forms, not part of their code (:mod:`dgplate.values`). The
    numbers are those of a checked spec (> 0); unknown group names are an error naming ``key``.
    """
    if not isinstance(data, dict):
        return values.constant(tagged.mesh, data)
    return tagged.group_function(data, key=key)


def continuation_schedule(
    continuation: MovingClampSpec | None, clamped: Sequence[str], data: object
) -> AlphaSchedule | None:
    """The schedule of ``model.continuation`` (None without one), checked against the data.

    A continuation needs clamped faces and data other than 'flat' (the end of the path);
    formulas in ``alpha`` need a continuation.
    """
    key = "model.continuation"
    if continuation is None:
        if mentions(data, "alpha"):
            raise InputError(
                "model.boundary_data uses alpha, which needs model.continuation (e.g. {steps = 10})"
            )
        return None
    if not clamped:
        raise InputError(f"{key} moves clamped data, but model.clamped is empty")
    if data == "flat":
        raise InputError(
            f"{key} needs model.boundary_data = {{g = [...]}}: the data at the end of the path"
        )
    return continuation.schedule()


def continuation_path(schedule: AlphaSchedule | None, mesh: Mesh) -> DataPath | None:
    """The Constant α (at its first value) with the schedule; None without a schedule."""
    if schedule is None:
        return None
    return DataPath(values.constant(mesh, schedule.alpha(0)), schedule)


def mentions(value: object, name: str) -> bool:
    """True when a formula of ``value`` (a string, or nested lists and tables) uses ``name``.

    Formulas that do not parse use nothing (their errors are reported where they are parsed).
    """
    if isinstance(value, dict):
        return any(mentions(v, name) for v in value.values())
    if isinstance(value, list | tuple):
        return any(mentions(v, name) for v in value)
    return isinstance(value, str) and expressions.uses(value, name)


def along_path(path: DataPath | None, check: Callable[[], None], samples: int = 100) -> None:
    """Run ``check`` (which raises ``InputError``) at the values of α the path will take.

    At most ``samples`` of them, evenly spread, and always α = 1; the error says at which α.
    α is put back to its first value. Collective when ``check`` is.
    """
    if path is None:
        check()
        return
    stages = path.schedule.stages
    picked = sorted({round(i * (stages - 1) / max(samples - 1, 1)) for i in range(samples)})
    try:
        for stage in picked if stages > samples else range(stages):
            path.alpha.value = np.asarray(path.schedule.alpha(stage))
            try:
                check()
            except InputError as err:
                raise InputError(f"{err} (at α = {path.schedule.alpha(stage):g})") from None
    finally:
        path.alpha.value = np.asarray(path.schedule.alpha(0))


@dataclass(frozen=True)
class BoundaryData:
    """``model.boundary_data`` as a table: clamped data g and Φ (numbers or formulas)."""

    g: list[float | str] = option(
        REQUIRED, "g: three numbers or formulas in x, y (and alpha on a path)", length=3
    )
    Phi: list[list[float | str]] | None = option(
        None, "Φ: a 3×2 matrix [[..], [..], [..]]", shown="∇g", length=3, each=Check(length=2)
    )

    def formulas(self) -> list[object]:
        """G and Φ (what :func:`mentions` searches)."""
        return [self.g, self.Phi or []]


def _check_path_formulas(value: BoundaryData, mesh: Mesh, key: str, path: DataPath) -> None:
    """Formulas in α of the clamped data must be finite on the plate all along the path."""
    texts = [(f"{key}.g[{i}]", t) for i, t in enumerate(value.g) if isinstance(t, str)]
    for i, row in enumerate(value.Phi or []):
        texts += [(f"{key}.Phi[{i}][{j}]", t) for j, t in enumerate(row) if isinstance(t, str)]

    def check() -> None:
        alpha = {"alpha": float(path.alpha.value)}
        for where, text in texts:
            if expressions.uses(text, "alpha"):
                expressions.check_finite_on_mesh(text, mesh, where, alpha)

    along_path(path, check)


def clamped_data(
    value: Literal["flat"] | BoundaryData,
    mesh: Mesh,
    key: str = "model.boundary_data",
    path: DataPath | None = None,
) -> tuple[Expr, Expr]:
    """Nitsche data (g, Φ) on clamped facets from a problem file.

    ``"flat"``: g = (x, y, 0), Φ = [I₂; 0]. A table ``{g = [3 formulas], Phi = [[2], [2], [2]]}``
    gives any data, e.g. a folded sheet; Φ defaults to ∇g. Numbers in the table are Constants
    (:mod:`dgplate.values`). With a ``path`` the data follow it (docs/continuation.md):
    formulas that use ``alpha`` are the path themselves (they must be finite for every α of
    the schedule); otherwise the path is (1 − α)·id + α·g, and Φ likewise (1 − α)·[I₂; 0] + α·Φ.
    """
    if value == "flat":
        return flat_identity(mesh)
    alpha = path.alpha if path is not None else None
    names = {"alpha": alpha} if alpha is not None else None
    g = values.vector(value.g, mesh, f"{key}.g", 3, names)
    if value.Phi is None:
        Phi: Expr = ufl.grad(g)
    else:
        matrix = values.array(value.Phi, mesh, f"{key}.Phi", names)
        assert not isinstance(matrix, float)  # a matrix gives a tensor
        Phi = matrix
    along_alpha = mentions(value.formulas(), "alpha")
    if path is not None and along_alpha:
        _check_path_formulas(value, mesh, key, path)
    if alpha is None or along_alpha:
        return g, Phi
    identity, gradient = flat_identity(mesh)
    moving: Expr = (1 - alpha) * identity + alpha * g
    moving_gradient: Expr = (1 - alpha) * gradient + alpha * Phi
    return moving, moving_gradient
