"""The starts a problem file names (``model.start``, :mod:`dgplate.models.starts`)."""

import math

import numpy as np
import pytest
from helpers import PROBLEMS

from dgplate import load_problem
from dgplate.errors import InputError
from dgplate.mesh.tagged import rectangle
from dgplate.models.starts import Start, resolve

POINTS = np.array([[0.0, 0.5, math.pi / 2, 3.0], [0.0, 0.25, 1.0, -1.0], [0.0, 0.0, 0.0, 0.0]])


def test_arc_is_the_self_avoiding_strips_former_python_start():
    """{type = 'arc', radius = 1}: y = (sin x₁, x₂, 1 − cos x₁), the demo's start."""
    y = Start.from_table({"type": "arc", "radius": 1.0}).function(None)(POINTS)
    x1, x2 = POINTS[0], POINTS[1]
    assert np.array_equal(y, np.vstack([np.sin(x1), x2, 1.0 - np.cos(x1)]))


def test_arc_along_y_shifted_and_bent_down():
    start = Start.from_table({"type": "arc", "radius": -2.0, "at": 0.5, "along": "y"})
    y = start.function(None)(POINTS)
    angle = (POINTS[1] - 0.5) / -2.0
    expected = np.vstack([POINTS[0], 0.5 - 2.0 * np.sin(angle), -2.0 * (1.0 - np.cos(angle))])
    assert np.allclose(y, expected, rtol=0, atol=1e-15)
    assert y[2].max() <= 0.0  # R < 0 bends down


def test_elastica_is_the_compressed_strips_start():
    """{type = 'elastica'}: the clamped ends at x₁ = a + Δ/2 and a + L − Δ/2, flat there, an
    isometry (arc length kept), and the midpoint height of the closed form."""
    from dgplate.reference.elastica import clamped_elastica

    start = Start.from_table({"type": "elastica", "length": 4.0, "shortening": 2.8, "at": -2.0})
    x1 = np.linspace(-2.0, 2.0, 4001)
    y = start.function(None)(np.vstack([x1, np.full_like(x1, 0.5), np.zeros_like(x1)]))
    assert np.allclose(y[0, [0, -1]], [-0.6, 0.6], atol=1e-9)
    assert np.allclose(y[2, [0, -1]], 0.0, atol=1e-9) and np.all(y[1] == 0.5)
    length = np.sum(np.hypot(np.diff(y[0]), np.diff(y[2])))
    assert abs(length - 4.0) < 1e-5
    assert abs(y[2, 2000] - clamped_elastica(4.0, 2.8)["height"]) < 1e-6


def test_formula_start_on_a_mesh(comm):
    tagged = rectangle(comm, [[0.0, 0.0], [1.0, 1.0]], [2, 2])
    start = Start.from_table({"type": "formula", "g": ["x", "2*y", 0.5]})
    y = start.function(tagged.mesh)(POINTS)
    assert np.array_equal(y, np.vstack([POINTS[0], 2 * POINTS[1], np.full(4, 0.5)]))


def test_flat_is_the_default_start(comm):
    tagged = rectangle(comm, [[0.0, 0.0], [1.0, 1.0]], [2, 2])
    problem = load_problem(PROBLEMS / "vertical_load.toml")
    assert problem.model.start == "flat"
    assert resolve(problem.model, None, tagged.mesh) is None
    assert resolve(problem.model, "flat", tagged.mesh) is None
    assert resolve(problem.model, {"type": "flat"}, tagged.mesh) is None


def test_initial_takes_precedence_over_model_start(comm):
    tagged = rectangle(comm, [[0.0, 0.0], [1.0, 1.0]], [2, 2])
    path = PROBLEMS / "self_avoiding_strip.toml"
    spec = load_problem(path).model
    assert spec.start_params.type == "arc"
    assert resolve(spec, "flat", tagged.mesh) is None
    own = resolve(spec, None, tagged.mesh)
    assert own is not None and np.array_equal(own(POINTS)[2], 1.0 - np.cos(POINTS[0]))


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"type": "formula", "g": ["x", "y"]}, r"model\.start\.g must have 3 entries"),
        ({"type": "formula", "g": ["x", "y", "import(1)"]}, r"model\.start\.g\[2\]"),
        ({"type": "arc", "radius": 1.0, "along": "z"}, r"model\.start\.along must be one of x, y"),
        ({"type": "arc", "radius": 1.0, "at": "x"}, r"model\.start\.at must be float"),
        ({"type": "flat", "radius": 1.0}, r"unknown key model\.start\.radius for type 'flat'"),
        (
            {"type": "elastica", "length": 4.0, "shortening": 4.0},
            r"model\.start: the shortening must lie in \(0, length\)",
        ),
    ],
)
def test_bad_start_tables(table, message):
    with pytest.raises(InputError, match=message):
        Start.from_table(table)
