"""Acceptance of the GP-SSM filter on the paper's study (snow-slalom, 250 s, N = 200).

Posterior-mean curves within 0.03 (MAE) of the true Magic Formula over the slip bins
visited at least 20 times, and the truth inside the 95 % band on at least 80 % of them, at
t = 50 s and at the end of the drive.
"""

import numpy as np
import pytest

from roadgrip.estimators.gpssm import GPSSMConfig, run_filter
from roadgrip.estimators.gpssm.accuracy import curve_accuracy
from roadgrip.sim.scenarios import simulate_scenario

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def drive():
    return simulate_scenario("snow-slalom", seed=0)


@pytest.mark.parametrize("basis", ["tensor:10x10", "separable-odd:20"])
def test_paper_study_curves_within_003_and_covered(drive, basis):
    # the paper's basis with the paper's model (no accelerometer gain: the drive is planar).
    # Its curves depend on the Monte Carlo stream far more than the command's basis does:
    # over drives and filter seeds 0-4 its end MAE is 0.017-0.074 with the gain fixed and
    # 0.015-0.059 / 0.023-0.182 with the gain learned (walk 0.003 / 0.01 per sqrt(s)),
    # against 0.003-0.010 for separable-odd:20 (docs/gpssm.md, Known limits)
    options = {"ay_gain_sigma": 0.0} if basis.startswith("tensor") else {}
    cfg = GPSSMConfig(basis=basis, particles=200, **options)
    t_end = float(drive.t[-1])
    table, curves = run_filter(drive, cfg, seed=0, curve_times=(50.0, t_end),
                               curve_alpha=np.radians(np.linspace(-20, 20, 161)))
    assert np.isfinite(table.drop(columns="grip_index").select_dtypes("number").to_numpy()).all()
    for t in (50.0, t_end):
        acc = curve_accuracy(curves[t], drive, t)
        for axle in ("front", "rear"):
            assert acc[axle]["bins"] >= 8
            assert acc[axle]["mae"] <= 0.03, (t, acc)
            assert acc[axle]["coverage"] >= 0.8, (t, acc)
    # the front curve's peak (about 5 deg) was reached: its estimate sits on the truth 0.3
    last = table.iloc[-1]
    assert last["peak_observed_front"]
    assert last["mu_front_lower"] - 0.01 <= 0.3 <= last["mu_front_upper"] + 0.01


@pytest.mark.parametrize("seed", [1, 2])
def test_peak_band_holds_the_true_peak_on_other_drives(seed):
    # the command's basis on two more drives. The peak band carries the basis truncation
    # error (curve_sigma_floor) as the curve band does: without it the observed front peak,
    # 0.303-0.306 against 0.300, had a band of +-0.003 that held the truth 11 % of the time
    d = simulate_scenario("snow-slalom", seed=seed)
    cfg = GPSSMConfig(basis="separable-odd:20", particles=200)
    table, _ = run_filter(d, cfg, seed=seed)
    late = table[table["t"] >= 40.0]
    for axle in ("front", "rear"):
        true_peak = d.true_tire(axle).peak()[1]
        inside = (late[f"mu_{axle}_lower"] <= true_peak) & (true_peak <= late[f"mu_{axle}_upper"])
        assert inside.mean() >= 0.9, (axle, inside.mean())
    # where the peak was observed (the front, most of the time) the band is the data's,
    # narrow, and still holds the truth
    obs = late[late["peak_observed_front"]]
    assert len(obs) > 0.8 * len(late)
    assert (obs["mu_front_upper"] - obs["mu_front_lower"]).max() < 0.05
    true_front = d.true_tire("front").peak()[1]
    assert ((obs["mu_front_lower"] <= true_front) & (true_front <= obs["mu_front_upper"])).mean() >= 0.9

