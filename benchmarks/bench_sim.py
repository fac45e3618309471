"""Simulation speed of every named scenario on every engine, in simulated seconds per wall second.

Run: ``.venv/bin/python benchmarks/bench_sim.py [--repeat N]``. The first call
of each integrator compiles it (numba, cached on disk); it is timed apart.
Multi-body drives are simulated with the drive cache off.
"""

from __future__ import annotations

import argparse
import time

from roadgrip.sim import SCENARIOS, simulate_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per scenario (best is kept)")
    args = ap.parse_args()
    print(f"{'scenario':<18} {'engine':<10} {'vehicle':<12} {'sim [s]':>8} {'internal [Hz]':>13} "
          f"{'first [s]':>10} {'best [s]':>9} {'x real time':>12}")
    for name, sc in SCENARIOS.items():
        for engine in sc.engines:
            vehicles = ("ford-escort", "vw-vanagon") if engine == "multibody" else (sc.vehicle,)
            for vehicle in vehicles:
                kw = {"engine": engine, "cache": False}
                if engine == "multibody":
                    kw["vehicle"] = vehicle
                t0 = time.perf_counter()
                d = simulate_scenario(name, seed=0, **kw)
                first = time.perf_counter() - t0
                best = float("inf")
                for k in range(args.repeat):
                    t0 = time.perf_counter()
                    simulate_scenario(name, seed=k + 1, **kw)
                    best = min(best, time.perf_counter() - t0)
                print(f"{name:<18} {engine:<10} {vehicle:<12} {d.duration:>8.0f} "
                      f"{d.meta.truth['internal_rate']:>13.0f} {first:>10.2f} {best:>9.3f} "
                      f"{d.duration / best:>12.0f}", flush=True)


if __name__ == "__main__":
    main()
