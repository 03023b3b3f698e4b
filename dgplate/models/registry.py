"""Model names in problem files → their spec dataclass and builder."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from dgplate.errors import InputError
from dgplate.models.bilayer import BilayerSpec, build_bilayer
from dgplate.models.fvk_params import FvKParameters
from dgplate.models.kirchhoff import KirchhoffSpec, build_kirchhoff
from dgplate.schema import from_dict


@dataclass(frozen=True)
class ModelEntry:
    spec: type
    build: Any  # (spec, tagged mesh) -> FlowModel
    kind: str = "flow"  # "flow": constrained gradient flow; "newton": SNES load stepping


MODELS: dict[str, ModelEntry] = {
    "kirchhoff": ModelEntry(KirchhoffSpec, build_kirchhoff),
    "bilayer": ModelEntry(BilayerSpec, build_bilayer),
    "fvk": ModelEntry(FvKParameters, None, kind="newton"),
}


def model_spec(data: Any):
    """Validate the [model] table with the spec of the model it names."""
    if data is not None and not isinstance(data, dict):
        raise InputError(f"[model] must be a table, got {data!r}")
    data = dict(data or {})
    name = data.get("name", "kirchhoff")
    if not isinstance(name, str) or name not in MODELS:
        raise InputError(f"model.name must be one of {', '.join(sorted(MODELS))}, got {name!r}")
    spec = from_dict(MODELS[name].spec, data, "model")
    if hasattr(spec, "validate"):
        spec.validate()
    return spec
