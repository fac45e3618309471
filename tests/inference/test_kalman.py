"""Shared EKF/UKF kernels against independent implementations."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.inference.kalman import (
    GaussianState,
    cholesky_lower,
    ekf_predict,
    ekf_update,
    merwe_weights,
    psd_sqrt,
    sigma_points,
    ukf_predict,
    ukf_update,
    unscented_transform,
)

DT = 0.05


def _fx_rows(X, dt):
    """A nonlinear 3-state model (pendulum-like with a product term), row-wise."""
    th, om, c = X[:, 0], X[:, 1], X[:, 2]
    return np.column_stack([th + dt * om, om - dt * (9.8 * np.sin(th) + c * om), c])


def _hx_rows(X):
    return np.column_stack([np.sin(X[:, 0]), X[:, 1] * X[:, 2] + X[:, 0] ** 2])


@pytest.mark.parametrize(("alpha", "beta", "kappa"), [(1.0, 2.0, 0.0), (0.3, 2.0, 1.0), (1e-3, 2.0, 0.0)])
def test_ukf_matches_filterpy(alpha, beta, kappa):
    kalman = pytest.importorskip("filterpy.kalman")
    rng = np.random.default_rng(3)
    n, m = 3, 2
    Q = np.diag([1e-4, 4e-3, 1e-3])
    R = np.array([[0.02, 0.003], [0.003, 0.05]])
    x0 = np.array([0.4, -0.2, 0.3])
    P0 = np.array([[0.1, 0.01, 0.0], [0.01, 0.2, 0.02], [0.0, 0.02, 0.05]])

    pts = kalman.MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa)
    ref = kalman.UnscentedKalmanFilter(
        dim_x=n, dim_z=m, dt=DT, points=pts,
        fx=lambda x, dt: _fx_rows(x[None, :], dt)[0], hx=lambda x: _hx_rows(x[None, :])[0],
    )
    ref.x, ref.P, ref.Q, ref.R = x0.copy(), P0.copy(), Q, R
    w = merwe_weights(n, alpha, beta, kappa)
    np.testing.assert_allclose(w.wm, pts.Wm, rtol=0, atol=1e-15)
    np.testing.assert_allclose(w.wc, pts.Wc, rtol=0, atol=1e-15)

    state = GaussianState(x0, P0)
    for _ in range(30):
        z = rng.normal([0.3, 0.1], 0.1)
        ref.predict()
        state = ukf_predict(state, _fx_rows, Q, w, DT)
        np.testing.assert_allclose(state.mean, ref.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(state.cov, ref.P, rtol=0, atol=1e-9)
        ref.update(z)
        state, innov = ukf_update(state, z, _hx_rows, R, w)
        np.testing.assert_allclose(state.mean, ref.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(state.cov, ref.P, rtol=0, atol=1e-9)
        np.testing.assert_allclose(innov.residual, ref.y, rtol=0, atol=1e-9)
        np.testing.assert_allclose(innov.cov, ref.S, rtol=0, atol=1e-9)


def test_ekf_on_linear_model_equals_kalman_filter():
    rng = np.random.default_rng(7)
    n, m = 4, 2
    A = np.eye(n) + DT * rng.normal(size=(n, n))
    B = rng.normal(size=(n, 1))
    H = rng.normal(size=(m, n))
    Q = np.diag(rng.uniform(0.01, 0.1, n))
    R = np.diag(rng.uniform(0.05, 0.2, m))
    x = np.zeros(n)
    P = np.eye(n)
    state = GaussianState(x.copy(), P.copy())
    for k in range(60):
        u = np.array([np.sin(0.1 * k)])
        z = rng.normal(size=m)
        # textbook Kalman filter, standard-form covariance update
        x = A @ x + B @ u
        P = A @ P @ A.T + Q
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        x = x + K @ (z - H @ x)
        P = (np.eye(n) - K @ H) @ P

        state = ekf_predict(state, lambda s, u: A @ s + B @ u, lambda s, u: A, Q, u)
        state, _ = ekf_update(state, z, lambda s: H @ s, lambda s: H, R)
        np.testing.assert_allclose(state.mean, x, rtol=0, atol=1e-10)
        np.testing.assert_allclose(state.cov, P, rtol=0, atol=1e-10)


def test_unscented_transform_is_exact_for_linear_maps():
    rng = np.random.default_rng(1)
    n = 5
    Araw = rng.normal(size=(n, n))
    P = Araw @ Araw.T + n * np.eye(n)
    x = rng.normal(size=n)
    M = rng.normal(size=(3, n))
    for alpha, kappa in ((1.0, 0.0), (0.5, 3.0 - n), (1e-2, 0.0)):
        w = merwe_weights(n, alpha, 2.0, kappa)
        L, _, _ = psd_sqrt(P)
        X = sigma_points(x, L, w.gamma)
        mean, cov = unscented_transform(X @ M.T, w.wm, w.wc, np.zeros((3, 3)))
        np.testing.assert_allclose(mean, M @ x, atol=1e-9)
        np.testing.assert_allclose(cov, M @ P @ M.T, rtol=1e-8, atol=1e-8)


def test_cholesky_and_positive_definiteness_repair():
    rng = np.random.default_rng(2)
    Araw = rng.normal(size=(6, 6))
    P = Araw @ Araw.T + 0.1 * np.eye(6)
    L, ok = cholesky_lower(P)
    assert ok
    np.testing.assert_allclose(L, np.linalg.cholesky(P), atol=1e-12)
    _, _, repaired = psd_sqrt(P)
    assert not repaired
    # an indefinite matrix (one negative eigenvalue, as rounding in P - K S K^T can leave)
    w, V = np.linalg.eigh(P)
    w[0] = -1e-3
    bad = (V * w) @ V.T
    assert not cholesky_lower(bad)[1]
    L, fixed, repaired = psd_sqrt(bad)
    assert repaired
    np.testing.assert_allclose(L @ L.T, fixed, atol=1e-10)
    assert np.linalg.eigvalsh(fixed).min() > 0.0
    # the repair only moves the offending eigenvalue
    np.testing.assert_allclose(np.linalg.eigvalsh(fixed)[1:], w[1:], rtol=1e-9)


def test_bad_input_is_rejected():
    w = merwe_weights(2)
    with pytest.raises(ValueError, match="alpha"):
        merwe_weights(2, alpha=0.0)
    with pytest.raises(ValueError, match="NaN"):
        ukf_predict(GaussianState(np.array([np.nan, 0.0]), np.eye(2)), lambda X: X, np.eye(2), w)
    with pytest.raises(ValueError, match="Q must have shape"):
        ukf_predict(GaussianState(np.zeros(2), np.eye(2)), lambda X: X, np.eye(3), w)
