"""A fast subset of benchmarks/fuzz.py (issue 24): generated inputs of every kind through the real entry point,
each checked for its exit status, one line on stderr, no traceback, the earlier results untouched, no partial set,
exit 0 only with the physics checks passing; and two interrupted runs. The full run (240 cases and every solver
path interrupted) is recorded in docs/fuzz/README.md."""

from __future__ import annotations


import pytest

from benchmarks import fuzz  # noqa: E402

pytestmark = pytest.mark.serial

CASES = fuzz.generate(seed=7, count=36)
SIGNALS = [fuzz.signal_cases()[0], fuzz.signal_cases()[-1]]  # the shell (SIGINT), a path after a solve (SIGTERM)


@pytest.fixture(scope="module")
def earlier(tmp_path_factory):
    return fuzz.earlier_results(tmp_path_factory.mktemp("earlier"))


@pytest.mark.parametrize("case", [pytest.param(c, id=c.name, marks=[pytest.mark.multirank] if c.ranks > 1 else [])
                                  for c in CASES + SIGNALS])
def test_fuzz_case(case, earlier, tmp_path):
    status, problems = fuzz.run_case(case, tmp_path, earlier)
    assert not problems, (case.argv, status, problems)


def test_the_generated_cases_cover_every_kind():
    kinds = {c.name.split("-", 1)[1] for c in CASES}
    assert kinds == {"flag_bad", "flag_good", "petsc_bad", "petsc_good", "scene_bad", "scene_good", "out_bad",
                     "mixed", "diverge", "hostile"}


@pytest.mark.parametrize("index", range(len(fuzz.hostile_cases())))
def test_hostile_case(index, earlier, tmp_path):
    """Every hostile case (obstacles the contact nodes cannot see, rtol given twice, a loose accuracy): exit 2 in
    one line or exit 3, never exit 0."""
    argv, files = fuzz.hostile_cases()[index]
    status, problems = fuzz.run_case(fuzz.Case(f"hostile-{index}", list(argv), dict(files)), tmp_path, earlier)
    assert not problems and status in (2, 3), (argv, status, problems)
