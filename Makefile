# fenics-coulomb: the README's two commands. Each runs inside the project's environment (container/run),
# which builds the trixie rootfs on first use and reuses it afterwards.
RUN := container/run
NP ?= 2
PYTEST_ARGS ?=

.PHONY: demo test test-serial test-mpi test-host env

demo:
	$(RUN) mpirun -n $(NP) python3 demos/cuboid.py

test: test-serial test-mpi test-host

test-serial:
	$(RUN) python3 -m pytest -q --color=no tests $(PYTEST_ARGS)

test-mpi:
	$(RUN) mpirun -n $(NP) python3 -m mpi4py -m pytest -q --color=no -p no:cacheprovider -m "not serial" tests $(PYTEST_ARGS)

# container/run itself, from the host: paths outside the repository, interrupts leave no process behind
test-host:
	tests/host/interrupts.sh
	tests/host/container_paths.sh

env:
	$(RUN) python3 -c "import dolfinx, petsc4py; print('DOLFINx', dolfinx.__version__)"
