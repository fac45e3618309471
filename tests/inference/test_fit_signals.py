"""Signal preparation of the vehicle fit: the logger's holds filled."""

from __future__ import annotations

import numpy as np

from roadgrip.inference.fit_signals import fill_held


def test_a_held_run_is_interpolated_from_its_first_sample_to_the_next_real_one():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 5.0, 0.01)
    v = np.sin(t) + 1e-3 * rng.standard_normal(t.size)
    held = v.copy()
    held[201:226] = held[200]  # the logger repeats sample 200 for 0.25 s
    out = fill_held(t, held)
    expect = np.interp(t[201:226], [t[200], t[226]], [v[200], v[226]])
    np.testing.assert_allclose(out[201:226], expect, rtol=0, atol=1e-12)
    assert out[200] == v[200] and out[226] == v[226]  # the real samples kept
    np.testing.assert_array_equal(np.delete(out, np.s_[201:226]), np.delete(v, np.s_[201:226]))
    assert np.max(np.abs(out[201:226] - np.sin(t[201:226]))) < 0.01  # close to the signal


def test_a_channel_that_may_sit_still_is_left_alone():
    """Without white noise above its resolution a channel can repeat a value for real
    (a pose at standstill): nothing is taken for a hold."""
    t = np.arange(0.0, 4.0, 0.01)
    v = np.round(np.where(t < 2.0, 0.0, t - 2.0), 2)
    out = fill_held(t, v)
    assert out is v
