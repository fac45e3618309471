"""The honesty rule (roadgrip.evaluate.honesty) on hand-made cases with known answers,
and on simulated drives whose truth is known."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from roadgrip.constants import GRIP_CLASS_SPLIT
from roadgrip.estimators.base import EstimateResult
from roadgrip.evaluate import honesty as H


def test_band_tolerance_is_003_or_8_percent_whichever_is_larger():
    # truth 0.3: 0.03; truth 1.0: 0.08 (camber lifts an axle's peak up to about 7 %)
    tru = np.array([0.3, 0.3, 1.0, 1.0])
    lo = np.array([0.3 + 0.0299, 0.3 + 0.0301, 1.0 + 0.079, 1.0 + 0.081])
    np.testing.assert_array_equal(H.band_wrong(lo, np.full(4, 2.0), tru, tru, np.zeros(4)),
                                  [False, True, False, True])
    up = np.array([0.3 - 0.0299, 0.3 - 0.0301, 1.0 - 0.079, 1.0 - 0.081])
    np.testing.assert_array_equal(H.band_wrong(np.zeros(4), up, tru, tru, np.zeros(4)),
                                  [False, True, False, True])


def test_missing_band_ends_claim_nothing_and_the_floor_judges_only_without_truth():
    nan = np.nan
    # NaN ends claim nothing, whatever the truth
    assert not H.band_wrong([nan], [nan], [0.3], [0.3], [0.0]).any()
    # a road band is wrong only when it excludes both axles' truth
    assert not H.band_wrong([0.95], [1.1], [0.9], [1.0], [0.0])[0]
    assert H.band_wrong([1.1], [1.2], [0.9], [1.0], [0.0])[0]
    # without truth, an upper end below the demonstrated floor is wrong, a lower end never
    np.testing.assert_array_equal(H.band_wrong([0.0, 0.9, 0.0], [0.7, 2.0, 0.9], [nan] * 3, [nan] * 3,
                                               [0.8, 0.8, 0.8]), [True, False, False])
    # with truth the floor is not used (the truth says more)
    assert not H.band_wrong([0.0], [0.7], [0.72], [0.72], [0.9])[0]


def test_classes_against_the_one_split():
    split = GRIP_CLASS_SPLIT
    cls = ["high", "high", "low", "low", "unknown"]
    tru = [split, split - 1e-6, split, split - 1e-6, 0.1]
    np.testing.assert_array_equal(H.class_wrong(cls, tru, np.zeros(5)), [False, True, True, False, False])
    # without truth only 'low' can be shown wrong, by a floor at or above the split
    np.testing.assert_array_equal(H.class_wrong(["low", "low", "high"], [np.nan] * 3, [split, split - 0.01, 0.0]),
                                  [True, False, False])


def test_lateral_velocity_band_margin():
    z = H.Z95
    np.testing.assert_array_equal(
        H.vy_wrong([0.0, 0.0, 0.0, np.nan], [0.1, 0.1, 0.0, 0.1], [z * 0.1 + 0.099, z * 0.1 + 0.101, -0.11, 0.0]),
        [False, True, True, True])


def test_grace_window_after_a_change_ends_1s_after_evidence_and_at_most_10s():
    t = np.arange(0.0, 60.0, 0.5)
    mu = np.where(t < 10.0, 1.0, 0.6)
    util = np.where((t >= 14.0) & (t < 16.0), 0.7, 0.1)  # the gravel shows itself at 14 s
    judged = H.judged_samples(t, mu, util)
    np.testing.assert_array_equal(t[~judged], np.arange(10.0, 15.0, 0.5))  # to 14 + 1 s
    util[:] = 0.1  # never shown: excused for 10 s only
    judged = H.judged_samples(t, mu, util)
    np.testing.assert_array_equal(t[~judged], np.arange(10.0, 20.0, 0.5))
    # a step within the tolerance is no change (noise of a binned truth)
    assert H.judged_samples(t, 1.0 + 0.01 * (t > 5.0), util).all()


class _Drive:
    """A minimal drive: times, columns, ``has`` / ``col`` as the Drive class offers them."""

    def __init__(self, **cols):
        self.data = pd.DataFrame(cols)
        self.t = self.data["t"].to_numpy(float)
        self.n = len(self.t)

        class _M:
            truth = None
            source = "hand-made"
        self.meta = _M()

    def has(self, *names):
        return all(n in self.data.columns for n in names)

    def col(self, name):
        return self.data[name].to_numpy(float)


def test_score_on_a_recording_uses_the_demonstrated_floor():
    # 10 s at 8 m/s^2 (0.82 g): every band ending below 0.80 after the first second is wrong
    t = np.arange(0.0, 10.0, 0.01)
    drive = _Drive(t=t, ay=np.full(t.size, 8.0))
    up = np.where(t < 5.0, 2.0, 0.7)
    tab = pd.DataFrame({"t": t, "mu_front": 0.5, "mu_rear": 0.5, "mu_front_lower": 0.0,
                        "mu_rear_lower": 0.0, "mu_front_upper": up, "mu_rear_upper": 2.0,
                        "excited": True, "peak_observed_front": False, "peak_observed_rear": False})
    s = H.score_result(EstimateResult("gpssm", tab, {}), drive, prior_band=(0.0, 2.0))
    assert s.wrong_axle == pytest.approx(0.5, abs=0.002)
    assert not s.honest
    # a classifier saying 'low' on that car is wrong once the floor passes the split
    cls = pd.DataFrame({"t": t, "grip_class": "low", "excited": True})
    s = H.score_result(EstimateResult("brls", cls, {"summary": {"LowerBound": 0.0, "UpperBound": 0.7}}),
                       drive, prior_band=(0.6, 1.0))
    floor = 8.0 / 9.80665 - H.FLOOR_MARGIN
    assert floor > GRIP_CLASS_SPLIT
    assert s.wrong_class > 0.85 and s.summary_wrong and s.wrong_vss > 0.85


def test_diverged_rows_claim_nothing_in_the_table():
    t = np.arange(0.0, 4.0, 0.01)
    drive = _Drive(t=t, ay=np.zeros(t.size), vy_true=np.zeros(t.size))
    tab = pd.DataFrame({"t": t, "vy": 5.0, "vy_std": 0.1, "diverged": True, "mu_front": 0.3,
                        "mu_rear": 0.3, "mu_front_lower": 0.0, "mu_rear_lower": 0.0,
                        "mu_front_upper": 2.0, "mu_rear_upper": 2.0, "excited": False,
                        "peak_observed_front": False, "peak_observed_rear": False})
    s = H.score_result(EstimateResult("gpssm", tab, {}), drive, prior_band=(0.0, 2.0))
    assert np.isnan(s.wrong_vy) and s.diverged == 1.0
    s = H.score_result(EstimateResult("gpssm", tab.assign(diverged=False), {}), drive, prior_band=(0.0, 2.0))
    assert s.wrong_vy == 1.0


def test_reference_velocity_of_a_recording_is_read_beside_it(tmp_path):
    rec = tmp_path / "car.csv"
    rec.write_text("t,ay\n0,0\n")
    assert H.reference_vy(rec, [0.0]) is None
    pd.DataFrame({"t": [0.0, 1.0], "vy_ref": [0.0, 2.0]}).to_csv(tmp_path / "car_reference.csv", index=False)
    np.testing.assert_allclose(H.reference_vy(rec, [0.5, 1.0, 2.0]), [1.0, 2.0, np.nan])


@pytest.fixture(scope="module")
def dgd():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("dry-gravel-dry", seed=0, duration=130.0)


def test_simulated_drive_is_judged_against_its_truth(dgd):
    k = H.knowledge(dgd, dgd.t)
    # dry asphalt then gravel: the truth is the tires' peak, the class that of the surface
    assert np.nanmax(k.surface) == pytest.approx(1.0) and np.nanmin(k.surface) == pytest.approx(0.6)
    assert np.all(np.isfinite(k.peak_front)) and np.all(np.isnan(k.floor))
    # each grace window starts at a change (dry -> gravel at 60 s, back at 120 s) and
    # ends within 10 s of it
    changes = dgd.t[np.flatnonzero(np.diff(dgd.col("mu_true"))) + 1]
    np.testing.assert_allclose(changes, [60.0, 120.0])
    excused = dgd.t[~k.judged]
    in_window = np.zeros(excused.size, bool)
    for c in changes:
        in_window |= (excused >= c) & (excused < c + H.CHANGE_MAX_S)
        assert np.any(np.isclose(excused, c))
    assert in_window.all()
    np.testing.assert_allclose(k.vy_ref, dgd.col("vy_true"))
