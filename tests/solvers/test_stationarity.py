"""The τ-independent stopping test (flow.stop = 'stationarity'): ‖P DE_h[yⁿ]‖_*' < tol, and
adaptive τ (flow.adaptive_tau).

Runs with τ = h and τ = h/4, or with fixed and adaptive τ, must stop at the same discrete
constrained critical point (up to the tolerance), which the published test
(E_h[yⁿ⁻¹] − E_h[yⁿ])/τ < tol does not ensure.
"""

import math

from mpi4py import MPI

import pytest
from helpers import bnn_flow

from dgplate.errors import InputError
from dgplate.reference.bnn import bnn_h
from dgplate.schema import from_dict
from dgplate.solvers.flow import FlowSpec
from dgplate.solvers.steps import stop_reason, stopping_column, stopping_value

TOL = 1e-5


def bnn(comm, tau_factor, stop="stationarity", n=6, adaptive_tau=False):
    return bnn_flow(
        comm,
        n,
        tau=tau_factor * bnn_h(n),
        tol=TOL if stop == "stationarity" else 1e-6,
        stop=stop,
        projection_steps=1,
        max_steps=400,
        adaptive_tau=adaptive_tau,
    )


@pytest.mark.mpi
def test_stop_does_not_depend_on_tau():
    energies = []
    for factor in (1.0, 0.25):
        flow = bnn(MPI.COMM_WORLD, factor)
        result = flow.run()
        assert result.converged and result.energy_increases == []
        assert result.history[-1].stationarity < TOL
        assert flow.stationarity() == pytest.approx(result.history[-1].stationarity)
        energies.append(result.energy)
        flow.destroy()
    assert energies[1] == pytest.approx(energies[0], rel=1e-7)


def test_published_test_stops_far_from_stationary():
    """The rate test with τ = h stops where the projected gradient is still ~60× TOL."""
    flow = bnn(MPI.COMM_SELF, 1.0, stop="rate")
    result = flow.run()
    assert result.converged
    assert math.isnan(result.history[-1].stationarity)
    assert flow.stationarity() > 10 * TOL
    flow.destroy()


def test_unknown_stop_is_refused():
    with pytest.raises(InputError, match=r"flow\.stop"):
        from_dict(FlowSpec, {"stop": "gradient"}, "flow")


@pytest.mark.mpi
def test_adaptive_tau_reaches_the_same_state_in_fewer_steps():
    results = {}
    for adaptive in (False, True):
        flow = bnn(MPI.COMM_WORLD, 1.0, adaptive_tau=adaptive)
        results[adaptive] = flow.run()
        assert results[adaptive].converged and results[adaptive].energy_increases == []
        flow.destroy()
    fixed, adaptive = results[False], results[True]
    assert adaptive.energy == pytest.approx(fixed.energy, rel=1e-6)
    assert adaptive.defect < 1e-10
    assert adaptive.steps < fixed.steps
    taus = [h.tau for h in adaptive.history]
    assert taus[-1] > taus[0]


def test_bad_defect_bound_is_refused():
    with pytest.raises(InputError, match=r"flow\.defect_bound"):
        from_dict(FlowSpec, {"adaptive_tau": True, "defect_bound": 0.0}, "flow")


def test_measure_of_one_state_does_not_depend_on_tau():
    """Flows with τ = h and τ = h/4 (whose measure systems carry 1/τ⁰ in the metric rows)
    measure the same state alike."""
    first, second = bnn(MPI.COMM_SELF, 1.0), bnn(MPI.COMM_SELF, 0.25)
    first.run(max_steps=3)
    second.y.x.array[:] = first.y.x.array
    assert second.stationarity() == pytest.approx(first.stationarity(), rel=1e-9)
    first.destroy()
    second.destroy()


def _box(tau):
    """The box's net (2 × 2 cells per panel) after one heat step with flow τ = ``tau``."""
    from pathlib import Path

    from dgplate.problems.prepare import build_mesh
    from dgplate.problems.registry import MODELS
    from dgplate.problems.specs import load_problem

    box = Path(__file__).resolve().parents[2] / "demos" / "problems" / "box_folding.toml"
    overrides = ["mesh.parameters.n=2", "mesh.parameters.m=2", "model.alpha=1.0"]
    overrides += ["schedule.flow_steps=3", f"flow.tau={tau}", "flow.checkpoint_every=0"]
    problem = load_problem(box, overrides)
    tagged = build_mesh(problem.mesh, MPI.COMM_WORLD)
    driver = MODELS["thermal"].build(problem.model, tagged).driver(problem.flow, [], None)
    driver.advance()
    return driver


def test_measure_is_regular_on_a_free_plate():
    """The box's net has nothing clamped and no L² part in the flow's metric (an anchor spring
    holds it); the measure's own metric gets the L² part (without it the translations, which
    neither the H² metric nor b_n sees, make its system singular). The measure of one state is
    finite, positive and the same for two τ⁰."""
    first, second = _box(0.05), _box(0.0125)
    second.flow.y.x.array[:] = first.flow.y.x.array
    measure = first.flow.stationarity()
    assert math.isfinite(measure) and measure > 0
    assert second.flow.stationarity() == pytest.approx(measure, rel=1e-8)
    first.destroy()
    second.destroy()


@pytest.mark.parametrize(
    "settings,value,column",
    [
        ({"stop": "rate"}, 3e-6, (1e-6, "rate")),  # |ΔE/τ|
        ({"stop": "stationarity"}, 2e-3, (1e-6, "stationarity")),
        ({"stop": "rate", "adaptive_tau": True}, 4e-6, (1e-3, "stationarity")),  # ‖P DE_h‖²
    ],
    ids=["rate", "stationarity", "rate with adaptive tau"],
)
def test_stopping_value_and_its_column(settings, value, column):
    """The rate −3·10⁻⁶, the measure 2·10⁻³: which the test compares, and the chart's column."""
    spec = FlowSpec(tol=1e-6, **settings)
    assert stopping_value(spec, -3e-6, 2e-3)[0] == pytest.approx(value, rel=1e-15)
    tol, name = stopping_column(spec)
    assert tol == pytest.approx(column[0], rel=1e-15) and name == column[1]
    assert stop_reason(spec, -3e-6, 2e-3) == ""  # each above 1e-6
    assert stop_reason(spec, -3e-7, 5e-7).endswith(" < 1e-06")
