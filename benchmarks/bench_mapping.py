"""Friction-grid fusion throughput (observations/s) and merge time; real-data maps.

Run: ``.venv/bin/python benchmarks/bench_mapping.py``. Random observations over a
200 m x 100 m area, 0.5 m cells (80,000 cells).

``--real OUTDIR`` also runs the cascade and the grid on the F1/10 runs DS1-DS5
of ``../shared/data/frictionmaps`` (when present), writes each map (NPZ, CSV,
PNG) and the merged DS3-DS5 map to OUTDIR, and prints how the maps of DS3, DS4
and DS5 (the same loop) agree on their common cells. ``--calibrate`` reads the
runs with the pose calibration of the reader (gyro and odometry-speed scales,
effective steering gain; ``roadgrip.io.frictionmaps``) and prints the fitted values.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import time

import numpy as np

from roadgrip import mapping as M


def main() -> None:
    rng = np.random.default_rng(0)
    g0 = M.empty_grid(0.5)
    M.fuse(g0, [0.0, 1.0], [0.0, 1.0], [0.5, 0.6], [0.1, 0.1])  # compile
    for n in (1_000_000, 5_000_000, 20_000_000):
        x = rng.uniform(-100, 100, n)
        y = rng.uniform(-50, 50, n)
        mu = rng.uniform(0.1, 1.2, n)
        var = rng.uniform(0.001, 0.5, n)
        best = np.inf
        for _ in range(3):
            t0 = time.perf_counter()
            g = M.fuse(g0, x, y, mu, var)
            best = min(best, time.perf_counter() - t0)
        print(f"fuse {n:>11,} observations: {best * 1e3:7.1f} ms -> {n / best / 1e6:6.1f} M observations/s "
              f"({int((g.n_obs > 0).sum()):,} cells)")
    a = M.fuse(g0, x[: n // 2], y[: n // 2], mu[: n // 2], var[: n // 2])
    b = M.fuse(g0, x[n // 2:], y[n // 2:], mu[n // 2:], var[n // 2:])
    t0 = time.perf_counter()
    m = M.merge(a, b)
    print(f"merge two {a.shape[0]}x{a.shape[1]} grids: {(time.perf_counter() - t0) * 1e3:.1f} ms, "
          f"observations kept {int(m.n_obs.sum()):,} of {n:,}")


def frictionmaps(outdir: str, calibrate: bool = False, steer_delay: float = 0.0) -> None:
    import sys
    from pathlib import Path

    from roadgrip.estimators import cascade as C
    from roadgrip.io.frictionmaps import read_frictionmaps
    from roadgrip.plots.maps import plot_grid

    root = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "frictionmaps"
    if not root.is_dir():
        print(f"real data not found at {root}", file=sys.stderr)
        return
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    grids = {}
    for ds in ("DS1", "DS2", "DS3", "DS4", "DS5"):
        drive = read_frictionmaps(root / ds, calibrate=calibrate, steer_delay=steer_delay)
        if calibrate:
            c = drive.meta.extra["calibration"]
            print(f"{ds}: gyro scale {c['gyro_scale']:.3f}, speed scale {c['speed_scale']:.3f}, "
                  f"steering gain {c['steer_gain']:.3f} ({c['steer_gain_n']} steady samples), ay/(vx r) "
                  f"{drive.meta.extra['kinematic_checks'].get('ay_over_vx_yaw_rate', np.nan):.2f}")
        res = C.run_cli(drive, C.EstimateRequest(plot_path=str(out / f"{ds}_cascade.png")))
        g = M.grid_from_estimates(res.table, 0.5)
        grids[ds] = g
        g.to_npz(out / f"{ds}_map.npz")
        g.to_csv(out / f"{ds}_cells.csv")
        plot_grid(g, out / f"{ds}_map.png", title=f"frictionmaps {ds}: cascade friction map")
        c = g.cells_frame(10)
        q = np.quantile(c["mu_mean"], [0.1, 0.5, 0.9]) if len(c) else [np.nan] * 3
        tab = res.table
        print(f"{ds}: {drive.n} samples, {drive.duration:.0f} s, excited front {100 * tab['excited_front'].mean():.0f} % "
              f"rear {100 * tab['excited_rear'].mean():.0f} %, {len(c)} cells with >= 10 observations, "
              f"mu p10/p50/p90 {q[0]:.2f}/{q[1]:.2f}/{q[2]:.2f}, {res.meta['timing']['samples_per_s']:,.0f} samples/s")
    same = [grids[k] for k in ("DS3", "DS4", "DS5")]
    merged = M.merge(*same)
    merged.to_npz(out / "DS3-DS5_map.npz")
    plot_grid(merged, out / "DS3-DS5_map.png", title="frictionmaps DS3+DS4+DS5 merged")
    for min_obs in (1, 5, 10):
        cmp = M.compare_grids(same, min_obs=min_obs)
        if len(cmp.cells) == 0:
            print(f"DS3/DS4/DS5, cells with >= {min_obs} observations in each: none in common")
            continue
        means = cmp.cells[["mu_0", "mu_1", "mu_2"]].mean()
        print(f"DS3/DS4/DS5, cells with >= {min_obs} observations in each: {len(cmp.cells)} common cells, "
              f"mean std across runs {cmp.spread_std:.3f}, largest difference {cmp.max_abs_diff:.3f}, "
              f"run means {means.iloc[0]:.2f}/{means.iloc[1]:.2f}/{means.iloc[2]:.2f}")


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--real", metavar="OUTDIR", help="also map the frictionmaps runs into OUTDIR")
    ap.add_argument("--calibrate", action="store_true", help="calibrate the real runs against the pose")
    ap.add_argument("--steer-delay", type=float, default=0.0, help="command delay [s] for the real runs")
    ap.add_argument("--real-only", action="store_true", help="skip the synthetic fusion benchmark")
    a = ap.parse_args()
    if not a.real_only:
        main()
    if a.real:
        frictionmaps(a.real, calibrate=a.calibrate, steer_delay=a.steer_delay)
