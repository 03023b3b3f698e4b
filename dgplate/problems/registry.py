"""Model names in problem files → their spec dataclass and builder."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

from dgplate.errors import InputError
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.base import Model
from dgplate.models.bilayer import BilayerSpec, build_bilayer
from dgplate.models.foundation import FoundationSpec, build_foundation
from dgplate.models.fvk.model import build_fvk
from dgplate.models.fvk.spec import FvKSpec
from dgplate.models.kirchhoff import KirchhoffSpec, build_kirchhoff
from dgplate.models.lce import LCESpec, build_lce
from dgplate.models.rod.energy import rod_mesh
from dgplate.models.rod.model import build_rod
from dgplate.models.rod.spec import ROD_IGNORES, RodSpec
from dgplate.models.thermal.model import build_thermal
from dgplate.models.thermal.spec import ThermalSpec
from dgplate.schema import from_dict
from dgplate.solvers import flow, rod_flow


@dataclass(frozen=True)
class ModelEntry:
    """A model name's spec dataclass (the [model] table) and its build function.

    ``build(spec, tagged)`` returns a :class:`dgplate.models.base.Model`. ``ignores`` names the
    keys that do nothing for this model ("section" for a whole table, or "section.key"), with
    the reason: giving one is an input error rather than a silently ignored setting. ``mesh``,
    when given, builds the model's own mesh from its spec (``mesh(spec, comm)``, e.g. a rod's
    interval): the [mesh] section then does not exist for the model. ``flow_defaults`` are
    the model's own defaults of [flow] keys, under the problem's (a rod's flow).
    """

    spec: type
    build: Callable[[Any, TaggedMesh], Model]
    ignores: Mapping[str, str] = field(default_factory=dict)
    mesh: Callable[[Any, MPI.Comm], TaggedMesh] | None = None
    flow_defaults: Mapping[str, Any] = field(default_factory=dict)

    def defaults(self, section: str) -> Mapping[str, Any]:
        """The model's own defaults of the keys of ``section`` (those of its spec otherwise)."""
        return self.flow_defaults if section == "flow" else {}

    def flow_table(self, table: object) -> object:
        """The problem's [flow] table over the model's defaults (not a table: as it is).

        With ``method = "bnn"`` the model's defaults do not apply: the published method is
        :class:`dgplate.solvers.flow.FlowSpec`'s own defaults.
        """
        if table is None:
            return dict(self.flow_defaults)
        if not isinstance(table, dict) or table.get("method") == "bnn":
            return table
        return {**self.flow_defaults, **table}

    def ignored_keys(self, section: str) -> set[str]:
        """The keys of ``section`` that this model ignores (what its schema leaves out)."""
        return {
            key for path in self.ignores for sec, _, key in [path.partition(".")] if sec == section
        }

    def reject_ignored(self, data: Mapping[str, Any], name: str) -> None:
        """InputError naming the first key of ``data`` (a problem) that this model ignores."""
        for path, why in self.ignores.items():
            section, _, key = path.partition(".")
            table = data.get(section)
            if not isinstance(table, dict):
                continue
            given = sorted(table) if not key else [key] if key in table else []
            if given:
                raise InputError(
                    f"{section}.{given[0]} has no effect with model.name = {name!r}: {why}; "
                    "remove it"
                )


MODELS: dict[str, ModelEntry] = {
    "kirchhoff": ModelEntry(KirchhoffSpec, build_kirchhoff, flow_defaults=flow.ACCURATE),
    "bilayer": ModelEntry(BilayerSpec, build_bilayer, flow_defaults=flow.ACCURATE),
    "foundation": ModelEntry(FoundationSpec, build_foundation, flow_defaults=flow.ACCURATE),
    "thermal": ModelEntry(ThermalSpec, build_thermal, flow_defaults=flow.ACCURATE),
    "lce": ModelEntry(
        LCESpec,
        build_lce,
        ignores={
            "path": "the lce model has no path following (kirchhoff, bilayer and foundation have)"
        },
        flow_defaults=flow.ACCURATE,
    ),
    "rod": ModelEntry(
        RodSpec, build_rod, ignores=ROD_IGNORES, mesh=rod_mesh, flow_defaults=rod_flow.DEFAULTS
    ),
    "fvk": ModelEntry(
        FvKSpec,
        build_fvk,
        ignores={
            "flow": "the fvk model is solved by Newton's method over load steps "
            "([newton]), not by the gradient flow",
        },
    ),
}


def model_spec(data: Any, problem: Mapping[str, Any] | None = None) -> Any:
    """Validate the [model] table with the spec of the model it names.

    Args:
        data: the [model] table.
        problem: the whole problem, whose driver sections (FvK's [newton]) the spec takes.

    Returns:
        The model's spec.
    """
    name = data.get("name", "kirchhoff") if isinstance(data, dict) else "kirchhoff"
    if not isinstance(name, str) or name not in MODELS:
        raise InputError(f"model.name must be one of {', '.join(sorted(MODELS))}, got {name!r}")
    if problem is not None:  # before the spec, which may read a section the model ignores
        MODELS[name].reject_ignored(problem, name)
    return from_dict(MODELS[name].spec, data, "model", problem=problem)
