"""The [material] section: a plate's layers in physical units, and the model keys they give.

The models are non-dimensional: lengths in units of the mesh's coordinates, the bending
energy ½∫μ|II − Z|². A [material] gives the length L of one mesh unit and the layers (bottom
first: the bottom layer lies on the −ν side of the reference plate), each with its thickness
tᵢ, Young's modulus Eᵢ, Poisson's ratio νᵢ and stress-free strain εᵢ = misfitᵢ + αᵢ ΔT.
Classical laminate theory (the strain ε₀ + κz through the thickness, each layer's energy
density proportional to its modulus) then gives

- the spontaneous curvature Z = −κ I, κ = (A S − B N)/(A C − B²), from the biaxial moduli
  Mᵢ = Eᵢ/(1 − νᵢ) of an isotropic misfit: A = Σ Mᵢ tᵢ, B = Σ Mᵢ ∫z, C = Σ Mᵢ ∫z²,
  N = Σ Mᵢ εᵢ tᵢ, S = Σ Mᵢ εᵢ ∫z over each layer. For two layers this is Timoshenko's bimetal
  formula (:mod:`dgplate.reference.timoshenko`) with n = M₁/M₂ (= E₁/E₂ for equal ν). Z > 0
  (the plate curls towards +ν) when the bottom layer is the longer one when free;
- the bending stiffness D = C' − B'²/A' with the plate moduli Eᵢ/(1 − νᵢ²) (one layer:
  D = E t³/(12(1 − ν²))), the unit of energy: μ = 1 and E_phys = D · E_h.

The model's energy density ½D|II − Z|² has no Poisson term: a strip rolls to the curvature
Z, Timoshenko's (a narrow strip's; a wide plate with the Poisson term, ``model.poisson``, rolls
to (1 + ν)Z).
The model keys are then Z = −κ L I (bilayer), and the physical figures of a run are its
non-dimensional ones times L (lengths), 1/L (curvatures) and D (energy); a non-dimensional
load f is the pressure f D/L³.

A rod takes a cross-section instead of layers (:mod:`dgplate.reference.sections`): its
bending stiffness EI is the unit, c_b = 1 and c_t = GJ/(EI), G = E/(2(1 + ν)); its energy
∫EI|u″|² ds scales with EI/L, the unit of energy of the run.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from dgplate.errors import InputError
from dgplate.reference.sections import circle_section, rectangle_section
from dgplate.schema import REQUIRED, from_dict, option
from dgplate.units import si

#: The models that take a [material]: the plates its layers, a rod its cross-section.
MODELS_WITH_MATERIAL = ("kirchhoff", "bilayer", "rod")


@dataclass
class LayerSpec:
    """One layer of [material]'s ``layers``."""

    thickness: float | str = option(REQUIRED, "thickness t (m, or e.g. '75 um')")
    E: float | str = option(REQUIRED, "Young's modulus (Pa, or e.g. '2 GPa')")
    nu: float = option(0.3, "Poisson's ratio", gt=-1, le=0.5)
    misfit: float | str = option(0.0, "stress-free strain: misfit, swelling or growth")
    alpha: float | str = option(
        0.0, "thermal expansion coefficient (1/K, or e.g. '1.2e-5 1/K'), times material.delta_T"
    )


@dataclass
class SectionSpec:
    """[material]'s ``section``: a rod's cross-section and its material."""

    TYPE_KEYS: ClassVar[dict[str, tuple[str, ...]]] = {
        "circle": ("radius",),
        "rectangle": ("width", "thickness"),
    }

    type: str = option(REQUIRED, "the cross-section", choices=tuple(TYPE_KEYS))
    E: float | str = option(REQUIRED, "Young's modulus (Pa, or e.g. '2 GPa')")
    nu: float = option(0.3, "Poisson's ratio", gt=-1, le=0.5)
    radius: float | str = option(0.0, "circle: the radius (m, or e.g. '0.5 mm')")
    width: float | str = option(0.0, "rectangle: one side (m, or e.g. '2 mm')")
    thickness: float | str = option(0.0, "rectangle: the other side")


@dataclass
class MaterialSpec:
    """The [material] section (docs/units.md); an empty table is no material."""

    length: float | str = option(
        REQUIRED,
        "the physical length of one unit of the mesh's coordinates, or of a rod's parameter (m, or e.g. '10 mm')",
    )
    layers: list[LayerSpec] = option(
        [],
        "plates: the layers, bottom (−ν side) first: tables of thickness, E, nu (0.3), misfit (0) and alpha (0); e.g. [{thickness = '75 um', E = '2 GPa', misfit = 0.01}, {thickness = '75 um', E = '2 GPa'}]",
        shown="(none)",  # commented out in `dgplate schema`: its [material] is empty
    )
    section: SectionSpec | None = option(
        None,
        "rods: the cross-section, e.g. {type = 'circle', radius = '0.5 mm', E = '2 GPa', nu = 0.3}",
        shown="(none)",  # commented out in `dgplate schema`
    )
    delta_T: float | str = option(
        0.0,
        "temperature change (K, or e.g. '40 K'; not '40 degC', a temperature)",
        shown="0 K",  # commented out in `dgplate schema`: its [material] is empty, no material
    )


@dataclass(frozen=True)
class Material:
    """The scales of a [material].

    The length L (m) of a mesh unit; the thickness (m); the bending stiffness (a plate's D
    in J, a rod's EI in N m²); a plate's spontaneous curvature κ (1/m); a rod's torsional
    stiffness GJ (N m², None for a plate).
    """

    length: float
    thickness: float
    stiffness: float
    curvature: float = 0.0
    torsion: float | None = None

    @property
    def length_mm(self) -> float:
        """L in mm: the length unit of a run's pictures, VTX series and solids."""
        return self.length * 1e3

    def model_keys(self, model: str) -> dict[str, Any]:
        """The [model] keys the material gives the model ``model`` (Z; a rod's c_b, c_t)."""
        if self.torsion is not None:
            return {"c_b": 1.0, "c_t": self.torsion / self.stiffness}
        return {"Z": self.curvature * self.length} if model == "bilayer" else {}

    def constants(self) -> tuple[float, dict[str, float]]:
        """(the unit of energy in J, the material's constants as summary.json names them)."""
        L, B = self.length, self.stiffness
        shared = {"length_scale_m": L, "thickness_m": self.thickness}
        if self.torsion is not None:  # a rod: ∫EI|u″|² ds = (EI/L) ∫|û″|² dŝ
            rod = {
                "bending_stiffness_Nm2": B,
                "torsional_stiffness_Nm2": self.torsion,
                "load_scale_N_per_m": B / L**3,
            }
            return B / L, {**shared, **rod}
        plate = {
            "bending_stiffness_J": B,
            "spontaneous_curvature_1_per_m": self.curvature,
            "load_scale_Pa": B / L**3,
        }
        return B, {**shared, **plate}

    def figures(self, summary: Mapping[str, Any]) -> dict[str, Any]:
        """The run's physical figures from its non-dimensional ones (summary.json's).

        Args:
            summary: the run's summary figures (energy, bbox, cylinder_fit, …).

        Returns:
            The constants and, of those figures the summary has, their values in SI units.
        """
        L = self.length
        energy, constants = self.constants()
        figures: dict[str, Any] = dict(constants)
        if "energy" in summary:
            figures["energy_J"] = summary["energy"] * energy
        if "bbox" in summary:
            figures["bbox_m"] = [[v * L for v in corner] for corner in summary["bbox"]]
        fit = summary.get("cylinder_fit")
        if fit:
            figures["cylinder_radius_m"] = fit["radius"] * L
            figures["cylinder_radius_mm"] = fit["radius"] * self.length_mm
        curvatures = summary.get("principal_curvatures")
        if curvatures:
            figures["principal_curvatures_1_per_m"] = {k: v / L for k, v in curvatures.items()}
        return figures


def length_mm(material: Material | None) -> float | None:
    """One mesh unit in mm, the length unit of a run's pictures and VTX (None: no material).

    Args:
        material: the problem's material, or None.

    Returns:
        1000 L, or None without a material (the outputs keep the mesh's units).
    """
    return material.length_mm if material is not None else None


def with_material(data: Mapping[str, Any]) -> tuple[Material | None, object]:
    """The material of a problem (None without one) and its [model] table with the derived keys.

    Args:
        data: the problem's sections (overrides applied).

    Returns:
        The material's scales and the [model] table to validate.
    """
    table, model = data.get("material"), data.get("model")
    if table is None or table == {}:
        return None, model
    spec = from_dict(MaterialSpec, table, "material")
    name = model.get("name", "kirchhoff") if isinstance(model, dict) else None
    if name not in MODELS_WITH_MATERIAL:
        raise InputError(
            f"[material] applies to model.name = {', '.join(MODELS_WITH_MATERIAL)}, "
            f"not {name!r}; the other models take non-dimensional keys"
        )
    assert isinstance(model, dict)
    material = rod_material(spec) if name == "rod" else derive(spec)
    if name == "kirchhoff" and material.curvature != 0.0:
        raise InputError(
            f"material.layers give a spontaneous curvature ({material.curvature:.4g} 1/m: a "
            "misfit, alpha or delta_T), which the kirchhoff model has not; use "
            "model.name = 'bilayer', or layers without it"
        )
    derived = material.model_keys(name)
    # a plate's μ = 1, a rod's c_b = 1: the bending stiffness is the unit of energy
    for key in (*(() if name == "rod" else ("mu",)), *derived):
        if key in model:
            raise InputError(
                f"model.{key} is derived from [material]; give one or the other (docs/units.md)"
            )
    return material, {**model, **derived}


def derive(spec: MaterialSpec) -> Material:
    """The scales of a plate's material: the laminate's D and κ (module docstring), and L."""
    length = _positive(spec.length, "length", "material.length")
    delta_T = si(spec.delta_T, "temperature_change", "material.delta_T")
    if spec.section is not None:
        raise InputError("material.section is a rod's; a plate takes material.layers")
    if not spec.layers:
        raise InputError("material.layers must have at least one layer")
    z, biaxial, plate = 0.0, _Sums(), _Sums()
    for i, layer in enumerate(spec.layers):
        key = f"material.layers[{i}]"
        t = _positive(layer.thickness, "length", f"{key}.thickness")
        E = _positive(layer.E, "modulus", f"{key}.E")
        strain = si(layer.misfit, "strain", f"{key}.misfit")
        strain += si(layer.alpha, "expansion", f"{key}.alpha") * delta_T
        biaxial.add(E / (1 - layer.nu), z, z + t, strain)
        plate.add(E / (1 - layer.nu**2), z, z + t, 0.0)
        z += t
    return Material(length, z, plate.stiffness(), -biaxial.curvature())


def rod_material(spec: MaterialSpec) -> Material:
    """The scales of a rod's material: EI and GJ of its cross-section, and L."""
    length = _positive(spec.length, "length", "material.length")
    if spec.layers:
        raise InputError("material.layers are a plate's; a rod takes material.section")
    section = spec.section
    if section is None:
        raise InputError("material.section is required for model.name = 'rod'")
    E = _positive(section.E, "modulus", "material.section.E")
    if section.type == "circle":
        radius = _positive(section.radius, "length", "material.section.radius")
        (I, J), thickness = circle_section(radius), 2 * radius
    else:
        width = _positive(section.width, "length", "material.section.width")
        height = _positive(section.thickness, "length", "material.section.thickness")
        (I, J), thickness = rectangle_section(width, height), min(width, height)
    bending, torsion = E * I, E / (2 * (1 + section.nu)) * J
    if not torsion < bending:
        raise InputError(
            f"material.section: the rod's energy needs c_t = GJ/(EI) < 1, got "
            f"{torsion / bending:.3g} (a rectangle wider than about twice its thickness "
            "bends one way only, which this rod model does not describe)"
        )
    return Material(length, thickness, bending, torsion=torsion)


def _positive(value: float | str, kind: str, key: str) -> float:
    number = si(value, kind, key)
    if number <= 0:
        raise InputError(f"{key} must be > 0, got {value!r}")
    return number


class _Sums:
    """A laminate's moduli-weighted moments ∫M, ∫Mz, ∫Mz², ∫Mε, ∫Mεz through the thickness."""

    def __init__(self) -> None:
        self.A = self.B = self.C = self.N = self.S = 0.0

    def add(self, modulus: float, z0: float, z1: float, strain: float) -> None:
        """Add a layer of ``modulus`` from z0 to z1 with the stress-free ``strain``."""
        first, second = (z1**2 - z0**2) / 2, (z1**3 - z0**3) / 3
        self.A += modulus * (z1 - z0)
        self.B += modulus * first
        self.C += modulus * second
        self.N += modulus * strain * (z1 - z0)
        self.S += modulus * strain * first

    def curvature(self) -> float:
        """κ of ε₀ + κz that minimises Σ∫M(ε₀ + κz − ε)²."""
        return (self.A * self.S - self.B * self.N) / (self.A * self.C - self.B**2)

    def stiffness(self) -> float:
        """∫M(z − z_n)², z_n = B/A the neutral plane: the bending stiffness."""
        return self.C - self.B**2 / self.A
