"""Heat equation θ_t − κΔθ = s (implicit Euler, continuous Lagrange, insulated edges).

Manufactured solution θ = cos(πx) cos(πy) e^{−t} on the unit square: ∂θ/∂n = 0 on every
side (Neumann-compatible) and s = (2π²κ − 1) θ. Expected rates: L² error O(h²) for P1 and
O(Δt) for implicit Euler.
"""

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from helpers import rates

from dgplate.coupling.heat import HeatSolver, HeatSource
from dgplate.errors import InputError
from dgplate.mesh.tagged import rectangle
from dgplate.models.thermal.spec import ScheduleSpec, ThermalSpec
from dgplate.schema import from_dict

KAPPA = 1.0


def exact(x, t):
    return ufl.cos(ufl.pi * x[0]) * ufl.cos(ufl.pi * x[1]) * ufl.exp(-t)


def source(x, t):
    return (2 * ufl.pi**2 * KAPPA - 1) * exact(x, t)


def initial(x):
    return np.cos(np.pi * x[0]) * np.cos(np.pi * x[1])


def solve(comm, n, steps, t_end, degree, cell_type="triangle"):
    tagged = rectangle(comm, [[0, 0], [1, 1]], [n, n], cell_type)
    heat = HeatSolver(tagged, KAPPA, t_end / steps, source, degree, initial)
    heat.advance_to(t_end)
    assert heat.steps == steps and heat.time == pytest.approx(t_end)
    return heat.l2_error(exact)


def test_space_convergence_p1():
    """P1, Δt ∝ h² (time error below the space error): L² rate 2 ± 0.2."""
    errors = [solve(MPI.COMM_SELF, n, max(1, n * n // 16), 0.1, 1) for n in (8, 16, 32)]
    observed = rates(errors)
    print(f"\nP1 L² errors {errors}, rates {observed}")
    assert all(abs(r - 2) < 0.2 for r in observed)


def test_time_convergence_implicit_euler():
    """P2 on a fine mesh (space error negligible): rate 1 ± 0.2 in Δt."""
    errors = [solve(MPI.COMM_SELF, 24, k, 1.0, 2) for k in (4, 8, 16)]
    observed = rates(errors)
    print(f"\nimplicit Euler L² errors {errors}, rates {observed}")
    assert all(abs(r - 1) < 0.2 for r in observed)


def test_quadrilaterals_q1():
    errors = [
        solve(MPI.COMM_SELF, n, max(1, n * n // 16), 0.1, 1, "quadrilateral") for n in (8, 16)
    ]
    assert abs(rates(errors)[0] - 2) < 0.25


def test_regional_source_conserves_heat():
    """Insulated edges: the mean temperature grows by s |region| / |ω| per unit time,
    whatever the time step, and a switch inside a step enters with its exact weight."""
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [2, 1]], [8, 4])
    heat = HeatSolver(tagged, 5.0, 0.3, HeatSource(((0.0, 5.0), (1.0, -5.0))))
    heat.advance_to(1.5)  # 5 steps; the switch at t = 1 lies inside the 4th step (0.9, 1.2)
    assert heat.time == pytest.approx(1.5)
    assert heat.mean() == pytest.approx(5.0 * 1.0 - 5.0 * 0.5, rel=1e-12)
    lo, hi = heat.min_max()
    assert lo == pytest.approx(2.5, rel=1e-10) and hi == pytest.approx(2.5, rel=1e-10)


def test_schedule_values_and_mean():
    s = HeatSource.switched(5.0, -5.0, 28.2)
    assert s.value(0.0) == 5.0 and s.value(28.1) == 5.0 and s.value(28.2) == -5.0
    assert s.average(28.0, 28.4) == pytest.approx(0.0)
    assert s.average(27.0, 28.2) == 5.0  # a step ending at the switch still heats
    assert s.switch_times == (28.2,)
    assert HeatSource(((1.0, 2.0),)).value(0.5) == 0.0  # nothing before the first time


def test_bad_input_is_reported():
    tagged = rectangle(MPI.COMM_SELF, [[0, 0], [1, 1]], [2, 2])
    with pytest.raises(InputError, match=r"^model\.kappa must be > 0, got -5"):
        from_dict(ThermalSpec, {"kappa": -5.0}, "model")
    with pytest.raises(InputError, match=r"^schedule\.heat_step must be > 0"):
        from_dict(ScheduleSpec, {"heat_step": 0.0}, "schedule")
    with pytest.raises(InputError, match=r"increase strictly: t = 1 \(entry 1\) follows t = 2"):
        HeatSource(((2.0, 5.0), (1.0, -5.0)))
    with pytest.raises(InputError, match="schedule is empty"):
        HeatSource(())
    with pytest.raises(InputError, match=r"unknown cell group 'heater'.*plate"):
        HeatSolver(tagged, 1.0, 0.1, HeatSource(((0.0, 1.0),), regions=("heater",)))
    with pytest.raises(InputError, match=r"^model\.heat_degree must be one of 1, 2, got 3"):
        from_dict(ThermalSpec, {"heat_degree": 3}, "model")


@pytest.mark.mpi
def test_same_temperature_on_any_number_of_ranks():
    def run(comm):
        tagged = rectangle(comm, [[0, 0], [2, 1]], [8, 4])
        region = lambda x, t: ufl.conditional(ufl.lt(x[0], 0.5), 5.0, 0.0)  # noqa: E731
        heat = HeatSolver(tagged, 5.0, 0.2, region)
        heat.advance_to(1.0)
        return np.array([*heat.min_max(), heat.mean()])

    serial, parallel = run(MPI.COMM_SELF), run(MPI.COMM_WORLD)
    assert np.allclose(parallel, serial, rtol=1e-12, atol=0)
