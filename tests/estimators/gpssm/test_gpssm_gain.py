"""The GP-SSM's learned accelerometer gain (``GPSSMConfig.ay_gain_sigma`` > 0, the default,
and ``ay_gain_gate``) against the planar simulator, whose accelerometer reads the true
lateral acceleration (gain 1)."""

import numpy as np
import pytest

from roadgrip.estimators.gpssm import GPSSMConfig, run_filter
from roadgrip.sim.scenarios import simulate_scenario

LEARNED = 0.1
"""Prior std of a learned accelerometer gain [-]."""


@pytest.fixture(scope="module")
def dgd1():
    # straight at 15-21 m/s for 25 s, slaloms on dry, gravel from 60 s, dry again from 120 s
    return simulate_scenario("dry-gravel-dry", seed=1)


@pytest.mark.slow
def test_straight_driving_does_not_pull_the_gain_down(dgd1):
    """Near zero a_y the predictive variance grows with the gain squared: weighing those
    steps by each particle's gain took the gain from 1 to below 0.7 within 20 s of
    straight driving, the friction learned in the next slalom was too high by the inverse,
    and the yaw rate ran away (flagged diverged). With the gate the gain stays near the
    truth, nothing diverges and the yaw rate follows the truth."""
    t0 = dgd1.t <= 20.0
    ungated, _ = run_filter(dgd1.slice_time(0.0, 20.0), GPSSMConfig(ay_gain_sigma=LEARNED, ay_gain_gate=0.0), seed=0)
    assert ungated["ay_gain"].iloc[-1] < 0.7
    table, _ = run_filter(dgd1, GPSSMConfig(ay_gain_sigma=LEARNED), seed=0)
    gain = table["ay_gain"].to_numpy()
    assert np.abs(gain[t0] - 1.0).max() < 0.2  # 0.87-1.0 here; the rest is the walk and resampling
    assert np.abs(gain[-1] - 1.0) < 0.1
    assert not table["diverged"].any()
    err = table["yaw_rate_est"].to_numpy() - dgd1.col("yaw_rate_true")
    assert np.sqrt(np.mean(err**2)) < 0.02
