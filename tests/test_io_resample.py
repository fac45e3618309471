"""resample: asynchronous streams onto one clock, against analytic signals."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from roadgrip.io import make_clock, resample


def _irregular(rng, t0, t1, mean_rate):
    n = int((t1 - t0) * mean_rate)
    return np.sort(rng.uniform(t0, t1, n))


def test_analytic_signals_interpolated():
    rng = np.random.default_rng(7)
    f = 0.5  # Hz, well below both stream rates
    ta = _irregular(rng, 0.0, 20.0, 40.0)
    tb = _irregular(rng, 0.3, 19.0, 25.0)
    a = pd.DataFrame({"t": ta, "sa": np.sin(2 * np.pi * f * ta)})
    b = pd.DataFrame({"t": tb, "cb": np.cos(2 * np.pi * f * tb)})
    out = resample({"a": a, "b": b}, rate=50.0)
    t = out["t"].to_numpy()
    # clock spans the overlap only: no extrapolation
    assert t[0] == pytest.approx(max(ta[0], tb[0]))
    assert t[-1] <= min(ta[-1], tb[-1])
    assert np.allclose(np.diff(t), 0.02)
    # linear interpolation error <= max_dt² / 8 * max|f''|
    for col, fn, ts in (("sa", np.sin, ta), ("cb", np.cos, tb)):
        bound = np.diff(ts).max() ** 2 / 8 * (2 * np.pi * f) ** 2
        err = np.abs(out[col].to_numpy() - fn(2 * np.pi * f * t)).max()
        assert err <= bound + 1e-12, (col, err, bound)
        assert err > 0  # really interpolated, not copied


def test_exact_at_knots_and_linear_exact():
    rng = np.random.default_rng(1)
    ts = _irregular(rng, 0.0, 5.0, 30.0)
    s = pd.DataFrame({"t": ts, "lin": 3.0 * ts - 1.0})
    out = resample({"s": s}, clock=ts)
    assert np.array_equal(out["lin"].to_numpy(), s["lin"].to_numpy())
    clock = np.linspace(ts[0], ts[-1], 777)
    out = resample({"s": s}, clock=clock)
    assert np.allclose(out["lin"], 3.0 * clock - 1.0, atol=1e-12)


def test_hold_is_zero_order():
    ts = np.array([0.0, 1.0, 2.0, 3.0])
    cmd = pd.DataFrame({"t": ts, "u": [10.0, 20.0, 30.0, 40.0]})
    out = resample({"c": cmd}, clock=np.array([0.0, 0.5, 0.999, 1.0, 2.7, 3.0]), hold=["u"])
    assert out["u"].tolist() == [10.0, 10.0, 10.0, 20.0, 30.0, 40.0]


def test_no_extrapolation_and_gaps():
    ts = np.r_[np.arange(0.0, 1.0, 0.1), np.arange(3.0, 4.0, 0.1)]  # gap of 2.1 s
    s = pd.DataFrame({"t": ts, "v": ts})
    clock = np.arange(-0.5, 4.5, 0.05)
    kept = resample({"s": s}, clock=clock, max_gap=0.25, drop_missing=False)
    v = kept["v"].to_numpy()
    tc = kept["t"].to_numpy()
    assert np.isnan(v[tc < 0]).all() and np.isnan(v[tc > ts[-1] + 1e-12]).all()
    assert np.isnan(v[(tc > 0.95) & (tc < 2.95)]).all()
    inside = ~np.isnan(v)
    assert np.allclose(v[inside], tc[inside])
    dropped = resample({"s": s}, clock=clock, max_gap=0.25)
    assert len(dropped) == inside.sum()
    assert not dropped.isna().any().any()


def test_errors():
    s = pd.DataFrame({"t": [0.0, 1.0], "v": [0.0, 1.0]})
    with pytest.raises(ValueError, match="exactly one of rate and clock"):
        resample({"s": s})
    with pytest.raises(ValueError, match="not strictly increasing"):
        resample({"s": pd.DataFrame({"t": [0.0, 0.0], "v": [1.0, 2.0]})}, rate=10.0)
    with pytest.raises(ValueError, match="appears in more than one stream"):
        resample({"a": s, "b": s}, rate=10.0)
    with pytest.raises(ValueError, match="do not overlap"):
        resample({"a": s, "b": s.assign(t=s.t + 5).rename(columns={"v": "w"})}, rate=10.0)
    with pytest.raises(ValueError, match="rate must be positive"):
        make_clock(0.0, 1.0, 0.0)


def test_make_clock_includes_end():
    c = make_clock(1.0, 2.0, 10.0)
    assert len(c) == 11 and c[-1] == pytest.approx(2.0)
