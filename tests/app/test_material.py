"""[material]: quantities with units, the laminate's Z and D against Timoshenko's bimetal formula
and the plate stiffness, and a run's physical figures in summary.json."""

import json
import tomllib

import dolfinx.common
import numpy as np
import pytest
from helpers import PROBLEMS

from dgplate import load_problem, run
from dgplate.cli import main
from dgplate.errors import InputError
from dgplate.problems.material import (
    LayerSpec,
    MaterialSpec,
    SectionSpec,
    derive,
    rod_material,
    with_material,
)
from dgplate.problems.pictures import picture_title
from dgplate.problems.shapes import export_solid
from dgplate.problems.specs import problem_from_dict
from dgplate.reference.sections import rectangle_section
from dgplate.reference.timoshenko import timoshenko_curvature
from dgplate.units import si

TIMOSHENKO = PROBLEMS / "bilayer_timoshenko.toml"


@pytest.mark.parametrize(
    ("value", "kind", "expected"),
    [
        ("150 um", "length", 1.5e-4),
        ("150 µm", "length", 1.5e-4),
        ("10 mm", "length", 0.01),
        (0.25, "length", 0.25),
        ("2 GPa", "modulus", 2e9),
        ("2 N/mm^2", "modulus", 2e6),
        ("1 %", "strain", 0.01),
        ("1.2e-3 1/K", "expansion", 1.2e-3),
        ("40 K", "temperature_change", 40.0),
        ("40 delta_degC", "temperature_change", 40.0),
    ],
)
def test_quantities_in_si(value, kind, expected):
    assert si(value, kind, "k") == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize(
    ("value", "kind", "message"),
    [
        (
            "2 GPa",
            "length",
            "material.length must be a length, e.g. '150 um', got '2 GPa' "
            "([mass] / [length] / [time] ** 2)",
        ),
        (
            "3 m",
            "strain",
            "material.length must be dimensionless (a strain), e.g. '0.01', got '3 m'",
        ),
        (
            "40 degC",
            "temperature_change",
            # pint 0.24 (Debian 13) refuses to read it, 0.26 reads it as the wrong kind
            "material.length must be a temperature difference, e.g. '40 K'",
        ),
        ("2 parsnips", "length", "material.length must be a length, e.g. '150 um'; cannot read"),
        ("", "length", "material.length must be a length, e.g. '150 um'; cannot read ''"),
        ("1e400 m", "length", "material.length must be a finite quantity, got '1e400 m'"),
    ],
)
def test_a_wrong_quantity_is_one_line_naming_the_key(value, kind, message):
    with pytest.raises(InputError) as err:
        si(value, kind, "material.length")
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def material(*layers, length="10 mm", delta_T=0.0):
    return MaterialSpec(
        length=length, layers=[LayerSpec(**layer) for layer in layers], delta_T=delta_T
    )


def test_one_layer_has_the_plate_stiffness_and_no_curvature():
    made = derive(material({"thickness": "0.5 mm", "E": "2 GPa", "nu": 0.4}))
    assert made.stiffness == pytest.approx(2e9 * 0.5e-3**3 / (12 * (1 - 0.4**2)), rel=1e-13)
    assert made.curvature == 0.0 and made.length == 0.01 and made.thickness == 5e-4


def test_equal_layers_curl_to_timoshenkos_radius():
    """h = 150 µm, ε = 1 %: R = 2h/(3ε) = 10 mm, towards +ν (the bottom layer is longer)."""
    made = derive(
        material(
            {"thickness": "75 um", "E": "2 GPa", "misfit": 0.01},
            {"thickness": "75 um", "E": "2 GPa"},
        )
    )
    assert 1 / made.curvature == pytest.approx(2 * 150e-6 / (3 * 0.01), rel=1e-13)
    assert made.model_keys("bilayer")["Z"] == pytest.approx(1.0, rel=1e-13)  # L = R


@pytest.mark.parametrize(
    ("thickness_ratio", "modulus_ratio"), [(1, 1), (1 / 3, 1), (1, 1 / 5), (1 / 3, 1 / 5), (3, 5)]
)
def test_two_layers_follow_timoshenkos_formula(thickness_ratio, modulus_ratio):
    """Any t₁:t₂ and E₁:E₂ (the issue's 1:3 and 1:5), equal ν; the top layer longer: Z < 0."""
    t2, E2, strain = 100e-6, 3e9, 2e-3
    t1, E1 = thickness_ratio * t2, modulus_ratio * E2
    made = derive(
        material(
            {"thickness": t1, "E": E1, "nu": 0.35},
            {"thickness": t2, "E": E2, "nu": 0.35, "misfit": strain},
        )
    )
    assert made.curvature == pytest.approx(-timoshenko_curvature(strain, t1, t2, E1, E2), rel=1e-12)


def test_thermal_strain_is_alpha_times_the_temperature_change():
    thermal = material(
        {"thickness": "50 um", "E": "1 GPa", "alpha": "2e-4 1/K"},
        {"thickness": "150 um", "E": "5 GPa", "alpha": "1.5e-5 1/K"},
        delta_T="40 delta_degC",
    )
    misfit = material(
        {"thickness": "50 um", "E": "1 GPa", "misfit": (2e-4 - 1.5e-5) * 40},
        {"thickness": "150 um", "E": "5 GPa"},
    )
    assert derive(thermal).curvature == pytest.approx(derive(misfit).curvature, rel=1e-12)
    assert derive(thermal).curvature > 0


def test_a_symmetric_laminate_does_not_curl():
    outer = {"thickness": "20 um", "E": "10 GPa", "misfit": 0.02}
    made = derive(material(outer, {"thickness": "100 um", "E": "1 GPa"}, outer))
    assert made.curvature == pytest.approx(0.0, abs=1e-9)


def test_no_material_and_an_empty_one_leave_the_model_as_it_is():
    model = {"name": "bilayer", "Z": 2.0}
    assert with_material({"model": model}) == (None, model)
    assert with_material({"model": model, "material": {}}) == (None, model)


@pytest.mark.parametrize(
    ("sets", "message"),
    [
        (["model.Z=1.0"], "model.Z is derived from [material]; give one or the other"),
        (["model.mu=2.0"], "model.mu is derived from [material]; give one or the other"),
        (
            ["model.name=lce"],
            "[material] applies to model.name = kirchhoff, bilayer, rod, not 'lce'",
        ),
        (["material.layers=[]"], "material.layers must have at least one layer"),
        (["material.length='-1 mm'"], "material.length must be > 0, got '-1 mm'"),
        (
            ["material.layers=[{thickness='2 GPa', E='2 GPa'}]"],
            "material.layers[0].thickness must be a length, e.g. '150 um', got '2 GPa'",
        ),
        (["material.layers=[{E='2 GPa'}]"], "material.layers[0].thickness is required"),
        (
            ["material.layers=[{thickness=1e-4, E=1e9, nu=0.6}]"],
            "material.layers[0].nu must be in (-1, 0.5]",
        ),
        (["material.delta_T='40 degC'"], "material.delta_T must be a temperature difference"),
    ],
)
def test_bad_material_names_the_key(sets, message):
    with pytest.raises(InputError) as err:
        load_problem(TIMOSHENKO, sets)
    assert str(err.value).startswith(message), str(err.value)


def test_kirchhoff_takes_a_single_layer_for_its_scales():
    problem = load_problem(
        PROBLEMS / "vertical_load.toml",
        ["material.length='1 cm'", "material.layers=[{thickness='1 mm', E='1 GPa', nu=0.0}]"],
    )
    assert problem.material is not None
    assert problem.material.stiffness == pytest.approx(1e9 * 1e-9 / 12, rel=1e-13)
    assert problem.material.figures({})["load_scale_Pa"] == pytest.approx(1e9 * 1e-9 / 12 / 1e-6)


def test_kirchhoff_refuses_layers_that_would_curve_it():
    """A misfit is a spontaneous curvature, which the kirchhoff model has not: refused, not
    dropped (while summary.json would report it)."""
    sets = ["material.length='1 cm'", "material.layers=[{thickness='1 mm', E='1 GPa', nu=0.0, misfit=0.01}, {thickness='1 mm', E='1 GPa', nu=0.0}]"]  # fmt: skip
    with pytest.raises(InputError, match=r"^material\.layers give a spontaneous curvature"):
        load_problem(PROBLEMS / "vertical_load.toml", sets)


def test_summary_has_the_physical_figures(tmp_path):
    """The shipped strip at 16×8: R = 10 mm (Timoshenko) to the discretisation's 1.9 % (0.82 %
    at 32×16, docs/units.md), and the energy in J is D times the non-dimensional one."""
    quiet = ("output.png=false", "output.vtx=false", "output.progress=0", "mesh.cells=[16,8]")
    sets = [arg for s in quiet for arg in ("--set", s)]
    assert main(["run", str(TIMOSHENKO), "--out", str(tmp_path / "out"), *sets]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    physical = summary["physical"]
    D = 2e9 * 150e-6**3 / (12 * (1 - 0.3**2))
    assert physical["bending_stiffness_J"] == pytest.approx(D, rel=1e-13)
    assert physical["energy_J"] == pytest.approx(summary["energy"] * D, rel=1e-13)
    assert physical["cylinder_radius_mm"] == pytest.approx(10.0, rel=0.02)
    assert physical["cylinder_radius_m"] == pytest.approx(
        summary["cylinder_fit"]["radius"] * 0.01, rel=1e-13
    )
    # the cylinder's energy ½Dκ²|ω|, |ω| = 20 mm × 10 mm, within the discretisation's 1 %
    assert physical["energy_J"] == pytest.approx(0.5 * D * 100.0**2 * 2e-4, rel=0.01)
    assert physical["bbox_m"][1][0] == pytest.approx(summary["bbox"][1][0] * 0.01, rel=1e-13)


def test_the_picture_title_has_the_physical_figures():
    summary = {"energy": 0.99381, "isometry_defect": 1.2e-11}
    assert picture_title("strip", summary) == "strip: E_h = 9.9381e-01, D_h = 1.20e-11"
    summary["physical"] = {"energy_J": 6.1431e-4, "cylinder_radius_mm": 10.1873}
    assert picture_title("strip", summary) == (
        "strip: E_h = 9.9381e-01, D_h = 1.20e-11\nE = 0.0006143 J, cylinder radius 10.19 mm"
    )


@pytest.mark.parametrize(("ratio", "table"), [(1, 0.141), (1.5, 0.196), (2, 0.229), (10, 0.312)])
def test_rectangle_torsion_constant_is_the_textbook_one(ratio, table):
    """J = β b h³ (Timoshenko and Goodier, Theory of Elasticity, §109, table to 3 digits)."""
    I, J = rectangle_section(ratio * 1e-3, 1e-3)
    assert J / (ratio * 1e-12) == pytest.approx(table, abs=6e-4)
    assert I == pytest.approx(ratio * 1e-12 / 12, rel=1e-14)
    assert rectangle_section(1e-3, ratio * 1e-3) == (I, J)  # either side first


def rod(section, length="10 cm"):
    return MaterialSpec(length=length, section=SectionSpec(**section))


def test_a_round_rod_has_EI_and_c_t_of_its_disc():
    made = rod_material(rod({"type": "circle", "radius": "0.5 mm", "E": "2 GPa", "nu": 0.25}))
    EI = 2e9 * np.pi * 0.5e-3**4 / 4
    assert made.stiffness == pytest.approx(EI, rel=1e-14)
    keys = made.model_keys("rod")
    assert keys["c_b"] == 1.0 and keys["c_t"] == pytest.approx(1 / 1.25, rel=1e-14)
    energy, constants = made.constants()
    assert energy == pytest.approx(EI / 0.1, rel=1e-14)
    assert constants["torsional_stiffness_Nm2"] == pytest.approx(EI / 1.25, rel=1e-14)


def test_a_square_rod_and_a_refused_flat_one():
    made = rod_material(rod({"type": "rectangle", "width": 1e-3, "thickness": 1e-3, "E": 1e9}))
    assert made.model_keys("rod")["c_t"] == pytest.approx(0.1406 * 12 / 2.6, rel=1e-3)
    with pytest.raises(InputError, match=r"^material.section: the rod's energy needs c_t"):
        rod_material(rod({"type": "rectangle", "width": 3e-3, "thickness": 1e-3, "E": 1e9}))


def rod_problem(sets=()):
    data = tomllib.loads((PROBLEMS / "rod_arc.toml").read_text())
    del data["model"]["c_b"], data["model"]["c_t"]
    data["material"] = {
        "length": "10 cm",
        "section": {"type": "circle", "radius": "0.5 mm", "E": "2 GPa", "nu": 0.3},
    }
    return problem_from_dict(data, "rod_arc", list(sets))


@pytest.mark.parametrize(
    ("sets", "message"),
    [
        (["model.c_t=0.5"], "model.c_t is derived from [material]; give one or the other"),
        (["material.section.radius='2 GPa'"], "material.section.radius must be a length"),
        (["material.section.width=1e-3"], "unknown key material.section.width for type 'circle'"),
        (["material.layers=[{thickness=1e-4, E=1e9}]"], "material.layers are a plate's; a rod"),
    ],
)
def test_bad_rod_material_names_the_key(sets, message):
    with pytest.raises(InputError) as err:
        rod_problem(sets)
    assert str(err.value).startswith(message), str(err.value)


def test_a_plate_refuses_a_section():
    with pytest.raises(InputError, match=r"^material.section is a rod's; a plate takes"):
        load_problem(TIMOSHENKO, ["material.section={type='circle', radius=1e-3, E=1e9}"])


def test_a_rods_summary_has_its_energy_in_joules(tmp_path):
    problem = rod_problem(["output.png=false", "output.vtx=false", "output.progress=0"])
    assert problem.model.c_b == 1.0 and problem.model.c_t == pytest.approx(1 / 1.3, rel=1e-14)
    summary = run(problem, out=tmp_path / "rod").summary
    physical = summary["physical"]
    EI = 2e9 * np.pi * 0.5e-3**4 / 4
    assert physical["bending_stiffness_Nm2"] == pytest.approx(EI, rel=1e-14)
    assert physical["energy_J"] == pytest.approx(summary["energy"] * EI / 0.1, rel=1e-14)
    assert physical["bbox_m"][1][0] == pytest.approx(summary["bbox"][1][0] * 0.1, rel=1e-14)
    with pytest.raises(InputError, match="a rod's run has a centreline, not a sheet"):
        export_solid(tmp_path / "rod", tmp_path / "rod.stl", 0.01)


@pytest.mark.skipif(not dolfinx.common.has_adios2, reason="DOLFINx without ADIOS2")
def test_the_vtx_series_is_in_millimetres(tmp_path):
    """The shipped strip (one mesh unit = 10 mm) at 4×2: deformation.bp holds y in mm (serial:
    the whole array is this rank's, in data.0)."""
    sets = ["mesh.cells=[4,2]", "output.png=false", "output.progress=0", "flow.max_steps=3"]
    result = run(load_problem(TIMOSHENKO, sets), out=tmp_path / "out")
    assert result.shape is not None
    y = result.shape.x.array
    data = (tmp_path / "out" / "deformation.bp" / "data.0").read_bytes()
    assert (10.0 * y).tobytes() in data and y.tobytes() not in data
