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


def pytest_configure(config):
    """Share simulated multi-body drives between test workers and runs (content-hashed)."""
    import os
    from pathlib import Path

    os.environ.setdefault("ROADGRIP_DRIVE_CACHE", str(Path(__file__).resolve().parents[1] / ".cache" / "drives"))
