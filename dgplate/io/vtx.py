"""Time series of the deformation for ParaView: VTX (ADIOS2) files, XDMF when ADIOS2 is absent.

``DeformationWriter`` writes the deformation y and the displacement u = y − x (so ParaView's
"Warp By Vector" on u shows the deformed plate) as DG fields of y's degree and, for a plate,
the Gaussian curvature ``gauss_curvature`` of the deformed surface per cell (with a target
metric G also ``target_gauss_curvature``, that of G). With a ``[material]`` (``length_mm``) the
mesh, y and u are written in millimetres and the curvatures in 1/mm², the units of a plate's
pictures' colours and of ``dgplate export``'s solids. VTX takes DG fields of any degree, but
one writer needs one element for all its functions, so extra functions on other elements (a P1
temperature, a DG0 cell field) go to their own ``.bp`` files next to the main one. XDMF stores only fields of the mesh's geometry degree: there
everything is interpolated into P1 (DG0 fields stay cell data).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from mpi4py import MPI

import dolfinx.common
import dolfinx.fem
import dolfinx.io
from ufl.core.expr import Expr

from dgplate import compat
from dgplate.compat import Function
from dgplate.errors import InputError
from dgplate.measure.fields import (
    CellField,
    gauss_field,
    output_element,
    set_displacement,
    to_output_space,
)
from dgplate.measure.prestrain import target_gauss_field

BACKENDS = ("auto", "vtx", "xdmf")


def _element_key(f: Function) -> tuple[int, bool]:
    """What a VTX writer needs to share: the scalar Lagrange element (any block size)."""
    element = compat.ufl_element(f.function_space)
    return (element.embedded_superdegree, element.discontinuous)


def _is_cellwise(f: Function) -> bool:
    """Whether ``f`` is a cell-wise constant (DG0) field, written as cell data."""
    return compat.ufl_element(f.function_space).embedded_superdegree == 0


class DeformationWriter:
    """Writes y, u = y − x, K (on a plate) and optional extra functions at each ``write(t)``.

    ``path`` names the main file (``.bp`` for VTX, ``.xdmf`` for XDMF; the suffix is set
    from the backend). Extra functions need unique names; on VTX those whose element differs
    from y's go to ``<stem>_<name>.bp``. ``backend``: "vtx", "xdmf" or "auto" (VTX when
    DOLFINx has ADIOS2). ``metric``: a plate's target metric G, whose Gaussian curvature is
    written too (``target_gauss_curvature``). ``length_mm``: the length of one mesh unit in
    mm (a ``[material]``'s), to write the mesh and the fields in mm and 1/mm²; None: mesh units.
    Collective: every rank constructs, writes and closes.
    """

    def __init__(
        self,
        path: str | Path,
        y: Function,
        extras: Sequence[Function] = (),
        backend: str = "auto",
        comm: MPI.Comm | None = None,
        metric: Expr | None = None,
        length_mm: float | None = None,
    ):
        if backend not in BACKENDS:
            raise InputError(
                f"output backend must be one of {', '.join(BACKENDS)}, not {backend!r}"
            )
        if backend == "auto":
            backend = "vtx" if dolfinx.common.has_adios2 else "xdmf"
        if backend == "vtx" and not dolfinx.common.has_adios2:
            raise InputError("VTX output needs DOLFINx built with ADIOS2; use backend='xdmf'")
        if y.ufl_shape != (3,):
            raise InputError(f"DeformationWriter needs y with three components, not {y.ufl_shape}")
        self.backend = backend
        self.comm = comm or y.function_space.mesh.comm
        self.y = y
        self.length_mm = length_mm
        # the Gaussian curvature of a surface (not of a rod's centreline), a DG0 cell field
        plate = y.function_space.mesh.topology.dim == 2
        self._cell_fields: list[CellField] = [gauss_field(y)] if plate else []
        if plate and metric is not None:  # K of the target metric G, to compare with
            self._cell_fields.append(target_gauss_field(y.function_space.mesh, metric))
        self.extras = [*extras, *(field.function for field in self._cell_fields)]
        names = ["deformation", "displacement", *(f.name for f in self.extras)]
        if len(set(names)) != len(names):
            raise InputError(f"output function names must be unique, got {names}")
        suffix = ".bp" if backend == "vtx" else ".xdmf"
        self.path = Path(path).with_suffix(suffix)
        if self.comm.rank == 0:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        self.comm.barrier()
        self.paths: list[Path] = []
        self._writers: list[dolfinx.io.VTXWriter | dolfinx.io.XDMFFile] = []
        self._extra_outputs: list[tuple[Function, Function]] = []  # (source, written copy)
        self._closed = False
        if backend == "vtx":
            self._open_vtx()
        else:
            self._open_xdmf()

    # -- set-up -----------------------------------------------------------------------------
    def _outputs(self, degree: int, discontinuous: bool) -> None:
        """The output copies of y and u on ``output_element(degree)`` and their dof coords."""
        mesh = self.y.function_space.mesh
        element = output_element(mesh, degree, self.y.ufl_shape, discontinuous)
        same = element == compat.ufl_element(self.y.function_space)
        space = self.y.function_space if same else dolfinx.fem.functionspace(mesh, element)
        self._copy = same  # same space: copy the dof values, else interpolate
        self.y_out: Function = dolfinx.fem.Function(space, name="deformation")
        self.u_out: Function = dolfinx.fem.Function(space, name="displacement")
        self._x = space.tabulate_dof_coordinates()

    def _open_vtx(self) -> None:
        """One VTX writer per element: y and u in one file, extras on other elements apart."""
        element = compat.ufl_element(self.y.function_space)
        self._outputs(element.embedded_superdegree, element.discontinuous)
        main_key = _element_key(self.y_out)
        groups: dict[tuple[int, bool], list[Function]] = {main_key: [self.y_out, self.u_out]}
        for f in self.extras:  # equispaced copies of degree >= 3 fields
            out = f if _is_cellwise(f) else to_output_space(f)
            self._extra_outputs.append((f, out))
            groups.setdefault(_element_key(out), []).append(out)
        policy = dolfinx.io.VTXMeshPolicy.reuse  # the reference mesh never changes
        for key, functions in groups.items():
            path = self.path
            if key != main_key:
                path = self.path.with_name(f"{self.path.stem}_{functions[0].name}.bp")
            self._writers.append(
                dolfinx.io.VTXWriter(self.comm, str(path), functions, "BPFile", policy)
            )
            self.paths.append(path)

    def _open_xdmf(self) -> None:
        """One XDMF file: P1 copies of y, u and the extras (DG0 fields as they are)."""
        self._outputs(1, discontinuous=False)  # XDMF: geometry-degree (P1) fields only
        for f in self.extras:
            self._extra_outputs.append((f, f if _is_cellwise(f) else to_output_space(f, 1, False)))
        mesh = self.y.function_space.mesh
        writer = dolfinx.io.XDMFFile(self.comm, str(self.path), "w")
        with self._geometry_in_mm():
            writer.write_mesh(mesh)
        self._writers.append(writer)
        self.paths += [self.path, self.path.with_suffix(".h5")]

    # -- output -----------------------------------------------------------------------------
    def _update(self) -> None:
        """Bring the written copies up to date with y and the extras (in mm with ``length_mm``).

        Never inside :meth:`_geometry_in_mm`: the curvature fields depend on the coordinates.
        """
        if self._copy:
            self.y_out.x.array[:] = self.y.x.array
        else:
            self.y_out.interpolate(self.y)
        set_displacement(self.u_out, self.y_out, self._x)
        for field in self._cell_fields:
            field.update()
        if self.length_mm is not None:  # lengths in mm, the Gaussian curvatures in 1/mm²
            for length in (self.y_out, self.u_out):
                length.x.array[:] *= self.length_mm
            for field in self._cell_fields:
                field.function.x.array[:] /= self.length_mm**2
        for source, out in self._extra_outputs:
            if out is not source:
                out.interpolate(source)

    def write(self, t: float) -> None:
        """Append the current state at time ``t`` to every file."""
        if self._closed:
            raise RuntimeError("DeformationWriter.write after close()")
        self._update()
        if self.backend == "vtx":
            with self._geometry_in_mm():  # the mesh is written at the first step (DG0: each)
                for writer in self._writers:
                    writer.write(float(t))
            return
        (writer,) = self._writers
        assert isinstance(writer, dolfinx.io.XDMFFile)
        for f in (self.y_out, self.u_out):
            writer.write_function(f, float(t))
        for _, out in self._extra_outputs:
            writer.write_function(out, float(t))

    @contextmanager
    def _geometry_in_mm(self) -> Iterator[None]:
        """The mesh's coordinates in mm for the duration (with ``length_mm``), then restored.

        DOLFINx's writers write the mesh's own geometry and take no scale; nothing is assembled
        while they write, and the coordinates are restored bit for bit from a copy.
        """
        x = self.y.function_space.mesh.geometry.x
        saved = x.copy() if self.length_mm is not None else None
        if self.length_mm is not None:
            x *= self.length_mm
        try:
            yield
        finally:
            if saved is not None:
                x[:] = saved

    def close(self) -> None:
        """Close every file (collective); later calls do nothing."""
        if not self._closed:
            for writer in self._writers:
                writer.close()
            self._closed = True

    def __enter__(self) -> DeformationWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def bp_variables(path: str | Path) -> set[str]:
    """Names of the fields a VTX ``.bp`` directory declares (from its VTK schema attribute).

    A light readability check that needs no ADIOS2 Python bindings; empty if unreadable.
    """
    import re

    names: set[str] = set()
    for meta in sorted(Path(path).glob("md.*")):
        text = meta.read_bytes().decode("latin-1")
        for _, block in re.findall(r"<(PointData|CellData)>(.*?)</\1>", text, flags=re.S):
            names.update(re.findall(r'DataArray Name="([^"]+)"', block))
    return names - {"TIME", "vtkOriginalPointIds", "vtkGhostType"}


__all__ = ["BACKENDS", "DeformationWriter", "bp_variables"]
