"""Friction-grid fusion throughput (observations/s) and merge time; real-data maps.

Run: ``.venv/bin/python benchmarks/bench_mapping.py``. Random observations over a
200 m x 100 m area, 0.5 m cells (80,000 cells).

``--real OUTDIR`` also runs the cascade and the grid on the F1/10 runs DS1-DS5
of ``../shared/data/frictionmaps`` (when present), writes each map (NPZ, CSV,
PNG) and the merged DS3-DS5 map to OUTDIR, and prints how the maps of DS3, DS4
and DS5 (the same loop) agree on their common cells. ``--calibrate`` reads the
runs with the pose calibration of the reader (gyro and odometry-speed scales,
effective steering gain; ``roadgrip.io.frictionmaps``) and prints the fitted values.

Per run it also prints the kinematic consistency of the sensors (``ay / (vx r)``,
pose speed over odometry speed), the sensor noise the cascade used, the mean
stage-2 NIS, the root-mean-square difference between the stage-1 lateral
velocity and the one differentiated from the pose, and the share of map cells
whose mean lies below the 90th percentile of the friction used there
(``|Fy| / Fz``, a lower bound of the peak that needs no slip angle): a map of
peak friction must not lie below it.
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


def _grip_used_check(tab, grid, cell: float) -> float:
    """Share of a grid's cells (>= 1 observation) whose mean lies below the friction used there.

    The friction used, ``|Fy| / Fz`` per axle at the axle position, is a lower bound of the peak
    friction that needs no slip angle; its 90th percentile per cell is compared with the map.
    """
    import pandas as pd

    cells = grid.cells_frame(1)
    if len(cells) == 0:
        return float("nan")
    rows = []
    for ax, f, fz in (("front", "Fyf", "Fzf"), ("rear", "Fyr", "Fzr")):
        rows.append(pd.DataFrame({"ix": np.floor(tab[f"x_{ax}"] / cell), "iy": np.floor(tab[f"y_{ax}"] / cell),
                                  "used": np.abs(tab[f]) / tab[fz]}))
    used = pd.concat(rows).dropna().groupby(["ix", "iy"])["used"].quantile(0.9).reset_index()
    used["x"], used["y"] = (used["ix"] + 0.5) * cell, (used["iy"] + 0.5) * cell
    m = cells.merge(used.round({"x": 9, "y": 9}), on=["x", "y"])
    return float(np.mean(m["mu_mean"] < m["used"]))


def _print_compare(label: str, grids: list, min_obs: int) -> None:
    cmp = M.compare_grids(grids, min_obs=min_obs)
    if len(cmp.cells) == 0:
        print(f"{label}, cells with >= {min_obs} observations in each: none in common")
        return
    means = cmp.cells[[f"mu_{i}" for i in range(len(grids))]].mean()
    print(f"{label}, cells with >= {min_obs} observations in each: {len(cmp.cells)} common cells, "
          f"mean std across runs {cmp.spread_std:.3f}, largest difference {cmp.max_abs_diff:.3f}, "
          f"run means {'/'.join(f'{v:.2f}' for v in means)}")


def frictionmaps(outdir: str, calibrate: bool = False, steer_delay: float = 0.0, cell: float = 0.5,
                 options: dict | None = None) -> None:
    import sys
    from pathlib import Path

    from roadgrip.estimators import run_estimator
    from roadgrip.io.frictionmaps import read_frictionmaps
    from roadgrip.plots.cascade import plot_result
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
        chk = drive.meta.extra["kinematic_checks"]
        if calibrate:
            c = drive.meta.extra["calibration"]
            print(f"{ds}: gyro scale {c['gyro_scale']:.3f}, speed scale {c['speed_scale']:.3f}, "
                  f"steering gain {c['steer_gain']:.3f} ({c['steer_gain_n']} steady samples)")
        res = run_estimator("cascade", drive, options or {})
        plot_result(drive, res, out / f"{ds}_cascade.png")
        g = M.grid_from_estimates(res.table, cell)
        grids[ds] = g
        g.to_npz(out / f"{ds}_map.npz")
        g.to_csv(out / f"{ds}_cells.csv")
        plot_grid(g, out / f"{ds}_map.png", title=f"frictionmaps {ds}: cascade friction map", vmin=0.0, vmax=1.2)
        c = g.cells_frame(10)
        q = np.quantile(c["mu_mean"], [0.1, 0.5, 0.9]) if len(c) else [np.nan] * 3
        tab = res.table
        dg = res.meta["diagnostics"]
        ok = np.isfinite(drive.data["vy_pose"]).to_numpy() & (drive.data["vx"].to_numpy() > 1.0)
        vy_rms = float(np.sqrt(np.mean((tab["vy_ekf"].to_numpy()[ok] - drive.data["vy_pose"].to_numpy()[ok]) ** 2)))
        obs = M.observations_from_estimates(tab, cell)
        med = f"{np.median(obs.mu):.2f}" if len(obs.mu) else "-"
        print(f"{ds}: {drive.n} samples, {drive.duration:.0f} s, excited front {100 * tab['excited_front'].mean():.1f} % "
              f"rear {100 * tab['excited_rear'].mean():.1f} %, {len(obs.mu)} observations fused (median {med}) "
              f"in {int((g.n_obs > 0).sum())} cells, {len(c)} cells with >= 10 observations, "
              f"mu p10/p50/p90 {q[0]:.2f}/{q[1]:.2f}/{q[2]:.2f}, {res.meta['timing']['samples_per_s']:,.0f} samples/s")
        print(f"     ay/(vx r) {chk.get('ay_over_vx_yaw_rate', np.nan):.2f}, pose speed/vx "
              f"{chk.get('pose_speed_over_vx', np.nan):.2f}, |ay| p99 {np.quantile(np.abs(drive.data['ay']), 0.99):.1f} m/s2, "
              f"noise accel {dg['accel noise std [m/s2]']:.2f} m/s2 gyro {dg['gyro noise std [rad/s]']:.3f} rad/s, "
              f"stage-2 NIS {dg['mean NIS stage 2 (5 dof)']:.1f} (5 dof), rms(vy - vy_pose) {vy_rms:.2f} m/s, "
              f"cells below the grip used there {100 * _grip_used_check(tab, g, cell):.0f} %")
    for names in (("DS3", "DS4", "DS5"), ("DS3", "DS5"), ("DS4", "DS5")):
        for min_obs in (1, 5, 10):
            _print_compare("/".join(names), [grids[k] for k in names], min_obs)
    merged = M.merge(*(grids[k] for k in ("DS3", "DS4", "DS5")))
    merged.to_npz(out / "DS3-DS5_map.npz")
    plot_grid(merged, out / "DS3-DS5_map.png", title="frictionmaps DS3+DS4+DS5 merged", vmin=0.0, vmax=1.2)


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--real", metavar="OUTDIR", help="also map the frictionmaps runs into OUTDIR")
    ap.add_argument("--calibrate", action="store_true", help="calibrate the real runs against the pose")
    ap.add_argument("--steer-delay", type=float, default=0.0, help="command delay [s] for the real runs")
    ap.add_argument("--real-only", action="store_true", help="skip the synthetic fusion benchmark")
    ap.add_argument("--cell", type=float, default=0.5, help="cell size [m] of the real-data maps")
    ap.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                    help="cascade option for the real runs (repeatable), e.g. slip_noise_z=0")
    a = ap.parse_args()
    if not a.real_only:
        main()
    if a.real:
        opts = {k: float(v) for k, v in (o.split("=", 1) for o in a.option)}
        frictionmaps(a.real, calibrate=a.calibrate, steer_delay=a.steer_delay, cell=a.cell, options=opts)
