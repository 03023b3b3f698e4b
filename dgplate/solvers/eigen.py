"""Eigenvalues of a symmetric matrix nearest a shift σ: the stability of an equilibrium.

A converged state of an energy Π is stable when the Hessian D²Π (the Newton Jacobian, restricted
to the free unknowns) is positive definite, and loses stability where its lowest eigenvalue
crosses zero (a bifurcation or a limit point). :func:`nearest_eigenpairs` computes the
``count`` eigenvalues of a symmetric matrix K nearest σ, and their eigenvectors, by shift and
invert: the eigenvalues θ of (K − σI)⁻¹ of largest magnitude are 1/(λ − σ) for the λ nearest σ.
One LU factorisation (MUMPS) serves all the solves.

Two solvers, the same answer:

- ``"slepc"``: SLEPc's Krylov–Schur with the ``sinvert`` spectral transformation (when
  slepc4py is importable; DOLFINx wheels ship it, Debian 13's packages need not).
- ``"lanczos"``: Lanczos on (K − σI)⁻¹ with full reorthogonalisation, a few dozen solves with
  the factorisation; the Ritz pair (θ, s) of the tridiagonal matrix T_m has the residual
  |β_m s_m|, and the iteration stops when the wanted ``count`` pairs are converged to ``tol``
  relative to |θ|.

``"auto"`` takes SLEPc when importable, else Lanczos. The start vector is pseudo-random with a
fixed seed over the global numbering; the eigenvalues do not depend on it (nor on the number of
ranks) beyond the tolerance. Eigenvectors are signed so that the sum of their entries (or, when
that vanishes, of their cubes) is positive, which does not depend on the numbering either.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import numpy.typing as npt
from petsc4py import PETSc

from dgplate import compat
from dgplate.errors import SolverError
from dgplate.solvers import linear

#: The eigensolvers: "auto" is "slepc" when slepc4py is importable, else "lanczos".
SOLVERS = ("auto", "slepc", "lanczos")

_SEED = 20170321


@dataclass
class Eigenpairs:
    """Eigenvalues (ascending) and their unit eigenvectors, and the solver that found them."""

    values: npt.NDArray[np.float64]
    vectors: list[PETSc.Vec]
    solver: str

    def destroy(self) -> None:
        """Free the eigenvectors."""
        for vector in self.vectors:
            vector.destroy()


def have_slepc() -> bool:
    """Whether slepc4py can be imported."""
    return importlib.util.find_spec("slepc4py") is not None


def resolve_solver(solver: str) -> str:
    """``"auto"`` → ``"slepc"`` or ``"lanczos"``; a named solver as it is (checked)."""
    if solver not in SOLVERS:
        raise ValueError(f"eigensolver must be one of {SOLVERS}, got {solver!r}")
    if solver == "auto":
        return "slepc" if have_slepc() else "lanczos"
    return solver


def nearest_eigenpairs(
    K: PETSc.Mat,
    count: int,
    shift: float = 0.0,
    solver: str = "auto",
    tol: float = 1e-10,
    max_it: int = 200,
) -> Eigenpairs:
    """The ``count`` eigenpairs of the symmetric matrix K nearest ``shift`` (collective).

    Fewer pairs when K is smaller than ``count``; an empty result when nothing converged.
    A :class:`SolverError` when K − σI cannot be factorised (σ an eigenvalue: singular).
    """
    count = max(1, min(count, K.getSize()[0]))
    name = resolve_solver(solver)
    try:
        if name == "slepc":
            values, vectors = _slepc(K, count, shift, tol, max_it)
        else:
            values, vectors = _lanczos(K, count, shift, tol, max_it)
    except (PETSc.Error, SystemError, np.linalg.LinAlgError) as err:
        raise SolverError(f"the eigensolver ({name}) failed near {shift:g}: {err}") from None
    order = np.argsort(values)
    for vector in vectors:
        _fix_sign(vector)
    return Eigenpairs(np.asarray(values)[order], [vectors[i] for i in order], name)


def negative_count(K: PETSc.Mat, M: PETSc.Mat | None = None, shift: float = 0.0) -> int:
    """The number of eigenvalues of K x = λ M x below ``shift`` (M = I when None; collective).

    Sylvester's law of inertia: the negative pivots of an LDLᵀ factorisation (MUMPS) of
    K − σM. Exact, unlike the eigenvalues nearest a shift, which miss large negative ones. A
    :class:`SolverError` when K − σM is singular.
    """
    shifted = K.copy()
    if shift:
        if M is None:
            shifted.shift(-shift)
        else:
            shifted.axpy(-shift, M)
    shifted.setOption(compat.SYMMETRIC, True)
    ksp = PETSc.KSP().create(K.comm)
    try:
        ksp.setOperators(shifted)
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("cholesky")
        pc.setFactorSolverType("mumps")
        pc.setFactorSetUpSolverType()
        factor = pc.getFactorMatrix()
        factor.setMumpsIcntl(13, 1)  # a sequential root: the inertia counts every pivot
        factor.setMumpsIcntl(24, 1)  # null pivots detected (needed for the inertia)
        pc.setUp()
        negative, _, _ = factor.getInertia()
    except PETSc.Error as err:
        raise SolverError(f"the inertia of K − {shift:g}M failed: {err}") from None
    finally:
        ksp.destroy()
        shifted.destroy()
    return int(negative)


def _fix_sign(v: PETSc.Vec) -> None:
    """Sign v so that Σv_i > 0, or Σv_i³ > 0 when Σv_i vanishes (numbering-independent)."""
    local = values_of(v)
    sums = np.array([local.sum(), (local**3).sum(), np.abs(local).sum()])
    total, cubes, size = v.getComm().tompi4py().allreduce(sums)
    key = total if abs(total) > 1e-8 * size else cubes
    if key < 0:
        v.scale(-1.0)


def values_of(v: PETSc.Vec) -> npt.NDArray[np.float64]:
    """The owned entries of a real vector (a read-only view)."""
    return np.asarray(v.getArray(readonly=True).real, dtype=np.float64)


def _real(value: object) -> float:
    """A PETSc scalar or norm as a float (petsc4py's stubs allow complex and pairs)."""
    return float(cast(Any, value).real)


def _shifted(K: PETSc.Mat, shift: float) -> PETSc.Mat:
    shifted = K.copy()
    if shift:
        shifted.shift(-shift)
    return shifted


def _slepc(
    K: PETSc.Mat, count: int, shift: float, tol: float, max_it: int
) -> tuple[list[float], list[PETSc.Vec]]:
    from slepc4py import SLEPc

    eps = SLEPc.EPS().create(K.getComm())
    eps.setOperators(K)
    eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
    eps.setDimensions(count)
    eps.setTarget(shift)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    eps.setTolerances(tol, max_it)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.LU)
    pc.setFactorSolverType("mumps")
    eps.solve()
    values: list[float] = []
    vectors: list[PETSc.Vec] = []
    for i in range(min(eps.getConverged(), count)):
        vector = K.createVecRight()
        values.append(_real(eps.getEigenpair(i, vector)))
        vectors.append(vector)
    eps.destroy()
    return values, vectors


def _start_vector(K: PETSc.Mat) -> PETSc.Vec:
    """A pseudo-random unit vector, the same global vector on any number of ranks."""
    q = K.createVecRight()
    start, end = q.getOwnershipRange()
    rng = np.random.default_rng(_SEED)
    q.setArray(cast(Any, rng.standard_normal(q.getSize())[start:end]))
    q.normalize()
    return q


def _lanczos(
    K: PETSc.Mat, count: int, shift: float, tol: float, max_it: int
) -> tuple[list[float], list[PETSc.Vec]]:
    shifted = _shifted(K, shift)
    ksp = linear.make_ksp(K.getComm().tompi4py(), shifted)
    basis = [_start_vector(K)]
    try:
        linear.factorise(ksp)
        theta, s = _lanczos_basis(ksp, basis, count, tol, min(max_it, K.getSize()[0]))
        wanted = np.argsort(-np.abs(theta))[:count]
        values = [shift + 1 / theta[i] for i in wanted]
        vectors = [_combination(basis, s[:, i]) for i in wanted]
    finally:
        linear.destroy_ksp(ksp)
        shifted.destroy()
        for vector in basis:
            vector.destroy()
    return values, vectors


def _lanczos_basis(
    ksp: PETSc.KSP, basis: list[PETSc.Vec], count: int, tol: float, steps: int
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Extend ``basis`` by Lanczos on the KSP's inverse: the Ritz values θ and vectors s."""
    alphas: list[float] = []
    betas: list[float] = []
    w = basis[0].duplicate()
    for _ in range(steps):
        linear.solve(ksp, basis[-1], w)
        alphas.append(_real(w.dot(basis[-1])))
        if not np.isfinite(alphas[-1]):
            raise np.linalg.LinAlgError("the shifted matrix is singular")
        for _twice in range(2):  # full reorthogonalisation, twice is enough
            for q in basis:
                w.axpy(-w.dot(q), q)
        betas.append(_real(w.norm()))
        theta, s = np.linalg.eigh(_tridiagonal(alphas, betas[:-1]))
        wanted = np.argsort(-np.abs(theta))[:count]
        residuals = np.abs(betas[-1] * s[-1, wanted])
        converged = len(wanted) == count and np.all(residuals <= tol * np.abs(theta[wanted]))
        if converged or betas[-1] <= 1e-14 * np.abs(theta).max():  # or an invariant subspace
            break
        basis.append(w.copy())
        basis[-1].scale(1 / betas[-1])
    w.destroy()
    return theta, s


def _tridiagonal(alphas: list[float], betas: list[float]) -> npt.NDArray[np.float64]:
    return np.diag(alphas) + np.diag(betas, 1) + np.diag(betas, -1)


def _combination(basis: list[PETSc.Vec], coefficients: npt.NDArray[np.float64]) -> PETSc.Vec:
    vector = basis[0].duplicate()
    vector.set(0.0)
    vector.maxpy(list(coefficients), basis[: len(coefficients)])
    vector.normalize()
    return vector


__all__ = ["SOLVERS", "Eigenpairs", "have_slepc", "nearest_eigenpairs", "resolve_solver"]
