"""Heat-coupled bilayer hinges: fold angles, the c·w rule, meshes of the nets, MPI parity."""

import math

from mpi4py import MPI

import dolfinx
import numpy as np
import pytest
import ufl
from conftest import PARITY_RTOL

from dgplate.coupling.heat import HeatSolver, HeatSource
from dgplate.errors import InputError
from dgplate.measure.hinges import (
    FoldAngles,
    Hinge,
    RegionFrame,
    RegionIntegrals,
    edge_nodes,
    hinge_strip,
)
from dgplate.mesh.tagged import load_geo
from dgplate.models.thermal import (
    ThermalBilayer,
    ThermalSettings,
    calibrate_alpha,
    hinge_penalty,
)
from dgplate.solvers.flow import FlowSpec

W = math.pi / 24


def folded_strip(x, phi, rotation, shift):
    """The strip folded by φ towards −z: left square flat, hinge a cylinder of curvature
    φ/w, right square rotated by φ; then a rigid motion. x: (3, N) reference points."""
    c = phi / W
    s = x[0]
    a = np.clip(s - 1, 0, W)
    b = np.maximum(s - 1 - W, 0)
    y = np.zeros((3, s.size))
    y[0] = np.where(s <= 1, s, 1 + np.sin(c * a) / c) + b * np.cos(phi)
    y[1] = x[1]
    y[2] = -(1 - np.cos(c * a)) / c - b * np.sin(phi)
    return rotation @ y + shift[:, None]


def deformation_space(tagged, degree=2):
    import basix.ufl

    mesh = tagged.mesh
    element = basix.ufl.element("DG", mesh.basix_cell(), degree, shape=(3,))
    return dolfinx.fem.functionspace(mesh, element)


def test_fold_angle_of_an_exact_fold_any_rigid_motion():
    tagged = hinge_strip(MPI.COMM_SELF, W, n=2, m=4)
    y = dolfinx.fem.Function(deformation_space(tagged))
    hinge = [Hinge("hinge", "left", "right")]
    q, _ = np.linalg.qr(np.array([[0.3, -1.0, 0.2], [0.9, 0.1, 0.5], [-0.2, 0.4, 1.0]]))
    q *= np.sign(np.linalg.det(q))  # a rotation
    for phi in (0.4, 1.2, -0.7, 2.5):
        y.interpolate(lambda x, phi=phi: folded_strip(x, phi, q, np.array([1.0, -2.0, 0.5])))
        # faces are mapped rigidly, which Q2 represents exactly: the angle is exact
        assert FoldAngles(y, tagged, hinge, sense=-1)()["hinge"] == pytest.approx(phi, abs=1e-12)
        assert FoldAngles(y, tagged, hinge, sense=1)()["hinge"] == pytest.approx(-phi, abs=1e-12)
        # the left face's frame undoes the rigid motion
        frame = RegionFrame(y, tagged, "left")
        _, Q, c_ref = frame()
        assert np.allclose(Q, q, atol=1e-12)
        assert np.allclose(c_ref, [0.5, 0.5, 0.0])
        corner = folded_strip(np.array([[0.0], [1.0], [0.0]]), phi, q, np.array([1.0, -2.0, 0.5]))
        assert np.allclose(frame.to_reference(corner.T), [[0.0, 1.0, 0.0]], atol=1e-12)


def test_edge_nodes_and_region_integrals():
    tagged = load_geo(MPI.COMM_SELF, "box_net", {"n": 2, "m": 2})
    y = dolfinx.fem.Function(deformation_space(tagged))
    y.interpolate(lambda x: np.vstack([x[0], x[1], np.zeros_like(x[0])]))
    ref, pos = edge_nodes(y, tagged, "lid_edge")
    assert len(ref) == 2 * 3  # two cells, three Q2 nodes on each one's edge
    assert np.allclose(ref[:, 1], 3 + 2 * W) and np.allclose(pos, ref)
    areas = RegionIntegrals(tagged)
    one = ufl.as_ufl(1.0)
    assert areas([one], "base")[0] == pytest.approx(1.0)
    assert areas([one], "hinge_lid")[0] == pytest.approx(W)


def test_box_net_and_microcapsule_meshes():
    net = load_geo(MPI.COMM_SELF, "box_net", {"n": 3, "m": 2})
    faces = ["base", "north", "south", "east", "west", "lid"]
    hinges = [f"hinge_{f}" for f in faces[1:]]
    assert set(net.names(2)) == set(faces + hinges)
    assert all(net.cells(f).size == 9 for f in faces)
    assert all(net.cells(h).size == 6 for h in hinges)  # 2 across, 3 along
    cap = load_geo(MPI.COMM_SELF, "microcapsule", {"n": 2})
    flaps = [f"flap_{d}" for d in ("north", "south", "east", "west")]
    assert set(cap.names(2)) == {"centre", *flaps}
    areas = RegionIntegrals(cap)
    for flap in flaps:  # trapezoid: (1 + 3/5) / 2 · 1
        assert areas([ufl.as_ufl(1.0)], flap)[0] == pytest.approx(0.8)


def test_one_hinge_folds_90_degrees_when_cw_is_pi_over_2():
    """θ = 10, α_cw = (π/2)/(wθ): the hinge (4 cells across) folds to 90° ± 5°, the stiff
    faces stay flat, and the calibration factor corrects the O(h) shortfall."""
    flow = FlowSpec(tau=0.1, tol=1e-5, l2_metric=False, projection_steps=1)
    alpha, info = calibrate_alpha(MPI.COMM_SELF, W, 4, 4, 10.0, flow, max_steps=600)
    print(f"\nstrip folds {info['strip_fold_deg']:.3f}° in {info['strip_flow_steps']} steps")
    assert info["strip_converged"]
    assert abs(info["strip_fold_deg"] - 90) < 5
    assert info["alpha_cw"] == pytest.approx(12 / 10)
    assert alpha == pytest.approx(info["alpha_cw"] * 90 / info["strip_fold_deg"])


def thermal_strip(comm, n=2, m=2, flow_steps=5, alpha=0.6):
    tagged = hinge_strip(comm, W, n, m)
    source = HeatSource.switched(5.0, -5.0, 2.0)
    heat = HeatSolver(tagged, 5.0, 1.0, source)
    settings = ThermalSettings(
        alpha={"hinge": alpha},
        mu={"left": 20.0, "hinge": 1.0, "right": 20.0},
        flow_steps=flow_steps,
        anchor="left",
        penalty=hinge_penalty(W, n, m),
    )
    model = ThermalBilayer(
        tagged, heat, FlowSpec(tau=0.05, l2_metric=False, projection_steps=1), settings
    )
    angles = FoldAngles(model.y, tagged, [Hinge("hinge", "left", "right")], sense=-1)
    model.measure = lambda _: angles()
    return model


def test_heating_folds_and_cooling_unfolds():
    model = thermal_strip(MPI.COMM_SELF, flow_steps=40)
    records = model.run(4.0)
    folds = [r.figures["hinge"] for r in records]
    assert [r.source for r in records] == [5.0, 5.0, -5.0, -5.0]
    assert folds[0] > 0 and folds[1] > folds[0]  # folds while heated (towards −ν) ...
    assert folds[3] < folds[2] < folds[1]  # ... and unfolds while cooled
    assert all(r.theta_max - r.theta_min < 5.0 for r in records)


def test_bad_thermal_input():
    tagged = hinge_strip(MPI.COMM_SELF, W, 2, 2)
    heat = HeatSolver(tagged, 1.0, 1.0)
    flow = FlowSpec(tau=0.1)
    with pytest.raises(InputError, match="flow_steps must be an integer >= 1"):
        ThermalSettings(flow_steps=0)
    with pytest.raises(InputError, match=r"unknown cell group 'hinges'"):
        ThermalBilayer(tagged, heat, flow, ThermalSettings(alpha={"hinges": 1.0}))
    with pytest.raises(InputError, match=r"thermal.mu.right must be a number > 0"):
        ThermalBilayer(tagged, heat, flow, ThermalSettings(mu={"left": 1, "hinge": 1, "right": 0}))
    other = HeatSolver(hinge_strip(MPI.COMM_SELF, W, 2, 2), 1.0, 1.0)
    with pytest.raises(InputError, match="same mesh"):
        ThermalBilayer(tagged, other, flow, ThermalSettings())


@pytest.mark.mpi
def test_same_folding_on_any_number_of_ranks():
    """Two heat steps of five flow steps each: energy and fold angle agree between one rank
    and all ranks (PARITY_RTOL relative, 1e−8 rad)."""
    results = []
    for comm in (MPI.COMM_SELF, MPI.COMM_WORLD):
        model = thermal_strip(comm)
        records = model.run(2.0)
        results.append((records[-1].energy, records[-1].figures["hinge"], model.flow.step_count))
        model.destroy()
    (e1, a1, s1), (e2, a2, s2) = results
    assert s1 == s2 == 10
    assert e2 == pytest.approx(e1, rel=PARITY_RTOL, abs=0)
    assert abs(a2 - a1) <= 1e-8
    assert a1 > 0.05
