"""Fixtures shared by the tests."""

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from roadgrip.blas_threads import one_blas_thread


def _blas_threads() -> dict[str, int]:
    return {d["filepath"]: d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"}


@pytest.fixture
def blas_threads():
    """A function: the threads of every loaded BLAS library, by file."""
    return _blas_threads


@pytest.fixture
def two_blas_threads():
    """BLAS set to two threads for the test, which gets their counts by file (skipped
    where BLAS cannot run two)."""
    with one_blas_thread():  # loads SciPy's BLAS too, so both libraries are listed
        pass
    with threadpool_limits(limits=2, user_api="blas"):
        threads = _blas_threads()
        if not threads or min(threads.values()) < 2:
            pytest.skip(f"BLAS runs one thread at most here: {threads}")
        yield threads
