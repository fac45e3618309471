"""MNIW conjugate statistics (roadgrip.estimators.mniw)."""

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from roadgrip.estimators import mniw


def _data(T=60, m=5, d=2, seed=0):
    rng = np.random.default_rng(seed)
    phis = rng.standard_normal((T, m))
    A = rng.standard_normal((d, m))
    zetas = phis @ A.T + 0.1 * rng.standard_normal((T, d))
    return phis, zetas


@pytest.mark.parametrize("lam", [1.0, 0.97])
def test_recursive_statistics_equal_batch_closed_form(lam):
    phis, zetas = _data()
    st = mniw.prior_stats((), 5, 2, nu0=7.0)
    for k, (p, z) in enumerate(zip(phis, zetas, strict=True)):
        if k:
            st = mniw.forget(st, lam)
        st = mniw.update(st, p, z)
    batch = mniw.batch_stats(phis, zetas, nu0=7.0, lam=lam)
    for a, b in zip(st, batch, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


def test_posterior_mean_equals_kalman_filter_on_linear_gaussian_model():
    # zeta_k = A phi_k + w, w ~ N(0, Q), prior A ~ MN(0, Q, I): the KF on vec(A) with
    # R = Q and P0 = I (x) Q gives the MNIW posterior mean M and covariance P (x) Q.
    phis, zetas = _data(T=40, m=4, d=2, seed=3)
    Q = np.array([[0.02, 0.005], [0.005, 0.01]])
    d, m = 2, 4
    kf = KalmanFilter(dim_x=d * m, dim_z=d)
    kf.x = np.zeros(d * m)
    kf.P = np.kron(np.eye(m), Q)  # vec(A) column-major: blocks of the columns of A
    kf.F = np.eye(d * m)
    kf.Q = np.zeros((d * m, d * m))
    kf.R = Q
    st = mniw.prior_stats((), m, d, nu0=5.0)
    for p, z in zip(phis, zetas, strict=True):
        kf.predict()
        kf.H = np.kron(p[None, :], np.eye(d))  # A p = (p^T (x) I) vec(A)
        kf.update(z)
        st = mniw.update(st, p, z)
    post = mniw.posterior(st, np.eye(d))
    np.testing.assert_allclose(kf.x.reshape(m, d).T, post.M, atol=1e-10)
    np.testing.assert_allclose(kf.P, np.kron(post.P, Q), atol=1e-10)


def test_predictive_matches_matrix_t_samples():
    phis, zetas = _data(T=30, m=3, d=2, seed=5)
    st = mniw.prior_stats((), 3, 2, nu0=6.0)
    for p, z in zip(phis, zetas, strict=True):
        st = mniw.update(st, p, z)
    post = mniw.posterior(st, 0.05 * np.eye(2))
    rng = np.random.default_rng(0)
    phi = np.array([0.3, -1.0, 0.5])
    A = mniw.sample_matrix_t(rng, post, 40000)
    # A phi + w with w ~ N(0, Q): draw Q again through the matrix-t of A and add noise
    # consistent with it is awkward; compare the noise-free part's covariance instead:
    # Cov(A phi) = phi^T P phi * Lambda / (nu - d - 1).
    ap = A @ phi
    loc, scale, dof = mniw.predictive(post, phi)
    s = phi @ post.P @ phi
    assert np.all(np.abs(ap.mean(0) - loc) < 5 * np.sqrt(np.diag(scale) / 40000 * 3))
    cov_expected = s * post.Lambda / (post.nu - 2 - 1)
    np.testing.assert_allclose(np.cov(ap.T), cov_expected, rtol=0.05)
    # the predictive of zeta = A phi + w has scale (1 + s) Lambda / dof with dof = nu - 1
    assert dof == pytest.approx(post.nu - 1)
    np.testing.assert_allclose(scale, (1 + s) * post.Lambda / dof)


def test_student_t_sampler_moments():
    rng = np.random.default_rng(1)
    loc = np.array([1.0, -2.0])
    scale = np.array([[0.5, 0.1], [0.1, 0.3]])
    x = mniw.sample_student_t(rng, np.broadcast_to(loc, (200000, 2)),
                              np.broadcast_to(scale, (200000, 2, 2)), np.full(200000, 12.0))
    np.testing.assert_allclose(x.mean(0), loc, atol=0.01)
    np.testing.assert_allclose(np.cov(x.T), scale * 12 / 10, rtol=0.03)
