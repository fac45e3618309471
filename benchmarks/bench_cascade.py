"""Cascade throughput, and the cascade's UKF against filterpy's UKF on the same model.

Run: ``.venv/bin/python benchmarks/bench_cascade.py`` (one core: ``NUMBA_NUM_THREADS=1``).
``--accuracy`` prints instead the map and per-sample figures on the multi-body
figure-eight drives (both vehicles, seeds 0-4, 5 m cells) and on ``f1tenth-patches``
(seeds 0-4, 0.5 m cells), each cell scored against the friction under the tires at
the positions inside it (:mod:`roadgrip.evaluate.map_truth`), and the ceiling of
each: the same observations with the true friction under their axle
(:func:`roadgrip.evaluate.map_truth.truth_at_observations`).

Prints samples/s of the whole three-stage cascade on the simulated
``f1tenth-patches`` drive, and, for the stage-2 force model (6 states, 5
measurements), steps/s of filterpy's ``UnscentedKalmanFilter``, of roadgrip's
pure-Python kernels (:mod:`roadgrip.inference.kalman`) and of the compiled loop
the cascade uses, with the largest difference of their estimates.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import time

import numpy as np
from numba import njit

from roadgrip.estimators import cascade as C
from roadgrip.inference.kalman import (
    GaussianState,
    merwe_weights,
    psd_sqrt,
    sigma_points,
    ukf_correct,
    ukf_predict,
    ukf_update,
    unscented_transform,
)
from roadgrip.sim.scenarios import simulate_scenario


def bench_cascade(repeats: int = 5) -> None:
    drive = simulate_scenario("f1tenth-patches", 0)
    C.run(drive)  # compile (cached after the first run)
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        C.run(drive)
        best = min(best, time.perf_counter() - t0)
    print(f"cascade (3 stages), f1tenth-patches: {drive.n} samples in {best * 1e3:.1f} ms "
          f"-> {drive.n / best:,.0f} samples/s (includes input checks, noise estimation and the table)")
    long = drive.with_data(
        __import__("pandas").concat(
            [drive.data.assign(t=drive.data["t"] + k * (drive.duration + 0.02)) for k in range(20)],
            ignore_index=True,
        )
    )
    t0 = time.perf_counter()
    C.run(long)
    wall = time.perf_counter() - t0
    print(f"cascade, 20 x the drive: {long.n} samples -> {long.n / wall:,.0f} samples/s")


@njit(cache=True)
def _compiled_ukf(x, P, steer, dt, mass, iz, lf, lr, Q, R, Z, wm, wc, g):
    n = Z.shape[0]
    out = np.empty((n, x.shape[0]))
    for k in range(n):
        L, _, _ = psd_sqrt(P)
        X = sigma_points(x, L, g)
        Y = C.force_transition(X, steer[k], dt, mass, iz, lf, lr)
        x, P = unscented_transform(Y, wm, wc, Q)
        L, P, _ = psd_sqrt(P)
        X = sigma_points(x, L, g)
        H = C.force_measurement(X, steer[k], mass)
        x, P, _, _ = ukf_correct(x, P, X, H, wm, wc, Z[k], R)
        out[k] = x
    return out


def bench_ukf(n: int = 3000) -> None:
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    drive = simulate_scenario("f1tenth-patches", 0)
    veh = drive.vehicle
    df = drive.data.iloc[:n]
    dt = 1.0 / drive.meta.sample_rate
    steer = df["steer"].to_numpy()
    Z = np.column_stack([df["vx"], df["yaw_rate"], np.zeros(len(df)), df["ax"], df["ay"]])
    Q = np.diag([1e-5, 1e-4, 1e-5, 4.0, 4.0, 4.0])
    R = np.diag([1e-3, 3e-5, 1e-3, 1e-2, 1e-2])
    x0 = np.array([Z[0, 0], 0, 0, 0, 0, 0.0])
    P0 = np.diag([1e-2, 1e-2, 1e-2, 100.0, 100.0, 100.0])
    args = (veh.mass, veh.yaw_inertia, veh.lf, veh.lr)
    w = merwe_weights(6, 1.0, 2.0, 0.0)

    pts = MerweScaledSigmaPoints(6, alpha=1.0, beta=2.0, kappa=0.0)
    ukf = UnscentedKalmanFilter(6, 5, dt, hx=None, fx=None, points=pts)
    ukf.x, ukf.P, ukf.Q, ukf.R = x0.copy(), P0.copy(), Q, R
    fp = np.empty((len(df), 6))
    t0 = time.perf_counter()
    for k in range(len(df)):
        d = steer[k]
        ukf.predict(fx=lambda s, _dt, d=d: C.force_transition(s[None, :], d, dt, *args)[0])
        ukf.update(Z[k], hx=lambda s, d=d: C.force_measurement(s[None, :], d, veh.mass)[0])
        fp[k] = ukf.x
    t_fp = time.perf_counter() - t0

    st = GaussianState(x0.copy(), P0.copy())
    py = np.empty_like(fp)
    t0 = time.perf_counter()
    for k in range(len(df)):
        st = ukf_predict(st, C.force_transition, Q, w, steer[k], dt, *args)
        st, _ = ukf_update(st, Z[k], C.force_measurement, R, w, steer[k], veh.mass)
        py[k] = st.mean
    t_py = time.perf_counter() - t0

    _compiled_ukf(x0.copy(), P0.copy(), steer[:5], dt, *args, Q, R, Z[:5], w.wm, w.wc, w.gamma)
    t0 = time.perf_counter()
    co = _compiled_ukf(x0.copy(), P0.copy(), steer, dt, *args, Q, R, Z, w.wm, w.wc, w.gamma)
    t_co = time.perf_counter() - t0

    print(f"stage-2 UKF (6 states, 5 measurements), {len(df)} steps:")
    print(f"  filterpy UnscentedKalmanFilter : {len(df) / t_fp:>12,.0f} steps/s")
    print(f"  roadgrip kernels, Python steps : {len(df) / t_py:>12,.0f} steps/s  "
          f"max |x - filterpy| = {np.abs(py - fp).max():.2e}")
    print(f"  roadgrip kernels, compiled loop: {len(df) / t_co:>12,.0f} steps/s  "
          f"max |x - filterpy| = {np.abs(co - fp).max():.2e}")


def bench_accuracy(seeds=(0, 1, 2, 3, 4)) -> None:
    import pandas as pd

    from roadgrip.constants import Z95
    from roadgrip.estimators import run_estimator
    from roadgrip.evaluate.map_truth import sample_score, score_map, truth_at_observations
    from roadgrip.mapping import grid_from_estimates

    def pooled_line(label: str, pooled: list) -> None:
        c = pd.concat(pooled)
        err = (c["mu_mean"] - c["mu_true"]).abs()
        if len(c):
            print(f"  {label}: {len(c)} cells with >= 10 observations, MAE {err.mean():.3f}, within 0.1 "
                  f"{100 * np.mean(err <= 0.1):.0f} %, truth in mean +- 1.96 std {100 * np.mean(err <= Z95 * c['mu_std']):.0f} %")

    rows = [("figure-eight", v, 5.0) for v in ("ford-escort", "vw-vanagon")] + [("f1tenth-patches", None, 0.5)]
    for scenario, vehicle, cell in rows:
        pooled, ceiling = [], []
        print(f"{scenario} {vehicle or ''} ({cell:g} m cells)")
        for seed in seeds:
            kw = {"engine": "multibody", "vehicle": vehicle} if vehicle else {}
            drive = simulate_scenario(scenario, seed, **kw)
            tab = run_estimator("cascade", drive, {}).table
            score = score_map(drive, grid_from_estimates(tab, cell=cell))
            s = sample_score(drive, tab)
            vy = np.sqrt(np.mean((tab["vy"] - drive.col("vy_true")) ** 2))
            print(f"  seed {seed}: excited {100 * tab['excited_front'].mean():4.1f} / {100 * tab['excited_rear'].mean():4.1f} %"
                  f"  vy rms {vy:.3f} m/s  {score.line()}  samples confidently wrong "
                  f"{100 * s['confidently_wrong']:.2f} %  below the grip floor "
                  f"{100 * max(s['below_floor_front'], s['below_floor_rear']):.2f} %")
            pooled.append(score.cells[(score.cells["n_obs"] >= 10) & score.cells["mu_true"].notna()])
            best = score_map(drive, grid_from_estimates(truth_at_observations(drive, tab), cell=cell))
            ceiling.append(best.cells[(best.cells["n_obs"] >= 10) & best.cells["mu_true"].notna()])
        pooled_line("pooled", pooled)
        # the same observations, each carrying the true friction under its axle: what the
        # places where the drive gave information allow any estimator
        pooled_line("ceiling (every observation exact)", ceiling)


if __name__ == "__main__":
    import sys

    if "--accuracy" in sys.argv:
        bench_accuracy()
    else:
        bench_cascade()
        bench_ukf()
