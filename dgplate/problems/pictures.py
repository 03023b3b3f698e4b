"""The run's pictures: final.png, the shapes a model keeps besides it, and the frames."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dgplate.models.base import Model
from dgplate.problems.material import length_mm
from dgplate.problems.observers import FrameWriter
from dgplate.problems.specs import Problem
from dgplate.solvers.driver import Driver

#: The folder of the frames in the output folder, and their size in pixels (the frames leave
#: out final.png's outline of the reference domain, which would dwarf e.g. a knotted ribbon).
FRAMES = "frames"
FRAME_SIZE = (640, 480)


def frames(problem: Problem, model: Model) -> FrameWriter | None:
    """The observer drawing ``output.frames_every``'s frames (None: none asked).

    Args:
        problem: the problem run.
        model: its model (which may draw its own pictures).

    Returns:
        The frame writer (opened on the driver once it is built), or None when
        ``output.frames_every`` is 0.
    """
    every = problem.output.frames_every
    if not every:
        return None

    def draw(driver: Driver, path: Path, title: str) -> None:
        _draw(problem, model, driver, path, title, window_size=FRAME_SIZE, reference=False)

    return FrameWriter(draw, every, problem.name)


def picture(
    problem: Problem, model: Model, driver: Driver, summary: dict[str, Any], path: Path
) -> None:
    """final.png of the final shape (collective: the lines are gathered).

    A nearly flat shape (an FvK plate's small deflection) has its heights exaggerated, as the
    title says (:func:`dgplate.io.plotting.height_factor`); the frames keep the true scale.
    """
    _draw(problem, model, driver, path, picture_title(problem.name, summary), exaggerate=True)


def picture_title(name: str, summary: dict[str, Any]) -> str:
    """final.png's title: E_h and D_h, and with a [material] the energy in J and the radius.

    Args:
        name: the problem's name.
        summary: the run's summary figures (``physical``: :mod:`dgplate.problems.material`).

    Returns:
        ``name: E_h = …, D_h = …``, with physical figures a second line
        ``E = … J, cylinder radius … mm``.
    """
    energy, defect = summary.get("energy"), summary.get("isometry_defect")
    text = name
    if isinstance(energy, float):
        text += f": E_h = {energy:.4e}"
    if isinstance(defect, float):
        text += f", D_h = {defect:.2e}"
    physical = summary.get("physical", {})
    figures = [f"E = {physical['energy_J']:.4g} J"] if "energy_J" in physical else []
    if "cylinder_radius_mm" in physical:
        figures.append(f"cylinder radius {physical['cylinder_radius_mm']:.4g} mm")
    return "\n".join([text, ", ".join(figures)]) if figures else text


def held_pictures(problem: Problem, model: Model, driver: Driver, folder: Path) -> None:
    """``<name>.png`` of the shapes a model keeps besides the final one (collective).

    A thermal model's ``held_shapes``: the box closed at the switch (``at_switch.png``),
    where final.png shows it open again after cooling. Each is drawn as final.png is, from
    the driver's shape set to it for the picture and put back afterwards.
    """
    shapes = model.held_shapes(driver)
    if not shapes:
        return
    final = driver.shape.x.array.copy()
    for name, (values, title) in shapes.items():
        driver.shape.x.array[:] = values
        _draw(problem, model, driver, folder / f"{name}.png", f"{problem.name}, {title}")
    driver.shape.x.array[:] = final


def _draw(
    problem: Problem, model: Model, driver: Driver, path: Path, title: str, **options: Any
) -> None:
    """A picture of the current shape: the model's own, else the coloured surface.

    Collective: the lines are gathered. ``options`` (``window_size``, ``reference``) go to the surface's
    picture; a model's own picture keeps its size.
    """
    from dgplate.io.plotting import plot_deformation

    if model.picture(driver, path, title):  # a model's own picture (a rod: a striped tube)
        return
    plot_deformation(
        driver.shape,
        path,
        title=title,
        color_by=problem.output.color_by,
        lines=model.lines(driver),
        length_mm=length_mm(problem.material),
        metric=model.metric,
        **options,
    )
