"""A few rows as NumPy columns: a Drive on them and the VSS rules read them as they read a
DataFrame's (pandas is the reference)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.estimators.array_frame import ArrayFrame
from roadgrip.io.vss import vss_records


def test_a_drive_on_an_array_frame_reads_as_on_the_dataframe():
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("straight-cruise", duration=0.1)
    recs = drive.data.to_dict("records")[:3]
    cols = list(drive.data.columns)
    light = Drive(ArrayFrame.from_records(recs, cols), drive.meta)  # type: ignore[arg-type]
    heavy = Drive(pd.DataFrame(recs, columns=cols), drive.meta)
    assert light.n == heavy.n == 3 and light.has_wheel_speeds == heavy.has_wheel_speeds
    assert light.has("ay", "yaw_rate") and not light.has("no_such_column")
    for c in ("t", "ay", "omega_fl"):
        np.testing.assert_array_equal(light.col(c), heavy.col(c))
        assert type(light.col(c)) is np.ndarray
    with pytest.raises(ValueError, match="no column 'no_such_column'"):
        light.col("no_such_column")


@pytest.mark.parametrize("method", ["cascade", "brls"])
def test_the_vss_rules_give_the_same_records_as_on_a_dataframe(method):
    rng = np.random.default_rng(0)
    n = 6
    rows = {"t": np.arange(n) * 0.01, "excited": rng.random(n) < 0.5}
    if method == "cascade":
        rows |= {c: rng.uniform(0.2, 1.1, n) for c in ("mu_front", "mu_rear", "grip_floor", "grip_now")}
        rows |= {c: rng.uniform(0.01, 0.3, n) for c in ("mu_front_std", "mu_rear_std")}
    else:
        rows |= {"grip_class": rng.choice(["high", "low", "unknown"], n), "grip_now": rng.uniform(0, 0.5, n),
                 "mu_front": np.full(n, np.nan), "mu_rear": np.full(n, np.nan)}
    records = [{c: v[i] for c, v in rows.items()} for i in range(n)]
    light = vss_records(ArrayFrame.from_records(records, list(rows)), method, (0.3, 1.1))  # type: ignore[arg-type]
    assert light == vss_records(pd.DataFrame(rows), method, (0.3, 1.1))
    assert any(len(r) > 1 for r in light)  # some claim: the comparison is not of empty records


def test_columns_of_different_lengths_are_refused():
    with pytest.raises(ValueError, match="different lengths"):
        ArrayFrame({"t": [0.0, 0.1], "ay": [0.0]})


def test_columns_from_records_are_those_of_the_records_given():
    """A column of :meth:`ArrayFrame.from_records` is built when first read, from the records
    as they were given: a caller that goes on to change its list changes nothing."""
    records = [{"t": 0.0, "ay": 0.5}, {"t": 0.01, "ay": 0.6}]
    frame = ArrayFrame.from_records(records, ["t", "ay"])
    records.pop(0)
    records.append({"t": 0.02, "ay": 0.7})
    assert len(frame) == 2 and tuple(frame.columns) == ("t", "ay")
    assert frame["ay"].to_numpy(float).tolist() == [0.5, 0.6]
    with pytest.raises(KeyError):
        frame["psi"]
    assert len(ArrayFrame.from_records([], ["t"])["t"]) == 0
