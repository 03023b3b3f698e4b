"""The declarative schema: types, constraints and nested specs checked by one mechanism
(:func:`dgplate.schema.from_dict`), one line naming the dotted key, and documented by
:func:`~dgplate.schema.options` and :func:`~dgplate.schema.describe`."""

import re
import tomllib
from dataclasses import dataclass
from typing import Literal

import pytest

from dgplate.cli import main
from dgplate.errors import InputError
from dgplate.problems.registry import MODELS
from dgplate.problems.specs import SECTIONS, problem_from_dict
from dgplate.schema import REQUIRED, Check, describe, from_dict, option, options


@dataclass
class Inner:
    """A nested spec with a required key."""

    kind: str = option(REQUIRED, "the kind", choices=("a", "b"))
    size: float = option(1.0, "a size", gt=0)


@dataclass
class Part:
    """A nested spec that is always there."""

    gamma: float = option(2.0, "a penalty", gt=0)
    power: float = option(1.0, "an exponent", ge=1, le=3)


@dataclass
class Spec:
    """Every kind of constraint."""

    every: int = option(1, "every n steps", ge=1)
    rate: float = option(0.5, "a rate", gt=0, le=1)
    solver: str = option("lu", "a solver", choices=("lu", "cg"), retired=("old",), note="gone")
    tau: float | Literal["h"] = option("h", "τ or 'h'", gt=0)
    cells: list[int] = option([4, 4], "cells", length=2, each=Check(ge=1))
    table: dict[str, float] = option({}, "numbers by name", each=Check(gt=0))
    direction: list[float] = option([1.0, 0.0], "a direction", length=2, nonzero=True)
    part: Part = option(Part(gamma=3.0), "a nested spec")
    inner: Inner | None = option(None, "an optional nested spec")


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"every": 0}, "s.every must be >= 1, got 0"),
        ({"every": 1.5}, "s.every must be int, got 1.5 (float)"),
        ({"every": True}, "s.every must be int, got True (bool)"),
        ({"rate": 0}, "s.rate must be in (0, 1], got 0"),
        ({"rate": 2.5}, "s.rate must be in (0, 1], got 2.5"),
        ({"solver": "gmres"}, "s.solver must be one of lu, cg, got 'gmres'"),
        ({"solver": "old"}, "s.solver must be one of lu, cg, got 'old' (gone)"),
        ({"tau": "big"}, "s.tau must be float or 'h', got 'big' (str)"),
        ({"tau": -1}, "s.tau must be > 0, got -1"),
        ({"cells": [4]}, "s.cells must have 2 entries, got [4]"),
        ({"cells": [4, "x"]}, "s.cells[1] must be int, got 'x' (str)"),
        ({"cells": [4, 0]}, "s.cells[1] must be >= 1, got 0"),
        ({"table": {"a": 0.0}}, "s.table.a must be > 0, got 0.0"),
        ({"table": {"a": "x"}}, "s.table.a must be float, got 'x' (str)"),
        ({"direction": [0, 0.0]}, "s.direction must not be the zero vector, got [0, 0.0]"),
        ({"part": {"power": 5}}, "s.part.power must be in [1, 3], got 5"),
        ({"part": {"gama": 1.0}}, "unknown key s.part.gama (known keys: gamma, power)"),
        ({"part": 3}, "s.part must be a table, got 3 (int)"),
        ({"inner": {"size": 2.0}}, "s.inner.kind is required"),
        ({"inner": {"kind": "c"}}, "s.inner.kind must be one of a, b, got 'c'"),
    ],
)
def test_a_broken_constraint_is_one_line_naming_the_dotted_key(data, message):
    with pytest.raises(InputError, match=f"^{re.escape(message)}$"):
        from_dict(Spec, data, "s")


def test_nested_specs_are_built_with_their_defaults():
    spec = from_dict(Spec, {"tau": 0.1, "part": {"power": 2}, "inner": {"kind": "b"}}, "s")
    assert spec.tau == 0.1 and spec.cells == [4, 4]
    assert spec.part == Part(gamma=3.0, power=2.0)  # keys left out: the outer default's
    assert spec.inner == Inner(kind="b", size=1.0)
    default = from_dict(Spec, {"inner": {}}, "s")
    assert default.part == Part(gamma=3.0) and default.inner is None
    assert default.cells is not Spec().cells  # a mutable default is copied


def test_the_constraints_are_documented_and_the_schema_is_toml():
    rows = {key: (default, doc) for key, default, doc in options(Spec)}
    assert rows["solver"] == ('"lu"', "a solver (one of: lu, cg)")
    assert rows["rate"][1] == "a rate (in (0, 1])"
    assert rows["cells"] == ("[4, 4]", "cells (2 entries, each >= 1)")
    assert rows["direction"] == ("[1.0, 0.0]", "a direction (2 entries, not all 0)")
    assert rows["part.gamma"] == ("3.0", "a penalty (> 0)")  # the outer spec's default
    assert "part" not in rows and rows["inner"][0] == "{}"
    assert rows["inner.kind"] == ("(required)", "the kind (one of: a, b)")
    text = describe(Spec, "s")
    assert "\n# inner.kind = (required)\n" in text and "\npart.power = 1.0\n" in text
    parsed = tomllib.loads(text)["s"]
    assert parsed["part"] == {"gamma": 3.0, "power": 1.0} and parsed["inner"] == {}
    assert from_dict(Spec, parsed, "s") == Spec()


@pytest.mark.parametrize("model", sorted(MODELS))
def test_the_schema_of_every_model_is_a_problem_file_of_its_defaults(model, capsys):
    """`dgplate schema --model NAME` prints TOML that validates: every section, every default."""
    assert main(["schema", "--model", model]) == 0
    data = tomllib.loads(capsys.readouterr().out)
    problem = problem_from_dict(data, "defaults")
    assert problem.model.name == model
    plates = dict.fromkeys(("kirchhoff", "bilayer", "foundation"), "path")
    driver_section = {"fvk": "newton", "thermal": "schedule", **plates}.get(model)
    assert (driver_section in data) if driver_section else set(data) <= set(SECTIONS)


@pytest.mark.parametrize("model", ["kirchhoff", "bilayer", "foundation", "lce", "thermal", "rod"])
def test_the_accurate_method_is_the_default_and_bnn_the_published_one(model):
    """A plate or rod flows to a discrete minimiser unless ``flow.method = "bnn"``; a key
    given in [flow] wins over either method."""
    data = {"model": {"name": model}}
    accurate = problem_from_dict(data, "p").flow
    assert accurate.method == "accurate" and accurate.adaptive_tau
    assert (accurate.projection_steps, accurate.stop) == (2, "stationarity")
    bnn = problem_from_dict({**data, "flow": {"method": "bnn"}}, "p").flow
    assert not bnn.adaptive_tau and (bnn.projection_steps, bnn.stop) == (0, "rate")
    given = problem_from_dict({**data, "flow": {"stop": "rate"}}, "p").flow
    assert given.adaptive_tau and given.stop == "rate"
    with pytest.raises(InputError, match=r"flow\.method must be one of"):
        problem_from_dict({**data, "flow": {"method": "fast"}}, "p")
