import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from roadgrip.blas_threads import one_blas_thread


def blas_threads() -> dict[str, int]:
    """Threads of every loaded BLAS library, by file."""
    return {d["filepath"]: d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"}


@pytest.fixture
def two_blas_threads():
    """BLAS set to two threads for the test (skipped where it cannot run two)."""
    with one_blas_thread():  # loads SciPy's BLAS too, so both libraries are listed
        pass
    with threadpool_limits(limits=2, user_api="blas"):
        threads = blas_threads()
        if not threads or min(threads.values()) < 2:
            pytest.skip(f"BLAS runs one thread at most here: {threads}")
        yield threads


def test_one_blas_thread_limits_every_library_inside_and_restores(two_blas_threads):
    with one_blas_thread():
        inside = blas_threads()
    assert set(inside) == set(two_blas_threads)
    assert all(n == 1 for n in inside.values())
    assert blas_threads() == two_blas_threads
