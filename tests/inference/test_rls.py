"""RLS and bRLS kernels (paper 002, eq. 5-7): limits, batch equality and the Fig. 4 study."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roadgrip.inference.rls import (
    batch_least_squares,
    brls_scalar_batch,
    brls_step,
    data_weight,
    rls_init,
    rls_step,
)


def _data(n=400, dim=3, seed=0):
    rng = np.random.default_rng(seed)
    Phi = rng.standard_normal((n, dim))
    theta = np.array([0.7, -1.3, 2.0])[:dim]
    y = Phi @ theta + 0.1 * rng.standard_normal(n)
    return Phi, y, theta


def test_rls_forgetting_one_equals_batch_least_squares():
    Phi, y, _ = _data()
    s0, theta0 = 1e3, np.array([0.5, 0.5, 0.5])
    st = rls_init(theta0, s0)
    for phi, yi in zip(Phi, y, strict=True):
        st, _ = rls_step(st, phi, yi, forgetting=1.0)
    # exact: RLS from (theta0, s0 I) is the regularised least squares
    A = Phi.T @ Phi + np.eye(3) / s0
    exact = np.linalg.solve(A, Phi.T @ y + theta0 / s0)
    np.testing.assert_allclose(st.theta, exact, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(st.S, np.linalg.inv(A), rtol=1e-8, atol=1e-12)
    # and with a vague start it is ordinary batch least squares
    st = rls_init(np.zeros(3), 1e9)
    for phi, yi in zip(Phi, y, strict=True):
        st, _ = rls_step(st, phi, yi, forgetting=1.0)
    np.testing.assert_allclose(st.theta, batch_least_squares(Phi, y), rtol=1e-6)


def test_rls_with_forgetting_is_exponentially_weighted_least_squares():
    Phi, y, _ = _data(n=150)
    mu, s0 = 0.9, 1e8
    st = rls_init(np.zeros(3), s0)
    for phi, yi in zip(Phi, y, strict=True):
        st, _ = rls_step(st, phi, yi, forgetting=mu)
    w = mu ** np.arange(len(y))[::-1]
    exact = np.linalg.solve((Phi * w[:, None]).T @ Phi, (Phi * w[:, None]).T @ y)
    np.testing.assert_allclose(st.theta, exact, rtol=1e-6)


def test_brls_gamma_zero_is_rls_and_small_gamma_tends_to_it():
    Phi, y, _ = _data(n=300, dim=2)
    a = b = c = rls_init(np.zeros(2), 100.0)
    for phi, yi in zip(Phi, y, strict=True):
        a, _ = rls_step(a, phi, yi, forgetting=0.96)
        b, _ = brls_step(b, phi, yi, theta_ref=np.array([5.0, 5.0]), forgetting=0.96, gamma=0.0)
        c, _ = brls_step(c, phi, yi, theta_ref=np.array([5.0, 5.0]), forgetting=0.96, gamma=1e-9)
    np.testing.assert_array_equal(a.theta, b.theta)
    np.testing.assert_allclose(a.theta, c.theta, rtol=1e-8)


def test_scalar_batch_equals_stepping():
    rng = np.random.default_rng(3)
    n = 500
    phi = rng.standard_normal(n) * np.where(np.arange(n) % 100 < 50, 1.0, 0.01)
    y = 0.8 * phi + 0.05 * rng.standard_normal(n)
    ref = np.where(np.arange(n) < 250, 0.2, np.nan)
    th, S, w = brls_scalar_batch(phi, y, ref, 0.1, 100.0, 0.96, 0.3, 1e4)
    st = rls_init([0.1], 100.0)
    for i in range(n):
        r = None if np.isnan(ref[i]) else [ref[i]]
        st, wi = brls_step(st, [phi[i]], y[i], r, 0.96, 0.3, s_max=1e4)
        assert st.theta[0] == pytest.approx(th[i], rel=1e-12, abs=1e-14)
        assert st.S[0, 0] == pytest.approx(S[i], rel=1e-12)
        assert wi == pytest.approx(w[i], rel=1e-12)


def test_data_weight_limits():
    assert data_weight(0.0, 0.5) == 0.0
    assert data_weight(10.0, 0.0) == 1.0
    assert data_weight(0.5 * math.log(2.0), 0.5) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="gamma"):
        data_weight(1.0, -1.0)
    with pytest.raises(ValueError, match="forgetting"):
        rls_step(rls_init([0.0]), [1.0], 1.0, forgetting=1.5)


def _fig4_data(seed=0):
    """Constant parameter 1; excited, long unexcited, excited, unexcited stretches."""
    rng = np.random.default_rng(seed)
    n = 2000
    i = np.arange(n)
    amp = np.where((i < 300) | ((i >= 1000) & (i < 1300)), 1.0, 0.02)
    phi = amp * rng.standard_normal(n)
    y = 1.0 * phi + 0.05 * rng.standard_normal(n)
    unexcited = amp < 0.5
    return phi, y, unexcited


def test_fig4_smooth_turn_off_holds_where_rls_drifts():
    """Paper 002 Fig. 4: mu = 0.96, RLS against bRLS with theta_ref = previous estimate (eq. 7)."""
    phi, y, unexc = _fig4_data()
    nan = np.full(phi.size, np.nan)
    rls, _, _ = brls_scalar_batch(phi, y, nan, 0.0, 100.0, 0.96, 0.0, 1e6)
    settle = np.ones(phi.size, bool)
    settle[:100] = False
    errs = {}
    for gamma in (0.01, 0.1, 1.0):
        th, _, _ = brls_scalar_batch(phi, y, nan, 0.0, 100.0, 0.96, gamma, 1e6)
        errs[gamma] = np.sqrt(np.mean((th[unexc & settle] - 1.0) ** 2))
        # excited stretches: converges like RLS
        assert abs(th[299] - 1.0) < 0.05
        assert abs(th[1299] - 1.0) < 0.05
    err_rls = np.sqrt(np.mean((rls[unexc & settle] - 1.0) ** 2))
    assert err_rls > 0.25  # RLS drifts on noise when the data are not excited
    # larger gamma holds better, and every bRLS holds better than RLS
    assert errs[1.0] < errs[0.1] < errs[0.01] < err_rls
    assert errs[1.0] < 0.06
    # as gamma decreases bRLS tends to RLS
    th_small, _, _ = brls_scalar_batch(phi, y, nan, 0.0, 100.0, 0.96, 1e-7, 1e6)
    np.testing.assert_allclose(th_small, rls, atol=1e-3)


def test_turn_off_preserves_estimate_exactly_at_zero_regressor():
    st = rls_init([0.37], 50.0)
    for _ in range(100):
        st, w = brls_step(st, [0.0], 3.0, None, 0.9, 0.1, s_max=1e4)
    assert st.theta[0] == 0.37
    assert w == 0.0
    assert st.S[0, 0] == pytest.approx(1e4)  # wind-up clipped
