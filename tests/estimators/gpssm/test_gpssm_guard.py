"""The GP-SSM filter's honesty checks (:mod:`roadgrip.estimators.gpssm.guard`)."""

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.estimators.gpssm import GPSSM, GPSSMConfig, Sample, drive_inputs, run_filter
from roadgrip.sim.scenarios import simulate_scenario
from roadgrip.vehicle import PRESETS


@pytest.fixture(scope="module")
def snow20():
    return simulate_scenario("snow-slalom", seed=3, duration=20.0)


def _cfg(drive, basis="separable:8", n=24, **kw):
    return GPSSMConfig(basis=basis, particles=n, **kw)


def _samples(drive):
    return [Sample(*row) for row in drive_inputs(drive)]


def test_a_runaway_state_is_flagged_reset_and_reported_with_the_prior_band(snow20):
    # a filter whose particles all left for |vy| = 30 m/s at 12 m/s: the next step is
    # flagged diverged, reports the prior band with a vy band as wide as the error, and
    # the particles are back at the start's spread; a few seconds later the flag is gone
    d = snow20.slice_time(0.0, 8.0)
    cfg = _cfg(d, "separable-odd:6", n=24)
    f = GPSSM(cfg, d.vehicle, seed=0)
    samples = _samples(d)
    for s in samples[:50]:
        est = f.step(s)
    assert not est.diverged
    f.state_.x[:, 0] = 30.0
    est = f.step(samples[50])
    assert est.diverged and abs(est.vy) > 0.5 * samples[50].vx
    assert est.vy_std >= abs(est.vy) - 1e-9
    for axle in ("front", "rear"):
        assert not getattr(est, f"peak_observed_{axle}")
        assert getattr(est, f"mu_{axle}_lower") == 0.0
        assert getattr(est, f"mu_{axle}_upper") == cfg.peak_max
    assert np.abs(f.state_.x[:, 0]).max() < 5 * cfg.sigma_vy0
    ests = [f.step(s) for s in samples[51:150]]
    assert not ests[-1].diverged and abs(ests[-1].vy - d.col("vy_true")[149]) < 0.3


def test_no_upper_bound_below_the_sustained_lateral_acceleration():
    # a steady turn at 0.6 g for 4 s: whatever the filter learned, no upper bound lies
    # below 0.6 once a full second has passed, and no peak below 0.6 over the learned
    # accelerometer gain
    n = 100
    df = pd.DataFrame({
        "t": np.arange(n) * 0.04, "ay": np.full(n, 0.6 * 9.80665), "yaw_rate": np.full(n, 0.6 * 9.80665 / 15.0),
        "steer": np.full(n, 0.03), "vx": np.full(n, 15.0),
    })
    d = Drive.from_frame(df, PRESETS["sedan"], source="steady turn")
    t, _ = run_filter(d, _cfg(d, "separable-odd:6", n=24), seed=0)
    late = t[t["t"] >= 1.0]
    np.testing.assert_allclose(late["floor"], 0.6, rtol=1e-9)
    for axle in ("front", "rear"):
        assert (late[f"mu_{axle}_upper"] >= 0.6 - 1e-12).all()
        assert (late[f"mu_{axle}"] >= 0.6 / late["ay_gain"] - 1e-12).all()
    assert (t.loc[t["t"] < 0.9, "floor"] == 0.0).all()


def test_collapsed_weights_report_the_yaw_rate_as_well_as_the_gyro_reads_it(snow20):
    """Resampling from an effective sample size near 1 leaves copies of one particle, whose
    spread is 0 (and stays near 0 for some steps, at equal weights): the reported
    yaw_rate_std is then at least the gyro's noise, in the online
    step and in the compiled run (a gyro noise assumed 100 times too small collapses the
    weights again and again)."""
    d = snow20.slice_time(0.0, 8.0)
    cfg = _cfg(d, "separable-odd:6", n=24)
    f = GPSSM(cfg, d.vehicle, seed=0)
    samples = _samples(d)
    for s in samples[:50]:
        f.step(s)
    f.state_.logw[:] = -np.inf
    f.state_.logw[0] = 0.0
    est = f.step(samples[50])
    assert est.ess < 1.5
    assert est.collapsed
    assert est.yaw_rate_std >= cfg.sigma_yaw_rate
    sharp = _cfg(d, "separable-odd:6", n=24, sigma_yaw_rate=1e-4)
    table, _ = run_filter(d, sharp, seed=0)
    collapsed = table["ess"].to_numpy() < 1.5
    assert collapsed.sum() >= 10
    assert (table["yaw_rate_std"].to_numpy()[collapsed] >= sharp.sigma_yaw_rate).all()
    # and the steps after, whose copies share equal weights: no spread below the gyro's
    std = table["yaw_rate_std"].to_numpy()
    assert (std >= 0.01 * sharp.sigma_yaw_rate).all()
    # every collapsed step is flagged, and so are the copies after it (equal weights, a
    # fine effective sample size, no spread)
    flagged = table["collapsed"].to_numpy()
    assert flagged[collapsed].all()
    assert (flagged & ~collapsed).any()
    assert not flagged[table["ess"].to_numpy() > 0.5 * sharp.particles].all()


def test_the_reference_step_flags_the_same_collapsed_steps(snow20):
    # the NumPy reference and the compiled step flag the same steps (same draws)
    d = snow20.slice_time(0.0, 2.0)
    tabs = [run_filter(d, _cfg(d, "separable-odd:6", n=24, sigma_yaw_rate=1e-4, linalg=mode), seed=0)[0]
            for mode in ("exact", "direct")]
    assert tabs[0]["collapsed"].sum() >= 5
    np.testing.assert_array_equal(tabs[0]["collapsed"].to_numpy(), tabs[1]["collapsed"].to_numpy())
    np.testing.assert_allclose(tabs[0]["ess"], tabs[1]["ess"], rtol=1e-6)
