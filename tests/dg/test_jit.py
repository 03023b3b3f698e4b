"""Forms are compiled once per problem shape: numbers of a problem are values, not code.

FFCx names a compiled module by the signatures of its forms, so equal signatures mean one
compilation (dgplate.values). The first test counts the modules in a private JIT cache over a
sweep of `dgplate run`; the others compare UFL signatures of every model's energy built with
other numbers, without compiling anything.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from dgplate.dg.forms import Penalty, facet_sets
from dgplate.measure.hinges import hinge_strip
from dgplate.mesh.tagged import rectangle
from dgplate.models.base import BoundaryData
from dgplate.models.bilayer import BilayerSpec, build_bilayer
from dgplate.models.fvk.energy import fvk_bending_energy
from dgplate.models.kirchhoff import KirchhoffSpec, build_kirchhoff
from dgplate.models.thermal.energy import anchor_energy, region_coefficient, thermal_energy
from dgplate.values import constant

VERTICAL = Path(__file__).resolve().parents[2] / "demos" / "problems" / "vertical_load.toml"


def test_sweep_compiles_once(tmp_path):
    """Three runs of vertical_load.toml with other load, μ, γ₀, γ₁ and τ: the 2nd and 3rd add
    nothing to the JIT cache, and their energies differ."""
    cache = tmp_path / "cache"
    env = {**os.environ, "XDG_CACHE_HOME": str(cache)}  # dolfinx.jit: $XDG_CACHE_HOME/fenics
    runs = [
        {"model.load": "[0.0, 0.0, 0.025]"},
        {"model.load": "[0.0, 0.01, 0.05]", "model.mu": "2.0", "flow.tau": "0.5"},
        {
            "model.load": "[0.0, 0.0, 0.1]",
            "model.penalty": "{gamma0 = 4000.0, gamma1 = 900.0}",
            "flow.tau": "0.75",
        },
    ]
    modules, energies = [], []
    for i, values in enumerate(runs):
        settings = {"mesh.cells": "[2, 2]", "output.png": "false", "output.vtx": "false"}
        args = [a for k, v in {**settings, **values}.items() for a in ("--set", f"{k}={v}")]
        out = tmp_path / f"run{i}"
        proc = subprocess.run(
            [sys.executable, "-m", "dgplate", "run", str(VERTICAL), "--out", str(out), *args],
            capture_output=True,
            text=True,
            timeout=900,
            env=env,
        )
        assert proc.returncode == 0, proc.stderr
        modules.append(sorted(p.name for p in (cache / "fenics").rglob("*") if p.is_file()))
        energies.append(json.loads((out / "summary.json").read_text())["energy"])
    print(f"\nJIT cache files after each run: {[len(m) for m in modules]}; energies {energies}")
    assert modules[0], "the first run compiles into the private cache"
    assert modules[1] == modules[0] and modules[2] == modules[0]
    assert len(set(energies)) == 3


def test_forms_compile_with_dgplates_flags_unless_the_user_sets_them(tmp_path):
    """dgplate's compiler flags are DOLFINx's default once dgplate is imported; a user's
    dolfinx_jit_options.json still wins (DOLFINx reads it from the working folder)."""
    import dolfinx.jit

    from dgplate import compat

    flags, _ = dolfinx.jit.DOLFINX_DEFAULT_JIT_OPTIONS["cffi_extra_compile_args"]
    assert flags == compat.JIT_COMPILE_ARGS
    script = (
        "from mpi4py import MPI; import dgplate.compat, dolfinx.jit; "
        "print(dolfinx.jit.get_options()['cffi_extra_compile_args'])"
    )
    env = {
        **os.environ,
        "PYTHONPATH": str(Path(__file__).resolve().parents[2]),
        "XDG_CONFIG_HOME": str(tmp_path / "config"),  # no user options but the test's
    }
    outputs = []
    for options in (None, '{"cffi_extra_compile_args": ["-O3"]}'):
        if options:
            (tmp_path / "dolfinx_jit_options.json").write_text(options)
        done = subprocess.run(
            [sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, env=env
        )
        assert done.returncode == 0, done.stderr
        outputs.append(done.stdout.strip())
    assert outputs == [str(compat.JIT_COMPILE_ARGS), "['-O3']"]


@pytest.fixture(scope="module")
def strip():
    return rectangle(MPI.COMM_SELF, [[0, 0], [2, 1]], [2, 1])


def deformation(tagged, shape=(3,)):
    return dolfinx.fem.Function(dolfinx.fem.functionspace(tagged.mesh, ("DG", 2, shape)))


def signature(build, spec, tagged) -> str:
    return build(spec, tagged).energy(deformation(tagged)).total.signature()


BOUNDARY = BoundaryData(["x", "y", 0.0], [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
SHIFTED = BoundaryData(["x", "y", 0.5], [[1.0, 0.0], [0.0, 1.0], [0.1, 0.0]])


@pytest.mark.parametrize(
    "build,spec,other,formula",
    [
        (
            build_kirchhoff,
            KirchhoffSpec(clamped=["left"], load=[0.0, 0.0, 0.0], boundary_data=BOUNDARY),
            KirchhoffSpec(
                clamped=["left"],
                load=[0.1, 0.0, -2.0],
                mu=3.0,
                penalty=Penalty(50.0, 7.0, 1.0),
                boundary_data=SHIFTED,
            ),
            KirchhoffSpec(clamped=["left"], load=[0.0, 0.0, "0.1*x"], boundary_data=BOUNDARY),
        ),
        (
            build_bilayer,
            BilayerSpec(clamped=["left"], Z=1.0, load=[0.0, 0.0, "x"]),
            BilayerSpec(clamped=["left"], Z=-5.0, mu=0.5, load=[1.0, 0.0, "x"]),
            BilayerSpec(clamped=["left"], Z=1.0, load=[0.0, 0.0, "y"]),
        ),
        (
            build_bilayer,
            BilayerSpec(Z=[[1.0, 0.0], [0.0, 2.0]]),
            BilayerSpec(Z=[[-5.0, 0.5], [0.5, 0.0]], penalty=Penalty(1.0, 2.0)),
            BilayerSpec(Z=[[1.0, "x"], ["x", 2.0]]),
        ),
        (
            build_bilayer,
            BilayerSpec(Z=[[1.0, "x"], ["x", 2.0]]),
            BilayerSpec(Z=[[-3.0, "x"], ["x", 0.0]]),
            BilayerSpec(Z=[[1.0, "2*x"], ["2*x", 2.0]]),
        ),
    ],
)
def test_numbers_do_not_change_the_signature(strip, build, spec, other, formula):
    """Numbers are values; the text of a formula is the problem's shape."""
    reference = signature(build, spec, strip)
    assert signature(build, other, strip) == reference
    assert signature(build, formula, strip) != reference


def test_thermal_and_fvk_numbers_do_not_change_the_signature():
    tagged = hinge_strip(MPI.COMM_SELF, 0.2, 2, 2)
    faces = facet_sets(tagged)
    y, w = deformation(tagged), deformation(tagged, ())
    theta = dolfinx.fem.Function(dolfinx.fem.functionspace(tagged.mesh, ("Lagrange", 1)))

    def thermal(alpha, mu, stiffness, penalty) -> str:
        energy = thermal_energy(
            y,
            faces,
            penalty,
            theta,
            region_coefficient(tagged, alpha, "alpha"),
            constant(tagged.mesh, mu),
            8,
            anchor_energy(y, tagged, "left", stiffness),
        )
        return energy.total.signature()

    def fvk(penalty, D, nu) -> str:
        D, nu = constant(tagged.mesh, D), constant(tagged.mesh, nu)
        return fvk_bending_energy(w, faces, penalty, D, nu, False).signature()

    assert thermal(1.0, 1.0, 1000.0, Penalty()) == thermal(2.5, 20.0, 10.0, Penalty(10.0, 1.0))
    assert thermal({"hinge": 1.0}, 1.0, 1000.0, Penalty()) == thermal(
        {"hinge": -2.0}, 1.0, 1000.0, Penalty()
    )
    assert fvk(Penalty(100.0, 100.0), 1e-3, 0.3) == fvk(Penalty(5.0, 7.0), 2.0, 0.1)
    # the power p of h⁻ᵖ chooses the form
    assert fvk(Penalty(100.0, 100.0), 1e-3, 0.3) != fvk(Penalty(100.0, 100.0, 2.0), 1e-3, 0.3)


def test_calibration_strip_shares_the_box_forms():
    """The hinge strip built like the gmsh box net takes its coordinate element, so that the
    α calibration and the box run compile one set of forms (a cold first box run: ~3 → ~1.5
    minutes); its cells are those of the default strip."""
    from dgplate.mesh.tagged import load_geo
    from dgplate.models.base import piecewise_constant

    net = load_geo(MPI.COMM_SELF, "box_net", {"n": 2, "m": 2})
    width = 0.2
    default, like = (
        hinge_strip(MPI.COMM_SELF, width, 2, 2),
        hinge_strip(MPI.COMM_SELF, width, 2, 2, like=net.mesh),
    )
    element = like.mesh.ufl_domain().ufl_coordinate_element()
    assert element == net.mesh.ufl_domain().ufl_coordinate_element()
    assert element != default.mesh.ufl_domain().ufl_coordinate_element()  # GLL-warped
    for name in ("left", "hinge", "right"):
        mids = [
            np.sort(dolfinx.mesh.compute_midpoints(t.mesh, 2, t.cells(name)), axis=0)
            for t in (default, like)
        ]
        assert mids[0].shape[0] > 0 and np.allclose(mids[0], mids[1], atol=1e-12), name

    def energy(tagged, mu, alpha, anchor) -> str:
        y = deformation(tagged)
        theta = dolfinx.fem.Function(dolfinx.fem.functionspace(tagged.mesh, ("Lagrange", 1)))
        mu = piecewise_constant(tagged, mu, "mu")  # μ before α, as the model creates them
        alpha = region_coefficient(tagged, alpha, "alpha")
        return thermal_energy(
            y,
            facet_sets(tagged),
            Penalty(),
            theta,
            alpha,
            mu,
            8,
            anchor_energy(y, tagged, anchor, 1000.0),
        ).total.signature()

    panels = {name: 20.0 for name in net.names(2)} | {"hinge_north": 1.0}
    box = energy(net, panels, {"hinge_north": 0.6}, "base")
    assert energy(like, {"left": 20.0, "hinge": 1.0, "right": 20.0}, {"hinge": 0.5}, "left") == box
    assert (
        energy(default, {"left": 20.0, "hinge": 1.0, "right": 20.0}, {"hinge": 0.5}, "left") != box
    )


def test_a_form_built_again_reuses_its_loaded_module_with_its_own_data(monkeypatch):
    """The same form on three meshes with other values (dgplate.compat's memo of FFCx's
    module loads): FFCx looks in its cache folder once at most (each look checks the module's
    ``.c.cached`` marker; three looks without the memo), and each form integrates its own
    mesh's function."""
    exists, looks = os.path.exists, []

    def counted(path):
        if str(path).endswith(".c.cached"):
            looks.append(path)
        return exists(path)

    monkeypatch.setattr(os.path, "exists", counted)
    values = []
    for n, value in ((2, 1.5), (3, 2.5), (4, -0.5)):
        mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, n, n)
        f = dolfinx.fem.Function(dolfinx.fem.functionspace(mesh, ("DG", 0)))
        f.x.array[:] = value
        values.append(dolfinx.fem.assemble_scalar(dolfinx.fem.form(f * f * f * ufl.dx)))
    assert len(looks) <= 1
    assert values == pytest.approx([1.5**3, 2.5**3, -(0.5**3)], rel=1e-12)
