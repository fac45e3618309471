"""Units and signs from kinematic consistency over generated corpora (tests/test_drive_units.py).

Valid drives (standstill, reversing, held, saturated and dropout segments; with and without
a pose and wheel speeds; sedan, SUV and 1:10 car; 100, 50 and 20 Hz) must never be refused;
the same drives with one channel in a wrong unit or with a flipped sign must be refused
naming it. Prints the counts; exit status 0 always (the acceptance is in the tests).

    .venv/bin/python benchmarks/units_consistency.py [--valid N] [--wrong N]
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from roadgrip.drive import Drive, DriveValidationError
from roadgrip.vehicle import PRESETS
from test_drive_units import MISTAKES, _mistaken, kinematic_drive

SEGMENTS = ("standstill", "reversing", "constant", "saturated", "dropout")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--valid", type=int, default=2160)
    ap.add_argument("--wrong", type=int, default=40, help="drives per mistake")
    a = ap.parse_args()
    warnings.simplefilter("ignore", UserWarning)
    rng = np.random.default_rng(2026)
    refused: Counter = Counter()
    for i in range(a.valid):
        veh = ("sedan", "suv", "f1tenth")[i % 3]
        segs = tuple(rng.choice(SEGMENTS, size=int(rng.integers(0, 5))))
        df = kinematic_drive(10_000 + i, vehicle=veh, pose=bool(i % 2), wheels=bool((i // 2) % 2),
                             dt=(0.01, 0.02, 0.05)[(i // 4) % 3], segments=segs, duration=40.0)
        try:
            Drive.from_frame(df, PRESETS[veh], source="valid")
        except DriveValidationError as exc:
            refused[str(exc).split(":")[0]] += 1
    print(f"valid drives refused: {sum(refused.values())} of {a.valid}")
    for msg, n in refused.most_common(5):
        print(f"  {n:5d}  {msg}")
    total = named = 0
    for mistake, (column, factor) in sorted(MISTAKES.items()):
        hit = 0
        for seed in range(a.wrong):
            veh = ("sedan", "f1tenth", "suv")[seed % 3]
            pose = column == "psi" or seed % 4 < 3
            df = _mistaken(kinematic_drive(20_000 + seed, vehicle=veh, pose=pose), column, factor)
            try:
                Drive.from_frame(df, PRESETS[veh], source="wrong")
            except DriveValidationError as exc:
                name = "omega_*" if column == "omega" else column
                hit += f"'{name}'" in str(exc) or f"{name} " in str(exc)
        total += a.wrong
        named += hit
        print(f"  {mistake:20s} refused naming the column: {hit} of {a.wrong}")
    print(f"wrong unit or sign refused naming the column: {named} of {total} ({100 * named / total:.1f} %)")


if __name__ == "__main__":
    main()
