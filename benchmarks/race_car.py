"""The race car's figures (issue 29): fit on the first half, estimate on the second.

Run: ``.venv/bin/python benchmarks/race_car.py [--seed 0] [--out DIR]``.

The full-size race car (``../shared/data/revs``, 550 s at 16-61 m/s, dry track, no wheel
speeds, INS lateral velocity as reference) is split at its middle. ``roadgrip vehicle fit``
(:func:`roadgrip.inference.vehicle_identification.fit_vehicle`) runs on the first half
with the shipped vehicle file as its base; the fitted vehicle and sensor calibration
are applied to the second half as the command line applies them (the drive read with
the fitted file, whose calibration the reader applies),
and every estimator runs on it (the GP-SSM also on the second half read with the shipped
file, for comparison):

- GP-SSM (the matrix's variant): lateral-velocity RMSE against the INS, the share of the
  unflagged samples whose band holds the INS (within 0.1 m/s), the share flagged, and the
  final peak lower bounds against the sustained ``|a_y|/g`` of the half (printed also over
  the upper end of the accelerometer scale's 95 % interval the fit found: the most an honest
  lower bound can claim from that accelerometer);
- cascade: the share of excited samples and the honesty rule's cell
  (:func:`roadgrip.evaluate.honesty.score_result`);
- bRLS and slip map, calibrated on the first half as ``'high'``
  (``roadgrip calibrate --label high``): the share of excited samples and of 'high' among
  them.

Each figure is printed beside the issue's target, with met / not met. The second half's
run also goes through the honesty rule for every method. Not a test: nothing fails here;
``tests/estimators/gpssm/test_gpssm_realdata.py`` and
``tests/estimators/test_classify_acceptance.py`` hold what is accepted.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "revs"
GPSSM_VARIANT = {"basis": "separable-odd:20"}


def _fmt(ok: bool) -> str:
    return "met" if ok else "NOT met"


def fit_first_half(out: Path):
    """The race car split at its middle, ``vehicle fit`` on the first half (the shipped file
    as its base) and the fitted file written to ``out``: returns the data path, the drive
    read with the shipped file, the middle [s], the fit and the fitted file's path."""
    from roadgrip.inference.vehicle_identification import fit_vehicle
    from roadgrip.io import read_drive

    path = ROOT / "race_car_100hz.csv"
    if not path.exists():
        raise SystemExit(f"race-car data not found at {path}")
    drive = read_drive(path, format="canonical", vehicle=str(ROOT / "race_car.yaml"))
    mid = drive.t[0] + 0.5 * drive.duration
    fit = fit_vehicle(drive.slice_time(drive.t[0], mid), drive.vehicle)
    out.mkdir(parents=True, exist_ok=True)
    car = out / "race_car_fitted.yaml"
    car.write_text(fit.to_yaml())
    return path, drive, mid, fit, car


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0, help="filter seed of the GP-SSM")
    ap.add_argument("--out", default=None, help="directory for the fitted vehicle file")
    args = ap.parse_args()

    from roadgrip.constants import Z95
    from roadgrip.estimators import run_estimator
    from roadgrip.estimators.classify import calibrate
    from roadgrip.evaluate.honesty import score_result
    from roadgrip.evaluate.honesty_matrix import reference_vy
    from roadgrip.io import read_drive
    from roadgrip.io.calibration import read_calibration
    from roadgrip.signals import sustained_grip

    t0 = time.perf_counter()
    path, drive, mid, fit, car = fit_first_half(Path(args.out) if args.out else Path("report") / "race_car")
    first = drive.slice_time(drive.t[0], mid)
    cal = read_calibration(car)
    print(f"vehicle fit on the first half ({first.duration:.0f} s) in {time.perf_counter() - t0:.1f} s -> {car}")
    for v in fit.values.values():
        val = f"{v.value:.4g} ± {v.std:.2g} {v.unit}" if v.fitted else f"undetermined ({v.note})"
        print(f"  {v.name:22s} {val}")
    # the fitted file as the command line uses it: the drive read with it (its sensor
    # calibration applied by the reader)
    fitted = read_drive(path, format="canonical", vehicle=str(car))
    second = fitted.slice_time(mid, np.inf)
    vy_ref = reference_vy(str(path), second.t)
    floor = float(sustained_grip(second.t, second.col("ay"))[-1])
    shipped_second = drive.slice_time(mid, np.inf)
    res = run_estimator("gpssm", shipped_second, dict(GPSSM_VARIANT), seed=args.seed)
    err = res.table["vy"].to_numpy() - reference_vy(str(path), shipped_second.t)
    print(f"GP-SSM on the second half with the shipped file (no calibration): vy RMSE "
          f"{np.sqrt(np.mean(err**2)):.2f} m/s")
    print(f"second half: {second.duration:.0f} s, sustained |a_y|/g {floor:.3f}, calibration applied {cal}")
    kg = fit.values.get("ay_gain")
    if kg is not None and kg.fitted:
        # the most a lower bound can claim from the accelerometer whose scale the fit found
        print(f"sustained |a_y|/g over the fitted accelerometer scale's 95 % upper end "
              f"({kg.value:.4f} + {Z95:.2f} x {kg.std:.3f}): {floor / (kg.value + Z95 * kg.std):.3f}")
    print()
    rows = []

    # GP-SSM
    t0 = time.perf_counter()
    res = run_estimator("gpssm", second, dict(GPSSM_VARIANT), seed=args.seed)
    tab = res.table
    err = tab["vy"].to_numpy() - vy_ref
    div = tab["diverged"].to_numpy(bool)
    cover = np.abs(err) <= Z95 * tab["vy_std"].to_numpy() + 0.1
    rmse = float(np.sqrt(np.mean(err**2)))
    cov = float(cover[~div].mean()) if (~div).any() else float("nan")
    lows = {a: float(tab[f"mu_{a}_lower"].iloc[-1]) for a in ("front", "rear")}
    s = score_result(res, second, vy_ref=vy_ref)
    rows += [("gpssm", "vy RMSE against the INS [m/s]", f"{rmse:.2f}", "<= 0.4", rmse <= 0.4),
             ("gpssm", "vy band holds the INS, unflagged", f"{100 * cov:.1f} %", ">= 90 %", cov >= 0.9),
             ("gpssm", "flagged diverged", f"{100 * div.mean():.1f} %", "–", True)]
    for a, lo in lows.items():
        rows.append(("gpssm", f"final {a} peak lower bound", f"{lo:.2f}", f">= {floor - 0.02:.2f}",
                     lo >= floor - 0.02))
    rows.append(("gpssm", "honest (rule: axle, VSS, vy)", f"wrong {100 * s.wrong:.2f} %", "<= 0.1 %", s.honest))
    print(f"gpssm: {time.perf_counter() - t0:.0f} s")

    # cascade
    res = run_estimator("cascade", second, {})
    exc = float(res.table["excited"].to_numpy(bool).mean())
    s = score_result(res, second, vy_ref=vy_ref)
    rows += [("cascade", "excited", f"{100 * exc:.1f} %", ">= 30 %", exc >= 0.3),
             ("cascade", "honest (rule)", f"wrong {100 * s.wrong:.2f} %", "<= 0.1 %", s.honest)]

    # classifiers, one labelled half
    calib = calibrate([(first, "high")])
    for method in ("brls", "slipmap"):
        res = run_estimator(method, second, {"calibration": calib})
        ex = res.table["excited"].to_numpy(bool)
        cls = res.table["grip_class"].to_numpy()
        high = float((cls[ex] == "high").mean()) if ex.any() else float("nan")
        s = score_result(res, second)
        rows += [(method, "excited", f"{100 * ex.mean():.1f} %", "–", True),
                 (method, "'high' among the excited", f"{100 * high:.1f} %", ">= 90 %", high >= 0.9),
                 (method, "honest (rule)", f"wrong {100 * s.wrong:.2f} %", "<= 0.1 %", s.honest)]

    print(f"\n{'method':8s} {'figure':36s} {'measured':>14s} {'target':>9s}  verdict")
    for m, name, val, target, ok in rows:
        print(f"{m:8s} {name:36s} {val:>14s} {target:>9s}  {_fmt(ok)}")


if __name__ == "__main__":
    main()
