"""The random vehicle family of the multi-body engine: its main parameters, and how far each
scenario drives each vehicle.

Run: ``.venv/bin/python benchmarks/vehicle_family.py [--seeds 100-119] [--scenarios ...]``.
Prints one row a vehicle (the two named ones first, for comparison): base, drive layout,
mass, yaw inertia, CG position and height, axle cornering stiffnesses, understeer gradient,
roll gradient; then per scenario the largest axle friction utilisation reached (the 99.9th
percentile of the larger of the two axles, so that one sample does not decide); for the snow
slalom the largest front and rear slip angles over their tires' peak slip angles on snow, and for
dry-gravel-dry the largest utilisation on gravel while cornering (its slalom and lane change).
Each scenario runs at its multi-body default duration and seed 0; ``ROADGRIP_DRIVE_CACHE``
caches the drives.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from roadgrip.constants import GRAVITY
from roadgrip.sim.scenarios import simulate_scenario
from roadgrip.sim.vehicle_family import axle_peak_slip, mb_vehicle

SCENARIOS = ("snow-slalom", "dry-gravel-dry", "figure-eight", "straight-cruise")
_GRAVEL_CORNERING = (60.0 + 27.0, 60.0 + 43.0)  # the slalom and lane change of the gravel segment [s]


def _seeds(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def _understeer(vp) -> float:
    """Understeer gradient [rad/(m/s²)] of the single-track description."""
    wb = vp.lf + vp.lr
    return vp.mass / wb * (vp.lr / vp.cornering_stiffness_front - vp.lf / vp.cornering_stiffness_rear)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", default="100-119", help="family seeds, 'a-b' (inclusive)")
    ap.add_argument("--scenarios", nargs="*", default=list(SCENARIOS), choices=SCENARIOS)
    args = ap.parse_args()
    names = ["ford-escort", "vw-vanagon", *(f"random:{s}" for s in _seeds(args.seeds))]
    short = {"snow-slalom": "snow", "dry-gravel-dry": "dgd", "figure-eight": "fig8", "straight-cruise": "cruise"}
    head = (f"{'vehicle':<11} {'base':<6} {'drive':<5} {'m [kg]':>6} {'Iz':>5} {'lf [m]':>6} {'lr [m]':>6} "
            f"{'h [m]':>5} {'Cf [kN/rad]':>11} {'Cr':>5} {'K_us [deg/g]':>12} {'roll [deg/g]':>12}")
    for sc in args.scenarios:
        head += f" {'util ' + short[sc]:>11}"
        if sc == "snow-slalom":
            head += f" {'af/peak':>7} {'ar/peak':>7}"
        if sc == "dry-gravel-dry":
            head += f" {'gravel corner':>13}"
    print(head)
    t_start = time.perf_counter()
    for name in names:
        v = mb_vehicle(name, sensors="ideal")
        vp = v.params
        base = v.description.get("base", name)
        row = (f"{name:<11} {base.split('-')[0][:6]:<6} {vp.drive:<5} {vp.mass:>6.0f} {vp.yaw_inertia:>5.0f} "
               f"{vp.lf:>6.2f} {vp.lr:>6.2f} {vp.cg_height:>5.2f} {vp.cornering_stiffness_front / 1e3:>11.0f} "
               f"{vp.cornering_stiffness_rear / 1e3:>5.0f} {np.degrees(_understeer(vp)) * GRAVITY:>12.2f} "
               f"{np.degrees(vp.roll_gradient) * GRAVITY:>12.1f}")
        for sc in args.scenarios:
            d = simulate_scenario(sc, seed=0, engine="multibody", vehicle=name, sensors="ideal")
            util = np.maximum(d.col("util_f_true"), d.col("util_r_true"))
            row += f" {np.quantile(util, 0.999):>11.2f}"
            if sc == "snow-slalom":
                peak_f, peak_r = axle_peak_slip(v, 0.3)
                row += (f" {np.abs(d.col('alpha_f_true')).max() / peak_f:>7.1f}"
                        f" {np.abs(d.col('alpha_r_true')).max() / peak_r:>7.1f}")
            if sc == "dry-gravel-dry":
                t = d.t
                corner = (t >= _GRAVEL_CORNERING[0]) & (t < _GRAVEL_CORNERING[1])
                row += f" {util[corner].max():>13.2f}"
        print(row, flush=True)
    print(f"({len(names)} vehicles x {len(args.scenarios)} scenarios in {time.perf_counter() - t_start:.0f} s)")


if __name__ == "__main__":
    main()
