"""holecli.threads: one BLAS thread while holecli measures, the limits put back afterwards."""

import os
import subprocess
import sys
import threading

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import holecli.robust.method  # noqa: F401  (loads scipy's BLAS, as detect does before its limit)
from holecli import detect
from holecli.errors import PointsError
from holecli.threads import BLAS_THREAD_VARIABLES, single_blas_thread, start_blas_single_threaded


def blas_threads():
    return sorted({pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"})


@pytest.fixture
def two_blas_threads():
    """Start from two BLAS threads (whatever the machine), so that a limit to one is visible."""
    assert blas_threads(), "numpy has no BLAS that threadpoolctl sees"
    with threadpool_limits(limits=2, user_api="blas"):
        yield


def test_the_block_runs_on_one_blas_thread_and_the_limit_is_put_back(two_blas_threads):
    with single_blas_thread():
        assert blas_threads() == [1]
    assert blas_threads() == [2]


def test_nested_blocks_restore_the_limit_once_the_outer_ends(two_blas_threads):
    with single_blas_thread():
        with single_blas_thread():
            assert blas_threads() == [1]
        assert blas_threads() == [1]
    assert blas_threads() == [2]


def test_a_block_in_another_thread_leaves_the_limits_alone(two_blas_threads):
    """OpenBLAS ignores limits set from other threads: the block must not try (a restore from there
    would not take either, and would leave the program at one thread)."""
    seen = []

    def worker():
        with single_blas_thread():
            seen.append(blas_threads())

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join(30)
    assert seen == [[2]]
    assert blas_threads() == [2]


def test_detect_restores_the_limit_when_it_raises(two_blas_threads):
    points = np.random.default_rng(0).normal(size=(200, 3))
    with pytest.raises(PointsError):
        detect(points, method="paper", min_diameter=1.0)
    assert blas_threads() == [2]


def test_detect_measures_on_one_blas_thread(two_blas_threads, monkeypatch):
    seen = []

    class Seen(Exception):
        pass

    def fake_detect_robust(points, **options):
        seen.append(blas_threads())
        raise Seen

    monkeypatch.setattr(holecli.robust.method, "detect_robust", fake_detect_robust)
    with pytest.raises(Seen):
        detect(np.random.default_rng(0).normal(size=(200, 3)))
    assert seen == [[1]]
    assert blas_threads() == [2]


def test_the_program_asks_blas_for_one_thread_unless_the_user_set_a_count():
    environ = {"MKL_NUM_THREADS": "3"}
    assert start_blas_single_threaded(environ) == ["OPENBLAS_NUM_THREADS"]
    assert environ == {"OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "3"}
    assert start_blas_single_threaded(environ) == []


PROGRAM_THEN_NUMPY = """
import sys
from holecli.__main__ import main
sys.argv = ["holecli", "--version"]
try:
    main()
except SystemExit:
    pass
import numpy
from threadpoolctl import threadpool_info
print(sorted({pool["num_threads"] for pool in threadpool_info() if pool["internal_api"] == "openblas"}))
"""


@pytest.mark.parametrize("given, expected", [(None, "[1]"), ("2", "[2]")])
def test_numpy_imported_by_the_program_starts_openblas_with_one_thread(given, expected):
    """The ``holecli`` program sets the variable before numpy loads OpenBLAS (which reads it only
    then): no BLAS threads are started at import. A count the user set is kept."""
    environment = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARIABLES}
    if given is not None:
        environment["OPENBLAS_NUM_THREADS"] = given
    result = subprocess.run([sys.executable, "-c", PROGRAM_THEN_NUMPY], env=environment, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    if result.stdout.strip().splitlines()[-1] == "[]":
        pytest.skip("numpy here has no OpenBLAS")
    assert result.stdout.strip().splitlines()[-1] == expected
