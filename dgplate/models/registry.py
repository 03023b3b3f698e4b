"""Model names in problem files → their spec dataclass and builder."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from dgplate.errors import InputError
from dgplate.models.bilayer import BilayerSpec, build_bilayer
from dgplate.models.kirchhoff import KirchhoffSpec, build_kirchhoff
from dgplate.schema import from_dict


@dataclass(frozen=True)
class ModelEntry:
    spec: type
    build: Any  # (spec, tagged mesh) -> FlowModel
    kind: str = "flow"  # "flow": constrained gradient flow


MODELS: dict[str, ModelEntry] = {
    "kirchhoff": ModelEntry(KirchhoffSpec, build_kirchhoff),
    "bilayer": ModelEntry(BilayerSpec, build_bilayer),
}


def model_spec(data: Any):
    """Validate the [model] table with the spec of the model it names."""
    data = dict(data or {})
    name = data.get("name", "kirchhoff")
    if name not in MODELS:
        raise InputError(f"model.name must be one of {', '.join(sorted(MODELS))}, got {name!r}")
    return from_dict(MODELS[name].spec, data, "model")
