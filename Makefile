# fenics-coulomb: the README's two commands. Each runs inside the project's environment (container/run),
# which builds the trixie rootfs on first use and reuses it afterwards.
RUN := container/run
NP ?= 2
PYTEST_ARGS ?=

.PHONY: demo test lint test-serial test-mpi test-host env

demo:
	$(RUN) mpirun -n $(NP) python3 demos/cuboid.py

# The static checks beside the serial pass (mypy without a cache, as on a clean clone, is ~40 s of one core: run
# first it left the other core idle), then the 2-rank pass and the host checks. Either failing fails the target;
# a lint failure is printed when it happens, and reported at the end of the serial pass.
test:
	@$(MAKE) --no-print-directory -j2 lint test-serial
	@$(MAKE) --no-print-directory test-mpi
	@$(MAKE) --no-print-directory test-host

# Static checks: ruff on the whole tree, mypy on the package (rules: pyproject.toml).
lint:
	@$(RUN) ruff check --quiet --output-format concise . || { \
	  echo "make lint: ruff found the problems above (rules: pyproject.toml [tool.ruff]; 'ruff check --fix' fixes those marked [*])"; exit 1; }
	@$(RUN) mypy fenics_coulomb || { \
	  echo "make lint: mypy found the type errors above (rules: pyproject.toml [tool.mypy])"; exit 1; }

# The serial pass as SHARDS pytest processes side by side, one per core (tests/conftest.py --shard: every process
# splits the collected tests the same way, whole modules, each run in its own order as unsharded). Each
# shard's output is printed when it ends; any failing shard fails the pass. SHARDS=1 is one process. Tests marked
# compares_ranks (a run on all ranks against one rank alone: on one rank they compare it with itself, or start
# their own mpirun) run in the 2-rank pass only.
# Tests marked multirank (they start a job of several ranks) run alone, the other shards waiting between their
# tests (--cores-lock, tests/cores.py): beside a busy shard such a job's ranks wait for cores in busy-polling
# collectives. A test that starts such a job without the mark fails.
SHARDS ?= 2

test-serial:
	@logs=$$(mktemp -d); pids=""; \
	for i in $$(seq 1 $(SHARDS)); do \
	  $(RUN) python3 -m pytest -q --color=no -p no:cacheprovider --shard $$i/$(SHARDS) --cores-lock $$logs/cores.lock -m "not compares_ranks" tests $(PYTEST_ARGS) \
	    > $$logs/$$i.log 2>&1 & pids="$$pids $$!"; \
	done; \
	status=0; i=0; for pid in $$pids; do \
	  i=$$((i + 1)); wait $$pid || status=1; echo "== serial shard $$i/$(SHARDS)"; cat $$logs/$$i.log; \
	done; rm -rf $$logs; exit $$status

# One MPI job per test package: a failure names its package, and no collective state outlives a package
# (docs/testing.md: the stall a long 2-rank process once met, its cause and its regression test).
MPI_PACKAGES = tests/cli tests/io tests/model tests/problems tests/scd tests/scenes

test-mpi:
	@for d in $(MPI_PACKAGES); do \
	  echo "== $$d on $(NP) ranks"; \
	  $(RUN) mpirun -n $(NP) python3 -m mpi4py -m pytest -q --color=no -p no:cacheprovider -m "not serial" $$d $(PYTEST_ARGS) \
	    || exit 1; \
	done

# container/run itself, from the host: paths outside the repository, interrupts leave no process behind
test-host:
	tests/host/interrupts.sh
	tests/host/container_paths.sh

env:
	$(RUN) python3 -c "import dolfinx, petsc4py; print('DOLFINx', dolfinx.__version__)"
