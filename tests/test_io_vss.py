"""VSS JSON-lines output: absent where the estimator does not know, within its band where it does."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from roadgrip.constants import Z95
from roadgrip.io.vss import VSS_PREFIX, vss_records, write_vss

MP, LB, UB = (VSS_PREFIX + k for k in ("MostProbable", "LowerBound", "UpperBound"))


def _run(method, drive, options=None):
    from roadgrip import estimators

    est = estimators.get(method)
    config = est.Config.from_options(options or {})
    return est.run(drive, config, 0), est.prior_band(config)


@pytest.fixture(scope="module")
def unexcited():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("straight-cruise", seed=0, duration=30.0)


@pytest.mark.parametrize(("method", "options"), [("cascade", {}), ("gpssm", {"particles": 50}), ("brls", {})])
def test_unexcited_drive_has_no_most_probable(tmp_path, unexcited, method, options):
    result, prior = _run(method, unexcited, options)
    assert not result.table["excited"].any()
    path = tmp_path / "out.jsonl"
    counts = write_vss(path, result.table, method, prior)
    lines = [json.loads(s) for s in path.read_text().splitlines()]
    assert len(lines) == len(result.table) == counts["lines"]
    assert counts["MostProbable"] == 0 and not any(MP in r for r in lines)
    # nor bounds: the band is the prior's, which the data did not move
    assert counts["LowerBound"] == counts["UpperBound"] == 0
    np.testing.assert_array_equal([r["t"] for r in lines], result.table["t"])


def _check_within_band(table, recs):
    """Every value lies in 0-100 % and in the union of the row's axle bands; LB <= MP <= UB."""
    lo = np.minimum(table["mu_front_lower"], table["mu_rear_lower"]).to_numpy()
    up = np.maximum(table["mu_front_upper"], table["mu_rear_upper"]).to_numpy()
    n_mp = 0
    for i, r in enumerate(recs):
        for key in (MP, LB, UB):
            if key in r:
                assert 0.0 <= r[key] <= 100.0
        if MP in r:
            n_mp += 1
            assert LB in r or UB not in r
            assert 100 * lo[i] - 1e-9 <= r[MP] <= 100 * up[i] + 1e-9, (i, r, lo[i], up[i])
            assert r.get(LB, 0.0) <= r[MP] <= r.get(UB, 100.0)
    return n_mp


def test_saturated_snow_gpssm_within_its_band():
    """Single-track snow slalom (mu 0.3, >= 15 % of the time past 80 % of the front peak)."""
    from roadgrip.estimators.gpssm.estimator import summary
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("snow-slalom", seed=0, duration=80.0)
    result, prior = _run("gpssm", drive, {"particles": 50})
    tab = result.table
    recs = vss_records(tab, "gpssm", prior)
    both = (tab["peak_observed_front"] & tab["peak_observed_rear"]).to_numpy()
    has_mp = np.array([MP in r for r in recs])
    # MostProbable exactly where both peaks are observed (and then within [0, 100] %)
    np.testing.assert_array_equal(has_mp, both)
    assert _check_within_band(tab, recs) == both.sum()
    # the last line is the estimator's own VSS summary in percent: its lower bound (above
    # the prior's 0 once the tires saturate); the rest only where both peaks are observed
    s = summary(tab)
    assert s["LowerBound"] > 0.2
    assert recs[-1][LB] == pytest.approx(100 * s["LowerBound"], rel=1e-12)
    if both[-1]:
        assert recs[-1][MP] == pytest.approx(100 * s["MostProbable"], rel=1e-12)
        assert recs[-1][UB] == pytest.approx(100 * s["UpperBound"], rel=1e-12)
    else:
        assert MP not in recs[-1] and UB not in recs[-1]


@pytest.mark.slow
def test_saturated_snow_cascade_within_its_band():
    """Multi-body snow slalom: the cascade's lines equal its own per-row summary where present."""
    from roadgrip.estimators.cascade.result import summary
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("snow-slalom", seed=0, engine="multibody", vehicle="ford-escort", duration=60.0)
    result, prior = _run("cascade", drive)
    tab = result.table
    recs = vss_records(tab, "cascade", prior)
    assert _check_within_band(tab, recs) > 0
    informed = np.logical_or.accumulate(tab["excited"].to_numpy())
    for i, r in enumerate(recs):
        if not informed[i]:
            assert set(r) == {"t"}
        if MP in r:
            s = summary(tab.iloc[i])
            assert r[MP] == pytest.approx(100 * s["MostProbable"], rel=1e-12)
            assert r[LB] == pytest.approx(100 * s["LowerBound"], rel=1e-12, abs=1e-12)
            assert s["UpperBound"] > 1.0 or r[UB] == pytest.approx(100 * s["UpperBound"], rel=1e-12)
            assert s["UpperBound"] - s["LowerBound"] < prior[1] - prior[0]


def _axle_table(**cols):
    n = len(cols["mu_front"])
    base = {"t": np.arange(n) * 0.1, "excited": np.ones(n, bool),
            "peak_observed_front": np.zeros(n, bool), "peak_observed_rear": np.zeros(n, bool)}
    base.update(cols)
    return pd.DataFrame(base)


def test_rules_on_hand_made_tables():
    # gpssm: a lower bound before the peaks are seen, all three after; prior (0, 2)
    tab = _axle_table(mu_front=[0.2, 0.3], mu_rear=[0.25, 0.32], mu_front_lower=[0.15, 0.28],
                      mu_rear_lower=[0.0, 0.29], mu_front_upper=[2.0, 0.33], mu_rear_upper=[2.0, 0.35],
                      peak_observed_front=[False, True], peak_observed_rear=[True, True])
    r = vss_records(tab, "gpssm", (0.0, 2.0))
    assert r[0] == {"t": 0.0}  # lower 0.0 = the prior's: not moved
    assert r[1] == pytest.approx({"t": 0.1, MP: 30.0, LB: 28.0, UB: 35.0})
    # cascade-style: a band reaching past friction 1.0 is left out, never clamped
    tab = _axle_table(mu_front=[0.9, 0.7], mu_rear=[0.9, 0.7], mu_front_std=[0.1, 0.4],
                      mu_rear_std=[0.1, 0.4], grip_floor=[0.0, 0.0])
    prior = (0.7 - Z95 * 0.4 / np.sqrt(2), 0.7 + Z95 * 0.4 / np.sqrt(2))
    r = vss_records(tab, "cascade", prior)
    sd = 0.1 / np.sqrt(2)
    assert r[0] == pytest.approx({"t": 0.0, MP: 90.0, LB: 100 * (0.9 - Z95 * sd)})
    assert r[1] == {"t": 0.1}  # the prior band again: nothing known
    # unexcited rows before the first excitation write nothing, even with a narrow band
    tab["excited"] = [False, False]
    assert vss_records(tab, "cascade", prior) == [{"t": 0.0}, {"t": 0.1}]
    # classifiers: the class's friction reference, nothing while 'unknown'
    tab = pd.DataFrame({"t": [0.0, 0.1, 0.2], "mu_front": np.nan, "grip_class": ["unknown", "high", "low"],
                        "excited": [False, True, True]})
    # the bounds follow from the class split (0.7), never from the references: 'high'
    # has no upper claim, 'low' no lower claim without a demonstrated floor
    r = vss_records(tab, "brls", (0.6, 1.0))
    assert r[0] == {"t": 0.0}
    assert r[1] == pytest.approx({"t": 0.1, MP: 100.0, LB: 70.0})
    assert r[2] == pytest.approx({"t": 0.2, MP: 60.0, UB: 70.0})
    # calibrated on DART's floors (0.84 / 0.35): 'low' with 0.31 used now; a larger grip
    # used earlier (grip_floor, maybe on another surface) is no floor of this one
    r = vss_records(tab.assign(grip_now=[0.0, 0.0, 0.31], grip_floor=[0.0, 0.5, 0.5]), "brls", (0.35, 0.84))
    assert r[2] == pytest.approx({"t": 0.2, MP: 35.0, LB: 31.0, UB: 70.0})
    # a diverged sample makes no claim in any output
    tab = _axle_table(mu_front=[0.3], mu_rear=[0.3], mu_front_lower=[0.28], mu_rear_lower=[0.28],
                      mu_front_upper=[0.33], mu_rear_upper=[0.33], peak_observed_front=[True],
                      peak_observed_rear=[True], diverged=[True])
    assert vss_records(tab, "gpssm", (0.0, 2.0)) == [{"t": 0.0}]
    # the cascade's road band: its lower end never below the friction the car uses now,
    # its upper end never below the friction it demonstrably used so far
    tab = _axle_table(mu_front=[0.5], mu_rear=[0.5], mu_front_std=[0.2], mu_rear_std=[0.2],
                      grip_floor=[0.6], grip_now=[0.6])
    r = vss_records(tab, "cascade", (0.0, 2.0))[0]
    assert r[LB] == pytest.approx(60.0) and r[MP] >= r[LB]
    # on a snow patch after dry cornering (used 0.9 before, 0.2 now) the lower end is the
    # band's own, not the dry road's
    tab = _axle_table(mu_front=[0.3], mu_rear=[0.3], mu_front_std=[0.05], mu_rear_std=[0.05],
                      grip_floor=[0.9], grip_now=[0.2])
    r = vss_records(tab, "cascade", (0.0, 2.0))[0]
    assert r[LB] == pytest.approx(100 * (0.3 - Z95 * 0.05 / np.sqrt(2))) and r[UB] == pytest.approx(90.0)


@pytest.mark.parametrize(("method", "scenario"), [("cascade", "snow-slalom"), ("slipmap", "dry-gravel-dry")])
def test_the_vss_columns_are_all_the_rules_read(method, scenario):
    """The live loop gives :func:`vss_records` only :data:`VSS_COLUMNS`: on a drive where the
    method claims, the records from those columns equal those from the whole estimate
    table, also with a NaN ``grip_now`` (the floor of a 'low' claim)."""
    from roadgrip.io.vss import VSS_COLUMNS
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario(scenario, seed=0, duration=60.0)
    result, prior = _run(method, drive)
    tab = result.table
    full = vss_records(tab, method, prior)
    assert sum(len(r) > 1 for r in full) > 100
    assert vss_records(tab[[c for c in tab.columns if c in VSS_COLUMNS]], method, prior) == full
    if "grip_now" in tab.columns:
        gap = tab.assign(grip_now=np.where(np.arange(len(tab)) % 3 == 0, np.nan, tab["grip_now"]))
        assert vss_records(gap[[c for c in gap.columns if c in VSS_COLUMNS]], method, prior) == vss_records(
            gap, method, prior)
