"""The flow's step systems solved through the Schur complement on the multipliers.

The step matrix is K = [[A ⊗ I₃, Bᵀ], [B, C]]: the constant block does not couple the three
components of y, so it is one scalar matrix A (a third of the rows) repeated three times, and
it does not change while τ is fixed; B is the linearised constraint, cell-local; C is zero or
the diagonal that pins unused edge multipliers. Eliminating δy,

    Σ λ = B (A⁻¹ ⊗ I₃) f − g,      Σ = B (A⁻¹ ⊗ I₃) Bᵀ − C,      δy = (A⁻¹ ⊗ I₃)(f − Bᵀ λ),

so one factorisation of A serves the whole run. Σ is solved by CG (MINRES when C ≠ 0, which
makes Σ indefinite) on a shell matrix. Its preconditioners start from P = B (D⁻¹ ⊗ I₃) Bᵀ + C
with D the cell-diagonal blocks of A: a cell-block-diagonal matrix, since B is cell-local, so
its block Jacobi LU is exact and the same on any partition. P alone ('cell') leaves a
condition number ∝ h⁻² (Σ has an order −2 part that no cell-local matrix sees), and so does
the scaled BFBᵀ approximation ('bfbt', :class:`ScaledBFBt`, the default) with a smaller
constant; the auxiliary-space preconditioner (:class:`AuxiliarySpace`, after
:meth:`SchurStepSolver.use_embedding`) adds the continuous Lagrange space and keeps the
iteration count bounded under refinement (docs/performance.md). Each application of A⁻¹
treats the three components as one three-column right-hand side (MatMatSolve), so the
factors are read once.

A is factorised in the cell-wise numbering (:mod:`dgplate.solvers.ordering`), the same on any
number of ranks. :func:`unsupported` says why a step matrix does not have this structure (then
the flow falls back to :class:`dgplate.solvers.linear.LaggedStepSolver`).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import cast

from mpi4py import MPI

import dolfinx
import numpy as np
import numpy.typing as npt
from petsc4py import PETSc

from dgplate import compat
from dgplate.compat import FunctionSpace, Indices
from dgplate.errors import InputError, SolverError
from dgplate.solvers import linear
from dgplate.solvers.linear import Options, OptionValue, SolveStats

#: The factorisation of A: MUMPS Cholesky (A is symmetric; LDLᵀ with pivoting if indefinite).
FACTOR_MUMPS: dict[str, OptionValue] = {
    "ksp_type": "preonly",
    "pc_type": "cholesky",
    "pc_factor_mat_solver_type": "mumps",
    "mat_mumps_icntl_14": 80,
}

#: The factorisation of H (auxiliary-space preconditioner): MUMPS Cholesky, optionally with
#: block low-rank compression (the factors only precondition).
H_FACTOR: dict[str, OptionValue] = {**FACTOR_MUMPS}

#: The Krylov solve on Σ. The tolerance makes the step agree with a direct solve to ~1e-11.
KRYLOV: dict[str, OptionValue] = {
    "ksp_rtol": 1e-12,
    "ksp_atol": 0.0,
    "ksp_max_it": 20000,
}

#: The cell-block preconditioner P: block Jacobi with LU blocks, exact since P is block diagonal.
CELL_BLOCKS: dict[str, OptionValue] = {"pc_type": "bjacobi", "sub_pc_type": "lu"}

#: Preconditioners of Σ, chosen by the step-solver option ``schur_pc`` (flow.solver):
#: 'aux' the auxiliary-space preconditioner in the continuous space of y's degree (the
#: default; the flow hands it the space with :meth:`SchurStepSolver.use_embedding`, and until
#: then, or without a flow, 'bfbt' serves), 'bfbt' the scaled BFBᵀ (least-squares commutator)
#: approximation of Σ⁻¹, 'cell' the cell-block matrix B (D⁻¹ ⊗ I₃) Bᵀ + C.
PRECONDITIONERS = ("aux", "bfbt", "cell")

#: The auxiliary-space preconditioner (built for one B) is rebuilt for the current B after a
#: solve that needed more than this factor times the iterations of its first solve.
REBUILD_GROWTH = 1.5

#: Relative size below which a block of the constant matrix counts as zero (or two as equal).
_EXACT = 1e-13

_DIFFERENT = cast("PETSc.Mat.Structure", PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
_ALLOCATION_ERR = cast("PETSc.Mat.Option", PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR)

_log = logging.getLogger(__name__)

Split = tuple[list[PETSc.IS], PETSc.IS]


def split_unknowns(K: PETSc.Mat, component: npt.NDArray[np.int32], numbering: PETSc.IS) -> Split:
    """Index sets of the three components of y and of the multipliers, in cell-wise order.

    ``component`` gives, for each owned row of K (its local numbering), the component of y
    (0, 1, 2) or −1 for a multiplier; ``numbering`` lists the rows owned here in the cell-wise
    numbering. Within a cell the nodes of the three components come in the same order, so
    the i-th entries of the three sets are the same node.
    """
    kind = K.createVecRight()
    kind.getArray()[:] = component
    perm = PETSc.Vec().createMPI((numbering.getLocalSize(), PETSc.DECIDE), comm=K.getComm())
    scatter = _scatter(kind, numbering, perm)
    scatter.scatter(kind, perm, compat.INSERT, compat.FORWARD)
    kinds = perm.getArray().round().astype(int)
    rows = numbering.getIndices()
    comm = K.getComm()
    parts = [PETSc.IS().createGeneral(rows[kinds == c], comm=comm) for c in (0, 1, 2, -1)]
    for obj in (kind, perm, scatter):
        obj.destroy()
    return parts[:3], parts[3]


def unsupported(A_const: PETSc.Mat, split: Split) -> str:
    """Why the constant block is not A ⊗ I₃ with no multiplier coupling ('' when it is)."""
    components, multipliers = split
    A = A_const.createSubMatrix(components[0], components[0])
    scale = max(_norm(A), 1e-300)
    try:
        for c, rows in enumerate(components):
            for d, cols in enumerate(components):
                if c == d == 0:
                    continue
                block = A_const.createSubMatrix(rows, cols)
                if c == d and c > 0:
                    block.axpy(-1.0, A)
                size = _norm(block)
                block.destroy()
                if size > _EXACT * scale:
                    what = "differs between components" if c == d else "couples components"
                    return f"the implicit part {what} ({c}, {d}): relative size {size / scale:.1e}"
        block = A_const.createSubMatrix(multipliers, components[0])
        size = _norm(block)
        block.destroy()
        if size > _EXACT * scale:
            return "the constant block couples multipliers to y"
    finally:
        A.destroy()
    return ""


def _scatter(source: PETSc.Vec, rows: PETSc.IS, target: PETSc.Vec) -> PETSc.Scatter:
    """The scatter of the entries ``rows`` of ``source`` to all of ``target``, in order."""
    return PETSc.Scatter().create(source, rows, target, None)  # type: ignore[arg-type]


def inverse_blocks(matrix: PETSc.Mat, n: int) -> PETSc.Mat:
    """The inverses of the n × n diagonal blocks of consecutive owned rows (one cell each)."""
    indptr, indices, values = matrix.getValuesCSR()
    start = matrix.getOwnershipRange()[0]
    local_rows = len(indptr) - 1
    rows = np.repeat(np.arange(local_rows), np.diff(indptr))
    cols = indices.astype(np.int64) - start
    inside = (cols >= 0) & (cols < local_rows) & (cols // n == rows // n)
    blocks = np.zeros((local_rows // n, n, n))
    blocks[rows[inside] // n, rows[inside] % n, cols[inside] % n] = values[inside]
    inverse = np.linalg.inv(blocks)
    new_indptr = np.arange(0, local_rows * n + 1, n, dtype=PETSc.IntType)
    columns = (start + (np.arange(local_rows)[:, None] // n) * n + np.arange(n)).reshape(-1)
    csr = (new_indptr, columns.astype(PETSc.IntType), inverse.reshape(-1))
    sizes = matrix.getSizes()
    return PETSc.Mat().createAIJ(size=sizes, csr=csr, comm=matrix.getComm())  # type: ignore[arg-type]


def _norm(matrix: PETSc.Mat) -> float:
    return float(cast("float", matrix.norm(compat.NORM_INFINITY)))


@dataclass
class Tally:
    """How often an operator was applied, and the wall time it took: where a solve's time goes."""

    applications: int = 0
    seconds: float = 0.0

    @contextmanager
    def timing(self) -> Iterator[None]:
        """Count one application and add its wall time."""
        start = time.perf_counter()
        try:
            yield
        finally:
            self.applications += 1
            self.seconds += time.perf_counter() - start


class SchurContext:
    """Python shell context: Σ λ = B (A⁻¹ ⊗ I₃) Bᵀ λ − C λ."""

    def __init__(self, solver: SchurStepSolver):
        self.s = solver

    def mult(self, mat: PETSc.Mat, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """Apply Σ: y = Σ x (called by petsc4py)."""
        with self.s.sigma_tally.timing():
            self._mult(x, y)

    def _mult(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        s = self.s
        for c, Bc in enumerate(s.B):
            column = s.rhs.getDenseColumnVec(c, "w")
            Bc.multTranspose(x, column)
            s.rhs.restoreDenseColumnVec(c, "w")
        s.apply_inverse()
        if s.C is not None:
            s.C.mult(x, y)
            y.scale(-1.0)
        else:
            y.zeroEntries()
        for c, Bc in enumerate(s.B):
            column = s.sol.getDenseColumnVec(c, "r")
            Bc.multAdd(column, y, y)
            s.sol.restoreDenseColumnVec(c, "r")


class ScaledBFBt:
    """Python PC context: Σ⁻¹ ≈ P⁻¹ F P⁻¹ with P = B (D⁻¹ ⊗ I₃) Bᵀ + C, F = B (D⁻¹AD⁻¹ ⊗ I₃) Bᵀ + C.

    The scaled BFBᵀ (least-squares commutator) approximation of the inverse Schur complement
    with the weight D, the cell-diagonal blocks of A. Both P and F are sparse and assembled
    once per constraint matrix; P is cell-block diagonal (its block-Jacobi LU is exact), so
    one application costs two cell-local solves and one sparse product, and no solve with A.
    """

    def __init__(self, solver: SchurStepSolver):
        self.s = solver
        self.work: PETSc.Vec | None = None

    def apply(self, pc: PETSc.PC, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """Apply the preconditioner: y = P⁻¹ F P⁻¹ x (called by petsc4py)."""
        s = self.s
        assert s.inner is not None and s.F is not None
        if self.work is None:
            self.work = x.duplicate()
        with s.pc_tally.timing():
            s.inner.solve(x, y)
            s.F.mult(y, self.work)
            s.inner.solve(self.work, y)


class AuxiliarySpace:
    """Python PC context: Σ⁻¹ ≈ (P + Q)⁻¹, Q = Ĝ (A_c⁻¹ ⊗ I₃) Ĝᵀ, applied by the Woodbury identity.

    E embeds the continuous Lagrange functions of the same degree into the dG space (one
    component). A⁻¹ ≈ D⁻¹ + E A_c⁻¹ Eᵀ with A_c = Eᵀ A E is the two-level additive (auxiliary
    space) approximation of A⁻¹: the cell blocks take the local, jump-dominated part, the
    continuous space the smooth part, where the cell blocks alone fail (Σ's condition number
    under the cell-block preconditioner grows like h⁻²). Inserted into Σ = B (A⁻¹ ⊗ I₃) Bᵀ − C
    it gives Σ ≈ P + Q with G_c = B_c E, and

        (P + Q)⁻¹ = P⁻¹ − P⁻¹ Ĝ H⁻¹ Ĝᵀ P⁻¹,    H = A_c ⊗ I₃ + Ĝᵀ P⁻¹ Ĝ,

    P⁻¹ exact and cell-block diagonal, H the (component-coupled) matrix on the continuous
    space, factorised by MUMPS. A_c is formed once per factorisation of A. B changes slowly
    from step to step, so P, Ĝ and H are kept (lagged, a fixed SPD preconditioner) until a
    solve needs more than :data:`REBUILD_GROWTH` times the iterations of the first solve with
    them; ``rebuilds`` counts the factorisations of H.
    """

    def __init__(self, solver: SchurStepSolver, embedding: PETSc.Mat):
        self.s = solver
        comm = embedding.getComm()
        first, last = embedding.getOwnershipRangeColumn()
        columns = PETSc.IS().createStride(last - first, first=first, step=1, comm=comm)
        self.E = embedding.createSubMatrix(solver.components[0], columns)
        columns.destroy()
        self.Ac: PETSc.Mat | None = None
        self.H: PETSc.Mat | None = None
        self.Pinv: PETSc.Mat | None = None
        self.G: list[PETSc.Mat] = []
        self.ksp: PETSc.KSP | None = None
        self.u, self.w = solver.lam.duplicate(), solver.lam.duplicate()
        self.coarse = [self.E.createVecRight() for _ in range(3)]
        self.h_rhs: PETSc.Vec | None = None
        self.h_sol: PETSc.Vec | None = None
        self.stale = True
        self.baseline: int | None = None
        self.rebuilds = 0

    def constant_changed(self) -> None:
        """A was refactorised: A_c = Eᵀ A E, and H must be rebuilt."""
        if self.Ac is not None:
            self.Ac.destroy()
        self.Ac = self.s.A.ptap(self.E)
        self.stale = True

    def observe(self, iterations: int) -> None:
        """Record a solve's iterations: rebuild at the next new B if they grew too much."""
        if self.baseline is None:
            self.baseline = iterations
        elif iterations > REBUILD_GROWTH * self.baseline:
            self.stale = True

    def constraint_changed(self, P: PETSc.Mat) -> None:
        """B changed: if stale, P⁻¹, G_c = B_c E and the factors of H for the current B."""
        assert self.Ac is not None
        if not self.stale:
            return
        self.stale, self.baseline = False, None
        self.rebuilds += 1
        self._destroy_constraint()
        cells = self.s.A.getLocalSize()[0] // self.s.nodes_per_cell
        self.Pinv = inverse_blocks(P, P.getLocalSize()[0] // max(cells, 1))
        self.G = [Bc.matMult(self.E) for Bc in self.s.B]
        PG = [self.Pinv.matMult(Gd) for Gd in self.G]
        blocks: list[list[PETSc.Mat]] = [[Gc.transposeMatMult(PGd) for PGd in PG] for Gc in self.G]
        for c in range(3):
            blocks[c][c].axpy(1.0, self.Ac, structure=_DIFFERENT)
        nest = PETSc.Mat().createNest(blocks, comm=P.getComm())
        self.H = nest.convert("aij")  # in place: H is the converted nest
        for obj in [*PG, *(b for row in blocks for b in row)]:
            obj.destroy()
        if self.ksp is None:
            comm = self.H.getComm()
            self.ksp = linear.make_ksp(comm, self.H, defaults=H_FACTOR)  # type: ignore[arg-type]
        self.ksp.setOperators(self.H)
        linear.factorise(self.ksp)
        if self.h_rhs is None:
            self.h_rhs, self.h_sol = self.H.createVecLeft(), self.H.createVecRight()

    def apply(self, pc: PETSc.PC, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """Apply the preconditioner: y = P⁻¹ x − P⁻¹ Ĝ H⁻¹ Ĝᵀ P⁻¹ x (called by petsc4py)."""
        with self.s.pc_tally.timing():
            self._apply(x, y)

    def _apply(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        assert self.Pinv is not None and self.ksp is not None
        assert self.h_rhs is not None and self.h_sol is not None
        self.Pinv.mult(x, self.u)
        n = self.coarse[0].getLocalSize()
        rhs = self.h_rhs.getArray()
        for c, Gc in enumerate(self.G):
            Gc.multTranspose(self.u, self.coarse[c])
            rhs[c * n : (c + 1) * n] = self.coarse[c].getArray(readonly=True)
        self.ksp.solve(self.h_rhs, self.h_sol)
        sol = self.h_sol.getArray(readonly=True)
        self.w.zeroEntries()
        for c, Gc in enumerate(self.G):
            self.coarse[c].getArray()[:] = sol[c * n : (c + 1) * n]
            Gc.multAdd(self.coarse[c], self.w, self.w)
        self.Pinv.mult(self.w, y)
        y.aypx(-1.0, self.u)

    def _destroy_constraint(self) -> None:
        for obj in [self.H, self.Pinv, *self.G]:
            if obj is not None:
                obj.destroy()
        self.H, self.Pinv, self.G = None, None, []

    def release(self) -> None:
        """Free the matrices, the factors and the work vectors.

        Not ``destroy``: petsc4py calls a context's ``destroy(pc)`` when its PC goes.
        """
        self._destroy_constraint()
        if self.ksp is not None:
            linear.destroy_ksp(self.ksp)
        for obj in [self.E, self.Ac, self.u, self.w, self.h_rhs, self.h_sol, *self.coarse]:
            if obj is not None:
                obj.destroy()


def continuous_embedding(W: FunctionSpace, V: FunctionSpace, vdofs: Indices) -> PETSc.Mat:
    """E: the continuous Lagrange space of V's degree → W, as the first component of y.

    V is the (discontinuous, three-component) space of y, collapsed from W with parent
    indices ``vdofs`` (component c of V's node i at ``vdofs[3 i + c]``). A discontinuous
    Lagrange element numbers its nodes as the continuous one, so the k-th node of a cell in V
    is the k-th node of the cell in the continuous space: E has one entry 1 per such row.
    """
    mesh = V.mesh
    cells = mesh.topology.index_map(mesh.topology.dim).size_local
    per_cell = V.dofmap.dof_layout.num_dofs
    degree = (
        round(math.sqrt(per_cell)) - 1
        if mesh.topology.cell_name() == "quadrilateral"
        else (round((math.sqrt(8 * per_cell + 1) - 3) / 2))
    )
    Vc = dolfinx.fem.functionspace(mesh, ("Lagrange", degree))
    nodes = V.dofmap.list[:cells].reshape(-1)
    rows = vdofs[3 * nodes].astype(np.int64)
    imap, bs = W.dofmap.index_map, W.dofmap.index_map_bs
    owned = rows < imap.size_local * bs
    rows = rows[owned] + imap.local_range[0] * bs
    cmap = Vc.dofmap.index_map
    cols = cmap.local_to_global(Vc.dofmap.list[:cells].reshape(-1).astype(np.int32))[owned]
    sizes = ((imap.size_local * bs, imap.size_global * bs), (cmap.size_local, cmap.size_global))
    E = PETSc.Mat().createAIJ(sizes, nnz=(1, 1), comm=imap.comm)
    E.setOption(_ALLOCATION_ERR, False)
    for r, c in zip(rows, cols, strict=True):
        E.setValue(int(r), int(c), 1.0, addv=compat.INSERT)
    E.assemble()
    return E


class SchurStepSolver:
    """Solves K x = b by the Schur complement on the multipliers (see the module docstring).

    ``split`` comes from :func:`split_unknowns`, ``nodes_per_cell`` is the number of nodes of
    one component of y in a cell (the size of D's blocks). Call :meth:`constant_changed` after
    A_const changed (a new τ): A is refactorised then.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        K: PETSc.Mat,
        A_const: PETSc.Mat,
        split: Split,
        nodes_per_cell: int,
        options: Options | None = None,
    ):
        self.K, self.A_const, self.nodes_per_cell = K, A_const, nodes_per_cell
        self.components, self.multipliers = split
        rows = self.components[0]
        options = dict(options or {})
        requested = str(options.pop("schur_pc", PRECONDITIONERS[0]))
        if requested not in PRECONDITIONERS:
            raise InputError(
                f"flow.solver.schur_pc must be one of {PRECONDITIONERS}, got {requested!r}"
            )
        #: whether the caller should hand over the continuous space (:meth:`use_embedding`)
        self.wants_embedding = requested == "aux"
        self.preconditioner = "bfbt" if self.wants_embedding else requested
        krylov = {k: v for k, v in options.items() if str(k).startswith("ksp_")}
        factor = {k: v for k, v in options.items() if not str(k).startswith("ksp_")}
        self.A = A_const.createSubMatrix(rows, rows)
        self.factor_ksp = linear.make_ksp(comm, self.A, factor, defaults=FACTOR_MUMPS)
        C = A_const.createSubMatrix(self.multipliers, self.multipliers)
        self.C: PETSc.Mat | None = C
        if _norm(C) == 0:
            C.destroy()
            self.C = None
        self.B = [K.createSubMatrix(self.multipliers, cols) for cols in self.components]
        n_local, n_global = cast("tuple[tuple[int, int], object]", self.A.getSizes())[0]
        dense = ((n_local, n_global), (PETSc.DECIDE, 3))
        self.rhs = PETSc.Mat().createDense(dense, comm=comm)  # type: ignore[arg-type]
        self.sol = PETSc.Mat().createDense(dense, comm=comm)  # type: ignore[arg-type]
        for mat in (self.rhs, self.sol):
            mat.setUp()
            mat.assemble()
        self.lam = self.B[0].createVecLeft()
        self.g = self.B[0].createVecLeft()
        template, whole = self.A.createVecRight(), K.createVecRight()
        self.y_scatters = [_scatter(whole, is_, template) for is_ in self.components]
        self.m_scatter = _scatter(whole, self.multipliers, self.lam)
        template.destroy()
        whole.destroy()
        self.context = SchurContext(self)
        m_sizes = self.lam.getSizes()
        self.S = PETSc.Mat().createPython((m_sizes, m_sizes), self.context, comm=comm)  # type: ignore[arg-type]
        self.S.setUp()
        self.P: PETSc.Mat | None = None
        method = "minres" if self.C is not None else "cg"
        cell = CELL_BLOCKS if self.preconditioner == "cell" else {"pc_type": "none"}
        defaults = {**KRYLOV, **cell, "ksp_type": method}
        self.ksp = linear.make_ksp(comm, self.S, krylov, defaults=defaults)
        self.ksp.setInitialGuessNonzero(True)
        self.Dinv: PETSc.Mat | None = None
        self.G: PETSc.Mat | None = None  # D⁻¹ A D⁻¹ ('bfbt')
        self.F: PETSc.Mat | None = None  # B (D⁻¹ A D⁻¹ ⊗ I₃) Bᵀ + C ('bfbt')
        self.inner: PETSc.KSP | None = None  # the cell-block solve with P ('bfbt')
        self.bfbt: ScaledBFBt | None = None
        self.aux: AuxiliarySpace | None = None
        self._factored = False
        self.factorisations = 0
        #: applications of Σ and of its preconditioner, and their wall time (profiles)
        self.sigma_tally, self.pc_tally = Tally(), Tally()

    # -- the constant part ------------------------------------------------------------------
    def constant_changed(self) -> None:
        """A_const was reassembled (τ changed): refactorise A at the next solve."""
        self._factored = False

    def _factorise(self) -> None:
        rows = self.components[0]
        self.A_const.createSubMatrix(rows, rows, submat=self.A)
        self.factor_ksp.setOperators(self.A)
        linear.factorise(self.factor_ksp)
        self.factor = self.factor_ksp.getPC().getFactorMatrix()
        if self.Dinv is not None:
            self.Dinv.destroy()
        self.Dinv = inverse_blocks(self.A, self.nodes_per_cell)
        if self.G is not None:
            self.G.destroy()
            self.G = None
        if self.preconditioner == "bfbt":
            self.G = self.Dinv.matMatMult(self.A, self.Dinv)
        if self.aux is not None:
            self.aux.constant_changed()
        self._factored = True
        self.factorisations += 1

    def _sandwich(self, middle: PETSc.Mat) -> PETSc.Mat:
        """B (middle ⊗ I₃) Bᵀ + C for the current B."""
        total: PETSc.Mat | None = None
        for Bc in self.B:
            Bt = Bc.transpose(PETSc.Mat())  # without an argument petsc4py transposes in place
            part = middle.ptap(Bt)
            Bt.destroy()
            if total is None:
                total = part
            else:
                total.axpy(1.0, part)
                part.destroy()
        assert total is not None
        if self.C is not None:
            total.axpy(1.0, self.C)
        return total

    def apply_inverse(self) -> None:
        """Apply A⁻¹: sol = A⁻¹ rhs, the three columns in one multi-right-hand-side substitution."""
        self.factor.matSolve(self.rhs, self.sol)

    # -- one solve --------------------------------------------------------------------------
    def _update_constraint(self) -> None:
        for cols, Bc in zip(self.components, self.B, strict=True):
            self.K.createSubMatrix(self.multipliers, cols, submat=Bc)
        for old in (self.P, self.F):
            if old is not None:
                old.destroy()
        assert self.Dinv is not None
        self.P = self._sandwich(self.Dinv)
        self.ksp.setOperators(self.S, self.P)
        if self.G is not None:
            self.F = self._sandwich(self.G)
            self._use_bfbt(self.P)
        if self.aux is not None:
            self.aux.constraint_changed(self.P)

    def use_embedding(self, embedding: PETSc.Mat) -> None:
        """Precondition Σ in the auxiliary space of ``embedding`` (:class:`AuxiliarySpace`).

        ``embedding`` is :func:`continuous_embedding` of the flow's spaces; the preconditioner
        is set up at the next solve.
        """
        self.preconditioner = "aux"
        self.aux = AuxiliarySpace(self, embedding)
        pc = self.ksp.getPC()
        pc.setType(PETSc.PC.Type.PYTHON)
        pc.setPythonContext(self.aux)
        self._factored = False

    def _use_bfbt(self, P: PETSc.Mat) -> None:
        """Precondition Σ by P⁻¹ F P⁻¹ (see :class:`ScaledBFBt`); P⁻¹ by block-Jacobi LU."""
        if self.inner is None:
            comm = self.ksp.getComm()
            cell = {"ksp_type": "preonly", **CELL_BLOCKS}
            self.inner = linear.make_ksp(comm, P, defaults=cell)  # type: ignore[arg-type]
            pc = self.ksp.getPC()
            pc.setType(PETSc.PC.Type.PYTHON)
            self.bfbt = ScaledBFBt(self)
            pc.setPythonContext(self.bfbt)
        self.inner.setOperators(P)

    def solve(self, b: PETSc.Vec, x: PETSc.Vec, refactor: bool = True) -> SolveStats:
        """Solve K x = b from the guess x's multipliers.

        ``refactor=False``: the same K as the last solve (a projection step): B is kept.
        """
        stats = SolveStats(False, 0, 0.0, 0.0)
        t0 = time.perf_counter()
        if not self._factored:
            self._factorise()
            stats.factorised = True
        if refactor or self.P is None:
            self._update_constraint()
        t1 = time.perf_counter()
        stats.factor_s = t1 - t0
        # right-hand side of Σ: B A⁻¹ f − g
        self._gather(b)
        self.apply_inverse()
        rhs = self.lam.duplicate()
        rhs.zeroEntries()
        for c, Bc in enumerate(self.B):
            column = self.sol.getDenseColumnVec(c, "r")
            Bc.multAdd(column, rhs, rhs)
            self.sol.restoreDenseColumnVec(c, "r")
        rhs.axpy(-1.0, self.g)
        self.m_scatter.scatter(x, self.lam, compat.INSERT, compat.FORWARD)
        self.ksp.solve(rhs, self.lam)
        rhs.destroy()
        reason = compat.converged_reason(self.ksp)
        if reason < 0:
            raise SolverError(f"Schur complement solve failed: KSP reason {reason}")
        stats.iterations = self.ksp.getIterationNumber()
        if self.aux is not None:
            self.aux.observe(stats.iterations)
        # δy = A⁻¹ (f − Bᵀ λ)
        self._gather(b)
        for c, Bc in enumerate(self.B):
            column = self.rhs.getDenseColumnVec(c, "w")
            work = column.duplicate()
            Bc.multTranspose(self.lam, work)
            column.axpy(-1.0, work)
            work.destroy()
            self.rhs.restoreDenseColumnVec(c, "w")
        self.apply_inverse()
        for c, scatter in enumerate(self.y_scatters):
            column = self.sol.getDenseColumnVec(c, "r")
            scatter.scatter(column, x, compat.INSERT, compat.REVERSE)
            self.sol.restoreDenseColumnVec(c, "r")
        self.m_scatter.scatter(self.lam, x, compat.INSERT, compat.REVERSE)
        stats.solve_s = time.perf_counter() - t1
        return stats

    def _gather(self, b: PETSc.Vec) -> None:
        """Gather b: rhs columns ← the three components of b's f; g ← its multiplier rows."""
        for c, scatter in enumerate(self.y_scatters):
            column = self.rhs.getDenseColumnVec(c, "w")
            scatter.scatter(b, column, compat.INSERT, compat.FORWARD)
            self.rhs.restoreDenseColumnVec(c, "w")
        self.m_scatter.scatter(b, self.g, compat.INSERT, compat.FORWARD)

    def destroy(self) -> None:
        """Free the factors, the KSPs, the blocks and the work objects."""
        self.factor_ksp.getPC().reset()
        linear.destroy_ksp(self.factor_ksp)
        linear.destroy_ksp(self.ksp)
        if self.inner is not None:
            linear.destroy_ksp(self.inner)
        if self.bfbt is not None and self.bfbt.work is not None:
            self.bfbt.work.destroy()
        if self.aux is not None:
            self.aux.release()
        others = [self.A, self.S, self.rhs, self.sol, self.lam, self.g, self.m_scatter]
        others += [*self.B, *self.y_scatters, *self.components, self.multipliers]
        others += [m for m in (self.C, self.P, self.Dinv, self.G, self.F) if m is not None]
        for obj in others:
            obj.destroy()


#: Every step solver of the flow.
StepSolver = linear.DirectStepSolver | linear.LaggedStepSolver | SchurStepSolver

_reported: set[str] = set()


def fall_back(comm: MPI.Comm, reason: str) -> None:
    """Say once (rank 0) why the Schur solver is not used; the flow then uses 'lagged'."""
    if reason not in _reported and comm.rank == 0:
        _log.warning("dgplate: flow.linear_solver = 'schur' not used (%s); using 'lagged'", reason)
    _reported.add(reason)
