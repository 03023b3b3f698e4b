"""Parameters of the Föppl–von Kármán model: the [model] table of a problem file (name = "fvk").

Every check raises a one-line InputError naming ``model.<key>``; the boundary-condition and
load-schedule conventions are explained in :mod:`dgplate.models.fvk`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dgplate.dg.forms import Penalty
from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh
from dgplate.schema import from_dict, option

#: Default penalties, used for the results in docs/fvk.md (Q2 and P3 cells).
PENALTY = {"gamma0": 100.0, "gamma1": 100.0}


def _number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


@dataclass
class FvKParameters:
    """[model] of a Föppl–von Kármán plate (name = "fvk")."""

    name: str = option("fvk", "the model")
    E: float = option(1.0, "Young's modulus E > 0")
    nu: float = option(0.3, "Poisson's ratio, −1 < ν < 0.5")
    thickness: float = option(0.01, "plate thickness t > 0")
    pressure: float = option(0.0, "uniform pressure p at full load (along +z)")
    prestrain: float = option(0.0, "isotropic in-plane prestrain ε₀ at full load (expansion > 0)")
    clamped: list = option([], "facet groups with w = 0 and ∇w = 0")
    simply_supported: list = option([], "facet groups with w = 0, rotation free")
    crease: list = option([], "interior facet groups where ∇w may jump (hinges)")
    membrane: dict = option({}, "{group: 'fixed' | 'normal' | 'free' | [ux, uy]} in-plane BCs")
    degree: int = option(2, "degree k >= 2 of w (DG_k) and u (CG_k)")
    penalty: dict = option(PENALTY, "IP penalties γ₀ (h⁻³[w]²), γ₁ (h⁻¹[∇w]²)")
    load_steps: int | list = option(10, "n uniform load steps, or a list of load factors")
    probe: list | None = option(None, "point [x, y] for w_center (default: bounding-box centre)")
    snes: dict = option({}, "PETSc options for SNES/KSP/PC, e.g. {snes_rtol = 1e-8}")

    def __post_init__(self) -> None:
        self.validate()

    @classmethod
    def from_dict(cls, data: dict) -> FvKParameters:
        """From a [model] table: unknown keys and wrong types are InputErrors."""
        return from_dict(cls, data, "model")

    def validate(self, tagged: TaggedMesh | None = None) -> None:
        """One-line InputErrors naming ``model.<key>``; with ``tagged``, check group names."""
        if self.name != "fvk":
            raise InputError(f"model.name must be 'fvk' for FvKParameters, got {self.name!r}")
        for key in ("E", "thickness"):
            value = getattr(self, key)
            if not (_number(value) and value > 0 and np.isfinite(value)):
                raise InputError(f"model.{key} must be > 0, got {value!r}")
        if not (_number(self.nu) and self.nu < 0.5):
            raise InputError(f"model.nu must be < 0.5, got {self.nu!r}")
        if not self.nu > -1:
            raise InputError(f"model.nu must be > -1, got {self.nu!r}")
        for key in ("pressure", "prestrain"):
            if not _number(getattr(self, key)):
                raise InputError(f"model.{key} must be a number, got {getattr(self, key)!r}")
        if isinstance(self.degree, bool) or not isinstance(self.degree, int) or self.degree < 2:
            raise InputError(f"model.degree must be an integer >= 2, got {self.degree!r}")
        for key in ("clamped", "simply_supported", "crease"):
            names = getattr(self, key)
            if not isinstance(names, list | tuple) or not all(isinstance(n, str) for n in names):
                raise InputError(f"model.{key} must be a list of facet group names, got {names!r}")
        both = sorted(set(self.clamped) & set(self.simply_supported))
        if both:
            raise InputError(f"model.clamped and model.simply_supported both list {both[0]!r}")
        for key in sorted(self.penalty):  # a missing one keeps its default
            value = self.penalty[key]
            if key not in ("gamma0", "gamma1"):
                raise InputError(f"unknown key model.penalty.{key} (known: gamma0, gamma1)")
            if not (_number(value) and value > 0):
                raise InputError(f"model.penalty.{key} must be a number > 0, got {value!r}")
        for group, cond in self.membrane.items():
            ok = cond in ("fixed", "normal", "free") or (
                isinstance(cond, list | tuple)
                and len(cond) == 2
                and all(_number(c) or c == "free" for c in cond)
            )
            if not ok:
                raise InputError(
                    f"model.membrane.{group} must be 'fixed', 'normal', 'free' or [ux, uy] "
                    f"(numbers or 'free'), got {cond!r}"
                )
        self.load_factors()  # checks load_steps
        if self.probe is not None and not (
            isinstance(self.probe, list | tuple) and len(self.probe) == 2
        ):
            raise InputError(f"model.probe must be a point [x, y], got {self.probe!r}")
        if not all(isinstance(k, str) for k in self.snes):
            raise InputError(f"model.snes keys must be PETSc option names, got {self.snes!r}")
        if tagged is not None:
            for key in ("clamped", "simply_supported", "crease", "membrane"):
                for group in getattr(self, key):
                    try:
                        tagged.facets(group)
                    except InputError as err:
                        raise InputError(f"model.{key}: {err}") from None

    def load_factors(self) -> list[float]:
        """The load factors λ of the schedule (see the module docstring)."""
        steps = self.load_steps
        if _number(steps) and isinstance(steps, int):
            if steps < 1:
                raise InputError(f"model.load_steps must be >= 1, got {steps}")
            return [(i + 1) / steps for i in range(steps)]
        ok = isinstance(steps, list | tuple) and len(steps) > 0 and all(map(_number, steps))
        if ok:
            lam = [float(s) for s in steps]
            ok = 0 < lam[0] and lam[-1] <= 1 and bool(np.all(np.diff(lam) > 0))
        if not ok:
            raise InputError(
                "model.load_steps must be a positive integer or an increasing list of load "
                f"factors in (0, 1], got {steps!r}"
            )
        return lam

    @property
    def penalty_params(self) -> Penalty:
        values = {**PENALTY, **self.penalty}
        return Penalty(float(values["gamma0"]), float(values["gamma1"]))

    @property
    def D(self) -> float:
        return self.E * self.thickness**3 / (12 * (1 - self.nu**2))
