"""The sections of a Föppl–von Kármán plate: [model] (:class:`FvKSpec`) and [newton].

``model.name = "fvk"``; [newton] (:class:`NewtonSpec`) holds the settings of its driver.

The model and its energy are described in the docstring of :mod:`dgplate.models.fvk`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from itertools import pairwise
from typing import ClassVar, Literal

from dgplate import expressions
from dgplate.dg.forms import PENALTY_LENGTH_HELP, PENALTY_LENGTHS, Penalty
from dgplate.errors import InputError
from dgplate.models import starts
from dgplate.schema import Check, option, section
from dgplate.solvers import eigen
from dgplate.solvers.linear import OptionValue, check_option_names
from dgplate.solvers.newton import Leave, Relaxation, Stability
from dgplate.solvers.path_spec import PathKeys

#: Default penalties, used for the results in docs/fvk.md (Q2 and P3 cells).
PENALTY = Penalty(gamma0=100.0, gamma1=100.0)

#: What the load factor λ can scale (``path.parameter``): every datum, or one of them.
PARAMETERS = (
    "load",
    "pressure",
    "prestrain",
    "natural_curvature",
    "membrane",
    "clamp_slope",
    "indentation",
)


@dataclass
class NewtonSpec:
    """[newton]: Newton's method over load steps, the FvK model's driver."""

    load_steps: int | list[float] = option(
        10,
        "n uniform load steps, or an increasing list of load factors in (0, 1]",
        ge=1,
        each=Check(gt=0, le=1),
    )
    snes: dict[str, OptionValue] = option(
        {}, "PETSc options for SNES/KSP/PC, e.g. {snes_rtol = 1e-8}"
    )
    stability: bool = option(
        True, "report the lowest Hessian eigenvalue after each load step (and its zero crossing)"
    )
    stability_modes: int = option(
        3, "eigenvalues nearest 0 computed per step; the lowest is reported", ge=1
    )
    perturb_unstable: float = option(
        0.0,
        "amplitude (a deflection) of the push along the unstable mode when the lowest eigenvalue turns negative; 0: none",
    )
    eigensolver: str = option(
        "auto", "'auto' (SLEPc when importable), 'slepc' or 'lanczos'", choices=eigen.SOLVERS
    )
    leave_unstable: bool = option(
        False,
        "leave every state whose lowest eigenvalue is negative: push along the unstable mode, relax by the energy-decreasing flow (first τ relaxation_tau), repeat until the lowest eigenvalue is >= -1e-3 × its path scale",
    )
    leave_unstable_push: float = option(
        0.05,
        "push of leave_unstable: this fraction of the largest change of the state since the start",
        gt=0,
        le=1,
    )
    relaxation: bool = option(
        False,
        "solve each load step (and each solve after a push) by an energy-decreasing proximal gradient flow, then Newton",
    )
    relaxation_tau: float = option(
        1.0, "first pseudo-time step τ of the relaxation (adapted: doubled or quartered)", gt=0
    )

    def __post_init__(self) -> None:
        """What spans keys: the load factors increase; the options that need stability."""
        steps = self.load_steps
        if isinstance(steps, list) and not (steps and all(b > a for a, b in pairwise(steps))):
            raise InputError(
                f"newton.load_steps must be a positive integer or an increasing list of load "
                f"factors in (0, 1], got {steps!r}"
            )
        check_option_names(self.snes, "newton.snes")
        if self.eigensolver == "slepc" and not eigen.have_slepc():
            raise InputError("newton.eigensolver = 'slepc' but slepc4py cannot be imported")
        needs = [key for key in ("perturb_unstable", "leave_unstable") if getattr(self, key)]
        if needs and not self.stability:
            raise InputError(f"newton.{needs[0]} needs newton.stability = true")

    @property
    def load_factors(self) -> list[float]:
        """The load factors of the schedule (docstring of :mod:`dgplate.models.fvk`)."""
        steps = self.load_steps
        if isinstance(steps, list):
            return [float(s) for s in steps]
        return [(i + 1) / steps for i in range(steps)]

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


@dataclass
class PathSpec(PathKeys):
    """[path] of an FvK plate: the path's keys and what its load factor scales."""

    parameter: str = option(
        "load",
        "what the load factor λ scales: 'load' (every datum below), or one of 'pressure', "
        "'prestrain', 'natural_curvature', 'membrane' (the prescribed edge displacements), "
        "'clamp_slope', 'indentation', the others held at their full values",
        choices=PARAMETERS,
    )


@dataclass
class FvKSpec:
    """[model] of a Föppl–von Kármán plate (name = "fvk"): physics and discretisation.

    Group names are checked against the mesh when the model is built (:func:`build_fvk`).
    The driver's settings are the section [newton] (:class:`NewtonSpec`).
    """

    #: The keys that moved to [newton].
    MOVED: ClassVar[dict[str, str]] = {f.name: f"newton.{f.name}" for f in fields(NewtonSpec)}

    name: str = option("fvk", "the model", choices=("fvk",))
    E: float = option(1.0, "Young's modulus E", gt=0)
    nu: float = option(0.3, "Poisson's ratio ν", gt=-1, lt=0.5)
    thickness: float = option(0.01, "plate thickness t", gt=0)
    pressure: float | str = option(
        0.0, "pressure p at full load (along +z): a number or a formula in x, y"
    )
    prestrain: float = option(0.0, "isotropic in-plane prestrain ε₀ at full load (expansion > 0)")
    natural_shape: float | str = option(
        0.0, "natural shape w₀(x, y), a number or formula: strain ½(∇w⊗∇w − ∇w₀⊗∇w₀) + sym∇u"
    )
    natural_curvature: float = option(
        0.0,
        "isotropic natural curvature κ₀ at full load: the moment is M(D²w − κ₀ I), as in a plate "
        "heated by ΔT through its thickness (κ₀ = αΔT/t) or a bilayer with a mismatch",
    )
    clamped: list[str] = option([], "facet groups with w = 0 and ∇w = 0 (or model.clamp_slope)")
    clamp_slope: list[float | str] = option(
        [0.0, 0.0],
        "∇w = [∂w/∂x, ∂w/∂y] prescribed on every clamped facet at full load (numbers or "
        "formulas in x, y): clamps turned by these slopes (w = 0 there, so only the slope "
        "normal to each clamp can be nonzero)",
        length=2,
    )
    simply_supported: list[str] = option([], "facet groups with w = 0, rotation free")
    mirror: list[str] = option(
        [],
        "facet groups on a mirror plane of a symmetric plate (straight edges along x or y): "
        "∂w/∂n = 0 and u·n = 0, so a half or a quarter of the plate is solved",
    )
    pin: list[float] | None = option(
        None,
        "point [x, y] where w = 0 is held (at one node): for a plate that no clamped or simply "
        "supported edge holds up (free and mirror edges leave its height free)",
        shown="(none)",
        length=2,
    )
    crease: list[str] = option([], "interior facet groups where ∇w may jump (hinges)")
    membrane: dict[str, Literal["fixed", "normal", "free"] | list[float | str]] = option(
        {},
        "{group: 'fixed' | 'normal' | 'free' | [ux, uy]} in-plane BCs ([ux, uy]: numbers, formulas in x, y or 'free')",
        each=Check(length=2),
    )
    degree: int = option(2, "degree k of w (DG_k) and u (CG_k)", ge=2)
    penalty: Penalty = option(PENALTY, "IP penalties γ₀ (h⁻³[w]²) and γ₁ (h⁻ᵖ[∇w]²)")
    penalty_length: str = option("diameter", PENALTY_LENGTH_HELP, choices=PENALTY_LENGTHS)
    probe: list[float] | None = option(
        None, "point [x, y] for w_center", shown="(the bounding-box centre)", length=2
    )
    probes: dict[str, list[float]] = option(
        {},
        "named points {name = [x, y]} whose deflection is recorded at every step as w_<name>",
        each=Check(length=2),
    )
    indenter: str | None = option(
        None,
        "cell group pushed down rigidly by the indentation (w − w₀ = −λδ there, penalty)",
        shown="(none)",
    )
    indentation: float = option(0.0, "indentation depth δ of the indenter at full load", ge=0)
    indenter_stiffness: float = option(
        1e4, "penalty k of the indenter: ½ k E t ∫_indenter (w − w₀ + λδ)²", gt=0
    )
    start: str | dict[str, object] = option(
        "flat",
        "Newton's first iterate (at λ = 0 for a path): "
        + starts.HELP.removeprefix("the flow's start: "),
    )
    newton: NewtonSpec = section(NewtonSpec, "newton")
    path: PathSpec = section(PathSpec, "path")

    def __post_init__(self) -> None:
        """What spans keys, and the formulas: one-line InputErrors naming ``model.<key>``."""
        expressions.check(self.pressure, "model.pressure")
        expressions.check(self.natural_shape, "model.natural_shape")
        for i, component in enumerate(self.clamp_slope):
            expressions.check(component, f"model.clamp_slope[{i}]")
        if not self.clamped and any(c not in (0, 0.0) for c in self.clamp_slope):
            raise InputError("model.clamp_slope needs model.clamped (the facets it turns)")
        self._start = starts.Start.from_table(self.start)
        self._check_parameter()
        self._check_disjoint_groups()
        for group, condition in self.membrane.items():
            if isinstance(condition, str):
                continue
            for i, component in enumerate(condition):
                if component != "free":
                    expressions.check(component, f"model.membrane.{group}[{i}]")
        if self.indentation and self.indenter is None:
            raise InputError("model.indentation needs model.indenter (the cell group pushed)")
        self._check_probes_and_height()

    def _check_probes_and_height(self) -> None:
        """Probe names make record fields; something holds a bent plate's height."""
        for name in self.probes:
            if not f"w_{name}".isidentifier() or name in ("center", "max"):
                raise InputError(
                    f"model.probes.{name}: a name of letters, digits and _ other than "
                    "'center' and 'max' (it is recorded as w_<name>)"
                )
        if self.bent and not self.held_up and self.pin is None:
            raise InputError(
                "model.pin: nothing holds the plate's height against its pressure or natural "
                "curvature (no clamped or simply supported group, no indenter); set "
                "model.pin = [x, y], a vertex where w = 0"
            )

    def _check_disjoint_groups(self) -> None:
        """A facet group has one bending condition: clamped, simply supported or mirror."""
        keys = ("clamped", "simply_supported", "mirror")
        for i, first in enumerate(keys):
            for second in keys[i + 1 :]:
                both = sorted(set(getattr(self, first)) & set(getattr(self, second)))
                if both:
                    raise InputError(f"model.{first} and model.{second} both list {both[0]!r}")

    def _check_parameter(self) -> None:
        """``path.parameter`` names a datum that is given: a path in it would change nothing."""
        name = self.path.parameter
        given = {
            "pressure": self.pressure not in (0, 0.0),
            "prestrain": self.prestrain != 0,
            "natural_curvature": self.natural_curvature != 0,
            "clamp_slope": any(c not in (0, 0.0) for c in self.clamp_slope),
            "indentation": self.indenter is not None and self.indentation > 0,
            "membrane": any(
                not isinstance(condition, str) and any(c not in (0, 0.0, "free") for c in condition)
                for condition in self.membrane.values()
            ),
        }
        if name != "load" and not given[name]:
            what = (
                "model.membrane has no prescribed displacement"
                if name == "membrane"
                else (f"model.{name} is not set")
            )
            raise InputError(f"path.parameter = {name!r} scales nothing: {what}")

    @property
    def start_params(self) -> starts.Start:
        """The validated ``start``: Newton's first iterate (at λ = 0 on a path)."""
        return self._start

    @property
    def held_up(self) -> bool:
        """Whether an edge (clamped or simply supported) or an indenter holds w."""
        return bool(self.clamped or self.simply_supported or self.indenter is not None)

    @property
    def bent(self) -> bool:
        """Whether a pressure or a natural curvature bends the plate."""
        return self.pressure not in (0, 0.0) or self.natural_curvature != 0

    @property
    def D(self) -> float:
        """The bending stiffness E t³/(12(1 − ν²))."""
        return float(self.E * self.thickness**3 / (12 * (1 - self.nu**2)))
