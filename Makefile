# The two commands of the README. Each brings a bare Debian 12 root machine to done by itself.
PY := .venv/bin/python
MPIRUN := OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 mpirun

.PHONY: setup demo test test-serial test-mpi bench clean

setup:
	@scripts/setup.sh

demo: setup
	.venv/bin/rodfem run paper1 --out results/paper1 --force

test: setup test-serial test-mpi

test-serial:
	$(PY) -m pytest -q tests

test-mpi:
	$(MPIRUN) -n 2 $(PY) -m mpi4py -m pytest -q tests

clean:
	rm -rf results .pytest_cache

bench: setup
	$(PY) benchmarks/bench_picard.py
