"""One BLAS thread around the estimators' small per-step matrix products.

The GP-SSM filter calls BLAS every step on small matrices (the peak summary's product of
the particles' posterior means with the features on the slip grid, ``N x m`` by ``m x
41``) and, every few dozen steps, on many small ones (the refactorisation). A
multithreaded BLAS, as NumPy and SciPy bundle (OpenBLAS, one thread per core by
default), splits each such product across its threads and keeps them spinning between
calls; on a 2-core machine that made a whole drive about 1.5 times slower than with one
thread. :func:`one_blas_thread` limits every loaded BLAS to one thread inside a ``with``
block and restores the previous setting on exit (``threadpoolctl``); the filter's
``step`` and ``run`` use it, so the setting of the rest of the program is left alone.
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from functools import lru_cache

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]


@lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    # SciPy's BLAS is the one the compiled kernels call (numba binds ``np.dot`` to
    # ``scipy.linalg.cython_blas``); load it before the controller lists the libraries
    import scipy.linalg.cython_blas  # noqa: F401

    return ThreadpoolController()


def one_blas_thread() -> AbstractContextManager:
    """Context manager: every BLAS library loaded at the first call runs one thread inside.

    About 15 µs per use (the controller, which lists the libraries once, is cached).
    """
    return _controller().limit(limits=1, user_api="blas")
