"""Slip angles (exact and linearised) and longitudinal slip."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.constants import V_EPS
from roadgrip.vehicle import PRESETS, longitudinal_slip, regularized_speed, slip_angles

SEDAN = PRESETS["sedan"]


def test_textbook_values_at_speed():
    # no regularisation: the arctan definitions exactly
    vx, vy, r, d = 20.0, 0.4, 0.2, 0.05
    af, ar = slip_angles(vx, vy, r, d, SEDAN, v_eps=0.0)
    assert af == pytest.approx(d - np.arctan((vy + SEDAN.lf * r) / vx), abs=1e-15)
    assert ar == pytest.approx(-np.arctan((vy - SEDAN.lr * r) / vx), abs=1e-15)


def test_exact_and_linearised_agree_for_small_angles():
    rng = np.random.default_rng(5)
    n = 1000
    vx = rng.uniform(5.0, 40.0, n)
    vy = rng.uniform(-0.1, 0.1, n) * vx * 0.05
    r = rng.uniform(-0.05, 0.05, n)
    d = rng.uniform(-0.03, 0.03, n)
    ae = np.stack(slip_angles(vx, vy, r, d, SEDAN))
    al = np.stack(slip_angles(vx, vy, r, d, SEDAN, exact=False))
    q = np.abs(ae - d * np.array([[1.0], [0.0]]))  # |arctan argument| (approximately)
    # arctan(q) = q - q³/3 + ...: the difference is third order
    assert np.all(np.abs(ae - al) <= q**3 / 3 * 1.01 + 1e-15)
    assert np.abs(ae - al).max() < 1e-5


def test_linearised_differs_at_large_angles():
    ae = slip_angles(5.0, 2.0, 0.5, 0.0, SEDAN)[0]
    al = slip_angles(5.0, 2.0, 0.5, 0.0, SEDAN, exact=False)[0]
    assert abs(ae - al) > 0.01


@pytest.mark.parametrize("vx", [0.0, 1e-9, 0.5, -0.5])
def test_finite_at_low_speed(vx):
    for exact in (True, False):
        af, ar = slip_angles(vx, 0.3, 0.5, 0.1, SEDAN, exact=exact)
        assert np.isfinite(af) and np.isfinite(ar)
    af, ar = slip_angles(vx, 0.3, 0.5, 0.1, SEDAN)
    assert abs(af) < np.pi / 2 and abs(ar) < np.pi / 2


def test_continuous_down_to_standstill():
    vx = np.linspace(0.0, 2.0, 20001)
    af, ar = slip_angles(vx, 0.05, 0.02, 0.0, SEDAN)
    assert np.abs(np.diff(af)).max() < 1e-3 and np.abs(np.diff(ar)).max() < 1e-3
    # documented value at standstill: -arctan(v_lat / v_eps)
    assert af[0] == pytest.approx(-np.arctan((0.05 + SEDAN.lf * 0.02) / V_EPS))
    assert ar[0] == pytest.approx(-np.arctan((0.05 - SEDAN.lr * 0.02) / V_EPS))
    af, ar = slip_angles(np.linspace(-1.0, 1.0, 101), 0.0, 0.0, 0.0, SEDAN)
    assert not af.any() and not ar.any()


def test_regularisation_documented_accuracy():
    vx = np.array([5.0, 10.0, 30.0])
    assert np.all(np.abs(regularized_speed(vx) / vx - 1.0) < 0.005)
    assert regularized_speed(0.0) == pytest.approx(V_EPS)
    assert regularized_speed(-3.0) == pytest.approx(-np.hypot(3.0, V_EPS))


def test_positive_slip_for_left_turn_steer():
    # steering left with no motion yet: positive front slip -> positive (left) force
    af, ar = slip_angles(20.0, 0.0, 0.0, 0.05, SEDAN)
    assert af > 0 and ar == 0


def test_longitudinal_slip():
    r = 0.3
    # at speed: the definition of paper 002 eq. 2
    assert longitudinal_slip(110.0 / 3, 10.0, r, v_eps=0.0) == pytest.approx((11.0 - 10.0) / 11.0)
    assert longitudinal_slip(90.0 / 3, 10.0, r, v_eps=0.0) == pytest.approx((9.0 - 10.0) / 10.0)
    assert longitudinal_slip(10.0 / r, 10.0, r) == 0.0
    # locked wheel -> -1, spinning from standstill bounded
    assert longitudinal_slip(0.0, 20.0, r) == pytest.approx(-1.0, abs=1e-3)
    s = longitudinal_slip(np.linspace(0, 50, 101), 0.0, r)
    assert np.isfinite(s).all() and np.all(s < 1.0)
    assert longitudinal_slip(0.0, 0.0, r) == 0.0
