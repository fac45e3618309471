"""Simulation speed of every named scenario, in simulated seconds per wall second.

Run: ``.venv/bin/python benchmarks/bench_sim.py [--repeat N]``. The first call
of each integrator compiles it (numba, cached on disk); it is timed apart.
"""

from __future__ import annotations

import argparse
import time

from roadgrip.sim import SCENARIOS, simulate_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per scenario (best is kept)")
    args = ap.parse_args()
    print(f"{'scenario':<18} {'model':<8} {'sim [s]':>8} {'internal [Hz]':>13} "
          f"{'first [s]':>10} {'best [s]':>9} {'x real time':>12}")
    for name, sc in SCENARIOS.items():
        t0 = time.perf_counter()
        d = simulate_scenario(name, seed=0)
        first = time.perf_counter() - t0
        best = float("inf")
        for k in range(args.repeat):
            t0 = time.perf_counter()
            simulate_scenario(name, seed=k + 1)
            best = min(best, time.perf_counter() - t0)
        print(f"{name:<18} {d.meta.truth['model']:<8} {sc.duration:>8.0f} "
              f"{d.meta.truth['internal_rate']:>13.0f} {first:>10.2f} {best:>9.3f} "
              f"{sc.duration / best:>12.0f}")


if __name__ == "__main__":
    main()
