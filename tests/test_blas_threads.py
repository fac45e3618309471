from roadgrip.blas_threads import one_blas_thread


def test_one_blas_thread_limits_every_library_inside_and_restores(two_blas_threads, blas_threads):
    with one_blas_thread():
        inside = blas_threads()
    assert set(inside) == set(two_blas_threads)
    assert all(n == 1 for n in inside.values())
    assert blas_threads() == two_blas_threads
