"""Least squares on sensor data (``roadgrip.inference.least_squares``) against analytic results."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.inference.least_squares import (
    HOLD_SAMPLES,
    eiv_lstsq,
    filter_noise_energy,
    fuse_scalar,
    held_samples,
    lstsq,
)
from roadgrip.io.derived import savgol_quadratic


def _regression(noise_std: float, n: int = 20000, seed: int = 0):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)  # true regressor, unit variance
    y = 2.0 * x + 0.5 + 0.05 * rng.standard_normal(n)
    X = np.column_stack([x + noise_std * rng.standard_normal(n), np.ones(n)])
    return X, y


def test_without_noise_it_is_ordinary_least_squares():
    X, y = _regression(0.3)
    b0, cov0, rss0 = lstsq(X, y)
    b1, cov1, rss1, _ = eiv_lstsq(X, y, np.zeros((2, 2)))
    np.testing.assert_allclose(b1, b0, rtol=1e-10)
    np.testing.assert_allclose(cov1, cov0, rtol=1e-8)
    assert rss1 == pytest.approx(rss0, rel=1e-10)


def test_known_regressor_noise_undoes_the_dilution():
    # plain least squares shrinks the slope by var(x) / (var(x) + s²) = 1 / 1.25 at s = 0.5
    s = 0.5
    X, y = _regression(s)
    b_ols = lstsq(X, y)[0]
    assert b_ols[0] == pytest.approx(2.0 / (1.0 + s**2), rel=0.02)
    noise = np.diag([len(y) * s**2, 0.0])
    b, cov, _, objective = eiv_lstsq(X, y, noise)
    assert b[0] == pytest.approx(2.0, abs=4 * np.sqrt(cov[0, 0]))
    assert abs(b[0] - 2.0) < 0.03
    assert b[1] == pytest.approx(0.5, abs=0.03)
    # the corrected objective: |y - X b|² - b' noise b at its minimum
    res = y - X @ b
    assert objective == pytest.approx(res @ res - b @ noise @ b, rel=1e-9)


def test_filter_noise_energy_of_the_slope_is_analytic():
    # slope weights k / (delta sum k²): energy 1 / (delta² sum k²)
    for m, delta in ((1, 1.0), (8, 0.01), (15, 0.01)):
        sum_k2 = m * (m + 1) * (2 * m + 1) / 3.0
        assert filter_noise_energy(m, 1, delta) == pytest.approx(1.0 / (delta**2 * sum_k2), rel=1e-12)


@pytest.mark.parametrize(("deriv", "shift"), [(0, 0.0), (0, 0.3), (1, 0.0)])
def test_filter_noise_energy_matches_filtered_white_noise(deriv, shift):
    m, dt = 10, 0.01
    e = np.random.default_rng(1).standard_normal(400_000)
    if shift:
        e = (1.0 - shift) * e[:-1] + shift * e[1:]  # linear interpolation between samples
    out = savgol_quadratic(e, 2 * m + 1, deriv=deriv, delta=dt)
    var = float(np.nanvar(out))
    assert var == pytest.approx(filter_noise_energy(m, deriv, dt, shift), rel=0.02)


def test_holds_are_found_on_a_noisy_channel():
    rng = np.random.default_rng(2)
    v = np.round(np.sin(np.arange(3000) * 0.01) + 0.01 * rng.standard_normal(3000), 4)
    v[1000:1020] = v[1000]
    v[2000:2000 + HOLD_SAMPLES - 1] = v[2000]  # too short to tell from chance
    held = held_samples(v)
    assert held[1000:1020].all()
    assert held.sum() == 20


def test_a_channel_quieter_than_its_resolution_is_never_held():
    # a quantised signal without noise sits still for real (a straight road): no holds
    v = np.round(np.concatenate([np.zeros(500), np.linspace(0, 0.05, 500)]), 3)
    assert not held_samples(v).any()
    assert not held_samples(np.zeros(10)).any()
    assert not held_samples([1.0, 2.0]).any()


def test_fuse_scalar_with_a_linear_function_is_the_kalman_update():
    # z = a'b + e: the combined estimate is the Kalman update, exactly and in one step
    rng = np.random.default_rng(4)
    A = rng.standard_normal((3, 3))
    cov = A @ A.T + np.eye(3)
    beta = rng.standard_normal(3)
    a = np.array([0.5, -2.0, 1.0])
    z, var = 3.0, 0.2
    b, c = fuse_scalar(beta, cov, lambda x: float(a @ x), z, var)
    gain = cov @ a / (a @ cov @ a + var)
    np.testing.assert_allclose(b, beta + gain * (z - a @ beta), rtol=1e-6)
    np.testing.assert_allclose(c, cov - np.outer(gain, a @ cov), rtol=1e-6, atol=1e-9)


def test_fuse_scalar_minimises_the_combined_objective():
    # a nonlinear g (a ratio, as 1/C_r of the single-track coefficients): the result is
    # the minimum of the objective, found independently by a general minimiser
    from scipy.optimize import minimize

    beta, cov = np.array([2.0, 1.0]), np.array([[0.04, 0.01], [0.01, 0.09]])
    g = lambda x: x[1] / x[0]  # noqa: E731
    z, var = 0.8, 0.01**2
    b, _ = fuse_scalar(beta, cov, g, z, var)
    c_inv = np.linalg.inv(cov)
    obj = lambda x: (x - beta) @ c_inv @ (x - beta) + (z - g(x)) ** 2 / var  # noqa: E731
    ref = minimize(obj, beta, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-14}).x
    np.testing.assert_allclose(b, ref, rtol=1e-5)
    assert g(b) == pytest.approx(z, abs=3 * 0.01)


def test_fuse_scalar_refuses_a_bad_variance():
    with pytest.raises(ValueError, match="variance"):
        fuse_scalar(np.zeros(2), np.eye(2), lambda x: x[0], 1.0, 0.0)
