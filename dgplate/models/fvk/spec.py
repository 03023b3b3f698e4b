"""The [model] section of a Föppl–von Kármán plate (``model.name = "fvk"``): :class:`FvKSpec`.

The model and its energy are described in the docstring of :mod:`dgplate.models.fvk`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from dgplate import expressions
from dgplate.dg.forms import PENALTY_LENGTH_HELP, Penalty, check_penalty_length
from dgplate.errors import InputError
from dgplate.schema import option
from dgplate.solvers import eigen
from dgplate.solvers.newton import Leave, Relaxation, Stability

#: Default penalties, used for the results in docs/fvk.md (Q2 and P3 cells).
PENALTY = Penalty(gamma0=100.0, gamma1=100.0)

_OPTION = re.compile(r"^[A-Za-z0-9_]+$")
_CONDITIONS = ("fixed", "normal", "free")


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _names(value: object) -> bool:
    return isinstance(value, list | tuple) and all(isinstance(n, str) for n in value)


@dataclass
class FvKSpec:
    """[model] of a Föppl–von Kármán plate (name = "fvk"); every key is checked once, here.

    Group names are checked against the mesh when the model is built (:func:`build_fvk`).
    """

    name: str = option("fvk", "the model")
    E: float = option(1.0, "Young's modulus E > 0")
    nu: float = option(0.3, "Poisson's ratio, −1 < ν < 0.5")
    thickness: float = option(0.01, "plate thickness t > 0")
    pressure: float | str = option(
        0.0, "pressure p at full load (along +z): a number or a formula in x, y"
    )
    prestrain: float = option(0.0, "isotropic in-plane prestrain ε₀ at full load (expansion > 0)")
    natural_shape: float | str = option(
        0.0, "natural shape w₀(x, y), a number or formula: strain ½(∇w⊗∇w − ∇w₀⊗∇w₀) + sym∇u"
    )
    clamped: list[Any] = option([], "facet groups with w = 0 and ∇w = 0")
    simply_supported: list[Any] = option([], "facet groups with w = 0, rotation free")
    crease: list[Any] = option([], "interior facet groups where ∇w may jump (hinges)")
    membrane: dict[str, Any] = option(
        {}, "{group: 'fixed' | 'normal' | 'free' | [ux, uy]} in-plane BCs"
    )
    degree: int = option(2, "degree k >= 2 of w (DG_k) and u (CG_k)")
    penalty: dict[str, Any] = option(
        {"gamma0": PENALTY.gamma0, "gamma1": PENALTY.gamma1},
        "IP penalties γ₀ (h⁻³[w]²) and γ₁ (h⁻ᵖ[∇w]²); gradient_power p (default 1, at most 3) over-penalises gradient jumps",
    )
    penalty_length: str = option("diameter", PENALTY_LENGTH_HELP)
    load_steps: int | list[Any] = option(10, "n uniform load steps, or a list of load factors")
    probe: list[Any] | None = option(
        None, "point [x, y] for w_center (default: bounding-box centre)"
    )
    snes: dict[str, Any] = option({}, "PETSc options for SNES/KSP/PC, e.g. {snes_rtol = 1e-8}")
    stability: bool = option(
        True, "report the lowest Hessian eigenvalue after each load step (and its zero crossing)"
    )
    stability_modes: int = option(
        3, "eigenvalues nearest 0 computed per step; the lowest is reported"
    )
    perturb_unstable: float = option(
        0.0,
        "amplitude (a deflection) of the push along the unstable mode when the lowest eigenvalue turns negative; 0: none",
    )
    eigensolver: str = option("auto", "'auto' (SLEPc when importable), 'slepc' or 'lanczos'")
    leave_unstable: bool = option(
        False,
        "leave every state whose lowest eigenvalue is negative: push along the unstable mode, relax by the energy-decreasing flow (first τ relaxation_tau), repeat until the lowest eigenvalue is >= -1e-3 × its path scale",
    )
    leave_unstable_push: float = option(
        0.05,
        "push of leave_unstable: this fraction (0 < a <= 1) of the largest change of the state since the start",
    )
    relaxation: bool = option(
        False,
        "solve each load step (and each solve after a push) by an energy-decreasing proximal gradient flow, then Newton",
    )
    relaxation_tau: float = option(
        1.0, "first pseudo-time step τ > 0 of the relaxation (adapted: doubled or quartered)"
    )
    indenter: str | None = option(
        None, "cell group pushed down rigidly by the indentation (w − w₀ = −λδ there, penalty)"
    )
    indentation: float = option(0.0, "indentation depth δ ≥ 0 of the indenter at full load")
    indenter_stiffness: float = option(
        1e4, "penalty k of the indenter: ½ k E t ∫_indenter (w − w₀ + λδ)², k > 0"
    )

    def __post_init__(self) -> None:
        """Check every key once: one-line InputErrors naming ``model.<key>``."""
        if self.name != "fvk":
            raise InputError(f"model.name must be 'fvk' for FvKSpec, got {self.name!r}")
        self._check_material()
        self._check_groups()
        self._penalty = Penalty.from_table(self.penalty, "model.penalty", PENALTY)
        check_penalty_length(self.penalty_length, "model.penalty_length")
        self._load_factors = _load_factors(self.load_steps)
        if self.probe is not None and not (
            isinstance(self.probe, list | tuple) and len(self.probe) == 2
        ):
            raise InputError(f"model.probe must be a point [x, y], got {self.probe!r}")
        _check_options(self.snes, "model.snes")
        self._check_stability()
        self._check_relaxation()
        expressions.check(self.natural_shape, "model.natural_shape")
        self._check_indenter()

    def _check_indenter(self) -> None:
        if self.indenter is not None and not isinstance(self.indenter, str):
            raise InputError(f"model.indenter must be a cell group name, got {self.indenter!r}")
        if not (_number(self.indentation) and 0 <= self.indentation < math.inf):
            raise InputError(f"model.indentation must be a number >= 0, got {self.indentation!r}")
        stiffness = self.indenter_stiffness
        if not (_number(stiffness) and 0 < stiffness < math.inf):
            raise InputError(f"model.indenter_stiffness must be > 0, got {stiffness!r}")
        if self.indentation and self.indenter is None:
            raise InputError("model.indentation needs model.indenter (the cell group pushed)")

    def _check_material(self) -> None:
        for key in ("E", "thickness"):
            value = getattr(self, key)
            if not (_number(value) and value > 0 and math.isfinite(value)):
                raise InputError(f"model.{key} must be > 0, got {value!r}")
        if not (_number(self.nu) and self.nu < 0.5):
            raise InputError(f"model.nu must be < 0.5, got {self.nu!r}")
        if not self.nu > -1:
            raise InputError(f"model.nu must be > -1, got {self.nu!r}")
        if not _number(self.prestrain):
            raise InputError(f"model.prestrain must be a number, got {self.prestrain!r}")
        expressions.check(self.pressure, "model.pressure")
        if not (_number(self.degree) and isinstance(self.degree, int) and self.degree >= 2):
            raise InputError(f"model.degree must be an integer >= 2, got {self.degree!r}")

    def _check_stability(self) -> None:
        if not isinstance(self.stability, bool):
            raise InputError(f"model.stability must be true or false, got {self.stability!r}")
        modes = self.stability_modes
        if not (isinstance(modes, int) and not isinstance(modes, bool) and modes >= 1):
            raise InputError(f"model.stability_modes must be an integer >= 1, got {modes!r}")
        if not (_number(self.perturb_unstable) and math.isfinite(self.perturb_unstable)):
            raise InputError(
                f"model.perturb_unstable must be a number, got {self.perturb_unstable!r}"
            )
        if self.eigensolver not in eigen.SOLVERS:
            raise InputError(
                f"model.eigensolver must be one of {', '.join(eigen.SOLVERS)}, "
                f"got {self.eigensolver!r}"
            )
        if self.eigensolver == "slepc" and not eigen.have_slepc():
            raise InputError("model.eigensolver = 'slepc' but slepc4py cannot be imported")
        if self.perturb_unstable and not self.stability:
            raise InputError("model.perturb_unstable needs model.stability = true")
        self._check_leave()

    def _check_leave(self) -> None:
        if not isinstance(self.leave_unstable, bool):
            raise InputError(
                f"model.leave_unstable must be true or false, got {self.leave_unstable!r}"
            )
        push = self.leave_unstable_push
        if not (_number(push) and 0 < push <= 1):
            raise InputError(f"model.leave_unstable_push must be in (0, 1], got {push!r}")
        if self.leave_unstable and not self.stability:
            raise InputError("model.leave_unstable needs model.stability = true")

    def _check_relaxation(self) -> None:
        if not isinstance(self.relaxation, bool):
            raise InputError(f"model.relaxation must be true or false, got {self.relaxation!r}")
        tau = self.relaxation_tau
        if not (_number(tau) and 0 < tau < math.inf):
            raise InputError(f"model.relaxation_tau must be a number > 0, got {tau!r}")

    @property
    def stability_options(self) -> Stability | None:
        """The driver's :class:`Stability` (None with ``stability = false``)."""
        if not self.stability:
            return None
        leave = Leave(
            fraction=float(self.leave_unstable_push),
            relaxation=Relaxation(tau=self.relaxation_tau, rtol=1e-4, max_steps=300, stall=10),
        )
        return Stability(
            modes=self.stability_modes,
            perturb=float(self.perturb_unstable),
            solver=self.eigensolver,
            leave=leave if self.leave_unstable else None,
        )

    def _check_groups(self) -> None:
        for key in ("clamped", "simply_supported", "crease"):
            if not _names(getattr(self, key)):
                raise InputError(
                    f"model.{key} must be a list of facet group names, got {getattr(self, key)!r}"
                )
        both = sorted(set(self.clamped) & set(self.simply_supported))
        if both:
            raise InputError(f"model.clamped and model.simply_supported both list {both[0]!r}")
        for group, condition in self.membrane.items():
            if not _membrane_condition(condition):
                raise InputError(
                    f"model.membrane.{group} must be 'fixed', 'normal', 'free' or [ux, uy] "
                    f"(numbers, formulas in x, y or 'free'), got {condition!r}"
                )
            if not isinstance(condition, str):
                for i, component in enumerate(condition):
                    if component != "free":
                        expressions.check(component, f"model.membrane.{group}[{i}]")

    @property
    def penalty_params(self) -> Penalty:
        """The penalty table with the FvK defaults for missing keys (:data:`PENALTY`)."""
        return self._penalty

    @property
    def load_factors(self) -> list[float]:
        """The load factors of the schedule (docstring of :mod:`dgplate.models.fvk`)."""
        return list(self._load_factors)

    @property
    def D(self) -> float:
        """The bending stiffness E t³/(12(1 − ν²))."""
        return float(self.E * self.thickness**3 / (12 * (1 - self.nu**2)))


def _membrane_condition(condition: object) -> bool:
    if isinstance(condition, str):
        return condition in _CONDITIONS
    return (
        isinstance(condition, list | tuple)
        and len(condition) == 2
        and all(_number(c) or isinstance(c, str) for c in condition)
    )


def _load_factors(steps: object) -> list[float]:
    """``n`` → 1/n … 1; an increasing list in (0, 1] as it is; anything else an InputError."""
    if _number(steps) and isinstance(steps, int):
        if steps < 1:
            raise InputError(f"model.load_steps must be >= 1, got {steps}")
        return [(i + 1) / steps for i in range(steps)]
    factors: list[float] = []
    if isinstance(steps, list | tuple) and steps and all(map(_number, steps)):
        factors = [float(s) for s in steps]
    if not (factors and 0 < factors[0] and factors[-1] <= 1 and np.all(np.diff(factors) > 0)):
        raise InputError(
            "model.load_steps must be a positive integer or an increasing list of load "
            f"factors in (0, 1], got {steps!r}"
        )
    return factors


def _check_options(options: dict[Any, Any], key: str) -> None:
    """PETSc option names (without '-') mapped to strings or numbers."""
    for name, value in options.items():
        if not (isinstance(name, str) and _OPTION.match(name)):
            raise InputError(
                f"{key}.{name} is not a PETSc option name (letters, digits and _, without the "
                "leading '-', e.g. snes_rtol)"
            )
        if not isinstance(value, str | int | float):
            raise InputError(f"{key}.{name} must be a string or a number, got {value!r}")
