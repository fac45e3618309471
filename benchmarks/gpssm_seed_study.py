"""GP-SSM seed study: do the bands of independent filter seeds agree, and cover the truth?

For every drive of the study (the project's own scenarios, the multi-body snow slaloms of
both vehicles and every recording in ``../shared/data``), the GP-SSM runs with filter seeds
0-4 and the script prints, per axle, the final peak band of each seed, whether they overlap
pairwise (:func:`~roadgrip.estimators.gpssm.accuracy.bands_overlap`) and, on simulated
drives, the share of visited 0.5 deg slip bins where each seed's final curve band covers
the true curve (:func:`~roadgrip.estimators.gpssm.accuracy.curve_accuracy`).

Usage::

    python benchmarks/gpssm_seed_study.py [--seeds 5] [--only SUBSTRING] [--jobs N]

Exit status 0 always: the figures are a measurement (the acceptance is in the tests).
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor

from roadgrip.evaluate.honesty_matrix import GPSSM_OPTIONS, DriveSpec, corpus, load_drive

AXLES = ("front", "rear")


def study_drives() -> list[DriveSpec]:
    """Seed 0 of each own scenario and multi-body snow slalom, and every recording."""
    keep = []
    for spec in corpus("full"):
        if spec.path is not None:
            keep.append(spec)
        elif spec.seed == 0 and (spec.vehicle is None or spec.scenario == "snow-slalom"):
            keep.append(spec)
    return keep


def run_drive(spec: DriveSpec, seeds: int) -> list[str]:
    from roadgrip.estimators.gpssm import GPSSMConfig, run_filter
    from roadgrip.estimators.gpssm.accuracy import bands_overlap, curve_accuracy
    from roadgrip.io.presets import preset_options

    drive, _ = load_drive(spec)
    cfg = GPSSMConfig.from_options({**GPSSM_OPTIONS, **preset_options("gpssm", drive)})
    truth = drive.has_truth
    bands = {a: [] for a in AXLES}
    cover = {a: [] for a in AXLES}
    t0 = time.perf_counter()
    for seed in range(seeds):
        table, curves = run_filter(drive, cfg, seed=seed, curve_times=(drive.duration + 1.0,))
        last = table.iloc[-1]
        for a in AXLES:
            bands[a].append((float(last[f"mu_{a}_lower"]), float(last[f"mu_{a}_upper"])))
        if truth and curves:
            acc = curve_accuracy(next(iter(curves.values())), drive)
            for a in AXLES:
                cover[a].append(acc[a]["coverage"])
    lines = []
    for a in AXLES:
        b = bands[a]
        txt = " ".join(f"[{lo:.3f},{hi:.3f}]" for lo, hi in b)
        cov = " cover " + " ".join(f"{100 * v:.0f}%" for v in cover[a]) if cover[a] else ""
        lines.append(f"{spec.name:<34} {a:<5} overlap {'yes' if bands_overlap(b) else 'NO '} {txt}{cov}")
    lines.append(f"{spec.name:<34} ({time.perf_counter() - t0:.0f} s for {seeds} seeds)")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--only", default="")
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()
    specs = [s for s in study_drives() if args.only in s.name]
    with ProcessPoolExecutor(args.jobs) as pool:
        for lines in pool.map(run_drive, specs, [args.seeds] * len(specs)):
            print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()
