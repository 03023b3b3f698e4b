"""Föppl–von Kármán plates: stretching + bending, solved by Newton (PETSc SNES) with load steps.

Model (docs/design.md §1). In-plane displacement u: ω → ℝ², deflection w: ω → ℝ, and the energy

    Π(u, w) = ½∫ N(ε):ε + ½ a_h(w, w) − ∫ p w,     ε = sym∇u + ½∇w⊗∇w − ε₀ I,
    N = A[(1−ν)ε + ν tr(ε) I],  A = E t/(1−ν²),  M = D[(1−ν)κ + ν tr(κ) I],  D = E t³/(12(1−ν²)).

Residual and Jacobian are ``ufl.derivative`` of Π; nothing else is written by hand.

Bending. ½a_h(w, w) is :func:`dgplate.dg.forms.bending_energy` on the scalar w with μ = D (clamped
faces: Nitsche data w = 0, ∇w = 0; crease faces: no gradient-jump terms), plus the Poisson part
νD[∫det D²w − Σ_e∫{cof(D²w) n}·[∇w]], cof(H) = tr(H) I − H. Together the cell terms are ½∫M:κ,
and the face terms are the consistent symmetric IP terms of the moment M: div cof(D²w) = 0, so
the shear terms of dg.py stay as they are. ν matters for free edges (the Kirchhoff free-edge
condition) and in the twisting moment on simply supported edges.

Simply supported faces: w = 0 with the rotation free. An element-wise integration by parts leaves
M_nt ∂_t v − Q_n v on such a face (M_nn = 0 there is the natural condition), so the Nitsche terms
are −(M n)·P_t∇w + Q_n w + ½γ₁D/h |P_t∇w|² + ½γ₀D/h³ w², P_t = I − n⊗n: the value jump and its
tangential derivative only, never ∂_n w. Without the twisting-moment term −(M n)·P_t∇w the
method is inconsistent: on 8/16/32 Q2 squares the centre deflection of the simply supported plate
is then off by 0.74/0.23/0.086 % instead of 0.28/0.07/0.02 % (docs/fvk.md).

Unknowns and membrane discretisation. One mixed space W = DG_k × [CG_k]² (k ≥ 2), one Newton
system, one MUMPS factorisation per iteration. The deflection uses the dG core; the in-plane
displacement is continuous Lagrange of the same degree: for this second-order, coercive
membrane problem (Korn, once an edge is held) conforming Lagrange is stable and needs no
penalty, and in-plane boundary conditions are plain Dirichlet conditions on u. The membrane
strain uses the element-wise gradient of w, which is consistent; jumps of w are controlled by
the bending penalty.

In-plane boundary conditions (``membrane`` = {facet group: condition}): "fixed" (u = 0),
"normal" (u·n = 0, u·t free: edges held against pull-in but free to slide; axis-parallel edges
only), "free", or [u_x, u_y] prescribed (numbers, or "free" per component; scaled with the
load). Clamped and simply supported groups default to "fixed", all other edges are free.

Load schedule. Pressure p, prestrain ε₀ (thermal expansion: ε₀ > 0 compresses a held plate)
and prescribed edge displacements are multiplied by a load factor λ. ``load_steps = n`` means
λ = 1/n, 2/n, …, 1; a list gives the factors (increasing, in (0, 1]). Each step starts from
the secant extrapolation of the two previous states and is solved by SNES newtonls with MUMPS LU
and the affine-covariant NLEQ-ERR line search (Deuflhard): it damps by the Newton correction,
not by a residual norm that mixes membrane and bending units, and takes full steps near the
solution, so convergence is quadratic there. A step that does not converge raises SolverError
with the SNES reason and keeps the last converged state; ``run_fvk`` then ends the schedule and
writes the outputs of the converged steps with ``converged = false`` and that reason, as the
gradient flow does. Iterations and residual norms of every step are recorded.
"""

from __future__ import annotations

import time
from typing import Any

from mpi4py import MPI

import basix.ufl
import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.geometry
import dolfinx.mesh
import numpy as np
import ufl
from petsc4py import PETSc

from dgplate import compat, interrupt, values
from dgplate.dg.forms import (
    FREE,
    FacetSets,
    Penalty,
    bending_energy,
    facet_sets,
    grad_laplacian,
    hessian,
    jump,
)
from dgplate.errors import InputError, SolverError
from dgplate.io import checkpoint
from dgplate.mesh.tagged import TaggedMesh
from dgplate.models.fvk_params import FvKParameters
from dgplate.solvers import linear as solvers

#: Face-set id of simply supported boundary faces (beside dg.SMOOTH … dg.FREE = 1 … 4).
SIMPLY_SUPPORTED = 5

#: Newton defaults; MUMPS LU as everywhere in dgplate. ``model.snes`` overrides any key.
SNES_DEFAULTS: dict[str, Any] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "nleqerr",
    "snes_rtol": 1e-10,
    "snes_max_it": 30,
    **solvers.DIRECT_MUMPS,
}

_REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}


def allreduce_array(comm: MPI.Comm, values, op=MPI.SUM) -> np.ndarray:
    """Element-wise reduction of a float array (the pickle-based allreduce cannot MIN/MAX)."""
    values = np.ascontiguousarray(values, dtype=np.float64)
    out = np.empty_like(values)
    comm.Allreduce(values, out, op=op)
    return out


def membrane_strain(u, w, prestrain=0.0):
    """ε = sym∇u + ½∇w⊗∇w − ε₀ I (with the element-wise gradient of a dG deflection)."""
    gw = ufl.grad(w)
    return ufl.sym(ufl.grad(u)) + 0.5 * ufl.outer(gw, gw) - prestrain * ufl.Identity(2)


def plane_stress(eps, stiffness, nu):
    """stiffness·[(1−ν)ε + ν tr(ε) I]: N for stiffness A, M (with ε = κ) for stiffness D."""
    return stiffness * ((1 - nu) * eps + nu * ufl.tr(eps) * ufl.Identity(2))


def fvk_bending_energy(w, faces: FacetSets, penalty: Penalty, D, nu, simply_supported: bool):
    """½a_h(w, w) with the Poisson part and simply supported faces (module docstring)."""
    n, h = faces.n, faces.h
    gamma0, gamma1 = penalty.constants(faces.mesh)
    H = hessian(w)
    zero = ufl.as_vector((0.0, 0.0))
    energy = bending_energy(w, faces, penalty, mu=D, g=0.0, Phi=zero)

    def cof(A):
        return ufl.tr(A) * ufl.Identity(2) - A

    energy += nu * D * ufl.det(H) * faces.dx
    energy -= (
        nu
        * D
        * ufl.inner(ufl.dot(ufl.avg(cof(H)), n("+")), jump(ufl.grad(w)))
        * (faces.dS_smooth())
    )
    if faces.has_clamped:
        energy -= nu * D * ufl.inner(ufl.dot(cof(H), n), ufl.grad(w)) * faces.ds_clamped()
    if simply_supported:
        tgrad = ufl.dot(ufl.Identity(2) - ufl.outer(n, n), ufl.grad(w))
        moment_n = ufl.dot(plane_stress(H, D, nu), n)
        energy += (
            -ufl.inner(moment_n, tgrad)
            + 0.5 * penalty.gradient_weight(h, gamma1) * D * ufl.inner(tgrad, tgrad)
            + D * ufl.inner(ufl.dot(grad_laplacian(w), n), w)
            + 0.5 * gamma0 * D / h**3 * w * w
        ) * faces.ds(SIMPLY_SUPPORTED)
    return energy


def fvk_facet_sets(tagged: TaggedMesh, params: FvKParameters) -> FacetSets:
    """dg.facet_sets plus the simply supported faces (id SIMPLY_SUPPORTED), all in one tag."""
    faces = facet_sets(tagged, clamped=params.clamped, crease=params.crease)
    if not params.simply_supported:
        return faces
    mesh, fdim = tagged.mesh, tagged.mesh.topology.dim - 1
    fmap = mesh.topology.index_map(fdim)
    values = faces.tags.values.copy()
    position = np.full(fmap.size_local + fmap.num_ghosts, -1, dtype=np.int64)
    position[faces.tags.indices] = np.arange(faces.tags.indices.size)
    for group in params.simply_supported:
        facets = tagged.facets(group)
        wrong = np.count_nonzero(values[position[facets]][facets < fmap.size_local] != FREE)
        owned = np.count_nonzero(facets < fmap.size_local)
        wrong, owned = allreduce_array(mesh.comm, [wrong, owned]).astype(int)
        if wrong or not owned:
            raise InputError(
                f"model.simply_supported: group '{group}' must be non-empty boundary facets "
                f"that are not clamped ({wrong} of {owned} are not)"
            )
        values[position[facets]] = SIMPLY_SUPPORTED
    tags = dolfinx.mesh.meshtags(mesh, fdim, faces.tags.indices, values)
    return FacetSets(mesh, tags, faces.num_clamped, faces.num_crease)


def _edge_axis(tagged: TaggedMesh, group: str) -> int:
    """Component of u normal to an axis-parallel edge group: 0 for x = const, 1 for y = const."""
    mesh = tagged.mesh
    facets = tagged.facets(group)
    x = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, mesh.topology.dim - 1, facets)]
    spread = np.ptp(x[:, :, :2], axis=1) if facets.size else np.zeros((0, 2))
    scale = np.ptp(mesh.geometry.x[:, :2], axis=0).max()
    flags = np.array([np.all(spread[:, 0] < 1e-10 * scale), np.all(spread[:, 1] < 1e-10 * scale)])
    flags = allreduce_array(mesh.comm, flags, op=MPI.MIN).astype(int)
    if flags.sum() != 1:
        raise InputError(
            f"model.membrane.{group} = 'normal' needs a straight edge parallel to the x or y axis"
        )
    return int(np.argmax(flags))


class FvKProblem:
    """The discrete FvK problem on a tagged mesh: spaces, energy, Newton solver, observables."""

    def __init__(self, tagged: TaggedMesh, params: FvKParameters):
        params.validate(tagged)
        self.tagged, self.params = tagged, params
        mesh = self.mesh = tagged.mesh
        self.comm = mesh.comm
        self.faces = fvk_facet_sets(tagged, params)
        k, cell = params.degree, mesh.basix_cell()
        elements = [
            basix.ufl.element("DG", cell, k),
            basix.ufl.element("Lagrange", cell, k, shape=(2,)),
        ]
        self.W = dolfinx.fem.functionspace(mesh, basix.ufl.mixed_element(elements))
        self.state = dolfinx.fem.Function(self.W, name="state")
        w, u = ufl.split(self.state)

        def const(value: float) -> dolfinx.fem.Constant:
            return values.constant(mesh, value)  # values, not literals: see dgplate.values

        self.lam = const(0.0)
        E, nu, t = const(params.E), const(params.nu), const(params.thickness)
        self.D = E * t**3 / (12 * (1 - nu**2))
        self.A = E * t / (1 - nu**2)
        eps = membrane_strain(u, w, self.lam * const(params.prestrain))
        self.energy = 0.5 * ufl.inner(plane_stress(eps, self.A, nu), eps) * self.faces.dx
        self.energy += fvk_bending_energy(
            w, self.faces, params.penalty_params, self.D, nu, bool(params.simply_supported)
        )
        self.energy -= self.lam * const(params.pressure) * w * self.faces.dx
        residual = ufl.derivative(self.energy, self.state, ufl.TestFunction(self.W))
        jacobian = ufl.derivative(residual, self.state, ufl.TrialFunction(self.W))
        self._forms = [dolfinx.fem.form(f) for f in (self.energy, residual, jacobian)]
        self.bcs, self._prescribed = self._membrane_bcs()
        self._setup_snes()
        self.dofs = self.W.dofmap.index_map.size_global * self.W.dofmap.index_map_bs
        self.w_space, self._w_dofs = compat.collapse(self.W.sub(0))
        self.w = dolfinx.fem.Function(self.w_space, name="w")
        tdim = mesh.topology.dim
        owned = np.arange(mesh.topology.index_map(tdim).size_local, dtype=np.int32)
        self._tree = dolfinx.geometry.bb_tree(mesh, tdim, entities=owned)
        lo = allreduce_array(self.comm, mesh.geometry.x[:, :2].min(axis=0), op=MPI.MIN)
        hi = allreduce_array(self.comm, mesh.geometry.x[:, :2].max(axis=0), op=MPI.MAX)
        self.probe = np.array(params.probe if params.probe is not None else (lo + hi) / 2, float)
        self.history: list[dict] = []
        self._states: list[tuple[float, np.ndarray]] = [(0.0, self.state.x.array.copy())]

    def _membrane_bcs(self):
        """Dirichlet conditions on u and the (Constant, value) pairs scaled by the load."""
        conditions = {g: "fixed" for g in [*self.params.clamped, *self.params.simply_supported]}
        conditions.update(self.params.membrane)
        fdim = self.mesh.topology.dim - 1
        bcs, prescribed = [], []
        for group, cond in conditions.items():
            if cond == "free":
                continue
            if cond == "fixed":
                values = [0.0, 0.0]
            elif cond == "normal":
                values = ["free", "free"]
                values[_edge_axis(self.tagged, group)] = 0.0
            else:
                values = list(cond)
            facets = self.tagged.facets(group)
            for comp, value in enumerate(values):
                if value == "free":
                    continue
                sub = self.W.sub(1).sub(comp)
                dofs = dolfinx.fem.locate_dofs_topological(sub, fdim, facets)
                c = dolfinx.fem.Constant(self.mesh, PETSc.ScalarType(0.0))
                bcs.append(dolfinx.fem.dirichletbc(c, dofs, sub))
                prescribed.append((c, float(value)))
        if not bcs:
            raise InputError(
                "model.membrane: no edge holds the in-plane displacement (rigid in-plane "
                "motions); clamp, simply support or fix at least one edge"
            )
        return bcs, prescribed

    def _setup_snes(self) -> None:
        self._prefix = f"dgplate_fvk_{id(self)}_"
        self._options = {**SNES_DEFAULTS, **self.params.snes}
        opts = PETSc.Options()
        for key, value in self._options.items():
            opts[f"{self._prefix}{key}"] = value
        self._A = dolfinx.fem.petsc.create_matrix(self._forms[2])
        self._b = self.state.x.petsc_vec.duplicate()
        self._x = self.state.x.petsc_vec.duplicate()
        snes = self.snes = PETSc.SNES().create(self.comm)
        snes.setOptionsPrefix(self._prefix)
        snes.setFunction(self._residual, self._b)
        snes.setJacobian(self._jacobian, self._A)
        self._norms: list[float] = []
        snes.setMonitor(lambda _snes, _it, norm: self._norms.append(float(norm)))
        snes.setFromOptions()

    def _update(self, x: PETSc.Vec) -> None:
        x.copy(self.state.x.petsc_vec)
        self.state.x.scatter_forward()

    def _residual(self, _snes, x, b) -> None:
        self._update(x)
        with b.localForm() as local:
            local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, self._forms[1])
        dolfinx.fem.petsc.apply_lifting(b, [self._forms[2]], [self.bcs], [x], -1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        dolfinx.fem.petsc.set_bc(b, self.bcs, x, -1.0)

    def _jacobian(self, _snes, x, A, _P) -> None:
        self._update(x)
        A.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(A, self._forms[2], bcs=self.bcs)
        A.assemble()

    def set_load(self, lam: float) -> None:
        self.lam.value = lam
        for constant, value in self._prescribed:
            constant.value = lam * value

    def solve_step(self, lam: float) -> dict:
        """Solve at load factor ``lam`` from a secant predictor; returns the step record.

        Raises SolverError (the SNES reason) when Newton fails; the state and the load factor
        are then those of the last converged step (or the unloaded plate)."""
        (l0, x0), (l1, x1) = ([(0.0, None), *self._states])[-2:]
        if x0 is not None and l1 > l0:
            self.state.x.array[:] = x1 + (lam - l1) / (l1 - l0) * (x1 - x0)
        self.set_load(lam)
        self.state.x.petsc_vec.copy(self._x)
        self._norms = []
        start = time.perf_counter()
        self.snes.solve(None, self._x)
        reason, its = self.snes.getConvergedReason(), self.snes.getIterationNumber()
        self._update(self._x)
        step = len(self.history) + 1
        if reason < 0:
            last_lam, last_state = self._states[-1]
            self.state.x.array[:] = last_state
            self.set_load(last_lam)
            raise SolverError(
                f"FvK Newton failed at load step {step} (load factor {lam:g}): SNES reason "
                f"{_REASONS.get(reason, reason)} after {its} iterations; try more "
                "model.load_steps or other model.snes options"
            )
        self._states = [*self._states[-1:], (lam, self.state.x.array.copy())]
        record = {
            "step": step,
            "load_factor": lam,
            "load": lam * self.params.pressure,
            "w_max": self.w_max(),
            "w_center": self.w_at(self.probe),
            "iterations": its,
            "residual_norms": list(self._norms),
            "reason": _REASONS.get(reason, str(reason)),
            "energy": self.energy_value(),
            "time_s": time.perf_counter() - start,
        }
        self.history.append(record)
        return record

    def checkpoint_fields(self) -> dict[str, dolfinx.fem.Function]:
        """The state and the one before it (the secant predictor's two points)."""
        previous = dolfinx.fem.Function(self.W)
        previous.x.array[:] = self._states[0][1]
        return {"state": self.state, "previous": previous}

    def checkpoint_state(self) -> dict:
        """The load steps done (their records) and the two load factors of the predictor."""
        return {"history": self.history, "loads": [lam for lam, _ in self._states]}

    def restore(self, found: checkpoint.Checkpoint) -> None:
        """Continue from a checkpoint written by :meth:`checkpoint_fields`/``_state``."""
        fields = self.checkpoint_fields()
        found.restore(fields)
        state = found.state["fvk"]
        self.history = list(state["history"])
        arrays = [fields["previous"].x.array.copy(), self.state.x.array.copy()]
        self._states = list(zip(state["loads"], arrays[-len(state["loads"]) :]))
        self.set_load(state["loads"][-1])

    def collapse_w(self) -> dolfinx.fem.Function:
        self.w.x.array[:] = self.state.x.array[self._w_dofs]
        return self.w

    def w_max(self) -> float:
        """The DOF value of w of largest magnitude (signed); the same on any number of ranks."""
        w = self.collapse_w()
        owned = w.x.array[: self.w_space.dofmap.index_map.size_local]
        lo = self.comm.allreduce(owned.min(initial=np.inf), op=MPI.MIN)
        hi = self.comm.allreduce(owned.max(initial=-np.inf), op=MPI.MAX)
        return float(hi if hi >= -lo else lo)

    def w_at(self, point) -> float:
        """w at ``point``: the mean over the cells containing it (w is discontinuous)."""
        w = self.collapse_w()
        x = np.zeros((1, 3), dtype=self.mesh.geometry.x.dtype)
        x[0, : len(point)] = point
        candidates = dolfinx.geometry.compute_collisions_points(self._tree, x)
        cells = dolfinx.geometry.compute_colliding_cells(self.mesh, candidates, x).links(0)
        local = np.sum(w.eval(np.repeat(x, cells.size, axis=0), cells)) if cells.size else 0.0
        total, count = allreduce_array(self.comm, [local, cells.size])
        if count == 0:
            raise InputError(f"model.probe {list(point)} lies outside the mesh")
        return float(total / count)

    def energy_value(self) -> float:
        local = dolfinx.fem.assemble_scalar(self._forms[0])
        return float(self.comm.allreduce(local, op=MPI.SUM))

    def close(self) -> None:
        """Free the PETSc objects and this problem's options."""
        opts = PETSc.Options()
        for key in self._options:
            opts.delValue(f"{self._prefix}{key}")
        for obj in (self.snes, self._A, self._b, self._x):
            obj.destroy()


def run_fvk(
    tagged: TaggedMesh,
    params: FvKParameters,
    out_dir=None,
    comm: MPI.Comm | None = None,
    progress: bool = False,
    force: bool = False,
    start: checkpoint.Checkpoint | None = None,
    fingerprint: str = "",
) -> dict:
    """Solve the load schedule; returns the summary (written with the outputs to ``out_dir``).

    Collective on the mesh communicator; ``comm`` defaults to it. Rank 0 prints (``progress``)
    and writes files. A load step that does not converge, or SIGINT/SIGTERM, ends the
    schedule: the summary says ``converged = false`` with the SNES reason (or the signal),
    and the outputs (summary.json, history.csv, the series and the picture) hold the
    converged steps, as for a gradient flow. A checkpoint is written after every load step;
    ``start`` continues from one. Any other error leaves nothing in ``out_dir`` but what was
    there before and the checkpoints.
    """
    from dgplate.models import fvk_output

    comm = comm or tagged.comm
    wall0 = time.perf_counter()
    problem = FvKProblem(tagged, params)
    if start is not None:
        problem.restore(start)
    writer = None
    if out_dir is not None:
        writer = fvk_output.Writer(problem, out_dir, force, resume=start is not None)
    failure, signum = None, 0
    try:
        for lam in params.load_factors()[len(problem.history) :]:
            try:
                rec = problem.solve_step(lam)
            except SolverError as err:  # collective: the SNES reason is the same on all ranks
                failure = f"{err}; the last converged state is kept"
                break
            if writer:
                writer.write_step(lam)
                _save_checkpoint(problem, writer.stage.checkpoint_dir, fingerprint, False)
            if progress and comm.rank == 0:
                print(
                    f"fvk step {rec['step']:3d}  load {rec['load']:.4g}  w_center "
                    f"{rec['w_center']:.6g}  Newton its {rec['iterations']}",
                    flush=True,
                )
            signum = interrupt.requested(comm)
            if signum:
                failure = interrupt.reason(signum)
                break
        summary = fvk_output.summary(problem, time.perf_counter() - wall0, failure)
        summary["interrupted"] = signum
        if writer:
            _save_checkpoint(problem, writer.stage.checkpoint_dir, fingerprint, failure is None)
            writer.finish(summary)
    except BaseException:
        if writer:
            writer.abort()
        raise
    finally:
        problem.close()
    return summary


def _save_checkpoint(problem: FvKProblem, directory, fingerprint: str, finished: bool) -> None:
    state = {
        "fingerprint": fingerprint,
        "step": len(problem.history),
        "finished": finished,
        "fvk": problem.checkpoint_state(),
    }
    checkpoint.save(directory, problem.comm, problem.checkpoint_fields(), state)


__all__ = [
    "SIMPLY_SUPPORTED",
    "FvKParameters",
    "FvKProblem",
    "fvk_bending_energy",
    "fvk_facet_sets",
    "membrane_strain",
    "plane_stress",
    "run_fvk",
]
