"""Coercivity of the dG bending form on a mesh: the sign and the lowest eigenvalues.

Assembles the matrix A of the FvK bending energy ½a_h(w, w) (ν, D = 1, clamped outer edge,
DG_k deflection alone) and the L² mass matrix M, and reports for each penalty length
(``model.penalty_length``) the number of negative eigenvalues of A (the inertia of an LDLᵀ
factorisation by MUMPS, exact) and the lowest generalised eigenvalues A x = λ M x (SLEPc, shift
and invert at a shift below the spectrum, found by the inertia). A negative count means that the
discrete energy is not coercive: some deflection has a negative bending energy.

    python benchmarks/dg_coercivity.py --h 0.15 0.07 --json benchmarks/results/dg_coercivity_polar.json

The mesh is ``meshes/polar_disc.geo`` (N = 16 sectors, the cone's mesh, docs/fvk_experiments.md).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import dolfinx.fem.petsc
import ufl
from petsc4py import PETSc
from slepc4py import SLEPc

from dgplate.dg.forms import PENALTY_LENGTHS, Penalty, facet_sets
from dgplate.mesh.tagged import TaggedMesh, load_geo
from dgplate.models.fvk.energy import fvk_bending_energy
from dgplate.solvers.eigen import negative_count


def matrices(tagged: TaggedMesh, degree: int, penalty: Penalty, length: str, nu: float):
    """A (the bending Hessian) and M (the L² mass) of DG_degree on ``tagged``."""
    facets = facet_sets(tagged, ["outer"], penalty_length=length)
    space = dolfinx.fem.functionspace(tagged.mesh, ("DG", degree))
    w = dolfinx.fem.Function(space)
    energy = fvk_bending_energy(w, facets, penalty, 1.0, nu, False)
    trial, test = ufl.TrialFunction(space), ufl.TestFunction(space)
    hessian = ufl.derivative(ufl.derivative(energy, w, test), w, trial)
    A = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(hessian))
    M = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(ufl.inner(trial, test) * ufl.dx))
    for matrix in (A, M):
        matrix.assemble()
        matrix.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    return A, M


def lowest(A: PETSc.Mat, M: PETSc.Mat, count: int = 3) -> tuple[list[float], float, int]:
    """The ``count`` lowest generalised eigenvalues, the shift used and the negative count."""
    negatives = negative_count(A, M, 0.0)
    shift = 0.0
    if negatives:
        shift = -1.0
        while negative_count(A, M, shift):
            shift *= 10
    eps = SLEPc.EPS().create(A.comm)
    eps.setOperators(A, M)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setDimensions(count)
    eps.setTarget(shift)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_REAL)
    st = eps.getST()
    st.setType("sinvert")
    st.setShift(shift)
    ksp = st.getKSP()
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    eps.setTolerances(1e-10, 200)
    eps.solve()
    values = sorted(eps.getEigenvalue(i).real for i in range(min(count, eps.getConverged())))
    eps.destroy()
    return values, shift, negatives


def main() -> None:
    """Each mesh size and penalty length in turn; a JSON of the counts and eigenvalues."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--h", type=float, nargs="+", default=[0.15, 0.07])
    parser.add_argument("--degree", type=int, default=3)
    parser.add_argument("--gamma", type=float, nargs=2, default=[100.0, 100.0])
    parser.add_argument("--nu", type=float, default=0.0)
    parser.add_argument("--json", default="")
    args = parser.parse_args()
    penalty = Penalty(gamma0=args.gamma[0], gamma1=args.gamma[1])
    runs = []
    for h in args.h:
        tagged = load_geo(MPI.COMM_WORLD, "polar_disc.geo", {"R": 1.0, "Rc": 0.15, "N": 16, "h": h})
        for length in PENALTY_LENGTHS:
            start = time.perf_counter()
            A, M = matrices(tagged, args.degree, penalty, length, args.nu)
            values, shift, negatives = lowest(A, M)
            run = {
                "h": h,
                "penalty_length": length,
                "dofs": A.getSize()[0],
                "negative_eigenvalues": negatives,
                "lowest_eigenvalues": values,
                "shift": shift,
                "seconds": time.perf_counter() - start,
            }
            runs.append(run)
            print(json.dumps(run), flush=True)
            A.destroy()
            M.destroy()
    if args.json:
        result = {"degree": args.degree, "gamma": args.gamma, "nu": args.nu, "runs": runs}
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
