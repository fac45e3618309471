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


def test_the_gains_prior_can_be_the_vehicles():
    """``ay_gain_prior='vehicle'``: the particles' gains start around ``1 + g
    roll_gradient`` of the drive's vehicle (what ``roadgrip vehicle fit`` writes), 1 by
    default; the prior's width is ``ay_gain_sigma`` either way; a bad value is named."""
    from roadgrip.constants import GRAVITY
    from roadgrip.estimators.gpssm.inputs import Sample
    from roadgrip.estimators.gpssm.state import Context, init_state
    from roadgrip.vehicle import PRESETS

    rolled = PRESETS["sedan"].replace(roll_gradient=0.012)
    sample = Sample(*([0.0] * len(Sample._fields)))._replace(vx=15.0)
    for prior, mean in (("one", 1.0), ("vehicle", 1.0 + GRAVITY * 0.012)):
        cfg = GPSSMConfig(particles=4000, ay_gain_prior=prior)
        ctx = Context(cfg, rolled)
        assert ctx.gain_mean == pytest.approx(mean)
        gains = init_state(ctx, sample, seed=0).x[:, 2]
        assert gains.mean() == pytest.approx(mean, abs=4 * LEARNED / np.sqrt(4000))
        assert gains.std() == pytest.approx(LEARNED, rel=0.05)
    with pytest.raises(ValueError, match="ay_gain_prior"):
        GPSSMConfig(ay_gain_prior="fitted")
