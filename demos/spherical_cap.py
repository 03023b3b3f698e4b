# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # A prestrained disc that becomes a spherical cap
#
# A *prestrained* (non-Euclidean) plate is a sheet whose material wants lengths that no flat
# sheet has: it has grown, swollen or been actuated unevenly, and its target is a metric G,
# a symmetric positive definite 2×2 field on the reference domain ω, in place of the identity.
# Its deformations y: ω → ℝ³ are constrained to realise G,
#
# $$\nabla y^T \nabla y = G \quad\text{in place of the isometry}\quad \nabla y^T\nabla y = I_2,$$
#
# and among them the plate takes the one of least bending energy. We use the energy of Bonito,
# Guignard, Nochetto and Yang (*LDG approximation of large deformations of prestrained plates*,
# J. Comput. Phys. 2022) with λ = 0, in dgplate's normalisation of the Kirchhoff energy,
#
# $$E[y] = \tfrac12 \int_\omega \sum_{k=1}^3 \big|G^{-1/2}\, D^2 y_k\, G^{-1/2}\big|^2\,dx .$$
#
# Their energy compares the second fundamental form II with a target Z, the spontaneous
# curvature of the sheet; here Z = 0, so the sheet's only wish is its metric. On the constraint
# set D²y_k = Γᵐ∂ₘy_k + II ν_k, so E differs from ½∫|G^{-1/2} II G^{-1/2}|² only by a function
# of G (the Christoffel symbols' part): both have the same minimisers. With G = I it is the
# Kirchhoff energy ½∫|D²y|² of `demos/vertical_load.py`.
#
# ## The sphere's metric on a disc
#
# The plate is the disc ω = {|x| < 1}, free, without load, and G is the metric of a sphere of
# radius R = 2 in geodesic polar coordinates (r = |x| is the distance from the pole along the
# sphere, θ the polar angle):
#
# $$G = dr^2 + R^2\sin^2(r/R)\,d\theta^2
#     = I + q(r)\,\big(|x|^2 I - x\otimes x\big), \qquad
#   q(r) = \frac{R^2\sin^2(r/R)/r^2 - 1}{r^2}.$$
#
# The circles about the centre want to be shorter than 2πr, as the circles of latitude of a
# sphere are: no flat disc meets G, and the flat plate is not even an admissible start.
#
# **Why the cap is the exact minimiser.** By Gauss's *Theorema egregium* every surface with
# ∇yᵀ∇y = G has the Gaussian curvature of G alone, K = κ₁κ₂ = 1/R². The principal curvatures
# κ₁, κ₂ are the eigenvalues of II relative to G, so
#
# $$\big|G^{-1/2}\, I\!I\, G^{-1/2}\big|^2 = \kappa_1^2 + \kappa_2^2 \;\ge\; 2\kappa_1\kappa_2
#   = 2K = \frac{2}{R^2},$$
#
# with equality only where κ₁ = κ₂, at umbilic points. A connected surface of umbilic points
# with K > 0 is a piece of a sphere, so the minimisers are the caps of the sphere of radius 2,
# y(x) = a(r)x + R(1 − cos(r/R)) e₃ with a(r) = R sin(r/R)/r, up to rigid motions
# (`dgplate.reference.spherical_cap.cap`). Their energy is E = 0.819381
# (`dgplate.reference.spherical_cap.energy(2.0)`: ½·2π∫₀¹ density(r) r dr with the density of
# the cap's Hessian, 2/R² at the centre and more away from it, so E is above π/R² = 0.785).
#
# ## The method
#
# dG P2 on the polar mesh `meshes/polar_disc.geo` (`penalty_length = "facet_normal"`: the
# cells at the centre are thin), the weighted Hessian H : G⁻¹HG⁻¹ with its symmetric
# interior-penalty terms, and the constraint imposed on cell means: the defect
# D_h = Σ_T |∫_T (∇yᵀ∇y − G)| is what `summary.json` calls `isometry_defect`. Since the flat
# plate violates the constraint, the flow begins with the *metric start*: Gauss–Newton steps on
# ½∫|∇yᵀ∇y − G|² from the flat plate lifted by a small paraboloid (a metric of positive
# curvature cannot be met in the plane), then Newton projections onto the cell means until
# D_h ≤ 10⁻¹⁰ (`summary.json`: `metric_start`, the stretching steps, the projections, its D_h
# and seconds). The discrete H² gradient flow with an adaptive τ then relaxes the energy.
#
# **The Gauss-curvature penalty.** The problem file adds to E_h, with β = 10 (the key
# `model.gauss_penalty`),
#
# $$\frac\beta2 \sum_T h_T^{-1} \int_T \big(\det I\!I(y) - K \det G\big)^2 .$$
#
# It is consistent: on any surface that realises G, det II = K det(∇yᵀ∇y) = K det G (Gauss
# again), so it vanishes on the cap and leaves the exact problem unchanged. It prices what a
# constraint on cell means leaves free: without it the cells along the free edge flatten
# (K_h < K, their missing curvature held in gradient jumps that the cell means do not see) and
# E_h falls through the exact energy, ending about 2 % below it (−2.5 % and −2.2 % at
# h = 0.05 and 0.025). β = 10 was chosen from a probe of β = 1, 10 and 100 at h = 0.1 and 0.05:
# β = 1 gave E_h errors of +2.19 % and −0.25 % (changing sign), β = 100 +4.09 % and +0.81 %,
# β = 10 +3.6 % and +0.63 % (docs/prestrain.md).
#
# Run: `python demos/spherical_cap.py` (h = 0.1, about 15 s), `--h 0.05` to choose the
# mesh size (`mesh.parameters.h`), `--paper` for the levels of `benchmarks/spherical_cap.py`,
# h = 0.2, 0.1, 0.05, 0.025 (about 3 minutes). Under MPI: `mpirun -n 2 python demos/spherical_cap.py`.
# Output: `out/spherical_cap/` (VTX, final.png, summary.json; one subfolder per level with
# `--paper`).

# %%
from pathlib import Path

import numpy as np

import dgplate
from dgplate import demo
from dgplate.measure.analysis import fit_sphere
from dgplate.reference.spherical_cap import energy

PROBLEM = Path(__file__).parent / "problems" / "spherical_disc.toml"
RADIUS = 2.0  # the sphere of the file's model.metric
PAPER = [0.2, 0.1, 0.05, 0.025]  # the levels of benchmarks/spherical_cap.py

parser = demo.parser(
    "spherical_cap", "a prestrained disc becomes a spherical cap", paper="h = 0.2, 0.1, 0.05, 0.025"
)
parser.add_argument("--h", type=float, default=0.1, help="mesh.parameters.h (default 0.1)")
args = demo.parse(parser)

# %% [markdown]
# Each run is the problem file `demos/problems/spherical_disc.toml` with its mesh size
# overridden; `dgplate run demos/problems/spherical_disc.toml --set mesh.parameters.h=0.05`
# does the same from the shell. The radius of the least-squares sphere through the nodal
# values of y (`dgplate.measure.analysis.fit_sphere`, collective) measures the shape.

# %%
exact = energy(RADIUS)
levels = PAPER if args.paper else [args.h]
rows = []
for h in levels:
    problem = dgplate.load_problem(PROBLEM, overrides={"mesh.parameters.h": h})
    subfolder = [] if len(levels) == 1 else [f"h{h:g}"]
    result = demo.run(problem, args, *subfolder)
    fit = fit_sphere(result.shape)  # a finished run reused by --resume has its y back too
    rows.append((h, result.summary, fit))
demo.copy_figure(Path(args.out, *subfolder), args.figure)

# %% [markdown]
# ## Against the cap
#
# Measured (1 rank; `benchmarks/results/spherical_cap.json` has the same runs): at the default
# h = 0.1, 736 cells and 15,456 DoFs, E_h = 0.848964, +3.6 % above the cap's 0.819381, the
# fitted radius 2.000283 (relative error +1.4·10⁻⁴), D_h = 5·10⁻¹⁵, the metric start 7 stretching steps and 4
# projections, then 7 flow steps. At h = 0.2, 0.1, 0.05, 0.025 the error of E_h is +13.1, +3.6,
# +0.63 and +0.08 %, from above like the interpolated cap's, at an observed order of 2.8 to 2.9
# on the three finer levels (the mesh size taken as cells^(−1/2), since the polar mesh's h is a
# target); the fitted radius is 2 within relative errors of 6.4·10⁻⁴, 1.4·10⁻⁴, 3.2·10⁻⁵, 7.8·10⁻⁶.
#
# The demo asserts at every level: the flow converged, D_h ≤ 10⁻¹⁰ and the metric start's
# D_h ≤ 10⁻¹⁰; E_h above the cap's (the penalty keeps the free edge from flattening, which
# took E_h below it); and, by the mesh size, the relative errors of E_h and of the fitted radius
# within the bounds below, about 1.4 to 6 times the measured errors (for h > 0.2 neither is
# checked):
#
# | h at most | E_h within | radius within |
# |---|---|---|
# | 0.2 | 20 % | 2·10⁻³ |
# | 0.1 | 5 % | 5·10⁻⁴ |
# | 0.05 | 1 % | 10⁻⁴ |
# | 0.025 | 0.5 % | 3·10⁻⁵ |
#
# With `--paper` it also asserts an observed order of the energy error above 2.3, the
# least-squares slope over the last three levels.

# %%
#: (h at most, E_h's relative error at most, the fitted radius's at most), finest first
BOUNDS = [(0.025, 5e-3, 3e-5), (0.05, 1e-2, 1e-4), (0.1, 5e-2, 5e-4), (0.2, 0.2, 2e-3)]
SOURCE = "the spherical cap, dgplate.reference.spherical_cap"

demo.say(
    f"\n{'h':>6} {'cells':>6} {'dofs':>7} {'E_h':>9} {'error':>8} {'radius':>9} {'error':>9} "
    f"{'D_h':>8} {'start':>6} {'start D_h':>9} {'start s':>7} {'steps':>5}"
)
for h, s, fit in rows:
    start = s["metric_start"]
    demo.say(
        f"{h:>6g} {s['cells']:>6} {s['dofs']:>7} {s['energy']:>9.6f} "
        f"{(s['energy'] - exact) / exact:>+8.2%} {fit['radius']:>9.6f} "
        f"{(fit['radius'] - RADIUS) / RADIUS:>+9.2e} {s['isometry_defect']:>8.1e} "
        f"{start['stretching_steps']:>2} + {start['projection_steps']:<2} "
        f"{start['defect']:>9.1e} {start['seconds']:>7.1f} {s['steps']:>5}"
    )
demo.say(f"exact: E = {exact:.6f}, R = {RADIUS:g}\n")

for h, s, fit in rows:
    demo.check(f"h = {h:g}: the flow converged", s["converged"])
    demo.check_between("D_h", s["isometry_defect"], high=1e-10)
    demo.check_between("D_h of the metric start", s["metric_start"]["defect"], high=1e-10)
    demo.check_between("E_h", s["energy"], low=exact, source=SOURCE)
    bound = next(((e, r) for most, e, r in BOUNDS if h <= most * (1 + 1e-12)), None)
    if bound is not None:
        demo.check_close("E_h", s["energy"], exact, rel=bound[0], source=SOURCE)
        demo.check_close("fitted radius", fit["radius"], RADIUS, rel=bound[1], source=SOURCE)

# %% [markdown]
# The observed order: with the error ∝ hᵖ and h ∝ cells^(−1/2), p is the slope of
# log|E_h − E| against −½ log(cells) (the benchmark's table gives it between neighbours).

# %%
if args.paper:
    cells = np.array([s["cells"] for _, s, _ in rows[-3:]], dtype=float)
    errors = np.array([abs(s["energy"] - exact) for _, s, _ in rows[-3:]])
    order = float(np.polyfit(-0.5 * np.log(cells), np.log(errors), 1)[0])
    demo.check_between("observed order of the E_h error, last three levels", order, low=2.3,
                       source="measured 2.8 and 2.9 between neighbours")  # fmt: skip
