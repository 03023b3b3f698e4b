"""Newton's method (PETSc SNES) on DΠ(u) = 0 for a load path (:mod:`dgplate.solvers.newton`).

The residual DΠ(u)[v] and the Jacobian D²Π(u)[v, δu] are the ``ufl.derivative`` of the energy;
both carry a proximal term (1/τ) M(u − uⁿ) that is zero outside the relaxation
(:class:`dgplate.solvers.branch.BranchLeaving`), so the Hessian is the plain one elsewhere.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, cast

from mpi4py import MPI

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl
from petsc4py import PETSc

from dgplate.solvers import linear

#: SNES defaults; the ``options`` of a :class:`dgplate.solvers.newton.LoadPath` override any key.
NEWTON_DEFAULTS: dict[str, Any] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "nleqerr",
    "snes_rtol": 1e-10,
    "snes_max_it": 30,
    **linear.DIRECT_MUMPS,
}

_REASONS: dict[int, str] = {
    value: name
    for name, value in vars(PETSc.SNES.ConvergedReason).items()
    if isinstance(value, int)
}


def snes_reason(code: int) -> str:
    """The name of a SNES converged reason, e.g. ``DIVERGED_MAX_IT``."""
    return _REASONS.get(code, str(code))


class NewtonSolver:
    """SNES on the residual of an energy Π(u) with Dirichlet conditions (collective)."""

    def __init__(
        self,
        state: dolfinx.fem.Function[np.float64],
        energy: ufl.Form,
        bcs: Sequence[dolfinx.fem.DirichletBC[np.float64]],
        prefix: str,
        options: Mapping[str, Any] | None,
        options_key: str,
    ) -> None:
        """SNES for Π = ``energy`` of ``state``, options under ``prefix`` over the defaults.

        Options that PETSc refuses are an InputError naming ``options_key``.
        """
        self.state, self.bcs, self.comm = state, list(bcs), state.function_space.mesh.comm
        self.norms: list[float] = []  # the residual norms of the last solve
        space = state.function_space
        residual = ufl.derivative(energy, state, ufl.TestFunction(space))
        self.anchor: dolfinx.fem.Function[np.float64] = dolfinx.fem.Function(space)
        self.inv_tau = dolfinx.fem.Constant(space.mesh, 0.0)
        # the proximal term (1/τ) M(v − vⁿ), zero outside the flow; always in the forms, so
        # that a relaxation may be asked for later (e.g. only for the solve after a push)
        gap, mesh = state - self.anchor, space.mesh
        residual += self.inv_tau * ufl.inner(gap, ufl.TestFunction(space)) * ufl.dx(domain=mesh)
        jacobian = ufl.derivative(residual, state, ufl.TrialFunction(space))
        self._energy = dolfinx.fem.form(energy)
        self._residual = dolfinx.fem.form(residual)
        self._jacobian = dolfinx.fem.form(jacobian)
        self._prefix = prefix
        self._options = {**NEWTON_DEFAULTS, **(options or {})}
        self._setup_snes(options_key)
        self.free = _free_rows(space, self.bcs)

    def _setup_snes(self, options_key: str) -> None:
        opts = PETSc.Options()
        for key, value in self._options.items():
            opts.setValue(f"{self._prefix}{key}", value)
        self._A = dolfinx.fem.petsc.create_matrix(self._jacobian)
        self._b = self.state.x.petsc_vec.duplicate()
        self._x = self.state.x.petsc_vec.duplicate()
        self._data = self.state.x.petsc_vec.duplicate()  # g on the Dirichlet rows, x elsewhere
        snes = self.snes = PETSc.SNES().create(self.comm)
        snes.setOptionsPrefix(self._prefix)
        snes.setFunction(self._assemble_residual, self._b)
        snes.setJacobian(self._assemble_jacobian, self._A)
        snes.setMonitor(self._monitor)
        try:
            snes.setFromOptions()
            linear.check_factor_package(snes.getKSP().getPC(), self._A)
        except PETSc.Error as err:
            # no driver: its PETSc objects and options go (another driver may take the prefix)
            self._free_petsc()
            raise linear.refused(options_key, err) from None

    def prefixes(self) -> list[str]:
        """The options prefix of the SNES (where ``model.snes``'s options are read)."""
        return [self.snes.getOptionsPrefix() or ""]

    def _monitor(self, _snes: PETSc.SNES, _it: int, norm: float) -> None:
        self.norms.append(float(norm))

    def _update(self, x: PETSc.Vec) -> None:
        # SNES updates only the owned entries of x: its ghosts (read by apply_lifting, e.g. the
        # values of load-dependent Dirichlet data on another rank's unknowns) must be refreshed
        x.ghostUpdate(PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD)  # type: ignore[arg-type]
        x.copy(self.state.x.petsc_vec)
        self.state.x.scatter_forward()

    def _assemble_residual(self, _snes: PETSc.SNES, x: PETSc.Vec, b: PETSc.Vec) -> None:
        self._update(x)
        with b.localForm() as local:
            local.set(0.0)
        # DOLFINx's stubs know only the form-first overloads of the assemblers
        dolfinx.fem.petsc.assemble_vector(b, self._residual)  # type: ignore[arg-type]
        if not self._holds_dirichlet_data(x):
            dolfinx.fem.petsc.apply_lifting(b, [self._jacobian], [self.bcs], [x], -1.0)
        b.ghostUpdate(PETSc.InsertMode.ADD, PETSc.ScatterMode.REVERSE)  # type: ignore[arg-type]
        dolfinx.fem.petsc.set_bc(b, self.bcs, x, -1.0)

    def _holds_dirichlet_data(self, x: PETSc.Vec) -> bool:
        """Whether ``x`` equals the Dirichlet data g exactly on its owned rows (collective).

        Then the lifting of the data, J(g − x), is zero, and it is skipped: it integrates the
        Jacobian over every cell at a Dirichlet boundary, 13 % of the time of a Newton solve
        on the FvK cone. A residual where x misses g (a load step's first, where g moved, or
        one where Newton reached g only to round-off) still lifts. In serial the result is the
        same bit for bit; under MPI the lifting also read g at ghost rows, where interpolated
        data may differ from its owner's by round-off.
        """
        data = self._data
        x.copy(data)
        dolfinx.fem.petsc.set_bc(data, self.bcs)
        data.axpy(-1.0, x)
        return bool(data.norm(PETSc.NormType.NORM_INFINITY) == 0.0)

    def _assemble_jacobian(
        self, _snes: PETSc.SNES, x: PETSc.Vec, A: PETSc.Mat, _P: PETSc.Mat
    ) -> None:
        self._update(x)
        A.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(A, self._jacobian, self.bcs)  # type: ignore[arg-type]
        A.assemble()

    def solve(self, atol: float | None = None, max_it: int | None = None) -> tuple[int, int]:
        """SNES from the current state; the state is the last iterate.

        Args:
            atol: this solve also stops at a residual norm ≤ atol (None: the options' own).
            max_it: this solve takes at most max_it iterations (None, or more than the options'
                own: the options' own).

        Returns:
            (SNES converged reason, iterations).
        """
        rtol, own_atol, stol, own_max_it = self.snes.getTolerances()
        self.snes.setTolerances(
            atol=own_atol if atol is None else max(atol, own_atol),
            max_it=own_max_it if max_it is None else min(max_it, own_max_it),
        )
        self.state.x.petsc_vec.copy(self._x)
        try:
            self.snes.solve(None, self._x)
        finally:
            self.snes.setTolerances(rtol, own_atol, stol, own_max_it)
        self._update(self._x)
        # an int at run time (petsc4py's stubs say ConvergedReason)
        return cast(int, self.snes.getConvergedReason()), int(self.snes.getIterationNumber())

    def residual(self, b: PETSc.Vec) -> None:
        """The residual of the current state into ``b``, as SNES sees it (collective).

        The Dirichlet rows hold u − g (g the data at the current load factor), the free rows
        DΠ(u) lifted by the Jacobian's Dirichlet columns times g − u.

        Args:
            b: the vector written (of the state's layout).
        """
        self.state.x.petsc_vec.copy(self._x)
        self._assemble_residual(self.snes, self._x, b)

    def jacobian(self) -> PETSc.Mat:
        """The Jacobian of the current state (collective).

        Returns:
            The solver's own matrix (do not destroy it), assembled now; its Dirichlet rows and
            columns are those of the identity.
        """
        self._assemble_jacobian(self.snes, self.state.x.petsc_vec, self._A, self._A)
        return self._A

    def plain_residual_norm(self) -> float:
        """‖DΠ(u)‖ of the current state with the Dirichlet rows as SNES sees them (collective)."""
        scale = float(self.inv_tau.value)
        self.inv_tau.value = np.asarray(0.0)
        self.residual(self._b)
        self.inv_tau.value = np.asarray(scale)
        return float(self._b.norm())

    def free_hessian(self) -> PETSc.Mat:
        """The Hessian of the current state on the free unknowns (a new matrix: destroy it)."""
        return self.jacobian().createSubMatrix(self.free[0], self.free[0])

    def energy_value(self) -> float:
        """Π of the current state (collective)."""
        local = dolfinx.fem.assemble_scalar(self._energy)
        return float(self.comm.allreduce(local, op=MPI.SUM))

    def _free_petsc(self) -> None:
        """Destroy the SNES, its matrix and vectors, and delete the options."""
        opts = PETSc.Options()
        for key in self._options:
            opts.delValue(f"{self._prefix}{key}")
        for obj in (self.snes, self._A, self._b, self._x, self._data):
            obj.destroy()

    def destroy(self) -> None:
        """Free the PETSc objects and delete the options."""
        self._free_petsc()
        self.free[0].destroy()


def _free_rows(
    space: dolfinx.fem.FunctionSpace[np.float64],
    bcs: Sequence[dolfinx.fem.DirichletBC[np.float64]],
) -> tuple[PETSc.IS, npt.NDArray[np.int64]]:
    """The owned unknowns without Dirichlet conditions: global rows (an IS) and local indices."""
    imap, bs = space.dofmap.index_map, space.dofmap.index_map_bs
    owned = imap.size_local * bs
    free = np.ones(owned, dtype=bool)
    for bc in bcs:
        dofs = bc.dof_indices()[0]
        free[dofs[dofs < owned]] = False
    local = np.flatnonzero(free).astype(np.int64)
    rows = PETSc.IS().createGeneral(
        (imap.local_range[0] * bs + local).astype(PETSc.IntType), comm=space.mesh.comm
    )
    return rows, local
