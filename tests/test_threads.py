"""holecli.threads: one BLAS thread while holecli measures, the limits put back afterwards."""

import threading

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import holecli.robust.method  # noqa: F401  (loads scipy's BLAS, as detect does before its limit)
from holecli import detect
from holecli.errors import PointsError
from holecli.threads import single_blas_thread


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
