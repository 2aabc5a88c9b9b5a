# The two commands of the README. Each brings a bare Debian 12 or 13 root machine to done by itself.
PY := .venv/bin/python
# Root allowed; oversubscription allowed, spelled for Open MPI 4 (Debian 12) and 5 (Debian 13).
MPIRUN := OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 \
  PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe mpirun

.PHONY: setup demo test test-full test-serial test-mpi test-container check check-mpi fuzz bench \
  clean container-test container-test-sid docs test-docs notebooks

setup:
	@scripts/setup.sh

demo: setup
	.venv/bin/rodfem run paper1 --out results/paper1 --force
	.venv/bin/rodfem plot results/paper1

# The suite's quick profile: every promise, the wide grids by representative cases, the long
# property tests left out (tests/conftest.py says how).
test: setup test-serial test-mpi

# The full profile: test's, with the tests marked slow (every case of the grids, the demos under
# mpirun, the long property tests).
test-full: export RODFEM_TEST_PROFILE := full
test-full: setup test-serial test-mpi

# The serial suite dealt to a process per core (at most four; pytest-xdist), a test file to each
# in turn, so that what a file's tests share is made once: TEST_JOBS=1 for one process.
TEST_JOBS ?= $(shell n=$$(nproc 2>/dev/null || echo 1); [ "$$n" -gt 4 ] && n=4; echo $$n)

test-serial:
	$(PY) -m pytest -q -n $(TEST_JOBS) --dist loadfile tests

test-mpi:
	$(MPIRUN) -n 2 $(PY) -m mpi4py -m pytest -q tests

# A quick look at every layer (under two minutes on two cores; `make test` runs everything, about
# 12 minutes): scenes and the command line's refusals, the forms against the NumPy reference, each
# method, a resumed run bit for bit, a sweep, the figures; then the parallel answer on two ranks.
CHECK_MPI := "tests/test_reference.py::test_paper_scenes_agree_with_reference[paper1-lumped]" \
  "tests/test_methods.py::test_methods_agree_on_the_paper_scenes[paper1]" \
  tests/test_sweep.py::test_rows_equal_single_runs_serially_and_under_mpirun tests/test_bad_input.py
CHECK_SERIAL := tests/test_architecture.py tests/test_expressions.py tests/test_scene_fuzz.py \
  $(CHECK_MPI) \
  tests/test_sweep.py::test_bad_sweep_files_are_one_line_exit_2_nothing_written \
  tests/test_resume.py::test_a_finished_run_extends_to_a_later_end tests/test_plot.py::test_one_run

check: setup
	$(PY) -m pytest -q $(CHECK_SERIAL)
	$(MAKE) --no-print-directory check-mpi

check-mpi:
	$(MPIRUN) -n 2 $(PY) -m mpi4py -m pytest -q $(CHECK_MPI)

# The suite the container checks run: the serial suite whole (its tests that start mpirun
# included), then check's part on two ranks. The whole suite on two ranks is make test's, natively.
test-container: setup test-serial check-mpi

# Scene loading fuzzed with 10^4 examples per property (the suite runs 150), and steady states
# and their verdicts over 2,000 random scenes (the suite runs 25).
fuzz: setup
	HYPOTHESIS_PROFILE=fuzz $(PY) -m pytest -q tests/test_scene_fuzz.py tests/test_steady_property.py

clean:
	rm -rf results .pytest_cache .hypothesis

# The documentation site in docs/_build/html, warnings as errors, every reference checked
# (nitpicky). Sets itself up: Sphinx, MyST, Furo, MathJax and Chromium from Debian, jupytext from
# PyPI (scripts/setup.sh docs). Runs every demo (CI=1) and generates the scene, CLI and API
# references from the code. About a minute and a half.
docs:
	@scripts/setup.sh docs
	$(PY) -m sphinx -b html -W --keep-going -n -q docs docs/_build/html
	@echo "docs: docs/_build/html/index.html"

# Checks of the built site: every page, link and image resolves, the references are complete,
# and headless Chromium renders the pages with their figures and formulas. Skipped (with the
# reason) without docs/_build/html: run `make docs` first.
test-docs:
	$(PY) -m pytest -q tests/test_docs_reference.py tests/test_docs_site.py

# The demos as Jupyter notebooks, in build/notebooks/ (jupytext; `pip install -e .[jupyter]` for
# Jupyter itself).
notebooks:
	@scripts/setup.sh docs
	@mkdir -p build/notebooks
	for demo in demos/demo_*.py; do \
	  $(PY) -m jupytext --quiet --to ipynb --output build/notebooks/$$(basename $$demo .py).ipynb $$demo \
	    || exit 1; \
	done

bench: setup
	$(PY) benchmarks/bench_picard.py
	$(PY) benchmarks/bench_scaling.py

# The container recipe (containers/Dockerfile, Debian 13) without Docker: a debootstrapped trixie
# chroot in build/, the Dockerfile's install step, then `make test-container` and an mpirun paper
# run there.
container-test:
	scripts/container-test.sh

# The same check of containers/Dockerfile.sid (Debian unstable, dolfinx 0.11) in build/sid.
container-test-sid:
	CONTAINER_DOCKERFILE=containers/Dockerfile.sid scripts/container-test.sh
