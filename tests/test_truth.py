"""True axle friction curves (parametric or binned) and friction utilisation."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.truth import (
    DEFAULT_BIN_WIDTH,
    PURE_LATERAL_MAX_FX,
    BinnedCurve,
    binned_truth_curve,
    friction_utilisation,
    has_parametric_truth,
    true_curve,
    utilisation_source,
)
from roadgrip.vehicle import PRESETS


def _curvature_bound(mu, lo: float, hi: float) -> float:
    """max |mu''| over [lo, hi] (finite differences on a fine grid)."""
    g = np.linspace(lo, hi, 4001)
    h = g[1] - g[0]
    return float(np.abs(np.gradient(np.gradient(mu(g), h), h)).max())


# -- binned against the parametric truth of the planar simulator --------------------------
@pytest.fixture(scope="module")
def planar_drives():
    from roadgrip.sim import scenarios as scen

    return {"dry-gravel-dry": scen.simulate_scenario("dry-gravel-dry", seed=0, duration=150),
            "f1tenth-patches": scen.simulate_scenario("f1tenth-patches", seed=0, duration=60)}


@pytest.mark.parametrize("name", ["dry-gravel-dry", "f1tenth-patches"])
@pytest.mark.parametrize("axle", ["front", "rear"])
def test_binned_curve_agrees_with_the_parametric_tire_at_the_bin_centres(planar_drives, name, axle):
    d = planar_drives[name]
    labels = sorted(set(d.data["surface"].astype(str)))
    checked = 0
    for lab in labels:
        bc = binned_truth_curve(d, axle, lab)
        if len(bc) < 5:
            continue  # a surface barely driven on (one sample of gravel at t = 60 s and 120 s)
        lat = d.true_tire(axle, surface=lab)
        w = bc.bin_width
        # Piecewise-linear through bin centroids: interpolation over <= 2 bins, extrapolation
        # over <= 1 and the in-bin averaging each cost at most ~ w² max|mu''| / 2 ...
        tol = 2.0 * w**2 * _curvature_bound(lat.mu, *bc.slip_range)
        # ... and the combined slip the 5 % longitudinal threshold lets in (friction ellipse).
        dx = d.true_tire(axle, "longitudinal", lab).peak()[1]
        tol += (1.0 - np.sqrt(1.0 - (PURE_LATERAL_MAX_FX / dx) ** 2)) * lat.peak()[1]
        err = np.abs(bc.at_centres() - lat.mu(bc.centres))
        assert np.isfinite(err).all()
        assert err.max() <= tol, (lab, err.max(), tol)
        checked += 1
    assert checked >= 1


def test_bin_means_read_at_the_centres_would_be_biased(planar_drives):
    """Why the curve goes through bin centroids: on dry asphalt (slope ~ 12 /rad) the raw
    bin mean sits several hundredths off the tire at the bin centre."""
    d = planar_drives["dry-gravel-dry"]
    bc = binned_truth_curve(d, "front", "dry_asphalt")
    lat = d.true_tire("front", surface="dry_asphalt")
    naive = np.abs(bc.mu_mean - lat.mu(bc.centres)).max()
    centroid = np.abs(bc.at_centres() - lat.mu(bc.centres)).max()
    assert naive > 0.02
    assert centroid < naive / 5


def test_combined_slip_samples_are_left_out(planar_drives):
    """f1tenth low-grip patches: the rear axle drives hard past its lateral peak, where the
    friction ellipse takes lateral force away. Without the |Fx|/Fz threshold the binned
    curve falls below the pure-lateral tire; with it, it does not."""
    d = planar_drives["f1tenth-patches"]
    lat = d.true_tire("rear", surface="low_grip")
    strict = binned_truth_curve(d, "rear", "low_grip")
    loose = binned_truth_curve(d, "rear", "low_grip", max_long=np.inf)
    assert loose.count.sum() > strict.count.sum()
    err_loose = np.nanmax(np.abs(loose.at_centres() - lat.mu(loose.centres)))
    err_strict = np.nanmax(np.abs(strict.at_centres() - lat.mu(strict.centres)))
    assert err_loose > 0.01 > err_strict


def test_true_curve_is_the_parametric_tire_when_the_drive_carries_one(planar_drives):
    d = planar_drives["f1tenth-patches"]
    assert has_parametric_truth(d, "front") and has_parametric_truth(d, "rear", "longitudinal")
    f = true_curve(d, "rear", "high_grip")
    a = np.linspace(-0.3, 0.3, 7)
    np.testing.assert_array_equal(f(a), d.true_tire("rear", surface="high_grip").mu(a))


# -- a hand-made drive with binned truth (as a multi-body model states it) ------------------
def _mu_a(a):
    return 0.3 * np.sin(1.4 * np.arctan(12.0 * a))


def _mu_b(a):
    return 0.8 * np.sin(1.6 * np.arctan(9.0 * a))


def _binned_drive(n: int = 20000, seed: int = 4) -> Drive:
    """Fy = mu(alpha) Fz, except on combined-slip rows (|Fx| = 0.3 Fz, Fy halved) and lifted
    rows (Fz = 0); 'snow' for the first 70 % of the time, 'tarmac' after."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    surface = np.where(np.arange(n) < int(0.7 * n), "snow", "tarmac")
    df = pd.DataFrame({"t": t, "surface": surface})
    for a in "fr":
        alpha = rng.uniform(-0.2, 0.15, n)
        fz = rng.uniform(3000.0, 6000.0, n)
        mu = np.where(surface == "snow", _mu_a(alpha), _mu_b(alpha))
        fy = mu * fz
        fx = rng.uniform(-0.04, 0.04, n) * fz
        comb = rng.random(n) < 0.2
        fx[comb] = 0.3 * fz[comb] * rng.choice([-1.0, 1.0], comb.sum())
        fy[comb] *= 0.5
        lifted = rng.random(n) < 0.02
        fz[lifted], fy[lifted], fx[lifted] = 0.0, 1.0, 0.0
        df[f"alpha_{a}_true"], df[f"Fx{a}_true"] = alpha, fx
        df[f"Fy{a}_true"], df[f"Fz{a}_true"] = fy, fz
    df["mu_true"] = np.where(surface == "snow", 0.3, 0.8)
    truth = {"model": "multibody", "truth_curve": "binned",
             "surfaces": {"snow": {"mu": 0.3}, "tarmac": {"mu": 0.8}}}
    return Drive.from_frame(df, PRESETS["suv"], source="sim:test", truth=truth, check_units=False)


@pytest.mark.parametrize("axle", ["front", "rear"])
def test_binned_curve_recovers_an_analytic_curve(axle):
    d = _binned_drive()
    assert not has_parametric_truth(d, axle)
    bc = true_curve(d, axle)  # default surface: the one under the vehicle most of the time
    assert isinstance(bc, BinnedCurve) and bc.surface == "snow"
    w = DEFAULT_BIN_WIDTH
    tol = 2.0 * w**2 * _curvature_bound(_mu_a, -0.2, 0.15)
    assert tol < 0.04 * 0.3  # a few % of the peak: the check has teeth
    err = np.abs(bc.at_centres() - _mu_a(bc.centres))
    assert err.max() <= tol
    # every visited bin between -0.2 and 0.15 rad, and only pure-lateral loaded samples
    assert bc.slip_range[0] <= -0.2 and bc.slip_range[1] >= 0.15 and len(bc) == 41
    a = "f" if axle == "front" else "r"
    data = d.data[d.data["surface"] == "snow"]
    pure = (data[f"Fz{a}_true"] > 0) & (data[f"Fx{a}_true"].abs() <= 0.05 * data[f"Fz{a}_true"])
    assert bc.count.sum() == pure.sum()
    # between the centres too, and NaN where the drive never went
    g = np.linspace(-0.195, 0.145, 301)
    assert np.abs(bc(g) - _mu_a(g)).max() <= tol
    assert np.isnan(bc(np.array([-0.25, 0.2, 0.5, np.nan]))).all()
    # the other surface, its own curve
    tar = binned_truth_curve(d, axle, "tarmac")
    tol_b = 2.0 * w**2 * _curvature_bound(_mu_b, -0.2, 0.15)
    assert np.abs(tar.at_centres() - _mu_b(tar.centres)).max() <= tol_b


def test_binned_curve_leaves_sparse_bins_out_and_keeps_shape():
    d = _binned_drive(n=2000)
    bc = binned_truth_curve(d, "front", "snow", bin_width=0.01, min_count=30)
    assert (bc.count >= 30).all()
    every = binned_truth_curve(d, "front", "snow", bin_width=0.01, min_count=1)
    assert len(every) > len(bc)
    dropped = np.setdiff1d(every.bins, bc.bins)
    assert np.isnan(bc((dropped + 0.5) * 0.01)).all()
    assert bc(np.zeros((2, 3))).shape == (2, 3)


def test_isolated_bin_is_constant_and_runs_extrapolate_to_their_edges():
    # bins 0, 1 (a run) and 5 (isolated); two samples each, on mu = 2 alpha
    w = 0.1
    alpha = np.array([0.02, 0.06, 0.12, 0.16, 0.52, 0.56])
    df = pd.DataFrame({"t": np.arange(6) * 0.1, "alpha_f_true": alpha, "Fxf_true": 0.0,
                       "Fyf_true": 2.0 * alpha * 1000.0, "Fzf_true": 1000.0})
    d = Drive.from_frame(df, PRESETS["sedan"], truth={"truth_curve": "binned"}, check_units=False)
    bc = binned_truth_curve(d, "front", bin_width=w, min_count=2)
    assert bc.bins.tolist() == [0, 1, 5]
    np.testing.assert_allclose(bc.alpha_mean, [0.04, 0.14, 0.54])
    # a straight line is reproduced exactly across and beyond the centroids of the run
    q = np.array([0.0, 0.03, 0.1, 0.19])
    np.testing.assert_allclose(bc(q), 2.0 * q, atol=1e-12)
    np.testing.assert_allclose(bc(np.array([0.5, 0.59])), [1.08, 1.08])  # constant
    assert np.isnan(bc(np.array([0.25, -0.01]))).all()


def test_binned_curve_errors_name_the_problem():
    d = _binned_drive(n=500)
    with pytest.raises(ValueError, match="axle must be 'front' or 'rear'"):
        binned_truth_curve(d, "middle")
    with pytest.raises(ValueError, match=r"surface 'ice' never occurs.*\['snow', 'tarmac'\]"):
        binned_truth_curve(d, "front", "ice")
    with pytest.raises(ValueError, match="bin_width must be a positive"):
        binned_truth_curve(d, "front", bin_width=0.0)
    with pytest.raises(ValueError, match="min_count must be a positive integer"):
        binned_truth_curve(d, "front", min_count=0)
    bare = Drive.from_frame(d.data[["t", "alpha_f_true", "Fyf_true"]], d.vehicle, source="x")
    with pytest.raises(ValueError, match=r"lacks truth column\(s\) \['Fxf_true', 'Fzf_true'\]"):
        binned_truth_curve(bare, "front")


def test_declared_binned_truth_wins_over_tire_dicts():
    from roadgrip.tire import SURFACES

    d = _binned_drive(n=2000)
    snow = SURFACES["snow"].lateral.to_dict()
    truth = dict(d.meta.truth, surfaces={"snow": {"front": snow, "rear": snow, "mu": 0.3},
                                         "tarmac": {"front": snow, "rear": snow, "mu": 0.8}})
    parametric = Drive.from_frame(d.data, d.vehicle, truth={**truth, "truth_curve": "parametric"},
                                  check_units=False)
    declared = Drive.from_frame(d.data, d.vehicle, truth=truth, check_units=False)
    assert has_parametric_truth(parametric, "front")
    assert not has_parametric_truth(parametric, "front", "longitudinal")  # no 'front_long'
    assert not has_parametric_truth(declared, "front")
    assert isinstance(true_curve(declared, "front"), BinnedCurve)


# -- utilisation --------------------------------------------------------------------------
def test_utilisation_from_columns_and_computed_from_forces():
    df = pd.DataFrame({"t": [0.0, 0.1, 0.2, 0.3],
                       "Fxr_true": [300.0, 0.0, -400.0, 10.0],
                       "Fyr_true": [400.0, 1000.0, 300.0, 0.0],
                       "Fzr_true": [1000.0, 2000.0, 1000.0, 0.0],
                       "mu_true": [1.0, 0.5, 0.5, 0.5]})
    d = Drive.from_frame(df, PRESETS["sedan"], check_units=False)
    assert utilisation_source(d, "rear") == "computed" and utilisation_source(d, "front") is None
    u = friction_utilisation(d, "rear")
    np.testing.assert_allclose(u[:3], [0.5, 1.0, 1.0])  # 500/1000, 1000/1000, 500/500
    assert np.isnan(u[3])  # no load: undefined
    d2 = Drive.from_frame(df.assign(util_r_true=[0.1, 0.2, 0.3, 0.4]), PRESETS["sedan"],
                          check_units=False)
    assert utilisation_source(d2, "rear") == "column"
    np.testing.assert_array_equal(friction_utilisation(d2, "rear"), [0.1, 0.2, 0.3, 0.4])
    with pytest.raises(ValueError, match="no front friction utilisation"):
        friction_utilisation(d, "front")


# -- the benchmark's scores on a drive with binned truth ------------------------------------
def test_true_peak_series_falls_back_to_mu_true_on_binned_truth():
    from roadgrip.evaluate.metrics import true_peak_series

    d = _binned_drive(n=1000)
    for axle in ("front", "rear"):
        np.testing.assert_array_equal(true_peak_series(d, axle), d.col("mu_true"))
    with pytest.raises(ValueError, match="carries no friction truth"):
        true_peak_series(Drive.from_frame(d.data.drop(columns="mu_true"), d.vehicle,
                                          truth=d.meta.truth, check_units=False))


def _curve_stand_in(method, drive, options=None, *, seed=0, progress=None):
    """Friction trace = mu_true; posterior curves = the analytic truth of the surface under
    the vehicle + 0.02 on the GP-SSM's slip grid, band +-0.05, at the requested curve times."""
    from roadgrip.estimators.base import EstimateResult, conform

    t = drive.t
    mu = drive.col("mu_true")
    tab = pd.DataFrame({"t": t, "mu_front": mu, "mu_rear": mu, "mu_front_lower": mu - 0.1,
                        "mu_front_upper": mu + 0.1, "mu_rear_lower": mu - 0.1,
                        "mu_rear_upper": mu + 0.1, "peak_observed_front": True,
                        "peak_observed_rear": True})
    grid = np.linspace(-0.3, 0.3, 161)
    frames = []
    for tc in options["curve_times"] or ():
        surface = drive.data["surface"].iloc[np.searchsorted(t - t[0], tc + 1e-9) - 1]
        mu_c = (_mu_a if surface == "snow" else _mu_b)(grid)
        frames += [pd.DataFrame({"t": tc, "axle": axle, "alpha": grid, "mu_mean": mu_c + 0.02,
                                 "mu_lower": mu_c - 0.03, "mu_upper": mu_c + 0.07})
                   for axle in ("front", "rear")]
    curves = pd.concat(frames, ignore_index=True) if frames else None
    return EstimateResult(method, conform(tab), {}, curves)


def test_suite_scores_curves_against_the_binned_truth(monkeypatch):
    import roadgrip.estimators as est
    from roadgrip.evaluate import suite

    monkeypatch.setattr(est, "run_estimator", _curve_stand_in)
    d = _binned_drive(n=10000)  # all snow for the first 70 s
    rec = suite.run_suite([suite.Case("binned", "gpssm", "gpssm")], suite.QUICK,
                          drives={"binned": d})[0]
    assert rec.status == "ok", rec.details
    m = rec.metrics
    # The curves are the truth + 0.02; the binned truth is within 2 w² max|mu''| of it and the
    # curves' linear interpolation on the 0.00375 rad grid within grid² max|mu''| / 8.
    curv = max(_curvature_bound(_mu_a, -0.2, 0.15), _curvature_bound(_mu_b, -0.2, 0.15))
    tol = 2.0 * DEFAULT_BIN_WIDTH**2 * curv + 0.00375**2 * curv / 8
    assert np.isfinite(m["curve_mae"])
    assert m["curve_mae"] == pytest.approx(0.02, abs=tol)
    assert m["curve_cov"] == 1.0
    assert abs(m["peak_err_f"]) < 1e-12  # the true peak is mu_true
    # curves at 50 s (snow) and at the end (tarmac), each against its own surface's truth
    scored = [x for x in rec.details if x.startswith("curve ")]
    assert len(scored) == 4 and any("front at t = 50 s" in x for x in scored)


def test_gpssm_curve_accuracy_and_curve_table_on_binned_truth():
    from roadgrip.estimators.gpssm import CurvePosterior, curves_frame
    from roadgrip.estimators.gpssm.accuracy import curve_accuracy

    d = _binned_drive(n=10000)
    grid = np.linspace(-0.3, 0.3, 161)
    mu = np.vstack([_mu_a(grid), _mu_a(grid)])
    post = CurvePosterior(grid, mu + 0.02, mu - 0.03, mu + 0.07, np.zeros_like(mu))
    curv = _curvature_bound(_mu_a, -0.2, 0.15)
    tol = 2.0 * DEFAULT_BIN_WIDTH**2 * curv + 0.00375**2 * curv / 8
    acc = curve_accuracy(post, d, 50.0)
    for axle in ("front", "rear"):
        assert acc[axle]["mae"] == pytest.approx(0.02, abs=tol)
        assert acc[axle]["coverage"] == 1.0 and acc[axle]["bins"] == 41
    # front slips beyond 0.1 rad only under combined slip: those bins have no truth, not scored
    df = d.data.copy()
    far = df["alpha_f_true"] > 0.1
    df.loc[far, "Fxf_true"] = 0.3 * df.loc[far, "Fzf_true"]
    acc = curve_accuracy(post, Drive(df, d.meta), 50.0)
    assert acc["front"]["alpha_max"] < 0.1 + DEFAULT_BIN_WIDTH and acc["front"]["bins"] < acc["rear"]["bins"] == 41
    assert acc["front"]["mae"] == pytest.approx(0.02, abs=tol)
    tab = curves_frame({50.0: post}, d)
    front = tab[tab["axle"] == "front"]
    inside = (front["alpha"] > -0.19) & (front["alpha"] < 0.145)
    assert np.isnan(front.loc[~inside & (front["alpha"].abs() > 0.21), "mu_true"]).all()
    assert np.abs(front.loc[inside, "mu_true"] - _mu_a(front.loc[inside, "alpha"])).max() <= tol


def test_curve_figures_draw_a_binned_truth_where_it_is_defined(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    from roadgrip.estimators.gpssm import CurvePosterior, curves_frame
    from roadgrip.plots import gpssm as PG
    from roadgrip.plots import signals as PS

    d = _binned_drive(n=4000)
    grid = np.linspace(-0.3, 0.3, 161)
    mu = np.vstack([_mu_a(grid), _mu_a(grid)])
    tab = curves_frame({20.0: CurvePosterior(grid, mu, mu - 0.05, mu + 0.05, 0 * mu)}, d)
    assert tab["mu_true"].isna().any() and tab["mu_true"].notna().any()
    written = []  # the Fig. 1 writer closes its figure: keep it
    monkeypatch.setattr(PG.plt, "close", written.append)
    PG.plot_curves(tab, pd.DataFrame({"t": d.t, "alpha_f": d.col("alpha_f_true"),
                                      "alpha_r": d.col("alpha_r_true")}), tmp_path / "fig1.png")
    monkeypatch.undo()
    assert (tmp_path / "fig1.png").exists() and len(written) == 1
    for fig in (PS.plot_curves(tab), written[0]):
        truth = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_label() == "truth"]
        assert len(truth) == 2  # front and rear
        y = np.asarray(truth[0].get_ydata(), float)
        assert np.isfinite(y).sum() > 80 and np.isnan(y).any()  # [-0.2, 0.15] of [-0.3, 0.3]
        plt.close(fig)
