"""Fleet-map throughput on Dask with 1 and 2 workers, and the accuracy of the fleet map.

Run: ``.venv/bin/python benchmarks/bench_fleet.py [--drives 50] [--workdir /tmp/fleet-bench]``.

Simulates ``--drives`` drives of the ``f1tenth-patches`` scenario (seeds 0..N-1, 60 s
each, written once as Parquet into ``--workdir`` and reused), then builds the fleet map
(:func:`roadgrip.mapping.fleet.fleet_map`, the cascade per drive, 0.5 m cells) on a
``LocalCluster`` of 1 and of 2 single-threaded worker processes. The workers are warmed up
first (imports and the compiled kernels loaded from numba's cache) and the best of
``--repeats`` runs counts, so the figures are the steady state: drives per minute and observations per second, and the speed-up of 2 workers
over 1 (target >= 1.7 on a quiet 2-core machine; the load average before each run and the
cores the workers actually got, their CPU time over the wall time, are printed). The two maps
must be equal to 1e-12.

Accuracy: the cells with >= 10 observations are scored as the cascade map acceptance
scores a drive's map (:mod:`roadgrip.evaluate.map_truth`: the truth of a cell is the true
friction at the axle positions inside it, here over all drives), and must have >= 90 %
within 0.1 and >= 90 % with the truth inside mean +- 1.96 std. The same score of the
ceiling map (the cascade's observations made exact) says what the places where the drives
gave information allow any estimator.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("ROADGRIP_DRIVE_CACHE", str(Path(__file__).resolve().parents[1] / ".cache" / "drives"))

import numpy as np
import pandas as pd

SCENARIO = "f1tenth-patches"


def _simulate(args: tuple[int, str]) -> str:
    seed, folder = args
    path = Path(folder) / f"{SCENARIO}-{seed:03d}.parquet"
    if not path.exists():
        from roadgrip.sim.scenarios import simulate_scenario

        simulate_scenario(SCENARIO, seed).to_parquet(path)
    return str(path)


def drives(n: int, folder: Path) -> list[str]:
    """The drive files, simulated on two processes where missing."""
    from concurrent.futures import ProcessPoolExecutor

    folder.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(2) as pool:
        return list(pool.map(_simulate, [(s, str(folder)) for s in range(n)]))


def _warm() -> None:
    """Import the estimator and load its kernels in a worker."""
    from roadgrip.estimators import run_estimator
    from roadgrip.sim.scenarios import simulate_scenario

    run_estimator("cascade", simulate_scenario(SCENARIO, 0, duration=5.0))


def run(paths: list[str], workers: int, repeats: int = 1):
    """The fleet map on a warmed-up local cluster; the best wall time [s] of ``repeats`` runs."""
    from distributed import Client, LocalCluster

    from roadgrip.mapping.fleet import FleetConfig, fleet_map

    best, cores = np.inf, np.nan
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cl, \
            Client(cl) as client:
        client.run(_warm)
        for _ in range(repeats):
            cpu0, main0 = sum(client.run(_cpu_seconds).values()), _cpu_seconds()
            t0 = time.perf_counter()
            part = fleet_map(paths, FleetConfig(), client=client)
            wall = time.perf_counter() - t0
            if wall < best:
                best = wall
                cores = ((sum(client.run(_cpu_seconds).values()) - cpu0) / wall, (_cpu_seconds() - main0) / wall)
    return part, best, cores


def _cpu_seconds() -> float:
    """CPU time [s] of the calling worker process."""
    import psutil

    t = psutil.Process().cpu_times()
    return t.user + t.system


def truth_of_cells(paths: list[str], cell: float) -> pd.Series:
    """Mean true friction at the axle positions inside each cell over all drives, by ``(ix, iy)``."""
    from roadgrip.evaluate.map_truth import AXLES, axle_positions, axle_truth
    from roadgrip.io import read_drive

    keys, vals = [], []
    for p in paths:
        d = read_drive(p)
        pos, mu = axle_positions(d), axle_truth(d)
        for a in AXLES:
            keys.append(np.stack([np.floor(pos[a][0] / cell), np.floor(pos[a][1] / cell)], axis=1).astype(np.int64))
            vals.append(mu[a])
    k = np.concatenate(keys)
    frame = pd.DataFrame({"ix": k[:, 0], "iy": k[:, 1], "mu": np.concatenate(vals)})
    return frame.groupby(["ix", "iy"])["mu"].mean()


def ceiling_map(paths: list[str], starts: pd.Series):
    """The fleet map with every observation exact: the cascade's observations of each drive carrying
    the true friction under their axle (:func:`roadgrip.evaluate.map_truth.truth_at_observations`),
    fused as the fleet map fuses them (:func:`roadgrip.mapping.fleet.square_map`, start times from the fleet run)."""
    from roadgrip.estimators import run_estimator
    from roadgrip.evaluate.map_truth import truth_at_observations
    from roadgrip.io import read_drive
    from roadgrip.mapping import merge
    from roadgrip.mapping.fleet import FleetConfig, square_map

    cfg = FleetConfig()
    maps = []
    for p in paths:
        d = read_drive(p, vehicle=cfg.vehicle)
        tab = truth_at_observations(d, run_estimator(cfg.method, d, dict(cfg.options), seed=cfg.seed).table)
        maps.append(square_map(tab, cfg, float(starts[p])))
    return merge(*maps)


def score(grid, truth: pd.Series, min_obs: int = 10) -> dict[str, float]:
    from roadgrip.constants import Z95

    ix, iy = grid.cell_index()
    mean, std = grid.cell_posterior()
    n = grid.cells.n_obs
    t = truth.reindex(pd.MultiIndex.from_arrays([ix, iy])).to_numpy(float)
    ok = (n >= min_obs) & np.isfinite(t)
    err = np.abs(mean - t)[ok]
    return {"cells": int(ok.sum()), "mae": float(err.mean()), "within_0.1": float(np.mean(err <= 0.1)),
            "calibrated_95": float(np.mean(err <= Z95 * std[ok])),
            "confidently_wrong": int(np.sum((err > 0.15) & (err > Z95 * std[ok])))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--drives", type=int, default=50)
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/roadgrip-fleet-bench"))
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=2, help="runs per cluster, the best wall time counts")
    a = ap.parse_args()
    t0 = time.perf_counter()
    paths = drives(a.drives, a.workdir)
    print(f"{len(paths)} drives of {SCENARIO} ready in {time.perf_counter() - t0:.1f} s ({a.workdir})")
    results = {}
    for w in a.workers:
        load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
        part, wall, cores = run(paths, w, a.repeats)
        d = part.drives
        n_obs, n_samp = int(d["observations"].sum()), int(d["samples"].sum())
        results[w] = (part, wall, cores[0])
        print(f"{w} worker(s): {wall:6.1f} s, {60 * len(d) / wall:6.1f} drives/min, {n_obs / wall:8.0f} "
              f"observations/s, {n_samp / wall:8.0f} samples/s ({n_obs} observations in {part.map.n_cells} "
              f"cells); cores used on average: workers {cores[0]:.2f}, scheduler and client {cores[1]:.2f}; "
              f"before the run: {load}")
    if 1 in results and 2 in results:
        (p1, w1, c1), (p2, w2, c2) = results[1], results[2]
        same = np.array_equal(p1.map.cells.key, p2.map.cells.key) and np.array_equal(p1.map.cells.n_obs,
                                                                                      p2.map.cells.n_obs)
        rel = max(float(np.max(np.abs(getattr(p1.map.cells, f) - getattr(p2.map.cells, f))
                               / np.maximum(np.abs(getattr(p1.map.cells, f)), 1e-300))) for f in ("s0", "s1", "s2"))
        print(f"speed-up of 2 workers over 1: {w1 / w2:.2f} (target >= 1.7); maps equal: cells and counts "
              f"{same}, largest relative difference of the sums {rel:.1e}")
        print(f"per core the workers got: {60 * a.drives / (w1 * c1):.0f} and {60 * a.drives / (w2 * c2):.0f} "
              f"drives/min (1 and 2 workers): 2 workers keep {100 * (w1 * c1) / (w2 * c2):.0f} % of one "
              "worker's efficiency, so on two free cores they would give about "
              f"{2 * (w1 * c1) / (w2 * c2):.2f} x")
    part = next(iter(results.values()))[0]  # (part, wall, cores)
    truth = truth_of_cells(paths, part.map.cell)
    starts = part.drives.set_index("source")["start_time"]
    for label, grid in (("fleet map", part.map), ("ceiling (every observation exact)", ceiling_map(paths, starts))):
        s = score(grid, truth)
        ok = s["within_0.1"] >= 0.9 and s["calibrated_95"] >= 0.9
        print(f"{label}, cells with >= 10 observations: {s['cells']}, MAE {s['mae']:.3f}, within 0.1 "
              f"{100 * s['within_0.1']:.1f} %, truth within mean +- 1.96 std {100 * s['calibrated_95']:.1f} %, "
              f"confidently wrong {s['confidently_wrong']} -> map acceptance {'met' if ok else 'NOT met'}")


if __name__ == "__main__":
    main()
