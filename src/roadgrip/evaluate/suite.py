"""Running the benchmark cases: load or simulate each drive once, run, time and score.

Each run is timed (after an untimed warm-up run that compiles the kernels) and
scored with :mod:`roadgrip.evaluate.scoring`; a run that raises is reported
with its error, so one failing estimator never hides the others. Everything is
seeded: the same seed gives the same table (apart from the timing columns).
The cases are in :mod:`roadgrip.evaluate.cases`, the table in
:mod:`roadgrip.evaluate.table`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roadgrip.evaluate.cases import (
    CLASSIFIERS,
    DEMO,
    FULL,
    MB_TAG,
    QUICK,
    BenchSettings,
    Case,
    RunRecord,
    default_cases,
    real_data_root,
)
from roadgrip.evaluate.scoring import score
from roadgrip.evaluate.table import write_outputs
from roadgrip.io.presets import preset_options

__all__ = [
    "DEMO",
    "FULL",
    "QUICK",
    "BenchSettings",
    "Case",
    "RunRecord",
    "bench",
    "case_options",
    "default_cases",
    "run_case",
    "run_suite",
]


def _load_drive(case: Case, settings: BenchSettings, seed: int, cache: dict):
    key = case.drive
    if key in cache:
        return cache[key]
    if case.path is not None:
        from roadgrip.io import read_drive

        drive = read_drive(case.path, format=case.format)
    else:
        from roadgrip.sim.scenarios import simulate_scenario

        if MB_TAG in case.drive:
            sc, vehicle = case.drive.split(MB_TAG)
            duration = settings.multibody_durations.get(sc)
            drive = simulate_scenario(sc, seed=seed, engine="multibody", vehicle=vehicle,
                                      duration=duration)
        else:
            duration = settings.durations.get(case.drive)
            kwargs = {"duration": duration} if duration else {}
            drive = simulate_scenario(case.drive, seed=seed, **kwargs)
    cache[key] = drive
    return drive


def case_options(case: Case, settings: BenchSettings, drive) -> dict[str, Any]:
    """The options of ``case``'s run (``Config.from_options`` of its method).

    The data set's presets (:func:`roadgrip.io.presets.preset_options`), then for the GP-SSM the settings'
    particles, the case's basis and its curve times, relative to the drive's start:
    t = 50 s (paper 000) where the drive is longer, and the end.
    """
    options = preset_options(case.method, drive)
    if case.method == "gpssm":
        times = [drive.duration]
        if drive.has_truth and drive.duration > 50.0:
            times.insert(0, 50.0)
        options.update(particles=settings.particles, basis=case.basis, curve_times=tuple(times))
    return {**options, **dict(case.options)}


def run_case(case: Case, settings: BenchSettings, seed: int, cache: dict) -> RunRecord:
    """Load or simulate the drive, run the estimator, score it; never raises."""
    try:
        drive = _load_drive(case, settings, seed, cache)
    except Exception as exc:  # reported in the table, never fatal
        return RunRecord(case, _status("error: drive", exc), details=[f"drive: {exc}"])
    from roadgrip.estimators import run_estimator

    try:
        options = case_options(case, settings, drive)
        if case.format == "dart" and case.method in CLASSIFIERS:
            # Calibrated on the first halves of every DART run, tested on this run's second half.
            options["calibration"] = _dart_calibration(cache)
            drive = drive.slice_time(drive.t[0] + 0.5 * drive.duration, np.inf)
        _warm_up(case, drive, options, seed)
        t0 = time.perf_counter()
        result = run_estimator(case.method, drive, options, seed=seed)
        wall = time.perf_counter() - t0
    except Exception as exc:  # reported in the table, never fatal
        return RunRecord(case, _status(f"error: {type(exc).__name__}", exc), drive=drive,
                         details=[f"{type(exc).__name__}: {exc}"])
    rec = RunRecord(case, "ok", drive=drive, result=result, wall_s=wall)
    try:
        score(rec)
    except Exception as exc:  # reported in the table, never fatal
        rec.status = _status(f"error: scoring: {type(exc).__name__}", exc)
        rec.details.append(f"scoring failed: {type(exc).__name__}: {exc}")
    return rec


def _warm_up(case: Case, drive, options: Mapping[str, Any], seed: int) -> None:
    """Run the estimator once on the first samples so that compilation is not timed."""
    from roadgrip.estimators import run_estimator

    n = min(drive.n - 1, WARMUP_SAMPLES)
    if n < 2:
        return
    short = drive.slice_time(drive.t[0], drive.t[n])
    try:
        run_estimator(case.method, short, {**options, "curve_times": None}, seed=seed)
    except Exception:  # the timed run reports any real problem
        pass


WARMUP_SAMPLES = 60
"""Samples of the untimed warm-up run (just-in-time compilation) before each timed run."""


def _dart_calibration(cache: dict):
    """bRLS / slipmap calibration from the first half of every DART run (computed once per cache)."""
    key = "__dart_calibration__"
    if key not in cache:
        from roadgrip.estimators.classify import calibrate
        from roadgrip.io import read_drive

        root = real_data_root()
        if root is None:
            raise ValueError("DART data not found")
        labelled = []
        for floor, ref in (("high_grip_rubbery_floor", "high"), ("low_grip_tape_and_tiles", "low")):
            for f in sorted((root / "dart" / floor).glob("*.csv")):
                d = read_drive(f, format="dart")
                labelled.append((d.slice_time(d.t[0], d.t[0] + 0.5 * d.duration), ref))
        cache[key] = calibrate(labelled)
    return cache[key]


def _status(prefix: str, exc: BaseException, width: int = 100) -> str:
    """One-line status: the prefix and the first line of the message, shortened."""
    first = (str(exc).strip().splitlines() or [""])[0]
    text = f"{prefix}: {first}"
    return text if len(text) <= width else text[: width - 1] + "…"


def run_suite(
    cases: Sequence[Case],
    settings: BenchSettings,
    *,
    seed: int = 0,
    on_case: Callable[[Case], None] | None = None,
    on_done: Callable[[RunRecord], None] | None = None,
    drives: dict | None = None,
) -> list[RunRecord]:
    """Run every case in order (drives are simulated or read once and shared).

    ``drives`` maps a case's ``drive`` name to a ready :class:`~roadgrip.drive.Drive`
    to use instead of simulating or reading it.
    """
    cache: dict = dict(drives or {})
    out = []
    for case in cases:
        if on_case:
            on_case(case)
        rec = run_case(case, settings, seed, cache)
        out.append(rec)
        if on_done:
            on_done(rec)
    return out



def bench(
    output: str | Path,
    settings: BenchSettings,
    *,
    seed: int = 0,
    cases: Sequence[Case] | None = None,
    drives: dict | None = None,
    on_case: Callable[[Case], None] | None = None,
    on_done: Callable[[RunRecord], None] | None = None,
) -> tuple[pd.DataFrame, list[RunRecord]]:
    """Run the suite and write ``bench.csv`` and ``bench.md`` to ``output``.

    ``cases`` defaults to :func:`~roadgrip.evaluate.cases.default_cases` of
    ``settings``; ``drives`` pre-supplies drives by name (see :func:`run_suite`).
    Returns the table and the records.
    """
    cases = list(cases) if cases is not None else default_cases(settings)
    records = run_suite(cases, settings, seed=seed, on_case=on_case, on_done=on_done, drives=drives)
    return write_outputs(records, Path(output), settings, seed), records
