"""Heat-coupled bilayer hinges: fold angles, the c·w rule, meshes of the nets, the thermal
model's spec and driver (schedule, holds, checkpoints), MPI parity."""

import math
import signal
from dataclasses import fields

from mpi4py import MPI

import dolfinx
import numpy as np
import pytest
import ufl
from helpers import PARITY_RTOL

from dgplate import interrupt
from dgplate.coupling.heat import HeatSolver
from dgplate.coupling.thermal_driver import HeatStepRecord, Schedule, ThermalBilayer
from dgplate.errors import InputError
from dgplate.io import checkpoint
from dgplate.measure.hinges import (
    FoldAngles,
    Hinge,
    RegionFrame,
    RegionIntegrals,
    edge_nodes,
    hinge_geometry,
    hinge_strip,
)
from dgplate.mesh.tagged import load_geo
from dgplate.models.thermal.energy import cell_aspect_ratio, hinge_penalty
from dgplate.models.thermal.model import build_thermal, calibrate_alpha
from dgplate.models.thermal.spec import Closure, ScheduleSpec, ThermalSpec
from dgplate.problems.registry import MODELS, model_spec
from dgplate.schema import describe, from_dict
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


STRIP_FLOW = {"tau": 0.05, "l2_metric": False, "projection_steps": 1}


SCHEDULE_KEYS = {f.name for f in fields(ScheduleSpec)}


def strip_spec(n=2, m=2, flow_steps=5, alpha=0.6, end_time=4.0, **more) -> ThermalSpec:
    """A hinge strip heated everywhere (s = 5 until t = 2, then −5; κ = 5, Δt = 1)."""
    return ThermalSpec(
        mu={"left": 20.0, "hinge": 1.0, "right": 20.0},
        alpha={"hinge": alpha},
        hinges={"hinge": ["left", "right"]},
        anchor="left",
        penalty_aspect="mesh",
        kappa=5.0,
        source=[[0.0, 5.0], [2.0, -5.0]],
        schedule=ScheduleSpec(
            heat_step=1.0,
            end_time=end_time,
            flow_steps=flow_steps,
            **{k: more.pop(k) for k in SCHEDULE_KEYS & set(more)},
        ),
        **more,
    )


def thermal_strip(comm, n=2, m=2, flow_steps=5, alpha=0.6, end_time=4.0, **more):
    """The driver of a strip model (``more``: further spec keys)."""
    spec = strip_spec(n, m, flow_steps, alpha, end_time, **more)
    model = build_thermal(spec, hinge_strip(comm, W, n, m))
    return model, model.driver(FlowSpec(**STRIP_FLOW), [], None)


def test_mesh_aspect_ratio_is_the_hinge_penalty_aspect():
    tagged = hinge_strip(MPI.COMM_SELF, W, 2, 4)
    expected = hinge_penalty(W, 2, 4)
    aspect = cell_aspect_ratio(tagged)
    assert 5000.0 * aspect**3 == pytest.approx(expected.gamma0, rel=1e-12)
    geometry = hinge_geometry(tagged, Hinge("hinge", "left", "right"))
    assert geometry.width == pytest.approx(W, rel=1e-12)
    assert geometry.length == pytest.approx(1.0, rel=1e-12)
    assert (geometry.across, geometry.along) == (4, 2)


def test_heating_folds_and_cooling_unfolds():
    _, driver = thermal_strip(MPI.COMM_SELF, flow_steps=40)
    result = driver.run()
    records = result.history
    folds = [r.figures["angle_hinge"] for r in records]
    assert result.converged and driver.finished and driver.time == pytest.approx(4.0)
    assert [r.source for r in records] == [5.0, 5.0, -5.0, -5.0]
    assert folds[0] > 0 and folds[1] > folds[0]  # folds while heated (towards −ν) ...
    assert folds[3] < folds[2] < folds[1]  # ... and unfolds while cooled
    assert all(r.theta_max - r.theta_min < 5.0 for r in records)
    assert [r.step for r in records] == [1, 2, 3, 4] and "hold" not in records[0].line()
    driver.destroy()


def test_a_heat_steps_last_flow_step_is_not_tested_a_holds_is():
    """One SQP step per heat step tracks the path: the stopping test (a solve as costly as the
    step) is skipped after a heat step's last step; a hold's steps are all tested. The record
    splits the heat step's seconds from the relaxation's."""
    flow = FlowSpec(**{**STRIP_FLOW, "adaptive_tau": True, "stop": "stationarity"})
    model = build_thermal(strip_spec(flow_steps=1, end_time=2.0, holds=[2.0]), hinge_strip(
        MPI.COMM_SELF, W, 2, 2))  # fmt: skip
    driver = model.driver(flow, [], None)
    heat = driver.advance()
    (step,) = driver.last_result.history
    assert math.isnan(step.stationarity) and not heat.flow_converged and heat.flow_steps == 1
    assert 0 < heat.heat_seconds < heat.seconds
    driver.advance()
    hold = driver.hold(max_steps=50)
    assert all(math.isfinite(s.stationarity) for s in driver.last_result.history)
    assert hold.flow_converged and hold.heat_seconds == 0.0
    driver.destroy()


class Recorder:
    """An observer that keeps what it is told."""

    def __init__(self):
        self.records, self.results = [], []

    def step(self, driver, record):
        self.records.append(record)

    def finish(self, driver, result):
        self.results.append(result)


def test_holds_observers_summary_and_figures():
    """Holds at the switch and the end: records, observers, summary and the model's figures."""
    model, driver = thermal_strip(
        MPI.COMM_SELF, flow_steps=3, end_time=3.0, holds=[2.0, 3.0], hold_steps=4, hold_tau=0.1
    )
    recorder = Recorder()
    driver.observers.append(recorder)
    result = driver.run(max_steps=3)  # heat, heat, hold at the switch
    assert not result.converged and "budget" in result.reason and result.steps == 3
    held = driver.y.x.array.copy()
    assert [r.hold for r in recorder.records] == [False, False, True]
    assert driver.flow.tau == 0.05  # the hold's τ is put back
    result = driver.run()
    assert [r.hold for r in result.history] == [False, True] and driver.finished
    assert recorder.results[-1] is result and len(driver.records) == 5
    assert result.converged is all(r.flow_converged for r in driver.records if r.hold)
    summary = driver.summary()
    assert summary["heat_steps"] == 3 and summary["holds"] == 2
    assert summary["flow_steps"] == sum(r.flow_steps for r in driver.records)
    assert "steps" not in summary  # the runner's: the driver's steps (heat steps and holds)
    figures = model.figures(driver)
    assert (
        figures["hinge_angles_deg_at_switch"]["hinge"] == driver.records[2].figures["angle_hinge"]
    )
    assert set(figures["hinge_angles_deg_final"]) == {"hinge"}
    anchor = driver.records[-1].figures["anchor_energy"]  # the last record's, in summary.json
    assert figures["anchor_energy_final"] == pytest.approx(anchor) and anchor > 0
    assert "energy_at_switch" in figures
    # the isometric plates' L¹ norms: D_h takes the norm of each cell's integral, so D_h ≤ ‖δI_h‖
    assert figures["isometry_defect_l1"] >= driver.flow.defect() > 0
    assert figures["gauss_curvature_l1"] >= 0
    # the shape at the switch's hold, for at_switch.png (final.png: the end, unfolded)
    shapes = model.held_shapes(driver)
    assert list(shapes) == ["at_switch"] and np.array_equal(shapes["at_switch"][0], held)
    assert shapes["at_switch"][1].startswith("held at t = 2:")
    assert not np.array_equal(driver.y.x.array, held)
    assert "hold" in driver.records[2].line()
    driver.destroy()


def test_checkpoint_and_restore_continue_exactly(tmp_path):
    """Stopped after a hold, saved, restored into a new driver and run on: the same final
    state and the same records as an uninterrupted run."""
    more = {"end_time": 3.0, "holds": [2.0], "hold_steps": 6}
    _, reference = thermal_strip(MPI.COMM_SELF, **more)
    expected = reference.run()
    _, first = thermal_strip(MPI.COMM_SELF, **more)
    first.run(max_steps=3)
    state = {"driver": first.checkpoint_state()}
    checkpoint.save(tmp_path, MPI.COMM_SELF, first.checkpoint_fields(), state)
    _, second = thermal_strip(MPI.COMM_SELF, **more)
    second.resume_from(checkpoint.load(tmp_path, MPI.COMM_SELF))
    assert second.time == pytest.approx(2.0) and second.holds_done == 1
    # the shape held at t = 2, before the checkpoint, comes back with it (at_switch.png)
    (step,) = first.held.steps()
    assert second.held.steps() == [step]
    assert np.array_equal(second.held.get(step).x.array, first.held.get(step).x.array)
    result = second.run()
    assert result.converged == expected.converged and result.steps == 1
    assert [r.step for r in second.records] == [r.step for r in reference.records]
    assert isinstance(second.records[0], HeatStepRecord)
    # the uninterrupted flow carries B(yⁿ) in its step matrix by increments, the restored one
    # assembles it whole: the two agree to round-off, seen through the lagged solver's 1e-9
    # (measured 4.6e-12; the reliability requirement is 1e-10)
    assert second.summary()["energy"] == pytest.approx(
        reference.summary()["energy"], rel=1e-10, abs=0
    )
    for driver in (reference, first, second):
        driver.destroy()


def test_thermal_problem_section():
    spec = model_spec({"name": "thermal", "alpha": 0.5}, {"schedule": {"holds": [0.5]}})
    assert isinstance(spec, ThermalSpec) and MODELS["thermal"].spec is ThermalSpec
    assert spec.schedule == ScheduleSpec(holds=[0.5])
    text = describe(ThermalSpec, "model")
    for key in ("alpha", "hinges", "closure", "source", "penalty_aspect"):
        assert f"\n{key} = " in text
    assert "\nholds = []" in describe(ScheduleSpec, "schedule")
    with pytest.raises(InputError, match=r"model.holds moved to schedule.holds"):
        model_spec({"name": "thermal", "holds": [0.5]})
    with pytest.raises(InputError, match=r"model.alpha = 'calibrate' needs model.hinges"):
        ThermalSpec(alpha="calibrate")
    with pytest.raises(
        InputError,
        match=r"schedule.holds must increase strictly in \[0, end_time = 1\], got \[0.5, 0.5\]",
    ):
        ScheduleSpec(holds=[0.5, 0.5])
    with pytest.raises(
        InputError,
        match=r"schedule.holds must increase strictly in \[0, end_time = 1\], got \[2.0\]",
    ):
        ScheduleSpec(holds=[2.0])
    with pytest.raises(InputError, match=r"model.source: .*increase strictly"):
        ThermalSpec(source=[[1.0, 5.0], [0.5, 0.0]])
    with pytest.raises(InputError, match=r"model.hinges.h must have 2 entries"):
        from_dict(ThermalSpec, {"hinges": {"h": ["a"]}}, "model")
    with pytest.raises(InputError, match=r"model.closure.panel is required"):
        from_dict(ThermalSpec, {"closure": {"edge": "e"}}, "model")
    with pytest.raises(InputError, match=r"model.penalty_aspect must be"):
        from_dict(ThermalSpec, {"penalty_aspect": "thin"}, "model")


def test_bad_thermal_input():
    tagged = hinge_strip(MPI.COMM_SELF, W, 2, 2)
    flow = FlowSpec(tau=0.1)
    with pytest.raises(InputError, match=r"schedule\.flow_steps must be >= 1"):
        from_dict(ScheduleSpec, {"flow_steps": 0}, "schedule")
    with pytest.raises(InputError, match=r"unknown cell group 'hinges'"):
        build_thermal(ThermalSpec(alpha={"hinges": 1.0}), tagged)
    with pytest.raises(InputError, match=r"model.mu.right must be > 0"):
        from_dict(ThermalSpec, {"mu": {"left": 1, "hinge": 1, "right": 0}}, "model")
    with pytest.raises(InputError, match=r"unknown facet group 'tips'"):
        build_thermal(ThermalSpec(edges={"tips": "left"}), tagged)
    with pytest.raises(
        InputError, match=r"l2_metric = false needs clamped facets or model\.anchor"
    ):
        build_thermal(ThermalSpec(), tagged).driver(FlowSpec(tau=0.1, l2_metric=False), [], None)
    model = build_thermal(ThermalSpec(), tagged)
    other = HeatSolver(hinge_strip(MPI.COMM_SELF, W, 2, 2), 1.0, 1.0)
    with pytest.raises(InputError, match="same mesh"):
        ThermalBilayer(model.facets, 2, model._energy(), other, flow, Schedule(1.0))


@pytest.mark.mpi
def test_same_folding_on_any_number_of_ranks():
    """Two heat steps of five flow steps each: energy and fold angle agree between one rank
    and all ranks (PARITY_RTOL relative, 1e−8 rad)."""
    results = []
    for comm in (MPI.COMM_SELF, MPI.COMM_WORLD):
        _, driver = thermal_strip(comm, end_time=2.0)
        records = driver.run().history
        angle = math.radians(records[-1].figures["angle_hinge"])
        results.append((records[-1].energy, angle, driver.flow.step_count))
        driver.destroy()
    (e1, a1, s1), (e2, a2, s2) = results
    assert s1 == s2 == 10
    assert e2 == pytest.approx(e1, rel=PARITY_RTOL, abs=0)
    assert abs(a2 - a1) <= 1e-8
    assert a1 > 0.05


@pytest.mark.mpi
def test_box_figures_on_any_number_of_ranks():
    """The box net's model, one heat step of three flow steps: hinge geometry, calibration-free
    figures (angles, closure gap, edge placement, anchor energy) and the drawn edge agree
    between one rank and all ranks."""
    faces = ["north", "south", "east", "west"]
    spec = ThermalSpec(
        mu={**dict.fromkeys(["base", *faces, "lid"], 20.0), **{f"hinge_{f}": 1.0 for f in faces}}
        | {"hinge_lid": 1.0},
        alpha={f"hinge_{f}": 0.6 for f in [*faces, "lid"]},
        hinges={**{f"hinge_{f}": ["base", f] for f in faces}, "hinge_lid": ["north", "lid"]},
        anchor="base",
        penalty_aspect="mesh",
        kappa=5.0,
        source=[[0.0, 5.0]],
        source_regions=["base"],
        schedule=ScheduleSpec(heat_step=2.0, end_time=2.0, flow_steps=3),
        closure=Closure("lid_edge", "base", ["x", 0.0, "-7/6"]),
        edges={"lid_edge": "base"},
    )
    results = []
    for comm in (MPI.COMM_SELF, MPI.COMM_WORLD):
        tagged = load_geo(comm, "box_net", {"n": 2, "m": 2})
        geometry = hinge_geometry(tagged, Hinge("hinge_lid", "north", "lid"))
        model = build_thermal(spec, tagged)
        driver = model.driver(FlowSpec(**STRIP_FLOW), [], None)
        driver.run()
        figures = model.figures(driver)
        lines = model.lines(driver)
        results.append((geometry, figures, lines))
        driver.destroy()
    (g1, f1, l1), (g2, f2, l2) = results
    assert g1 == g2 and (g1.across, g1.along) == (2, 2)
    for key in ("closure_gap_final", "lid_edge_height_final", "lid_edge_distance_final"):
        assert f2[key] == pytest.approx(f1[key], rel=PARITY_RTOL, abs=1e-12), key
    for name, angle in f1["hinge_angles_deg_final"].items():
        assert abs(f2["hinge_angles_deg_final"][name] - angle) <= 1e-6, name
    assert f1["hinge_angles_deg_final"]["hinge_north"] > 0.5  # folding has begun
    if MPI.COMM_WORLD.rank == 0:
        # the lid's edge: two facets, three Q2 nodes each, in any order of the ranks
        assert len(l1) == len(l2) == 2 and all(line.shape == (3, 3) for line in l1 + l2)
        l1, l2 = (sorted(lines, key=lambda line: float(line[:, 0].sum())) for lines in (l1, l2))
        assert all(np.allclose(a, b, rtol=0, atol=1e-8) for a, b in zip(l1, l2))


class Interrupter:
    """Sets the interrupt flag as a signal handler would, after flow step ``at`` (an
    observer of the driver's inner flow)."""

    def __init__(self, at: int):
        self.at = at

    def step(self, flow, info):
        if info.step == self.at:
            interrupt._received = signal.SIGTERM

    def finish(self, flow, result):
        pass


@pytest.mark.parametrize("at", [2, 3])
def test_a_signal_stops_at_a_step_boundary(at):
    """SIGTERM in the relaxation after a heat step (flow step 2) stops the run after that
    heat step; during the hold (flow step 3) the hold stops, is not counted and is done again
    by the next run."""
    _, driver = thermal_strip(MPI.COMM_SELF, flow_steps=2, end_time=2.0, holds=[1.0], hold_steps=20)
    recorder = Recorder()
    driver.observers.append(recorder)
    driver.flow.observers.append(Interrupter(at))
    try:
        with interrupt.StopOnSignal():
            result = driver.run()
    finally:
        interrupt._received = 0
    assert result.interrupted == signal.SIGTERM and result.reason == "interrupted (SIGTERM)"
    assert not result.converged and recorder.results == [result]
    assert len(driver.records) == 1 and driver.holds_done == 0  # an interrupted hold: undone
    assert driver.flow.step_count == at and len(recorder.records) == 1
    driver.flow.observers.clear()
    result = driver.run()
    assert driver.finished and [r.hold for r in driver.records] == [False, True, False]
    assert [r.step for r in driver.records] == [1, 2, 3] and result.steps == 2
    driver.destroy()
