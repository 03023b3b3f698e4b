"""``model.self_avoidance`` of the thermal bilayer: ρ·TP[y] explicit in every relaxation.

The hinge strip of tests/models/test_thermal.py (two stiff squares and a soft hinge, heated, then
cooled) with the tangent-point term: every flow step lowers I_bend + ρTP, the records and the
summary carry the least distance of non-neighbouring points and the steps redone, ρTP of the
folded strip is positive, and the term's load is the derivative of the ρTP the flow uses
(central differences). On 1 and 2 ranks.
"""

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest
from helpers import check_load_is_derivative
from test_thermal import STRIP_FLOW, W, strip_spec

from dgplate.dg.self_avoidance import PlateTangentPoint, SelfAvoidance
from dgplate.errors import InputError
from dgplate.measure.hinges import hinge_strip
from dgplate.models.thermal.model import build_thermal
from dgplate.models.thermal.spec import ThermalSpec
from dgplate.schema import from_dict
from dgplate.solvers.flow import FlowSpec

TP = {"rho": 1e-3, "q": 4.5, "theta": 0.5}


@pytest.mark.mpi
def test_thermal_strip_with_tangent_point():
    comm = MPI.COMM_WORLD
    spec = strip_spec(flow_steps=20, self_avoidance=SelfAvoidance(**TP))
    model = build_thermal(spec, hinge_strip(comm, W, 2, 2))
    driver = model.driver(FlowSpec(**STRIP_FLOW), [], None)
    result = driver.run()
    assert result.converged and driver.finished
    summary = driver.summary()
    assert summary["energy_increases"] == []
    records = driver.records
    folds = [r.figures["angle_hinge"] for r in records]
    assert folds[1] > folds[0] > 0  # it still folds while heated
    for record in records:
        assert record.figures["min_distance"] > 0.05
        assert 0 < record.figures["least_distance"] <= record.figures["min_distance"] + 1e-12
        assert record.figures["redone"] == 0  # no step came close enough to be redone
    figures = model.figures(driver)
    assert figures["self_avoidance_energy"] > 0
    assert figures["min_distance"] == pytest.approx(records[-1].figures["min_distance"])
    # the flow's energy has the term; its load is the derivative of its ρTP at the final shape
    (term,) = driver.flow.energy.nonlocal_terms
    assert isinstance(term, PlateTangentPoint)
    assert term.update() == pytest.approx(figures["self_avoidance_energy"])
    direction = dolfinx.fem.Function(driver.y.function_space)
    direction.interpolate(lambda x: np.vstack([np.sin(3 * x[0]), x[1] ** 2, np.cos(2 * x[0])]))
    check_load_is_derivative(term, driver.y, direction, comm)
    driver.destroy()


def test_thermal_self_avoidance_key():
    assert ThermalSpec().self_avoidance is None
    params = from_dict(ThermalSpec, {"self_avoidance": {"rho": 1e-3}}, "model").self_avoidance
    assert params is not None and params.rho == 1e-3 and params.q == 4.5
    with pytest.raises(InputError, match=r"model\.self_avoidance\.rho must be >= 0"):
        from_dict(ThermalSpec, {"self_avoidance": {"rho": -1.0}}, "model")
