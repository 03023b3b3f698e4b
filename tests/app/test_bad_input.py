"""Bad input is one line ``dgplate: error: <message naming the key>`` on stderr, exit code 2 and
nothing written, serially and under ``mpirun -n 2``; accepted but pointless input is one
``dgplate: warning:`` line per warning, and the run goes on."""

import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

import pytest
from helpers import mpirun as _mpirun

from dgplate import check, expressions, load_problem
from dgplate.cli import main
from dgplate.errors import InputError
from dgplate.mesh.tagged import rectangle
from dgplate.problems import advice
from dgplate.problems.specs import problem_from_dict

ROOT = Path(__file__).resolve().parents[2]
PROBLEMS = ROOT / "demos" / "problems"
VERTICAL = PROBLEMS / "vertical_load.toml"
BILAYER = PROBLEMS / "bilayer_cylinder.toml"
TIMOSHENKO = PROBLEMS / "bilayer_timoshenko.toml"
FVK = PROBLEMS / "fvk_square.toml"
ROD = PROBLEMS / "rod_arc.toml"

THERMAL = b'[model]\nname = "thermal"\n'
SMALL = ("mesh.cells=[4,4]", "output.png=false", "output.vtx=false", "output.progress=0")
ROD_SMALL = ("output.png=false", "output.vtx=false", "output.progress=0")
MISSING, DIRECTORY = "<missing file>", "<directory>"


@dataclass(frozen=True)
class Case:
    """One bad input: ``--set`` overrides on a problem, and text the error must contain."""

    sets: tuple[str, ...]
    expected: str
    problem: Path | str | bytes = VERTICAL  # a file, MISSING, DIRECTORY, or the file's bytes
    base: tuple[str, ...] = SMALL


def bad_load(formula: str, expected: str) -> Case:
    return Case((f"model.load=[0,0,'{formula}']",), f"model.load[2]{expected}")


BAD_INPUT = {
    # -- keys, types and ranges -----------------------------------------------------------------
    "unknown key": Case(("flow.tua=0.1",), "unknown key flow.tua"),
    "wrong type": Case(("mesh.cells='many'",), "mesh.cells must be list"),
    "gmsh key on a rectangle": Case(
        ("mesh.file='rectangle.geo'",), "mesh.file has no effect with mesh.type = 'rectangle'"
    ),
    "tau zero": Case(("flow.tau=0",), "flow.tau must be > 0"),
    "frames negative": Case(("output.frames_every=-1",), "output.frames_every must be >= 0"),
    "progress negative": Case(("output.progress=-1",), "output.progress must be >= 0, got -1"),
    "progress word": Case(("output.progress='often'",), "output.progress must be int or 'auto'"),
    "tau negative": Case(("flow.tau=-0.5",), "flow.tau must be > 0"),
    "tau word": Case(("flow.tau=big",), "flow.tau must be float or 'h'"),
    "degree 1": Case(("model.degree=1",), "model.degree must be >= 2"),
    "missing mesh file": Case(
        ("mesh.type=gmsh", "mesh.file='nosuch.geo'"), "mesh file not found: nosuch.geo"
    ),
    "unknown group": Case(
        ("model.clamped=['left','botom']",), "error: model.clamped: unknown facet group 'botom'"
    ),
    "empty clamped set": Case(
        ("model.clamped=[]", "flow.l2_metric=false"),
        "model.clamped is empty but flow.l2_metric = false",
    ),
    "malformed set, no '='": Case(("flow.tau",), "malformed --set 'flow.tau'"),
    "malformed set, bad value": Case(("mesh.cells=[4,4",), "malformed --set"),
    "malformed set, bad key": Case(("tau=0.1",), "the key must be section.name"),
    "unknown section": Case(("solver.type=lu",), "unknown section [solver]"),
    "unknown model": Case(("model.name=kirchof",), "model.name must be one of"),
    "empty model name": Case(("model.name=''",), "model.name must be one of"),
    "model name not a string": Case(("model.name=[1]",), "model.name must be one of"),
    "penalty not positive": Case(
        ("model.penalty={gamma0=-1.0, gamma1=1.0}",), "model.penalty.gamma0 must be"
    ),
    "gradient power out of range": Case(
        ("model.penalty={gamma0=5000.0, gamma1=1100.0, gradient_power=5}",),
        "model.penalty.gradient_power must be in [1, 3]",
    ),
    "unknown hessian": Case(
        ("model.hessian='lifted'",), "model.hessian must be one of broken, ldg, got 'lifted'"
    ),
    "crease on boundary": Case(("model.crease=['top']",), "crease group 'top' contains"),
    "mu not positive": Case(("model.mu=0",), "model.mu must be > 0"),
    "unknown mu region": Case(
        ("model.mu={hinge=1.0}",), "error: model.mu: unknown cell group 'hinge'"
    ),
    "unknown step solver": Case(("flow.linear_solver='cg'",), "flow.linear_solver must be"),
    "removed Schur solver": Case(
        ("flow.linear_solver='schur'",),
        "flow.linear_solver must be one of lagged, direct, got 'schur' (the Schur solver "
        "was removed: docs/performance.md)",
    ),
    "refactor_its zero": Case(("flow.refactor_its=0",), "flow.refactor_its must be"),
    # a warning (τ ≫ h, nothing to solve) never comes before the error
    "absurd tau and a bad solver": Case(
        ("flow.tau=1e300", "flow.linear_solver='cg'"), "flow.linear_solver must be"
    ),
    "no load and an unknown group": Case(
        ("model.load=[0,0,0]", "model.clamped=['left','botom']"),
        "error: model.clamped: unknown facet group 'botom'",
    ),
    "load not a list": Case(("model.load={a=1}",), "model.load must be list"),
    "load entry a boolean": Case(("model.load=[0,0,true]",), "model.load[2] must be float or str"),
    "huge integer": Case(("mesh.cells=[99999999999,4]",), "mesh.cells[0] must be at most"),
    "solver option name": Case(
        ("flow.solver={'ksp type'='cg'}",), "flow.solver.ksp type is not a PETSc option name"
    ),
    "solver option table": Case(
        ("flow.solver={ksp_type={a=1}}",), "flow.solver.ksp_type must be str or int or float"
    ),
    # -- group names the mesh does not have: the message begins with the key ------------------------
    "unknown crease group": Case(
        ("model.crease=['middle']",), "error: model.crease: unknown facet group 'middle'"
    ),
    "unknown Z group": Case(
        ("model.Z={nogroup=1.0}",), "error: model.Z: unknown cell group 'nogroup'", BILAYER
    ),
    "negative Gauss penalty": Case(
        ("model.gauss_penalty=-1",), "model.gauss_penalty must be >= 0, got -1", BILAYER
    ),
    # -- physical quantities ([material], docs/units.md) -----------------------------------------
    "a modulus for a length": Case(
        ("material.length='2 GPa'",),
        "material.length must be a length, e.g. '150 um', got '2 GPa'",
        TIMOSHENKO,
    ),
    "no quantity": Case(
        ("material.layers=[{thickness='75 umm', E='2 GPa'}]",),
        "material.layers[0].thickness must be a length, e.g. '150 um'; cannot read '75 umm'",
        TIMOSHENKO,
    ),
    "Z given twice": Case(
        ("model.Z=2.0",), "model.Z is derived from [material]; give one or the other", TIMOSHENKO
    ),
    "fvk key of the driver in [model]": Case(
        ("model.load_steps=3",), "model.load_steps moved to newton.load_steps", FVK
    ),
    "path ds not positive": Case(("path.ds=0",), "path.ds must be > 0", FVK),
    "path unknown key": Case(("path.dss=0.1",), "unknown key path.dss", FVK),
    "path ds beyond ds_max": Case(
        ("path.ds=2.0",),
        "path.ds must lie in [path.ds_min, path.ds_max] = [1e-06, 0.5], got 2",
        FVK,
    ),
    "path step bounds reversed": Case(
        ("path.ds_min=1.0",), "path.ds_min = 1 exceeds path.ds_max = 0.5", FVK
    ),
    "path on a rod": Case(
        ("path.ds=0.1",),
        "unknown section [path] (known: mesh, model, flow, output, material); "
        "[path] is for model.name = 'kirchhoff' or 'bilayer' or 'foundation' or 'fvk'",
        ROD,
        ROD_SMALL,
    ),
    "path unknown method": Case(("path.method='crisfield'",), "path.method must be one of", FVK),
    "fvk pin not a node": Case(
        ("model.pin=[0.3, 0.3]",), "model.pin [0.3, 0.3] is not a vertex of the mesh", FVK
    ),
    "fvk height held by nothing": Case(
        ("model.clamped=[]",),
        "model.pin: nothing holds the plate's height against its pressure or natural curvature",
        FVK,
    ),
    "fvk free plate with one mirror": Case(
        ("model.clamped=[]", "model.mirror=['bottom']", "model.pin=[0.0, 0.0]"),
        "model.mirror: a plate that no clamped or simply supported group holds needs mirror "
        "edges along x and along y",
        FVK,
    ),
    "fvk probe named max": Case(
        ("model.probes={max=[0.5, 0.5]}",),
        "model.probes.max: a name of letters, digits and _ other than 'center' and 'max'",
        FVK,
    ),
    "fvk mirror edge also clamped": Case(
        ("model.mirror=['left']",), "model.clamped and model.mirror both list 'left'", FVK
    ),
    "fvk unknown mirror group": Case(
        ("model.mirror=['axis']",), "error: model.mirror: unknown facet group 'axis'", FVK
    ),
    "fvk path in an unset natural curvature": Case(
        ("path.method='arclength'", "path.parameter='natural_curvature'"),
        "path.parameter = 'natural_curvature' scales nothing: model.natural_curvature is not set",
        FVK,
    ),
    "fvk unknown indenter": Case(
        ("model.indenter='tip'",), "error: model.indenter: unknown cell group 'tip'", FVK
    ),
    "fvk unknown clamped group": Case(
        ("model.clamped=['lfet']",), "error: model.clamped: unknown facet group 'lfet'", FVK
    ),
    "thermal unknown anchor": Case(
        ("model.anchor='nope'",), "error: model.anchor: unknown cell group 'nope'", THERMAL
    ),
    "thermal unknown source region": Case(
        ("model.source_regions=['nope']",),
        "error: model.source_regions: unknown cell group 'nope'",
        THERMAL,
    ),
    "thermal unknown hinge": Case(
        ("model.hinges={h=['plate','plate']}",),
        "error: model.hinges: unknown cell group 'h'",
        THERMAL,
    ),
    "thermal unknown hinge panel": Case(
        ("model.hinges={plate=['plate','nope']}",),
        "error: model.hinges.plate: unknown cell group 'nope'",
        THERMAL,
    ),
    "thermal unknown clamped group": Case(
        ("model.clamped=['lfet']",), "error: model.clamped: unknown facet group 'lfet'", THERMAL
    ),
    # -- PETSc options that PETSc refuses (the factor package only at a factorisation) ----------
    "unknown pc type": Case(
        ("flow.solver={pc_type='nonexistent'}",),
        "flow.solver: PETSc refused the options: Unable to find requested PC type nonexistent",
    ),
    "unknown ksp type": Case(
        ("flow.solver={ksp_type='nonexistent'}",),
        "flow.solver: PETSc refused the options: Unable to find requested KSP type nonexistent",
    ),
    "unknown factor package": Case(
        ("flow.solver={pc_factor_mat_solver_type='nosuchpkg'}",),
        "flow.solver: PETSc refused the options: Could not locate solver type nosuchpkg",
    ),
    "unknown factor package, direct solver": Case(
        ("flow.linear_solver='direct'", "flow.solver={pc_factor_mat_solver_type='nosuchpkg'}"),
        "flow.solver: PETSc refused the options: Could not locate solver type nosuchpkg",
    ),
    "factor package without ILU": Case(
        ("flow.solver={pc_type='ilu'}",),
        "flow.solver: PETSc refused the options: MatSolverType mumps does not support "
        "factorization type ILU",
    ),
    "fvk unknown snes type": Case(
        ("newton.snes={snes_type='bogus'}",),
        "newton.snes: PETSc refused the options: Unable to find requested SNES type bogus",
        FVK,
    ),
    "fvk unknown pc type": Case(
        ("newton.snes={pc_type='bogus'}",),
        "newton.snes: PETSc refused the options: Unable to find requested PC type bogus",
        FVK,
    ),
    "fvk unknown factor package": Case(
        ("newton.snes={pc_factor_mat_solver_type='nosuchpkg'}",),
        "newton.snes: PETSc refused the options: Could not locate solver type nosuchpkg",
        FVK,
    ),
    # -- non-finite numbers ---------------------------------------------------------------------
    "load inf": Case(("model.load=[0,0,inf]",), "model.load[2] must be a finite number, got inf"),
    "load nan": Case(("model.load=[0,0,nan]",), "model.load[2] must be a finite number, got nan"),
    "load -inf": Case(("model.load=[-inf,0,0]",), "model.load[0] must be a finite number"),
    "penalty nan": Case(
        ("model.penalty={gamma0=nan, gamma1=1100.0}",),
        "model.penalty.gamma0 must be a finite number, got nan",
    ),
    "penalty inf": Case(
        ("model.penalty={gamma0=inf, gamma1=1100.0}",),
        "model.penalty.gamma0 must be a finite number, got inf",
    ),
    "penalty -inf": Case(
        ("model.penalty={gamma0=5000.0, gamma1=-inf}",),
        "model.penalty.gamma1 must be a finite number, got -inf",
    ),
    "tau inf": Case(("flow.tau=inf",), "flow.tau must be a finite number, got inf"),
    "tau nan": Case(("flow.tau=nan",), "flow.tau must be a finite number, got nan"),
    "corner inf": Case(("mesh.corners=[[0,0],[inf,1]]",), "mesh.corners[1][0] must be a finite"),
    "mu nan": Case(("model.mu=nan",), "model.mu must be a finite number"),
    "solver option nan": Case(("flow.solver={ksp_rtol=nan}",), "flow.solver.ksp_rtol must be"),
    "nan in the file": Case(
        (), "model.load[0] must be a finite number", b"[model]\nload = [nan, 0, 0]\n"
    ),
    "inf in the file": Case((), "flow.tau must be a finite number", b"[flow]\ntau = inf\n"),
    "fvk modulus inf": Case(("model.E=inf",), "model.E must be a finite number", FVK),
    # -- formulas ---------------------------------------------------------------------------------
    "division by zero": bad_load("sin(x)/0", ": formula 'sin(x)/0' divides by zero"),
    "overflow": bad_load("9**9**9**9", ": formula '9**9**9**9' overflows"),
    "huge literal": bad_load("1e999", ": formula '1e999' overflows"),
    "constant not finite": bad_load("exp(1000)", ": formula 'exp(1000)' is not finite"),
    "constant part not finite": bad_load("sqrt(-1)*x", ": formula 'sqrt(-1)*x' is not finite"),
    "not real": bad_load("(-8)**(1/3)", ": formula '(-8)**(1/3)' is not a real number"),
    "nan on the plate": bad_load("sqrt(-1-x)", ": formula 'sqrt(-1-x)' is not finite on the plate"),
    "log of negative on the plate": bad_load("ln(x-5)", ": formula 'ln(x-5)' is not finite on"),
    "zero denominator on the plate": bad_load("x/(0*x)", ": formula 'x/(0*x)' is not finite on"),
    "import call": bad_load('__import__("os")', ": calling '__import__' is not allowed"),
    "lambda call": bad_load("(lambda: 1)()", ": calling a lambda is not allowed"),
    "method call": bad_load('os.system("ls")', ": calling 'os.system' is not allowed"),
    "attribute access": bad_load("x.real", ": attribute access 'x.real' is not allowed"),
    "unknown name": bad_load("z*x", ": unknown name 'z'"),
    "syntax error": bad_load("x +", ": cannot parse formula 'x +'"),
    "condition not a comparison": bad_load("where(x, 1, 0)", ": a condition that is not a"),
    "comparison as a value": bad_load("1 + (x < 1)", ": a comparison outside the condition"),
    "wrong arity": bad_load("sin(x, y)", ": sin() with 2 argument(s) (it takes 1)"),
    "keyword argument": bad_load("sin(x=1)", ": a keyword or starred argument"),
    "deep nesting": bad_load("-" * 50000 + "x", ": nesting this deep is not allowed"),
    "clamped data formula": Case(
        ("model.boundary_data={g=['x','y','1/0']}",),
        "model.boundary_data.g[2]: formula '1/0' divides by zero",
    ),
    "curvature not finite on the plate": Case(
        ("model.Z=[[1,0],[0,'sqrt(-1-y)']]",),
        "model.Z[1][1]: formula 'sqrt(-1-y)' is not finite on the plate",
        BILAYER,
    ),
    # -- keys that do nothing for the model ---------------------------------------------------------
    "fvk with flow keys": Case(
        ("flow.tau=0.1",), "flow.tau has no effect with model.name = 'fvk'", FVK
    ),
    "fvk penalty power": Case(
        ("model.penalty={gradient_power=4}",),
        "model.penalty.gradient_power must be in [1, 3]",
        FVK,
    ),
    # -- accepted silently before ---------------------------------------------------------------
    "obstacle without psi": Case(
        ("model.obstacle={type='below', epsilon=1e-3}",),
        "model.obstacle.psi is required for type 'below': the obstacle's height ψ",
    ),
    "self-avoidance quadrature degree 0": Case(
        ("model.self_avoidance={rho=1e-4, quadrature_degree=0}",),
        "model.self_avoidance.quadrature_degree must be >= 1, got 0",
    ),
    # -- the start (model.start) ----------------------------------------------------------------
    "start of unknown type": Case(
        ("model.start={type='cone'}",),
        "model.start.type must be one of flat, arc, formula, elastica, got 'cone'",
    ),
    "start arc without radius": Case(
        ("model.start={type='arc'}",), "model.start.radius is required for type 'arc'"
    ),
    "start arc of radius 0": Case(
        ("model.start={type='arc', radius=0}",), "model.start.radius must be a finite number ≠ 0"
    ),
    "start key of another type": Case(
        ("model.start={type='arc', radius=1.0, g=[0,0,0]}",),
        "unknown key model.start.g for type 'arc' (known: type, radius, at, along)",
    ),
    "start formula not finite on the plate": Case(
        ("model.start={type='formula', g=['x', 'y', 'sqrt(-1-x)']}",),
        "model.start.g[2]: formula 'sqrt(-1-x)' is not finite on the plate",
    ),
    # -- too large for the memory of any machine, refused before anything is built --------------------
    "rod of 1e8 cells": Case(
        ("model.cells=100000000",),
        "model.cells: 100,000,000 cells of degree 2 make 1,400,000,007 unknowns",
        ROD,
        base=ROD_SMALL,
    ),
    "plate of 1e10 cells": Case(
        ("mesh.cells=[100000,100000]",),
        "mesh.cells: 10,000,000,000 cells of degree 2 make 300,000,000,000 unknowns",
    ),
    "gmsh mesh of 4e9 cells": Case(
        (),
        "mesh.parameters: about ",
        b'[mesh]\ntype = "gmsh"\nfile = "rectangle.geo"\nparameters = { h = 1e-4 }\n',
        base=(),
    ),
    "degree 40": Case(("model.degree=40",), "model.degree = 40 is above 6"),
    "rod degree 40": Case(("model.degree=40",), "model.degree = 40 is above 6", ROD, ROD_SMALL),
    # -- the problem file itself ------------------------------------------------------------------
    "empty problem file": Case(
        (), "the problem 'empty_problem_file' is empty: give at least [model]", b"", base=()
    ),
    "missing problem file": Case((), "problem file not found", MISSING),
    "problem file is a directory": Case((), "is a directory, not a file", DIRECTORY),
    "problem file not UTF-8": Case(
        (), "is not UTF-8 text (byte 0xff at offset 6)", b"[mesh]\xff\xfe\ncells = [4, 4]\n"
    ),
    "invalid TOML": Case((), "invalid TOML", b"[mesh\ncells = 3"),
    "mesh file not UTF-8": Case(
        (),
        "binary.geo is not UTF-8 text",
        b'[mesh]\ntype = "gmsh"\nfile = "{inputs}/binary.geo"\n',
        base=(),
    ),
    # -- model.metric (docs/prestrain.md) ------------------------------------------------------
    "metric not positive definite": Case(
        ("model.metric={g11='x - 2'}",),
        "model.metric: G is not symmetric positive definite at (x, y) = (",
    ),
    "metric nan on the plate": Case(
        ("model.metric={g22='sqrt(x - 10)'}",),
        "model.metric.g22: formula 'sqrt(x - 10)' is not finite on the plate: nan at",
    ),
    "metric with the ldg hessian": Case(
        ("model.metric={g11=2.0}", "model.hessian='ldg'"),
        "model.metric needs model.hessian = 'broken'",
    ),
    "metric with the edge constraint": Case(
        ("model.metric={g11=2.0}", "flow.edge_constraint=true"),
        "flow.edge_constraint holds free edges to the metric I: not with model.metric",
    ),
    # -- model.director (docs/prestrain.md) ----------------------------------------------------
    "director lambda zero": Case(
        ("model.director={angle=0.3, lambda=0}",), "model.director.lambda must be > 0, got 0"
    ),
    "director lambda negative": Case(
        ("model.director={angle=0.3, lambda=-0.9}",),
        "model.director.lambda must be > 0, got -0.9",
    ),
    "director lambda a formula": Case(
        ("model.director={angle=0.3, lambda='x'}",), "model.director.lambda must be a number"
    ),
    "director without an angle": Case(
        ("model.director={lambda=0.9}",), "model.director.angle is required"
    ),
    "director unknown key": Case(
        ("model.director={angle=0, lambda=0.9, mu=1}",),
        "unknown key model.director.mu (known keys: angle, lambda, nu)",
    ),
    "director angle not parsed": Case(
        ("model.director={angle='x +', lambda=0.9}",),
        "model.director.angle: cannot parse formula 'x +'",
    ),
    "director nu nan": Case(
        ("model.director={angle=0, lambda=0.9, nu=nan}",),
        "model.director.nu must be a finite number",
    ),
    "director and metric": Case(
        ("model.director={angle=0, lambda=0.9}", "model.metric={g11=2.0}"),
        "model.director sets the target metric, as model.metric does: give one of them",
    ),
    "metric on a bilayer with the edge constraint": Case(
        ("model.metric={g11=2.0}", "flow.edge_constraint=true"),
        "flow.edge_constraint holds free edges to the metric I: not with model.metric",
        problem=BILAYER,
    ),
    "metric on a bilayer with the ldg hessian": Case(
        ("model.metric={g11=2.0}", "model.hessian='ldg'", "flow.edge_constraint=false"),
        "model.metric needs model.hessian = 'broken'",
        problem=BILAYER,
    ),
    "director on a bilayer with the ldg hessian": Case(
        ("model.director={angle=0, lambda=0.9}", "model.hessian='ldg'"),
        "model.director needs model.hessian = 'broken'",
        problem=BILAYER,
    ),
    "metric on an lce plate with the edge constraint": Case(
        ("model.metric={g11=2.0}", "flow.edge_constraint=true"),
        "flow.edge_constraint holds free edges to the metric I: not with model.metric",
        problem=PROBLEMS / "lce_strip.toml",
    ),
    "director table on an lce plate": Case(
        ("model.director={angle=0, lambda=0.9}",),
        "model.director must be str, got {",
        problem=PROBLEMS / "lce_strip.toml",
    ),
    "director with the ldg hessian": Case(
        ("model.director={angle=0, lambda=0.9}", "model.hessian='ldg'"),
        "model.director needs model.hessian = 'broken'",
    ),
    "director angle not finite": Case(
        ("model.director={angle='log(x)', lambda=0.9}",),
        "model.director.angle: formula 'log(x)' is not finite on the plate: -inf at (x, y) = (0,",
    ),
    "director lambda overflows": Case(
        ("model.director={angle=0, lambda=1e-100, nu=4}",),
        "model.director.lambda, model.director.nu: λ² and λ^(-2ν) must be finite and > 0",
    ),
    "director with a jump": Case(
        ("model.director={angle='where(x > 0.3, 0, pi/2)', lambda=0.9}",),
        "model.director.angle: the director is not smooth: its metric G jumps by 1",
    ),
    "director with the edge constraint": Case(
        ("model.director={angle=0, lambda=0.9}", "flow.edge_constraint=true"),
        "not with model.metric or model.director",
    ),
    "metric group unknown": Case(
        ("model.metric={g11={nogroup=1.2}}",),
        "model.metric.g11: unknown cell group 'nogroup'",
        PROBLEMS / "straight_fold.toml",
    ),
    "metric group not SPD": Case(
        ("model.metric={g11={side_left=-1.0}}",),
        "): g11 = -1, g12 = 0, g22 = 1 (det G = -1)",
        PROBLEMS / "straight_fold.toml",
    ),
    "metric group formula does not parse": Case(
        ("model.metric={g22={side_left='x +'}}",),
        "model.metric.g22.side_left: cannot parse formula 'x +'",
        PROBLEMS / "straight_fold.toml",
    ),
    # -- model.poisson: the trace term of the bending energy (docs/prestrain.md) -----------------
    "poisson on a bilayer above one half": Case(
        ("model.poisson=0.7",), "model.poisson must be in (-1, 0.5], got 0.7", BILAYER
    ),
    "poisson above one half": Case(
        ("model.poisson=0.6",), "model.poisson must be in (-1, 0.5], got 0.6"
    ),
    "poisson at minus one": Case(
        ("model.poisson=-1",), "model.poisson must be in (-1, 0.5], got -1"
    ),
}

#: Cases that also run under mpirun -n 2: one or two of each place where input is refused (the
#: problem file, the schema and its units, formulas, sizes, checks on the mesh, PETSc options).
#: Every case runs serially (``test_bad_input_is_one_line_naming_the_key``); each launch here
#: costs about 1.3 s, so the cases that take a path already taken here run serially only
#: (overflow like division by zero, log of a negative like nan on the plate, ...).
MPI_CASES = [
    "problem file not UTF-8",
    "a modulus for a length",
    "load inf",
    "lambda call",
    "division by zero",
    "fvk with flow keys",
    "rod of 1e8 cells",
    "unknown group",
    "nan on the plate",
    "curvature not finite on the plate",
    "start formula not finite on the plate",
    "metric not positive definite",
    "director angle not finite",
    "unknown factor package",
    "fvk unknown snes type",
]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    """A folder for the problem files that cases write, apart from each test's tmp_path."""
    folder = tmp_path_factory.mktemp("inputs")
    (folder / "binary.geo").write_bytes(bytes(range(256)))
    (folder / "folder.toml").mkdir()
    return folder


def problem_file(case: Case, inputs: Path, name: str) -> Path:
    if case.problem == MISSING:
        return inputs / "none.toml"
    if case.problem == DIRECTORY:
        return inputs / "folder.toml"
    if isinstance(case.problem, bytes):
        path = inputs / f"{name.replace(' ', '_')}.toml"
        path.write_bytes(case.problem.replace(b"{inputs}", str(inputs).encode()))
        return path
    return Path(case.problem)


def command(case: Case, problem: Path, out: Path, verb: str = "run") -> list[str]:
    sets = [arg for value in (*case.base, *case.sets) for arg in ("--set", value)]
    return [verb, str(problem), "--out", str(out), *sets]


def assert_nothing_written(run_dir: Path) -> None:
    assert sorted(p.name for p in run_dir.iterdir()) == ["keep.txt"], "nothing may be written"
    assert (run_dir / "keep.txt").read_text() == "user data"


def assert_one_error(err: str, expected: str) -> None:
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("dgplate: error: "), err
    assert expected in lines[0], err


def test_matrix_size():
    assert len(BAD_INPUT) >= 40 and len(MPI_CASES) >= 10
    assert set(MPI_CASES) <= set(BAD_INPUT)


@pytest.mark.parametrize("verb", ["run", "check"])
@pytest.mark.parametrize("name", list(BAD_INPUT))
def test_bad_input_is_one_line_naming_the_key(name, verb, inputs, tmp_path, capsys):
    """``dgplate check`` refuses every bad input that ``dgplate run`` refuses, in its words."""
    case = BAD_INPUT[name]
    (tmp_path / "keep.txt").write_text("user data")
    code = main(command(case, problem_file(case, inputs, name), tmp_path / "out", verb))
    captured = capsys.readouterr()
    assert code == 2, captured.err
    assert_one_error(captured.err, case.expected)
    assert_nothing_written(tmp_path)


@pytest.mark.spawns_mpirun
@pytest.mark.skipif(_mpirun() is None, reason="no mpirun")
@pytest.mark.parametrize("name", MPI_CASES)
def test_bad_input_under_mpirun(name, inputs, tmp_path):
    """Two ranks: exit code 2, the one message printed by rank 0 only, and no hang."""
    case = BAD_INPUT[name]
    (tmp_path / "keep.txt").write_text("user data")
    problem = problem_file(case, inputs, name)
    args = [_mpirun(), "-n", "2", sys.executable, "-m", "mpi4py", "-m", "dgplate"]
    paths = [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}
    proc = subprocess.run(
        [*args, *command(case, problem, tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert proc.returncode == 2, proc.stderr
    # besides dgplate's line, only the launcher's notice that mpi4py aborted the job with
    # the exit code of a rank (MPICH: "Abort(2) on node 1 ...")
    ours = [line for line in proc.stderr.splitlines() if "dgplate" in line]
    assert_one_error("\n".join(ours), case.expected)
    assert "Traceback" not in proc.stderr, proc.stderr
    assert_nothing_written(tmp_path)


@pytest.mark.mpi
@pytest.mark.parametrize("name", ["load inf", "nan on the plate", "unknown group"])
def test_bad_input_in_parallel_in_process(name, inputs, tmp_path, capsys):
    """Under ``mpirun -n 2 pytest``: every rank returns 2, rank 0 alone prints."""
    comm = MPI.COMM_WORLD
    case = BAD_INPUT[name]
    out = Path(comm.bcast(str(tmp_path / "out"), root=0))
    assert main(command(case, problem_file(case, inputs, name), out)) == 2
    err = capsys.readouterr().err
    if comm.rank == 0:
        assert_one_error(err, case.expected)
    else:
        assert err == ""
    comm.barrier()
    assert not out.exists()


def test_refused_petsc_options_are_not_reported_unused(inputs, tmp_path):
    """PETSc lists the options never read when it ends: none follow the one-line error."""
    case = BAD_INPUT["unknown pc type"]
    paths = [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}
    proc = subprocess.run(
        [sys.executable, "-m", "dgplate", *command(case, VERTICAL, tmp_path / "out", "check")],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert proc.returncode == 2, proc.stderr
    assert_one_error(proc.stderr, case.expected)
    assert "WARNING" not in proc.stdout + proc.stderr, proc.stdout + proc.stderr


# -- a damaged checkpoint ----------------------------------------------------------------------------
BUDGET = ("flow.tol=1e-12", "flow.checkpoint_every=1")


@pytest.fixture(scope="module")
def spent_run(tmp_path_factory) -> Path:
    """The output folder of a run that spent its budget of 2 steps (a checkpoint to resume)."""
    comm = MPI.COMM_WORLD
    folder = Path(comm.bcast(str(tmp_path_factory.mktemp("spent") / "out"), root=0))
    sets = [arg for value in (*SMALL, *BUDGET, "flow.max_steps=2") for arg in ("--set", value)]
    assert main(["run", str(VERTICAL), "--out", str(folder), *sets]) == 1
    return folder


def _damage(data: bytes, how: str) -> bytes:
    if how == "truncated":
        return data[:300]
    if how == "empty":
        return b""
    if how == "text":  # NumPy took such bytes for a pickle and advised allow_pickle
        return b"not a checkpoint\n"
    flipped = bytearray(data)  # a byte of the state's JSON: the CRC no longer matches
    flipped[200] ^= 0xFF
    return bytes(flipped)


@pytest.mark.mpi
@pytest.mark.parametrize("verb", ["run", "check"])
@pytest.mark.parametrize("how", ["truncated", "empty", "flipped byte", "text"])
def test_damaged_checkpoint_is_one_line(spent_run, how, verb, tmp_path, capsys):
    """--resume from a damaged state.npz: one line naming the file, exit 2 on every rank."""
    comm = MPI.COMM_WORLD
    out = Path(comm.bcast(str(tmp_path / "out"), root=0))
    state = out / "checkpoint" / "state.npz"
    if comm.rank == 0:
        shutil.copytree(spent_run, out)
        state.write_bytes(_damage(state.read_bytes(), how))
    before = comm.bcast(sorted((p.name, p.stat().st_mtime_ns) for p in out.rglob("*")))
    sets = [arg for value in (*SMALL, *BUDGET, "flow.max_steps=4") for arg in ("--set", value)]
    code = main([verb, str(VERTICAL), "--out", str(out), "--resume", *sets])
    err = capsys.readouterr().err
    assert code == 2, err
    if comm.rank == 0:
        assert_one_error(err, f"--resume: the checkpoint {state} is damaged")
        assert "pickle" not in err
    else:
        assert err == ""
    comm.barrier()
    assert sorted((p.name, p.stat().st_mtime_ns) for p in out.rglob("*")) == before


# -- warnings: accepted but pointless input --------------------------------------------------------
def run_warned(tmp_path, capsys, problem: Path, *sets: str, base=SMALL) -> tuple[int, list[str]]:
    """Run in-process; the exit code and the warning lines (each one line)."""
    out = Path(MPI.COMM_WORLD.bcast(str(tmp_path / "out"), root=0))
    code = main(
        ["run", str(problem), "--out", str(out)]
        + [arg for value in (*base, *sets) for arg in ("--set", value)]
    )
    err = capsys.readouterr().err
    assert (out / "summary.json").exists(), err
    return code, [line for line in err.splitlines() if line.startswith("dgplate: warning:")]


def test_warning_nothing_to_solve_empty_problem(tmp_path, capsys):
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    code, warnings = run_warned(tmp_path, capsys, empty, "flow.max_steps=5")
    assert code == 0
    assert len(warnings) == 1, warnings
    assert "nothing to solve" in warnings[0] and "no [model] given" in warnings[0]


def test_warning_load_on_a_free_plate(tmp_path, capsys):
    """A load on a plate with nothing clamped: one warning line (the flow carries it off)."""
    code, warnings = run_warned(tmp_path, capsys, VERTICAL, "model.clamped=[]", "flow.max_steps=3")
    assert code == 1  # the budget ends the run, as it would without the warning
    assert len(warnings) == 1, warnings
    assert "model.load on a plate with nothing clamped and no model.obstacle: its " in warnings[0]
    assert "resultant ∫f = (0, 0, 0.4) is not zero" in warnings[0]  # 2.5e-2 on (0, 4)²
    # a balanced load (no net force): no warning
    balanced = "model.load=[0, 0, '0.01*((x - 2)**2 - 4/3)']"
    sets = ("model.clamped=[]", balanced, "flow.max_steps=3")
    code, warnings = run_warned(tmp_path, capsys, VERTICAL, *sets)
    assert warnings == []


@pytest.mark.mpi
def test_warning_unused_solver_option(tmp_path, capsys):
    """A misspelt option is named; options PETSc read (MUMPS' at the factorisation) are not."""
    code, warnings = run_warned(
        tmp_path,
        capsys,
        VERTICAL,
        "flow.solver={ksp_typ='cg', ksp_rtol=1e-10, mat_mumps_icntl_14=90}",
    )
    assert code == 0
    if MPI.COMM_WORLD.rank == 0:
        assert len(warnings) == 1, warnings
        assert "flow.solver.ksp_typ was never read by PETSc" in warnings[0]
    else:
        assert warnings == []


def test_warning_tau_too_large(tmp_path, capsys):
    code, warnings = run_warned(tmp_path, capsys, VERTICAL, "flow.tau=1e300")
    assert code == 0
    assert len(warnings) == 1 and "flow.tau = 1e+300 is more than 1000 h" in warnings[0]


def test_warning_tau_too_small(tmp_path, capsys):
    code, warnings = run_warned(tmp_path, capsys, VERTICAL, "flow.tau=1e-12", "flow.max_steps=1")
    assert code == 1  # the step budget: the run still writes its outputs
    assert len(warnings) == 1 and "flow.tau = 1e-12 is less than 1e-06 h²" in warnings[0]


def test_warning_isometry_defect_of_order_one(tmp_path, capsys):
    """A bilayer on 4×4 cells, the published method with τ = 0.5 and no projection: converged
    by the rate test, D_h/|Ω| ≈ 0.17.

    The energy is test_bilayer's cylinder (γ₁ = 1100, p = 1), so its forms are compiled once.
    """
    code, warnings = run_warned(
        tmp_path,
        capsys,
        BILAYER,
        "flow.method='bnn'",
        "model.penalty={gamma0=5000.0, gamma1=1100.0}",
        "flow.tau=0.5",
        "flow.tol=1e-2",
        "flow.projection_steps=0",
        "flow.edge_constraint=false",
    )
    assert code == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["converged"] and summary["isometry_defect"] > 0.2
    assert len(warnings) == 1, warnings
    assert "the converged state has isometry defect D_h" in warnings[0]
    assert "smaller flow.tau (now 0.5)" in warnings[0]


@pytest.mark.mpi
@pytest.mark.parametrize("length", ["diameter", "facet_normal"])
def test_warning_long_cells_with_the_diameter_penalty(tmp_path, capsys, length):
    """Cells 8 times longer than wide (a 4 × 4 plate on 4 × 32 cells) warn with the diameter
    as the penalties' length, not with the facet-normal one; 2 times (4 × 8) do not."""
    sets = ("mesh.cells=[4,32]", f"model.penalty_length='{length}'", "flow.max_steps=1")
    code, warnings = run_warned(tmp_path, capsys, VERTICAL, *sets)
    assert code == 1  # the step budget
    if MPI.COMM_WORLD.rank == 0 and length == "diameter":
        (warning,) = warnings
        assert "model.penalty_length = 'diameter' on cells 8 times longer than wide" in warning
        assert "(mesh.cells = [4, 32])" in warning and "penalty_length = 'facet_normal'" in warning
    else:
        assert warnings == []
    assert advice.long_cells(load_problem(VERTICAL, {"mesh.cells": [4, 8]})) is None


def test_warning_a_gmsh_plate_of_a_few_cells(tmp_path, capsys):
    """``mesh.parameters.h = 10`` on the 5 × 2 L-plate: 3 cells, and a warning naming them."""
    sets = ("mesh.parameters.h=10", "flow.max_steps=1", "output.png=false", "output.vtx=false")
    plate = PROBLEMS / "bilayer_partial_clamp.toml"
    code, warnings = run_warned(tmp_path, capsys, plate, *sets, base=())
    assert code == 1  # the budget of one step
    assert len(warnings) == 1, warnings
    assert "the mesh of long_plate.geo has 3 cell(s)" in warnings[0]
    assert "'h': 10.0" in warnings[0] and "too few to resolve a bending shape" in warnings[0]


def test_warning_adaptive_key_without_adaptive_tau(tmp_path, capsys):
    code, warnings = run_warned(tmp_path, capsys, VERTICAL, "flow.tau_growth=3.0")
    assert code == 0
    assert warnings == [
        "dgplate: warning: flow.tau_growth has no effect without flow.adaptive_tau = true "
        "(τ stays flow.tau)"
    ]


def test_warning_path_key_without_arclength(tmp_path, capsys):
    code, warnings = run_warned(tmp_path, capsys, FVK, "path.ds=0.05", "newton.load_steps=1")
    assert code == 0
    assert warnings == ["dgplate: warning: path.ds has no effect without path.method = 'arclength'"]


def test_warning_newton_key_with_arclength(tmp_path, capsys):
    sets = ("path.method='arclength'", "path.steps=2", "newton.perturb_unstable=0.1")
    code, warnings = run_warned(tmp_path, capsys, FVK, *sets)
    assert code == 0
    assert warnings == [
        f"dgplate: warning: newton.{key} has no effect with path.method = 'arclength' (of "
        "[newton] the continuation reads newton.snes only)"
        for key in ("load_steps", "perturb_unstable")
    ]


def test_warning_flow_key_with_a_plates_arclength(tmp_path, capsys):
    """A plate's path reads [flow]'s constraint keys only: flow.tau is a warning."""
    sets = ("mesh.cells=[8,1]", "flow.tau=0.1", "path.steps=2")
    code, warnings = run_warned(tmp_path, capsys, PROBLEMS / "turned_strip.toml", *sets, base=())
    assert code == 0
    assert warnings == [
        "dgplate: warning: flow.tau has no effect with path.method = 'arclength' (of [flow] "
        "the continuation reads flow.multiplier_degree, flow.edge_constraint only)"
    ]


@pytest.mark.mpi
def test_warning_unused_snes_option(tmp_path, capsys):
    """FvK's newton.snes is checked as flow.solver is: a misspelt option is named."""
    code, warnings = run_warned(
        tmp_path,
        capsys,
        FVK,
        "newton.snes={snes_rtoll=1e-8, snes_rtol=1e-9}",
        "newton.load_steps=1",
    )
    assert code == 0
    if MPI.COMM_WORLD.rank == 0:
        assert len(warnings) == 1, warnings
        assert (
            "newton.snes.snes_rtoll was never read by PETSc (options prefix -dgplate_fvk_)"
            in (warnings[0])
        )
    else:
        assert warnings == []


# -- output folders and names ----------------------------------------------------------------------
def test_empty_out_is_refused(tmp_path, capsys):
    """``--out ""`` was taken for no --out (output.dir, else out/<name>)."""
    sets = [arg for value in SMALL for arg in ("--set", value)]
    for verb in ("run", "check"):
        assert main([verb, str(VERTICAL), "--out", "", *sets]) == 2
        assert_one_error(capsys.readouterr().err, "--out is empty: give a folder")


def test_output_dir_errors_name_output_dir(tmp_path, capsys):
    """A refused output.dir is named as the user gave it, not as a --out never typed."""
    user = tmp_path / "mine"
    user.mkdir()
    (user / "notes.txt").write_text("user data")
    problem = tmp_path / "p.toml"
    problem.write_text(f'[mesh]\ncells = [4, 4]\n[output]\ndir = "{user}"\n')
    assert main(["check", str(problem)]) == 2
    message = f"output.dir {user} is a non-empty folder that dgplate did not write"
    assert_one_error(capsys.readouterr().err, message)
    assert sorted(p.name for p in user.iterdir()) == ["notes.txt"]


@pytest.mark.parametrize("name", ["../../../tmp/x", "a/b", "..", "", "a\\b"])
def test_problem_name_must_be_plain(name):
    """The name makes the default folder out/<name>: it may not leave out/."""
    with pytest.raises(InputError, match="the problem name must be a plain name"):
        problem_from_dict({"mesh": {"cells": [4, 4]}}, name)


# -- the Python API ---------------------------------------------------------------------------------
def test_numpy_values_are_numbers():
    """NumPy scalars and arrays pass where Python numbers and lists do."""
    import numpy as np

    overrides = {"mesh.cells": [np.int64(4), np.int32(4)], "flow.max_steps": np.int64(3)}
    problem = load_problem(VERTICAL, {**overrides, "flow.tau": np.float32(0.5)})
    assert problem.mesh.cells == [4, 4] and problem.flow.max_steps == 3
    assert problem.flow.tau == 0.5 and type(problem.flow.tau) is float
    data = {"mesh": {"cells": np.array([4, 4])}, "output": {"png": np.bool_(False)}}
    problem = problem_from_dict(data, "x")
    assert problem.mesh.cells == [4, 4] and problem.output.png is False


def test_initial_flat_and_bad_initials(tmp_path):
    """``initial``: a function, 'flat' or a start table; anything else one clear line."""
    problem = load_problem(VERTICAL, {"mesh.cells": [4, 4]})
    out = tmp_path / "out"
    assert check(problem, out=out, initial="flat")["warnings"] == []
    assert check(problem, out=out, initial={"type": "arc", "radius": 2.0})["dofs"] > 0
    with pytest.raises(InputError, match=r"initial must be 'flat' or a table \{type"):
        check(problem, out=out, initial="round")
    with pytest.raises(InputError, match=r"initial must be a function x ↦ y\(x\).* got int 3"):
        check(problem, out=out, initial=3)


# -- the advice functions themselves ---------------------------------------------------------------
def test_tau_bounds():
    h = 0.25
    assert advice.tau_scale(h, h) is None
    assert advice.tau_scale(0.99e3 * h, h) is None and advice.tau_scale(1.01e3 * h, h)
    assert advice.tau_scale(1.01e-6 * h * h, h) is None and advice.tau_scale(0.99e-6 * h * h, h)


def test_advise_result():
    summary = {"isometry_defect": 0.3, "converged": True, "tau": 0.5}
    assert advice.advise_result(summary, area=4.0) == []  # D_h/|Ω| = 0.075
    (message,) = advice.advise_result(summary, area=2.0)
    assert "D_h = 0.3" in message and "(now 0.5)" in message
    assert advice.advise_result({"converged": True}) == []  # FvK summaries have no D_h


NOTHING = "nothing to solve"


@pytest.mark.parametrize(
    ("model", "nothing"),
    [
        ({}, True),
        ({"load": [0, 0, "0*x"]}, True),
        ({"load": [0, 0, "where(x > 100, 1, 0)"]}, True),  # zero on the plate [0, 1]²
        ({"load": [0, 0, "0.1*sin(pi*x)"]}, False),
        ({"clamped": ["left"], "boundary_data": {"g": ["x", "y", 0]}}, True),
        ({"clamped": ["left"], "boundary_data": {"g": ["x", "y", "0.1*x"]}}, False),
        ({"name": "bilayer", "Z": 0.0}, True),
        ({"name": "bilayer", "Z": {"plate": 0.0}}, True),
        ({"name": "bilayer", "Z": [[0, 0], [0, "x"]]}, False),
        ({"name": "fvk", "clamped": ["left"]}, False),  # not a gradient-flow model
    ],
)
def test_nothing_to_solve(model, nothing):
    problem = problem_from_dict({"model": model}, "p")  # {}: the default kirchhoff plate
    tagged = rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [4, 4], "quadrilateral", "right")
    message = advice.nothing_to_solve(problem, tagged.mesh)
    assert (message is not None and NOTHING in message) == nothing, message
    assert advice.nothing_to_solve(problem, tagged.mesh, starts_flat=False) is None


def test_option_used_through_ctypes_agrees_with_petsc4py():
    """The ctypes path (petsc4py < 3.24) answers like Options.used where both exist."""
    from petsc4py import PETSc

    options = PETSc.Options()
    prefix = "dgplate_test_used_"
    options[f"{prefix}ksp_type"] = "cg"
    options[f"{prefix}ksp_typ"] = "cg"
    ksp = PETSc.KSP().create(MPI.COMM_SELF)
    try:
        ksp.setOptionsPrefix(prefix)
        ksp.setFromOptions()
        assert advice.c_option_used(f"{prefix}ksp_type") is True
        assert advice.c_option_used(f"{prefix}ksp_typ") is False
        if hasattr(options, "used"):
            assert options.used(f"{prefix}ksp_typ") is False
    finally:
        ksp.destroy()
        for key in ("ksp_type", "ksp_typ"):
            options.delValue(f"{prefix}{key}")


def test_check_formulas_without_a_mesh():
    expressions.check([0, "0.1*sin(pi*x)", "where(x < 0.5, 1, -1)"], "model.load")
    with pytest.raises(InputError, match=r"model\.Z\[0\]\[1\]: formula '1/0' divides by zero"):
        expressions.check([[1, "1/0"], [0, 1]], "model.Z")


@pytest.mark.mpi
def test_fewer_cells_than_ranks_is_bad_input(comm, tmp_path):
    """A rank without a cell is refused before anything is written (it crashed the run)."""
    if comm.size == 1:
        pytest.skip("needs 2 ranks")
    problem = load_problem(VERTICAL, {"mesh.cells": [1, 1]})
    with pytest.raises(InputError, match=r"mesh: 1 cell\(s\) for \d+ ranks"):
        check(problem, comm=comm)


def test_a_mesh_file_that_makes_no_cells_is_bad_input():
    problem = problem_from_dict(
        {"mesh": {"type": "gmsh", "file": "rectangle.geo", "parameters": {"Lx": 0}}}, "empty"
    )
    # gmsh 4.15 makes an empty mesh, Debian 13's 4.13 stops with its own error
    with pytest.raises(InputError, match=r"gmsh (made no cells from|failed on) rectangle\.geo"):
        check(problem)


def test_python_api_type_errors_are_input_errors(tmp_path):
    """The API's wrong types say what was expected; a single --set text and tuples work."""
    with pytest.raises(InputError, match="a problem is a dict of sections, got NoneType"):
        problem_from_dict(None, "x")
    with pytest.raises(InputError, match=r"must be a dgplate\.Problem .* got str"):
        check(str(VERTICAL))
    problem = load_problem(VERTICAL, "mesh.cells=[4, 4]")
    assert problem.mesh.cells == [4, 4]
    assert load_problem(VERTICAL, {"mesh.cells": (4, 4)}).mesh.cells == [4, 4]
    with pytest.raises(InputError, match="out must be a folder path, got int 123"):
        check(problem, out=123)


def test_a_self_intersecting_boundary_ends_at_once(tmp_path):
    """gmsh alone splits such a boundary's edges for minutes; dgplate stops it: no cells."""
    import gmsh

    if tuple(int(part) for part in gmsh.__version__.split(".")[:2]) < (4, 15):
        pytest.skip("gmsh < 4.15 (Debian 13 has 4.13) loops whatever Mesh.MaxRetries says")
    geo = tmp_path / "bowtie.geo"
    geo.write_text(
        "Point(1) = {0, 0, 0, 0.2}; Point(2) = {1, 1, 0, 0.2};\n"
        "Point(3) = {1, 0, 0, 0.2}; Point(4) = {0, 1, 0, 0.2};\n"
        "Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};\n"
        'Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1}; Physical Surface("plate") = {1};\n'
    )
    problem = problem_from_dict({"mesh": {"type": "gmsh", "file": str(geo)}}, "bowtie")
    with pytest.raises(InputError, match=r"gmsh (made no cells from|failed on) bowtie\.geo"):
        check(problem)
