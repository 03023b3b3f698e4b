# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # A liquid-crystal-elastomer disc with a +1 defect becomes a cone
#
# A nematic elastomer sheet whose in-plane director makes the angle θ(x) with the x axis
# contracts by λ along the director and stretches by λ^{−ν} across it when it is heated
# (Modes, Bhattacharya and Warner, *Gaussian curvature from flat elastica sheets*, Proc. R.
# Soc. A 2011). It then wants the metric
#
# $$G = R(\theta)\,\mathrm{diag}(\lambda^2, \lambda^{-2\nu})\,R(\theta)^T,$$
#
# and its deformations y realise ∇yᵀ∇y = G while they minimise the bending energy
# ½∫Σ_k|G^{-1/2} D²y_k G^{-1/2}|² (the prestrained plate of `demos/spherical_cap.py` and
# docs/prestrain.md, with `model.director` setting G).
#
# **The azimuthal defect.** With the director along the circles about the centre,
# θ = polar angle + π/2 (`angle = "atan2(y, x) + pi/2"`), the circle of radius r lies along
# the director and becomes 2πλr long, while a radius lies across it and becomes λ^{−ν}r long.
# A circle of geodesic radius ρ = λ^{−ν}r thus has the length 2πρ λ^{1+ν} < 2πρ: the sheet has
# an angular deficit and is flat (K = 0) everywhere but at the centre. Such a surface is a cone: its generators are the images of the
# radii, and a circle of geodesic radius ρ lies at the distance ρ sin φ from the cone's axis,
# so the half-angle φ of the cone (between a generator and the axis) is
#
# $$\sin\varphi = \lambda^{1+\nu}, \qquad \lambda = 0.9,\ \nu = 0.5:\ \varphi = 58.63°.$$
#
# All the Gauss curvature sits at the tip: ∫K dA = 2π(1 − sin φ), the angular deficit. A
# circular cone is the only isometric immersion of this metric that is smooth off the tip and
# symmetric about it. Modes, Bhattacharya and Warner predicted these cones (and anticones,
# for the radial director: `demos/prestrained_discs.py`); heated LCE sheets with such defect
# patterns make them in experiments (de Haan et al., Angew. Chem. 2012; Ware et al.,
# Science 2015).
#
# ## The problem
#
# `demos/problems/lce_cone.toml`: the disc |x| < 1 on the polar mesh of `polar_disc.geo` (P2,
# h = 0.2), free, no load, the director table `{angle = "atan2(y, x) + pi/2", lambda = 0.9,
# nu = 0.5}`. The flat plate violates ∇yᵀ∇y = G: the flow first makes an admissible start
# (stretching steps from a lifted flat plate, then projections onto the metric), then runs the
# constrained gradient flow to a discrete minimiser.
#
# ## What is measured
#
# The half-angle is fitted from the shape: the least-squares cone through the nodal values of
# y with |x| > r₀ (`dgplate.measure.prestrain.cone_half_angle`), r₀ = 0.3 and 0.5, away from
# the tip where ∇y has no limit. Also D_h = Σ_T|∫_T(∇yᵀ∇y − G)| and K of G at the cell
# midpoints (0 off the tip).
#
# Run: `python demos/lce_cone.py` (h = 0.2, seconds), `--h` for another mesh size, `--paper`
# for h = 0.2, 0.1, 0.05 (about a minute), `mpirun -n 2 python demos/lce_cone.py` under MPI.
# Output: `out/lce_cone/` with VTX, final.png and summary.json (a subfolder per level with
# `--paper`).

# %%
import math
from pathlib import Path

import dgplate
from dgplate import demo
from dgplate.measure.prestrain import cone_half_angle

PROBLEM = Path(__file__).parent / "problems" / "lce_cone.toml"
STRETCH, NU = 0.9, 0.5  # λ, ν of the file's model.director
INNER = (0.3, 0.5)  # the fit uses the nodes with |x| above these radii
PAPER = [0.2, 0.1, 0.05]  # the levels of benchmarks/lce_cone.py

parser = demo.parser("lce_cone", "an LCE disc with a +1 defect becomes a cone",
                     paper="h = 0.2, 0.1, 0.05")  # fmt: skip
parser.add_argument("--h", type=float, default=0.2, help="mesh.parameters.h (default 0.2)")
args = demo.parse(parser)

# %% [markdown]
# Each run is the problem file with its mesh size overridden; `dgplate run
# demos/problems/lce_cone.toml --set mesh.parameters.h=0.1` does the same from the shell.

# %%
exact = math.asin(STRETCH ** (1 + NU))
levels = PAPER if args.paper else [args.h]
rows = []
for h in levels:
    problem = dgplate.load_problem(PROBLEM, overrides={"mesh.parameters.h": h})
    subfolder = [] if len(levels) == 1 else [f"h{h:g}"]
    result = demo.run(problem, args, *subfolder)
    angles = {inner: cone_half_angle(result.shape, inner) for inner in INNER}
    rows.append((h, result.summary, angles))
demo.copy_figure(Path(args.out, *subfolder), args.figure)

# %% [markdown]
# ## Against sin φ = λ^{1+ν}
#
# Measured (1 rank; `benchmarks/results/lce_cone.json` has the same runs): at h = 0.2, 0.1,
# 0.05 the half-angle fitted over |x| > 0.3 is 58.616°, 58.612°, 58.631° against 58.629°
# (relative errors −2.3·10⁻⁴, −2.9·10⁻⁴, +2.6·10⁻⁵), over |x| > 0.5 58.520°, 58.591°,
# 58.628° (−1.9·10⁻³, −6.6·10⁻⁴, −2.6·10⁻⁵); D_h ≤ 10⁻¹⁴. E_h does not converge
# (docs/prestrain.md): at the tip ∇y has no limit, and the gradient jumps there stay of order
# one whatever h.
#
# The demo asserts at every level: the flow converged, D_h ≤ 10⁻¹⁰ and the start's
# D_h ≤ 10⁻¹⁰, |K| of G ≤ 10⁻¹⁰ at the cell midpoints (the tip is a vertex of the mesh), and
# the half-angle fitted over |x| > 0.3 within 1 % of φ (the acceptance bound of the issue;
# measured 0.03 % at most); for h ≤ 0.2 also within 0.1 %.

# %%
demo.say(f"\n{'h':>6} {'cells':>6} {'steps':>5} {'D_h':>8} " +
         " ".join(f"{'φ, |x| > ' + str(r):>14} {'error':>9}" for r in INNER))  # fmt: skip
for h, s, angles in rows:
    fits = " ".join(f"{math.degrees(a):>14.3f} {a / exact - 1:>+9.1e}" for a in angles.values())
    demo.say(f"{h:>6g} {s['cells']:>6} {s['steps']:>5} {s['isometry_defect']:>8.1e} {fits}")
demo.say(f"exact: φ = asin(λ^(1+ν)) = {math.degrees(exact):.3f}°\n")

SOURCE = "sin φ = λ^(1+ν) (Modes, Bhattacharya and Warner 2011)"
for h, s, angles in rows:
    demo.check(f"h = {h:g}: the flow converged", s["converged"])
    demo.check_between("D_h", s["isometry_defect"], high=1e-10)
    demo.check_between("D_h of the metric start", s["metric_start"]["defect"], high=1e-10)
    gauss = s["metric_gauss_curvature"]
    largest = max(abs(gauss["target_min"]), abs(gauss["target_max"]))
    demo.check_between("|K| of G at the midpoints", largest, high=1e-10)
    demo.check_close("half-angle, |x| > 0.3", angles[0.3], exact, rel=0.01, source=SOURCE)
    if h <= 0.2 * (1 + 1e-12):
        demo.check_close("half-angle, |x| > 0.3", angles[0.3], exact, rel=1e-3, source=SOURCE)
