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
classifiers calibrated with ``roadgrip calibrate --label high --vehicle car.yaml`` on the dry
first minute of ``dry-gravel-dry`` seed 10, both drives read with the car's fitted vehicle file
(``roadgrip vehicle fit`` on :data:`FIT_DRIVE`, the same seed 10: a drive separate from the
scored one; its delays and accelerometer biases applied, :meth:`~roadgrip.inference.vehicle_identification.VehicleFit.read`), as the issue
asks ("plus the fitted vehicle"): the channels on/off, longitudinal/lateral, and the latency
of the wheel speeds behind the accelerometer the calibration still aligns (``lat ms``; the
file moves ``a_x`` by its own delay where the fit drive's pose times it), scored on seed 0
(gravel flagged within 1 s of its first sample at true utilisation >= 0.6, no false switch;
``-`` where the calibration refuses the car); ``--no-fit`` reads both drives as logged,
``--classifiers`` prints the classifier columns both ways side by side (as logged | with the
fitted file) without the cascade,
the cascade's 5 m cells on ``figure-eight`` seed 0 (the observations the map kept, the most
in one cell, the cells with >= 10 observations: how many, their mean |error|, the share
within mean +- 1.96 std, confidently wrong cells), and whether each run is honest
(:mod:`roadgrip.evaluate.honesty`).

``--cascade`` prints the cascade's columns alone, with the preset car and with the fitted car
(below) side by side. Rules for the cascade, fixed before measuring. Its sensors: the preset car's drive has the
accelerometer and the gyro on separate messages, unaligned, so the cascade is told their
latencies' spread, ``accel_latency_std`` = :data:`UNALIGNED_LATENCY_STD` (two independent
0-150 ms latencies of the simulator's realistic sensors); a drive aligned by the fitted car's
calibration keeps the fit's delay error, :data:`ALIGNED_LATENCY_STD` (the issue's bound on a
fitted delay). The cells criterion's first two parts (mean |error| <= 0.05 and >= 90 % within
mean +- 1.96 std, over the cells with >= 10 observations) need such cells: a vehicle whose run
yields none is excluded from them (``-`` in ``pass``, its counts printed), and they count over
the others; the third part, no confidently wrong cell (any cell), is judged on every vehicle.
The last lines say how many pass of how many judged.

``--fit`` prints ``roadgrip vehicle fit`` against the truth, one row a vehicle, and the
cascade's figure-eight cells again with the fitted vehicle and its sensor calibration
(delays aligned, steering and accelerometer corrected) applied to the drive, as ``roadgrip
estimate --vehicle car.yaml`` does. Rules fixed before measuring: the fit drive is
``dry-gravel-dry`` seed 10 whole (180 s: two dry minutes with a slalom, a lane change,
accelerations and brakings each, and the gravel minute; ``--mu 0.6`` so that the linear range
``|a_y| < 0.24 g`` holds on gravel too; its dry minute alone leaves the stiffnesses undetermined
even with error-free sensors). The truths: the front stiffness is the tire's in series with the
steering compliance, ``1/(1/C_f + c)`` (a steering-angle sensor cannot tell the two apart, and it
is what an estimator reading that sensor needs); the rear is the tire's; each delay is its
sensor's latency minus the gyro's (the speed's: the undriven wheels', or the ``vx`` column's on
an all-wheel drive, which is what :func:`roadgrip.signals.wheel_speed_vx` reads; the
accelerometer's: ``a_y``'s; ``ax ms``: ``a_x``'s, against the delay the file moves ``a_x`` by,
its own ``delay_accelerometer_x`` or, where that is undetermined, ``a_y``'s); the steering offset is the road-wheel angle at a zero reading,
``-offset/(1 + ratio_error)``. An undetermined value fails its criterion.

``--gpssm`` prints the GP-SSM on ``snow-slalom`` seed 0 (200 particles, filter seed 0, as the
multi-body acceptance runs it; ``--particles`` and ``--filter-seed`` change them) with the
fitted vehicle and calibration: per axle the final
curve's MAE and band coverage (:func:`roadgrip.estimators.gpssm.accuracy.honesty_figures`;
pass: MAE <= 0.02 and coverage >= 0.9 on both axles) and whether the run is honest.

``--fit-drive vehicle-id`` (with ``--fit`` or ``--gpssm``) fits each car on the identification
drive ``vehicle-id`` seed 10 instead (dry only, ``--mu 1.0``: slaloms, a lane change and speed
steps at 8, 12, 16 and 20 m/s), and prints the count passing at the end.
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


def _classifier_cells(name: str, fit=None) -> str:
    """Calibration and both classifiers' scores on one vehicle (``--estimators``); with
    ``fit``, both drives read with the fitted vehicle file (:meth:`~roadgrip.inference.vehicle_identification.VehicleFit.read`)."""
    from roadgrip.estimators import run_estimator
    from roadgrip.estimators.classify import calibrate
    from roadgrip.evaluate.classification import surface_change_scores
    from roadgrip.evaluate.honesty import score_result

    cal_drive = simulate_scenario("dry-gravel-dry", seed=10, engine="multibody", vehicle=name)
    test = simulate_scenario("dry-gravel-dry", seed=0, engine="multibody", vehicle=name)
    if fit is not None:
        cal_drive, test = fit.read(cal_drive), fit.read(test)
    dry = cal_drive.slice_time(0.0, 60.0)
    try:
        cal = calibrate([(dry, "high")])
    except ValueError:
        return f" {'fails':>8} {'-':>6}" + f" {'-':>7} {'-':>3} {'-':>4} {'-':>6}" * 2
    lat = cal.diagnostics["wheel_latency"]
    row = (f" {cal.diagnostics['long_channel'] + '/' + cal.diagnostics['lat_channel']:>8}"
           + (f" {1e3 * lat['latency_s']:>+6.0f}" if lat["fitted"] else f" {'-':>6}"))
    for method in ("brls", "slipmap"):
        res = run_estimator(method, test, {"calibration": cal})
        sc = surface_change_scores(test, res.table["grip_class"].to_numpy())
        ok = sc.delays[0] <= 1.0 and sc.false_switches == 0
        row += (f" {sc.delays[0]:>7.2f} {sc.false_switches:>3d} {'yes' if ok else 'no':>4}"
                f" {'yes' if score_result(res, test).honest else 'no':>6}")
    return row


UNALIGNED_LATENCY_STD = 0.06
"""``accel_latency_std`` [s] of the preset car's drive: the standard deviation of the difference
of two independent uniform 0-150 ms latencies, ``0.15 / sqrt(6)``."""
ALIGNED_LATENCY_STD = 0.02
"""``accel_latency_std`` [s] of a drive aligned by the fitted calibration: the issue's bound on
a fitted delay's error."""

CASCADE_HEADER = (f"{'map obs':>7} {'max n':>5} {'cells':>5} {'mae':>5} {'cover':>5} {'wrong':>5} {'pass':>4} "
                  f"{'honest':>6}")
"""Column titles of :func:`_cascade_cells`."""


def _cascade_cells(name: str, fit=None, tally: dict | None = None) -> str:
    """The cascade's 5 m cells on the figure-eight and its honesty (``--estimators``); with
    ``fit`` (a :class:`~roadgrip.inference.vehicle_identification.VehicleFit`), on the drive
    calibrated by it and with its vehicle. ``tally`` counts ``vehicles``, ``honest``,
    ``judged``, ``passed`` and ``excluded`` (the module docstring's rules)."""
    from roadgrip.constants import Z95
    from roadgrip.estimators import run_estimator
    from roadgrip.evaluate.honesty import score_result
    from roadgrip.evaluate.map_truth import score_map
    from roadgrip.mapping import grid_from_estimates

    d = simulate_scenario("figure-eight", seed=0, engine="multibody", vehicle=name)
    run_on = d if fit is None else fit.read(d)
    latency = UNALIGNED_LATENCY_STD if fit is None else ALIGNED_LATENCY_STD
    res = run_estimator("cascade", run_on, {"accel_latency_std": latency})
    score = score_map(run_on, grid_from_estimates(res.table, cell=5.0))
    n_map = int(score.cells["n_obs"].sum())
    n_max = int(score.cells["n_obs"].max()) if len(score.cells) else 0
    c = score.cells[(score.cells["n_obs"] >= 10) & score.cells["mu_true"].notna()]
    err = (c["mu_mean"] - c["mu_true"]).abs()
    mae = float(err.mean()) if len(c) else float("nan")
    cover = float(np.mean(err <= Z95 * c["mu_std"])) if len(c) else float("nan")
    ok = mae <= 0.05 and cover >= 0.9 and score.confidently_wrong == 0
    honest = score_result(res, run_on).honest
    if tally is not None:
        for key, add in (("vehicles", True), ("honest", honest), ("judged", len(c) > 0),
                         ("passed", len(c) > 0 and ok), ("excluded", len(c) == 0),
                         ("none_wrong", score.confidently_wrong == 0)):
            tally[key] = tally.get(key, 0) + int(add)
    verdict = "-" if len(c) == 0 else "yes" if ok else "no"
    return (f" {n_map:>7d} {n_max:>5d} {len(c):>5d} {mae:>5.2f} {cover:>5.2f} {score.confidently_wrong:>5d}"
            f" {verdict:>4} {'yes' if honest else 'no':>6}")


def _cascade_tally(tally: dict) -> str:
    """The family's cascade figures gathered by :func:`_cascade_cells`, one line."""
    n = tally.get("vehicles", 0)
    return (f"cascade: honest {tally.get('honest', 0)} of {n}; no confidently wrong cell {tally.get('none_wrong', 0)}"
            f" of {n}; cells criterion {tally.get('passed', 0)} of {tally.get('judged', 0)} judged, "
            f"{tally.get('excluded', 0)} excluded (no 5 m cell with >= 10 observations)")


FIT_DRIVE = ("dry-gravel-dry", 10, 0.6)
"""The fit's drive: scenario, seed and the ``--mu`` of its linear range (module docstring)."""
FIT_MU = {"dry-gravel-dry": 0.6, "vehicle-id": 1.0}
"""``--mu`` of each drive the fit may run on (``--fit-drive``): the lowest friction driven."""
FIT_DURATION = 180.0
"""Length of the fit's drive [s] (``dry-gravel-dry``)."""
FIT_LIMITS = {"stiffness": 0.10, "delay": 0.020, "offset": np.radians(0.1)}
"""The issue's bounds: relative stiffness error [-], delay error [s], steering offset error [rad]."""


def fit_family_vehicle(name: str, scenario: str | None = None):
    """``roadgrip vehicle fit`` of a family vehicle on :data:`FIT_DRIVE` (or on ``scenario``
    with its seed and ``--mu``)."""
    from roadgrip.inference.vehicle_identification import fit_vehicle

    scenario = scenario or FIT_DRIVE[0]
    drive = simulate_scenario(scenario, seed=FIT_DRIVE[1], engine="multibody", vehicle=name)
    return fit_vehicle(drive, mu=FIT_MU[scenario])


def fit_errors(name: str, fit, duration: float = FIT_DURATION) -> dict[str, float]:
    """Each fitted quantity's error against the truth
    (:func:`roadgrip.sim.vehicle_family.fit_truth`): stiffnesses and the gyro's scale relative
    [-], delays [s], the steering offset and the heading bias [rad], the gyro's bias [rad/s];
    NaN where undetermined."""
    from roadgrip.sim.vehicle_family import fit_truth
    from roadgrip.sim.vehicle_family import mb_vehicle as _mb

    out = {}
    for k, true in fit_truth(_mb(name), duration).items():
        fv = fit.values.get(k)
        if k == "delay_accelerometer_x" and (fv is None or not fv.fitted):
            fv = fit.values.get("delay_accelerometer")  # what the file moves a_x by without it
        val = fv.value if fv is not None and fv.fitted else float("nan")
        out[k] = (val / true - 1.0) if k.startswith("cornering") or k.endswith("scale") else val - true
    return out


def fit_passes(err: dict[str, float]) -> bool:
    """The issue's criterion on :func:`fit_errors` (NaN fails)."""
    lim = FIT_LIMITS
    return bool(all(abs(err[k]) <= lim["stiffness"] for k in err if k.startswith("cornering"))
                and all(abs(err[k]) <= lim["delay"] for k in err if "delay" in k)
                and abs(err["steer_offset"]) <= lim["offset"])


def fit_table(names: list[str], scenario: str | None = None) -> None:
    """Print the fit against the truth and the cascade with the fitted car (module docstring),
    the fit on :data:`FIT_DRIVE` or on ``scenario`` (same seed and ``--mu``)."""
    from roadgrip.sim.scenarios import SCENARIOS as ALL

    duration = float(ALL[scenario or FIT_DRIVE[0]].multibody_duration)
    print(f"{'vehicle':<11} {'drive':<5} {'Cf %':>6} {'Cr %':>6} {'acc ms':>6} {'steer':>6} {'speed':>6} "
          f"{'pose':>6} {'ax ms':>6} {'off deg':>7} {'pass':>4} {'gyro %':>6} {'mrad/s':>6} {'head':>6} | "
          f"{CASCADE_HEADER}")
    t_start = time.perf_counter()
    tally: dict = {}
    n_pass = 0
    for name in names:
        fit = fit_family_vehicle(name, scenario)
        e = fit_errors(name, fit, duration)
        row = (f"{name:<11} {fit.vehicle.drive:<5} {100 * e['cornering_stiffness_front']:>+6.1f} "
               f"{100 * e['cornering_stiffness_rear']:>+6.1f}")
        for k in ("delay_accelerometer", "steer_delay", "delay_speed", "delay_pose", "delay_accelerometer_x"):
            row += f" {1e3 * e[k]:>+6.0f}"
        ok = fit_passes(e)
        n_pass += ok
        row += f" {np.degrees(e['steer_offset']):>+7.3f} {'yes' if ok else 'no':>4}"
        row += (f" {100 * e['yaw_rate_scale']:>+6.2f} {1e3 * e['yaw_rate_bias']:>+6.2f}"
                f" {1e3 * e['pose_heading_bias']:>+6.2f} |")
        print(row + _cascade_cells(name, fit, tally), flush=True)
    print(f"fit on {scenario or FIT_DRIVE[0]} seed {FIT_DRIVE[1]}: the whole criterion on {n_pass} of {len(names)}")
    print(_cascade_tally(tally))
    print(f"({len(names)} vehicles in {time.perf_counter() - t_start:.0f} s)")


def _gpssm_cells(name: str, fit=None, particles: int = 200, seed: int = 0) -> tuple[str, bool]:
    """The GP-SSM's final curves on the snow slalom and its honesty (``--gpssm``), and
    whether it meets the criterion."""
    from roadgrip.estimators.base import EstimateResult
    from roadgrip.estimators.gpssm import GPSSMConfig, run_filter
    from roadgrip.estimators.gpssm.accuracy import honesty_figures
    from roadgrip.estimators.gpssm.estimator import summary
    from roadgrip.evaluate.honesty import score_result

    d = simulate_scenario("snow-slalom", seed=0, engine="multibody", vehicle=name)
    run_on = d if fit is None else fit.read(d)
    cfg = GPSSMConfig(particles=particles)
    table, cv = run_filter(run_on, cfg, seed=seed, curve_times=(1e9,),
                           curve_alpha=np.radians(np.linspace(-20, 20, 161)))
    h = honesty_figures(run_on, table, next(iter(cv.values())))
    res = EstimateResult("gpssm", table, {"config": cfg.to_meta(), "summary": summary(table)}, None)
    ok = all(h[a]["mae"] <= 0.02 and h[a]["coverage"] >= 0.9 for a in ("front", "rear"))
    return (f" {h['front']['mae']:>6.3f} {h['front']['coverage']:>5.2f} {h['rear']['mae']:>6.3f}"
            f" {h['rear']['coverage']:>5.2f} {'yes' if ok else 'no':>4}"
            f" {'yes' if score_result(res, run_on).honest else 'no':>6}"), ok


def gpssm_table(names: list[str], particles: int = 200, seed: int = 0, scenario: str | None = None) -> None:
    """Print the GP-SSM's snow-slalom criteria with the car fitted on :data:`FIT_DRIVE` or on
    ``scenario`` (module docstring)."""
    print(f"{'vehicle':<11} {'drive':<5} {'mae f':>6} {'cov f':>5} {'mae r':>6} {'cov r':>5} {'pass':>4} "
          f"{'honest':>6}")
    t_start = time.perf_counter()
    n_pass = 0
    for name in names:
        fit = fit_family_vehicle(name, scenario)
        cells, ok = _gpssm_cells(name, fit, particles, seed)
        n_pass += ok
        print(f"{name:<11} {fit.vehicle.drive:<5}{cells}", flush=True)
    print(f"fitted on {scenario or FIT_DRIVE[0]}: the criterion on {n_pass} of {len(names)}")
    print(f"({len(names)} vehicles in {time.perf_counter() - t_start:.0f} s)")


_CLASSIFIER_HEAD = f"{'x/y':>8} {'lat ms':>6} " + " ".join(
    f"{m + ' [s]':>7} {'fs':>3} {'pass':>4} {'honest':>6}" for m in ("bRLS", "map"))


def estimator_table(names: list[str], fitted: bool = True) -> None:
    """Print the issue's family criteria, one row a vehicle (module docstring); ``fitted``:
    the classifiers on the drives read with the fitted vehicle file."""
    print(f"{'vehicle':<11} {'drive':<5} {_CLASSIFIER_HEAD} | {CASCADE_HEADER}")
    t_start = time.perf_counter()
    tally: dict = {}
    for name in names:
        drive = mb_vehicle(name, sensors="ideal").params.drive
        fit = fit_family_vehicle(name) if fitted else None
        print(f"{name:<11} {drive:<5}{_classifier_cells(name, fit)} |{_cascade_cells(name, tally=tally)}",
              flush=True)
    print(_cascade_tally(tally))
    print(f"({len(names)} vehicles in {time.perf_counter() - t_start:.0f} s)")


def classifier_table(names: list[str]) -> None:
    """Print the classifiers' family criteria as logged and with the fitted vehicle file,
    side by side (``--classifiers``)."""
    print(f"{'':<17} {'as logged':^61} | {'with the fitted vehicle file':^61}")
    print(f"{'vehicle':<11} {'drive':<5} {_CLASSIFIER_HEAD} | {_CLASSIFIER_HEAD}")
    t_start = time.perf_counter()
    for name in names:
        drive = mb_vehicle(name, sensors="ideal").params.drive
        print(f"{name:<11} {drive:<5}{_classifier_cells(name)} |"
              f"{_classifier_cells(name, fit_family_vehicle(name))}", flush=True)
    print(f"({len(names)} vehicles in {time.perf_counter() - t_start:.0f} s)")


def cascade_table(names: list[str]) -> None:
    """Print the cascade's family criteria with the preset car and with the fitted car, side
    by side (``--cascade``; the module docstring's rules)."""
    print(f"{'':<17} {'preset car':^57} | {'fitted car':^57}")
    print(f"{'vehicle':<11} {'drive':<5} {CASCADE_HEADER} | {CASCADE_HEADER}")
    t_start = time.perf_counter()
    preset: dict = {}
    fitted: dict = {}
    for name in names:
        drive = mb_vehicle(name, sensors="ideal").params.drive
        print(f"{name:<11} {drive:<5}{_cascade_cells(name, tally=preset)} |"
              f"{_cascade_cells(name, fit_family_vehicle(name), fitted)}", flush=True)
    print("preset car " + _cascade_tally(preset))
    print("fitted car " + _cascade_tally(fitted))
    print(f"({len(names)} vehicles in {time.perf_counter() - t_start:.0f} s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", default="100-119", help="family seeds, 'a-b' (inclusive)")
    ap.add_argument("--scenarios", nargs="*", default=list(SCENARIOS), choices=SCENARIOS)
    ap.add_argument("--estimators", action="store_true",
                    help="the classifiers' and the cascade's family criteria instead of the parameters")
    ap.add_argument("--fit", action="store_true",
                    help="vehicle fit against the truth and the cascade with the fitted car")
    ap.add_argument("--gpssm", action="store_true",
                    help="the GP-SSM on the snow slalom with the fitted car")
    ap.add_argument("--fit-drive", default=None,
                    help="with --fit or --gpssm: the drive fitted on (default dry-gravel-dry; vehicle-id "
                         "is the identification drive)", choices=list(FIT_MU))
    ap.add_argument("--particles", type=int, default=200, help="with --gpssm: the particle count")
    ap.add_argument("--filter-seed", type=int, default=0, help="with --gpssm: the filter's seed")
    ap.add_argument("--no-fit", action="store_true",
                    help="with --estimators: the classifiers on the drives as logged, not read with the fitted car")
    ap.add_argument("--classifiers", action="store_true",
                    help="the classifiers' family criteria as logged and with the fitted car, side by side")
    ap.add_argument("--cascade", action="store_true",
                    help="the cascade's family criteria with the preset and with the fitted car, side by side")
    args = ap.parse_args()
    names = ["ford-escort", "vw-vanagon", *(f"random:{s}" for s in _seeds(args.seeds))]
    if args.gpssm:
        gpssm_table(names[2:], args.particles, args.filter_seed, args.fit_drive)
        return
    if args.fit:
        fit_table(names[2:], args.fit_drive)
        return
    if args.classifiers:
        classifier_table(names[2:])
        return
    if args.cascade:
        cascade_table(names[2:])
        return
    if args.estimators:
        estimator_table(names[2:], fitted=not args.no_fit)
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
