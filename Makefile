# The two commands of the README. Each brings a bare Debian 12 or 13 root machine to done by itself.
PY := .venv/bin/python
# Root allowed; oversubscription allowed, spelled for Open MPI 4 (Debian 12) and 5 (Debian 13).
MPIRUN := OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 \
  PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe mpirun

.PHONY: setup demo test test-serial test-mpi fuzz bench clean container-test container-test-sid

setup:
	@scripts/setup.sh

demo: setup
	.venv/bin/rodfem run paper1 --out results/paper1 --force
	.venv/bin/rodfem plot results/paper1

test: setup test-serial test-mpi

test-serial:
	$(PY) -m pytest -q tests

test-mpi:
	$(MPIRUN) -n 2 $(PY) -m mpi4py -m pytest -q tests

# Scene loading fuzzed with 10^4 examples per property (the suite runs 150).
fuzz: setup
	HYPOTHESIS_PROFILE=fuzz $(PY) -m pytest -q tests/test_scene_fuzz.py

clean:
	rm -rf results .pytest_cache .hypothesis

bench: setup
	$(PY) benchmarks/bench_picard.py
	$(PY) benchmarks/bench_scaling.py

# The container recipe (containers/Dockerfile, Debian 13) without Docker: a debootstrapped trixie
# chroot in build/, the Dockerfile's install step, then `make test` and an mpirun paper run there.
container-test:
	scripts/container-test.sh

# The same check of containers/Dockerfile.sid (Debian unstable, dolfinx 0.11) in build/sid.
container-test-sid:
	CONTAINER_DOCKERFILE=containers/Dockerfile.sid scripts/container-test.sh
