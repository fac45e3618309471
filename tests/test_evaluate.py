"""Metrics of roadgrip.evaluate on hand-made cases with known answers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.evaluate import (
    band_coverage,
    cell_truth,
    classification_accuracy,
    confident_wrong_class_rate,
    confident_wrong_rate,
    count_switches,
    covered_mask,
    curve_error,
    detection_delays,
    map_metrics,
    peak_error,
    sustained,
    true_peak_series,
    truth_excitation,
    truth_grip_class,
)
from roadgrip.tire import SURFACES
from roadgrip.vehicle import PRESETS


# -- friction curves ------------------------------------------------------------------
def test_constant_estimate_against_magic_formula_matches_quadrature():
    """A constant estimate against the snow curve: MAE equals the integral mean of |c - mu|."""
    tire = SURFACES["snow"].lateral
    grid = np.linspace(-0.2, 0.2, 4001)
    visited = np.random.default_rng(1).uniform(0.0, 0.1, 200_000)  # covers [0, 0.1) only
    c = 0.2
    m = curve_error(grid, np.full_like(grid, c), tire.mu, visited, bin_width=0.01, min_visits=20)
    # Independent answer: the covered range is exactly [0, 0.1); average |c - mu| there.
    fine = np.linspace(0.0, 0.1, 200_001)[:-1]
    expected = np.mean(np.abs(c - tire.mu(fine)))
    assert m.slip_range[0] == pytest.approx(0.0, abs=1e-4)
    assert m.slip_range[1] == pytest.approx(0.1, abs=2e-4)
    assert m.mae == pytest.approx(expected, abs=2e-4)
    assert m.max_error == pytest.approx(max(c, tire.peak()[1] - c), abs=1e-4)


def test_curve_error_at_bin_centres_interpolates_the_curves():
    """Linear curves are interpolated exactly: the error at the covered centres is known."""
    grid = np.linspace(-0.1, 0.1, 41)
    visited = np.r_[np.full(25, 0.012), np.full(25, 0.031), np.full(5, 0.05)]
    m = curve_error(grid, 2 * grid, lambda a: 2 * a + 0.01 * (a > 0.02), visited,
                    mu_lower=2 * grid - 0.005, mu_upper=2 * grid + 0.005, bin_width=0.01,
                    min_visits=20, at_bin_centres=True)
    assert m.n_points == 2 and m.slip_range == pytest.approx((0.015, 0.035))
    assert m.mae == pytest.approx(0.005)  # 0 at 0.015, 0.01 at 0.035
    assert m.coverage == pytest.approx(0.5)


def test_curve_error_ignores_rarely_visited_bins():
    grid = np.array([0.0025, 0.0075, 0.0125])
    visited = np.r_[np.full(20, 0.001), np.full(19, 0.006), np.full(100, 0.011)]
    assert covered_mask(grid, visited, bin_width=0.005, min_visits=20).tolist() == [True, False, True]
    m = curve_error(grid, [0.1, 5.0, 0.3], [0.0, 0.0, 0.0], visited, bin_width=0.005)
    assert m.n_points == 2
    assert m.mae == pytest.approx(0.2)  # the wrong middle point is not judged


def test_curve_error_band_coverage_of_known_band():
    grid = np.linspace(0, 1, 101)
    truth = grid.copy()
    lower = truth - 0.05
    upper = truth + 0.05
    upper[:30] = truth[:30] - 0.01  # band misses the truth on the first 30 points
    lower[:30] = truth[:30] - 0.1
    m = curve_error(grid, truth, truth, grid.repeat(30), mu_lower=lower, mu_upper=upper,
                    bin_width=0.01, min_visits=20)
    assert m.mae == 0.0
    assert m.coverage == pytest.approx(71 / 101)


def test_curve_error_nothing_covered_is_nan_not_zero():
    m = curve_error([0.1, 0.2], [0.3, 0.3], [0.3, 0.3], [0.5] * 100)
    assert m.n_points == 0 and np.isnan(m.mae)


def test_band_coverage_and_malformed_band():
    assert band_coverage([1, 2, 3, 4], [0, 0, 0, 0], [1, 1, 3.5, 3.9]) == pytest.approx(0.5)
    assert band_coverage([1, np.nan], [0, 0], [2, 2]) == 1.0
    with pytest.raises(ValueError, match="lower > upper"):
        band_coverage([1.0], [2.0], [1.5])


def test_peak_error_sign_and_finite_check():
    assert peak_error(0.25, 0.3) == pytest.approx(-0.05)
    with pytest.raises(ValueError, match="finite"):
        peak_error(np.nan, 0.3)


# -- classification --------------------------------------------------------------------
def _trace(delay_s=0.7, dt=0.01):
    """Truth high for 10 s, low 10 s, high 10 s; estimate follows each change after delay_s."""
    t = np.arange(0, 30, dt)
    truth = np.where((t >= 10) & (t < 20), "low", "high")
    pred = np.where((t >= 10 + delay_s) & (t < 20 + delay_s), "low", "high")
    return t, truth, pred


def test_detection_delay_of_a_shifted_trace():
    t, truth, pred = _trace(0.7)
    excited = ((t >= 10.2) & (t < 11)) | ((t >= 20.5) & (t < 21))
    ev = detection_delays(t, pred, truth, excited)
    assert [e.new_class for e in ev] == ["low", "high"]
    assert [e.t_change for e in ev] == pytest.approx([10.0, 20.0])
    assert [e.delay_from_change for e in ev] == pytest.approx([0.7, 0.7], abs=1e-9)
    assert [e.delay_from_excitation for e in ev] == pytest.approx([0.5, 0.2], abs=1e-9)
    acc = classification_accuracy(pred, truth)
    assert acc.accuracy == pytest.approx(1 - 2 * 70 / len(t))


def test_detection_requires_hold_and_reports_misses():
    t = np.arange(0, 10, 0.1)
    truth = np.where(t >= 2, "low", "high")
    pred = np.full(len(t), "high", dtype=object)
    pred[(t >= 3) & (t < 3.25)] = "low"  # a flicker of 0.2 s (3.0, 3.1, 3.2)
    pred[t >= 6] = "low"
    ev = detection_delays(t, pred, truth, np.ones(len(t), bool), hold=1.0)[0]
    assert ev.t_detected == pytest.approx(6.0)
    assert ev.delay_from_change == pytest.approx(4.0)
    never = detection_delays(t, np.full(len(t), "high"), truth, np.zeros(len(t), bool))[0]
    assert not never.detected and np.isnan(never.t_excited)


def test_unknown_counts_as_wrong_but_not_as_confident_wrong():
    pred = ["unknown"] * 5 + ["low"] * 2 + ["high"] * 3
    truth = ["high"] * 10
    acc = classification_accuracy(pred, truth)
    assert acc.accuracy == pytest.approx(0.3)
    assert acc.unknown_fraction == pytest.approx(0.5)
    assert confident_wrong_class_rate(pred, truth) == pytest.approx(0.2)
    assert count_switches(pred) == 1


def test_classification_mask():
    acc = classification_accuracy(["high", "low", "low"], ["high", "high", "low"], [True, False, True])
    assert acc.accuracy == 1.0 and acc.n_samples == 2


def test_sustained_excitation():
    t = np.arange(0, 1, 0.1)
    flag = [0, 1, 1, 1, 1, 0, 1, 1, 0, 0]
    assert sustained(flag, t, 0.2).tolist() == [0, 0, 0, 1, 1, 0, 0, 0, 0, 0]


def test_truth_excitation_from_accelerations():
    t = np.arange(0, 2, 0.01)
    ay = np.where((t >= 0.5) & (t < 1.5), 3.0, 0.5)
    d = Drive.from_frame(pd.DataFrame({"t": t, "ax": 0 * t, "ay": ay}), PRESETS["sedan"])
    exc = truth_excitation(d, min_accel=2.0, min_duration=0.3)
    on = t[exc]
    assert on.min() == pytest.approx(0.8) and on.max() == pytest.approx(1.49)


def test_truth_class_threshold():
    assert truth_grip_class([1.0, 0.75, 0.6, 0.3]).tolist() == ["high", "high", "low", "low"]


def test_true_peak_series_uses_surface_labels():
    t = np.arange(4) * 0.1
    df = pd.DataFrame({"t": t, "surface": ["dry_asphalt", "dry_asphalt", "gravel", "gravel"]})
    truth = {"surfaces": {n: {"front": SURFACES[n].lateral.to_dict(), "rear": SURFACES[n].lateral.to_dict(),
                              "mu": SURFACES[n].mu_peak} for n in ("dry_asphalt", "gravel")}}
    d = Drive.from_frame(df, PRESETS["sedan"], truth=truth)
    peaks = true_peak_series(d, "front")
    assert peaks == pytest.approx([SURFACES["dry_asphalt"].lateral.peak()[1]] * 2
                                  + [SURFACES["gravel"].lateral.peak()[1]] * 2)


# -- confident wrong claims -------------------------------------------------------------
def test_confident_wrong_rate_counts_only_narrow_wrong_estimates():
    n = 100
    truth = np.full(n, 0.3)
    est = np.full(n, 0.3)
    lo, hi = est - 0.05, est + 0.05
    est[:10] = 0.6  # confident and wrong
    lo[:10], hi[:10] = 0.55, 0.65
    est[10:30] = 0.6  # wrong but honest: wide band
    lo[10:30], hi[10:30] = 0.1, 0.9
    assert confident_wrong_rate(est, lo, hi, truth, tol=0.1) == pytest.approx(0.10)
    observed = np.ones(n, bool)
    observed[:5] = False  # a lower bound, not a claim of the peak
    assert confident_wrong_rate(est, lo, hi, truth, tol=0.1, observed=observed) == pytest.approx(0.05)


# -- maps --------------------------------------------------------------------------------
def test_map_metrics_known_cells_and_calibration():
    rng = np.random.default_rng(3)
    n = 4000
    truth = rng.uniform(0.3, 1.0, n)
    std = np.full(n, 0.05)
    mean = truth + rng.normal(0.0, 0.05, n)  # errors drawn from the stated std: calibrated
    nobs = np.full(n, 50)
    m = map_metrics(mean, std, nobs, truth)
    assert m.n_cells == n
    assert m.mae == pytest.approx(0.05 * np.sqrt(2 / np.pi), rel=0.05)
    for nominal, empirical in m.calibration:
        assert empirical == pytest.approx(nominal, abs=0.03)
    over = map_metrics(mean, std / 3, nobs, truth)  # overconfident map
    assert over.coverage95 < 0.6


def test_map_metrics_excludes_thin_cells_and_checks_unobserved_width():
    m = map_metrics([0.5, 0.9, np.nan, 0.5], [0.01, 0.01, np.nan, 0.05], [10, 9, 0, 0],
                    [0.55, 0.1, 0.7, 0.7])
    assert m.n_cells == 1 and m.mae == pytest.approx(0.05)
    assert m.coverage95 == 0.0  # 0.05 off with std 0.01
    assert m.unobserved_wide == pytest.approx(0.5)  # NaN std counts as wide, 0.05 does not


def test_cell_truth_bins_samples():
    x = np.array([0.1, 0.4, 1.2, 1.3, -0.2])
    y = np.array([0.1, 0.2, 0.3, 0.1, 0.1])
    mu = np.array([0.4, 0.6, 0.9, 0.7, 0.2])
    out = cell_truth([0.25, 1.25, -0.25, 3.0], [0.25, 0.25, 0.25, 3.0], 0.5, x, y, mu)
    assert out[:3] == pytest.approx([0.5, 0.8, 0.2])
    assert np.isnan(out[3])


# -- the benchmark suite, with stand-in estimators ----------------------------------------
def _hand_drive(n=800, dt=0.05):
    """Dry for the first half, snow after; truth per surface; cornering throughout."""
    t = np.arange(n) * dt
    surface = np.where(t < t[n // 2], "dry_asphalt", "snow")
    truth = {"surfaces": {s: {"front": SURFACES[s].lateral.to_dict(), "rear": SURFACES[s].lateral.to_dict(),
                              "mu": SURFACES[s].mu_peak} for s in ("dry_asphalt", "snow")}}
    df = pd.DataFrame({"t": t, "ax": 0.0 * t, "ay": 3.0 * np.sin(0.7 * t), "vx": np.full(n, 15.0),
                       "mu_true": np.where(surface == "snow", 0.3, 1.0), "surface": surface})
    return Drive.from_frame(df, PRESETS["sedan"], source="hand-made", truth=truth)


def _stand_in(method, drive, options=None, *, seed=0, progress=None):
    """A seeded stand-in estimator: truth plus noise, or a class trace 1 s late."""
    from roadgrip.estimators.base import EstimateResult, conform

    if method == "broken":
        raise RuntimeError("diverged")
    if method == "cascade":
        raise ValueError("unknown method 'cascade'")
    options = options or {}
    rng = np.random.default_rng(seed)
    t = drive.t
    if method == "brls":
        cls = np.where((t >= t[drive.n // 2] + 1.0), "low", "high")
        return EstimateResult(method, conform(pd.DataFrame({"t": t, "grip_class": cls})), {})
    mu = true_peak_series(drive) + rng.normal(0.0, 0.02, drive.n)
    tab = pd.DataFrame({"t": t, "mu_front": mu, "mu_rear": mu, "mu_front_lower": mu - 0.1,
                        "mu_front_upper": mu + 0.1, "mu_rear_lower": mu - 0.1, "mu_rear_upper": mu + 0.1,
                        "peak_observed_front": True,
                        "peak_observed_rear": not options.get("lower_bound", False)})
    if options.get("offset"):
        for c in ("mu_front", "mu_front_lower", "mu_front_upper"):
            tab[c] = tab[c] + options["offset"]
    # the prior band of the VSS lines, which the honesty rule reads for a method it does not know
    return EstimateResult(method, conform(tab), {"prior_band": (0.0, 2.0)})


@pytest.fixture
def stand_ins(monkeypatch):
    import roadgrip.estimators as est
    from roadgrip.evaluate import suite

    monkeypatch.setattr(est, "run_estimator", _stand_in)
    return suite


def test_suite_runs_scores_and_isolates_failures(stand_ins):
    suite = stand_ins
    cases = [suite.Case("hand", "gpssm", "gpssm"), suite.Case("hand", "brls", "brls"),
             suite.Case("hand", "cascade", "cascade"), suite.Case("hand", "broken", "broken")]
    recs = suite.run_suite(cases, suite.QUICK, seed=3, drives={"hand": _hand_drive()})
    status = [r.status for r in recs]
    assert status[:2] == ["ok", "ok"]
    assert status[2] == "error: ValueError: unknown method 'cascade'"
    assert status[3].startswith("error: RuntimeError: diverged")
    g, b = recs[0].metrics, recs[1].metrics
    assert abs(g["peak_err_f"]) < 0.1 and g["mu_band_cov"] > 0.99
    assert b["class_acc"] == pytest.approx(1 - 20 / 800)  # 1 s late at 20 Hz
    assert b["delay_change_s"] == pytest.approx(1.0) and b["delay_exc_s"] == pytest.approx(1.0)
    assert b["switches"] == 1


def test_unobserved_peak_is_judged_as_a_lower_bound(stand_ins):
    suite = stand_ins
    rec = suite.run_suite([suite.Case("hand", "gpssm", "gpssm", options=(("lower_bound", True),))],
                          suite.QUICK, drives={"hand": _hand_drive()})[0]
    assert "peak_err_f" in rec.metrics and "peak_err_r" not in rec.metrics
    assert any("rear: peak not observed" in d and "bound holds" in d for d in rec.details)


def test_narrow_wrong_estimates_count_as_confident_wrong_claims(stand_ins):
    suite = stand_ins
    drive = _hand_drive()
    # gpssm: a narrow band 0.3 too high on the front axle, peak observed: a wrong claim
    gp = suite.run_suite([suite.Case("hand", "gpssm", "gpssm", options=(("offset", 0.3),))],
                         suite.QUICK, drives={"hand": drive})[0]
    assert gp.metrics["conf_wrong"] == pytest.approx(1.0)
    assert gp.metrics["peak_err_f"] == pytest.approx(0.3, abs=0.1)
    # a method without peak flags (as the cascade): its mu is a claim of the peak, judged as one
    ok = suite.run_suite([suite.Case("hand", "brls-free", "mu-method")], suite.QUICK,
                         drives={"hand": drive})[0]
    assert ok.status == "ok" and gp.status == "ok"
    assert ok.metrics["conf_wrong"] < 0.01 and "peak_err_f" in ok.metrics
    assert ok.metrics["wrong_claims"] == 0.0 and gp.metrics["wrong_claims"] > 0.5


def test_bench_is_reproducible_by_seed_and_writes_markdown_and_csv(stand_ins, tmp_path):
    suite = stand_ins
    cases = [suite.Case("hand", "gpssm", "gpssm"), suite.Case("hand", "brls", "brls")]
    drives = {"hand": _hand_drive()}
    acc = ["peak_err_f", "peak_err_r", "mu_band_cov", "class_acc", "delay_exc_s", "conf_wrong", "wrong_claims"]
    a = suite.bench(tmp_path / "a", suite.QUICK, seed=1, cases=cases, drives=drives)[0][acc]
    b = suite.bench(tmp_path / "b", suite.QUICK, seed=1, cases=cases, drives=drives)[0][acc]
    c = suite.bench(tmp_path / "c", suite.QUICK, seed=2, cases=cases, drives=drives)[0][acc]
    pd.testing.assert_frame_equal(a, b)
    assert a["peak_err_f"].iloc[0] != c["peak_err_f"].iloc[0]
    csv = pd.read_csv(tmp_path / "a" / "bench.csv")
    assert list(csv["method"]) == ["gpssm", "brls"]
    md = (tmp_path / "a" / "bench.md").read_text()
    assert "| drive | method |" in md and "samples/s" in md and "real-time" in md
    assert "change to low" in md


def test_real_data_cases_follow_the_data_folder(monkeypatch, tmp_path):
    from roadgrip.evaluate import suite

    monkeypatch.setenv("ROADGRIP_SHARED_DATA", str(tmp_path))
    assert all(c.path is None for c in suite.default_cases(suite.FULL))
    (tmp_path / "dart" / "low_grip_tape_and_tiles").mkdir(parents=True)
    (tmp_path / "dart" / "low_grip_tape_and_tiles" / "car_1_Datarecording_09_09_2024_17_58_23.csv").touch()
    (tmp_path / "frictionmaps" / "DS3").mkdir(parents=True)
    real = [c for c in suite.default_cases(suite.QUICK) if c.path is not None]
    assert {(c.drive, c.method) for c in real} == {
        ("dart:low:0909-1758", "gpssm"), ("dart:low:0909-1758", "brls"), ("dart:low:0909-1758", "slipmap"),
        ("frictionmaps:DS3", "cascade")}
    assert all(c.reference == "low" for c in real if c.format == "dart")
    monkeypatch.setenv("ROADGRIP_SHARED_DATA", str(tmp_path / "absent"))
    assert suite.real_data_root() is None


DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


@pytest.mark.realdata
def test_dart_classifier_runs_on_the_second_half_with_a_first_half_calibration(monkeypatch):
    if not (DATA / "dart").is_dir():
        pytest.skip(f"DART data not found at {DATA} (../shared/data beside the checkout)")
    from roadgrip.evaluate import suite

    monkeypatch.setenv("ROADGRIP_SHARED_DATA", str(DATA))
    case = next(c for c in suite.default_cases(suite.QUICK) if c.format == "dart" and c.method == "brls")
    rec = suite.run_suite([case], suite.QUICK)[0]
    assert rec.status == "ok"
    from roadgrip.io import read_drive

    full = read_drive(case.path, format="dart")
    tab = rec.result.table
    assert len(tab) == pytest.approx(full.n / 2, abs=2)
    assert tab["t"].iloc[0] >= full.t[0] + 0.5 * full.duration - 1e-9
    assert 0.0 <= rec.metrics["class_acc_exc"] <= 1.0
    assert any("calibrated on the first halves" in d for d in rec.details)


@pytest.mark.slow
def test_real_estimators_are_reproducible_by_seed():
    from dataclasses import replace

    from roadgrip.evaluate import suite
    from roadgrip.evaluate.table import bench_table

    settings = replace(suite.QUICK, particles=20, real_data=False,
                       durations={"snow-slalom": 20.0, "f1tenth-patches": 20.0},
                       scenarios=("snow-slalom", "f1tenth-patches"), gpssm_variants=("gpssm-sep-odd",))
    cases = suite.default_cases(settings)
    speed = ["samples_per_s", "rtf"]
    a = bench_table(suite.run_suite(cases, settings, seed=4)).drop(columns=speed)
    b = bench_table(suite.run_suite(cases, settings, seed=4)).drop(columns=speed)
    assert (a["status"] == "ok").all(), a["status"].tolist()
    pd.testing.assert_frame_equal(a, b)


def test_cell_truth_is_the_field_at_the_observations_the_grid_fused():
    # against an independent computation: the true field fused into a grid with the
    # observations' own precisions (the value each cell's estimate converges to)
    from roadgrip.estimators import run_estimator
    from roadgrip.evaluate.maps import cells_from_result, true_cell_friction
    from roadgrip.mapping import empty_grid, fuse, observations_from_estimates
    from roadgrip.sim.friction import mu_at
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("f1tenth-patches", 0, duration=30.0)
    res = run_estimator("cascade", drive)
    cells, cell, _ = cells_from_result(res, drive)
    truth = true_cell_friction(drive, cells, cell, table=res.table)
    area = true_cell_friction(drive, cells, cell)
    field = drive.meta.truth["friction_field"]
    obs = observations_from_estimates(res.table, cell)
    tg = fuse(empty_grid(cell), obs.x, obs.y, mu_at(field, obs.t, obs.x, obs.y), obs.var)
    X, Y = tg.centres()
    seen = tg.n_obs > 0
    expect = {(round(a, 6), round(b, 6)): s1 / s0
              for a, b, s1, s0 in zip(X[seen], Y[seen], tg.s1[seen], tg.s0[seen], strict=True)}
    observed = cells["n_obs"].to_numpy() > 0
    assert observed.sum() >= 10
    for (xc, yc), got in zip(cells[["x", "y"]].to_numpy()[observed], truth[observed], strict=True):
        assert got == pytest.approx(expect[(round(xc, 6), round(yc, 6))], abs=1e-12)
    # cells without observations keep the area average
    np.testing.assert_allclose(truth[~observed], area[~observed])


def test_exact_observations_at_every_sample_map_the_path_truth():
    """The ceiling map (every observation exact) equals the cell truth of the scoring when every
    sample is an observation of equal precision: the scoring and the ceiling measure the same
    thing, and the ceiling falls short only where observations are missing."""
    from roadgrip.estimators import run_estimator
    from roadgrip.evaluate.map_truth import axle_positions, path_cell_truth, truth_at_observations
    from roadgrip.mapping import empty_grid, fuse, observations_from_estimates
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("f1tenth-patches", 0, duration=20.0)
    tab = run_estimator("cascade", drive).table
    pos = axle_positions(drive)
    for a in ("front", "rear"):
        tab[f"x_{a}"], tab[f"y_{a}"] = pos[a]
        tab[f"excited_{a}"] = True
        tab[f"mu_{a}_obs_std"] = 1e-3
        tab[f"mu_{a}_obs_sys"] = 0.0
    exact = truth_at_observations(drive, tab)
    assert not np.allclose(exact["mu_front_obs"], tab["mu_front_obs"], equal_nan=True)
    obs = observations_from_estimates(exact)
    assert len(obs.mu) == 2 * drive.n
    g = fuse(empty_grid(0.5), obs.x, obs.y, obs.mu, obs.var)
    truth = path_cell_truth(drive, 0.5)
    iy, ix = np.nonzero(g.n_obs > 0)
    w_mean = g.s1[iy, ix] / g.s0[iy, ix]
    # the observations' weighted mean; the posterior adds the prior, weighted up in the cells
    # on a patch edge, whose observations disagree beyond their variances
    fused = pd.Series(w_mean, index=pd.MultiIndex.from_arrays([ix + g.ix0, iy + g.iy0]))
    assert len(fused) == len(truth) and (truth.max() - truth.min()) > 0.2
    np.testing.assert_allclose(fused.reindex(truth.index).to_numpy(), truth.to_numpy(), atol=1e-12)
    mean, _ = g.posterior()
    np.testing.assert_allclose(mean[iy, ix], w_mean, atol=1e-3)
    with pytest.raises(ValueError, match="rows"):
        truth_at_observations(drive, tab.iloc[:-1])
