"""Least squares on sensor data (``roadgrip.inference.least_squares``) against analytic results."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.inference.least_squares import (
    HOLD_SAMPLES,
    eiv_lstsq,
    filter_noise_energy,
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
