"""The studies behind docs/ (long runs, never in the tests): each module runs as a script inside the environment
(``container/run mpirun -n 2 python3 benchmarks/table2.py ...``); the tests import the ones whose fast subsets
they check (``from benchmarks import robustness``)."""
