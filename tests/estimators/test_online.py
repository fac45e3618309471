"""The online estimator: samples pushed one at a time give the rows of the batch run on the
same samples, each row out once the declared look-ahead has passed, in bounded memory."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from roadgrip.estimators import run_estimator
from roadgrip.estimators.online import CONTEXT_SAMPLES, OnlineEstimator


@pytest.fixture(scope="module")
def patches():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("f1tenth-patches", seed=2, duration=5.0)


def _push_all(online: OnlineEstimator, drive) -> tuple[pd.DataFrame, list[float], int]:
    rows, lags, held = [], [], 0
    for rec in drive.data.to_dict("records"):
        got = online.push(rec)
        rows += got
        lags += [rec["t"] - r["t"] for r in got]
        held = max(held, len(online._rows))
    rows += online.finish()
    return online.table(rows), lags, held


@pytest.mark.parametrize("method, options", [("brls", None), ("slipmap", None), ("cascade", None),
                                             ("gpssm", {"particles": 30})])
def test_pushed_samples_give_the_rows_of_the_run(method, options, patches):
    whole = run_estimator(method, patches, options).table
    online = OnlineEstimator(method, patches.vehicle, options, sample_rate=patches.meta.sample_rate)
    table, lags, held = _push_all(online, patches)
    assert len(table) == len(whole)
    num = whole.select_dtypes(["number", "bool"]).columns
    np.testing.assert_allclose(table[num].to_numpy(float), whole[num].to_numpy(float), rtol=1e-9, atol=1e-12)
    assert (table["grip_class"] == whole["grip_class"]).all()
    # each row comes out once its look-ahead has passed (the first rows wait for 3 samples)
    h = 1.0 / patches.meta.sample_rate
    assert online.lookahead == run_estimator(method, patches, options).meta["lookahead"]
    assert max(lags[5:]) <= online.lookahead + h + 1e-9
    # bounded: twice the look-ahead and a few samples behind the last row out, the
    # look-ahead in front of it; not the drive
    assert held <= round(3 * online.lookahead / h) + CONTEXT_SAMPLES + 4 < patches.n / 2


def test_bad_samples_are_named(patches):
    online = OnlineEstimator("brls", patches.vehicle)
    recs = patches.data.to_dict("records")
    online.push(recs[0])
    with pytest.raises(ValueError, match="does not follow"):
        online.push(recs[0])
    with pytest.raises(ValueError, match="columns"):
        online.push({"t": recs[1]["t"], "ax": 0.0})
    with pytest.raises(ValueError, match="'t'"):
        online.push({"ax": 0.0})


def test_a_warm_up_holds_the_first_rows_then_one_row_per_sample(patches):
    """With a warm-up, nothing comes out before it has passed; then its rows at once and
    one row per sample, all equal to the run's (a causal method: no look-ahead)."""
    bare = patches.with_data(patches.data.drop(columns=["x", "y", "psi"]))
    whole = run_estimator("cascade", bare).table
    online = OnlineEstimator("cascade", bare.vehicle, warmup=1.0)
    counts, rows = [], []
    for rec in bare.data.to_dict("records"):
        got = online.push(rec)
        counts.append(len(got))
        rows += got
    assert online.finish() == []
    first = int(np.searchsorted(bare.t - bare.t[0], 1.0 - 1e-9))  # the sample that ends the warm-up
    assert sum(counts[:first]) == 0 and counts[first] == first + 1 and set(counts[first + 1:]) == {1}
    table = online.table(rows)
    num = whole.select_dtypes(["number", "bool"]).columns
    np.testing.assert_allclose(table[num].to_numpy(float), whole[num].to_numpy(float), rtol=1e-9, atol=1e-12)


def test_the_gpssm_keeps_the_sub_steps_of_the_start_across_a_gap(patches):
    """Half a second of samples missing: the sub-steps per interval stay those of the start
    (1 at 50 Hz), as the run interpolates them, not those of the gap's interval (13 at
    ``max_dt`` 0.04 s), which the GP-SSM's ``prepare`` of the two rows around it would take."""
    bare = patches.with_data(patches.data.drop(columns=["x", "y", "psi"]))
    keep = (bare.t < bare.t[0] + 2.0) | (bare.t >= bare.t[0] + 2.5)
    gapped = bare.with_data(bare.data[keep])
    options = {"particles": 30}
    whole = run_estimator("gpssm", gapped, options).table
    online = OnlineEstimator("gpssm", gapped.vehicle, options)
    rows = [r for rec in gapped.data.to_dict("records") for r in online.push(rec)] + online.finish()
    assert online.info is not None and online.info.derived["substeps"] == 1
    table = online.table(rows)
    num = whole.select_dtypes(["number", "bool"]).columns
    np.testing.assert_allclose(table[num].to_numpy(float), whole[num].to_numpy(float), rtol=1e-9, atol=1e-12)
