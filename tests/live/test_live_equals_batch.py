"""Live equals batch: a drive replayed through the virtual bus and estimated live gives the
rows of the causal batch run; the DBC's quantisation is the only difference, bounded here."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from live_replay import causal_batch, replay_live

from roadgrip.io.can import FrameEncoder
from roadgrip.live.replay import quantised

WARMUP_ROWS = 101  # 1 s at 100 Hz, both ends
LSB_HALF = {"ax": 5e-4, "ay": 5e-4, "yaw_rate": 0.005 * np.pi / 180, "steer": 5e-5, "vx": 0.005 / 3.6,
            "omega_fl": 5e-3, "omega_fr": 5e-3, "omega_rl": 5e-3, "omega_rr": 5e-3}
"""Half the resolution of each signal of the shipped DBC [SI]."""


@pytest.fixture(scope="module")
def drive():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("dry-gravel-dry", seed=0, duration=20.0)


@pytest.fixture(scope="module")
def carried(drive, codec):
    return quantised(drive, FrameEncoder(*codec))


def _float_diff(a: pd.DataFrame, b: pd.DataFrame) -> float:
    cols = [c for c in a.columns if a[c].dtype.kind == "f"]
    x, y = a[cols].to_numpy(float), b[cols].to_numpy(float)
    assert (np.isnan(x) == np.isnan(y)).all()
    same = (x == y) | np.isnan(x)  # equal values, infinities included
    return float(np.abs(x[~same] - y[~same]).max()) if (~same).any() else 0.0


def test_the_dbc_carries_each_signal_within_half_a_bit(drive, carried):
    for c, half in LSB_HALF.items():
        assert np.abs(carried.col(c) - drive.col(c)).max() <= half * (1 + 1e-9) + 1e-12, c


@pytest.mark.parametrize(("method", "options"), [("cascade", None), ("brls", None), ("slipmap", None),
                                                 ("gpssm", {"particles": 50})])
def test_live_gives_the_rows_of_the_causal_batch_run(drive, carried, codec, method, options):
    est, rows, stats = replay_live(drive, method, codec, options=options)
    assert stats.ended == "idle 1 s" and stats.rows == drive.n
    assert stats.frames_report["accepted"] == 5 * drive.n and stats.dropped_rows == 0
    live = pd.concat(est.tables, ignore_index=True)
    batch = causal_batch(carried, method, WARMUP_ROWS, options)
    assert len(live) == len(batch) == drive.n
    assert _float_diff(live, batch) <= 1e-9
    assert (live["grip_class"].to_numpy() == batch["grip_class"].to_numpy()).all()
    # the rows out: 'warming_up' through the first chunk, then the estimator's own rows
    reasons = [r.reason for r in rows]
    assert set(reasons[:WARMUP_ROWS]) == {"warming_up"} and "warming_up" not in reasons[WARMUP_ROWS:]
    out_cls = np.array([r.grip_class for r in rows[WARMUP_ROWS:]])
    assert (out_cls == batch["grip_class"].to_numpy()[WARMUP_ROWS:]).all()


@pytest.mark.parametrize(("method", "mu_bound"), [("cascade", 0.02), ("brls", None)])
def test_the_quantisation_moves_the_estimates_little(drive, carried, method, mu_bound):
    exact = causal_batch(drive, method, WARMUP_ROWS)
    on_bus = causal_batch(carried, method, WARMUP_ROWS)
    same_class = float((exact["grip_class"].to_numpy() == on_bus["grip_class"].to_numpy()).mean())
    assert same_class >= 0.99, same_class
    if mu_bound is not None:
        for c in ("mu_front", "mu_rear"):
            assert np.abs(exact[c] - on_bus[c]).max() <= mu_bound, c
