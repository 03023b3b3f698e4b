# dgplate: the two commands are `make demo` and `make test`; both set up .venv first.
VENV   := .venv
PY     := $(VENV)/bin/python
MPIRUN  = $(if $(wildcard $(VENV)/bin/mpirun),$(VENV)/bin/mpirun,mpirun)
NP     ?= 2
# The main demo: the self-folding box once it exists, else the most complete one.
DEMO   ?= $(firstword $(wildcard demos/box_folding.py demos/vertical_load.py demos/biharmonic.py))
PYTEST_FLAGS ?= -q

.PHONY: setup demo test test-fast test-serial test-mpi lint format check-debian bench bench-large bench-tau bench-paper docs docs-check clean

setup:
	@bash .ci/setup-venv.sh

demo: setup
	$(MPIRUN) -n $(NP) $(PY) $(DEMO)

test: setup test-serial test-mpi

# The fast tier (about 2 minutes on 2 cores, warm JIT cache): every test but those marked slow
# (tests/slow_tests.txt: 2 s or more; the demos; the shipped problem files) and those that
# launch mpirun.
test-fast: setup
	$(PY) -m pytest $(PYTEST_FLAGS) -n $(NP) --dist worksteal -m "not slow and not spawns_mpirun" tests

# Two passes: the tests on NP parallel workers (pytest-xdist), then those that launch mpirun
# themselves (marker spawns_mpirun, among them a demo of each model and feature on 2 ranks) one
# at a time, with the cores to themselves and the forms already in the JIT cache.
test-serial: setup
	$(PY) -m pytest $(PYTEST_FLAGS) -n $(NP) --dist worksteal -m "not spawns_mpirun" tests
	$(PY) -m pytest $(PYTEST_FLAGS) -m spawns_mpirun tests

# Tests marked `mpi` again on NP ranks; `-m mpi4py` aborts all ranks when one fails. A test
# still running after 5 minutes (the longest takes under a minute) prints each rank's stack.
# A rank that ends with exit code 15 and no message ran out of MPICH's communicator ids
# (MPI_ERR_OTHER; tests/conftest.py collects each module's garbage against it).
test-mpi: setup
	$(MPIRUN) -n $(NP) $(PY) -m mpi4py -m pytest $(PYTEST_FLAGS) -p no:cacheprovider \
	  -o faulthandler_timeout=300 -m mpi tests

LINT_DIRS = $(wildcard dgplate tests demos benchmarks docs)

# ruff (with Google docstrings and complexity ≤ 10 on dgplate/) and mypy (strict on the
# numerical core: dg, solvers, models; relaxed on tests, demos, benchmarks; see pyproject.toml)
lint: setup
	$(VENV)/bin/ruff check $(LINT_DIRS)
	$(VENV)/bin/ruff format --check $(LINT_DIRS)
	$(VENV)/bin/mypy

format: setup
	$(VENV)/bin/ruff format $(LINT_DIRS)
	$(VENV)/bin/ruff check --fix $(LINT_DIRS)

# The performance study (about 45 min on 2 cores): JSON in benchmarks/results, then the plot
# and the performance page's tables (docs/performance.md). Growth and scaling use the 2-rank rows; 64² also runs
# on 1 rank with the naive flow to the end (same step count, same E_h), and 128² on 1 rank for
# the scaling. The 64² optimised runs are repeated three times on 1 and 2 ranks; the scaling
# uses the median runs. The memory bandwidth on 1 and on 2 ranks at once (the ceiling of the
# substitutions' speed-up) is measured before and after them.
BENCH_OUT ?= benchmarks/results
bench: setup
	$(PY) benchmarks/bandwidth.py --json $(BENCH_OUT)/bandwidth_before.json
	$(PY) benchmarks/flow.py --cells 64 --repeat 3 --compare-naive \
	  --json $(BENCH_OUT)/flow_64_np1.json
	$(PY) benchmarks/flow.py --cells 128 --json $(BENCH_OUT)/flow_128_np1.json
	for n in 16 32 64 128; do \
	  $(MPIRUN) -n 2 $(PY) benchmarks/flow.py --cells $$n --compare-naive --naive-steps 3 \
	    $$( [ $$n = 64 ] && echo --repeat 3 ) --json $(BENCH_OUT)/flow_$${n}_np2.json || exit 1; \
	done
	$(PY) benchmarks/bandwidth.py --json $(BENCH_OUT)/bandwidth_after.json
	$(PY) benchmarks/report.py --results $(BENCH_OUT)

# The BNN plate past Table 1: 256² cells (1.97 M DoFs) on 2 ranks to the published stop, about
# an hour and 17 GB; it checkpoints as it goes, and the same command resumes an interrupted run.
LARGE_RUN ?= out/bnn_256
bench-large: setup
	$(MPIRUN) -n 2 $(PY) benchmarks/bnn_large.py --cells 256 --out $(LARGE_RUN) \
	  --json $(BENCH_OUT)/bnn_256_np2.json
	$(PY) benchmarks/report.py --results $(BENCH_OUT)

# Time to solution (about 35 min on 2 cores, 1 rank): fixed τ = h against adaptive τ and the
# SQP finish, each to the τ-independent stop, on the BNN 64² plate, the bilayer cylinder 32×16
# and the box's two holds; then the performance page's tables again (its table below the
# flow study's).
bench-tau: setup
	$(PY) benchmarks/adaptive_tau.py --problem bnn --cells 64 \
	  --json $(BENCH_OUT)/adaptive_tau_bnn64_newton_np1.json
	$(PY) benchmarks/adaptive_tau.py --problem cylinder --cells 32 16 \
	  --json $(BENCH_OUT)/adaptive_tau_cylinder32x16_newton_np1.json
	$(PY) benchmarks/box_relaxation.py --json $(BENCH_OUT)/box_relaxation_np1.json
	$(PY) benchmarks/report.py --results $(BENCH_OUT)

# The published sizes (about 90 min on 2 cores): the box's problem file and the demos with
# --paper on 2 ranks (the box, the I-shape), then the roll-ups through ¼, ½ and 1 turn; JSON in
# benchmarks/results and the tables of docs/performance.md and docs/box.md.
bench-paper: setup
	$(PY) benchmarks/paper_sizes.py --ranks 2 --json $(BENCH_OUT)/paper_sizes.json
	$(PY) benchmarks/rollup.py --cells 96 8 --json $(BENCH_OUT)/rollup.json

# The documentation site in docs/_build/html (entry page index.html), warnings as errors.
docs: setup
	@$(PY) -c "import sphinx, myst_nb, furo" 2>/dev/null || $(PY) -m pip install --quiet -e ".[docs]"
	$(PY) -m sphinx -W --keep-going -q -b html docs docs/_build/html

# The site in headless Chromium (Debian's chromium and chromium-driver, installed if missing):
# console errors, broken links and images; screenshots in docs/_build/screenshots.
docs-check: docs
	@bash .ci/install-chromium.sh
	$(PY) -m pytest -q -p no:cacheprovider docs/test_site.py

# Serial tests with Debian 13's DOLFINx 0.9 in a debootstrap chroot (cached in .cache/).
check-debian:
	bash .ci/check-debian.sh

clean:
	rm -rf $(VENV) .cache build dist *.egg-info .pytest_cache .ruff_cache out results docs/_build docs/_generated
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
