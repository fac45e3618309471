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

``--estimators`` prints instead the issue's family criteria, one row a vehicle: the
classifiers calibrated with ``roadgrip calibrate --label high`` on the dry first minute of
``dry-gravel-dry`` seed 10 and scored on seed 0 (gravel flagged within 1 s of its first
sample at true utilisation >= 0.6, no false switch; ``-`` where the calibration fails),
the cascade's 5 m cells on ``figure-eight`` seed 0 (cells with >= 10 observations: how
many, their mean |error|, the share within mean +- 1.96 std, confidently wrong cells), and
whether each run is honest (:mod:`roadgrip.evaluate.honesty`).
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


def _classifier_cells(name: str) -> str:
    """Calibration and both classifiers' scores on one vehicle (``--estimators``)."""
    from roadgrip.estimators import run_estimator
    from roadgrip.estimators.classify import calibrate
    from roadgrip.evaluate.classification import surface_change_scores
    from roadgrip.evaluate.honesty import score_result

    dry = simulate_scenario("dry-gravel-dry", seed=10, engine="multibody", vehicle=name).slice_time(0.0, 60.0)
    test = simulate_scenario("dry-gravel-dry", seed=0, engine="multibody", vehicle=name)
    try:
        cal = calibrate([(dry, "high")])
    except ValueError:
        return f" {'fails':>8}" + f" {'-':>7} {'-':>3} {'-':>4} {'-':>6}" * 2
    row = f" {cal.diagnostics['long_channel'] + '/' + cal.diagnostics['lat_channel']:>8}"
    for method in ("brls", "slipmap"):
        res = run_estimator(method, test, {"calibration": cal})
        sc = surface_change_scores(test, res.table["grip_class"].to_numpy())
        ok = sc.delays[0] <= 1.0 and sc.false_switches == 0
        row += (f" {sc.delays[0]:>7.2f} {sc.false_switches:>3d} {'yes' if ok else 'no':>4}"
                f" {'yes' if score_result(res, test).honest else 'no':>6}")
    return row


def _cascade_cells(name: str) -> str:
    """The cascade's 5 m cells on the figure-eight and its honesty (``--estimators``)."""
    from roadgrip.constants import Z95
    from roadgrip.estimators import run_estimator
    from roadgrip.evaluate.honesty import score_result
    from roadgrip.evaluate.map_truth import score_map
    from roadgrip.mapping import grid_from_estimates

    d = simulate_scenario("figure-eight", seed=0, engine="multibody", vehicle=name)
    res = run_estimator("cascade", d, {})
    score = score_map(d, grid_from_estimates(res.table, cell=5.0))
    c = score.cells[(score.cells["n_obs"] >= 10) & score.cells["mu_true"].notna()]
    err = (c["mu_mean"] - c["mu_true"]).abs()
    mae = float(err.mean()) if len(c) else float("nan")
    cover = float(np.mean(err <= Z95 * c["mu_std"])) if len(c) else float("nan")
    ok = len(c) > 0 and mae <= 0.05 and cover >= 0.9 and score.confidently_wrong == 0
    return (f" {len(c):>5d} {mae:>5.2f} {cover:>5.2f} {score.confidently_wrong:>5d} {'yes' if ok else 'no':>4}"
            f" {'yes' if score_result(res, d).honest else 'no':>6}")


def estimator_table(names: list[str]) -> None:
    """Print the issue's family criteria, one row a vehicle (module docstring)."""
    cls = " ".join(f"{m + ' [s]':>7} {'fs':>3} {'pass':>4} {'honest':>6}" for m in ("bRLS", "map"))
    print(f"{'vehicle':<11} {'drive':<5} {'x/y':>8} {cls} | {'cells':>5} {'mae':>5} {'cover':>5} "
          f"{'wrong':>5} {'pass':>4} {'honest':>6}")
    t_start = time.perf_counter()
    for name in names:
        drive = mb_vehicle(name, sensors="ideal").params.drive
        print(f"{name:<11} {drive:<5}{_classifier_cells(name)} |{_cascade_cells(name)}", flush=True)
    print(f"({len(names)} vehicles in {time.perf_counter() - t_start:.0f} s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", default="100-119", help="family seeds, 'a-b' (inclusive)")
    ap.add_argument("--scenarios", nargs="*", default=list(SCENARIOS), choices=SCENARIOS)
    ap.add_argument("--estimators", action="store_true",
                    help="the classifiers' and the cascade's family criteria instead of the parameters")
    args = ap.parse_args()
    names = ["ford-escort", "vw-vanagon", *(f"random:{s}" for s in _seeds(args.seeds))]
    if args.estimators:
        estimator_table(names[2:])
        return
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
