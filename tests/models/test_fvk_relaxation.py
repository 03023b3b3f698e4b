"""The relaxation of the FvK driver (``newton.relaxation``): an energy-decreasing proximal
gradient flow that leaves an unstable flat plate for the stable buckled one, where Newton from
the same push returns to the flat state.

The case is the perfect simply supported square of ``demos/problems/fvk_buckling.toml`` (8 × 8)
at 1.3 times its Timoshenko–Gere shortening Δ_cr, in one load step, pushed by 10⁻³ t along the
unstable mode: a push too small for Newton (which returns to w = 0 even after doubling it three
times), not for the flow.
"""

import itertools
from typing import Any

from mpi4py import MPI

import pytest

from dgplate.errors import InputError
from dgplate.mesh.tagged import rectangle
from dgplate.models.fvk.model import build_fvk
from dgplate.models.fvk.spec import FvKSpec, NewtonSpec
from dgplate.schema import from_dict

T = 0.01
PLATE: dict[str, Any] = {
    "E": 1.0,
    "nu": 0.3,
    "thickness": T,
    "simply_supported": ["left", "right", "bottom", "top"],
    "membrane": {
        "left": [0.0, "free"],
        "right": [-4.6998116e-4, "free"],  # 1.3 Δ_cr
        "bottom": "normal",
        "top": "free",
    },
}


def _buckle(comm: MPI.Comm, relaxation: bool) -> dict:
    tagged = rectangle(comm, [[0.0, 0.0], [1.0, 1.0]], [8, 8])
    spec = FvKSpec(
        **PLATE,
        newton=NewtonSpec(
            load_steps=[1.0], perturb_unstable=1e-3 * T, relaxation=relaxation, relaxation_tau=1e4
        ),
    )
    driver = build_fvk(spec, tagged).driver(None, [], None)
    try:
        assert driver.run().converged
        summary = driver.summary()
        summary["w_max"] = vars(driver.history[-1])["w_max"]
        summary["residual"] = driver.newton.plain_residual_norm()
    finally:
        driver.destroy()
    return summary


@pytest.fixture(scope="module")
def newton() -> dict:
    return _buckle(MPI.COMM_SELF, relaxation=False)


@pytest.fixture(scope="module")
def relaxed() -> dict:
    return _buckle(MPI.COMM_SELF, relaxation=True)


def test_newton_returns_to_the_unstable_flat_state(newton):
    """The reference for the next test: Newton after the push is back at w = 0, unstable."""
    assert abs(newton["w_max"]) < 1e-12
    assert newton["lowest_eigenvalues"][-1] < 0


def test_relaxation_reaches_the_stable_buckled_state(newton, relaxed):
    """From the same push the flow reaches a buckled state (|w| ~ t) with a non-negative
    lowest Hessian eigenvalue and a lower energy than the flat one; it is a critical point
    (plain residual at round-off after the Newton polish)."""
    assert relaxed["perturbations"] and relaxed["perturbations"][0]["eigenvalue"] < 0
    assert relaxed["lowest_eigenvalues"][-1] >= 0
    assert abs(relaxed["w_max"]) > 0.3 * T
    assert relaxed["energy"] < newton["energy"]
    assert relaxed["residual"] < 1e-12


def test_relaxation_decreases_the_energy_at_every_step(relaxed):
    """Every accepted proximal step lowers Π (or keeps it): no increase in any solve."""
    assert relaxed["energy_increases"] == []
    assert len(relaxed["relaxations"]) == 2  # the load step, then the solve after the push
    for solve in relaxed["relaxations"]:
        energies = solve["energies"]
        assert len(energies) > 1
        assert all(b <= a for a, b in itertools.pairwise(energies))
    assert relaxed["relaxations"][1]["energies"][-1] < relaxed["relaxations"][1]["energies"][0]


@pytest.mark.mpi
@pytest.mark.parity
def test_relaxation_same_state_on_any_number_of_ranks():
    """The relaxed state on the world communicator equals the one-rank state."""
    parallel = _buckle(MPI.COMM_WORLD, relaxation=True)
    serial = _buckle(MPI.COMM_SELF, relaxation=True)
    assert parallel["energy"] == pytest.approx(serial["energy"], rel=1e-6)
    assert parallel["w_max"] == pytest.approx(serial["w_max"], rel=1e-6)
    steps = [len(s["energies"]) for s in serial["relaxations"]]
    assert [len(s["energies"]) for s in parallel["relaxations"]] == steps


@pytest.mark.parametrize(
    ("keys", "message"),
    [
        ({"relaxation": 1}, "newton.relaxation must be bool, got 1"),
        ({"relaxation_tau": 0.0}, "newton.relaxation_tau must be > 0, got 0.0"),
        ({"relaxation_tau": "x"}, "newton.relaxation_tau must be float"),
    ],
)
def test_bad_relaxation_keys(keys, message):
    with pytest.raises(InputError, match=message):
        from_dict(NewtonSpec, keys, "newton")
