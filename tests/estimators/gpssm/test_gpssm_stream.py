"""The GP-SSM filter in chunks (roadgrip.estimators.gpssm.stream): the chunks give the
whole drive's rows and curves for the same seed, bit for bit, wherever the seams fall (also
across interpolated sub-steps); a state handed back resumes where it was; what passes
from chunk to chunk does not grow with the number of chunks; bad chunks are named."""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest

from roadgrip.estimators.gpssm import GPSSMConfig, curves_frame, run, run_filter
from roadgrip.estimators.gpssm.guard import FLOOR_WINDOW
from roadgrip.estimators.gpssm.stream import carried_bytes, pending_curves, run_chunk, run_chunks
from roadgrip.sim.scenarios import simulate_scenario


@pytest.fixture(scope="module")
def snow20():
    """20 s of snow slalom at 25 Hz (501 samples), truth and pose dropped: the filter reads
    the wheels, the gyro and the accelerometer."""
    d = simulate_scenario("snow-slalom", seed=3, duration=20.0)
    keep = [c for c in d.data.columns if not c.endswith("_true") and c not in ("surface", "x", "y", "psi")]
    return d.with_data(d.data[keep])


def _pieces(drive, edges):
    return [drive.with_data(drive.data.iloc[a:b].reset_index(drop=True)) for a, b in itertools.pairwise(edges)]


ALPHA = np.radians(np.linspace(-12.0, 12.0, 13))
"""Slip grid of the curves [rad] (coarse: the curves cost more than the short drive)."""


def _streamed(drive, edges, cfg, seed):
    results = list(run_chunks(_pieces(drive, edges), cfg, seed, curve_alpha=ALPHA))
    curves = {}
    for r in results:
        curves.update(r.curves)
    curves.update(pending_curves(results[-1].state))  # times beyond the end: at the last sample
    return results, pd.concat([r.table for r in results], ignore_index=True), curves


@pytest.mark.parametrize(("basis", "linalg", "extra"), [
    ("separable-odd:6", "exact", {}),
    ("tensor:4x4", "fast", {"proposal": "prior", "axle_loads": "dynamic"}),
])
def test_chunks_equal_the_whole_drive(snow20, basis, linalg, extra):
    # seams: inside a refactorisation period (every 80 steps), a chunk of one sample, one
    # of two, and curve times on both sides of a seam and beyond the end
    # (a learned accelerometer gain, so that its walk crosses the seams too)
    cfg = GPSSMConfig(basis=basis, particles=24, linalg=linalg, curve_times=(8.0, 8.04, 30.0),
                      ay_gain_sigma=0.1, **extra)
    table, whole_curves = run_filter(snow20, cfg, seed=7, curve_alpha=ALPHA)
    edges = [0, 77, 78, 80, 201, 202, 450, snow20.n]
    results, parts, curves = _streamed(snow20, edges, cfg, 7)
    pd.testing.assert_frame_equal(parts, table, check_exact=True)
    # across the seams the particles were resampled, the gain walked, the floor rose
    assert table["resampled"].sum() > 20 and table["ay_gain"].nunique() > 100
    assert parts["floor"].is_monotonic_increasing and parts["floor"].iloc[-1] > 0.2
    # the curves: one dict updated with each chunk's
    assert sorted(curves) == [8.0, 8.04, 30.0]
    # 8.0 s is the last sample of the fourth chunk, 8.04 s the one sample of the fifth
    assert set(results[3].curves) == {8.0} and set(results[4].curves) == {8.04}
    assert set(pending_curves(results[3].state)) == {8.04, 30.0}
    pd.testing.assert_frame_equal(curves_frame(curves, snow20), curves_frame(whole_curves, snow20),
                                  check_exact=True)
    # the running diagnostics: those of run's meta over the whole table
    diag = results[-1].state.tally.diagnostics()
    assert diag["ess_mean"] == pytest.approx(table["ess"].mean(), rel=1e-12)
    assert diag["ess_min"] == table["ess"].min() and diag["resampling_rate"] == table["resampled"].mean()
    assert diag["diverged_samples"] == table["diverged"].sum() and diag["excited_samples"] == table["excited"].sum()
    assert diag["collapsed_samples"] == table["collapsed"].sum()
    assert all(r.info is results[0].info for r in results)


@pytest.mark.parametrize("linalg", ["exact", "direct"])
def test_sub_steps_across_the_seams_equal_the_whole_drive(snow20, linalg):
    """At 12.5 Hz the filter takes two steps per sample interval (``max_dt`` 0.04 s); the
    step between two chunks interpolates from the last sample before the seam. Also
    through the NumPy reference step (``linalg='direct'``)."""
    slow = snow20.with_data(snow20.data.iloc[::2].reset_index(drop=True))
    cfg = GPSSMConfig(basis="separable-odd:6", particles=24, linalg=linalg)
    whole = run(slow, cfg, seed=3)
    results, parts, _ = _streamed(slow, [0, 2, 3, 100, 101, slow.n], cfg, 3)
    assert results[0].info.derived["substeps"] == 2
    pd.testing.assert_frame_equal(parts, whole.table, check_exact=True)


def test_a_state_handed_back_resumes_where_it_was(snow20):
    """The state of a chunk's result is its own: filtering on from it (later, again)
    gives the next chunk's rows."""
    cfg = GPSSMConfig(basis="separable-odd:6", particles=24, linalg="fast")
    pieces = _pieces(snow20, [0, 150, 300, snow20.n])
    results = list(run_chunks(pieces, cfg, seed=1))
    again = run_chunk(results[0].state, pieces[1])
    pd.testing.assert_frame_equal(again.table, results[1].table, check_exact=True)
    pd.testing.assert_frame_equal(run_chunk(again.state, pieces[2]).table, results[2].table, check_exact=True)


def test_the_carried_state_does_not_grow_with_the_chunks(snow20):
    """Sixty chunks of about eight samples: after the first second (the guard's window
    filled) what passes between chunks has the same size after every chunk, and no more
    than the state after two long chunks."""
    cfg = GPSSMConfig(basis="separable-odd:6", particles=24, curve_times=(100.0,))
    edges = np.linspace(0, snow20.n, 61).astype(int)
    sizes, windows = [], []
    for r in run_chunks(_pieces(snow20, edges), cfg, seed=0):
        sizes.append(carried_bytes(r.state))
        windows.append(len(r.state.filter.guard.times))
        assert r.state.filter.k == r.state.tally.rows  # one step per sample so far, none kept
    rate = snow20.n / snow20.duration
    assert max(windows) <= FLOOR_WINDOW * rate + 1
    assert len(set(sizes[5:])) == 1, sizes
    (long,) = list(run_chunks(_pieces(snow20, [0, snow20.n]), cfg, seed=0))[-1:]
    assert sizes[-1] == carried_bytes(long.state)


def test_bad_chunks_are_named(snow20):
    cfg = GPSSMConfig(basis="separable-odd:6", particles=12)
    pieces = _pieces(snow20, [0, 100, 200])
    with pytest.raises(ValueError, match=r"chunks must follow each other in time: a chunk starts at t = 0.0 s"):
        list(run_chunks([pieces[0], pieces[0]], cfg))
    with pytest.raises(ValueError, match="first chunk of a streamed drive needs at least two samples, got 1"):
        list(run_chunks(_pieces(snow20, [0, 1, 100]), cfg))
    overlap = _pieces(snow20, [99, 200])[0]  # starts at the last sample of the chunk before
    with pytest.raises(ValueError, match=r"starts at t = 3.96 s, the one before ended at t = 3.96 s"):
        list(run_chunks([pieces[0], overlap], cfg))
