"""What a run returns: :class:`Result`, the summary and the final state of a run."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import dolfinx.fem
import numpy as np

from dgplate.io.run_reader import outcome

#: The summary's figures in a :class:`Result`'s one-line ``repr``.
_REPR_KEYS = ("steps", "energy", "isometry_defect")


@dataclass
class Result:
    """What :func:`run` returns: the summary (also ``summary.json``) and the final state.

    ``result["energy"]`` reads the summary. ``shape`` is the final deformation y: ω → ℝ³;
    ``fields`` holds every function of the final state (those a checkpoint stores);
    ``history`` the rows of ``history.csv``; ``folder`` the output folder. In a notebook a
    result shows itself as a table of its main figures and its ``final.png``.
    """

    summary: dict[str, Any]
    shape: dolfinx.fem.Function[np.float64] | None = None
    fields: dict[str, dolfinx.fem.Function[np.float64]] = field(default_factory=dict)
    history: list[dict[str, Any]] = field(default_factory=list)
    folder: Path | None = None

    def __getitem__(self, key: str) -> Any:
        return self.summary[key]

    def _repr_html_(self) -> str:
        """Jupyter's view: the main figures of summary.json and the final picture."""
        import base64
        import html

        keys = ["problem", "model", "converged", "reason", "steps", "energy"]
        keys += ["isometry_defect", "dofs", "ranks", "wall_time_s"]
        rows = "".join(
            f"<tr><th style='text-align:left'>{key}</th><td style='text-align:left'>"
            f"{html.escape(_shown(self.summary[key]))}</td></tr>"
            for key in keys
            if key in self.summary
        )
        out = f"<table>{rows}</table>"
        picture = self.folder / "final.png" if self.folder is not None else None
        if picture is not None and picture.is_file():
            data = base64.b64encode(picture.read_bytes()).decode("ascii")
            out += f"<img src='data:image/png;base64,{data}' style='max-width:640px'>"
        return f"<div style='display:flex;gap:1em;align-items:flex-start'>{out}</div>"

    def get(self, key: str, default: Any = None) -> Any:
        """``summary.get(key, default)``."""
        return self.summary.get(key, default)

    def __repr__(self) -> str:
        """One line: the run, how it ended, E_h and D_h (the summary has everything)."""
        s = self.summary
        shown = [f"{s.get('problem', '?')} ({s.get('model', '?')})"]
        if "converged" in s:
            shown.append(outcome(s))
        shown += [f"{key}={_shown(s[key])}" for key in _REPR_KEYS if key in s]
        folder = f", folder={str(self.folder)!r}" if self.folder is not None else ""
        return f"Result({', '.join(shown)}{folder})"


def _shown(value: Any) -> str:
    """A summary value as a notebook shows it: floats to 6 significant digits."""
    return f"{value:.6g}" if isinstance(value, float) else str(value)
