"""Causality: cutting a drive at time T leaves every row before T minus the estimator's
declared look-ahead unchanged, for every method of the registry.

The short check (make test) runs every method on a short simulated drive and on the first
minute of one recording of each shared data set; the sweep (slow) runs every scenario
on both engines and every recording. A deliberately non-causal estimator shows that the
check can fail, and the cascade's pose velocity shows that its declared look-ahead is
needed.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.estimators import CONTRACT_COLUMNS, get, names, register, run_estimator, unregister
from roadgrip.estimators.protocol import DriveInfo, Estimator, Prepared, run_by_stepping
from roadgrip.evaluate.honesty_matrix import GPSSM_OPTIONS, DriveSpec, corpus, load_drive
from roadgrip.io.presets import preset_options

BUILT_IN = ("gpssm", "brls", "slipmap", "cascade")
FAST_GPSSM = {"particles": 50}
"""GP-SSM options of the short check (the particle count does not change causality)."""


def cut(drive: Drive, t_end: float) -> Drive:
    """The drive's samples before ``t_end`` [s] (metadata unchanged)."""
    k = int(np.searchsorted(drive.t, t_end, side="left"))
    return drive.with_data(drive.data.iloc[:k])


def options(method: str, drive: Drive, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """The options the honesty matrix runs ``method`` with on ``drive``."""
    opts = preset_options(method, drive)
    if method == "gpssm":
        opts = {**GPSSM_OPTIONS, **opts}
    return {**opts, **(extra or {})}


def first_difference(a: pd.DataFrame, b: pd.DataFrame, atol: float = 1e-9) -> tuple[float, str] | None:
    """Time [s] and column of the first row of ``b`` that differs from the same row of ``a``
    (by position: ``b``'s index) in any contract column (floats beyond ``atol`` or 1e-9
    relative, NaN equal to NaN)."""
    rows = b.index.to_numpy()
    assert np.array_equal(a["t"].to_numpy()[rows], b["t"].to_numpy()), "row times differ"
    first: tuple[float, str] | None = None
    for col, kind in CONTRACT_COLUMNS.items():
        x, y = a[col].to_numpy()[rows], b[col].to_numpy()
        if kind == "float":
            x, y = x.astype(float), y.astype(float)
            same = np.isclose(x, y, rtol=1e-9, atol=atol) | (np.isnan(x) & np.isnan(y))
        else:
            same = x.astype(str) == y.astype(str)
        bad = np.flatnonzero(~same)
        if len(bad) and (first is None or b["t"].iloc[bad[0]] < first[0]):
            first = (float(b["t"].iloc[bad[0]]), col)
    return first


def assert_causal(method: str, drive: Drive, t_cut: float, extra: dict[str, Any] | None = None,
                  whole: Any = None) -> Any:
    """Run ``method`` on ``drive`` and on it cut at ``t_cut``; every row before
    ``t_cut - lookahead`` must agree. Returns the whole run (pass it back as ``whole``)."""
    opts = options(method, drive, extra)
    whole = whole if whole is not None else run_estimator(method, drive, opts, seed=0)
    part = run_estimator(method, cut(drive, t_cut), opts, seed=0)
    lookahead = whole.meta["lookahead"]
    assert np.isfinite(lookahead) and lookahead >= 0, f"{method}: look-ahead {lookahead!r}"
    assert part.meta["lookahead"] == lookahead, f"{method}: the look-ahead depends on the samples"
    before = part.table[part.table["t"] < t_cut - lookahead - 1e-9]
    diff = first_difference(whole.table, before)
    assert diff is None, (
        f"{method} on {drive.meta.source}: cut at {t_cut - drive.t[0]:.2f} s changed row "
        f"t={diff[0] - drive.t[0]:.3f} s ({diff[1]}), look-ahead {lookahead} s")
    return whole


def test_every_method_declares_a_lookahead():
    for m in names():
        est = get(m)
        assert est.lookahead(est.Config(), None) >= 0


@pytest.fixture(scope="module")
def slalom():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("f1tenth-patches", seed=0, duration=12.0)


@pytest.mark.parametrize("method", BUILT_IN)
def test_cut_leaves_earlier_rows_unchanged(method, slalom):
    """Two cuts: during the first noise estimates (3 s) and late in the drive (10 s)."""
    extra = FAST_GPSSM if method == "gpssm" else None
    whole = assert_causal(method, slalom, slalom.t[0] + 10.0, extra)
    assert_causal(method, slalom, slalom.t[0] + 3.0, extra, whole=whole)


def test_cascade_lookahead_is_the_half_window_of_its_pose_fit(slalom):
    """The drive has a pose and no pose-velocity columns: the cascade differentiates it with
    centred fits, declares half the longest window (and 10 % for a jittered clock) and
    needs it (rows inside differ)."""
    whole = run_estimator("cascade", slalom)
    assert whole.meta["derived"]["pose_velocity"] == "derived"
    assert whole.meta["lookahead"] == pytest.approx(0.55 * get("cascade").Config().pose_window)
    t_cut = slalom.t[0] + 10.0
    part = run_estimator("cascade", cut(slalom, t_cut))
    inside = part.table[part.table["t"] >= t_cut - whole.meta["lookahead"]]
    assert first_difference(whole.table, inside, atol=0.0) is not None
    # without the pose the cascade is causal: look-ahead 0 and the rows agree to the cut
    bare = slalom.with_data(slalom.data.drop(columns=["x", "y", "psi"]))
    assert run_estimator("cascade", bare).meta["lookahead"] == 0.0
    assert_causal("cascade", bare, t_cut)


def test_stepping_a_cut_drive_gives_the_rows_of_the_whole_run(slalom):
    """The online path: stepping the cut drive's samples one at a time gives the whole
    drive's rows (to the cut, look-ahead 0 without a pose)."""
    bare = slalom.with_data(slalom.data.drop(columns=["x", "y", "psi"]))
    t_cut = bare.t[0] + 3.0
    for method in ("cascade", "brls", "slipmap"):
        est = get(method)
        whole = est.run(bare, est.Config(), 0).table
        stepped = run_by_stepping(est, cut(bare, t_cut), est.Config()).table
        assert first_difference(whole, stepped) is None, method


def _whole_mean_prepare(drive: Drive, config: Any) -> Prepared:
    # a whole-drive constant, as the noise levels were: the mean |a_y| of the drive
    scale = float(np.mean(np.abs(drive.col("ay"))))
    return Prepared(DriveInfo.from_drive(drive, scale=scale), list(zip(drive.t, drive.col("ay"), strict=True)))


def test_a_whole_drive_constant_is_caught(slalom):
    """An estimator whose rows use the mean of the whole drive fails the check."""
    cascade = get("cascade")

    def step(state, sample):
        t, ay = sample
        return state, {"t": float(t), "grip_index": float(min(abs(ay) / (10 * state), 1.0))}

    leaky = Estimator(
        name="leaky", paper="-", summary="test", Config=cascade.Config,
        prepare=_whole_mean_prepare, init=lambda info, config, seed=0: info.derived["scale"],
        step=step, run=lambda drive, config=None, seed=0, progress=None: run_by_stepping(
            get("leaky"), drive, config, seed), prior_band=cascade.prior_band)
    register(leaky)
    try:
        with pytest.raises(AssertionError, match="changed row"):
            assert_causal("leaky", slalom, slalom.t[0] + 6.0)
        causal = dataclasses.replace(leaky, name="leaky", prepare=lambda d, c: Prepared(
            DriveInfo.from_drive(d, scale=1.0), list(zip(d.t, d.col("ay"), strict=True))))
        unregister("leaky")
        register(causal)
        assert_causal("leaky", slalom, slalom.t[0] + 6.0)
    finally:
        unregister("leaky")


def _real_short():
    return [s for s in corpus("short") if s.path is not None]


@pytest.mark.realdata
@pytest.mark.parametrize("spec", _real_short(), ids=lambda s: s.name)
def test_cut_on_recordings(spec):
    """The first minute of one recording of each data set, cut at 40 s (the GP-SSM on 20 s)."""
    drive, _ = load_drive(spec)
    for method in BUILT_IN:
        d = cut(drive, drive.t[0] + 20.0) if method == "gpssm" else drive
        extra = FAST_GPSSM if method == "gpssm" else None
        assert_causal(method, d, d.t[0] + 0.6 * d.duration, extra)


def _sweep():
    from roadgrip.sim.scenarios import MB_VEHICLES, SCENARIOS

    specs = [s for s in corpus("full") if s.path is not None]
    for sc, scenario in SCENARIOS.items():
        for engine in scenario.engines:
            for vehicle in MB_VEHICLES if engine == "multibody" else (None,):
                name = f"{engine}:{vehicle + ':' if vehicle else ''}{sc}"
                specs.append(DriveSpec(name, sc, vehicle, seed=1, duration=60.0))
    return specs


@pytest.mark.slow
@pytest.mark.parametrize("spec", _sweep(), ids=lambda s: s.name)
def test_cut_sweep(spec):
    """Every scenario on every engine (60 s, seed 1) and every recording (whole; the GP-SSM on
    its first minute), cut at 25 % and 70 % of the drive."""
    drive, _ = load_drive(spec)
    for method in BUILT_IN:
        d = cut(drive, drive.t[0] + 60.0) if method == "gpssm" else drive
        whole = None
        for frac in (0.7, 0.25):
            whole = assert_causal(method, d, d.t[0] + frac * d.duration, whole=whole)
