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

import time
from pathlib import Path

import numpy as np
import pandas as pd

from roadgrip.report.builder import SECTIONS, build_report

__all__ = ["SECTIONS", "build_report", "demo_cli", "report_cli"]


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
    from roadgrip.evaluate.suite import CLASSIFIERS, Case

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


def report_cli(inputs, output, *, console=None) -> Path:
    """``roadgrip report``: read drives, estimates and benchmark tables; write the report."""
    from rich.console import Console

    from roadgrip.estimators.base import EstimateResult
    from roadgrip.evaluate.suite import FULL, Case, RunRecord, run_case, score
    from roadgrip.io import read_drive
    from roadgrip.io.read import detect_format

    console = console or Console()
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
            console.print(f"running {case.method} on {name} ...")
            records.append(run_case(case, FULL, 0, cache))
    notes = [f"inputs: {', '.join(str(i) for i in inputs)}"]
    path = build_report(records, output, title="roadgrip report", notes=notes, bench=bench,
                        extra_drives={n: d for n, (d, _) in drives.items()})
    console.print(f"report: {path.resolve()}")
    return path


def demo_cli(out, *, seed: int = 0, console=None, settings=None) -> Path:
    """``roadgrip demo``: simulate the three scenarios, run every estimator, benchmark, report.

    Parameters
    ----------
    out : path
        Report folder; receives ``index.html``, the PNG figures, ``bench.md`` and ``bench.csv``.
    seed : int
        Seed of the simulations and the estimators.
    settings : BenchSettings, optional
        Default :data:`roadgrip.evaluate.suite.DEMO`.
    """
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from roadgrip.evaluate.suite import DEMO, default_cases, rich_table, run_suite, write_outputs

    console = console or Console()
    settings = settings or DEMO
    cases = default_cases(settings)
    t0 = time.perf_counter()
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeElapsedColumn(), console=console, transient=True) as progress:
        task = progress.add_task("demo", total=len(cases))
        records = run_suite(
            cases, settings, seed=seed,
            on_case=lambda c: progress.update(task, description=f"{c.drive} / {c.label}"),
            on_done=lambda r: progress.advance(task),
        )
    out = Path(out)
    table = write_outputs(records, out, settings, seed)
    console.print(rich_table(table, title=f"roadgrip demo benchmark (seed {seed})"))
    wall = time.perf_counter() - t0
    notes = [
        f"seed {seed}; {settings.describe()}",
        "scenarios simulated with ground truth; every estimator run where it applies "
        "(snow-slalom: GP-SSM; dry-gravel-dry: bRLS and slip-map classifier; "
        "f1tenth-patches: Kalman cascade and friction grid)",
        f"estimation and scoring took {wall:.1f} s",
    ]
    missing = [r for r in records if r.status != "ok"]
    notes += [f"{r.case.drive} / {r.case.label}: {r.status}" for r in missing]
    path = build_report(records, out, title="roadgrip demo report", notes=notes)
    console.print(f"report written to {path.resolve()}")
    return path
