"""The HTML report (``roadgrip report``) and the end-to-end demo (``roadgrip demo``).

``roadgrip report DRIVE_OR_RESULTS... -o report/`` accepts, in any mix:

* drives (canonical CSV/Parquet or a shared data set): their signals are shown,
  and every estimator that applies is run on them unless estimates for that
  drive are given too;
* estimates files written by ``roadgrip estimate`` (Parquet with roadgrip
  metadata), paired with the drive of the same length and times, or with the
  only drive given;
* curve files written by ``roadgrip estimate --curves`` (attached to the
  preceding GP-SSM estimates);
* a benchmark folder or its ``bench.csv`` written by ``roadgrip bench``.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from roadgrip.report.builder import SECTIONS, build_report

__all__ = ["SECTIONS", "build_report", "demo_notes", "real_data_note", "run_demo", "write_report"]


def _kind(path: Path) -> str:
    """'bench', 'estimates', 'curves' or 'drive'."""
    if path.is_dir():
        return "bench" if (path / "bench.csv").is_file() else "drive"
    suffix = path.suffix.lower()
    if suffix == ".csv":
        head = path.open(encoding="utf-8", errors="replace").readline()
        cols = [c.strip() for c in head.split(",")]
        if {"drive", "method", "status"} <= set(cols):
            return "bench"
        return "drive"
    if suffix in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        schema = pq.read_schema(str(path))
        md = schema.metadata or {}
        if b"roadgrip_estimate" in md:
            return "estimates"
        if {"axle", "alpha", "mu_mean"} <= set(schema.names):
            return "curves"
        return "drive"
    return "drive"


def _same_clock(drive, table: pd.DataFrame) -> bool:
    t = table["t"].to_numpy(float)
    return len(t) == drive.n and np.allclose(t, drive.t)


def _cases_for(name: str, drive, fmt: str | None):
    from roadgrip.evaluate.cases import CLASSIFIERS, Case

    scenario = (drive.meta.truth or {}).get("scenario")
    if scenario is None and drive.meta.source.startswith("sim:"):
        scenario = drive.meta.source[4:]
    table = {
        "snow-slalom": ["gpssm"],
        "dry-gravel-dry": list(CLASSIFIERS),
        "f1tenth-patches": ["cascade"],
        "dart": ["gpssm", *CLASSIFIERS],
        "frictionmaps": ["cascade"],
    }
    methods = table.get(scenario or fmt or "", ["gpssm", *CLASSIFIERS, "cascade"])
    return [Case(name, m, m) for m in methods]


def write_report(inputs, output, *, on_run: Callable[[str, str], None] | None = None) -> Path:
    """``roadgrip report``: read drives, estimates and benchmark tables; write the report.

    Parameters
    ----------
    inputs : sequence of path
        Drives, estimates files, curve files and benchmark folders or tables.
    output : path
        Report folder.
    on_run : callable, optional
        Called with ``(method, drive name)`` before an estimator runs on a drive
        that came without estimates.

    Returns
    -------
    Path
        The written ``index.html``.
    """
    from roadgrip.estimators.base import EstimateResult
    from roadgrip.evaluate.cases import FULL, Case, RunRecord
    from roadgrip.evaluate.scoring import score
    from roadgrip.evaluate.suite import run_case
    from roadgrip.io import read_drive
    from roadgrip.io.read import detect_format

    if not inputs:
        raise ValueError("give at least one drive, estimates file or benchmark folder")
    drives: dict[str, tuple[object, str | None]] = {}
    results: list[EstimateResult] = []
    bench = None
    for raw in inputs:
        p = Path(raw)
        if not p.exists():
            raise ValueError(f"no such file or folder: {p}")
        kind = _kind(p)
        if kind == "bench":
            bench = pd.read_csv(p / "bench.csv" if p.is_dir() else p)
        elif kind == "estimates":
            results.append(EstimateResult.read_parquet(p))
        elif kind == "curves":
            target = next((r for r in reversed(results) if r.method == "gpssm"), None)
            if target is None:
                raise ValueError(f"{p} holds tire curves but no GP-SSM estimates file precedes it")
            results[results.index(target)] = EstimateResult(
                target.method, target.table, target.meta, pd.read_parquet(p))
        else:
            fmt = detect_format(p)
            drives[p.stem if p.is_file() else p.name] = (read_drive(p, format=fmt), fmt)
    records = []
    paired: set[str] = set()
    for res in results:
        name = next((n for n, (d, _) in drives.items() if _same_clock(d, res.table)), None)
        if name is None and len(drives) == 1:
            name = next(iter(drives))
        drive = drives[name][0] if name else None
        if name:
            paired.add(name)
        rec = RunRecord(Case(name or "estimates", res.method, res.method), "ok", drive=drive, result=res)
        if drive is not None:
            try:
                score(rec)
            except Exception as exc:  # reported in the table, never fatal
                rec.details.append(f"not scored: {exc}")
        records.append(rec)
    cache = {n: d for n, (d, _) in drives.items()}
    for name, (drive, fmt) in drives.items():
        if name in paired:
            continue
        for case in _cases_for(name, drive, fmt):
            if on_run is not None:
                on_run(case.method, name)
            records.append(run_case(case, FULL, 0, cache))
    notes = [f"inputs: {', '.join(str(i) for i in inputs)}"]
    return build_report(records, output, title="roadgrip report", notes=notes, bench=bench,
                        extra_drives={n: d for n, (d, _) in drives.items()})


def real_data_note(records: Sequence, settings) -> str:
    """One line saying whether the shared real data were found, and whether they were used.

    Parameters
    ----------
    records : sequence of RunRecord
        The runs of the report; a run of a real drive has a ``case.path``.
    settings : BenchSettings
        The settings the runs were made with (``real_data``: run them where present).

    Returns
    -------
    str
        ``'real data: used, ...'``, ``'real data: found at ROOT, not used (...)'`` or
        ``'real data: not found (...)'``; the root is
        :func:`roadgrip.evaluate.cases.real_data_root`.
    """
    import os

    from roadgrip.evaluate.cases import real_data_root

    root = real_data_root()
    used = sorted({r.case.drive for r in records if getattr(r.case, "path", None)})
    if used:
        where = f" from {root}" if root is not None else ""
        return f"real data: used, {len(used)} drive{'s' * (len(used) != 1)}{where} ({', '.join(used)})"
    if root is None:
        env = os.environ.get("ROADGRIP_SHARED_DATA")
        if env:
            return f"real data: not found ($ROADGRIP_SHARED_DATA={env} is no folder)"
        return ("real data: not found (no $ROADGRIP_SHARED_DATA, no ../shared/data beside the "
                "checkout or the working directory)")
    if not settings.real_data:
        return f"real data: found at {root}, not used (the '{settings.name}' settings simulate every drive)"
    return f"real data: found at {root}, but none of its drives ran"


def demo_notes(settings, records: Sequence, *, seed: int, wall: float) -> list[str]:
    """The settings section of the demo report: settings, scenarios, real data, timing, failures."""
    # the settings line without its 'real data: yes/no' (a flag, not whether data were found
    # and used): :func:`real_data_note` says that
    described = re.sub(r";\s*real data: (yes|no)\b", "", settings.describe())
    notes = [
        f"seed {seed}; {described}",
        "scenarios simulated with ground truth; every estimator run where it applies "
        "(snow-slalom: GP-SSM; dry-gravel-dry: GP-SSM, bRLS and slip-map classifier; "
        "f1tenth-patches: Kalman cascade and friction grid)",
        real_data_note(records, settings),
        f"estimation and scoring took {wall:.1f} s",
    ]
    notes += [f"{r.case.drive} / {r.case.label}: {r.status}" for r in records if r.status != "ok"]
    return notes


def run_demo(out, *, seed: int = 0, settings=None, on_case=None, on_done=None) -> tuple[Path, pd.DataFrame]:
    """``roadgrip demo``: simulate the scenarios, run every estimator, benchmark, report.

    Parameters
    ----------
    out : path
        Report folder; receives ``index.html``, the PNG figures, ``bench.md`` and ``bench.csv``.
    seed : int
        Seed of the simulations and the estimators.
    settings : BenchSettings, optional
        Default :data:`roadgrip.evaluate.cases.DEMO`.
    on_case, on_done : callable, optional
        Progress callbacks of :func:`roadgrip.evaluate.suite.run_suite`.

    Returns
    -------
    (Path, DataFrame)
        The written ``index.html`` and the benchmark table.
    """
    from roadgrip.evaluate.cases import DEMO
    from roadgrip.evaluate.suite import bench

    settings = settings or DEMO
    out = Path(out)
    t0 = time.perf_counter()
    table, records = bench(out, settings, seed=seed, on_case=on_case, on_done=on_done)
    wall = time.perf_counter() - t0
    notes = demo_notes(settings, records, seed=seed, wall=wall)
    path = build_report(records, out, title="roadgrip demo report", notes=notes)
    return path, table
