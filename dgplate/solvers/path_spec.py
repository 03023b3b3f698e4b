"""[path]: the keys of an arclength path common to every model that has one.

A model's own ``PathSpec`` subclasses :class:`PathKeys` and adds ``parameter``, what its load
factor scales (:class:`dgplate.models.fvk.spec.PathSpec`, the constrained plates'
:class:`dgplate.models.kirchhoff.PlatePathSpec`).
"""

from __future__ import annotations

from dataclasses import dataclass

from dgplate.errors import InputError
from dgplate.schema import option
from dgplate.solvers.arclength import StepLength
from dgplate.solvers.continuation import PathSettings


@dataclass
class PathKeys:
    """[path]: how the load path is followed (:mod:`dgplate.solvers.continuation`).

    A model with path following subclasses it, adding ``parameter``: what the load factor
    scales.
    """

    method: str = option(
        "load_steps",
        "'load_steps': the model's own driver (FvK: Newton at the load factors of [newton]; a plate: the gradient flow); 'arclength': pseudo-arclength continuation through folds",
        choices=("load_steps", "arclength"),
    )
    ds: float = option(0.1, "first arclength step (load-factor units)", gt=0)
    ds_max: float = option(0.5, "longest arclength step", gt=0)
    ds_min: float = option(
        1e-6, "shortest arclength step: a corrector failing at it ends the path", gt=0
    )
    steps: int = option(
        50,
        "points of the path: no step starts once there are this many (the start and the special "
        "points count; a last step that finds a special point adds it and the point after it, "
        "one more)",
        ge=2,
    )
    lambda_max: float = option(
        1.0, "the path ends when the load factor leaves [-lambda_max, lambda_max]", gt=0
    )
    switch: bool = option(
        False, "leave the first simple bifurcation along the critical eigenvector"
    )

    def __post_init__(self) -> None:
        """The step bounds are ordered: ds_min ≤ ds ≤ ds_max."""
        if self.ds_min > self.ds_max:
            raise InputError(
                f"path.ds_min = {self.ds_min:g} exceeds path.ds_max = {self.ds_max:g}: the "
                "least step must not be longer than the greatest"
            )
        if not self.ds_min <= self.ds <= self.ds_max:
            raise InputError(
                f"path.ds must lie in [path.ds_min, path.ds_max] = [{self.ds_min:g}, "
                f"{self.ds_max:g}], got {self.ds:g}"
            )

    def settings(self) -> PathSettings:
        """The continuation's settings.

        Returns:
            The step control and the path's bounds of these keys.
        """
        step = StepLength(ds=self.ds, ds_max=self.ds_max, ds_min=self.ds_min)
        return PathSettings(step, self.steps, self.lambda_max, self.switch)
