"""The pose's windowed derivative: a quadratic Savitzky-Golay fit without scipy.signal,
against scipy's filter and against exact answers."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.io.derived import body_velocity_from_pose, savgol_quadratic


@pytest.mark.parametrize("window", [3, 5, 7, 15, 31, 61])
@pytest.mark.parametrize("deriv", [0, 1])
def test_savgol_quadratic_is_scipys_filter_inside(window, deriv):
    from scipy.signal import savgol_filter

    rng = np.random.default_rng(window)
    v = 50.0 + np.cumsum(rng.normal(size=400)) * 0.05  # a position far from zero, as a pose's
    h = 0.02
    ours = savgol_quadratic(v, window, deriv=deriv, delta=h)
    theirs = savgol_filter(v, window, 2, deriv=deriv, delta=h)
    m = window // 2
    assert np.isnan(ours[:m]).all() and np.isnan(ours[len(v) - m:]).all()
    # both round: scipy's weights are a least-squares solution, so a pose's offset (50 m)
    # does not cancel exactly in its slope (1e-11 m/s here)
    np.testing.assert_allclose(ours[m:-m], theirs[m:-m], rtol=0, atol=1e-13 * np.abs(v).max() / h**deriv)


def test_savgol_quadratic_is_exact_on_a_quadratic():
    t = np.arange(40) * 0.1
    v = 3.0 - 2.0 * t + 0.5 * t**2
    m = 4
    np.testing.assert_allclose(savgol_quadratic(v, 9)[m:-m], v[m:-m], rtol=1e-13)
    np.testing.assert_allclose(savgol_quadratic(v, 9, deriv=1, delta=0.1)[m:-m], (-2.0 + t)[m:-m],
                               rtol=1e-12)
    # a constant has slope zero exactly (the pairs cancel), however large
    assert np.all(savgol_quadratic(np.full(20, 1.0e6 + 0.1), 7, deriv=1, delta=0.01)[3:-3] == 0.0)


def test_savgol_quadratic_edges_and_arguments():
    assert np.isnan(savgol_quadratic(np.ones(4), 5)).all()  # shorter than a window
    with pytest.raises(ValueError, match="odd"):
        savgol_quadratic(np.ones(10), 4)
    with pytest.raises(ValueError, match="deriv"):
        savgol_quadratic(np.ones(10), 5, deriv=2)


def test_windowed_pose_velocity_is_unchanged_from_scipys():
    """The body velocity of a noisy pose with a gap and a bad sample: the NaNs where they
    were, the values those of the scipy filter to rounding (scipy's own error is larger)."""
    from scipy.signal import savgol_filter

    rng = np.random.default_rng(3)
    rate, n, radius, speed, beta = 50.0, 1500, 3.0, 2.0, 0.15
    t = np.arange(n) / rate
    w = speed / radius
    x = radius * np.sin(w * t) + 40.0 + rng.normal(0, 0.01, n)
    y = radius * (1 - np.cos(w * t)) - 25.0 + rng.normal(0, 0.01, n)
    psi = w * t - beta + rng.normal(0, 0.01, n)
    bad = np.zeros(n, bool)
    bad[700] = True
    keep = np.ones(n, bool)
    keep[1000:1010] = False
    t, x, y, psi, bad = t[keep], x[keep], y[keep], psi[keep], bad[keep]
    vx, vy = body_velocity_from_pose(t, x, y, psi, window=0.3, bad=bad)

    # the scipy reference, segment by segment (15 samples: 0.3 s at 50 Hz)
    ref_x, ref_y = np.full(len(t), np.nan), np.full(len(t), np.nan)
    seg = np.cumsum(np.r_[True, np.diff(t) > 1.5 / rate] | bad)
    for s in np.unique(seg):
        idx = np.flatnonzero((seg == s) & ~bad)
        if len(idx) < 15:
            continue
        i0, i1 = idx[0], idx[-1] + 1
        xd = savgol_filter(x[i0:i1], 15, 2, deriv=1, delta=1 / rate)
        yd = savgol_filter(y[i0:i1], 15, 2, deriv=1, delta=1 / rate)
        ps = savgol_filter(np.unwrap(psi)[i0:i1], 15, 2)
        bx, by = np.cos(ps) * xd + np.sin(ps) * yd, -np.sin(ps) * xd + np.cos(ps) * yd
        bx[:7] = bx[-7:] = by[:7] = by[-7:] = np.nan
        ref_x[i0:i1], ref_y[i0:i1] = bx, by
    np.testing.assert_array_equal(np.isnan(vx), np.isnan(ref_x))
    np.testing.assert_allclose(vx, ref_x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(vy, ref_y, rtol=0, atol=1e-10)
