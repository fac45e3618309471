"""Calibration fits of the saturation model (roadgrip.estimators.classify.fit)."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.estimators.classify.fit import (
    ZERO_SLIP_ACCEL,
    ZERO_SLIP_MIN_SAMPLES,
    fit_slip_angle_offsets,
)
from roadgrip.estimators.classify.grip_model import ALPHA_OFFSET_MAX, GripModel, channels
from roadgrip.inference.kinematic import KinematicOutput, estimate_kinematics


def _kin(alpha_f, alpha_r, vx=10.0):
    n = alpha_f.size
    z = np.zeros(n)
    return KinematicOutput(vx=np.full(n, vx), vy=z, beta=z, kappa=np.zeros((n, 4)),
                           alpha_f=alpha_f, alpha_r=alpha_r, wheels_valid=np.ones((n, 4), bool))


def test_offsets_are_the_intercepts_of_the_linear_range():
    """Slip angles proportional to the lateral acceleration plus a constant, turning both
    ways: the fit returns the constants exactly, and ignores what lies beyond the linear
    range (there a saturated tire's slip angle grows faster)."""
    ay = np.linspace(-6.0, 6.0, 1201)
    sat = np.abs(ay) > ZERO_SLIP_ACCEL
    af = 0.004 * ay - 0.02 + np.where(sat, 0.01 * np.sign(ay) * (np.abs(ay) - 1.5) ** 2, 0.0)
    ar = 0.003 * ay + 0.008 + np.where(sat, 0.02 * np.sign(ay) * (np.abs(ay) - 1.5) ** 2, 0.0)
    off_f, off_r, fit = fit_slip_angle_offsets([(None, "high", _kin(af, ar), ay)])
    assert fit["fitted"]
    assert off_f == pytest.approx(-0.02, abs=1e-12) and off_r == pytest.approx(0.008, abs=1e-12)
    assert fit["slope_deg_per_mps2"] == pytest.approx(np.degrees([0.004, 0.003]))


def test_offsets_need_samples_turning_both_ways():
    """Too few near-linear samples, or one lateral acceleration only (intercept not
    separated from slope), or a standstill: no offsets."""
    few = np.linspace(-1.0, 1.0, ZERO_SLIP_MIN_SAMPLES - 1)
    one = np.full(500, 1.0)
    for ay, vx in ((few, 10.0), (one, 10.0), (np.linspace(-1.0, 1.0, 500), 0.1)):
        a = 0.004 * ay + 0.01
        off_f, off_r, fit = fit_slip_angle_offsets([(None, "low", _kin(a, a, vx), ay)])
        assert (off_f, off_r) == (0.0, 0.0) and not fit["fitted"]


def test_offsets_are_bounded_and_validated():
    ay = np.linspace(-1.0, 1.0, 500)
    a = 0.004 * ay + 0.5  # a broken steering signal, not an offset
    off_f, off_r, _ = fit_slip_angle_offsets([(None, "high", _kin(a, -a), ay)])
    assert (off_f, off_r) == (ALPHA_OFFSET_MAX, -ALPHA_OFFSET_MAX)
    with pytest.raises(ValueError, match="alpha_offset_f"):
        GripModel(20.0, 20.0, 1.0, 0.5, alpha_offset_f=0.2)
    with pytest.raises(ValueError, match="alpha_offset_r"):
        GripModel(20.0, 20.0, 1.0, 0.5, alpha_offset_r=float("nan"))


def test_channels_see_the_slip_angles_less_the_offsets():
    rng = np.random.default_rng(0)
    n = 200
    af, ar = rng.normal(0.0, 0.05, n), rng.normal(0.0, 0.04, n)
    ay, steer = rng.normal(0.0, 4.0, n), rng.normal(0.0, 0.05, n)
    ax = np.zeros(n)
    from roadgrip.vehicle import PRESETS

    veh = PRESETS["sedan"]
    shifted = GripModel(15.0, 12.0, 1.0, 0.4, alpha_offset_f=0.01, alpha_offset_r=-0.005)
    plain = GripModel(15.0, 12.0, 1.0, 0.4)
    a, _ = channels(_kin(af, ar), ax, ay, steer, veh, shifted)
    b, _ = channels(_kin(af - 0.01, ar + 0.005), ax, ay, steer, veh, plain)
    np.testing.assert_allclose(a.phi_lat, b.phi_lat, rtol=1e-12)
    np.testing.assert_allclose(a.y_lat, b.y_lat, rtol=1e-12)


@pytest.mark.slow
def test_a_steering_offset_is_found_on_a_multibody_drive():
    """The multi-body van's kinematic slip angles have no zero error of their own (below
    0.05 degrees); a steering signal reading 1 degree high shifts the front slip angle by
    exactly that, and the fit finds it within 0.05 degrees, leaving the rear alone."""
    from roadgrip.inference.kinematic import drive_lateral_acceleration
    from roadgrip.sim.scenarios import simulate_scenario

    drives = [simulate_scenario(name, seed=10, engine="multibody", vehicle="vw-vanagon")
              for name in ("dry-gravel-dry", "snow-slalom")]

    def offsets(shift):
        data = []
        for d in drives:
            df = d.data.copy()
            df["steer"] = df["steer"] + shift
            d2 = d.with_data(df)
            kin = estimate_kinematics(d2)
            data.append((d2, "high", kin, drive_lateral_acceleration(d2, kin, "auto")))
        return fit_slip_angle_offsets(data)

    f0, r0, fit0 = offsets(0.0)
    assert fit0["fitted"] and abs(np.degrees(f0)) < 0.05 and abs(np.degrees(r0)) < 0.05
    f1, r1, _ = offsets(np.radians(1.0))
    assert np.degrees(f1 - f0) == pytest.approx(1.0, abs=0.05)
    assert np.degrees(r1 - r0) == pytest.approx(0.0, abs=0.05)
