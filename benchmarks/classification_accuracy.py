"""Surface-change accuracy of the paper 002 classifiers on multi-body drives.

For each vehicle (``ford-escort``, ``vw-vanagon``) and each test seed of
``dry-gravel-dry`` (1.0 -> 0.5 -> 1.0 at 60 s and 120 s), both classifiers are
run uncalibrated and calibrated with :func:`roadgrip.estimators.classify.calibrate`
(what ``roadgrip calibrate`` runs) on other drives of the same vehicle:
``dry-gravel-dry`` seed 10 cut into its surfaces (dry high, gravel low) and a
``snow-slalom`` (seed 10, low). Printed per drive and classifier
(:func:`roadgrip.evaluate.classification.surface_change_scores`): the detection
delays after the first sample on the new surface with true axle utilisation
> 0.6, the switches the truth does not call for, the % correct on samples
with utilisation >= 0.6, samples called 'high' on gravel and 'low' on dry,
and the fraction 'unknown'.

With ``--dart``: every shared DART recording classified after a calibration without it
(leave-one-out on the high-grip floor; first half / second half on the low-grip floor,
which has one recording), the fraction of its excited samples after 10 s in its class.

Run: ``.venv/bin/python benchmarks/classification_accuracy.py [--seeds 0 1 2 3 4]
[--vehicles ford-escort vw-vanagon] [--calibration-seed 10] [--model saturation|stiffness]
[--dart]``.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("ROADGRIP_DRIVE_CACHE", os.path.join(os.path.dirname(__file__), "..", ".cache", "drives"))

from roadgrip.estimators import run_estimator
from roadgrip.estimators.classify import calibrate
from roadgrip.evaluate.classification import surface_change_scores
from roadgrip.sim.scenarios import simulate_scenario


def mb(name: str, vehicle: str, seed: int):
    return simulate_scenario(name, seed=seed, engine="multibody", vehicle=vehicle)


def calibration_drives(vehicle: str, seed: int = 10) -> list:
    """Labelled drives of ``vehicle`` other than the test drives."""
    d = mb("dry-gravel-dry", vehicle, seed)
    snow = mb("snow-slalom", vehicle, seed)
    return [(d.slice_time(0.0, 60.0), "high"), (d.slice_time(60.0, 120.0), "low"),
            (d.slice_time(120.0, 180.0), "high"), (snow, "low")]


def fmt(s) -> str:
    delays = ", ".join("-" if x != x else f"{x:.2f}" for x in s.delays)
    return (f"delays [{delays}] s, false switches {s.false_switches}, "
            f"correct at util>=0.6 {100 * s.accuracy_util:.1f} % (n={s.n_util}), "
            f"high on gravel {s.high_on_low}, low on dry {s.low_on_high}, "
            f"unknown {100 * s.unknown_fraction:.0f} %")


def dart(model: str) -> None:
    from pathlib import Path

    import numpy as np

    from roadgrip.io import read_drive

    root = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "dart"
    high = [read_drive(p, format="dart") for p in sorted((root / "high_grip_rubbery_floor").glob("*.csv"))]
    low = [read_drive(p, format="dart") for p in sorted((root / "low_grip_tape_and_tiles").glob("*.csv"))]
    cases = []
    for i, d in enumerate(high):
        cal = [(h, "high") for j, h in enumerate(high) if j != i] + [(lo, "low") for lo in low]
        cases.append((Path(d.meta.source).name, cal, d, "high"))
    for d in low:
        mid = d.t[0] + 0.5 * d.duration
        cal = [(h, "high") for h in high] + [(d.slice_time(d.t[0], mid), "low")]
        cases.append((Path(d.meta.source).name + " (second half)", cal, d.slice_time(mid, np.inf), "low"))
    for name, cal_set, test, label in cases:
        cal = calibrate(cal_set, model=model)
        for method in ("brls", "slipmap"):
            table = run_estimator(method, test, {"calibration": cal}).table
            t = table["t"].to_numpy() - table["t"].iloc[0]
            m = table["excited"].to_numpy() & (t > 10.0)
            acc = float((table["grip_class"].to_numpy()[m] == label).mean())
            print(f"DART {method:7s} {label:4s} {name}: {100 * acc:.1f} % of {int(m.sum())} excited samples")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--vehicles", nargs="+", default=["ford-escort", "vw-vanagon"])
    ap.add_argument("--calibration-seed", type=int, default=10)
    ap.add_argument("--model", default="saturation", choices=("saturation", "stiffness"))
    ap.add_argument("--dart", action="store_true", help="DART leave-one-out instead")
    args = ap.parse_args()
    if args.dart:
        dart(args.model)
        return
    for veh in args.vehicles:
        t0 = time.perf_counter()
        cal = calibrate(calibration_drives(veh, args.calibration_seed), model=args.model)
        print(f"{veh}: calibrated in {time.perf_counter() - t0:.1f} s: {cal.diagnostics}")
        for seed in args.seeds:
            drive = mb("dry-gravel-dry", veh, seed)
            for method in ("brls", "slipmap"):
                for label, opts in (("uncalibrated", {}), ("calibrated", {"calibration": cal})):
                    res = run_estimator(method, drive, opts)
                    s = surface_change_scores(drive, res.table["grip_class"].to_numpy())
                    print(f"{veh} seed {seed} {method:7s} {label:12s} {fmt(s)}")


if __name__ == "__main__":
    main()
