"""Friction-grid fusion throughput (observations/s) and merge time.

Run: ``.venv/bin/python benchmarks/bench_mapping.py``. Random observations over a
200 m x 100 m area, 0.5 m cells (80,000 cells).
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


if __name__ == "__main__":
    main()
